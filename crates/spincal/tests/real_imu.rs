//! Evidence on measured recordings nobody here wrote (../shared/data/imu; skipped when absent):
//! static calibration against each source's own published calibration.

// Axis loops index several parallel per-axis arrays at once.
#![allow(clippy::needless_range_loop)]

use crate::common;

use spincal::correctors::static_cal::{fit_static, pose_means, spread_about, StaticFitOptions, StaticModel};
use spincal::correctors::static_detect::{detect_static, labelled_intervals, StaticOptions, StillInterval};
use spincal::input::formats::{read_path, Format, Loaded, ReadOptions};

fn load(relative: &str, format: Format) -> Option<Loaded> {
    let path = common::shared_data(relative)?;
    let options = ReadOptions {
        format: Some(format),
        ..Default::default()
    };
    Some(read_path(&path, &options).unwrap())
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// RMS of |f(raw)| − g over every sample of every interval.
fn sample_spread(
    loaded: &Loaded,
    intervals: &[StillInterval],
    g: f64,
    f: impl Fn([f64; 3]) -> [f64; 3],
) -> f64 {
    let a = &loaded.recording.accel_mps2;
    let norms: Vec<f64> = intervals
        .iter()
        .flat_map(|iv| iv.start..iv.end)
        .map(|i| norm(f([a[0][i], a[1][i], a[2][i]])))
        .collect();
    spread_about(&norms, g)
}

/// RMS of |f(pose mean)| − g over the intervals.
fn pose_spread(intervals: &[StillInterval], g: f64, f: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
    let norms: Vec<f64> = intervals.iter().map(|iv| norm(f(iv.mean))).collect();
    spread_about(&norms, g)
}

fn matvec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

fn inverse(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    [
        [c(1, 1, 2, 2) / det, -c(0, 1, 2, 2) / det, c(0, 1, 1, 2) / det],
        [-c(1, 0, 2, 2) / det, c(0, 0, 2, 2) / det, -c(0, 0, 1, 2) / det],
        [c(1, 0, 2, 1) / det, -c(0, 0, 2, 1) / det, c(0, 0, 1, 1) / det],
    ]
}

fn json_matrix(v: &serde_json::Value) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| v[r][c].as_f64().unwrap()))
}

#[test]
fn imucal_six_poses_match_imucal_own_calibration() {
    let Some(loaded) = load("imu/imucal/annotated_session.csv", Format::Imucal) else {
        return;
    };
    let Some(cal_path) = common::shared_data("imu/imucal/example_cal.json") else {
        return;
    };
    let reference: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cal_path).unwrap()).unwrap();
    let k = json_matrix(&reference["K_a"]);
    let r = json_matrix(&reference["R_a"]);
    let b: [f64; 3] = std::array::from_fn(|i| reference["b_a"][i].as_f64().unwrap());
    let (k_inv, r_inv) = (inverse(&k), inverse(&r));
    // imucal's README: acc = R_a⁻¹ K_a⁻¹ (raw − b_a), m/s².
    let imucal = |raw: [f64; 3]| matvec(&r_inv, matvec(&k_inv, std::array::from_fn(|i| raw[i] - b[i])));

    let rec = &loaded.recording;
    let labels = loaded.labels.as_ref().unwrap();
    let intervals = labelled_intervals(&rec.time_s, &rec.accel_mps2, labels, |l| !l.contains("rot"));
    assert_eq!(intervals.len(), 6);
    let g = 9.81;
    // Six poses fix six parameters: the 6-parameter model (misalignment is unobservable from norms
    // of axis-aligned poses; imucal gets it from the known pose directions instead).
    let options = StaticFitOptions {
        model: StaticModel::BiasScale,
        gravity_mps2: g,
        input_unit: "counts".into(),
    };
    let fit = fit_static(&pose_means(&intervals), &options).unwrap();
    let ours = |raw: [f64; 3]| fit.calibration.apply(&raw);
    let (pose_ours, pose_ref) = (
        pose_spread(&intervals, g, ours),
        pose_spread(&intervals, g, imucal),
    );
    let (all_ours, all_ref) = (
        sample_spread(&loaded, &intervals, g, ours),
        sample_spread(&loaded, &intervals, g, imucal),
    );
    eprintln!("imucal: pose-mean RMS |a|−g ours {pose_ours:.2e} vs imucal {pose_ref:.2e}; per-sample ours {all_ours:.4} vs imucal {all_ref:.4} m/s²");
    assert!(pose_ours <= pose_ref, "{pose_ours} > {pose_ref}");
    assert!(all_ours <= all_ref, "{all_ours} > {all_ref}");
    for i in 0..3 {
        let rel = (1.0 / fit.calibration.scale[i]) / k[i][i] - 1.0;
        eprintln!(
            "imucal: axis {i}: 1/scale {:.3} vs K_a {:.3} counts per m/s² ({:+.3} %)",
            1.0 / fit.calibration.scale[i],
            k[i][i],
            100.0 * rel
        );
        assert!(rel.abs() < 0.01);
    }
}

#[test]
fn xsens_still_intervals_found_and_calibration_beats_factory_values() {
    let Some(loaded) = load("imu/imu_tk_xsens/xsens_acc.mat", Format::Whitespace) else {
        return;
    };
    assert!(loaded.raw_counts);
    let rec = &loaded.recording;
    let detection = detect_static(&rec.time_s, &rec.accel_mps2, &StaticOptions::default()).unwrap();
    let intervals = &detection.intervals;
    // The recording: ~50 s still, then many poses joined by rotations.
    assert!(intervals.len() >= 30, "{} intervals", intervals.len());
    assert!(intervals[0].t_end_s - intervals[0].t_start_s > 40.0);
    let g = 9.81744;
    let options = StaticFitOptions {
        model: StaticModel::Misalignment,
        gravity_mps2: g,
        input_unit: "counts".into(),
    };
    let fit = fit_static(&pose_means(intervals), &options).unwrap();
    let ours = |raw: [f64; 3]| fit.calibration.apply(&raw);
    // Factory values from the data README: offset [33123 33276 32360] counts, 415/413/415 counts per m/s².
    let (off, k) = ([33123.0, 33276.0, 32360.0], [415.0, 413.0, 415.0]);
    let factory = |raw: [f64; 3]| std::array::from_fn(|i| (raw[i] - off[i]) / k[i]);
    let (pose_ours, pose_fac) = (
        pose_spread(intervals, g, ours),
        pose_spread(intervals, g, factory),
    );
    let (all_ours, all_fac) = (
        sample_spread(&loaded, intervals, g, ours),
        sample_spread(&loaded, intervals, g, factory),
    );
    eprintln!(
        "xsens: {} intervals; pose-mean RMS |a|−g ours {pose_ours:.5} vs factory {pose_fac:.5}; per-sample ours {all_ours:.5} vs factory {all_fac:.5} m/s²",
        intervals.len()
    );
    assert!(pose_ours < pose_fac);
    assert!(all_ours < all_fac);
}

#[test]
fn mpu6050_calibration_beats_the_authors_parameters() {
    let Some(loaded) = load("imu/mpu6050/example_data_calibration.csv", Format::Mpu6050) else {
        return;
    };
    let Some(params_path) = common::shared_data("imu/mpu6050/params_acc.csv") else {
        return;
    };
    let p: Vec<f64> = std::fs::read_to_string(params_path)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    // Their model: a = T K (raw + b), T = [[1, −m_yz, m_zy], [0, 1, −m_zx], [0, 0, 1]], K = diag(s).
    let t = [[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]];
    let authors = |raw: [f64; 3]| matvec(&t, std::array::from_fn(|i| p[3 + i] * (raw[i] + p[6 + i])));
    let rec = &loaded.recording;
    let detect = StaticOptions {
        threshold_factor: 5.0,
        ..Default::default()
    };
    let intervals = detect_static(&rec.time_s, &rec.accel_mps2, &detect)
        .unwrap()
        .intervals;
    assert_eq!(intervals.len(), 10, "the authors list 10 still intervals");
    let g = 9.81;
    // 10 poses: the 6-parameter model is well over-determined; the 9-parameter one has 1 residual
    // degree of freedom (its α_yz is poorly determined on these poses), so both are checked.
    for model in [StaticModel::BiasScale, StaticModel::Misalignment] {
        let options = StaticFitOptions {
            model,
            gravity_mps2: g,
            input_unit: "counts".into(),
        };
        let fit = fit_static(&pose_means(&intervals), &options).unwrap();
        let ours = |raw: [f64; 3]| fit.calibration.apply(&raw);
        let (pose_ours, pose_auth) = (
            pose_spread(&intervals, g, ours),
            pose_spread(&intervals, g, authors),
        );
        let (all_ours, all_auth) = (
            sample_spread(&loaded, &intervals, g, ours),
            sample_spread(&loaded, &intervals, g, authors),
        );
        eprintln!("mpu6050 {model:?}: pose-mean RMS |a|−g ours {pose_ours:.5} vs authors {pose_auth:.5}; per-sample ours {all_ours:.5} vs authors {all_auth:.5} m/s²; param std {:?}", fit.param_std);
        for i in 0..3 {
            let rel = fit.calibration.scale[i] / p[3 + i] - 1.0;
            eprintln!(
                "mpu6050 {model:?}: axis {i} scale {:+.3} % vs authors, bias {:.1} vs {:.1} counts",
                100.0 * rel,
                fit.calibration.bias[i],
                -p[6 + i]
            );
        }
        assert!(pose_ours < pose_auth);
        assert!(all_ours <= all_auth);
    }
}

/// The RealSense T265 log stamps samples to 10 ms at about 200 Hz, so half the stamps repeat the
/// previous one: every sample is read, the rate comes from all the stamps, and the repeats are
/// reported with the first line.
#[test]
fn t265_log_with_repeated_timestamps_reads_whole_at_its_true_rate() {
    let Some(loaded) = load("imu/realsense_t265/t265_acc.mat", Format::Whitespace) else {
        return;
    };
    let rec = &loaded.recording;
    let path = common::shared_data("imu/realsense_t265/t265_acc.mat").unwrap();
    let lines = std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .count();
    assert_eq!(rec.len(), lines);
    let mean_rate = (rec.len() - 1) as f64 / rec.duration_s();
    assert!(
        (rec.sample_rate_hz() / mean_rate - 1.0).abs() < 0.01,
        "{} Hz against {mean_rate} Hz from the span",
        rec.sample_rate_hz()
    );
    let inspection = spincal::input::inspect::inspect(rec, None);
    assert!(inspection.repeated_times > rec.len() / 3, "{inspection:?}");
    assert_eq!(inspection.first_repeated_line, Some(3));
    assert_eq!(inspection.backward_steps, 0);
    assert_eq!(
        inspection.gap_count, 0,
        "10 ms steps at 5 ms are the clock's tick, not gaps"
    );
    // Re-timed: evenly spaced at that rate, no repeats; the span stays within 0.1 % (the few
    // longer steps of the log are evened out).
    let options = ReadOptions {
        format: Some(Format::Whitespace),
        retime: true,
        ..Default::default()
    };
    let path = common::shared_data("imu/realsense_t265/t265_acc.mat").unwrap();
    let retimed = read_path(&path, &options).unwrap().recording;
    let again = spincal::input::inspect::inspect(&retimed, None);
    assert_eq!((again.repeated_times, again.gap_count), (0, 0));
    assert!((retimed.duration_s() / rec.duration_s() - 1.0).abs() < 1e-3);
}
