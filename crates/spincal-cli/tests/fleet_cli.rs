//! `spincal simulate --fleet` and `spincal fleet` from the outside, on the suite's one fleet
//! (`suite_fleet`, calibrated once by the library): the CLI writes the same units, a broken unit
//! is reported while the others are written (exit code 3), each unit's results equal the
//! library's calibration of it and `calibrate --campaign`'s, and every number of fleet.html is
//! read from fleet.json. The fleet's statistics and the faulty unit's flags are the library's
//! fleet test.

use assert_cmd::Command;

use crate::suite_fleet::{self, comparable_results, normalised, REFERENCE_UNITS};

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

#[test]
fn a_simulated_fleet_is_calibrated_and_a_broken_unit_is_reported_alone() {
    let stored = suite_fleet::suite_fleet();
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet");
    let run = spincal()
        .args(["simulate", "--fleet", "8", "--faulty"])
        .arg((suite_fleet::FAULTY + 1).to_string())
        .args(["--seed", &suite_fleet::SEED.to_string(), "--out"])
        .arg(&fleet)
        .arg("--setup")
        .arg(stored.setup_json())
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stdout).contains("faulty: unit-06"));
    // The CLI's fleet is the suite's fleet, file for file.
    let mut files = 0;
    for unit in stored.unit_names() {
        for name in crate::harness::listing(&stored.unit(&unit)) {
            let ours = std::fs::read(fleet.join(&unit).join(&name)).unwrap();
            assert!(
                ours == std::fs::read(stored.unit(&unit).join(&name)).unwrap(),
                "{unit}/{name}"
            );
            files += 1;
        }
    }
    assert!(files >= 8 * 5, "{files} files");
    assert_eq!(
        std::fs::read(fleet.join("fleet-truth.json")).unwrap(),
        std::fs::read(stored.units().join("fleet-truth.json")).unwrap()
    );

    // Writing the fleet again refuses and changes nothing.
    let again = spincal()
        .args(["simulate", "--fleet", "8", "--out"])
        .arg(&fleet)
        .output()
        .unwrap();
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));

    // A third unit with a recording missing.
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
        .args(REFERENCE_UNITS.map(|u| stored.unit(u)))
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
    assert!(stdout.contains("2 calibrated, 1 failed"), "{stdout}");
    for unit in REFERENCE_UNITS {
        let unit_dir = out.join(unit);
        assert!(unit_dir.join("report.html").exists(), "{unit}");
        // The library's calibration of the same unit, to the byte.
        let results = std::fs::read_to_string(unit_dir.join("results.json")).unwrap();
        assert!(
            comparable_results(&normalised(&results, &stored.units())) == stored.results(unit),
            "{unit}: results.json differs from the library's"
        );
        let model = std::fs::read_to_string(unit_dir.join("model.json")).ok();
        assert_eq!(
            model.map(|m| normalised(&m, &stored.units())),
            stored.model(unit),
            "{unit}"
        );
    }
    assert!(!out.join("broken").exists());

    let csv = std::fs::read_to_string(out.join("fleet.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4, "{csv}");
    assert!(
        lines[0].starts_with("unit,source,status,saved,held_out_rms (m/s²),bias_x (m/s²),bias_x SE (m/s²)")
    );
    assert!(
        lines[3].starts_with("broken,") && lines[3].contains(",failed,"),
        "{}",
        lines[3]
    );

    // Two units are too few to judge outliers: nothing is flagged, and fleet.json says so.
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fleet.json")).unwrap()).unwrap();
    assert!(table["rows"]
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r["flags"].as_array().unwrap().is_empty()));
    let stats = table["stats"]
        .as_array()
        .expect("fleet.json has each parameter's statistics");
    assert!(
        !stats.is_empty() && stats.iter().all(|p| p["judged"] == false),
        "{stdout}"
    );

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
    assert!(checked > 2 * 24, "only {checked} numbers tied to fleet.json");
    assert!(html.contains("<svg"), "no plots");

    // The faulty unit alone: `calibrate --campaign` gives the fleet's results.
    let alone = dir.path().join("alone");
    let run = spincal()
        .args(["calibrate", "--campaign"])
        .arg(stored.unit("unit-06").join("campaign.toml"))
        .arg("--out")
        .arg(&alone)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let a = std::fs::read_to_string(alone.join("results.json")).unwrap();
    let b = std::fs::read_to_string(out.join("unit-06").join("results.json")).unwrap();
    assert!(
        comparable_results(&a) == comparable_results(&b),
        "results.json differs"
    );
    assert_eq!(
        std::fs::read(alone.join("model.json")).ok(),
        std::fs::read(out.join("unit-06").join("model.json")).ok()
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
