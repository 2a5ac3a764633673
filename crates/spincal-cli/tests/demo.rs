//! `spincal demo` end to end: the files, the numbers in results.json, the report in a real browser,
//! and every number shown in the report equal to the one in results.json.

use crate::support;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use serde_json::Value;

/// The suite's one demo run (`support::demo`): its output folder and results.json.
fn run_demo() -> (PathBuf, Value) {
    let (dir, stdout) = support::demo();
    assert!(stdout.contains("report.html"), "{stdout}");
    let dir = dir.join("spincal-demo");
    let results = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    (dir, results)
}

fn param(results: &Value, name: &str) -> (f64, f64) {
    let p = results["paper"]["turntable"]["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("no parameter {name}"));
    (
        p["value"].as_f64().unwrap(),
        p["std_error"].as_f64().unwrap_or(f64::NAN),
    )
}

fn row<'a>(results: &'a Value, table: &str, model: &str) -> &'a Value {
    results["paper"][table]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["model"] == model)
        .unwrap()
}

/// One demo run serves all checks (it is the expensive part).
#[test]
fn demo_writes_model_results_and_a_report_that_renders() {
    let (dir, results) = run_demo();
    let d = dir.as_path();
    for file in [
        "results.json",
        "report.html",
        "rec33.csv",
        "rec45.csv",
        "rec33.truth.json",
    ] {
        assert!(d.join(file).exists(), "{file} missing");
    }

    // The third part: a phone's zips calibrated with no radius stated; each placement's chip
    // radius within 2 mm of the simulation's truth, and the terminal says so beside the truth.
    let phone_truth: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("phone/truth.json")).unwrap()).unwrap();
    let phone: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("phone-calibration/results.json")).unwrap())
            .unwrap();
    for t in phone_truth["placements"].as_array().unwrap() {
        let fitted = phone["placements"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["label"] == t["label"])
            .unwrap();
        let error = fitted["radius_m"].as_f64().unwrap() - t["chip_radius_m"].as_f64().unwrap();
        assert!(error.abs() < 2e-3, "placement {}: {error} m", t["label"]);
    }
    let stdout = &support::demo().1;
    assert!(
        stdout.contains("A phone on the record player") && stdout.contains("placement A: chip at"),
        "{stdout}"
    );
    // Turntable parameters recovered: ω against the simulator's truth, the radius against 10 cm.
    for (k, name) in ["rec33", "rec45"].iter().enumerate() {
        let truth: Value =
            serde_json::from_str(&std::fs::read_to_string(d.join(format!("{name}.truth.json"))).unwrap())
                .unwrap();
        let true_omega = truth["session"]["omega_radps"].as_f64().unwrap();
        let (omega, _) = param(&results, &format!("omega[{}]", k + 1));
        assert!(
            (omega / true_omega - 1.0).abs() < 1e-3,
            "{name}: ω {omega} vs {true_omega}"
        );
    }
    let (radius, _) = param(&results, "radius");
    assert!((radius - 0.10).abs() < 0.003, "radius {radius}");
    // Two turntable recordings alone, each held out in turn, determine no sensor parameter well
    // enough to trust a correction: nothing is saved, first in the verdict, with what to record
    // next; the campaign part saves.
    let verdict = results["verdict"].as_str().unwrap();
    assert!(results["saved"].is_null() && !d.join("model.json").exists());
    assert!(
        verdict.starts_with("Nothing saved") && verdict.contains("Record next"),
        "{verdict}"
    );
    assert!(d.join("campaign-calibration/model.json").exists());
    assert!(results["paper"]["turntable"]["undetermined"]
        .as_array()
        .unwrap()
        .is_empty());

    // Correction helps, and the network beats the linear corrector on the test part.
    let test_fit = |model: &str| {
        row(&results, "comparison", model)["test"]["fit_percent_mean"]
            .as_f64()
            .unwrap()
    };
    assert!(
        test_fit("ANN") > test_fit("linear"),
        "ANN {} vs linear {}",
        test_fit("ANN"),
        test_fit("linear")
    );
    assert!(test_fit("linear") > test_fit("uncorrected"));
    // The choice is made on validation, never on test.
    let chosen = results["paper"]["best_on_validation"].as_str().unwrap();
    let validation = |model: &str| {
        row(&results, "comparison", model)["validation"]["fit_percent_mean"]
            .as_f64()
            .unwrap()
    };
    assert!(["ANN", "linear"]
        .iter()
        .all(|m| validation(chosen) >= validation(m)));
    // ARX on a pure-sine reference reproduces it without its input: the row says so, and such a
    // row is not "best overall" however high its fit.
    let arx = row(&results, "comparison", "ARX");
    assert!(
        arx["warnings"].as_array().is_some_and(|w| !w.is_empty()
            && w.iter().all(|m| m.as_str().unwrap().contains("held constant"))),
        "{arx}"
    );
    let best = row(
        &results,
        "comparison",
        results["paper"]["best_overall"].as_str().unwrap(),
    );
    assert!(best.get("warnings").is_none(), "{best}");
    // The cross-condition check ran on the 45 rpm recording for every corrector.
    let cross = results["paper"]["cross_condition"].as_array().unwrap();
    assert!(cross
        .iter()
        .any(|c| c["model"] == "ANN" && c["tested_on"] == "rec45.csv"));
    assert!(cross.iter().any(|c| c["model"] == "linear"));
    // At 45 rpm the centripetal level moves the inputs out of what the network saw at 33⅓ rpm;
    // the row says so, and only the network's row carries the share.
    let ann = cross.iter().find(|c| c["model"] == "ANN").unwrap();
    assert!(
        ann["outside_training_range_percent"].as_f64().unwrap() > 50.0,
        "{ann}"
    );
    assert!(cross
        .iter()
        .filter(|c| c["model"] != "ANN")
        .all(|c| c.get("outside_training_range_percent").is_none()));

    // The campaign's saved model applies to new data through `spincal correct`.
    let corrected = d.join("corrected.csv");
    Command::cargo_bin("spincal")
        .unwrap()
        .args(["correct", "--model"])
        .arg(d.join("campaign-calibration/model.json"))
        .arg(d.join("rec45.csv"))
        .arg("-o")
        .arg(&corrected)
        .assert()
        .success();
    let rows = std::fs::read_to_string(&corrected).unwrap().lines().count();
    let input_rows = std::fs::read_to_string(d.join("rec45.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, input_rows, "every input row comes out");

    // Every number shown in the report is the one in results.json (times data-scale where the
    // page shows it in other units, e.g. degrees for an angle stored in rad).
    let html = std::fs::read_to_string(d.join("report.html")).unwrap();
    let mut checked = 0;
    let mut scaled = 0;
    for piece in html.split("data-json=\"").skip(1) {
        let (pointer, rest) = piece.split_once('"').unwrap();
        let (tag, after) = rest.split_once('>').unwrap();
        let attribute = |name: &str| {
            tag.split(&format!("{name}=\"")[..])
                .nth(1)
                .map(|v| v.split('"').next().unwrap())
        };
        let digits: usize = attribute("data-digits").unwrap().parse().unwrap();
        let scale: f64 = attribute("data-scale").map_or(1.0, |s| {
            scaled += 1;
            s.parse().unwrap()
        });
        let shown = after.split('<').next().unwrap();
        let value = results
            .pointer(pointer)
            .unwrap_or_else(|| panic!("{pointer} not in results.json"));
        let expected = match value.as_f64().map(|v| v * scale) {
            Some(v) if v.is_finite() => format!("{v:.digits$}"),
            _ => "—".to_string(),
        };
        assert_eq!(shown, expected, "{pointer}");
        checked += 1;
    }
    assert!(checked > 100, "only {checked} numbers are tied to results.json");
    assert!(scaled > 0, "no converted number (data-scale) was checked");
    // Angles in degrees and drift in g, as `spincal fit` prints them; no Rust enum names.
    let tilt_row = html
        .split("<td>tilt[1]</td>")
        .nth(1)
        .unwrap()
        .split("</tr>")
        .next()
        .unwrap();
    assert!(tilt_row.contains("<td>deg</td>"), "{tilt_row}");
    let drift_row = html
        .split("<td>drift_x[1]</td>")
        .nth(1)
        .unwrap()
        .split("</tr>")
        .next()
        .unwrap();
    assert!(drift_row.contains("g over the recording"), "{drift_row}");
    for debug_name in ["Cw<", "Ccw<", "NoProgress", "Contiguous", "Some(", "None<"] {
        assert!(!html.contains(debug_name), "{debug_name} reached the report");
    }

    // The report renders in a real browser with every plot drawn.
    if support::chromium().is_none() {
        return;
    }
    let screenshots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot");
    std::fs::create_dir_all(&screenshots).unwrap();
    let page = support::render(&d.join("report.html"), &screenshots).unwrap();
    eprintln!("report screenshot: {}", page.screenshot.display());
    assert!(page.console_errors.is_empty(), "{:?}", page.console_errors);
    assert_eq!(page.empty_svgs(), 0);
    assert!(page.svg_count() >= 10, "{} plots", page.svg_count());
    assert!(std::fs::metadata(&page.screenshot).unwrap().len() > 50_000);
}
