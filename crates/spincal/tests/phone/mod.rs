//! Phone exports read as the apps write them: phyphox (zip in its five CSV variants, Android's and
//! iOS's names, its Excel workbook, two exports paired by meta/time.csv), Sensor Logger (zip and
//! folder, Android and iOS conventions) and Physics Toolbox; each refusal with its message. The
//! files are written by `writer` from a known motion; one session per format.

// Axis loops index the read and the true values side by side.
#![allow(clippy::needless_range_loop)]

mod campaign;
pub(crate) mod writer;

use spincal::input::formats::phone::{read_pair, PhoneError};
use spincal::input::formats::{detect, read_bytes, read_path, Format, FormatError, Loaded, ReadOptions};
use spincal::input::recording::STANDARD_GRAVITY;
use writer::{App, Motion, VARIANTS};

const ACCEL_HZ: f64 = 200.0;
const GYRO_HZ: f64 = 190.0;
const SAMPLES: usize = 800;

fn accel_times() -> Vec<f64> {
    writer::times(0.0, ACCEL_HZ, SAMPLES)
}

/// Starts before and ends after the accelerometer, on its own clock.
fn gyro_times() -> Vec<f64> {
    writer::times(-0.013, GYRO_HZ, SAMPLES + 20)
}

fn read(bytes: &[u8], file: &str) -> Result<Loaded, FormatError> {
    read_bytes(bytes, file, &ReadOptions::default())
}

/// Time and acceleration as written (`rel` is the text's relative precision; `t0_s` the written
/// time of the recording's zero, for files whose time starts at their first sample), and the
/// gyroscope aligned with the accelerometer within one gyroscope period: its error is below what
/// any axis changes in one period. The same check fails for a gyroscope two periods late.
fn assert_session(l: &Loaded, rel: f64, with_gyro: bool, t0_s: f64) {
    let r = &l.recording;
    assert!(r.len() > SAMPLES * 9 / 10, "{} samples", r.len());
    let written = accel_times();
    let mut k = 0;
    for (i, &t) in r.time_s.iter().enumerate() {
        // Every kept sample is one of the written ones, in order, at its time.
        let t = t + t0_s;
        while k < written.len() && (written[k] - t).abs() > 1e-9 * written[k].abs().max(1.0) {
            k += 1;
        }
        assert!(k < written.len(), "sample {i} at {t} s was not written");
        let a = Motion::accel(written[k]);
        for axis in 0..3 {
            let v = r.accel_mps2[axis][i];
            assert!(
                (v - a[axis]).abs() <= rel * a[axis].abs() + 1e-300,
                "accel {axis} at {t} s: {v} vs {}",
                a[axis]
            );
        }
    }
    let Some(g) = &r.gyro_radps else {
        assert!(!with_gyro, "no gyroscope");
        return;
    };
    assert!(with_gyro);
    let times: Vec<f64> = r.time_s.iter().map(|t| t + t0_s).collect();
    let period = 1.1 / GYRO_HZ;
    let bound = Motion::change_within(Motion::gyro, &times, period);
    let (mut worst, mut worst_late): (f64, f64) = (0.0, 0.0);
    for (i, &t) in times.iter().enumerate() {
        let (w, w_late) = (Motion::gyro(t), Motion::gyro(t + 2.0 * period));
        for axis in 0..3 {
            worst = worst.max((g[axis][i] - w[axis]).abs());
            worst_late = worst_late.max((g[axis][i] - w_late[axis]).abs());
        }
    }
    assert!(
        worst < bound,
        "gyro error {worst} rad/s ≥ one period's change {bound}"
    );
    assert!(
        worst_late > bound,
        "the alignment check cannot fail ({worst_late} vs {bound})"
    );
}

#[test]
fn phyphox_android_zip_in_each_csv_variant_merges_accelerometer_and_gyroscope() {
    for variant in VARIANTS {
        let sets = [
            writer::accelerometer_set(App::Android, &accel_times()),
            writer::gyroscope_set(App::Android, &gyro_times()),
        ];
        let zip = writer::phyphox_zip(App::Android, &sets, variant, 1_796_126_400.0);
        let l = read(&zip, "Turntable 2026-11-28.zip").unwrap_or_else(|e| panic!("{variant:?}: {e}"));
        assert_eq!(l.format, Format::PhyphoxZip);
        let reason = &l.detection.as_ref().unwrap().reason;
        assert!(
            reason.contains("meta/time.csv") && reason.contains("Accelerometer.csv"),
            "{reason}"
        );
        assert_eq!(l.recording.source.format, "phyphox-zip");
        assert_eq!(
            l.recording.source.columns,
            [
                "Time (s)",
                "Acceleration x (m/s^2)",
                "Acceleration y (m/s^2)",
                "Acceleration z (m/s^2)",
                "Gyroscope x (rad/s)",
                "Gyroscope y (rad/s)",
                "Gyroscope z (rad/s)"
            ]
        );
        // 10 significant digits.
        assert_session(&l, 1e-9, true, 0.0);
        assert_eq!(
            l.notes.iter().any(|n| n == "decimal comma converted"),
            variant.decimal == ',',
            "{variant:?}: {:?}",
            l.notes
        );
        assert!(
            l.notes.iter().any(|n| n.contains("interpolated linearly")),
            "{:?}",
            l.notes
        );
    }
}

#[test]
fn phyphox_ios_zip_reads_its_names_and_refuses_its_fused_gyroscope() {
    let variant = VARIANTS[4];
    let accel = writer::accelerometer_set(App::Ios, &accel_times());
    let zip = writer::phyphox_zip(App::Ios, std::slice::from_ref(&accel), variant, 1_796_126_400.0);
    let l = read(&zip, "ios.zip").unwrap();
    assert_eq!(l.format, Format::PhyphoxZip);
    assert_eq!(l.recording.source.columns[1], "X (m/s^2)");
    assert_session(&l, 1e-9, false, 0.0);
    assert!(l.notes.iter().any(|n| n.contains("−9.81")), "{:?}", l.notes);

    let sets = [accel, writer::gyroscope_set(App::Ios, &gyro_times())];
    let zip = writer::phyphox_zip(App::Ios, &sets, variant, 1_796_126_400.0);
    let e = read(&zip, "ios.zip").unwrap_err();
    assert!(
        matches!(&e, FormatError::Phone(PhoneError::FusedRotationRate { file, .. }) if file == "ios.zip/Gyroscope.csv"),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        "ios.zip/Gyroscope.csv: phyphox's iOS gyroscope is iOS's fused rotation rate (Core Motion's device motion, its bias removed by the attitude filter), not the gyroscope's own output; calibrate the accelerometer from an export without the gyroscope set, or record the raw gyroscope with Sensor Logger's Gyroscope Uncalibrated"
    );
}

#[test]
fn phyphox_built_in_experiment_zip_and_csv() {
    let set = writer::raw_data_set(&accel_times());
    let zip = writer::phyphox_zip(
        App::Android,
        std::slice::from_ref(&set),
        VARIANTS[0],
        1_796_126_400.0,
    );
    let l = read(&zip, "Acceleration with g.zip").unwrap();
    assert_eq!(l.format, Format::PhyphoxZip);
    assert_session(&l, 1e-9, false, 0.0);
    // The same set as a single CSV, and with iOS's names.
    for (app, s) in [
        (App::Android, set),
        (App::Ios, writer::accelerometer_set(App::Ios, &accel_times())),
    ] {
        let csv = writer::phyphox_csv(app, &s, VARIANTS[3]);
        assert_eq!(detect(&csv).format, Format::Phyphox);
        let l = read(&csv, "Raw Data.csv").unwrap();
        assert_eq!(l.format, Format::Phyphox);
        assert_session(&l, 1e-9, false, 0.0);
    }
}

#[test]
fn phyphox_excel_workbook_reads_through_calamine() {
    let sets = [
        writer::accelerometer_set(App::Android, &accel_times()),
        writer::gyroscope_set(App::Android, &gyro_times()),
    ];
    let xlsx = writer::phyphox_xlsx(&sets, 1_796_126_400.0);
    assert_eq!(detect(&xlsx).format, Format::PhyphoxExcel);
    let l = read(&xlsx, "run.xlsx").unwrap();
    assert_eq!(l.format, Format::PhyphoxExcel);
    assert_eq!(l.recording.source.format, "phyphox-excel");
    // Number cells: the values themselves.
    assert_session(&l, 1e-15, true, 0.0);
}

#[test]
fn two_phyphox_zips_pair_only_when_meta_time_overlaps() {
    let dir = tempfile::tempdir().unwrap();
    let start = 1_796_126_400.0;
    let accel = writer::accelerometer_set(App::Android, &accel_times());
    let accel_zip = dir.path().join("accel.zip");
    std::fs::write(
        &accel_zip,
        writer::phyphox_zip(App::Android, &[accel], VARIANTS[0], start),
    )
    .unwrap();
    // The gyroscope's export is of its own experiment, started `delay` s after the
    // accelerometer's; `behind` s of that delay show in its experiment time.
    let gyro = |delay: f64, behind: f64| {
        let mut s = writer::gyroscope_set(App::Android, &gyro_times());
        for row in &mut s.rows {
            row[0] -= behind;
        }
        writer::phyphox_zip(App::Android, &[s], VARIANTS[2], start + delay)
    };
    let gyro_zip = dir.path().join("gyro.zip");
    std::fs::write(&gyro_zip, gyro(1.5, 1.5)).unwrap();
    let l = read_pair(&accel_zip, &gyro_zip, &ReadOptions::default()).unwrap();
    assert_session(&l, 1e-9, true, 0.0);
    assert!(
        l.notes.iter().any(|n| n.contains("meta/time.csv")),
        "{:?}",
        l.notes
    );

    // A gyroscope recorded an hour later is not of this session.
    std::fs::write(&gyro_zip, gyro(3600.0, 0.0)).unwrap();
    let Err(e) = read_pair(&accel_zip, &gyro_zip, &ReadOptions::default()) else {
        panic!("an hour apart, yet paired");
    };
    assert!(
        matches!(&e, FormatError::Phone(PhoneError::NoOverlap { .. })),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.contains("accel.zip")
            && text.contains("gyro.zip")
            && text.contains("do not overlap in time by their meta/time.csv"),
        "{text}"
    );
}

#[test]
fn gravity_removed_and_centripetal_exports_are_refused_by_name() {
    let times = accel_times();
    for (app, file) in [
        (App::Android, "lin.zip/Linear Acceleration.csv"),
        (App::Ios, "lin.zip/Linear Accelerometer.csv"),
    ] {
        let zip = writer::phyphox_zip(app, &[writer::linear_set(app, &times)], VARIANTS[0], 0.0);
        let e = read(&zip, "lin.zip").unwrap_err();
        assert!(
            matches!(&e, FormatError::Phone(PhoneError::GravityRemoved { file: f, .. }) if f == file),
            "{e}"
        );
        assert!(e.to_string().contains("\"Acceleration with g\""), "{e}");
    }
    // With an accelerometer beside it, the linear set is not needed and not refused.
    let zip = writer::phyphox_zip(
        App::Android,
        &[
            writer::linear_set(App::Android, &times),
            writer::accelerometer_set(App::Android, &times),
        ],
        VARIANTS[0],
        0.0,
    );
    assert_eq!(read(&zip, "both.zip").unwrap().recording.len(), SAMPLES);

    let csv = writer::phyphox_csv(
        App::Android,
        &writer::linear_set(App::Android, &times),
        VARIANTS[3],
    );
    let e = read(&csv, "Raw Data.csv").unwrap_err();
    assert_eq!(
        e.to_string(),
        "Raw Data.csv: phyphox's \"Raw Data\" set has gravity removed (the phone's own estimate subtracted), so it cannot calibrate an accelerometer; use the \"Acceleration with g\" experiment, or the Accelerometer sensor of a simple experiment"
    );

    let csv = writer::phyphox_csv(App::Android, &writer::centripetal_set(20), VARIANTS[0]);
    let e = read(&csv, "Data.csv").unwrap_err();
    assert!(
        matches!(&e, FormatError::Phone(PhoneError::Centripetal { file }) if file == "Data.csv"),
        "{e}"
    );
    assert!(e.to_string().contains("2 Hz averages"), "{e}");
}

fn sensor_logger_files(platform: &str, standardised: bool) -> Vec<(String, Vec<u8>)> {
    let epoch0: i64 = 1_796_126_400_123_456_789;
    let ios_raw = platform == "ios" && !standardised;
    let mut files = vec![(
        "Metadata.csv".to_string(),
        writer::sensor_logger_metadata(platform, standardised),
    )];
    let accel_file = if platform == "ios" {
        "AccelerometerUncalibrated.csv"
    } else {
        "TotalAcceleration.csv"
    };
    files.push((
        accel_file.into(),
        writer::sensor_logger_csv(epoch0, epoch0 - 250_000_000, &accel_times(), move |t| {
            // iOS without standardisation: g, and iOS's sign (UNITS.md, CROSSPLATFORM.md).
            Motion::accel(t).map(|v| if ios_raw { -v / STANDARD_GRAVITY } else { v })
        }),
    ));
    files.push((
        "Gyroscope.csv".into(),
        writer::sensor_logger_csv(epoch0, epoch0 - 250_000_000, &gyro_times(), Motion::gyro),
    ));
    // Gravity removed: present in the export, never used.
    files.push((
        "Accelerometer.csv".into(),
        writer::sensor_logger_csv(epoch0, epoch0 - 250_000_000, &accel_times(), |t| {
            let a = Motion::accel(t);
            [a[0], a[1], a[2] - STANDARD_GRAVITY]
        }),
    ));
    files
}

#[test]
fn sensor_logger_zip_and_folder_on_android_and_ios() {
    for (platform, standardised) in [("android", false), ("ios", false), ("ios", true)] {
        let files = sensor_logger_files(platform, standardised);
        let zip = writer::zip(&files);
        let l = read(&zip, "2026-11-28_12-00-00.zip").unwrap_or_else(|e| panic!("{platform}: {e}"));
        assert_eq!(l.format, Format::SensorLogger, "{platform}");
        assert!(l.detection.as_ref().unwrap().reason.contains("Metadata.csv"));
        // Shortest round-trip decimals; time from its first sample, exact to the nanosecond.
        let written = accel_times();
        assert_session(&l, 1e-15, true, written[0]);
        let ns = |w: f64| (w * 1e9).round() as i64;
        for (k, &w) in written.iter().enumerate() {
            let exact = (ns(w) - ns(written[0])) as f64 * 1e-9;
            assert_eq!(l.recording.time_s[k], exact, "sample {k}");
        }

        let dir = tempfile::tempdir().unwrap();
        for (name, bytes) in &files {
            std::fs::write(dir.path().join(name), bytes).unwrap();
        }
        let from_dir = read_path(dir.path(), &ReadOptions::default()).unwrap();
        assert_eq!(from_dir.format, Format::SensorLogger);
        assert_eq!(from_dir.recording.accel_mps2, l.recording.accel_mps2);
        assert_eq!(from_dir.recording.gyro_radps, l.recording.gyro_radps);
    }

    // Only the gravity-removed file: refused, pointing to the one to use.
    let files: Vec<_> = sensor_logger_files("android", false)
        .into_iter()
        .filter(|(n, _)| n != "TotalAcceleration.csv")
        .collect();
    let e = read(&writer::zip(&files), "s.zip").unwrap_err();
    assert!(
        matches!(&e, FormatError::Phone(PhoneError::GravityRemoved { file, .. }) if file == "s.zip/Accelerometer.csv"),
        "{e}"
    );
    assert!(e.to_string().contains("use TotalAcceleration.csv"), "{e}");
}

#[test]
fn physics_toolbox_csv_with_decimal_comma_and_unicode_minus() {
    let csv = writer::physics_toolbox_csv(&accel_times(), true);
    assert!(csv.starts_with(b"\ntime;gFx"));
    assert_eq!(detect(&csv).format, Format::PhysicsToolbox);
    let l = read(&csv, "Physics Toolbox.csv").unwrap();
    assert_eq!(l.format, Format::PhysicsToolbox);
    // Six decimals of g, six of rad/s, written with U+2212.
    let r = &l.recording;
    for i in 0..r.len() {
        let (a, w) = (Motion::accel(r.time_s[i]), Motion::gyro(r.time_s[i]));
        for k in 0..3 {
            assert!(
                (r.accel_mps2[k][i] - a[k]).abs() < 1e-5,
                "{} vs {}",
                r.accel_mps2[k][i],
                a[k]
            );
            assert!((r.gyro_radps.as_ref().unwrap()[k][i] - w[k]).abs() < 1e-6);
        }
    }
    assert!(
        r.accel_mps2[0].iter().any(|v| *v < 0.0),
        "the minus signs were read"
    );

    let linear = "\ntime;ax;ay;az;aT\n0,01;0,1;\u{2212}0,2;0,3;0,4\n0,02;0,1;0,2;0,3;0,4\n";
    let e = read(linear.as_bytes(), "lin.csv").unwrap_err();
    assert!(
        matches!(
            &e,
            FormatError::Phone(PhoneError::GravityRemoved {
                app: "Physics Toolbox",
                ..
            })
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .starts_with("lin.csv: Physics Toolbox's Linear Accelerometer"),
        "{e}"
    );
}
