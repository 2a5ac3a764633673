//! Flight-controller logs (tests/fixtures/flight, written byte by byte from the formats'
//! documentation by make_fixtures.py) read as the reference readers read them: every sample,
//! stamp and temperature equal to the bit to what pyulog (ULog) and pymavlink (DataFlash) wrote
//! as CSV; instances chosen, device ids found, damage refused without a panic.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::input::formats::flight::FlightStack;
use spincal::input::formats::{detect, read_bytes, read_path, Format, Loaded, ReadOptions};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/flight")
        .join(name)
}

/// A reference CSV: its columns by header name, as text.
struct Csv {
    columns: HashMap<String, Vec<String>>,
    rows: usize,
}

impl Csv {
    fn read(name: &str) -> Csv {
        Csv::read_path(&fixture(name))
    }

    fn read_path(path: &Path) -> Csv {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let mut columns: HashMap<String, Vec<String>> =
            header.iter().map(|h| (h.clone(), Vec::new())).collect();
        let mut rows = 0;
        for line in lines {
            for (h, v) in header.iter().zip(line.split(',')) {
                columns.get_mut(h).unwrap().push(v.to_string());
            }
            rows += 1;
        }
        Csv { columns, rows }
    }

    fn f64s(&self, name: &str) -> Vec<f64> {
        self.columns[name].iter().map(|v| v.parse().unwrap()).collect()
    }

    fn ints(&self, name: &str) -> Vec<i64> {
        self.columns[name].iter().map(|v| v.parse().unwrap()).collect()
    }

    /// The rows in the order of an integer column (stable: the log's order among equals).
    fn sorted_by(&self, key: &str) -> Csv {
        let k = self.ints(key);
        let mut order: Vec<usize> = (0..self.rows).collect();
        order.sort_by_key(|&i| k[i]);
        Csv {
            columns: self
                .columns
                .iter()
                .map(|(name, v)| (name.clone(), order.iter().map(|&i| v[i].clone()).collect()))
                .collect(),
            rows: self.rows,
        }
    }

    /// The rows where `keep` holds.
    fn filter(&self, keep: impl Fn(usize) -> bool) -> Csv {
        Csv {
            columns: self
                .columns
                .iter()
                .map(|(k, v)| {
                    (
                        k.clone(),
                        (0..self.rows)
                            .filter(|&i| keep(i))
                            .map(|i| v[i].clone())
                            .collect(),
                    )
                })
                .collect(),
            rows: (0..self.rows).filter(|&i| keep(i)).count(),
        }
    }
}

fn read(name: &str, topic: Option<&str>) -> Loaded {
    read_path(
        &fixture(name),
        &ReadOptions {
            topic: topic.map(String::from),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Equal to the bit (so -0.0 ≠ 0.0 and NaN = NaN of the same payload).
fn assert_bits(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g.to_bits(), w.to_bits(), "{what}[{i}]: {g} ≠ {w}");
    }
}

/// Seconds from the first stamp, as whole microseconds divided once.
fn seconds(us: &[i64]) -> Vec<f64> {
    us.iter().map(|&t| (t - us[0]) as f64 / 1e6).collect()
}

fn has_note(l: &Loaded, want: &str) {
    assert!(
        l.notes.iter().any(|n| n.contains(want)),
        "no note with '{want}': {:#?}",
        l.notes
    );
}

#[test]
fn px4_sensor_accel_and_gyro_equal_pyulog_to_the_bit() {
    let l = read("px4_sensor_accel.ulg", None);
    assert_eq!(l.format, Format::Ulog);
    assert!(l.detection.as_ref().unwrap().reason.contains("ULog magic"));
    let accel = Csv::read("px4_sensor_accel.sensor_accel_0.csv");
    let gyro = Csv::read("px4_sensor_accel.sensor_gyro_0.csv");
    let r = &l.recording;
    assert_eq!(r.len(), accel.rows);
    assert_eq!(accel.ints("timestamp_sample"), gyro.ints("timestamp_sample"));
    assert_bits("t", &r.time_s, &seconds(&accel.ints("timestamp_sample")));
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        assert_bits(axis, &r.accel_mps2[k], &accel.f64s(axis));
        assert_bits(axis, &r.gyro_radps.as_ref().unwrap()[k], &gyro.f64s(axis));
    }
    assert_bits(
        "temperature",
        r.temperature_c.as_ref().unwrap(),
        &accel.f64s("temperature"),
    );
    let f = l.flight.as_ref().unwrap();
    assert_eq!(f.stack, FlightStack::Px4);
    assert_eq!((f.instance, f.instances.clone()), (0, vec![0, 1]));
    assert_eq!(f.source, "sensor_accel + sensor_gyro");
    assert_eq!(
        Some(i64::from(f.device_id.unwrap())),
        accel.ints("device_id").first().copied()
    );
    assert_eq!(f.device_id_from, "sensor_accel.device_id");
    has_note(&l, "300 equal, 0 interpolated, 0 accelerometer samples");
    has_note(&l, "accelerometer device id 2490378");
    assert_eq!(r.source.format, "ulog");
    assert!(
        r.source.metadata.iter().any(|m| m == "sys_name: PX4"),
        "{:?}",
        r.source.metadata
    );
}

#[test]
fn px4_second_instance_interpolates_the_gyro_the_logger_dropped() {
    let l = read("px4_sensor_accel.ulg", Some("sensor_accel_1"));
    let accel = Csv::read("px4_sensor_accel.sensor_accel_1.csv");
    let gyro = Csv::read("px4_sensor_accel.sensor_gyro_1.csv");
    let r = &l.recording;
    let (ta, tg) = (accel.ints("timestamp_sample"), gyro.ints("timestamp_sample"));
    assert_eq!(r.len(), accel.rows, "the gyro spans every accelerometer sample");
    assert_bits("t", &r.time_s, &seconds(&ta));
    assert_bits(
        "temperature",
        r.temperature_c.as_ref().unwrap(),
        &accel.f64s("temperature"),
    );
    let mut interpolated = 0;
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        assert_bits(axis, &r.accel_mps2[k], &accel.f64s(axis));
        let g = gyro.f64s(axis);
        let want: Vec<f64> = ta
            .iter()
            .map(|t| match tg.binary_search(t) {
                Ok(j) => g[j],
                Err(j) => {
                    interpolated += 1;
                    let f = (t - tg[j - 1]) as f64 / (tg[j] - tg[j - 1]) as f64;
                    g[j - 1] + f * (g[j] - g[j - 1])
                }
            })
            .collect();
        assert_bits(axis, &r.gyro_radps.as_ref().unwrap()[k], &want);
    }
    assert_eq!(interpolated, 3 * (accel.rows - gyro.rows));
    has_note(
        &l,
        &format!(
            "sensor_gyro instance 1 (device id 3014666, the accelerometer's) on the accelerometer's stamps: {} equal, {} interpolated",
            gyro.rows,
            accel.rows - gyro.rows
        ),
    );
    assert_eq!(l.flight.as_ref().unwrap().device_id, Some(3_014_666));
    // The same instance by number alone.
    assert_eq!(read("px4_sensor_accel.ulg", Some("1")).recording, l.recording);
}

/// A sensor_combined reference's rows with an accelerometer sample, and their times (µs).
fn combined_reference(name: &str) -> (Csv, Vec<i64>) {
    let all = Csv::read(name);
    let relative = all.ints("accelerometer_timestamp_relative");
    let csv = all.filter(|i| relative[i] != 0x7fff_ffff);
    let t: Vec<i64> = csv
        .ints("timestamp")
        .iter()
        .zip(csv.ints("accelerometer_timestamp_relative"))
        .map(|(t, r)| t + r)
        .collect();
    (csv, t)
}

fn assert_combined(l: &Loaded, csv: &Csv, t: &[i64]) {
    let r = &l.recording;
    assert_bits("t", &r.time_s, &seconds(t));
    for k in 0..3 {
        assert_bits(
            "accel",
            &r.accel_mps2[k],
            &csv.f64s(&format!("accelerometer_m_s2[{k}]")),
        );
        assert_bits(
            "gyro",
            &r.gyro_radps.as_ref().unwrap()[k],
            &csv.f64s(&format!("gyro_rad[{k}]")),
        );
    }
    assert!(r.temperature_c.is_none());
    has_note(l, "no temperature: sensor_combined carries none");
    assert_eq!(l.flight.as_ref().unwrap().source, "sensor_combined");
}

#[test]
fn px4_sensor_combined_equals_pyulog_and_names_the_missing_temperature() {
    let l = read("px4_sensor_combined.ulg", None);
    let (csv, t) = combined_reference("px4_sensor_combined.sensor_combined_0.csv");
    assert_eq!(csv.rows, 399, "one message without an accelerometer sample");
    assert_combined(&l, &csv, &t);
    has_note(&l, "1 messages without an accelerometer sample");
    let selection = Csv::read("px4_sensor_combined.sensor_selection_0.csv");
    let f = l.flight.as_ref().unwrap();
    assert_eq!(
        f.device_id.map(i64::from),
        selection.ints("accel_device_id").first().copied()
    );
    assert_eq!(f.device_id_from, "sensor_selection.accel_device_id");
    // A log with both: sensor_combined when asked for.
    let l = read("px4_sensor_accel.ulg", Some("sensor_combined"));
    let (csv, t) = combined_reference("px4_sensor_accel.sensor_combined_0.csv");
    assert_combined(&l, &csv, &t);
    assert!(l.flight.as_ref().unwrap().device_id.is_none());
    assert!(l.flight.as_ref().unwrap().device_id_from.contains("CAL_ACCn_ID"));
}

#[test]
fn ardupilot_imu_equals_pymavlink_to_the_bit_for_each_instance() {
    let all = Csv::read("ardupilot_imu.IMU.csv");
    let params = Csv::read("ardupilot_imu.PARM.csv");
    let param = |name: &str| {
        let i = params.columns["Name"].iter().position(|n| n == name).unwrap();
        params.f64s("Value")[i] as u32
    };
    for (instance, topic, id) in [
        (0, None, param("INS_ACC_ID")),
        (1, Some("IMU[1]"), param("INS_ACC2_ID")),
    ] {
        let l = read("ardupilot_imu.bin", topic);
        assert_eq!(l.format, Format::DataFlash);
        let inst = all.ints("I");
        let csv = all.filter(|i| inst[i] == instance);
        let r = &l.recording;
        assert_eq!(r.len(), 300);
        assert_bits("t", &r.time_s, &seconds(&csv.ints("TimeUS")));
        for (k, axis) in ["X", "Y", "Z"].into_iter().enumerate() {
            assert_bits("acc", &r.accel_mps2[k], &csv.f64s(&format!("Acc{axis}")));
            assert_bits(
                "gyr",
                &r.gyro_radps.as_ref().unwrap()[k],
                &csv.f64s(&format!("Gyr{axis}")),
            );
        }
        assert_bits("T", r.temperature_c.as_ref().unwrap(), &csv.f64s("T"));
        let f = l.flight.as_ref().unwrap();
        assert_eq!(f.stack, FlightStack::ArduPilot);
        assert_eq!((f.instance, f.instances.clone()), (instance as u8, vec![0, 1]));
        assert_eq!(f.device_id, Some(id));
        assert!(
            f.device_id_from.starts_with("PARM INS_ACC"),
            "{}",
            f.device_id_from
        );
    }
    assert_eq!(
        read("ardupilot_imu.bin", None).recording.source.metadata,
        vec!["ArduCopter V4.5.7 (2a3dc4b7)".to_string()]
    );
}

#[test]
fn flight_logs_are_detected_by_their_first_bytes() {
    for (name, format) in [
        ("px4_sensor_accel.ulg", Format::Ulog),
        ("px4_sensor_combined.ulg", Format::Ulog),
        ("ardupilot_imu.bin", Format::DataFlash),
    ] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        assert_eq!(detect(&bytes[..64]).format, format, "{name}");
        assert_eq!(Format::parse(format.name()), Some(format));
    }
    assert_eq!(Format::parse("ulg"), Some(Format::Ulog));
    assert_eq!(Format::parse("bin"), Some(Format::DataFlash));
}

/// Cut and flipped bytes in every fixture: read or refused with an error naming the file, never
/// a panic. (Seeded, so every run tries the same damage.)
#[test]
fn damaged_logs_are_read_or_refused_by_name_never_a_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(48);
    for name in [
        "px4_sensor_accel.ulg",
        "px4_sensor_combined.ulg",
        "ardupilot_imu.bin",
    ] {
        let good = std::fs::read(fixture(name)).unwrap();
        for trial in 0..150 {
            let mut bad = good.clone();
            if trial % 3 == 0 {
                bad.truncate(rng.gen_range(0..good.len()));
            } else {
                for _ in 0..rng.gen_range(1..4) {
                    let at = rng.gen_range(0..bad.len());
                    bad[at] = rng.gen();
                }
            }
            for salvage in [false, true] {
                let options = ReadOptions {
                    salvage,
                    ..Default::default()
                };
                if let Err(e) = read_bytes(&bad, name, &options) {
                    let text = e.to_string();
                    assert!(text.starts_with(name), "{name} trial {trial}: {text}");
                }
            }
        }
    }
}

/// Real logs, when `SPINCAL_FLIGHT_LOGS` names a folder of `.ulg`/`.bin` files with the reference
/// readers' CSVs beside them (`make_fixtures.py --reference DIR LOG...` writes them): each log's
/// default reading (and sensor_combined where the log has it) equals pyulog's or pymavlink's to
/// the bit. No real flight log is in ../shared/data, so without the variable this skips.
#[test]
fn real_logs_equal_the_reference_readers_when_given() {
    let Some(dir) = std::env::var_os("SPINCAL_FLIGHT_LOGS").map(PathBuf::from) else {
        eprintln!("skipped: SPINCAL_FLIGHT_LOGS is not set (no real flight log is in ../shared/data)");
        return;
    };
    let mut checked = 0;
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for path in names {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "ulg" && ext != "bin" {
            continue;
        }
        let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
        let csv = |suffix: &str| {
            let p = dir.join(format!("{stem}.{suffix}.csv"));
            p.is_file().then(|| Csv::read_path(&p))
        };
        let options = |topic: Option<&str>| ReadOptions {
            topic: topic.map(String::from),
            ..Default::default()
        };
        if ext == "bin" {
            let l = read_path(&path, &options(None)).unwrap_or_else(|e| panic!("{e}"));
            let all = csv("IMU").unwrap();
            let instance = i64::from(l.flight.as_ref().unwrap().instance);
            let inst = all.ints("I");
            let c = all.filter(|i| inst[i] == instance).sorted_by("TimeUS");
            assert_bits("t", &l.recording.time_s, &seconds(&c.ints("TimeUS")));
            for (k, axis) in ["X", "Y", "Z"].into_iter().enumerate() {
                assert_bits("acc", &l.recording.accel_mps2[k], &c.f64s(&format!("Acc{axis}")));
                assert_bits(
                    "gyr",
                    &l.recording.gyro_radps.as_ref().unwrap()[k],
                    &c.f64s(&format!("Gyr{axis}")),
                );
            }
            eprintln!(
                "{stem}: IMU[{instance}] {} samples equal pymavlink's",
                l.recording.len()
            );
            checked += 1;
            continue;
        }
        let l = read_path(&path, &options(None)).unwrap_or_else(|e| panic!("{e}"));
        let f = l.flight.as_ref().unwrap();
        if f.source.starts_with("sensor_accel") {
            let mut c = csv(&format!("sensor_accel_{}", f.instance))
                .unwrap()
                .sorted_by("timestamp_sample");
            if l.recording.gyro_radps.is_some() {
                // Accelerometer samples outside the gyro's span are left out: the gyro of the same
                // device id (else the same instance) gives the span.
                let id = c.ints("device_id")[0];
                let gyros: Vec<Csv> = (0..8).filter_map(|i| csv(&format!("sensor_gyro_{i}"))).collect();
                let g = gyros
                    .iter()
                    .find(|g| g.ints("device_id").first() == Some(&id))
                    .unwrap_or_else(|| &gyros[f.instance as usize])
                    .sorted_by("timestamp_sample");
                let span = g.ints("timestamp_sample");
                let (first, last) = (span[0], span[span.len() - 1]);
                let t = c.ints("timestamp_sample");
                c = c.filter(|i| t[i] >= first && t[i] <= last);
            }
            assert_bits("t", &l.recording.time_s, &seconds(&c.ints("timestamp_sample")));
            for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
                assert_bits(axis, &l.recording.accel_mps2[k], &c.f64s(axis));
            }
            if let Some(t) = &l.recording.temperature_c {
                assert_bits("temperature", t, &c.f64s("temperature"));
            }
            assert_eq!(f.device_id.map(i64::from), c.ints("device_id").first().copied());
            eprintln!(
                "{stem}: sensor_accel {} ({} samples) equals pyulog's; notes: {:?}",
                f.instance,
                l.recording.len(),
                l.notes
            );
            checked += 1;
        }
        if let Some(all) = csv("sensor_combined_0") {
            let l = read_path(&path, &options(Some("sensor_combined"))).unwrap_or_else(|e| panic!("{e}"));
            let relative = all.ints("accelerometer_timestamp_relative");
            let mut c = all.filter(|i| relative[i] != 0x7fff_ffff);
            let t: Vec<String> = c
                .ints("timestamp")
                .iter()
                .zip(c.ints("accelerometer_timestamp_relative"))
                .map(|(t, r)| (t + r).to_string())
                .collect();
            c.columns.insert("t".into(), t);
            let c = c.sorted_by("t");
            assert_combined(&l, &c, &c.ints("t"));
            eprintln!(
                "{stem}: sensor_combined ({} samples) equals pyulog's",
                l.recording.len()
            );
            checked += 1;
        }
    }
    assert!(
        checked > 0,
        "SPINCAL_FLIGHT_LOGS={}: no log with reference CSVs",
        dir.display()
    );
}
