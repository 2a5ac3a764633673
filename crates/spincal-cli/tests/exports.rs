//! spincal's calibrations in other tools' files, read back by those tools: imucal's own loader
//! applies `imucal.json`; PyYAML reads the Kalibr file and allantools recomputes its noise
//! density; imu_tk's `.calib` is checked against the files imu_tk itself wrote. The gyroscope
//! calibration is applied by `correct` to the gyro columns.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::harness::{fails, run, shared, spincal, venv_python};

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

/// A simulated campaign with gyro, calibrated; returns (campaign dir, output dir).
fn calibrated_campaign(dir: &Path) -> (PathBuf, PathBuf) {
    let campaign = dir.join("campaign");
    let out = dir.join("calibration");
    run(spincal()
        .args(["simulate", "--campaign"])
        .arg(&campaign)
        .args(["--seed", "11"]));
    run(spincal()
        .args(["calibrate", "--campaign"])
        .arg(campaign.join("campaign.toml"))
        .arg("--out")
        .arg(&out));
    (campaign, out)
}

#[test]
fn campaign_calibration_loads_in_imucal_applies_to_the_gyro_and_writes_imu_tk_files() {
    let dir = tempfile::tempdir().unwrap();
    let (campaign, out) = calibrated_campaign(dir.path());
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let sensor: spincal::correctors::physical::SensorModel =
        serde_json::from_value(results["joint"]["sensor"].clone()).unwrap();
    let gyro: spincal::correctors::gyro::GyroModel =
        serde_json::from_value(results["gyro"]["model"].clone()).unwrap();
    let linear = spincal::correctors::physical::SensorModel {
        quadratic_per_mps2: [0.0; 3],
        ..sensor
    };
    let gyro_corrector = gyro.corrector().unwrap();
    let run_csv = campaign.join("run-1-33rpm-r0.060-out+x-up+z.csv");
    let (header, rows) = read_csv(&run_csv);
    assert_eq!(header[4], "gx_radps");

    // correct: the gyro columns come out calibrated, the same numbers as the library's inverse.
    let corrected = dir.path().join("corrected.csv");
    run(spincal()
        .args(["correct", "--model"])
        .arg(out.join("model.json"))
        .arg(&run_csv)
        .arg("-o")
        .arg(&corrected));
    let (out_header, out_rows) = read_csv(&corrected);
    let gx = out_header
        .iter()
        .position(|h| h == "gx_corrected_radps")
        .expect("gyro corrected columns");
    for (row, out_row) in rows.iter().zip(&out_rows).step_by(97) {
        let w = gyro_corrector.correct([row[4], row[5], row[6]]);
        for k in 0..3 {
            assert_eq!(
                out_row[gx + k],
                w[k],
                "correct's gyro columns are the library's inverse"
            );
        }
    }

    // imu_tk: the files parse with imu_tk's layout and give the corrected vectors in imu_tk's
    // (rotated) frame: the same lengths and the same angle between force and rate.
    let acc_tk = spincal::export::ImuTkCalib::parse(
        &std::fs::read_to_string(out.join("imu_tk_acc.calib")).unwrap(),
        "acc",
    )
    .unwrap();
    let gyr_tk = spincal::export::ImuTkCalib::parse(
        &std::fs::read_to_string(out.join("imu_tk_gyro.calib")).unwrap(),
        "gyr",
    )
    .unwrap();
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    for row in rows.iter().step_by(101) {
        let (m, wm) = ([row[1], row[2], row[3]], [row[4], row[5], row[6]]);
        let (f, w) = (linear.correct(m).unwrap(), gyro_corrector.correct(wm));
        let (f_tk, w_tk) = (acc_tk.apply(m), gyr_tk.apply(wm));
        assert!((dot(f, f) - dot(f_tk, f_tk)).abs() < 1e-8);
        assert!((dot(w, w) - dot(w_tk, w_tk)).abs() < 1e-10);
        assert!((dot(f, w) - dot(f_tk, w_tk)).abs() < 1e-9);
    }

    // imucal's own loader and calibrate(): the same numbers as spincal's linear inverse.
    let Some(python) = venv_python() else { return };
    let imucal_out = dir.path().join("imucal.csv");
    let script = r#"
import sys, numpy as np
from imucal.management import load_calibration_info
cal = load_calibration_info(sys.argv[1])
data = np.loadtxt(sys.argv[2], delimiter=",", skiprows=1)
acc, gyr = cal.calibrate(data[:, 1:4], data[:, 4:7], "m/s^2", "rad/s")
np.savetxt(sys.argv[3], np.hstack([acc, gyr]), delimiter=",", fmt="%.17g", header="ax,ay,az,gx,gy,gz", comments="")
print(type(cal).__name__)
"#;
    let kind = run(Command::new(&python)
        .args(["-c", script])
        .arg(out.join("imucal.json"))
        .arg(&run_csv)
        .arg(&imucal_out));
    assert_eq!(kind.trim(), "FerrarisCalibrationInfo");
    let (_, theirs) = read_csv(&imucal_out);
    assert_eq!(theirs.len(), rows.len());
    let mut worst = [0.0f64; 2];
    for (row, t) in rows.iter().zip(&theirs) {
        let f = linear.correct([row[1], row[2], row[3]]).unwrap();
        let w = gyro_corrector.correct([row[4], row[5], row[6]]);
        for k in 0..3 {
            worst[0] = worst[0].max((t[k] - f[k]).abs());
            worst[1] = worst[1].max((t[3 + k] - w[k]).abs());
        }
    }
    assert!(
        worst[0] < 1e-10 && worst[1] < 1e-12,
        "imucal differs from spincal by {worst:?}"
    );
}

/// Noise density by an independent Allan deviation (allantools' overlapping ADEV) of the same
/// samples, read off the −½ line the same way: mean of log(σ√τ) over the points whose local slope
/// is within ±0.15 of −½, left of the minimum. Arguments: accel file, gyro file (the same file when
/// it has gyro columns), t₀, t₁, rate.
const ALLANTOOLS_DENSITY: &str = r#"
import sys, numpy as np, allantools
def load(path):
    csv = path.endswith(".csv")
    return np.genfromtxt(path, delimiter="," if csv else None, skip_header=1 if csv else 0)
acc_path, gyr_path, t0, t1, rate = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
acc = load(acc_path)
gyr = acc[:, 3:] if gyr_path == acc_path else load(gyr_path)
keep = (acc[:, 0] >= t0) & (acc[:, 0] <= t1)
columns = [acc[keep, 1 + k] for k in range(3)] + [gyr[keep, 1 + k] for k in range(3)]
out = []
for y in columns:
    taus = np.unique(np.round(np.logspace(0, np.log10(len(y) / 10), 60)).astype(int)) / rate
    t, ad, _, _ = allantools.oadev(y, rate=rate, data_type="freq", taus=taus)
    lt, la = np.log10(t), np.log10(ad)
    kmin = int(np.argmin(ad))
    slope = np.diff(la) / np.diff(lt)
    pts = [la[k] + 0.5 * lt[k] for k in range(max(kmin, 1)) if k < len(slope) and -0.65 <= slope[k] <= -0.35]
    out.append(10 ** np.mean(pts) if pts else float("nan"))
print(",".join(repr(float(v)) for v in out))
"#;

/// `spincal allan --kalibr` on a recording: Kalibr's keys parse with PyYAML, and the noise
/// densities agree with allantools within 10 %.
fn kalibr_against_allantools(python: &Path, accel: &Path, gyro: Option<&Path>, dir: &Path) {
    let yaml_path = dir.join("imu.yaml");
    let mut args: Vec<std::ffi::OsString> = vec!["allan".into(), accel.into(), "--still".into()];
    if let Some(g) = gyro {
        args.extend(["--gyro-file".into(), g.into()]);
    }
    run(spincal()
        .args(&args)
        .arg("--kalibr")
        .arg(&yaml_path)
        .args(["--kalibr-topic", "/imu0"]));
    let check = r#"
import sys, yaml
d = yaml.safe_load(open(sys.argv[1]))
keys = {"accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density", "gyroscope_random_walk", "rostopic", "update_rate"}
assert set(d) == keys, set(d) ^ keys
assert d["rostopic"] == "/imu0"
for k in keys - {"rostopic"}:
    assert isinstance(d[k], float) and d[k] > 0, (k, d[k])
print(d["accelerometer_noise_density"], d["gyroscope_noise_density"], d["update_rate"])
"#;
    let parsed = run(Command::new(python).args(["-c", check]).arg(&yaml_path));
    let v: Vec<f64> = parsed.split_whitespace().map(|s| s.parse().unwrap()).collect();
    let report: serde_json::Value = serde_json::from_str(&run(spincal().args(&args).arg("--json"))).unwrap();
    let rate = report["sample_rate_hz"].as_f64().unwrap();
    assert!((v[2] / rate - 1.0).abs() < 1e-9, "update_rate {} vs {rate}", v[2]);
    let span = &report["span_s"];
    let theirs = run(Command::new(python)
        .args(["-c", ALLANTOOLS_DENSITY])
        .arg(accel)
        .arg(gyro.unwrap_or(accel))
        .arg(span[0].as_f64().unwrap().to_string())
        .arg(span[1].as_f64().unwrap().to_string())
        .arg(rate.to_string()));
    let theirs: Vec<f64> = theirs.trim().split(',').map(|s| s.parse().unwrap()).collect();
    let ours_acc: Vec<f64> = serde_json::from_value(report["params"]["noise_density"].clone()).unwrap();
    let ours_gyr: Vec<f64> = serde_json::from_value(report["gyro_params"]["noise_density"].clone()).unwrap();
    for (k, ours) in ours_acc.iter().chain(&ours_gyr).enumerate() {
        let rel = (ours / theirs[k] - 1.0).abs();
        println!(
            "{} axis {k}: spincal {ours:.4e}, allantools {:.4e}",
            accel.display(),
            theirs[k]
        );
        assert!(
            rel < 0.10,
            "axis {k}: spincal {ours:.4e} vs allantools {:.4e} ({:.1} %)",
            theirs[k],
            100.0 * rel
        );
    }
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!((v[0] / max(&ours_acc) - 1.0).abs() < 1e-6);
    assert!((v[1] / max(&ours_gyr) - 1.0).abs() < 1e-6);
}

#[test]
fn kalibr_file_of_a_simulated_still_recording_parses_and_matches_allantools() {
    let Some(python) = venv_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let still = dir.path().join("still");
    let setup = dir.path().join("setup.json");
    std::fs::write(&setup, r#"{"poses": 1, "pose_duration_s": 600.0, "runs": []}"#).unwrap();
    run(spincal()
        .args(["simulate", "--campaign"])
        .arg(&still)
        .arg("--setup")
        .arg(&setup));
    kalibr_against_allantools(&python, &still.join("still-poses.csv"), None, dir.path());
}

#[test]
fn kalibr_file_of_the_real_t265_still_start_parses_and_matches_allantools() {
    let (Some(acc), Some(gyr)) = (
        shared("imu/realsense_t265/t265_acc.mat"),
        shared("imu/realsense_t265/t265_gyr.mat"),
    ) else {
        return;
    };
    let Some(python) = venv_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    kalibr_against_allantools(&python, &acc, Some(&gyr), dir.path());
}

/// A model.json with a thermal model, the shape `CorrectorFile` reads.
const THERMAL_MODEL: &str = r#"{"format_version": 1, "spincal_version": "test", "corrector": {"kind": "physical",
 "sensor": {"bias_mps2": [0.1, -0.2, 0.05], "scale_error": [0.01, 0.0, -0.01],
 "misalignment_rad": [0.0, 0.0, 0.0], "quadratic_per_mps2": [0.0, 0.0, 0.0]},
 "gravity_mps2": 9.80665, "input_range_mps2": [[-10, 10], [-10, 10], [-10, 10]]},
 "thermal": {"reference_c": 25.0, "bias_mps2": [0.05, -0.03, 0.08], "scale_error": [0.004, -0.002, 0.006],
 "misalignment_rad": [0.003, -0.002, 0.004], "bias_per_c": [[0.0021, -4e-5, 6e-7], [-0.0013], [0.0035, 1e-5]],
 "scale_per_c": [[1.5e-4], [], []], "lag_s": 18.0, "smoothing_s": 60.0, "fitted_range_c": [5.0, 55.0]}}"#;

#[test]
fn export_writes_the_flight_stacks_files_from_the_models_thermal_field() {
    use spincal::thermal::flight_stacks::{self, ArduPilotTarget, Px4Target};
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.json");
    std::fs::write(&model, THERMAL_MODEL).unwrap();
    let (ap, px4) = (dir.path().join("imu.param"), dir.path().join("imu.params"));
    let export = |extra: &[&str]| {
        let mut cmd = spincal();
        cmd.args(["export", "--model"])
            .arg(&model)
            .arg("--ardupilot")
            .arg(&ap);
        cmd.args(["--ardupilot-imu", "2", "--px4"]).arg(&px4);
        cmd.args(["--px4-device-id", "1310988", "--px4-accel", "1"])
            .args(extra);
        cmd
    };
    let stdout = run(&mut export(&[]));
    assert!(
        stdout.contains("gain's change"),
        "what is left out is shown: {stdout}"
    );
    let thermal = spincal::correctors::model_file::CorrectorFile::read_path(&model)
        .unwrap()
        .thermal
        .unwrap();
    let want_ap = flight_stacks::ardupilot(&thermal, ArduPilotTarget { imu: 2 })
        .unwrap()
        .text;
    let target = Px4Target {
        accel: 1,
        device_id: 1_310_988,
        system_id: 1,
        component_id: 1,
    };
    let want_px4 = flight_stacks::px4(&thermal, target).unwrap().text;
    assert_eq!(std::fs::read_to_string(&ap).unwrap(), want_ap);
    assert_eq!(std::fs::read_to_string(&px4).unwrap(), want_px4);
    assert!(want_ap.contains("INS_TCAL2_ACC3_X,") && want_px4.contains("\tTC_A1_X3_2\t"));
    // Its own files are replaced on a rerun; a file it did not write is not. The firmware code
    // holds no thermal correction, so asking for it beside them is refused by name.
    run(&mut export(&[]));
    let stderr = fails(export(&["--out"]).arg(dir.path().join("firmware")));
    assert!(stderr.contains("thermal"), "{stderr}");
    assert!(!dir.path().join("firmware/fusion.txt").exists());
    std::fs::write(&ap, "INS_TCAL2_ENABLE,0\n").unwrap();
    let stderr = fails(&mut export(&[]));
    assert!(
        stderr.contains("imu.param") && stderr.contains("did not write"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&ap).unwrap(), "INS_TCAL2_ENABLE,0\n");

    // A model without a thermal model, and a bias the stacks cannot hold, are refused by name.
    let plain = dir.path().join("plain.json");
    let mut value: serde_json::Value = serde_json::from_str(THERMAL_MODEL).unwrap();
    value.as_object_mut().unwrap().remove("thermal");
    std::fs::write(&plain, value.to_string()).unwrap();
    let out = dir.path().join("new.param");
    let refusal = || {
        fails(
            spincal()
                .args(["export", "--model"])
                .arg(&plain)
                .arg("--ardupilot")
                .arg(&out),
        )
    };
    let stderr = refusal();
    assert!(stderr.contains("no thermal model"), "{stderr}");
    let quartic = THERMAL_MODEL.replace("[0.0035, 1e-5]", "[0.0035, 1e-5, 0.0, 2e-9]");
    std::fs::write(&plain, quartic).unwrap();
    // model.json itself holds at most a cubic: the file is refused by the field.
    let stderr = refusal();
    assert!(stderr.contains("thermal.bias_per_c[2]"), "{stderr}");
    assert!(!out.exists());
}
