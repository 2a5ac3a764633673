//! The README's phone recipe, run as written: the commands between its `phone-recipe` markers,
//! from the zips to a corrected file, then the chip's radius held against the simulation's truth
//! and the corrected still pose against gravity. Once as phyphox zips (the recipe as written), once
//! as Sensor Logger zips (`simulate --setup` naming the app, with shorter runs).

use std::path::Path;
use std::process::Command;

use serde_json::Value;

/// The README's commands between `<!-- phone-recipe -->` and `<!-- /phone-recipe -->`: each line
/// of the fenced block that starts with `spincal`, its trailing `# comment` removed, as words.
fn recipe() -> Vec<Vec<String>> {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md")).unwrap();
    let (_, rest) = readme
        .split_once("<!-- phone-recipe -->")
        .expect("the README's phone recipe marker");
    let (block, _) = rest
        .split_once("<!-- /phone-recipe -->")
        .expect("the README's phone recipe end marker");
    block
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("spincal "))
        .map(|l| {
            l.split_once(" #")
                .map_or(l, |(command, _)| command)
                .split_whitespace()
                .map(String::from)
                .collect()
        })
        .collect()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
        .unwrap()
}

#[test]
fn the_readme_phone_recipe_runs_from_the_zips_to_a_corrected_file() {
    run_recipe(None);
}

/// The same recipe on Sensor Logger zips: `simulate` also takes a PhoneSetup naming the app, its
/// runs 20 s (the default 30 s) to keep the test short.
#[test]
fn the_readme_phone_recipe_runs_from_sensor_logger_zips() {
    run_recipe(Some(r#"{"app": "sensor-logger", "run_s": 20.0}"#));
}

/// Runs the README's recipe in a fresh folder, `simulate` given `setup` (PhoneSetup JSON) when
/// some, and holds the results against the truth.
fn run_recipe(setup: Option<&str>) {
    let commands = recipe();
    assert!(
        (3..=5).contains(&commands.len()),
        "the phone recipe is at most five commands: {commands:?}"
    );
    let dir = tempfile::tempdir().unwrap();
    if let Some(setup) = setup {
        std::fs::write(dir.path().join("setup.json"), setup).unwrap();
    }
    for words in &commands {
        let mut command = Command::new(env!("CARGO_BIN_EXE_spincal"));
        command.current_dir(dir.path()).args(&words[1..]).arg("--quiet");
        if setup.is_some() && words[1] == "simulate" {
            command.args(["--setup", "setup.json"]);
        }
        let out = command.output().unwrap();
        assert!(
            out.status.success(),
            "`{}` exited with {:?}:\n{}\n{}",
            words.join(" "),
            out.status.code(),
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // The recipe's own names: the session's folder, the calibration's and the corrected file.
    let word_after = |command: &str, flag: &str| {
        let words = commands
            .iter()
            .find(|w| w[1] == command)
            .unwrap_or_else(|| panic!("no `spincal {command}` in the recipe"));
        let at = words
            .iter()
            .position(|w| w == flag)
            .unwrap_or_else(|| panic!("no {flag}"));
        dir.path().join(&words[at + 1])
    };
    let session = word_after("simulate", "--phone");
    let calibration = word_after("calibrate", "--out");
    let corrected = word_after("correct", "-o");
    let truth = json(&session.join("truth.json"));
    if setup.is_some() {
        let listing: Vec<String> = std::fs::read_dir(&session)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        let zip = std::fs::read(session.join("pose-01.zip")).unwrap();
        let names = String::from_utf8_lossy(&zip);
        assert!(
            names.contains("TotalAcceleration.csv"),
            "a Sensor Logger zip: {listing:?}"
        );
    }
    let results = json(&calibration.join("results.json"));

    // The chip's radius from the runs alone (no radius stated), within 2 mm and 3 standard
    // errors of the truth in each placement.
    let campaign = std::fs::read_to_string(session.join("campaign.toml")).unwrap();
    assert!(!campaign.contains("radius_m"), "{campaign}");
    let fitted = results["placements"].as_array().unwrap();
    let truths = truth["placements"].as_array().unwrap();
    assert_eq!(fitted.len(), truths.len());
    for t in truths {
        let f = fitted.iter().find(|f| f["label"] == t["label"]).unwrap();
        let (value, se, true_m) = (
            f["radius_m"].as_f64().unwrap(),
            f["radius_se_m"].as_f64().unwrap(),
            t["chip_radius_m"].as_f64().unwrap(),
        );
        assert!(
            (value - true_m).abs() < 2e-3 && (value - true_m).abs() < 3.0 * se,
            "placement {}: {value} ± {se} m, true {true_m} m",
            t["label"]
        );
    }
    assert!(calibration.join("model.json").exists(), "{}", results["verdict"]);

    // The corrected file: every sample of the still pose, corrected towards gravity's magnitude.
    let text = std::fs::read_to_string(&corrected).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no {name} in {header:?}"))
    };
    let raw = ["ax_mps2", "ay_mps2", "az_mps2"].map(column);
    let fixed = ["ax_corrected_mps2", "ay_corrected_mps2", "az_corrected_mps2"].map(column);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    assert!(rows.len() > 200, "{} rows", rows.len());
    let g = 9.80665;
    let mean_norm = |cols: [usize; 3]| {
        rows.iter()
            .map(|r| cols.iter().map(|&c| r[c] * r[c]).sum::<f64>().sqrt())
            .sum::<f64>()
            / rows.len() as f64
    };
    let (before, after) = ((mean_norm(raw) - g).abs(), (mean_norm(fixed) - g).abs());
    assert!(
        after < 0.02 && after < before,
        "|a| − g: {before} before, {after} after"
    );
}
