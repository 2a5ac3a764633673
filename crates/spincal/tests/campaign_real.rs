//! The physical sensor model fitted on real still poses (../shared/data/imu; skipped when absent),
//! judged on poses it never saw: each pose held out in turn, RMS of |a| − g over the held-out
//! poses, and on the poses it fitted, against the source's own published calibration (which saw
//! every pose).

// Axis loops index several parallel per-axis arrays at once.
#![allow(clippy::needless_range_loop)]

mod common;

use spincal::campaign::joint::{fit_joint, JointSettings, PoseInput, SensorTerms};
use spincal::formats::{read_path, Format, ReadOptions};
use spincal::static_detect::{detect_static, StaticOptions, StillInterval};

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

fn pose(rec: &spincal::Recording, iv: &StillInterval, to_si: f64) -> PoseInput {
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
    for terms in [SensorTerms::BIAS_SCALE, SensorTerms::LINEAR] {
        let held_out = held_out_rms(&poses, terms, g);
        let settings = JointSettings {
            gravity_mps2: g,
            terms,
            ..JointSettings::default()
        };
        let all = fit_joint(&[], &poses, &settings, &spincal::progress::silent).unwrap();
        let in_sample = (poses
            .iter()
            .map(|p| (norm(all.sensor.correct(p.mean_mps2).unwrap()) - g).powi(2))
            .sum::<f64>()
            / poses.len() as f64)
            .sqrt();
        eprintln!(
            "mpu6050 {}: RMS |a| − g on poses it fitted {in_sample:.4}, held out one at a time {held_out:.4} m/s² (authors, fitted on every pose: {authors_rms:.4})",
            terms.describe()
        );
        assert!(held_out.is_finite());
        // On the poses both fitted, the physical model explains gravity better than theirs.
        assert!(in_sample < authors_rms, "{in_sample} vs {authors_rms}");
    }
}
