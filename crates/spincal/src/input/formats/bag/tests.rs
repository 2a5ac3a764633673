//! The bag reader's tests: chunk limits, temperature merging, topic choice, detection and pair
//! merging.

use super::assemble::{merge, Timed};
use super::choice::{choose, Choice};
use super::msg::{Encoding, MsgKind};
use super::*;

#[test]
fn a_chunk_is_held_to_its_stated_size_and_the_chunk_limit() {
    use std::io::Write;
    let zeros = vec![0u8; 4 << 20];
    let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
    bz.write_all(&zeros).unwrap();
    let bz = bz.finish().unwrap();
    assert!(bz.len() < 1024, "{}", bz.len());
    // 4 MiB of zeros in under 1 KiB: over 4096 × its size + 1 MiB, refused unopened.
    let e = decompress_chunk("bz2", &bz, zeros.len()).unwrap_err();
    assert!(e.contains("over the limit of"), "{e}");
    assert!(chunk_limit(bz.len()) < zeros.len() as u64);
    // A 3 GiB claim from a large chunk is over MAX_CHUNK_BYTES.
    let big = vec![0u8; 1 << 20];
    let e = decompress_chunk("zstd", &big, 3 << 30).unwrap_err();
    assert!(e.contains(&format!("at most {MAX_CHUNK_BYTES}")), "{e}");
    // Within the limits: exactly the stated size, and no more.
    let small = zstd::encode_all(&zeros[..100_000], 3).unwrap();
    assert_eq!(decompress_chunk("zstd", &small, 100_000).unwrap().len(), 100_000);
    let e = decompress_chunk("zstd", &small, 99_999).unwrap_err();
    assert_eq!(
        e,
        "zstd chunk decompresses to 100000+ bytes, its header says 99999"
    );
}

/// A bag's `sensor_msgs/Temperature` topic goes beside the IMU's samples, on their stamps:
/// interpolated within its span, held beyond it, in ROS 1 and ROS 2 encodings alike; a
/// damaged temperature topic is left out with a note and never stops the IMU data.
#[test]
fn a_temperature_topic_is_merged_on_the_imu_stamps() {
    for (encoding, name) in [(Encoding::Cdr, "cdr"), (Encoding::Ros1, "ros1")] {
        let (imu_type, temp_type) = match encoding {
            Encoding::Cdr => ("sensor_msgs/msg/Imu", "sensor_msgs/msg/Temperature"),
            Encoding::Ros1 => ("sensor_msgs/Imu", "sensor_msgs/Temperature"),
        };
        for damaged in [false, true] {
            // --topic names the IMU only: the temperature is read all the same.
            let mut c = Collector::new("b", Some("/imu"), false);
            let imu = c.topic("/imu", imu_type, name);
            let temp = c.topic("/imu/temperature", temp_type, name);
            let t0 = 1_700_000_000_000_000_000i64;
            let message = |stamp_ns: i64, vector: [f64; 3]| msg::Decoded {
                stamp_ns,
                frame_id: "imu_link".into(),
                vector,
                angular_velocity: Some([0.0; 3]),
                accel_cov0: 0.0,
                gyro_cov0: 0.0,
            };
            // IMU at 100 Hz for 3 s; temperature at 1 Hz from 0.5 s to 2.5 s, 20 °C rising 1 °C/s.
            for k in 0..300 {
                let m = message(t0 + k * 10_000_000, [0.0, 0.0, 9.8]);
                c.message(
                    imu,
                    0,
                    &msg::encode(&m, encoding, MsgKind::Imu, k as u32),
                    &|| String::new(),
                );
            }
            for k in 0..3 {
                let m = message(t0 + 500_000_000 + k * 1_000_000_000, [20.0 + k as f64, 0.01, 0.0]);
                let mut bytes = msg::encode(&m, encoding, MsgKind::Temperature, k as u32);
                if damaged && k == 1 {
                    bytes.truncate(bytes.len() - 3);
                }
                c.message(temp, 0, &bytes, &|| String::new());
            }
            let read = assemble(c, Storage::Mcap, Some("/imu")).unwrap();
            let r = &read.recording;
            assert_eq!(r.len(), 300);
            if damaged {
                assert!(r.temperature_c.is_none());
                assert!(
                    read.notes
                        .iter()
                        .any(|n| n.starts_with("temperature topic /imu/temperature left out")),
                    "{:?}",
                    read.notes
                );
                continue;
            }
            let temp = r.temperature_c.as_ref().expect("the temperature was merged");
            assert_eq!(r.source.columns.last().map(String::as_str), Some("temperature"));
            assert_eq!(temp[0], 20.0, "held before its first message");
            assert!((temp[150] - 21.0).abs() < 1e-12, "{}", temp[150]);
            assert!((temp[100] - 20.5).abs() < 1e-12, "{}", temp[100]);
            assert_eq!(temp[299], 22.0, "held after its last message");
            assert!(
                read.notes
                    .iter()
                    .any(|n| n.contains("201 within its span") && n.contains("99 beyond it")),
                "{:?}",
                read.notes
            );
        }
    }
}

fn collector_with(topics: &[(&str, &str)]) -> Collector {
    let mut c = Collector::new("b", None, false);
    for (name, ty) in topics {
        let i = c.topic(name, ty, "cdr");
        c.topics[i].count = 3;
    }
    c
}

#[test]
fn choice_lists_or_picks() {
    let c = collector_with(&[("/imu", "sensor_msgs/msg/Imu"), ("/cam", "sensor_msgs/msg/Image")]);
    assert_eq!(choose(&c, None).unwrap(), Choice::Imu(0));
    let c = collector_with(&[("/imu", "sensor_msgs/msg/Imu"), ("/imu2", "sensor_msgs/Imu")]);
    let e = choose(&c, None).unwrap_err().to_string();
    assert!(
        e.contains("2 IMU topics") && e.contains("/imu2 (sensor_msgs/Imu, 3 messages)"),
        "{e}"
    );
    assert_eq!(choose(&c, Some("/imu2")).unwrap(), Choice::Imu(1));
    assert!(matches!(
        choose(&c, Some("/nope")),
        Err(BagError::NoSuchTopic { .. })
    ));
    let c = collector_with(&[
        ("/camera/accel/sample", "geometry_msgs/msg/Vector3Stamped"),
        ("/camera/gyro/sample", "geometry_msgs/msg/Vector3Stamped"),
    ]);
    assert_eq!(
        choose(&c, None).unwrap(),
        Choice::Vectors {
            accel: 0,
            gyro: Some(1)
        }
    );
    let c = collector_with(&[("/cam", "sensor_msgs/msg/Image")]);
    let e = choose(&c, None).unwrap_err().to_string();
    assert!(
        e.contains("no IMU topic") && e.contains("/cam (sensor_msgs/msg/Image, 3 messages)"),
        "{e}"
    );
}

#[test]
fn detected_by_magic_and_other_versions_refused() {
    use crate::input::formats::{detect, Format};
    for head in [
        &b"\x89MCAP0\r\n\x01"[..],
        b"SQLite format 3\0xyz",
        b"#ROSBAG V2.0\n",
    ] {
        assert_eq!(detect(head).format, Format::RosBag, "{head:?}");
    }
    let e = read_bytes(b"#ROSBAG V1.2\n\0\0", "old.bag", None, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("old.bag: '#ROSBAG V1.2': only ROS 1 bag format 2.0"),
        "{e}"
    );
    let e = read_bytes(b"\x89MCAP0\r\n", "cut.mcap", None, false)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "cut.mcap: byte 8: the file ends without a footer record (truncated)"
    );
    let e = read_bytes(b"#ROSBAG V2.0\n\x05\0\0\0", "cut.bag", None, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("cut.bag: byte 13: record header of 5 bytes runs past the end"),
        "{e}"
    );
    let e = read_bytes(b"SQLite format 3\0", "x.db3", None, false)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("x.db3: sqlite3 storage"), "{e}");
}

#[test]
fn merge_takes_equal_stamps_and_interpolates_others() {
    let accel = Timed {
        ns: vec![0, 10, 20, 40],
        v: [vec![1.0; 4], vec![2.0; 4], vec![3.0; 4]],
        g: None,
        clock: "header stamp",
    };
    let gyro = Timed {
        ns: vec![5, 10, 30],
        v: [vec![0.0, 1.0, 3.0], vec![0.0; 3], vec![0.0; 3]],
        g: None,
        clock: "header stamp",
    };
    let mut notes = Vec::new();
    let m = merge(accel, gyro, &mut notes, ("a", "g"));
    assert_eq!(m.ns, [10, 20]);
    assert_eq!(m.g.unwrap()[0], [1.0, 2.0]);
    assert!(
        notes[0].contains("1 equal, 1 interpolated, 2 accelerometer samples"),
        "{notes:?}"
    );
}
