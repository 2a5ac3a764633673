//! `spincal strobe` end to end: files, text, JSON, exit codes.

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

#[test]
fn json_names_the_file_and_bar_counts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.svg");
    let run = spincal()
        .args([
            "strobe", "--rpm", "100/3", "--rpm", "45", "--mains", "60", "--json", "-o",
        ])
        .arg(&out)
        .assert()
        .success();
    let json: serde_json::Value = serde_json::from_slice(&run.get_output().stdout).unwrap();
    assert_eq!(json["output"], out.display().to_string());
    assert_eq!(json["rings"][0]["bars"], 216);
    assert_eq!(json["rings"][1]["bars"], 160);
    assert_eq!(json["rings"][1]["exact"], true);
    let svg = std::fs::read_to_string(&out).unwrap();
    assert_eq!(svg.matches("class=\"bar\"").count(), 216 + 160);
}

#[test]
fn non_integer_bars_are_reported_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.svg");
    let run = spincal()
        .args(["strobe", "--rpm", "45", "-o"])
        .arg(&out)
        .assert()
        .success();
    let text = String::from_utf8(run.get_output().stdout.clone()).unwrap();
    assert!(
        text.contains("133 bars (exactly 133.3333 needed; 133 bars stand still at 45.1128 rpm, +0.251 %)"),
        "{text}"
    );
    let run = spincal()
        .args(["strobe", "--rpm", "45", "--exact", "-o"])
        .arg(dir.path().join("e.svg"))
        .assert()
        .code(1);
    assert!(String::from_utf8_lossy(&run.get_output().stderr).contains("not an integer"));
    assert!(!dir.path().join("e.svg").exists());
    spincal().args(["strobe", "--rpm", "fast"]).assert().code(2);
    spincal()
        .args(["strobe", "--rpm", "45", "--diameter-mm", "20", "-o"])
        .arg(&out)
        .assert()
        .code(2);
}
