//! ROS bags written by the pure-Python `rosbags` package (scripts/make_bag_fixtures.py, run at
//! test time with the test venv) from a simulated CSV recording: every storage kind gives the
//! CSV's samples (accelerometer and gyro to the bit: the messages carry float64; time to 1 ns:
//! stamps are integer ns), the same rotation rate, topics are listed and chosen, and damaged bags
//! give located errors.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use spincal::input::formats::bag::BagError;
use spincal::input::formats::{read_bytes, read_path, Format, FormatError, Loaded, ReadOptions};
use spincal::input::recording::{AccelUnit, Recording};
use spincal::simulate::{simulate, SensorProfile, TurntableSetup};
use spincal::turntable::spectrum::{estimate_rotation_rate, RateSearch};

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The test venv's python, or `None` (skip, with the reason printed) when it is absent; with
/// `SPINCAL_REQUIRE_PYTHON=1` (CI) its absence fails the test.
fn venv_python() -> Option<PathBuf> {
    let python = Path::new(REPO).join(".venv/bin/python");
    if python.is_file() {
        return Some(python);
    }
    let why = format!(
        "{} is absent: run `bash scripts/setup.sh` (or scripts/python_env.sh)",
        python.display()
    );
    if std::env::var("SPINCAL_REQUIRE_PYTHON").is_ok_and(|v| v == "1") {
        panic!("SPINCAL_REQUIRE_PYTHON=1: {why}");
    }
    eprintln!("skipped: {why}");
    None
}

struct Fixtures {
    dir: PathBuf,
    csv: Recording,
}

/// The CSV recording (a simulated 33⅓ rpm run with a gyro added: z follows the platter) and the
/// bags made from it, once per test process.
fn fixtures() -> Option<&'static Fixtures> {
    static FIXTURES: OnceLock<Option<Fixtures>> = OnceLock::new();
    FIXTURES
        .get_or_init(|| {
            let python = venv_python()?;
            let dir = std::env::temp_dir().join(format!("spincal-bags-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            let table = TurntableSetup {
                duration_s: 30.0,
                ..TurntableSetup::default()
            };
            let mut rec = simulate(&SensorProfile::default(), &table, 7).unwrap().recording;
            if rec.gyro_radps.is_none() {
                let t = &rec.time_s;
                let omega = table.rpm * std::f64::consts::PI / 30.0;
                rec.gyro_radps = Some([
                    t.iter().map(|t| 0.003 * (0.7 * t).sin()).collect(),
                    t.iter().map(|t| -0.002 + 1e-4 * t).collect(),
                    t.iter()
                        .map(|t| omega * (1.0 + 0.001 * (1.3 * t).cos()))
                        .collect(),
                ]);
            }
            let csv_path = dir.join("rec.csv");
            rec.write_csv_path(&csv_path, AccelUnit::Mps2).unwrap();
            // The CSV as spincal reads it back is the reference (its text holds every bit).
            let csv = read_path(&csv_path, &ReadOptions::default()).unwrap().recording;
            let out = dir.join("bags");
            let status = Command::new(&python)
                .arg(Path::new(REPO).join("scripts/make_bag_fixtures.py"))
                .arg(&csv_path)
                .arg(&out)
                .status()
                .unwrap();
            assert!(status.success(), "make_bag_fixtures.py failed: {status}");
            Some(Fixtures { dir: out, csv })
        })
        .as_ref()
}

fn read(path: &Path, topic: Option<&str>) -> Result<Loaded, FormatError> {
    read_path(
        path,
        &ReadOptions {
            topic: topic.map(String::from),
            ..Default::default()
        },
    )
}

fn assert_same_samples(bag: &Recording, csv: &Recording, what: &str) {
    assert_eq!(bag.len(), csv.len(), "{what}: sample count");
    let t0 = csv.time_s[0];
    for (i, (b, c)) in bag.time_s.iter().zip(&csv.time_s).enumerate() {
        assert!((b - (c - t0)).abs() <= 1e-9, "{what}: t[{i}] {b} vs {c}");
    }
    for k in 0..3 {
        for (i, (b, c)) in bag.accel_mps2[k].iter().zip(&csv.accel_mps2[k]).enumerate() {
            assert_eq!(b.to_bits(), c.to_bits(), "{what}: accel[{k}][{i}] {b} vs {c}");
        }
    }
    let (bg, cg) = (bag.gyro_radps.as_ref().unwrap(), csv.gyro_radps.as_ref().unwrap());
    for k in 0..3 {
        for (i, (b, c)) in bg[k].iter().zip(&cg[k]).enumerate() {
            assert_eq!(b.to_bits(), c.to_bits(), "{what}: gyro[{k}][{i}] {b} vs {c}");
        }
    }
}

/// Every storage kind and compression, as a directory and as the single storage file.
fn single_imu_bags(dir: &Path) -> Vec<(PathBuf, &'static str)> {
    vec![
        (dir.join("mcap"), "ROS 2 mcap"),
        (dir.join("mcap/mcap.mcap"), "ROS 2 mcap"),
        (dir.join("mcap_zstd"), "ROS 2 mcap"),
        (dir.join("sqlite3"), "ROS 2 sqlite3"),
        (dir.join("sqlite3/sqlite3.db3"), "ROS 2 sqlite3"),
        (dir.join("ros1_none.bag"), "ROS 1 bag 2.0"),
        (dir.join("ros1_bz2.bag"), "ROS 1 bag 2.0"),
        (dir.join("ros1_lz4.bag"), "ROS 1 bag 2.0"),
    ]
}

#[test]
fn every_storage_gives_the_csv_samples_and_rate() {
    let Some(fx) = fixtures() else { return };
    let csv_rate = estimate_rotation_rate(&fx.csv, RateSearch::default()).unwrap();
    for (path, storage) in single_imu_bags(&fx.dir) {
        let what = path.display().to_string();
        let loaded = read(&path, None).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(loaded.format, Format::RosBag, "{what}");
        let d = loaded.detection.as_ref().unwrap();
        assert!(d.reason.contains(storage), "{what}: {}", d.reason);
        let rec = &loaded.recording;
        assert_same_samples(rec, &fx.csv, &what);
        let meta = rec.source.metadata.join("\n");
        assert!(meta.contains(&format!("storage: {storage}")), "{what}: {meta}");
        assert!(meta.contains("topic: /imu (sensor_msgs"), "{what}: {meta}");
        assert!(meta.contains("frame_id: imu_link"), "{what}: {meta}");
        assert!(
            meta.contains("time: header stamp from 1700000000.000000000 s"),
            "{what}: {meta}"
        );
        assert_eq!(rec.source.format, "rosbag");
        // Stamps, not receive times (1 ms later), were used: checked by the time comparison above.
        let rate = estimate_rotation_rate(rec, RateSearch::default()).unwrap();
        assert!(
            (rate.rpm - csv_rate.rpm).abs() <= 1e-9 * csv_rate.rpm,
            "{what}: {} rpm vs the CSV's {} rpm",
            rate.rpm,
            csv_rate.rpm
        );
    }
}

#[test]
fn bag_bytes_read_like_bag_files() {
    let Some(fx) = fixtures() else { return };
    for name in ["mcap/mcap.mcap", "sqlite3/sqlite3.db3", "ros1_lz4.bag"] {
        let bytes = std::fs::read(fx.dir.join(name)).unwrap();
        let loaded = read_bytes(&bytes, name, &ReadOptions::default()).unwrap();
        assert_eq!(loaded.format, Format::RosBag);
        assert_same_samples(&loaded.recording, &fx.csv, name);
    }
}

#[test]
fn several_imu_topics_are_listed_and_one_is_chosen() {
    let Some(fx) = fixtures() else { return };
    let n = fx.csv.len();
    for name in ["two_imus_mcap", "two_imus_sqlite3", "two_imus.bag"] {
        let path = fx.dir.join(name);
        let e = read(&path, None).unwrap_err();
        let text = e.to_string();
        assert!(
            matches!(e, FormatError::Bag(BagError::SeveralTopics { count: 2, .. })),
            "{name}: {text}"
        );
        assert!(
            text.contains(&format!("/imu (sensor_msgs/msg/Imu, {n} messages)"))
                || text.contains(&format!("/imu (sensor_msgs/Imu, {n} messages)")),
            "{text}"
        );
        assert!(text.contains("/imu_b (") && text.contains("`topic`"), "{text}");
        assert!(text.starts_with(&path.display().to_string()), "{text}");

        let a = read(&path, Some("/imu")).unwrap().recording;
        assert_same_samples(&a, &fx.csv, name);
        let b = read(&path, Some("/imu_b")).unwrap().recording;
        for k in 0..3 {
            for (x, y) in b.accel_mps2[k].iter().zip(&fx.csv.accel_mps2[k]) {
                assert_eq!(*x, 2.0 * y);
            }
        }
        assert!(b.source.metadata.iter().any(|m| m.starts_with("topic: /imu_b")));
        let e = read(&path, Some("/temperature")).unwrap_err();
        assert!(matches!(e, FormatError::Bag(BagError::NoSuchTopic { .. })), "{e}");
    }
}

#[test]
fn vector3stamped_pairs_are_merged() {
    let Some(fx) = fixtures() else { return };
    for name in ["pairs_mcap", "pairs.bag"] {
        let path = fx.dir.join(name);
        for topic in [None, Some("/camera/accel/sample,/camera/gyro/sample")] {
            let loaded = read(&path, topic).unwrap();
            assert_same_samples(&loaded.recording, &fx.csv, name);
            assert!(
                loaded
                    .notes
                    .iter()
                    .any(|n| n.contains(&format!("{} equal, 0 interpolated", fx.csv.len()))),
                "{:?}",
                loaded.notes
            );
        }
        // The accelerometer topic alone: no gyro.
        let alone = read(&path, Some("/camera/accel/sample")).unwrap().recording;
        assert!(alone.gyro_radps.is_none());
        assert_eq!(alone.accel_mps2, fx.csv.accel_mps2);
    }
}

#[test]
fn zero_stamps_fall_back_to_receive_times() {
    let Some(fx) = fixtures() else { return };
    let loaded = read(&fx.dir.join("zero_stamps"), None).unwrap();
    assert_same_samples(&loaded.recording, &fx.csv, "zero_stamps");
    assert!(
        loaded.notes.iter().any(|n| n.contains("receive (log) times")),
        "{:?}",
        loaded.notes
    );
    assert!(loaded
        .recording
        .source
        .metadata
        .iter()
        .any(|m| m.starts_with("time: receive time")));
}

/// Every cut of a bag file is refused with an error naming the file and a place in it.
#[test]
fn truncated_bags_give_located_errors() {
    let Some(fx) = fixtures() else { return };
    for name in [
        "mcap/mcap.mcap",
        "mcap_zstd/mcap_zstd.mcap",
        "ros1_none.bag",
        "ros1_bz2.bag",
        "ros1_lz4.bag",
        "sqlite3/sqlite3.db3",
    ] {
        let bytes = std::fs::read(fx.dir.join(name)).unwrap();
        let cuts: Vec<usize> = (1..40)
            .map(|k| bytes.len() * k / 40)
            .chain([bytes.len() - 1, 20])
            .collect();
        for cut in cuts {
            let r = read_bytes(&bytes[..cut], name, &ReadOptions::default());
            let e = match r {
                Err(e) => e.to_string(),
                // sqlite may still read a database cut in its free pages; it must then be whole.
                Ok(l) => {
                    assert!(name.ends_with(".db3"), "{name} cut at {cut} was read");
                    assert_same_samples(&l.recording, &fx.csv, name);
                    continue;
                }
            };
            assert!(e.starts_with(name), "{name} cut at {cut}: {e}");
            let located = e.contains("byte ") || e.contains("row id") || e.contains("sqlite3 storage");
            assert!(located, "{name} cut at {cut}: {e}");
            if !name.ends_with(".db3") && cut > 100 {
                assert!(
                    e.contains("truncated") || e.contains("runs past"),
                    "{name} cut at {cut}: {e}"
                );
            }
            // A cut leaves every message before it whole: the refusal counts them, and salvage
            // reads exactly those, the first samples of the recording, and says where it stopped.
            let intact = e
                .split("; the ")
                .nth(1)
                .and_then(|rest| rest.split(" messages before it are intact").next())
                .and_then(|n| n.parse::<usize>().ok());
            let salvage = ReadOptions {
                salvage: true,
                ..Default::default()
            };
            match read_bytes(&bytes[..cut], name, &salvage) {
                Ok(l) => {
                    assert!(
                        !name.ends_with(".db3"),
                        "{name}: salvage is for cut MCAP and ROS 1 files"
                    );
                    let r = &l.recording;
                    assert!(intact.is_some_and(|n| n >= r.len()), "{name} cut at {cut}: {e}");
                    let prefix = fx
                        .csv
                        .select(&(0..fx.csv.len()).map(|i| i < r.len()).collect::<Vec<_>>());
                    assert_same_samples(r, &prefix, name);
                    assert!(
                        l.notes.iter().any(|n| n.starts_with("salvaged: ")),
                        "{:?}",
                        l.notes
                    );
                }
                Err(s) => assert!(
                    intact.is_none_or(|n| n < 2) || name.ends_with(".db3"),
                    "{name} cut at {cut}: {e}; salvage: {s}"
                ),
            }
        }
    }
}

#[test]
fn damaged_messages_name_topic_index_and_place() {
    let Some(fx) = fixtures() else { return };
    // ROS 1: the 3rd /imu message's frame_id length made huge.
    let mut bytes = std::fs::read(fx.dir.join("ros1_none.bag")).unwrap();
    let needle = b"\x08\x00\x00\x00imu_link";
    let hits: Vec<usize> = bytes
        .windows(needle.len())
        .enumerate()
        .filter(|(_, w)| *w == needle)
        .map(|(i, _)| i)
        .collect();
    // The first hit may be a /temperature message (the 1st sample writes both); take /imu's 3rd.
    let at = hits[3];
    bytes[at..at + 4].copy_from_slice(&0x7fff_0000u32.to_le_bytes());
    let e = read_bytes(&bytes, "damaged.bag", &ReadOptions::default()).unwrap_err();
    let text = e.to_string();
    match &e {
        FormatError::Bag(BagError::Message { topic, index, at, .. }) => {
            assert_eq!(topic, "/imu", "{text}");
            assert!(*index == 2 || *index == 3, "{text}");
            assert!(at.contains("byte"), "{text}");
        }
        other => panic!("{other}"),
    }
    assert!(text.contains("header.frame_id length"), "{text}");

    // MCAP (rosbags writes no chunk CRC, so the message decoder sees it): the first /imu
    // message's frame_id length changed, located by its record's byte offset in the chunk.
    let mut bytes = std::fs::read(fx.dir.join("mcap/mcap.mcap")).unwrap();
    let needle = b"\x09\x00\x00\x00imu_link\x00";
    let at = bytes.windows(needle.len()).position(|w| w == needle).unwrap();
    bytes[at] = 0x7f;
    let e = read_bytes(&bytes, "damaged.mcap", &ReadOptions::default()).unwrap_err();
    let text = e.to_string();
    match &e {
        FormatError::Bag(BagError::Message {
            topic,
            index,
            at: place,
            ..
        }) => {
            assert_eq!((topic.as_str(), *index), ("/imu", 1), "{text}");
            assert!(place.contains("in the chunk at byte"), "{text}");
            assert!(place.contains(&format!("data at byte {}", at - 12)), "{text}");
        }
        other => panic!("{other}"),
    }
    assert!(text.contains("byte 16 of the message: header.frame_id"), "{text}");
}

/// Inputs the `bag` fuzz target once crashed on (fuzz/regressions/bag): refused, not aborted.
/// crash-c9e2…: a zstd chunk whose decompressed records claim a record of 2⁵⁸ bytes (the `mcap`
/// crate's chunk reader reserved it; chunks are now walked here, lengths checked first).
/// oom-5e82…: a record string (schema, channel or chunk compression) of 4 GB stated length (the
/// `mcap` crate's parser allocated it; string lengths are now checked before it parses).
#[test]
fn fuzz_regressions_are_refused() {
    let dir = Path::new(REPO).join("fuzz/regressions/bag");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let data = std::fs::read(&path).unwrap();
        let (&choice, file) = data.split_first().unwrap();
        let topic = [
            None,
            Some("/imu"),
            Some("/camera/accel/sample,/camera/gyro/sample"),
            Some("/camera/accel/sample"),
        ][usize::from(choice) % 4];
        // Found without salvage; (choice & 0x7f) % 4 is choice % 4, the fuzz target's topic.
        let e = spincal::input::formats::bag::read_bytes(file, "regression.bag", topic, false)
            .map(|_| ())
            .unwrap_err();
        assert!(
            e.to_string().starts_with("regression.bag"),
            "{}: {e}",
            path.display()
        );
    }
}
