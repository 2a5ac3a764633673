//! Black-box tests of `spincal inspect`, `static` and `allan` on files written here.

use assert_cmd::Command;
use spincal::input::formats::gx1::{encode, Gx1EncodeOptions, EEPROM_REPLY_LEN, VECTORS_LEN};
use spincal::input::recording::{Recording, Source};

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

fn still_poses_file(dir: &std::path::Path) -> std::path::PathBuf {
    // 14 poses of 4 s at 100 Hz joined by 1 s moves, raw counts: r = a·k + offset (+ tiny ripple).
    let (k, off) = ([415.0, 413.0, 417.0], [33123.0, 33276.0, 32360.0]);
    let g = 9.81744;
    let mut text = String::new();
    let mut t = 0.0;
    for p in 0..14 {
        let (th, ph) = (p as f64 * 0.9, p as f64 * 2.1);
        let a = [g * th.sin() * ph.cos(), g * th.sin() * ph.sin(), g * th.cos()];
        for i in 0..500 {
            let moving = i >= 400;
            let wobble = if moving {
                200.0 * (i as f64 * 0.7).sin()
            } else {
                (i % 3) as f64 - 1.0
            };
            let r: Vec<String> = (0..3)
                .map(|x| format!("{}", (a[x] * k[x] + off[x] + wobble).round()))
                .collect();
            text += &format!("{t:.3} {} {} {}\n", r[0], r[1], r[2]);
            t += 0.01;
        }
    }
    let path = dir.join("poses.txt");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn static_recovers_offsets_and_writes_json_and_yaml() {
    let dir = tempfile::tempdir().unwrap();
    let rec = still_poses_file(dir.path());
    let cal = dir.path().join("cal.json");
    let yaml = dir.path().join("kalibr.yaml");
    let out = spincal()
        .args([
            "static",
            rec.to_str().unwrap(),
            "--gravity",
            "9.81744",
            "--model",
            "9",
            "--json",
            "-o",
        ])
        .arg(&cal)
        .arg("--yaml")
        .arg(&yaml)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["format"]["format"], "whitespace");
    assert_eq!(report["intervals"].as_array().unwrap().len(), 14);
    let file: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(file["corrector"]["kind"], "static");
    let c = &file["corrector"];
    for (i, off) in [33123.0, 33276.0, 32360.0].iter().enumerate() {
        assert!((c["bias"][i].as_f64().unwrap() - off).abs() < 1.0, "{c}");
    }
    assert!((1.0 / c["scale"][2].as_f64().unwrap() - 417.0).abs() < 0.5, "{c}");
    assert!(std::fs::read_to_string(&yaml)
        .unwrap()
        .contains("  accelerometers:\n    M: [["));
    // The calibration is a corrector file like any other: `spincal correct` applies it.
    let corrected = dir.path().join("corrected.csv");
    let out = spincal()
        .args(["correct", "--model"])
        .arg(&cal)
        .arg(&rec)
        .arg("-o")
        .arg(&corrected)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read_to_string(&corrected).unwrap().lines().count() > 1);
}

#[test]
fn inspect_reports_detected_gx1_format_and_damage_offset() {
    let n = 200;
    let rec = Recording {
        time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
        accel_mps2: [vec![0.5; n], vec![-0.25; n], vec![9.8; n]],
        gyro_radps: None,
        temperature_c: None,
        source: Source::default(),
    };
    let mut bytes = encode(&rec, &Gx1EncodeOptions::default()).unwrap();
    let bad = EEPROM_REPLY_LEN + 7 * VECTORS_LEN;
    bytes[bad + 9] ^= 0xff;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.bin");
    std::fs::write(&path, bytes).unwrap();
    let out = spincal().arg("inspect").arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("format: 3dm-gx1 (detected: binary data"), "{text}");
    assert!(text.contains("samples: 199 "), "{text}");
    assert!(text.contains(&format!("byte {bad}: bad checksum")), "{text}");
    assert!(
        text.contains("AccelGainScale 5000 (EEPROM reply at byte 0)"),
        "{text}"
    );
}

#[test]
fn usage_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let rec = still_poses_file(dir.path());
    spincal()
        .args(["static", rec.to_str().unwrap(), "--model", "7"])
        .assert()
        .code(2);
    // Raw counts without a scale cannot give m/s² noise figures.
    let out = spincal().args(["allan", rec.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("raw counts"));
    spincal()
        .args(["inspect", rec.to_str().unwrap(), "--format", "nope"])
        .assert()
        .code(2);
    // A non-finite offset would make every acceleration non-finite.
    let out = spincal()
        .args(["inspect", rec.to_str().unwrap(), "--accel-offset", "inf,0,0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("'inf' is not a finite number"));
}

#[test]
fn allan_writes_curve_and_profile() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("t,ax,ay,az\n");
    // Deterministic pseudo-noise (an LCG) around gravity.
    let mut s: u64 = 12345;
    for i in 0..5000 {
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
        };
        text += &format!("{},{},{},{}\n", i as f64 * 0.01, r(), r(), 9.8 + r());
    }
    let rec = dir.path().join("still.csv");
    std::fs::write(&rec, text).unwrap();
    let (curve, profile) = (dir.path().join("a.csv"), dir.path().join("p.json"));
    spincal()
        .arg("allan")
        .arg(&rec)
        .arg("--curve")
        .arg(&curve)
        .arg("--profile")
        .arg(&profile)
        .assert()
        .success();
    let p: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&profile).unwrap()).unwrap();
    // Uniform noise of width 0.02 m/s² has σ = 0.02/√12 per sample: the simulator profile's noise.
    let expected = 0.02 / 12f64.sqrt() / 9.80665;
    let n = p["noise_g"].as_f64().unwrap();
    assert!((n / expected - 1.0).abs() < 0.1, "{n} vs {expected}");
    // The simulator takes the profile as it is.
    spincal()
        .args(["simulate", "--duration", "10", "-o"])
        .arg(dir.path().join("imitated.csv"))
        .arg("--sensor")
        .arg(&profile)
        .assert()
        .success();
    assert!(std::fs::read_to_string(&curve)
        .unwrap()
        .starts_with("tau_s,adev_x,adev_y,adev_z\n"));
}

/// `simulate --thermal` writes a thermal campaign whose files carry the reported temperature,
/// which `inspect` reads back with its range and resolution; the truth matches the simulated
/// profile; the folder is never overwritten.
#[test]
fn simulated_thermal_campaign_carries_its_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("warm");
    spincal()
        .args(["simulate", "--thermal", out.to_str().unwrap(), "--seed", "3"])
        .assert()
        .success();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("truth.json")).unwrap()).unwrap();
    assert_eq!(truth["model"]["lag_s"], 20.0);
    assert_eq!(truth["recordings"].as_array().unwrap().len(), 1 + 60 + 80);
    let inspected = spincal()
        .args(["inspect", out.join("warmup-00.csv").to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8(inspected.stdout).unwrap();
    assert!(
        text.contains("temperature: 15.00 .. 40.00 °C, resolution 1 °C"),
        "{text}"
    );
    // The die temperature in the truth is not stepped.
    let die = spincal()
        .args([
            "inspect",
            "--json",
            out.join("warmup-00.truth.csv").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let report: serde_json::Value = serde_json::from_slice(&die.stdout).unwrap();
    assert!(
        report["inspection"]["temperature"]["distinct_values"]
            .as_u64()
            .unwrap()
            > 10_000
    );
    let again = spincal()
        .args(["simulate", "--thermal", out.to_str().unwrap(), "--seed", "3"])
        .assert()
        .failure();
    let stderr = String::from_utf8(again.get_output().stderr.clone()).unwrap();
    assert!(stderr.contains("already exists"), "{stderr}");
}
