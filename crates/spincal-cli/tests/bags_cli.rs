//! Black-box tests of reading ROS bags: bags written by the `rosbags` Python package
//! (scripts/make_bag_fixtures.py, in the test venv) from a `spincal simulate` CSV.

use std::path::{Path, PathBuf};
use std::process::Command as StdCommand;

use assert_cmd::Command;

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// The test venv's python; its absence skips (printed) or, with SPINCAL_REQUIRE_PYTHON=1, fails.
fn venv_python() -> Option<PathBuf> {
    let python = Path::new(REPO).join(".venv/bin/python");
    if python.is_file() {
        return Some(python);
    }
    let why = format!("{} is absent: run `bash scripts/setup.sh`", python.display());
    if std::env::var("SPINCAL_REQUIRE_PYTHON").is_ok_and(|v| v == "1") {
        panic!("SPINCAL_REQUIRE_PYTHON=1: {why}");
    }
    eprintln!("skipped: {why}");
    None
}

fn stdout(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The lines of `spincal fit` that carry the rates.
fn rate_lines(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| l.contains("rotation from the spectrum") || l.contains("fitted ω"))
        .map(|l| l.trim().to_string())
        .collect()
}

#[test]
fn bags_read_inspect_and_fit_like_their_csv() {
    let Some(python) = venv_python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    spincal()
        .args(["simulate", "--duration", "30", "-o"])
        .arg(&csv)
        .assert()
        .success();
    let bags = dir.path().join("bags");
    let status = StdCommand::new(python)
        .arg(Path::new(REPO).join("scripts/make_bag_fixtures.py"))
        .arg(&csv)
        .arg(&bags)
        .status()
        .unwrap();
    assert!(status.success());

    let fit_csv = rate_lines(&stdout(spincal().arg("fit").arg(&csv)));
    assert_eq!(fit_csv.len(), 2, "{fit_csv:?}");
    for bag in ["mcap", "sqlite3", "ros1_bz2.bag"] {
        let path = bags.join(bag);
        let text = stdout(spincal().arg("inspect").arg(&path));
        for want in [
            "format: rosbag (detected:",
            "samples: 3000",
            "gyro: no",
            "metadata: topic: /imu (sensor_msgs",
            "metadata: frame_id: imu_link",
            "metadata: storage: ROS",
        ] {
            assert!(text.contains(want), "{bag}: no '{want}' in\n{text}");
        }
        let fit_bag = rate_lines(&stdout(spincal().arg("fit").arg(&path)));
        assert_eq!(fit_bag, fit_csv, "{bag}");
    }

    // Two IMU topics: listed with counts (exit 1), then chosen with --topic.
    let two = bags.join("two_imus_mcap");
    let out = spincal().arg("inspect").arg(&two).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("2 IMU topics; choose one as `--topic`: /imu (sensor_msgs/msg/Imu, 3000 messages); /imu_b (sensor_msgs/msg/Imu, 3000 messages)"),
        "{err}"
    );
    let text = stdout(spincal().arg("inspect").arg(&two).args(["--topic", "/imu_b"]));
    assert!(text.contains("metadata: topic: /imu_b"), "{text}");
    let out = spincal()
        .arg("inspect")
        .arg(&two)
        .args(["--topic", "/nope"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no IMU topic '/nope'"));
}
