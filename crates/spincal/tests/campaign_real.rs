//! The physical sensor model fitted on real still poses (../shared/data/imu: MPU-6050, Xsens,
//! T265; skipped when absent),
//! judged on poses it never saw: each pose held out in turn, RMS of |a| − g over the held-out
//! poses, and on the poses it fitted, against the source's own published calibration (which saw
//! every pose).

// Axis loops index several parallel per-axis arrays at once.
#![allow(clippy::needless_range_loop)]

use crate::common;

use spincal::campaign::joint::{fit_joint, JointSettings, PoseInput, SensorTerms};
use spincal::correctors::static_detect::{detect_static, StaticOptions, StillInterval};
use spincal::input::formats::{read_path, Format, ReadOptions};

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn pose(rec: &spincal::input::recording::Recording, iv: &StillInterval, to_si: f64) -> PoseInput {
    let n = iv.len() as f64;
    PoseInput {
        name: format!("{:.1}–{:.1} s", iv.t_start_s, iv.t_end_s),
        mean_mps2: iv.mean.map(|m| m * to_si),
        sigma_mean_mps2: iv.std.map(|s| (s * to_si / n.sqrt()).max(1e-6)),
        samples: iv.len(),
        time_s: 0.5 * (rec.time_s[iv.start] + rec.time_s[iv.end - 1]),
        session: 0,
        gyro_mean_radps: None,
        gyro_sigma_mean_radps: None,
        wander: None,
    }
}

/// Leave-one-pose-out RMS of |corrected| − g for a physical model with `terms`.
fn held_out_rms(poses: &[PoseInput], terms: SensorTerms, g: f64) -> f64 {
    let settings = JointSettings {
        gravity_mps2: g,
        terms,
        ..JointSettings::default()
    };
    let mut sum = 0.0;
    for k in 0..poses.len() {
        let training: Vec<PoseInput> = poses
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != k)
            .map(|(_, p)| p.clone())
            .collect();
        let fit = fit_joint(&[], &training, &settings, &spincal::progress::silent).unwrap();
        let f = fit.sensor.correct(poses[k].mean_mps2).unwrap();
        sum += (norm(f) - g).powi(2);
    }
    (sum / poses.len() as f64).sqrt()
}

#[test]
fn mpu6050_held_out_poses_physical_model_against_the_authors() {
    let Some(path) = common::shared_data("imu/mpu6050/example_data_calibration.csv") else {
        return;
    };
    let Some(params_path) = common::shared_data("imu/mpu6050/params_acc.csv") else {
        return;
    };
    let options = ReadOptions {
        format: Some(Format::Mpu6050),
        ..Default::default()
    };
    let loaded = read_path(&path, &options).unwrap();
    let rec = &loaded.recording;
    let p: Vec<f64> = std::fs::read_to_string(params_path)
        .unwrap()
        .lines()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    let t = [[1.0, -p[0], p[1]], [0.0, 1.0, -p[2]], [0.0, 0.0, 1.0]];
    let authors = |raw: [f64; 3]| -> [f64; 3] {
        let v: [f64; 3] = std::array::from_fn(|i| p[3 + i] * (raw[i] + p[6 + i]));
        std::array::from_fn(|r| t[r][0] * v[0] + t[r][1] * v[1] + t[r][2] * v[2])
    };
    let detect = StaticOptions {
        threshold_factor: 5.0,
        ..Default::default()
    };
    let intervals = detect_static(&rec.time_s, &rec.accel_mps2, &detect)
        .unwrap()
        .intervals;
    assert_eq!(intervals.len(), 10);
    let g = 9.81;
    // ±2 g over 16 bits: the nominal scale; the model fits the error about it.
    let to_si = 9.80665 / 16384.0;
    let poses: Vec<PoseInput> = intervals.iter().map(|iv| pose(rec, iv, to_si)).collect();
    // The authors fitted all ten poses: on each held-out pose they had seen it, so this favours them.
    let authors_rms = (intervals
        .iter()
        .map(|iv| (norm(authors(iv.mean)) - g).powi(2))
        .sum::<f64>()
        / intervals.len() as f64)
        .sqrt();
    // No correction: the nominal scale alone, on the same poses.
    let uncorrected_rms = rms_about_g(&intervals, g, |raw| raw.map(|v| v * to_si));
    for terms in [SensorTerms::BIAS_SCALE, SensorTerms::LINEAR] {
        let (in_sample, held_out) = physical_rms(&poses, terms, g);
        eprintln!(
            "mpu6050 {}: RMS |a| − g on poses it fitted {in_sample:.4}, held out one at a time {held_out:.4} m/s² (authors, fitted on every pose: {authors_rms:.4}; uncorrected {uncorrected_rms:.4})",
            terms.describe()
        );
        // Held out, the model removes most of the uncorrected error.
        assert!(
            held_out < 0.5 * uncorrected_rms,
            "{held_out} vs uncorrected {uncorrected_rms}"
        );
        // On the poses both fitted, the physical model explains gravity better than theirs.
        assert!(in_sample < authors_rms, "{in_sample} vs {authors_rms}");
    }
}

/// RMS of |calibrate(mean)| − g over the poses.
fn rms_about_g(intervals: &[StillInterval], g: f64, calibrate: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
    let sum: f64 = intervals
        .iter()
        .map(|iv| (norm(calibrate(iv.mean)) - g).powi(2))
        .sum();
    (sum / intervals.len() as f64).sqrt()
}

/// In-sample and leave-one-pose-out RMS of the physical model with `terms`.
fn physical_rms(poses: &[PoseInput], terms: SensorTerms, g: f64) -> (f64, f64) {
    let settings = JointSettings {
        gravity_mps2: g,
        terms,
        ..JointSettings::default()
    };
    let all = fit_joint(&[], poses, &settings, &spincal::progress::silent).unwrap();
    let in_sample = (poses
        .iter()
        .map(|p| (norm(all.sensor.correct(p.mean_mps2).unwrap()) - g).powi(2))
        .sum::<f64>()
        / poses.len() as f64)
        .sqrt();
    (in_sample, held_out_rms(poses, terms, g))
}

#[test]
fn xsens_held_out_poses_physical_model_against_the_factory_calibration() {
    let Some(path) = common::shared_data("imu/imu_tk_xsens/xsens_acc.mat") else {
        return;
    };
    let loaded = read_path(&path, &ReadOptions::default()).unwrap();
    let rec = &loaded.recording;
    assert!(loaded.raw_counts, "the Xsens file holds raw counts");
    let intervals = detect_static(&rec.time_s, &rec.accel_mps2, &StaticOptions::default())
        .unwrap()
        .intervals;
    assert!(intervals.len() >= 20, "{} still poses", intervals.len());
    // The data README's factory values and local gravity; the factory never saw these poses.
    let (offset, scale, g) = ([33123.0, 33276.0, 32360.0], [415.0, 413.0, 415.0], 9.81744);
    let factory = |raw: [f64; 3]| std::array::from_fn(|k| (raw[k] - offset[k]) / scale[k]);
    let factory_rms = rms_about_g(&intervals, g, factory);
    // Raw counts about mid-scale, at the nominal 415 counts per m/s²; the model fits the rest.
    let poses: Vec<PoseInput> = intervals
        .iter()
        .map(|iv| {
            let mut p = pose(rec, iv, 1.0 / 415.0);
            p.mean_mps2 = iv.mean.map(|m| (m - 32768.0) / 415.0);
            p
        })
        .collect();
    for terms in [SensorTerms::BIAS_SCALE, SensorTerms::LINEAR] {
        let (in_sample, held_out) = physical_rms(&poses, terms, g);
        eprintln!(
            "xsens {} ({} poses): RMS |a| − g on poses it fitted {in_sample:.4}, held out one at a time {held_out:.4} m/s² (factory calibration, which saw none: {factory_rms:.4})",
            terms.describe(),
            poses.len()
        );
        // Held out, the physical model still beats the factory's numbers on these poses.
        assert!(held_out < factory_rms, "{held_out} vs {factory_rms}");
    }
}

#[test]
fn t265_held_out_poses_physical_model_against_imu_tk() {
    let (Some(path), Some(calib)) = (
        common::shared_data("imu/realsense_t265/t265_acc.mat"),
        common::shared_data("imu/realsense_t265/t265_test_imu_acc.calib"),
    ) else {
        return;
    };
    let loaded = read_path(&path, &ReadOptions::default()).unwrap();
    let rec = &loaded.recording;
    let text = std::fs::read_to_string(&calib).unwrap();
    let imu_tk = spincal::export::ImuTkCalib::parse(&text, "t265_test_imu_acc.calib").unwrap();
    // A 50 s initial still period and a 0.5 s window (the default 1 s window merges poses here).
    let detect = StaticOptions {
        init_s: 50.0,
        window_s: 0.5,
        min_interval_s: 1.0,
        ..StaticOptions::default()
    };
    let intervals = detect_static(&rec.time_s, &rec.accel_mps2, &detect)
        .unwrap()
        .intervals;
    assert!(intervals.len() >= 30, "{} still poses", intervals.len());
    // The fork's run log does not state its gravity magnitude: take the mean |a| of imu_tk's own
    // calibration over these poses (its RMS about it is the smallest any g gives it).
    let norms: Vec<f64> = intervals.iter().map(|iv| norm(imu_tk.apply(iv.mean))).collect();
    let g = norms.iter().sum::<f64>() / norms.len() as f64;
    let imu_tk_rms = rms_about_g(&intervals, g, |raw| imu_tk.apply(raw));
    let poses: Vec<PoseInput> = intervals.iter().map(|iv| pose(rec, iv, 1.0)).collect();
    for terms in [SensorTerms::BIAS_SCALE, SensorTerms::LINEAR] {
        let (in_sample, held_out) = physical_rms(&poses, terms, g);
        eprintln!(
            "t265 {} ({} poses): RMS |a| − g on poses it fitted {in_sample:.4}, held out one at a time {held_out:.4} m/s² (imu_tk, fitted on every pose: {imu_tk_rms:.4})",
            terms.describe(),
            poses.len()
        );
        if terms == SensorTerms::LINEAR {
            // The same model class as imu_tk's (bias, scale, misalignment). imu_tk minimises
            // this very criterion (|a| − g, every pose alike); the joint fit weights each pose by
            // its standard error, so in-sample it is slightly above. Held out one pose at a time
            // (imu_tk has no such number: it fitted every pose) it stays within 15 %. Measured
            // when written: 0.0060 in-sample, 0.0063 held out, imu_tk 0.0057 (g = 9.8010).
            assert!(in_sample <= imu_tk_rms * 1.06, "{in_sample} vs {imu_tk_rms}");
            assert!(held_out < 1.15 * imu_tk_rms, "{held_out} vs {imu_tk_rms}");
        }
    }
}
