//! The gyroscope from still poses and rotations (`correctors::gyro_poses`): it recovers what the
//! simulator put in, in rad/s and in raw counts; it agrees with imu_tk on the T265 recording; and
//! it refuses bad input by name.

// 3×3 comparisons read best with indices.
#![allow(clippy::needless_range_loop)]

use crate::common;

use spincal::correctors::gyro::{GyroInputUnit, GyroModel};
use spincal::correctors::gyro_poses::{
    fit_gyro_poses, still_poses, GyroBiasSource, GyroPoseError, GyroPoseFit, GyroPoseOptions, StillPose,
};
use spincal::correctors::static_cal::{fit_static, pose_means, StaticFitOptions, StaticModel};
use spincal::correctors::static_detect::{detect_static, StaticOptions};
use spincal::simulate::gyro_poses::{simulate_pose_session, PoseSession, PoseSessionSetup};

/// The whole pipeline as `spincal static --gyro-file` runs it: still intervals detected on the
/// accelerometer, its static fit, then the gyro.
fn calibrate(
    time_s: &[f64],
    accel: &[Vec<f64>; 3],
    gyro: &[Vec<f64>; 3],
    options: &GyroPoseOptions,
) -> GyroPoseFit {
    let detection = detect_static(time_s, accel, &StaticOptions::default()).unwrap();
    let accel_fit = fit_static(
        &pose_means(&detection.intervals),
        &StaticFitOptions {
            model: StaticModel::Misalignment,
            gravity_mps2: 9.81,
            input_unit: "counts".into(),
        },
    )
    .unwrap();
    let poses = still_poses(&detection.intervals, &accel_fit.calibration);
    fit_gyro_poses(time_s, gyro, &poses, options).unwrap()
}

fn simulate(setup: &PoseSessionSetup, seed: u64) -> PoseSession {
    simulate_pose_session(setup, seed).unwrap()
}

/// (within 3 SE, count) over b and K, and the largest absolute errors of b and K; prints how
/// many lie within 1 SE.
fn score(fit: &GyroPoseFit, truth: &GyroModel) -> (usize, usize, f64, f64) {
    let mut one_se = 0;
    let mut inside = 0;
    let mut total = 0;
    let (mut bias_error, mut k_error) = (0.0f64, 0.0f64);
    for i in 0..3 {
        let e = (fit.model.bias_radps[i] - truth.bias_radps[i]).abs();
        bias_error = bias_error.max(e);
        inside += usize::from(e <= 3.0 * fit.bias_se[i]);
        one_se += usize::from(e <= fit.bias_se[i]);
        total += 1;
        for j in 0..3 {
            let e = (fit.model.sensitivity[i][j] - truth.sensitivity[i][j]).abs();
            k_error = k_error.max(e);
            inside += usize::from(e <= 3.0 * fit.sensitivity_se[i][j]);
            one_se += usize::from(e <= fit.sensitivity_se[i][j]);
            total += 1;
        }
    }
    println!("  {one_se}/{total} within 1 SE");
    (inside, total, bias_error, k_error)
}

/// Recovery across 20 seeds: random sensors (scale ±5 %, cross-axis ±1 %, bias ±0.02 rad/s), 30
/// poses, rotations of 30–180° in 1–3 s at 100 Hz, gyro noise 0.005 rad/s per sample. Measured
/// when written: 239 of 240 (99.6 %) parameters within ±3 SE (180, 75 %, within ±1 SE); largest
/// errors 2.5e-4 rad/s (bias) and 9.6e-4 (K).
#[test]
fn recovers_simulated_bias_and_sensitivity_within_their_standard_errors() {
    let (mut inside, mut total) = (0, 0);
    let (mut worst_bias, mut worst_k) = (0.0f64, 0.0f64);
    for seed in 0..20 {
        let setup = PoseSessionSetup::random(seed);
        let s = simulate(&setup, 1000 + seed);
        let fit = calibrate(&s.time_s, &s.accel, &s.gyro, &GyroPoseOptions::default());
        let (i, t, b, k) = score(&fit, &setup.gyro);
        println!(
            "seed {seed}: {i}/{t} within 3 SE, bias error {b:.2e}, K error {k:.2e}, {} rotations, residual RMS {:.3}°",
            fit.rotations.len(),
            fit.rms_residual_deg
        );
        inside += i;
        total += t;
        worst_bias = worst_bias.max(b);
        worst_k = worst_k.max(k);
        // A seed's errors stay small whatever its coverage.
        assert!(b < 1e-3 && k < 1e-2, "seed {seed}: bias error {b}, K error {k}");
        assert!(
            fit.rms_residual_deg < 1.0,
            "seed {seed}: {}",
            fit.rms_residual_deg
        );
    }
    let coverage = inside as f64 / total as f64;
    println!("coverage {inside}/{total} = {coverage:.3}; worst bias error {worst_bias:.2e}, worst K error {worst_k:.2e}");
    assert!(coverage >= 0.90, "coverage {coverage}");
}

/// Raw counts: about −800 counts per rad/s on x (sign flipped), +760 and +830 on y and z, a bias of
/// 32 768 counts. The fit finds each axis's sign and size from the rotations alone.
#[test]
fn finds_sign_and_scale_of_a_gyro_in_counts() {
    for seed in [3, 4, 5] {
        let mut setup = PoseSessionSetup::random(seed);
        let scales = [-800.0, 760.0, 830.0];
        let truth = GyroModel {
            bias_radps: [32_768.0, 32_700.0, 32_810.0],
            sensitivity: std::array::from_fn(|i| {
                std::array::from_fn(|j| setup.gyro.sensitivity[i][j] * scales[i])
            }),
            input_unit: GyroInputUnit::Counts,
        };
        setup.gyro = truth.clone();
        let s = simulate(&setup, 77 + seed);
        let options = GyroPoseOptions {
            input_unit: GyroInputUnit::Counts,
            ..Default::default()
        };
        let fit = calibrate(&s.time_s, &s.accel, &s.gyro, &options);
        assert_eq!(fit.model.input_unit, GyroInputUnit::Counts);
        fit.model.validate().unwrap();
        for i in 0..3 {
            let k = fit.model.sensitivity[i][i];
            let rel = k / truth.sensitivity[i][i] - 1.0;
            assert!(
                rel.abs() < 0.005,
                "seed {seed} axis {i}: {k} vs {}",
                truth.sensitivity[i][i]
            );
            assert!((k - truth.sensitivity[i][i]).abs() < 4.0 * fit.sensitivity_se[i][i].max(1e-9));
            assert!((fit.model.bias_radps[i] - truth.bias_radps[i]).abs() < 2.0);
        }
        // The corrector turns counts into rad/s: a still reading gives about zero rate.
        let w = fit.model.corrector().unwrap().correct(truth.bias_radps);
        assert!(w.iter().all(|v| v.abs() < 2e-3), "{w:?}");
    }
}

/// imu_tk's own result for the T265 recording: ω = T S (m − b) (`t265_test_imu_gyro.calib`), so
/// our K should be (T S)⁻¹ and b the same. Two comparisons:
/// - gravity directions from imu_tk's own accelerometer calibration (`t265_test_imu_acc.calib`):
///   the gyro estimators alone are compared;
/// - gravity directions from our static fit: its misalignment differs from imu_tk's by a few
///   hundredths of a radian (weakly determined by 40 poses), and K's off-diagonal terms, which
///   live in the accelerometer's frame, follow it.
///
/// Still intervals: 50 s initial period, 0.5 s window, 1 s shortest (imu_tk finds 41 intervals;
/// the default 1 s window merges poses here), 38 rotations. Measured when written: with imu_tk's
/// accelerometer, K within 4.4e-3 of imu_tk's entry by entry (1.1 of our SE; SEs 0.0025–0.0054),
/// rotation residual RMS 1.56°; with ours, within 0.026 (3.3 SE, the off-diagonal terms), RMS
/// 2.48°, the diagonal within 0.0025 either way; b within 1.5e-4 rad/s (imu_tk averages its own
/// initial window). The tolerances are about twice these.
#[test]
fn t265_gyro_agrees_with_imu_tk() {
    let (Some(acc_path), Some(gyr_path), Some(acc_calib), Some(gyr_calib)) = (
        common::shared_data("imu/realsense_t265/t265_acc.mat"),
        common::shared_data("imu/realsense_t265/t265_gyr.mat"),
        common::shared_data("imu/realsense_t265/t265_test_imu_acc.calib"),
        common::shared_data("imu/realsense_t265/t265_test_imu_gyro.calib"),
    ) else {
        return;
    };
    let read = |path: &std::path::Path| {
        let options = spincal::input::formats::ReadOptions {
            retime: true,
            ..Default::default()
        };
        spincal::input::formats::read_path(path, &options)
            .unwrap()
            .recording
    };
    let imu_tk = |path: &std::path::Path| {
        spincal::export::ImuTkCalib::parse(&std::fs::read_to_string(path).unwrap(), "calib").unwrap()
    };
    let acc = read(&acc_path);
    let gyr = read(&gyr_path);
    let gyro = gyr.gyro_radps.clone().unwrap_or(gyr.accel_mps2.clone());
    let detect = StaticOptions {
        init_s: 50.0,
        window_s: 0.5,
        threshold_factor: 3.0,
        min_interval_s: 1.0,
    };
    let detection = detect_static(&acc.time_s, &acc.accel_mps2, &detect).unwrap();
    let accel_fit = fit_static(
        &pose_means(&detection.intervals),
        &StaticFitOptions {
            model: StaticModel::Misalignment,
            gravity_mps2: 9.81,
            input_unit: "m/s^2".into(),
        },
    )
    .unwrap();
    let acc_tk = imu_tk(&acc_calib);
    let tk = imu_tk(&gyr_calib);
    // imu_tk's K: (T S)⁻¹, column c the corrector of "K = T S" applied to the unit vector e_c.
    let ts = GyroModel {
        bias_radps: [0.0; 3],
        sensitivity: std::array::from_fn(|r| std::array::from_fn(|c| tk.misalignment[r][c] * tk.scale[c])),
        input_unit: GyroInputUnit::RadPerS,
    }
    .corrector()
    .unwrap();
    let columns: [[f64; 3]; 3] =
        std::array::from_fn(|c| ts.correct(std::array::from_fn(|r| f64::from(u8::from(r == c)))));
    let k_tk: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| columns[j][i]));

    let with_tk_accel: Vec<StillPose> = detection
        .intervals
        .iter()
        .map(|i| StillPose {
            start: i.start,
            end: i.end,
            accel_mps2: acc_tk.apply(i.mean),
        })
        .collect();
    let with_our_accel = still_poses(&detection.intervals, &accel_fit.calibration);
    let mut worst = Vec::new();
    for (name, poses) in [
        ("imu_tk's accelerometer", &with_tk_accel),
        ("our accelerometer", &with_our_accel),
    ] {
        let fit = fit_gyro_poses(&acc.time_s, &gyro, poses, &GyroPoseOptions::default()).unwrap();
        let mut worst_k = 0.0f64;
        let mut worst_se = 0.0f64;
        for i in 0..3 {
            for j in 0..3 {
                let ours = fit.model.sensitivity[i][j];
                println!(
                    "{name}: K[{i}][{j}] spincal {ours:.5} ± {:.5}, imu_tk {:.5}",
                    fit.sensitivity_se[i][j], k_tk[i][j]
                );
                worst_k = worst_k.max((ours - k_tk[i][j]).abs());
                worst_se = worst_se.max((ours - k_tk[i][j]).abs() / fit.sensitivity_se[i][j]);
            }
        }
        let worst_bias = (0..3)
            .map(|i| (fit.model.bias_radps[i] - tk.bias[i]).abs())
            .fold(0.0, f64::max);
        println!(
            "{name}: {} rotations, residual RMS {:.3}°; worst |ΔK| {worst_k:.2e} ({worst_se:.1} SE), worst |Δb| {worst_bias:.2e} rad/s",
            fit.rotations.len(),
            fit.rms_residual_deg
        );
        worst.push((worst_k, worst_bias));
    }
    assert!(
        worst[0].0 < 0.01,
        "K (imu_tk's accelerometer) differs by {}",
        worst[0].0
    );
    assert!(
        worst[1].0 < 0.05,
        "K (our accelerometer) differs by {}",
        worst[1].0
    );
    assert!(worst[0].1 < 3e-4 && worst[1].1 < 3e-4, "b differs by {worst:?}");
}

fn small_session() -> (PoseSession, Vec<StillPose>, PoseSessionSetup) {
    let setup = PoseSessionSetup::random(9);
    let s = simulate(&setup, 9);
    let poses = s
        .still
        .iter()
        .map(|&(start, end)| {
            let mean: [f64; 3] =
                std::array::from_fn(|k| s.accel[k][start..end].iter().sum::<f64>() / (end - start) as f64);
            StillPose {
                start,
                end,
                accel_mps2: setup.accel.apply(&mean),
            }
        })
        .collect();
    (s, poses, setup)
}

#[test]
fn bad_input_is_refused_with_its_location() {
    let (s, poses, setup) = small_session();
    let options = GyroPoseOptions::default();
    // The true poses fit; the bias from every still interval has the smaller standard error (the
    // simulated bias does not drift) and still covers the truth.
    let first = fit_gyro_poses(&s.time_s, &s.gyro, &poses, &options).unwrap();
    let all = GyroPoseOptions {
        bias_from: GyroBiasSource::AllIntervals,
        ..Default::default()
    };
    let all = fit_gyro_poses(&s.time_s, &s.gyro, &poses, &all).unwrap();
    for i in 0..3 {
        assert!(all.bias_se[i] < first.bias_se[i]);
        assert!((all.model.bias_radps[i] - setup.gyro.bias_radps[i]).abs() < 3.0 * all.bias_se[i]);
    }

    let mut short = s.gyro.clone();
    short[1].pop();
    let e = fit_gyro_poses(&s.time_s, &short, &poses, &options).unwrap_err();
    assert!(matches!(e, GyroPoseError::LengthMismatch { .. }), "{e}");
    assert!(e.to_string().contains("samples"), "{e}");

    let mut nan = s.gyro.clone();
    nan[2][4321] = f64::NAN;
    let e = fit_gyro_poses(&s.time_s, &nan, &poses, &options).unwrap_err();
    assert!(e.to_string().contains("axis z at sample 4321"), "{e}");

    let e = fit_gyro_poses(&s.time_s, &s.gyro, &poses[..4], &options).unwrap_err();
    assert!(
        matches!(e, GyroPoseError::TooFewRotations { found: 3, .. }),
        "{e}"
    );

    // A gap: samples missing in the middle of rotation 5.
    let (from, to) = (poses[5].end, poses[6].start);
    let cut = (from + to) / 2;
    let keep = |v: &Vec<f64>| -> Vec<f64> { v[..cut].iter().chain(&v[cut + 10..]).copied().collect() };
    let time: Vec<f64> = keep(&s.time_s);
    let gyro: [Vec<f64>; 3] = std::array::from_fn(|k| keep(&s.gyro[k]));
    let shifted: Vec<StillPose> = poses
        .iter()
        .map(|p| {
            let shift = |i: usize| if i > cut { i - 10 } else { i };
            StillPose {
                start: shift(p.start),
                end: shift(p.end),
                accel_mps2: p.accel_mps2,
            }
        })
        .collect();
    let e = fit_gyro_poses(&time, &gyro, &shifted, &options).unwrap_err();
    assert!(matches!(e, GyroPoseError::GapInMotion { rotation: 5, .. }), "{e}");

    let mut unordered = poses.clone();
    unordered.swap(2, 3);
    let e = fit_gyro_poses(&s.time_s, &s.gyro, &unordered, &options).unwrap_err();
    assert!(matches!(e, GyroPoseError::BadPose { index: 3, .. }), "{e}");
}

/// Rotations all about one body axis leave the other two axes' scales unknown: refused.
#[test]
fn rotations_about_one_axis_are_refused() {
    let setup = PoseSessionSetup::random(2);
    let mut s = simulate(&setup, 2);
    // Keep only the z gyro's motion: as if every rotation were about z.
    let poses: Vec<StillPose> = s
        .still
        .iter()
        .map(|&(start, end)| StillPose {
            start,
            end,
            accel_mps2: [0.0, 0.0, 9.81],
        })
        .collect();
    for k in 0..2 {
        let b = setup.gyro.bias_radps[k];
        s.gyro[k].iter_mut().for_each(|v| *v = b);
    }
    let e = fit_gyro_poses(&s.time_s, &s.gyro, &poses, &GyroPoseOptions::default()).unwrap_err();
    assert!(matches!(e, GyroPoseError::PoorlySpanned { .. }), "{e}");
    assert!(e.to_string().contains("do not span"), "{e}");
}

/// A model in counts may have any scale, but its rows must stay dominant and independent; the
/// unit is written only when it is counts, so earlier files read as before.
#[test]
fn models_in_counts_are_checked_and_written_with_their_unit() {
    let counts = GyroModel {
        bias_radps: [32_768.0; 3],
        sensitivity: [[-800.0, 5.0, 0.0], [3.0, 760.0, -4.0], [0.0, 2.0, 830.0]],
        input_unit: GyroInputUnit::Counts,
    };
    counts.validate().unwrap();
    let text = serde_json::to_string(&counts).unwrap();
    assert!(text.contains(r#""input_unit":"counts""#), "{text}");
    assert_eq!(serde_json::from_str::<GyroModel>(&text).unwrap(), counts);
    // In rad/s the same numbers are refused (an axis's own sensitivity must lie within 0.5–2).
    let as_radps = GyroModel {
        input_unit: GyroInputUnit::RadPerS,
        ..counts.clone()
    };
    assert!(as_radps.validate().is_err());
    let radps_text = serde_json::to_string(&GyroModel::IDEAL).unwrap();
    assert!(!radps_text.contains("input_unit"), "{radps_text}");
    // A row led by another axis, and two nearly parallel rows, are refused by field.
    let mut swapped = counts.clone();
    swapped.sensitivity[1] = [760.0, 3.0, -4.0];
    let e = swapped.validate().unwrap_err();
    assert_eq!(e.field, "sensitivity[1][1]", "{}", e.reason);
    let mut parallel = counts.clone();
    parallel.sensitivity[1] = [-780.0, 800.0, 0.0];
    parallel.sensitivity[0] = [-800.0, 760.0, 0.0];
    let e = parallel.validate().unwrap_err();
    assert_eq!(e.field, "sensitivity", "{}", e.reason);
}
