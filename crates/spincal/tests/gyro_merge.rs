//! Two files, one recording (issue 48 item 2): an accelerometer and a gyroscope logged on their own
//! jittered clocks at different rates, merged on time by the one rule, read whole
//! (`attach_gyro_file`) and inside `correct`'s stream. The merged gyro lies within linear
//! interpolation's error over one gyro interval (h²/8 · max|ω''|) of the true rate; the rows
//! outside the gyro's span or in its gap are the ones the direct rule names; under half overlap
//! is refused naming both spans.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use spincal::correctors::gyro::GyroModel;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};
use spincal::correctors::static_cal::StaticCalibration;
use spincal::correctors::stream::{correct_to_path, correct_to_writer, CorrectError};
use spincal::input::formats::{read_path, ReadOptions};
use spincal::input::gyro_file::{attach_gyro_file, GyroFileError, GYRO_GAP_INTERVALS};

/// The true rate, rad/s: (amplitude, frequency Hz, phase) per axis, plus an offset on z.
const AXES: [(f64, f64, f64); 3] = [(0.8, 0.7, 0.0), (0.3, 1.3, 0.4), (0.2, 0.2, 1.0)];

fn truth(t: f64) -> [f64; 3] {
    std::array::from_fn(|a| {
        let (amplitude, f, phase) = AXES[a];
        amplitude * (TAU * f * t + phase).sin() + if a == 2 { 0.1 } else { 0.0 }
    })
}

/// Times at `rate_hz` from `from_s` to `to_s`, each moved by up to ±`jitter_s`, none in `gap`.
fn clock(
    rng: &mut ChaCha8Rng,
    rate_hz: f64,
    from_s: f64,
    to_s: f64,
    jitter_s: f64,
    gap: Option<(f64, f64)>,
) -> Vec<f64> {
    let n = ((to_s - from_s) * rate_hz) as usize;
    (0..=n)
        .map(|i| from_s + i as f64 / rate_hz + rng.gen_range(-jitter_s..jitter_s))
        .filter(|t| gap.is_none_or(|(a, b)| *t <= a || *t >= b))
        .collect()
}

struct Session {
    _dir: tempfile::TempDir,
    accel: PathBuf,
    gyro: PathBuf,
    accel_t: Vec<f64>,
    gyro_t: Vec<f64>,
}

/// An accelerometer at 100 Hz (±2 ms jitter) over 0–20 s beside a gyro at 190 Hz (±1 ms) over
/// `gyro_from_s`–`gyro_to_s` with a dropped stretch at 10.0–10.5 s.
fn session(seed: u64, gyro_from_s: f64, gyro_to_s: f64) -> Session {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let accel_t = clock(&mut rng, 100.0, 0.0, 20.0, 0.002, None);
    let gyro_t = clock(&mut rng, 190.0, gyro_from_s, gyro_to_s, 0.001, Some((10.0, 10.5)));
    let dir = tempfile::tempdir().unwrap();
    let accel = dir.path().join("accel.csv");
    let rows: String = accel_t
        .iter()
        .map(|t| format!("{t:.6},0.01,-0.02,9.81\n"))
        .collect();
    std::fs::write(&accel, format!("t,ax,ay,az\n{rows}")).unwrap();
    // imu_tk's layout: `t gx gy gz`, whitespace, no header.
    let gyro = dir.path().join("gyro.txt");
    let rows: String = gyro_t
        .iter()
        .map(|&t| {
            let w = truth(t);
            format!("{t:.6} {:.10} {:.10} {:.10}\n", w[0], w[1], w[2])
        })
        .collect();
    std::fs::write(&gyro, rows).unwrap();
    Session {
        _dir: dir,
        accel,
        gyro,
        accel_t,
        gyro_t,
    }
}

/// The direct rule: covered when inside the gyro's span and its two samples around are no more
/// than GYRO_GAP_INTERVALS median intervals apart (times as written: 6 decimals).
fn covered(accel_t: &[f64], gyro_t: &[f64]) -> Vec<bool> {
    let round = |t: f64| format!("{t:.6}").parse::<f64>().unwrap();
    let g: Vec<f64> = gyro_t.iter().map(|t| round(*t)).collect();
    let mut steps: Vec<f64> = g.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let widest = GYRO_GAP_INTERVALS * steps[steps.len() / 2];
    accel_t
        .iter()
        .map(|&t| {
            let t = round(t);
            let j = g.partition_point(|&x| x < t);
            j < g.len() && (g[j] == t || (j > 0 && g[j] - g[j - 1] <= widest * 1.05))
        })
        .collect()
}

/// Linear interpolation's error bound over the widest gyro interval kept, per axis, plus the
/// files' rounding.
fn bound(gyro_t: &[f64]) -> [f64; 3] {
    let h = gyro_t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d < 0.1)
        .fold(0.0, f64::max);
    std::array::from_fn(|a| {
        let (amplitude, f, _) = AXES[a];
        h * h / 8.0 * amplitude * (TAU * f).powi(2) + 1e-6
    })
}

#[test]
fn a_gyro_on_its_own_clock_is_merged_within_interpolation_error_and_the_uncovered_rows_named() {
    let s = session(7, 2.0, 17.0);
    let expected = covered(&s.accel_t, &s.gyro_t);
    let outside = expected.iter().filter(|c| !**c).count();
    assert!(outside > 450 && outside < 600, "{outside}");
    let bound = bound(&s.gyro_t);
    let mut loaded = read_path(&s.accel, &ReadOptions::default()).unwrap();
    let note = attach_gyro_file(&mut loaded, &s.gyro, &ReadOptions::default()).unwrap();
    let rec = &loaded.recording;
    assert_eq!(rec.len(), s.accel_t.len() - outside);
    assert!(note
        .unwrap()
        .contains(&format!("{outside} samples outside its span")));
    let gyro = rec.gyro_radps.as_ref().unwrap();
    let kept: Vec<f64> = (s.accel_t.iter().zip(&expected))
        .filter(|(_, c)| **c)
        .map(|(t, _)| format!("{t:.6}").parse().unwrap())
        .collect();
    assert_eq!(rec.time_s, kept, "the samples kept are the covered ones");
    for (i, &t) in rec.time_s.iter().enumerate() {
        let w = truth(t);
        for a in 0..3 {
            assert!(
                (gyro[a][i] - w[a]).abs() <= bound[a],
                "t {t} axis {a}: {} vs {}",
                gyro[a][i],
                w[a]
            );
        }
    }
}

/// A static calibration that removes nothing, with a gyro calibration that removes 0.01 rad/s on x.
fn model() -> CorrectorFile {
    let mut file = CorrectorFile::new(CorrectorModel::Static(Box::new(StaticCalibration::identity(
        9.81,
    ))));
    let mut gyro = GyroModel::IDEAL;
    gyro.bias_radps = [0.01, 0.0, 0.0];
    file.gyro = Some(gyro);
    file
}

fn column(header: &[&str], name: &str) -> usize {
    header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("{name} in {header:?}"))
}

#[test]
fn the_stream_merges_on_time_and_writes_every_row_marking_those_outside_the_gyro() {
    let s = session(11, 2.0, 17.0);
    let expected = covered(&s.accel_t, &s.gyro_t);
    let bound = bound(&s.gyro_t);
    let mut out = Vec::new();
    let summary = correct_to_writer(
        &model(),
        &s.accel,
        &ReadOptions::default(),
        Some(&s.gyro),
        &mut out,
    )
    .unwrap();
    let text = String::from_utf8(out).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let (gx, gz, valid, status) = (
        column(&header, "gx_corrected_radps"),
        column(&header, "gz_corrected_radps"),
        column(&header, "valid"),
        column(&header, "status"),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.splitn(header.len(), ',').collect()).collect();
    assert_eq!(rows.len(), s.accel_t.len(), "every input row is written");
    assert_eq!(summary.rows, s.accel_t.len());
    assert_eq!(summary.no_gyro, expected.iter().filter(|c| !**c).count());
    let (mut before, mut gap, mut after) = (0, 0, 0);
    for (k, (row, covered)) in rows.iter().zip(&expected).enumerate() {
        let t: f64 = row[0].parse().unwrap();
        if *covered {
            let w = truth(t);
            let x: f64 = row[gx].parse().unwrap();
            let z: f64 = row[gz].parse().unwrap();
            assert!((x - (w[0] - 0.01)).abs() <= bound[0], "row {k} t {t}: {x}");
            assert!((z - w[2]).abs() <= bound[2], "row {k} t {t}: {z}");
            assert_eq!((row[valid], row[status]), ("1", "ok"), "row {k}");
        } else {
            // The accelerometer corrected, the gyro empty, the reason named with the line.
            assert!(row[column(&header, "ax_corrected_mps2")].parse::<f64>().is_ok());
            assert_eq!((row[gx], row[valid]), ("", "0"), "row {k}");
            // Quoted: the reason holds the separator.
            let why = row[status].trim_matches('"');
            assert!(why.starts_with(&format!("no-gyro: line {}, ", k + 2)), "{why}");
            before += usize::from(why.contains("before the gyro's first sample"));
            gap += usize::from(
                why.contains("in a gap of the gyro (10.0") || why.contains("in a gap of the gyro (9.99"),
            );
            after += usize::from(why.contains("after the gyro's last sample"));
        }
    }
    assert!(before > 150 && gap > 30 && after > 250, "{before} {gap} {after}");
    assert_eq!(before + gap + after, summary.no_gyro);
    assert!(summary
        .warnings()
        .iter()
        .any(|w| w.contains("outside the gyro file's span")));
    assert!(summary
        .notes
        .iter()
        .any(|n| n.contains("interpolated linearly onto the input's")));

    // The file read whole (a scale makes it so) gives the same gyro values by the same rule.
    let whole = ReadOptions {
        accel_scale: Some(1.0),
        ..Default::default()
    };
    let mut out = Vec::new();
    let summary_whole = correct_to_writer(&model(), &s.accel, &whole, Some(&s.gyro), &mut out).unwrap();
    assert_eq!(summary_whole.no_gyro, summary.no_gyro);
    let text_whole = String::from_utf8(out).unwrap();
    let header_whole: Vec<&str> = text_whole.lines().next().unwrap().split(',').collect();
    let gx_whole = column(&header_whole, "gx_corrected_radps");
    for (a, b) in text.lines().skip(1).zip(text_whole.lines().skip(1)) {
        let (a, b): (Vec<&str>, Vec<&str>) = (a.split(',').collect(), b.split(',').collect());
        assert_eq!(a[gx], b[gx_whole]);
    }
}

fn checksum(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

#[test]
fn under_half_overlap_is_refused_naming_both_spans() {
    // The gyro covers 14–25 s of a 0–20 s recording: under half.
    let s = session(3, 14.0, 25.0);
    let (accel_before, gyro_before) = (checksum(&s.accel), checksum(&s.gyro));
    // Both spans as written (6 decimals), shown to the millisecond.
    let shown = |t: &[f64]| {
        let r = |t: f64| format!("{t:.6}").parse::<f64>().unwrap();
        format!("{:.3}–{:.3} s", r(t[0]), r(t[t.len() - 1]))
    };
    let (gyro_span, accel_span) = (shown(&s.gyro_t), shown(&s.accel_t));
    let spans = |e: &dyn std::fmt::Display| {
        let m = e.to_string();
        assert!(m.contains("gyro.txt"), "{m}");
        assert!(
            m.contains(&format!("the gyro file's span ({gyro_span}")),
            "{m} / {gyro_span}"
        );
        assert!(
            m.contains(&format!("the recording's {accel_span}")),
            "{m} / {accel_span}"
        );
    };
    let mut loaded = read_path(&s.accel, &ReadOptions::default()).unwrap();
    let e = attach_gyro_file(&mut loaded, &s.gyro, &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, GyroFileError::NoOverlap { .. }));
    spans(&e);
    // The stream refuses it too, and a file output is not written.
    let output = s.accel.with_file_name("corrected.csv");
    let e = correct_to_path(
        &model(),
        &s.accel,
        &ReadOptions::default(),
        Some(&s.gyro),
        &output,
    )
    .unwrap_err();
    assert!(
        matches!(&e, CorrectError::Gyro(g) if matches!(**g, GyroFileError::NoOverlap { .. })),
        "{e}"
    );
    spans(&e);
    assert!(!output.exists());
    assert_eq!(
        (checksum(&s.accel), checksum(&s.gyro)),
        (accel_before, gyro_before)
    );
}
