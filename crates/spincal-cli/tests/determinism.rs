//! results.json and model.json are the same, bit for bit, whatever the number of threads: every
//! kernel sums in a fixed order and factorisations run sequentially inside each parallel task.

use assert_cmd::Command;
use serde_json::Value;

fn spincal() -> Command {
    Command::cargo_bin("spincal").unwrap()
}

/// The document without its timings (the only values allowed to differ).
fn without_timings(value: &mut Value) {
    match value {
        Value::Object(map) => {
            map.retain(|key, _| !key.contains("seconds"));
            map.values_mut().for_each(without_timings);
        }
        Value::Array(items) => items.iter_mut().for_each(without_timings),
        _ => {}
    }
}

#[test]
fn calibration_results_are_identical_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path();
    for (name, rpm, seed) in [("a.csv", "33.333", "4"), ("b.csv", "45", "5")] {
        spincal()
            .current_dir(work)
            .args([
                "simulate",
                "--quiet",
                "--duration",
                "15",
                "-o",
                name,
                "--rpm",
                rpm,
                "--seed",
                seed,
            ])
            .assert()
            .success();
    }
    let mut results = Vec::new();
    let mut models = Vec::new();
    for threads in ["1", "2"] {
        let out = format!("cal{threads}");
        spincal()
            .current_dir(work)
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "calibrate",
                "a.csv",
                "b.csv",
                "--radius",
                "0.1",
                "--restarts",
                "2",
                "--quiet",
                "--out",
                &out,
            ])
            .assert()
            .success();
        let mut json: Value =
            serde_json::from_str(&std::fs::read_to_string(work.join(&out).join("results.json")).unwrap())
                .unwrap();
        without_timings(&mut json);
        results.push(json);
        models.push(std::fs::read(work.join(&out).join("model.json")).ok());
    }
    // Every model of the paper's comparison, the sweep and the turntable fit are in there, and
    // every candidate on every held-out condition.
    let rows = results[0]["paper"]["comparison"].as_array().unwrap().len();
    assert!(rows >= 6, "{rows} comparison rows");
    let held_out = results[0]["held_out"].as_array().unwrap().len();
    assert!(held_out >= 10, "{held_out} held-out scores");
    assert_eq!(
        results[0], results[1],
        "results.json differs between 1 and 2 threads"
    );
    assert_eq!(models[0], models[1], "model.json differs between 1 and 2 threads");
}

/// A campaign's held-out conditions run in parallel; results.json and model.json do not depend
/// on how many threads ran them.
#[test]
fn campaign_results_are_identical_across_thread_counts() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path();
    spincal()
        .current_dir(work)
        .args(["simulate", "--quiet", "--seed", "6", "--campaign", "unit"])
        .assert()
        .success();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = format!("cal{threads}");
        spincal()
            .current_dir(work)
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "calibrate",
                "--quiet",
                "--campaign",
                "unit/campaign.toml",
                "--out",
                &out,
            ])
            .assert()
            .success();
        let mut results: Value =
            serde_json::from_str(&std::fs::read_to_string(work.join(&out).join("results.json")).unwrap())
                .unwrap();
        without_timings(&mut results);
        let model = std::fs::read(work.join(&out).join("model.json")).ok();
        outputs.push((results, model));
    }
    assert_eq!(outputs[0].0, outputs[1].0);
    assert_eq!(outputs[0].1, outputs[1].1);
}
