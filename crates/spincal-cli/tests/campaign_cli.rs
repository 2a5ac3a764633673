//! `spincal simulate --campaign` and `spincal calibrate --campaign` from the outside: files,
//! exit codes, located errors, and a physical corrector applied by `correct`.

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

#[test]
fn simulated_campaign_calibrates_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let unit = dir.path().join("unit");
    spincal()
        .args(["simulate", "--seed", "4", "--campaign"])
        .arg(&unit)
        .assert()
        .success();
    let campaign = unit.join("campaign.toml");
    assert!(campaign.exists());
    let out = dir.path().join("cal");
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(&campaign)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let stdout = String::from_utf8_lossy(&run.stdout);
    // The held-out table is the report's (and --tables'), not the terminal's.
    assert!(!stdout.contains("held-out condition"), "{stdout}");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let saved = results["saved"].as_str();
    assert_eq!(out.join("model.json").exists(), saved.is_some());
    // The default campaign's physical model removes most of the error: it must be saved, and the
    // verdict must state what was saved, on how many held-out conditions, with the numbers
    // recomputed here from the held-out rows.
    let verdict = results["verdict"].as_str().unwrap();
    let saved = saved.unwrap_or_else(|| panic!("nothing saved: {verdict}"));
    assert!(saved.starts_with("physical"), "{saved}");
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("model.json")).unwrap()).unwrap();
    assert!(model["corrector"].is_object(), "{model}");
    let n = results["conditions"].as_array().unwrap().len();
    assert!(n >= 2, "{n} held-out conditions");
    // The verdict leads with where the saved physical model can be trusted, then what was saved.
    assert_eq!(
        verdict.starts_with("Trusted where"),
        results["error_map"].is_object(),
        "{verdict}"
    );
    assert!(verdict.contains(&format!("Saved {saved} (")), "{verdict}");
    assert!(
        verdict.contains(&format!("validated on {n} conditions it never trained on")),
        "{verdict}"
    );
    let rows: Vec<&serde_json::Value> = results["held_out"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|h| h["candidate"] == saved)
        .collect();
    assert_eq!(rows.len(), n);
    let rms = |h: &serde_json::Value| {
        let v: Vec<f64> = h["physics"]["rms_mps2"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        (v.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt()
    };
    let mean = rows.iter().map(|h| rms(h)).sum::<f64>() / n as f64;
    let worst = rows
        .iter()
        .map(|h| h["physics"]["ratio"].as_f64().unwrap())
        .fold(0.0, f64::max);
    assert!(
        worst < 1.0,
        "the saved corrector is worse than uncorrected somewhere: {worst}"
    );
    assert!(
        verdict.contains(&format!(
            "it leaves {mean:.4} m/s² mean RMS, at worst {worst:.2}× the uncorrected residual"
        )),
        "{verdict} (mean {mean:.4}, worst {worst:.2})"
    );
    let check = &results["truth_check"];
    let would = check["would_save"].as_str().unwrap_or("nothing");
    let agrees = if check["agrees"].as_bool().unwrap() {
        "agrees"
    } else {
        "disagrees"
    };
    assert!(
        verdict.contains(&format!("truth would have saved {would} ({agrees})")),
        "{verdict}"
    );
    // The terminal leads with one line: the model saved, where, and where it can be trusted (the
    // verdict's first sentence, the error map's); the rest of the verdict follows.
    let mut lines = stdout.lines();
    let first = lines.next().unwrap();
    let lead = format!("Saved {} ({saved}). ", out.join("model.json").display());
    let sentence = first.strip_prefix(&lead).unwrap_or_else(|| panic!("{stdout}"));
    assert!(sentence.starts_with("Trusted where"), "{stdout}");
    let rest = lines
        .next()
        .and_then(|l| l.strip_prefix(&format!("unit {}: ", results["unit"].as_str().unwrap())))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert_eq!(format!("{sentence} {rest}"), verdict);
    // The files it wrote, each named.
    for name in ["model.json", "results.json", "report.html", "imucal.json"] {
        assert!(stdout.contains(&out.join(name).display().to_string()), "{stdout}");
    }
    // Judged by physics; the simulation's truth scores the same samples beside it.
    for row in results["held_out"].as_array().unwrap() {
        assert!(row["physics"]["ratio"].as_f64().is_some(), "{row}");
        assert!(row["truth"]["ratio"].as_f64().is_some(), "{row}");
    }
    assert!(results["truth_check"]["agrees"].is_boolean(), "{results}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("Verdict"));
    // The pictures: held-out errors against physics and truth, the sensor parameters with their
    // intervals, each run's residual, the gyro against the accelerometer's rate.
    for title in [
        "Held-out residual against physics",
        "Held-out error against truth",
        "Sensor parameters",
        "Joint fit residual per run",
        "Gyro against the accelerometer",
    ] {
        assert!(html.contains(title), "the report lacks the figure {title:?}");
    }

    // A second simulation into the same folder refuses, and leaves the first untouched.
    let before = std::fs::read(&campaign).unwrap();
    let again = spincal()
        .args(["simulate", "--seed", "5", "--campaign"])
        .arg(&unit)
        .output()
        .unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
    assert_eq!(std::fs::read(&campaign).unwrap(), before);

    // The file names the datasheet and each recording's random error; every held-out floor is
    // measured from it.
    let text = String::from_utf8_lossy(&before).into_owned();
    assert!(
        text.contains("nonlinearity_pct_fs = 0.2") && text.contains("random_error = "),
        "{text}"
    );
    for row in results["held_out"].as_array().unwrap() {
        assert!(row["floor_mps2"].is_array(), "{row}");
    }
    // A random-error file that does not match its recording is named by the campaign's line.
    let random = std::fs::read_dir(&unit)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().ends_with(".random.csv"))
        .unwrap();
    let rows = std::fs::read_to_string(&random).unwrap();
    let half: Vec<&str> = rows.lines().take(rows.lines().count() / 2).collect();
    std::fs::write(&random, half.join("\n") + "\n").unwrap();
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(&campaign)
        .arg("--out")
        .arg(dir.path().join("cal-2"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("`random_error`") && stderr.contains("samples but the recording has"),
        "{stderr}"
    );
}

#[test]
fn a_bad_campaign_entry_is_named_by_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("c.toml");
    std::fs::write(
        &file,
        "unit = \"u\"\n[[recording]]\nfile = \"r.csv\"\nkind = \"turntable\"\nrpm = 33.3\nradius_m = -0.1\nradius_tol_m = 0.002\nout = \"+x\"\nup = \"+z\"\n",
    )
    .unwrap();
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("c.toml:6: `radius_m`"), "{stderr}");

    // A missing recording names the campaign line and the file.
    std::fs::write(
        &file,
        "[[recording]]\nfile = \"missing.csv\"\nkind = \"static\"\n",
    )
    .unwrap();
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("c.toml:1: `file`") && stderr.contains("missing.csv"),
        "{stderr}"
    );
}

#[test]
fn correct_applies_a_physical_corrector_to_every_row() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.json");
    std::fs::write(
        &model,
        r#"{"format_version": 1, "spincal_version": "test", "corrector": {"kind": "physical",
            "sensor": {"bias_mps2": [0.1, -0.2, 0.05], "scale_error": [0.01, 0.0, -0.01],
                       "misalignment_rad": [0.0, 0.0, 0.0], "quadratic_per_mps2": [0.0, 0.0, 0.0]},
            "gravity_mps2": 9.80665, "input_range_mps2": [[-10, 10], [-10, 10], [-10, 10]]}}"#,
    )
    .unwrap();
    let input = dir.path().join("in.csv");
    std::fs::write(
        &input,
        "t_s,ax_mps2,ay_mps2,az_mps2\n0,1.11,-0.2,9.75\n0.01,0.1,0.8,9.6\n",
    )
    .unwrap();
    let out = dir.path().join("out.csv");
    spincal()
        .arg("correct")
        .arg(&input)
        .arg("--model")
        .arg(&model)
        .arg("-o")
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{text}");
    // ax_corrected_mps2 = (1.11 − 0.1) / 1.01 = 1.0.
    assert!(
        text.starts_with("t_s,ax_mps2,ay_mps2,az_mps2,ax_corrected_mps2,"),
        "{text}"
    );
    let x: f64 = rows[0].split(',').nth(4).unwrap().parse().unwrap();
    assert!((x - 1.0).abs() < 1e-9, "{text}");
}

/// `correct` with a campaign's linear-12 model.json (a linear map with its 12 parameters'
/// covariance) writes each row's predicted sd per axis and `predicted_better`, the library's
/// values; the same map without a covariance (an older file) writes neither.
#[test]
fn correct_with_a_linear_12_model_writes_its_error_bar() {
    let dir = tempfile::tempdir().unwrap();
    let variances = [
        1e-4, 4e-4, 1e-4, 1e-6, 1e-6, 1e-6, 4e-6, 1e-6, 1e-6, 1e-6, 1e-6, 9e-6,
    ];
    let covariance: Vec<String> = (0..12)
        .map(|a| {
            let row: Vec<String> = (0..12)
                .map(|b| {
                    if a == b {
                        variances[a].to_string()
                    } else {
                        "0".into()
                    }
                })
                .collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    let map = r#""axes": ["x", "y", "z"], "offset_mps2": [-0.1, 0.2, -0.05],
        "matrix": [[0.99, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.01]], "training": null"#;
    let with = format!(
        r#"{{"format_version": 3, "spincal_version": "test", "corrector": {{"kind": "linear", {map},
            "uncertainty": {{"covariance": [{}], "noise_sd_mps2": [0.02, 0.02, 0.02]}}}}}}"#,
        covariance.join(", ")
    );
    let without = format!(
        r#"{{"format_version": 3, "spincal_version": "test", "corrector": {{"kind": "linear", {map}}}}}"#
    );
    let input = dir.path().join("in.csv");
    std::fs::write(
        &input,
        "t_s,ax_mps2,ay_mps2,az_mps2\n0,1.11,-0.2,9.75\n0.01,-10,-0.18,0.2\n0.02,9.8,0.1,0.05\n",
    )
    .unwrap();
    for (name, text, error_bar) in [("with.json", &with, true), ("without.json", &without, false)] {
        let model = dir.path().join(name);
        std::fs::write(&model, text).unwrap();
        let out = dir.path().join(format!("out-{name}.csv"));
        spincal()
            .arg("correct")
            .arg(&input)
            .arg("--model")
            .arg(&model)
            .arg("-o")
            .arg(&out)
            .assert()
            .success();
        let written = std::fs::read_to_string(&out).unwrap();
        let header = written.lines().next().unwrap();
        if !error_bar {
            assert!(
                !header.contains("_corrected_sd_") && !header.contains("predicted_better"),
                "{written}"
            );
            continue;
        }
        assert!(
            header.starts_with(
                "t_s,ax_mps2,ay_mps2,az_mps2,ax_corrected_mps2,ay_corrected_mps2,az_corrected_mps2,ax_corrected_sd_mps2,ay_corrected_sd_mps2,az_corrected_sd_mps2,predicted_better,"
            ),
            "{written}"
        );
        let file = spincal::correctors::model_file::CorrectorFile::from_json(text, name).unwrap();
        let error_model = file
            .corrector
            .error_model()
            .expect("a linear map with a covariance");
        let mut flags = Vec::new();
        for row in written.lines().skip(1) {
            let v: Vec<f64> = row.split(',').take(11).map(|x| x.parse().unwrap()).collect();
            let m = [v[1], v[2], v[3]];
            let sd = error_model.predicted_sd(m).unwrap();
            for k in 0..3 {
                assert!((v[7 + k] - sd[k]).abs() <= 1e-12 * sd[k], "axis {k}: {row}");
            }
            let better =
                (0..3).all(|k| spincal::correctors::physical::predicted_to_help(v[4 + k] - m[k], sd[k]));
            assert_eq!(v[10], f64::from(u8::from(better)), "{row}");
            flags.push(better);
        }
        // Every correction of the first row is well beyond its sd; the second's x is none
        // (0.99 · −10 − 0.1 = −10).
        assert_eq!(flags[..2], [true, false], "{written}");
    }
}
