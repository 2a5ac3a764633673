use super::*;
use crate::input::formats::{read_path, ReadOptions};

fn short() -> PhoneSetup {
    PhoneSetup {
        poses: 2,
        pose_s: 1.0,
        run_s: 3.0,
        rpm: vec![45.0],
        ..PhoneSetup::default()
    }
}

#[test]
fn same_seed_same_session_and_the_clocks_are_the_phones() {
    let a = simulate_phone(&short(), 5).unwrap();
    let b = simulate_phone(&short(), 5).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, simulate_phone(&short(), 6).unwrap());
    // Two poses, then a run per placement; the placements turned 180° put the chip on opposite
    // sides of the phone's centre, so their radii differ by twice the chip's offset along y.
    assert_eq!(a.recordings.len(), 4);
    let [pa, pb] = [&a.truth.placements[0], &a.truth.placements[1]];
    let dy = a.truth.chip_offset_m[1];
    assert!(
        ((pa.chip_radius_m - pb.chip_radius_m) - 2.0 * dy).abs() < 2e-3,
        "{pa:?} {pb:?}"
    );
    for r in &a.recordings {
        let (accel, gyro) = (&r.accel_mps2.time_s, &r.gyro_radps.time_s);
        // Each sensor on its own jittered clock near its nominal rate.
        let intervals: Vec<f64> = accel.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(intervals.iter().all(|d| *d > 0.0));
        let mean = intervals.iter().sum::<f64>() / intervals.len() as f64;
        assert!((mean * 100.0 - 1.0).abs() < 1e-3, "{mean}");
        assert!(intervals.iter().any(|d| (d - mean).abs() > 1e-4), "no jitter");
        assert!((gyro.len() as f64 / accel.len() as f64 - 2.0).abs() < 0.05);
        assert_ne!(accel[0], gyro[0]);
    }
    // A still pose reads gravity's magnitude within the sensor's errors.
    let pose = &a.recordings[0].accel_mps2.values;
    let norm = (0..3).map(|k| pose[k][0].powi(2)).sum::<f64>().sqrt();
    assert!((norm - STANDARD_GRAVITY).abs() < 0.5, "{norm}");
}

/// The exports read back through the readers a user's files go through, with both sensors, and
/// the campaign file names each of them.
#[test]
fn exports_read_back_as_the_apps_files() {
    let dir = tempfile::tempdir().unwrap();
    for (app, folder) in [(PhoneApp::Phyphox, "phyphox"), (PhoneApp::SensorLogger, "logger")] {
        let setup = PhoneSetup { app, ..short() };
        let session = simulate_phone(&setup, 9).unwrap();
        let path = dir.path().join(folder);
        session.write_folder(&path, false).unwrap();
        // A second write into the same folder is refused, naming a file.
        assert!(matches!(
            session.write_folder(&path, false),
            Err(crate::simulate::fleet::WriteError::Exists { .. })
        ));
        let run = &session.recordings[2];
        let loaded = read_path(&path.join(&run.file), &ReadOptions::default()).unwrap();
        let rec = &loaded.recording;
        // Accelerometer samples outside the gyroscope's span are left out by the pairing; the
        // rest are the written ones, in order.
        let written = &run.accel_mps2.values;
        let n = written[0].len();
        assert!(rec.len() + 2 >= n && rec.len() <= n, "{} of {n}", rec.len());
        let first = (0..=n - rec.len())
            .find(|&i| (0..3).all(|k| (written[k][i] - rec.accel_mps2[k][0]).abs() < 1e-6))
            .expect("the first sample read is a written one");
        for s in [0, rec.len() / 2, rec.len() - 1] {
            for k in 0..3 {
                let w = written[k][first + s];
                assert!((rec.accel_mps2[k][s] - w).abs() < 1e-6 * w.abs().max(1.0));
            }
        }
        // The gyro is interpolated onto the accelerometer's times: the platter's rate on z.
        let gyro = rec.gyro_radps.as_ref().expect("the gyroscope");
        let mid = gyro[2][rec.len() / 2];
        assert!(
            (mid.abs() - 45.0 * 1.01 * std::f64::consts::PI / 30.0).abs() < 0.1,
            "{mid}"
        );
        let campaign = crate::campaign::file::Campaign::read_path(&path.join("campaign.toml")).unwrap();
        assert_eq!(campaign.recordings.len(), session.recordings.len());
        let truth: PhoneTruth =
            serde_json::from_str(&std::fs::read_to_string(path.join("truth.json")).unwrap()).unwrap();
        assert_eq!(truth, session.truth);
    }
}

#[test]
fn a_setup_the_simulation_cannot_run_is_refused_by_name() {
    let bad = [
        PhoneSetup {
            accel_rate_hz: 0.0,
            ..short()
        },
        PhoneSetup {
            jitter_s: 0.01,
            ..short()
        },
        PhoneSetup {
            rpm: Vec::new(),
            ..short()
        },
        PhoneSetup {
            placements: vec![PlacementSetup {
                label: "../A".into(),
                ..PlacementSetup::default()
            }],
            ..short()
        },
    ];
    for (setup, name) in bad
        .iter()
        .zip(["accel_rate_hz", "jitter_s", "rpm", "placements.label"])
    {
        match simulate_phone(setup, 1) {
            Err(SimulationError::Invalid { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: {other:?}"),
        }
    }
}

#[test]
fn phyphox_numbers_and_times_are_written_as_the_app_writes_them() {
    assert_eq!(files::java_scientific(-0.0123456789012), "-1.234567890E-2");
    assert_eq!(files::java_scientific(98.0665), "9.806650000E1");
    assert_eq!(
        files::utc_text(1_795_867_200.25),
        "2026-11-28 12:00:00.250 UTC+00:00"
    );
}
