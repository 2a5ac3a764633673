//! `spincal train` / `correct` end to end through the real binary.

use crate::common::write_pair;
use std::path::Path;

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// `spincal correct --model MODEL INPUT -o OUTPUT`, which must succeed; returns its standard error.
fn correct_ok(model: &Path, input: &Path, output: &Path) -> String {
    let out = spincal()
        .args(["correct", "--model"])
        .arg(model)
        .arg(input)
        .arg("-o")
        .arg(output)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn train_then_correct_streams_every_row_with_validity() {
    let dir = tempfile::tempdir().unwrap();
    let (m, r) = write_pair(dir.path(), 800);
    let model = dir.path().join("ann.json");
    let out = spincal()
        .args([
            "train",
            "--data",
            &m,
            "--reference",
            &r,
            "--hidden",
            "4",
            "--delays",
            "2",
        ])
        .args(["--restarts", "2", "--max-epochs", "50", "--json", "-o"])
        .arg(&model)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["kind"], "ann");
    assert!(
        summary["fits"]["test"][0].as_f64().unwrap() > summary["uncorrected"]["test"][0].as_f64().unwrap()
    );

    let corrected = dir.path().join("corrected.csv");
    let stderr = correct_ok(&model, Path::new(&m), &corrected);
    assert!(
        !stderr.contains("warning"),
        "the training recording is in range: {stderr}"
    );
    let text = std::fs::read_to_string(&corrected).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "t,ax,ay,az,ax_corrected_mps2,ay_corrected_mps2,valid,status"
    );
    assert_eq!(lines.len(), 801, "every input row comes out");
    assert!(lines[1..].iter().all(|l| l.ends_with(",ok")));
    let valid: Vec<&str> = lines[1..].iter().map(|l| l.rsplit(',').nth(1).unwrap()).collect();
    assert_eq!(&valid[..3], &["0", "0", "1"]);
    assert!(valid[2..].iter().all(|v| *v == "1"));

    // Three times the x acceleration (another turntable speed, say): still every row out, and a
    // warning that counts the rows the network extrapolates and names the first.
    let mut louder = String::from("t,ax,ay,az\n");
    for row in std::fs::read_to_string(&m).unwrap().lines().skip(1) {
        let v: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        louder += &format!("{},{},{},{}\n", v[0], 3.0 * v[1], v[2], v[3]);
    }
    let loud = dir.path().join("loud.csv");
    std::fs::write(&loud, louder).unwrap();
    let stderr = correct_ok(&model, &loud, &corrected);
    assert!(
        stderr.contains("warning: ")
            && stderr.contains("loud.csv: ")
            && stderr.contains("of 800 rows")
            && stderr.contains("first at line 2"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&corrected).unwrap().lines().count(), 801);
}

#[test]
fn correct_writes_a_bad_row_in_place_with_its_reason_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let (m, r) = write_pair(dir.path(), 300);
    let model = dir.path().join("linear.json");
    spincal()
        .args(["train", "--kind", "linear", "--data", &m, "--reference", &r, "-o"])
        .arg(&model)
        .assert()
        .success();
    let mut text = std::fs::read_to_string(&m).unwrap();
    text = text.replacen("\n0.5,", "\n0.5,oops,", 1);
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, text).unwrap();
    let out_path = dir.path().join("out.csv");
    let out = spincal()
        .args(["correct", "--model"])
        .arg(&model)
        .arg(&bad)
        .arg("-o")
        .arg(&out_path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("1 of 300 rows refused") && stderr.contains("bad.csv:52"),
        "{stderr}"
    );
    let written = std::fs::read_to_string(&out_path).unwrap();
    let lines: Vec<&str> = written.lines().collect();
    assert_eq!(lines.len(), 301, "every input row comes out");
    assert!(lines[0].ends_with(",valid,status"), "{}", lines[0]);
    let refused: Vec<&&str> = lines.iter().filter(|l| l.contains("refused: line 52")).collect();
    assert_eq!(refused.len(), 1, "{written}");
    assert!(
        refused[0].starts_with("0.5,oops,"),
        "the row comes out in place: {}",
        refused[0]
    );
    assert_eq!(lines.iter().filter(|l| l.ends_with(",1,ok")).count(), 299);
    // A refused row breaks no later row: the one after it is corrected.
    let at = lines.iter().position(|l| l.contains("refused")).unwrap();
    assert!(lines[at + 1].ends_with(",ok"), "{}", lines[at + 1]);

    // A model file from another format version is refused by name.
    let future = std::fs::read_to_string(&model).unwrap().replacen(
        "\"format_version\": 4",
        "\"format_version\": 9",
        1,
    );
    let future_path = dir.path().join("future.json");
    std::fs::write(&future_path, future).unwrap();
    let out = spincal()
        .args(["correct", "--model"])
        .arg(&future_path)
        .arg(&m)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("future.json") && stderr.contains("format_version 9"),
        "{stderr}"
    );
}
