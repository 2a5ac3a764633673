//! Temperature checked like every other input, as a user meets it (issue 47 item 2): a simulated
//! thermal campaign (`simulate --thermal` with a short profile) edited as a faulty sensor or a
//! careless user would, then `calibrate --campaign`, `correct` and `export`. Each case checks the
//! exit code, the message, and that no input changed.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use crate::harness::{run, run_with_stderr, spincal};

/// The default unit at 10 Hz over 20-minute sessions (the same 15–40 °C warm-ups).
fn simulated(dir: &Path) -> PathBuf {
    let setup = dir.join("profile.json");
    std::fs::write(
        &setup,
        r#"{"sample_rate_hz": 10.0, "session_s": 1200.0, "warmup_time_s": 450.0}"#,
    )
    .unwrap();
    let sim = dir.join("warm");
    run(spincal()
        .args(["simulate", "--thermal"])
        .arg(&sim)
        .args(["--seed", "7", "--setup"])
        .arg(&setup));
    sim
}

/// Every file under `dir` with its content: what must not change.
fn contents(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect()
}

/// `file`'s lines with `edit(line number, temperature)` giving each data line's new temperature
/// (the last column).
fn edit_temperatures(file: &Path, edit: impl Fn(usize, f64) -> String) {
    let text = std::fs::read_to_string(file).unwrap();
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if i == 0 {
            assert!(line.ends_with("temp_c"), "{line}");
            out.push(line.to_string());
            continue;
        }
        let (head, value) = line.rsplit_once(',').unwrap();
        out.push(format!("{head},{}", edit(i + 1, value.parse().unwrap())));
    }
    std::fs::write(file, out.join("\n") + "\n").unwrap();
}

fn failed(out: &Output) -> (Option<i32>, String) {
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn glitches_resets_and_absurd_models_from_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path());
    // One 95 °C sample in the warm-up's 12,000.
    edit_temperatures(&sim.join("warmup-00.csv"), |line, v| {
        if line == 6001 {
            "95".into()
        } else {
            v.to_string()
        }
    });
    let inputs = contents(&sim);
    let cal = dir.path().join("cal");
    let stdout = run(spincal()
        .args(["calibrate", "--campaign"])
        .arg(sim.join("campaign.toml"))
        .arg("--out")
        .arg(&cal));
    assert!(
        stdout.contains("warmup-00.csv:6001: temperature glitch to 95 °C"),
        "{stdout}"
    );
    assert_eq!(contents(&sim), inputs, "calibrate changed an input");
    let model_path = cal.join("model.json");
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model_path).unwrap()).unwrap();
    let range = &model["thermal"]["fitted_range_c"];
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(lo > 14.0 && hi < 41.0, "fitted over {lo}–{hi} °C");
    let results = std::fs::read_to_string(cal.join("results.json")).unwrap();
    assert!(
        results.contains("\"temperature_findings\""),
        "results.json lists them"
    );
    let param = dir.path().join("tcal.param");
    run(spincal()
        .args(["export", "--model"])
        .arg(&model_path)
        .arg("--ardupilot")
        .arg(&param));
    let tmax: f64 = std::fs::read_to_string(&param)
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("INS_TCAL1_TMAX,"))
        .unwrap()
        .parse()
        .unwrap();
    assert!(tmax < 41.0, "INS_TCAL1_TMAX {tmax}");

    // Six held-out poses (20 s each, 10 s apart) logged as one stream by `correct`, whose sensor
    // resets: 10 °C lower for a minute, data lines 302–901.
    let held = dir.path().join("stream.csv");
    let mut stream = String::new();
    for k in 30..36 {
        let text = std::fs::read_to_string(sim.join(format!("held-out-{k}.csv"))).unwrap();
        let skip = if k == 30 { 0 } else { 1 };
        for line in text.lines().skip(skip) {
            stream.push_str(line);
            stream.push('\n');
        }
    }
    std::fs::write(&held, stream).unwrap();
    edit_temperatures(&held, |line, v| {
        if (302..=901).contains(&line) {
            (v - 10.0).to_string()
        } else {
            v.to_string()
        }
    });
    let held_bytes = std::fs::read(&held).unwrap();
    let (stdout, stderr) = run_with_stderr(
        spincal()
            .arg("correct")
            .arg(&held)
            .arg("--model")
            .arg(&model_path),
    );
    assert_eq!(std::fs::read(&held).unwrap(), held_bytes);
    let mut rows = stdout.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let status = header.iter().position(|h| *h == "status").unwrap();
    let statuses: Vec<String> = rows
        .map(|r| r.split(',').nth(status).unwrap().to_string())
        .collect();
    assert_eq!(statuses.len(), 1200);
    assert!(
        statuses[300..900].iter().all(|s| s == "suspect-temperature"),
        "{:?}",
        &statuses[295..305]
    );
    assert!(statuses[..300].iter().all(|s| s == "ok"), "before the reset");
    assert!(statuses[900..].iter().all(|s| s == "ok"), "after the reset");
    assert!(
        stderr.contains("600 of 1200")
            && stderr.contains("suspect-temperature")
            && stderr.contains("line 302"),
        "{stderr}"
    );

    // Kelvin under `temp_c` in `correct`: refused before any row, naming the unit.
    let kelvin = sim.join("held-out-31.csv");
    edit_temperatures(&kelvin, |_, v| format!("{}", v + 273.15));
    let kelvin_bytes = std::fs::read(&kelvin).unwrap();
    let out_csv = dir.path().join("kelvin-corrected.csv");
    let (code, stderr) = failed(
        &spincal()
            .arg("correct")
            .arg(&kelvin)
            .arg("--model")
            .arg(&model_path)
            .arg("-o")
            .arg(&out_csv)
            .output()
            .unwrap(),
    );
    assert_eq!(code, Some(1), "{stderr}");
    for part in ["held-out-31.csv", "column `temp_c`", "kelvin", "temp_k"] {
        assert!(stderr.contains(part), "{part} in {stderr}");
    }
    assert!(!out_csv.exists());
    assert_eq!(std::fs::read(&kelvin).unwrap(), kelvin_bytes);

    // The same model with a bias coefficient edited to 1e9: refused on read by `correct` and by
    // both exports, naming the field; nothing written.
    let mut absurd = model.clone();
    absurd["thermal"]["bias_per_c"][0][0] = serde_json::json!(1e9);
    let absurd_path = dir.path().join("absurd.json");
    std::fs::write(&absurd_path, serde_json::to_string_pretty(&absurd).unwrap()).unwrap();
    let absurd_bytes = std::fs::read(&absurd_path).unwrap();
    let out_csv = dir.path().join("corrected.csv");
    let attempts = [
        spincal()
            .arg("correct")
            .arg(&held)
            .arg("--model")
            .arg(&absurd_path)
            .arg("-o")
            .arg(&out_csv)
            .output()
            .unwrap(),
        spincal()
            .args(["export", "--model"])
            .arg(&absurd_path)
            .arg("--ardupilot")
            .arg(dir.path().join("a.param"))
            .output()
            .unwrap(),
        spincal()
            .args(["export", "--model"])
            .arg(&absurd_path)
            .arg("--px4")
            .arg(dir.path().join("p.params"))
            .args(["--px4-device-id", "1"])
            .output()
            .unwrap(),
    ];
    for out in &attempts {
        let (code, stderr) = failed(out);
        assert_eq!(code, Some(1), "{stderr}");
        assert!(
            stderr.contains("absurd.json")
                && stderr.contains("thermal.bias_per_c[0]")
                && stderr.contains("half a g"),
            "{stderr}"
        );
    }
    assert!(
        !out_csv.exists() && !dir.path().join("a.param").exists() && !dir.path().join("p.params").exists()
    );
    assert_eq!(std::fs::read(&absurd_path).unwrap(), absurd_bytes);
}

#[test]
fn kelvin_under_a_celsius_name_is_refused_naming_kelvin() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated(dir.path());
    edit_temperatures(&sim.join("warmup-00.csv"), |_, v| format!("{}", v + 273.15));
    let inputs = contents(&sim);
    let cal = dir.path().join("cal");
    let out = spincal()
        .args(["calibrate", "--campaign"])
        .arg(sim.join("campaign.toml"))
        .arg("--out")
        .arg(&cal)
        .output()
        .unwrap();
    let (code, stderr) = failed(&out);
    assert_eq!(code, Some(1), "{stderr}");
    for part in ["warmup-00.csv", "column `temp_c`", "kelvin", "temp_k"] {
        assert!(stderr.contains(part), "{part} in {stderr}");
    }
    assert!(!cal.join("model.json").exists());
    assert_eq!(contents(&sim), inputs, "calibrate changed an input");
}
