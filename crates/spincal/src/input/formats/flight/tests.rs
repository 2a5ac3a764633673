//! Unit tests of the flight-log readers on logs built here byte by byte (the fixtures read by
//! pyulog and pymavlink are in tests/flight_logs.rs).

use super::*;
use crate::input::formats::{detect, read_bytes, FormatError};

#[test]
fn topics_name_an_instance() {
    assert_eq!(parse_topic("1"), (None, Some(1)));
    assert_eq!(parse_topic("sensor_accel_1"), (Some("sensor_accel"), Some(1)));
    assert_eq!(parse_topic("IMU[2]"), (Some("IMU"), Some(2)));
    assert_eq!(parse_topic(" sensor_combined "), (Some("sensor_combined"), None));
    assert_eq!(parse_topic("IMU2"), (Some("IMU2"), None));
}

#[test]
fn gyro_is_taken_at_equal_stamps_interpolated_between_and_dropped_outside() {
    let gyro = Series {
        us: vec![100, 200, 300],
        v: [vec![1.0, 2.0, 4.0], vec![0.0; 3], vec![-1.0, -1.0, -3.0]],
        temperature: Vec::new(),
        offset: vec![0; 3],
    };
    let (kept, values, counts) = gyro_on_accel_stamps(&[50, 100, 150, 275, 300, 301], &gyro);
    assert_eq!(kept, vec![1, 2, 3, 4]);
    assert_eq!(values[0], vec![1.0, 1.5, 3.5, 4.0]);
    assert_eq!(values[2], vec![-1.0, -1.0, -2.5, -3.0]);
    assert_eq!(counts, [2, 2, 2]);
}

#[test]
fn sorting_moves_every_value_with_its_stamp() {
    let mut s = Series {
        us: vec![3, 1, 2, 1],
        v: [vec![30.0, 10.0, 20.0, 11.0], vec![0.0; 4], vec![0.0; 4]],
        temperature: vec![3.5, 1.5, 2.5, 1.6],
        offset: vec![300, 100, 200, 101],
    };
    let mut beside = [vec![-3.0, -1.0, -2.0, -1.1], vec![0.0; 4], vec![0.0; 4]];
    assert!(s.sort_with(&mut beside));
    assert_eq!(s.us, vec![1, 1, 2, 3]);
    assert_eq!(s.v[0], vec![10.0, 11.0, 20.0, 30.0]);
    assert_eq!(s.temperature, vec![1.5, 1.6, 2.5, 3.5]);
    assert_eq!(s.offset, vec![100, 101, 200, 300]);
    assert_eq!(beside[0], vec![-1.0, -1.1, -2.0, -3.0]);
    assert!(!s.sort());
}

#[test]
fn magics_are_detected() {
    let mut ulog = ULOG_MAGIC.to_vec();
    ulog.extend([1, 0, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(detect(&ulog).format, Format::Ulog);
    assert_eq!(detect(&[0xA3, 0x95, 0x80, 128, 89]).format, Format::DataFlash);
    // A DataFlash message of another type first is not the start of a log.
    assert_ne!(detect(&[0xA3, 0x95, 0x81, 0, 0]).format, Format::DataFlash);
}

/// A DataFlash log written from the format's description.
#[cfg(feature = "dataflash")]
mod dataflash_logs {
    use super::*;

    fn size(c: u8) -> usize {
        match c {
            b'b' | b'B' | b'M' => 1,
            b'h' | b'H' | b'c' | b'C' | b'g' => 2,
            b'i' | b'I' | b'f' | b'e' | b'E' | b'L' | b'n' => 4,
            b'q' | b'Q' | b'd' => 8,
            b'N' => 16,
            _ => 64,
        }
    }

    fn padded(text: &str, n: usize) -> Vec<u8> {
        let mut b = text.as_bytes().to_vec();
        b.resize(n, 0);
        b
    }

    pub(super) fn fmt(out: &mut Vec<u8>, msg_type: u8, name: &str, format: &str, labels: &str) {
        let length = 3 + format.bytes().map(size).sum::<usize>();
        out.extend([0xA3, 0x95, 128, msg_type, length as u8]);
        out.extend(padded(name, 4));
        out.extend(padded(format, 16));
        out.extend(padded(labels, 64));
    }

    pub(super) fn header() -> Vec<u8> {
        let mut out = Vec::new();
        fmt(&mut out, 128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
        out
    }

    /// An old (pre-4.0) IMU message: TimeMS, gyro, accel, no instance, no temperature.
    fn old_imu(out: &mut Vec<u8>, msg_type: u8, ms: u32, g: [f32; 3], a: [f32; 3]) {
        out.extend([0xA3, 0x95, msg_type]);
        out.extend(ms.to_le_bytes());
        for v in g.iter().chain(&a) {
            out.extend(v.to_le_bytes());
        }
    }

    fn old_log(n: u32) -> Vec<u8> {
        let mut out = header();
        fmt(
            &mut out,
            129,
            "IMU",
            "Iffffff",
            "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
        );
        fmt(
            &mut out,
            130,
            "IMU2",
            "Iffffff",
            "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
        );
        for i in 0..n {
            let x = i as f32;
            old_imu(&mut out, 129, 1000 + 10 * i, [x, 0.0, 0.0], [0.0, 0.0, -9.8]);
            old_imu(&mut out, 130, 1001 + 10 * i, [0.0, x, 0.0], [0.1, 0.0, -9.8]);
        }
        out
    }

    fn read(bytes: &[u8], topic: Option<&str>, salvage: bool) -> Result<Loaded, FormatError> {
        read_bytes(
            bytes,
            "t.bin",
            &ReadOptions {
                topic: topic.map(String::from),
                salvage,
                ..Default::default()
            },
        )
    }

    #[test]
    fn pre_4_0_logs_name_the_second_imu_imu2_and_count_milliseconds() {
        let log = old_log(5);
        let l = read(&log, None, false).unwrap();
        assert_eq!(l.format, Format::DataFlash);
        let f = l.flight.as_ref().unwrap();
        assert_eq!((f.instance, f.instances.clone()), (0, vec![0, 1]));
        assert_eq!(l.recording.time_s, vec![0.0, 0.01, 0.02, 0.03, 0.04]);
        assert_eq!(
            l.recording.gyro_radps.as_ref().unwrap()[0],
            vec![0.0, 1.0, 2.0, 3.0, 4.0]
        );
        assert!(l.recording.temperature_c.is_none());
        assert!(l.notes.iter().any(|n| n.contains("no T field")), "{:?}", l.notes);
        for topic in ["IMU2", "IMU[1]", "1"] {
            let l = read(&log, Some(topic), false).unwrap();
            assert_eq!(l.flight.as_ref().unwrap().instance, 1, "{topic}");
            assert_eq!(l.recording.accel_mps2[0][0], f64::from(0.1f32), "{topic}");
        }
        let e = read(&log, Some("IMU[4]"), false).unwrap_err().to_string();
        assert!(
            e.contains("no IMU instance 'IMU[4]'") && e.contains("IMU[1] (5 messages)"),
            "{e}"
        );
        // The device id is where ArduPilot keeps it, and said so.
        assert!(f.device_id.is_none());
        assert!(f.device_id_from.contains("INS_ACC_ID"), "{}", f.device_id_from);
    }

    #[test]
    fn damage_is_refused_at_its_byte_and_salvage_keeps_what_precedes_it() {
        let log = old_log(6);
        let at = header().len() + 2 * 89 + 2 * 31 * 3;
        let mut bad = log.clone();
        bad[at] = 0x00;
        let e = read(&bad, None, false).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("t.bin: byte {at}: expected a message header A3 95, found 00 95")
        );
        let l = read(&bad, None, true).unwrap();
        assert_eq!(l.recording.len(), 3);
        assert!(l
            .notes
            .iter()
            .any(|n| n.contains(&format!("stopped at byte {at}"))));
        // A type without a FMT before it.
        let mut bad = log.clone();
        bad[at + 2] = 150;
        let e = read(&bad, None, false).unwrap_err().to_string();
        assert!(
            e.contains(&format!("byte {at}: message type 150 has no FMT")),
            "{e}"
        );
        // A FMT whose length disagrees with its format.
        let mut bad = log.clone();
        bad[89 + 4] = 30;
        let e = read(&bad, None, false).unwrap_err().to_string();
        assert!(
            e.contains("byte 89: FMT of IMU (type 129): format 'Iffffff' makes 31 bytes"),
            "{e}"
        );
        // A last message cut short is left out with a note.
        let l = read(&log[..log.len() - 5], None, false).unwrap();
        assert_eq!(l.recording.len(), 6);
        assert!(l.notes.iter().any(|n| n.contains("cut short")), "{:?}", l.notes);
        assert_eq!(
            read(&log[..log.len() - 5], Some("1"), false)
                .unwrap()
                .recording
                .len(),
            5
        );
        // Padding after the last message is no damage.
        let mut padded = log;
        padded.extend([0u8; 100]);
        let l = read(&padded, None, false).unwrap();
        assert_eq!(l.recording.len(), 6);
        assert!(
            l.notes.iter().any(|n| n.contains("100 bytes of padding")),
            "{:?}",
            l.notes
        );
    }

    #[test]
    fn a_log_without_imu_messages_says_so() {
        let mut log = header();
        fmt(
            &mut log,
            129,
            "IMU",
            "Iffffff",
            "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
        );
        let e = read(&log, None, false).unwrap_err().to_string();
        assert!(e.starts_with("t.bin: no IMU messages"), "{e}");
        let mut one = log.clone();
        old_imu(&mut one, 129, 5, [0.0; 3], [0.0; 3]);
        let e = read(&one, None, false).unwrap_err().to_string();
        assert!(e.contains("only 1 IMU samples"), "{e}");
        let mut nan = log;
        old_imu(&mut nan, 129, 5, [0.0; 3], [0.0; 3]);
        let at = nan.len();
        old_imu(&mut nan, 129, 6, [0.0; 3], [0.0, f32::NAN, 0.0]);
        let e = read(&nan, None, false).unwrap_err().to_string();
        assert!(e.contains(&format!("byte {at} (IMU Acc, axis y): NaN")), "{e}");
    }

    #[test]
    fn half_floats_and_scaled_kinds_read_as_pymavlink_reads_them() {
        assert_eq!(super::dataflash_number(b'g', &0x3c00u16.to_le_bytes()), Some(1.0));
        assert_eq!(
            super::dataflash_number(b'g', &0xc100u16.to_le_bytes()),
            Some(-2.5)
        );
        assert_eq!(
            super::dataflash_number(b'g', &0x0001u16.to_le_bytes()),
            Some(2f64.powi(-24))
        );
        assert_eq!(
            super::dataflash_number(b'c', &(-1234i16).to_le_bytes()),
            Some(-1234.0 * 0.01)
        );
        assert_eq!(
            super::dataflash_number(b'L', &(-353_000_000i32).to_le_bytes()),
            Some(-353_000_000.0 * 1.0e-7)
        );
        assert_eq!(super::dataflash_number(b'Z', &[0; 64]), None);
    }
}

#[cfg(feature = "dataflash")]
use super::dataflash::number as dataflash_number;

/// ULog records written from the format's description.
#[cfg(feature = "ulog")]
mod ulog_logs {
    use super::*;

    fn record(out: &mut Vec<u8>, kind: u8, payload: &[u8]) {
        out.extend((payload.len() as u16).to_le_bytes());
        out.push(kind);
        out.extend(payload);
    }

    /// Header, flag bits, sensor_accel's format, subscription, then `n` samples.
    fn log(n: u64) -> Vec<u8> {
        let mut out = ULOG_MAGIC.to_vec();
        out.push(1);
        out.extend(0u64.to_le_bytes());
        record(&mut out, b'B', &[0; 40]);
        record(
            &mut out,
            b'F',
            b"sensor_accel:uint64_t timestamp;uint32_t device_id;float x;float y;float z;uint8_t[4] _padding0;",
        );
        let mut add = vec![0u8, 0, 0];
        add.extend(b"sensor_accel");
        record(&mut out, b'A', &add);
        for i in 0..n {
            let mut d = vec![0u8, 0];
            d.extend((1000 + 500 * i).to_le_bytes());
            d.extend(77u32.to_le_bytes());
            for v in [0.5f32, -0.25, -9.75] {
                d.extend(v.to_le_bytes());
            }
            record(&mut out, b'D', &d);
        }
        out
    }

    fn read(bytes: &[u8]) -> Result<Loaded, FormatError> {
        read_bytes(bytes, "t.ulg", &ReadOptions::default())
    }

    #[test]
    fn a_topic_without_sample_stamp_gyro_or_temperature_is_read_and_noted() {
        let l = read(&log(4)).unwrap();
        assert_eq!(l.recording.time_s, vec![0.0, 0.0005, 0.001, 0.0015]);
        assert_eq!(l.recording.accel_mps2[2], vec![-9.75; 4]);
        assert!(l.recording.gyro_radps.is_none() && l.recording.temperature_c.is_none());
        let f = l.flight.unwrap();
        assert_eq!(
            (f.device_id, f.device_id_from.as_str()),
            (Some(77), "sensor_accel.device_id")
        );
        for want in ["time from timestamp", "no sensor_gyro", "no temperature field"] {
            assert!(l.notes.iter().any(|n| n.contains(want)), "{want}: {:?}", l.notes);
        }
    }

    #[test]
    fn records_the_parser_would_index_past_their_end_are_refused_by_offset() {
        let good = log(3);
        // The format record follows the header (16 bytes) and the flag bits (3 + 40).
        let at = 16 + 43;
        let fmt_len = u16::from_le_bytes([good[at], good[at + 1]]) as usize;
        let a_at = at + 3 + fmt_len;
        let mut bad = good[..a_at].to_vec();
        record(&mut bad, b'A', &[0, 0]);
        let e = read(&bad).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "t.ulg: byte {a_at}: add_logged message ('A') of 2 bytes"
            )),
            "{e}"
        );
        let mut bad = good[..a_at].to_vec();
        record(&mut bad, b'P', &[200, b'a']);
        let e = read(&bad).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "byte {a_at}: parameter message ('P'): its key of 200 bytes runs past its 2 bytes"
            )),
            "{e}"
        );
        // A data message of the wrong size is px4-ulog's error, at its record, in one line.
        let mut bad = good.clone();
        let d_at = bad.len();
        record(&mut bad, b'D', &[0, 0, 1]);
        let e = read(&bad).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("t.ulg: byte {d_at}: 'D' message: parse error: data message had wrong size 3")
        );
        // Cut short: the samples before the cut, with a note.
        let l = read(&good[..good.len() - 4]).unwrap();
        assert_eq!(l.recording.len(), 2);
        assert!(l.notes.iter().any(|n| n.contains("cut short")), "{:?}", l.notes);
    }

    #[test]
    fn an_instance_the_log_lacks_is_refused_with_the_list() {
        let e = read_bytes(
            &log(3),
            "t.ulg",
            &ReadOptions {
                topic: Some("sensor_accel_2".into()),
                ..Default::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "t.ulg: no IMU instance 'sensor_accel_2' (the log has: sensor_accel 0)"
        );
    }
}
