//! Temperature end to end, as a user meets it: `simulate --thermal` writes a campaign whose still
//! recordings log their temperature; `calibrate --campaign` saves a model.json that corrects for
//! it over the range it saw; `correct` reads a recording's temperature column and marks the rows
//! it cannot correct for temperature.

use crate::harness::{run, run_with_stderr, spincal};

/// Median |a| of the rows whose status is `ok`, from `correct`'s output, and the statuses seen.
fn corrected_magnitudes(text: &str) -> (f64, Vec<String>) {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("{name} in {header:?}"))
    };
    let (ax, ay, az) = (
        col("ax_corrected_mps2"),
        col("ay_corrected_mps2"),
        col("az_corrected_mps2"),
    );
    let status = col("status");
    let mut norms = Vec::new();
    let mut statuses = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        statuses.push(f[status].to_string());
        if f[status] == "ok" {
            let v: Vec<f64> = [ax, ay, az].iter().map(|&c| f[c].parse().unwrap()).collect();
            norms.push(v.iter().map(|x| x * x).sum::<f64>().sqrt());
        }
    }
    norms.sort_by(f64::total_cmp);
    (norms.get(norms.len() / 2).copied().unwrap_or(f64::NAN), statuses)
}

#[test]
fn a_thermal_campaign_calibrates_and_corrects_by_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("warm");
    run(spincal()
        .args(["simulate", "--thermal"])
        .arg(&sim)
        .args(["--seed", "5"]));
    let cal = dir.path().join("cal");
    run(spincal()
        .args(["calibrate", "--campaign"])
        .arg(sim.join("campaign.toml"))
        .arg("--out")
        .arg(&cal));
    let model: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cal.join("model.json")).unwrap()).unwrap();
    let range = &model["thermal"]["fitted_range_c"];
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(
        lo < 17.0 && hi > 38.0,
        "fitted over {lo}–{hi} °C of a 15–40 °C warm-up"
    );
    let results = std::fs::read_to_string(cal.join("results.json")).unwrap();
    assert!(
        results.contains("Corrected for temperature"),
        "the verdict states it"
    );
    // The other tools' files cannot hold the change with temperature, and say so.
    let imucal = std::fs::read_to_string(cal.join("imucal.json")).unwrap();
    assert!(imucal.contains("reference temperature"), "{imucal}");

    // A held-out pose from the middle of its warm-up, corrected row by row with its temperature.
    let held = sim.join("held-out-40.csv");
    let text = std::fs::read_to_string(&held).unwrap();
    let corrected = run(spincal()
        .arg("correct")
        .arg(&held)
        .arg("--model")
        .arg(cal.join("model.json")));
    let (median, statuses) = corrected_magnitudes(&corrected);
    assert!(
        statuses.iter().all(|s| s == "ok"),
        "{:?}",
        statuses.iter().find(|s| *s != "ok")
    );
    let g = 9.80665;
    assert!((median - g).abs() < 0.01, "corrected |a| median {median}");

    // The same rows with the temperature blanked in one and far too hot in another: both corrected
    // as at the reference temperature, valid 0, named in the status; the others unchanged.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let temp = header.iter().position(|h| *h == "temp_c").expect("temp_c column");
    let edit = |line: &str, value: &str| {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        f[temp] = value.to_string();
        f.join(",")
    };
    lines[100] = edit(&lines[100], "");
    lines[200] = edit(&lines[200], "95");
    let edited = dir.path().join("edited.csv");
    std::fs::write(&edited, lines.join("\n") + "\n").unwrap();
    let (stdout, stderr) = run_with_stderr(
        spincal()
            .arg("correct")
            .arg(&edited)
            .arg("--model")
            .arg(cal.join("model.json")),
    );
    assert!(
        stderr.contains("1 of") && stderr.contains("reference temperature"),
        "{stderr}"
    );
    // 95 °C between two rows at about 25 °C is faster than a die can change: a glitch.
    assert!(
        stderr.contains("suspect-temperature") && stderr.contains("line 201"),
        "{stderr}"
    );
    let (_, statuses) = corrected_magnitudes(&stdout);
    assert_eq!(statuses.len(), lines.len() - 1, "every row written");
    assert_eq!(statuses[99], "no-temperature");
    assert_eq!(statuses[199], "suspect-temperature");
    assert_eq!(statuses.iter().filter(|s| *s == "ok").count(), statuses.len() - 2);

    // The firmware code holds no temperature correction: it says so instead of dropping it.
    let refused = spincal()
        .args(["export", "--model"])
        .arg(cal.join("model.json"))
        .arg("--out")
        .arg(dir.path().join("fw"))
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("thermal"));
}
