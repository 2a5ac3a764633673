//! `spincal static --gyro-file`: the gyroscope calibrated from still poses and rotations, saved in
//! cal.json, and applied by `spincal allan --calibration` so that the Kalibr file of a raw-count
//! IMU (the Xsens of imu_tk's test data) is in m/s² and rad/s.

// Parallel per-axis arrays read best with indices.
#![allow(clippy::needless_range_loop)]

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::harness::{fails, run, shared, spincal, venv_python};

use spincal::correctors::gyro::{GyroInputUnit, GyroModel};
use spincal::simulate::gyro_poses::{simulate_pose_session, PoseSessionSetup};

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap()
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// Noise densities (accel x y z, gyro x y z) by allantools' overlapping ADEV of the samples in
/// [t₀, t₁], calibrated in numpy from cal.json's numbers (the static fit's a = T diag(s) (r − b),
/// the gyro's ω = K⁻¹ (m − b)), read off the −½ line as the exports test does: the mean of
/// log(σ√τ) over the points left of the minimum whose local slope is within ±0.15 of −½.
/// Arguments: accel file, gyro file, cal.json, t₀, t₁, rate.
const CALIBRATED_ALLANTOOLS_DENSITY: &str = r#"
import sys, json, numpy as np, allantools
acc = np.loadtxt(sys.argv[1]); gyr = np.loadtxt(sys.argv[2])
cal = json.load(open(sys.argv[3]))
t0, t1, rate = float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])
s = cal["corrector"]
yz, zy, zx = s["misalignment"]
T = np.array([[1, -yz, zy], [0, 1, -zx], [0, 0, 1]])
a = (T @ (np.array(s["scale"])[:, None] * (acc[:, 1:4] - np.array(s["bias"])).T)).T
g = cal["gyro"]
w = np.linalg.solve(np.array(g["sensitivity"]), (gyr[:, 1:4] - np.array(g["bias_radps"])).T).T
keep = (acc[:, 0] >= t0) & (acc[:, 0] <= t1)
out = []
for y in [a[keep, k] for k in range(3)] + [w[keep, k] for k in range(3)]:
    taus = np.unique(np.round(np.logspace(0, np.log10(len(y) / 10), 60)).astype(int)) / rate
    t, ad, _, _ = allantools.oadev(y, rate=rate, data_type="freq", taus=taus)
    lt, la = np.log10(t), np.log10(ad)
    kmin = int(np.argmin(ad))
    slope = np.diff(la) / np.diff(lt)
    pts = [la[k] + 0.5 * lt[k] for k in range(max(kmin, 1)) if k < len(slope) and -0.65 <= slope[k] <= -0.35]
    out.append(10 ** np.mean(pts) if pts else float("nan"))
print(",".join(repr(float(v)) for v in out))
"#;

/// The Xsens of imu_tk's test data (raw counts for both sensors): `static --gyro-file` calibrates
/// both, the accelerometer near the README's factory values and the gyro with small rotation
/// residuals; `allan --calibration --still --kalibr` then writes a Kalibr file in SI units whose
/// keys PyYAML reads and whose noise densities agree with allantools' within 10 % on the same
/// calibrated samples. Measured when written: the initial still period 0.03–51.4 s; noise
/// densities, spincal against allantools, accel 8.97e-4 / 9.11e-4, 8.81e-4 / 9.08e-4,
/// 9.07e-4 / 9.36e-4 m/s²/√Hz (−1.5, −3.0, −3.1 %), gyro 5.95e-4 / 5.91e-4, 5.94e-4 / 5.94e-4,
/// 5.95e-4 / 5.91e-4 rad/s/√Hz (+0.7, −0.1, +0.6 %).
#[test]
fn xsens_counts_calibrate_and_give_a_kalibr_file_in_si_units() {
    let (Some(acc), Some(gyr)) = (
        shared("imu/imu_tk_xsens/xsens_acc.mat"),
        shared("imu/imu_tk_xsens/xsens_gyro.mat"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal.json");
    let report = json(&run(spincal()
        .arg("static")
        .arg(&acc)
        .arg("--gyro-file")
        .arg(&gyr)
        .args(["--gravity", "9.81744", "--json", "-o"])
        .arg(&cal)));

    // The accelerometer against the README's factory values: offsets within 10 counts (0.024
    // m/s²) and scales within 0.5 %. Measured when written: offsets 0.8, 0.8 and 4.5 counts off,
    // scales 0.14, 0.24 and 0.09 % low.
    let c = &report["fit"]["calibration"];
    let factory_offset = [33123.0, 33276.0, 32360.0];
    let factory_counts_per_mps2 = [415.0, 413.0, 415.0];
    for k in 0..3 {
        let offset = f(&c["bias"][k]);
        let counts_per_mps2 = 1.0 / f(&c["scale"][k]);
        println!(
            "accel {k}: offset {offset:.1} (factory {}), {counts_per_mps2:.2} counts per m/s² (factory {})",
            factory_offset[k], factory_counts_per_mps2[k]
        );
        assert!((offset - factory_offset[k]).abs() < 10.0, "offset {k}: {offset}");
        assert!((counts_per_mps2 / factory_counts_per_mps2[k] - 1.0).abs() < 0.005);
    }

    // The gyro: found in counts, every rotation's residual small. Measured when written: 38
    // rotations, residual RMS 0.52°, largest 1.02°; K's diagonal about 4770 counts per rad/s
    // (SE 4–6), b = [32777, 32460, 32512] counts.
    let g = &report["gyro"];
    assert_eq!(g["input_unit"], "counts", "{g}");
    let fit = &g["fit"];
    let rotations = fit["rotations"].as_array().unwrap();
    let residuals: Vec<f64> = rotations.iter().map(|r| f(&r["residual_deg"])).collect();
    let worst = residuals.iter().copied().fold(0.0, f64::max);
    let rms = f(&fit["rms_residual_deg"]);
    println!(
        "gyro: {} rotations, residual RMS {rms:.3}°, largest {worst:.3}°; K = {}, SE {}; b = {}",
        rotations.len(),
        fit["model"]["sensitivity"],
        fit["sensitivity_se"],
        fit["model"]["bias_radps"]
    );
    assert!(rotations.len() >= 20, "{}", rotations.len());
    assert!(rms < 1.0 && worst < 2.0, "residuals {residuals:?}");
    let file: serde_json::Value = json(&std::fs::read_to_string(&cal).unwrap());
    let model: GyroModel = serde_json::from_value(file["gyro"].clone()).unwrap();
    assert_eq!(model.input_unit, GyroInputUnit::Counts);
    for i in 0..3 {
        // Hundreds of counts per rad/s, each axis dominated by its own entry.
        let own = model.sensitivity[i][i].abs();
        assert!((100.0..10_000.0).contains(&own), "{model:?}");
    }

    // Without the calibration the gyro counts are refused, saying how to calibrate.
    let refused = fails(
        spincal()
            .arg("allan")
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr)
            .args(["--accel-scale", "0.0024", "--still"]),
    );
    assert!(
        refused.contains("raw counts") && refused.contains("calibrate the gyroscope first"),
        "{refused}"
    );

    let Some(python) = venv_python() else { return };
    let yaml = dir.path().join("imu.yaml");
    let allan = |extra: &[&str]| {
        let mut cmd = spincal();
        cmd.arg("allan")
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr)
            .arg("--calibration")
            .arg(&cal)
            .arg("--still")
            .args(extra);
        run(&mut cmd)
    };
    allan(&["--kalibr", yaml.to_str().unwrap()]);
    let check = r#"
import sys, yaml
d = yaml.safe_load(open(sys.argv[1]))
keys = {"accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density", "gyroscope_random_walk", "rostopic", "update_rate"}
assert set(d) == keys, set(d) ^ keys
for k in keys - {"rostopic"}:
    assert isinstance(d[k], float) and d[k] > 0, (k, d[k])
print(d["accelerometer_noise_density"], d["gyroscope_noise_density"], d["update_rate"])
"#;
    let parsed = run(Command::new(&python).args(["-c", check]).arg(&yaml));
    let kalibr: Vec<f64> = parsed.split_whitespace().map(|s| s.parse().unwrap()).collect();
    let report = json(&allan(&["--json"]));
    let rate = f(&report["sample_rate_hz"]);
    assert!((kalibr[2] / rate - 1.0).abs() < 1e-9);
    let span = &report["span_s"];
    println!("still span {} – {} s", span[0], span[1]);
    assert!(
        f(&span[1]) - f(&span[0]) > 30.0,
        "the initial still period: {span}"
    );
    let theirs = run(Command::new(&python)
        .args(["-c", CALIBRATED_ALLANTOOLS_DENSITY])
        .arg(&acc)
        .arg(&gyr)
        .arg(&cal)
        .arg(f(&span[0]).to_string())
        .arg(f(&span[1]).to_string())
        .arg(rate.to_string()));
    let theirs: Vec<f64> = theirs.trim().split(',').map(|s| s.parse().unwrap()).collect();
    let ours_acc: Vec<f64> = serde_json::from_value(report["params"]["noise_density"].clone()).unwrap();
    let ours_gyr: Vec<f64> = serde_json::from_value(report["gyro_params"]["noise_density"].clone()).unwrap();
    for (k, ours) in ours_acc.iter().chain(&ours_gyr).enumerate() {
        let rel = ours / theirs[k] - 1.0;
        println!(
            "{} {}: spincal {ours:.4e}, allantools {:.4e} ({:+.1} %)",
            if k < 3 {
                "accel m/s²/√Hz"
            } else {
                "gyro rad/s/√Hz"
            },
            ['x', 'y', 'z'][k % 3],
            theirs[k],
            100.0 * rel
        );
        assert!(rel.abs() < 0.10, "axis {k}: {ours:.4e} vs {:.4e}", theirs[k]);
    }
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!((kalibr[0] / max(&ours_acc) - 1.0).abs() < 1e-6);
    assert!((kalibr[1] / max(&ours_gyr) - 1.0).abs() < 1e-6);
    // SI units, not counts: an MTi's gyro noise is of order 1e-3 rad/s/√Hz, its accelerometer's
    // 1e-3 m/s²/√Hz (counts would be hundreds of times more).
    assert!(kalibr[1] < 0.05 && kalibr[0] < 0.05, "{kalibr:?}");
}

/// Writes a simulated session as imu_tk's two whitespace files (`t ax ay az`, `t gx gy gz`).
fn write_session(dir: &Path, setup: &PoseSessionSetup, seed: u64) -> (PathBuf, PathBuf) {
    let s = simulate_pose_session(setup, seed).unwrap();
    let write = |name: &str, v: &[Vec<f64>; 3]| {
        let mut text = String::new();
        for i in 0..s.time_s.len() {
            text += &format!(
                "{:.5} {:.3} {:.3} {:.3}\n",
                s.time_s[i], v[0][i], v[1][i], v[2][i]
            );
        }
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    (write("acc.txt", &s.accel), write("gyr.txt", &s.gyro))
}

/// A simulated gyro in counts (−800 counts per rad/s on x): `static --gyro-file` recovers K, and
/// `allan` applies it.
#[test]
fn simulated_counts_are_calibrated_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let mut setup = PoseSessionSetup::random(21);
    let scales = [-800.0, 700.0, 900.0];
    setup.gyro = GyroModel {
        bias_radps: [32_768.0, 32_500.0, 33_000.0],
        sensitivity: std::array::from_fn(|i| {
            std::array::from_fn(|j| setup.gyro.sensitivity[i][j] * scales[i])
        }),
        input_unit: GyroInputUnit::Counts,
    };
    let (acc, gyr) = write_session(dir.path(), &setup, 5);
    let cal = dir.path().join("cal.json");
    let text = run(spincal()
        .arg("static")
        .arg(&acc)
        .arg("--gyro-file")
        .arg(&gyr)
        .args(["--gravity", "9.81", "-o"])
        .arg(&cal));
    assert!(text.contains("rotations between still poses"), "{text}");
    let file: serde_json::Value = json(&std::fs::read_to_string(&cal).unwrap());
    let model: GyroModel = serde_json::from_value(file["gyro"].clone()).unwrap();
    for i in 0..3 {
        for j in 0..3 {
            let truth = setup.gyro.sensitivity[i][j];
            assert!(
                (model.sensitivity[i][j] - truth).abs() < 0.005 * scales[i].abs(),
                "K[{i}][{j}] {} vs {truth}",
                model.sensitivity[i][j]
            );
        }
    }
    // Without the calibration allan refuses the gyro counts and says how to calibrate them.
    let refused = fails(
        spincal()
            .arg("allan")
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&gyr)
            .args(["--accel-scale", "0.0024", "--still"]),
    );
    assert!(
        refused.contains("raw counts") && refused.contains("a static calibration given the gyro file"),
        "{refused}"
    );
    // allan applies it: the gyro of the still start reads about zero rad/s.
    let report = json(&run(spincal()
        .arg("allan")
        .arg(&acc)
        .arg("--gyro-file")
        .arg(&gyr)
        .arg("--calibration")
        .arg(&cal)
        .args(["--still", "--json"])));
    assert!(
        report["gyro_params"]["noise_density"][0].as_f64().unwrap() < 0.01,
        "{report}"
    );
}

#[test]
fn bad_gyro_input_is_refused_with_its_location() {
    let dir = tempfile::tempdir().unwrap();
    let setup = PoseSessionSetup::random(8);
    let (acc, gyr) = write_session(dir.path(), &setup, 8);
    let text = std::fs::read_to_string(&gyr).unwrap();
    let lines: Vec<&str> = text.lines().collect();

    // A gyro file of another length without a time of its own (both timed by --sample-rate):
    // taken sample for sample, so refused; with its time it is merged on time instead.
    let short = dir.path().join("short.txt");
    std::fs::write(&short, lines[..lines.len() - 5].join("\n") + "\n").unwrap();
    let e = fails(
        spincal()
            .arg("static")
            .arg(&acc)
            .arg("--gyro-file")
            .arg(&short)
            .args(["--sample-rate", "100"]),
    );
    assert!(
        e.contains("short.txt") && e.contains("samples") && e.contains("as long"),
        "{e}"
    );

    // NaN in the gyro: named by sample (the reader or the fit, whichever sees it first).
    let nan = dir.path().join("nan.txt");
    let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let fields: Vec<&str> = lines[3000].split_whitespace().collect();
    edited[3000] = format!("{} {} nan {}", fields[0], fields[1], fields[3]);
    std::fs::write(&nan, edited.join("\n") + "\n").unwrap();
    let e = fails(spincal().arg("static").arg(&acc).arg("--gyro-file").arg(&nan));
    assert!(e.contains("3000") || e.contains("3001"), "{e}");

    // Too few rotations: six poses (enough for the accelerometer's 6 parameters), five rotations.
    let few_dir = dir.path().join("few");
    std::fs::create_dir(&few_dir).unwrap();
    let few = PoseSessionSetup {
        poses: 6,
        still_s: [4.0, 5.0],
        ..setup.clone()
    };
    let (acc_few, gyr_few) = write_session(&few_dir, &few, 3);
    let e = fails(
        spincal()
            .arg("static")
            .arg(&acc_few)
            .arg("--gyro-file")
            .arg(&gyr_few)
            .args(["--model", "6"]),
    );
    assert!(e.contains("rotations"), "{e}");
}
