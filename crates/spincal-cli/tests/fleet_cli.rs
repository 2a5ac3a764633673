//! `spincal simulate --fleet` and `spincal fleet` from the outside: files per unit and for the
//! fleet, a broken unit reported while the others are written (exit code 3), the faulty unit
//! flagged, a unit's results equal to `calibrate --campaign`'s, and every number of fleet.html
//! read from fleet.json.

use assert_cmd::Command;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

fn without_time(text: &str) -> serde_json::Value {
    let mut value: serde_json::Value = serde_json::from_str(text).unwrap();
    value.as_object_mut().unwrap().remove("seconds_total");
    value.as_object_mut().unwrap().remove("stage_seconds");
    value
}

#[test]
fn a_simulated_fleet_is_calibrated_and_a_broken_unit_is_reported_alone() {
    let dir = tempfile::tempdir().unwrap();
    let setup = crate::harness::short_campaign_setup(dir.path());
    let fleet = dir.path().join("fleet");
    let run = spincal()
        .args([
            "simulate", "--fleet", "8", "--faulty", "2", "--seed", "11", "--out",
        ])
        .arg(&fleet)
        .arg("--setup")
        .arg(&setup)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stdout).contains("faulty: unit-02"));
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fleet.join("fleet-truth.json")).unwrap()).unwrap();
    assert_eq!(truth["units"].as_array().unwrap().len(), 8);
    assert_eq!(truth["units"][1]["faulty"], true);

    // Writing the fleet again refuses and changes nothing.
    let again = spincal()
        .args(["simulate", "--fleet", "8", "--out"])
        .arg(&fleet)
        .output()
        .unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));

    // A ninth unit with a recording missing.
    let broken = dir.path().join("broken");
    std::fs::create_dir(&broken).unwrap();
    for name in crate::harness::listing(&fleet.join("unit-01")) {
        let path = fleet.join("unit-01").join(name);
        std::fs::copy(&path, broken.join(path.file_name().unwrap())).unwrap();
    }
    std::fs::remove_file(broken.join("still-poses.csv")).unwrap();

    let out = dir.path().join("cal");
    let run = spincal()
        .arg("fleet")
        .arg(&fleet)
        .arg(&broken)
        .arg("--out")
        .arg(&out)
        .args(["--threads", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(3), "{stderr}\n{stdout}");
    assert!(
        stderr.contains("broken") && stderr.contains("still-poses.csv"),
        "{stderr}"
    );
    assert!(stdout.contains("8 calibrated, 1 failed"), "{stdout}");
    for unit in 1..=8 {
        let unit_dir = out.join(format!("unit-{unit:02}"));
        assert!(unit_dir.join("results.json").exists(), "unit-{unit:02}");
        assert!(unit_dir.join("report.html").exists(), "unit-{unit:02}");
    }
    assert!(!out.join("broken").exists());

    let csv = std::fs::read_to_string(out.join("fleet.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 10, "{csv}");
    assert!(
        lines[0].starts_with("unit,source,status,saved,held_out_rms (m/s²),bias_x (m/s²),bias_x SE (m/s²)")
    );
    assert!(
        lines[9].starts_with("broken,") && lines[9].contains(",failed,"),
        "{}",
        lines[9]
    );

    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fleet.json")).unwrap()).unwrap();
    let flagged: Vec<&str> = table["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| !r["flags"].as_array().unwrap().is_empty())
        .map(|r| r["unit"].as_str().unwrap())
        .collect();
    assert_eq!(flagged, ["unit-02"], "{stdout}");

    // Every number in fleet.html is the one at its pointer in fleet.json.
    let html = std::fs::read_to_string(out.join("fleet.html")).unwrap();
    let mut checked = 0;
    for piece in html.split("<span data-json=\"").skip(1) {
        let (pointer, rest) = piece.split_once('"').unwrap();
        let shown = rest.split_once('>').unwrap().1.split_once('<').unwrap().0;
        let value = table.pointer(pointer).unwrap_or_else(|| panic!("{pointer}"));
        let expected = value.as_f64().unwrap_or_else(|| panic!("{pointer}: {value}"));
        if pointer.ends_with("units_ok") || pointer.ends_with("units_failed") {
            assert_eq!(shown, format!("{expected}"), "{pointer}");
        } else {
            assert_eq!(shown, format!("{expected:.6e}"), "{pointer}");
        }
        checked += 1;
    }
    assert!(checked > 8 * 24, "only {checked} numbers tied to fleet.json");
    assert!(html.contains("<svg"), "no plots");

    // One unit of the fleet equals `calibrate --campaign` on the same campaign.
    let alone = dir.path().join("alone");
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(fleet.join("unit-02").join("campaign.toml"))
        .arg("--out")
        .arg(&alone)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let a = std::fs::read_to_string(alone.join("results.json")).unwrap();
    let b = std::fs::read_to_string(out.join("unit-02").join("results.json")).unwrap();
    assert!(without_time(&a) == without_time(&b), "results.json differs");
    assert_eq!(
        std::fs::read(alone.join("model.json")).ok(),
        std::fs::read(out.join("unit-02").join("model.json")).ok()
    );
}

#[test]
fn nothing_calibrated_is_exit_1_and_bad_usage_is_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let run = spincal()
        .arg("fleet")
        .arg(&empty)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("must hold campaign.toml"), "{stderr}");
    // The failure is still in the table.
    let csv = std::fs::read_to_string(dir.path().join("out").join("fleet.csv")).unwrap();
    assert!(csv.lines().nth(1).unwrap().starts_with("empty,"), "{csv}");

    let run = spincal()
        .args(["simulate", "--fleet", "3", "--faulty", "4", "--out"])
        .arg(dir.path().join("f"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("--faulty 4"));
    let run = spincal()
        .args(["fleet", "x", "--out", "o", "--threads", "0"])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
}
