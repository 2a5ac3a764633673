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
    let mut printed = Vec::new();
    for threads in ["1", "2"] {
        let out = format!("cal{threads}");
        // The second run also prints the tables (the first gives a default, to keep one argument
        // list): they change what is printed, nothing else.
        let tables = if threads == "2" { "--tables" } else { "--seed=1" };
        let run = spincal()
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
                tables,
                "--out",
                &out,
            ])
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        printed.push(String::from_utf8(run.stdout).unwrap().replace(&out, "OUT"));
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
    assert_printed_tables_only_with_the_flag(
        &printed,
        &[HELD_OUT_TABLE, "the paper's protocol", "best on validation"],
    );
    // Recordings at the working directory's top: the unit is that folder's name, made safe (a
    // temporary folder's leading dot dropped).
    let folder = work.canonicalize().unwrap();
    let folder = folder.file_name().unwrap().to_string_lossy();
    assert_eq!(results[0]["unit"], folder.trim_start_matches('.'), "{folder}");
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
    let mut printed = Vec::new();
    for threads in ["1", "2"] {
        let out = format!("cal{threads}");
        let tables = if threads == "2" { "--tables" } else { "--seed=1" };
        let run = spincal()
            .current_dir(work)
            .env("RAYON_NUM_THREADS", threads)
            .args([
                "calibrate",
                "--quiet",
                tables,
                "--campaign",
                "unit/campaign.toml",
                "--out",
                &out,
            ])
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        printed.push(String::from_utf8(run.stdout).unwrap().replace(&out, "OUT"));
        let mut results: Value =
            serde_json::from_str(&std::fs::read_to_string(work.join(&out).join("results.json")).unwrap())
                .unwrap();
        without_timings(&mut results);
        let model = std::fs::read(work.join(&out).join("model.json")).ok();
        outputs.push((results, model));
    }
    assert_eq!(outputs[0].0, outputs[1].0);
    assert_eq!(outputs[0].1, outputs[1].1);
    assert_printed_tables_only_with_the_flag(&printed, &[HELD_OUT_TABLE, "rate from accel", "bias offsets"]);
}

/// The held-out table's heading (the verdict may say "held-out condition" too).
const HELD_OUT_TABLE: &str = "held-out condition            corrector";

/// `printed[0]` without `--tables`, `printed[1]` with it: the first line says what was saved and
/// where it can be trusted, every line of the short summary is in the long one, and the tables'
/// headings (`headings`) only in the long one.
fn assert_printed_tables_only_with_the_flag(printed: &[String], headings: &[&str]) {
    let (short, long) = (&printed[0], &printed[1]);
    let first = short.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("Saved OUT/model.json (")
            || first.starts_with("No model saved (no model.json in OUT)"),
        "{short}"
    );
    assert_eq!(long.lines().next(), Some(first));
    for line in short.lines().filter(|l| !l.contains("--tables")) {
        assert!(
            long.lines().any(|l| l == line),
            "{line:?} is missing with --tables:\n{long}"
        );
    }
    for heading in headings {
        assert!(
            !short.contains(heading),
            "{heading:?} printed without --tables:\n{short}"
        );
        assert!(
            long.contains(heading),
            "{heading:?} missing with --tables:\n{long}"
        );
    }
}
