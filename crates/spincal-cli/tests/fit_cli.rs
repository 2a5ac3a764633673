//! Black-box tests of `spincal simulate`, `fit` and `sensitivity`: the real binary, real files.

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `spincal fit FILE`, expects failure with exit code 1, returns stderr.
fn fit_error(path: &Path, extra: &[&str]) -> String {
    let out = spincal().arg("fit").arg(path).args(extra).output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stderr).unwrap()
}

fn simulated(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let path = dir.join(name);
    spincal()
        .arg("simulate")
        .arg("-o")
        .arg(&path)
        .args(extra)
        .assert()
        .success();
    path
}

#[test]
fn simulate_then_fit_two_speeds_recovers_the_radius() {
    let dir = tempfile::tempdir().unwrap();
    let a = simulated(
        dir.path(),
        "a.csv",
        &["--rpm", "33.333", "--seed", "1", "--ideal"],
    );
    let b = simulated(dir.path(), "b.csv", &["--rpm", "45", "--seed", "2", "--ideal"]);
    let out = spincal()
        .args(["fit", "--json"])
        .arg(&a)
        .arg(&b)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let fit: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let radius = fit["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "radius")
        .unwrap();
    let (value, se) = (
        radius["value"].as_f64().unwrap(),
        radius["std_error"].as_f64().unwrap(),
    );
    assert!((value - 0.10).abs() < 4.0 * se, "{value} ± {se}");
    assert!(fit["undetermined"].as_array().unwrap().is_empty());
    // The truth sidecar is there and names the seed.
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("a.truth.json")).unwrap()).unwrap();
    assert_eq!(truth["seed"], 1);
}

#[test]
fn fit_table_prints_rotation_rate_and_remedy() {
    let dir = tempfile::tempdir().unwrap();
    let a = simulated(dir.path(), "a.csv", &["--seed", "3"]);
    let out = spincal().arg("fit").arg(&a).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("rotation from the spectrum: 33.5"), "{text}");
    assert!(text.contains("rad/s"), "{text}");
    assert!(text.contains("not determined"), "{text}");
    assert!(text.contains("--radius 0.10 --radius-tol 0.005"), "{text}");
}

#[test]
fn every_bad_input_gets_its_own_message() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let f = write(d, "word.csv", "t,ax,ay,az\n0,0,0,1\n0.01,x1,0,1\n");
    assert!(fit_error(&f, &[]).contains("word.csv:3, column 2 (ax): 'x1' is not a number"));
    let f = write(d, "nan.csv", "t,ax,ay,az\n0,0,0,1\n0.01,0,NaN,1\n");
    assert!(fit_error(&f, &[])
        .contains("nan.csv:3, column 3 (ay): the value is NaN; spincal needs finite numbers"));
    let f = write(d, "inf.csv", "t,ax,ay,az\n0,0,0,1\n0.01,0,0,-inf\n");
    assert!(fit_error(&f, &[])
        .contains("inf.csv:3, column 4 (az): the value is -inf; spincal needs finite numbers"));
    let f = write(d, "back.csv", "t,ax,ay,az\n0,0,0,1\n0.02,0,0,1\n0.01,0,0,1\n");
    assert!(fit_error(&f, &[]).contains("back.csv:4: time goes backwards (0.02 s, then 0.01 s)"));
    let f = write(d, "empty.csv", "");
    assert!(fit_error(&f, &[]).contains("empty.csv: the file is empty"));
    let f = write(d, "cut.csv", "t,ax,ay,az\n0,0,0,1\n0.01,0,0");
    assert!(
        fit_error(&f, &[]).contains("cut.csv: the last line (3) has no line ending and only 3 of 4 fields")
    );
    let short: String = (0..40).map(|i| format!("{},0,0,1\n", i as f64 * 0.01)).collect();
    let f = write(d, "short.csv", &format!("t,ax,ay,az\n{short}"));
    assert!(
        fit_error(&f, &[]).contains("short.csv: 40 samples are too few for a spectrum (need at least 64)")
    );
    // Two seconds at 33 rpm is about one turn.
    let f = simulated(d, "brief.csv", &["--duration", "2"]);
    let err = fit_error(&f, &["--rpm", "33.3"]);
    assert!(
        err.contains("brief.csv: only 1.1 rotations (the rate found within 10 % of the rpm given: "),
        "{err}"
    );
    assert!(
        err.contains("for 2.0 s); at least 3 are needed to fit the turntable"),
        "{err}"
    );
}

#[test]
fn gaps_and_saturation_are_reported_not_hidden() {
    let dir = tempfile::tempdir().unwrap();
    let src = simulated(dir.path(), "src.csv", &["--seed", "4"]);
    let text = std::fs::read_to_string(&src).unwrap();
    // Drop 50 rows (0.5 s) in the middle and clip three x samples at 5 g.
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines.drain(3000..3050);
    for line in lines.iter_mut().skip(100).take(3) {
        let mut fields: Vec<String> = line.split(',').map(String::from).collect();
        fields[1] = "5".into();
        *line = fields.join(",");
    }
    let f = write(dir.path(), "flawed.csv", &(lines.join("\n") + "\n"));
    let out = spincal()
        .arg("fit")
        .arg(&f)
        .args(["--range-g", "5"])
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("flawed.csv:3001: 1 gap(s) in time, the first of 0.5100 s"),
        "{text}"
    );
    assert!(
        text.contains("flawed.csv:101: 3 sample(s) of ax at the range limit 5.0000 g (saturated)"),
        "{text}"
    );
}

/// A 5-minute logging gap in the middle of a run (the platter's angle across it unknown): the fit
/// says where it cut the run and fits a phase per segment.
#[test]
fn a_logging_gap_cuts_the_run_and_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let src = simulated(dir.path(), "src.csv", &["--seed", "5"]);
    let text = std::fs::read_to_string(&src).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for line in lines.iter_mut().skip(3001) {
        let mut fields: Vec<String> = line.split(',').map(String::from).collect();
        fields[0] = format!("{:.4}", fields[0].parse::<f64>().unwrap() + 300.0);
        *line = fields.join(",");
    }
    let f = write(dir.path(), "gapped.csv", &(lines.join("\n") + "\n"));
    let out = spincal().arg("fit").arg(&f).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        text.contains("gapped.csv: cut at 1 gap (300.0 s after line 3001) into 2 segments"),
        "{text}"
    );
    assert!(text.contains("phase_segment2"), "{text}");
}

#[test]
fn contradicting_bounds_and_bad_flags_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let f = simulated(dir.path(), "a.csv", &["--duration", "20"]);
    let out = spincal()
        .arg("fit")
        .arg(&f)
        .args(["--bounds", "radius=0.2:0.1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("bounds for radius contradict each other: lower 0.2 > upper 0.1"),
        "{err}"
    );
    let out = spincal()
        .arg("fit")
        .arg(&f)
        .args(["--bounds", "wobble=0:1"])
        .output()
        .unwrap();
    assert!(String::from_utf8(out.stderr)
        .unwrap()
        .contains("no parameter is called 'wobble'"));
    let out = spincal()
        .arg("fit")
        .arg(&f)
        .args(["--axes", "yz"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(spincal().arg("fit").output().unwrap().status.code(), Some(2));
    assert_eq!(spincal().arg("--help").output().unwrap().status.code(), Some(0));
}

#[test]
fn sensitivity_prints_the_papers_table_1() {
    let out = spincal()
        .args([
            "sensitivity",
            "--radius",
            "0.10",
            "--tilt-deg",
            "5",
            "--omega",
            "3.49",
            "--gravity",
            "9.81",
        ])
        .args(["--vary", "15", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mean = |p: &str, c: f64| {
        rows.as_array()
            .unwrap()
            .iter()
            .find(|r| r["parameter"] == p && r["change_pct"].as_f64().unwrap() == c)
            .unwrap()["mean_ax_g"]
            .as_f64()
            .unwrap()
    };
    // The paper's printed values, within one unit of their last digit (its own rounding is loose:
    // 0.1056 matches g = 9.80, 0.1428 matches g = 9.81).
    assert!((mean("r", -15.0) - 0.1056).abs() <= 1e-4);
    assert!((mean("r", 15.0) - 0.1428).abs() <= 1e-4);
    assert!((mean("omega", 15.0) - 0.164).abs() <= 1e-3);
}

#[test]
fn a_closed_pipe_is_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let f = simulated(dir.path(), "a.csv", &["--duration", "20"]);
    let bin = assert_cmd::cargo::cargo_bin("spincal");
    // bash's PIPESTATUS gives the exit code of spincal, whose reader went away after 10 bytes.
    let status = std::process::Command::new("bash")
        .arg("-c")
        .arg(format!(
            "'{}' fit --json '{}' | head -c 10 >/dev/null; echo ${{PIPESTATUS[0]}}",
            bin.display(),
            f.display()
        ))
        .output()
        .unwrap();
    assert_eq!(String::from_utf8_lossy(&status.stdout).trim(), "0");
}

#[test]
fn compare_prints_table_2_and_writes_csv_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let a = simulated(
        dir.path(),
        "a.csv",
        &["--rpm", "33.333", "--seed", "5", "--duration", "40"],
    );
    let b = simulated(
        dir.path(),
        "b.csv",
        &["--rpm", "45", "--seed", "6", "--duration", "40"],
    );
    let csv = dir.path().join("table.csv");
    let common = [
        "--radius",
        "0.1",
        "--sweep",
        "none",
        "--hidden",
        "4",
        "--restarts",
        "1",
        "--arx",
        "4,4,1",
    ];
    let out = spincal()
        .arg("compare")
        .arg(&a)
        .arg(&b)
        .args(common)
        .arg("--csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    for model in ["uncorrected", "ANN", "linear", "ARX", "BJ", "NARX", "HW"] {
        assert!(
            text.lines().any(|l| l.starts_with(model)),
            "{model} missing:\n{text}"
        );
    }
    assert!(text.contains("ARX [na nb nk] = [4 4 1]"), "{text}");
    assert!(text.contains("cross-condition"), "{text}");
    let table = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(table.lines().count(), 8, "{table}");
    assert!(table.starts_with("model,structure,kind,train_fit_sim"));
    let out = spincal()
        .arg("compare")
        .arg(&a)
        .args(common)
        .arg("--json")
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = json["comparison"].as_array().unwrap();
    assert_eq!(rows.len(), 7);
    let bj = rows.iter().find(|r| r["model"] == "BJ").unwrap();
    assert!(
        bj["train_one_step"].is_object(),
        "dynamic models carry one-step scores: {bj}"
    );
    assert_eq!(
        spincal()
            .arg("compare")
            .arg(&a)
            .args(["--bj", "4,4"])
            .output()
            .unwrap()
            .status
            .code(),
        Some(2)
    );
}
