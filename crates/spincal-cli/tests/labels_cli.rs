//! Labels and units checked against the data (issue 47 item 4): a `static` recording that turns
//! (no gyro), a file in g read as m/s², a trained map that ignores an input, a corrected value no
//! sensor reads, and a model the C export cannot hold. Each case checks the exit code, the
//! message, and that no input or earlier output changed.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use serde_json::Value;

fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}

/// Runs spincal: exit code and stderr.
fn run(args: &[&OsStr]) -> (i32, String) {
    let out = crate::harness::spincal().args(args).output().unwrap();
    (
        out.status.code().expect("spincal ended by a signal"),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Every file under `dir` with its bytes, sorted by path.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.push((path.clone(), std::fs::read(&path).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// A linear model (x, y; in m/s²) with its matrix's first weight set to `weight`.
fn edited_model(dir: &Path, model: &Path, weight: f64) -> PathBuf {
    let mut json: Value = serde_json::from_str(&std::fs::read_to_string(model).unwrap()).unwrap();
    json["corrector"]["matrix"][0][0] = serde_json::json!(weight);
    let path = dir.join("edited.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    path
}

#[test]
fn a_turntable_run_without_gyro_listed_as_static_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let setup = crate::harness::short_campaign_setup(dir.path());
    let camp = dir.path().join("camp");
    crate::harness::run(
        crate::harness::spincal()
            .args(["simulate", "--quiet", "--seed", "7", "--setup"])
            .arg(&setup)
            .arg("--campaign")
            .arg(&camp),
    );
    // The first run's gyro columns cut off, and the run listed as a still recording.
    let toml_path = camp.join("campaign.toml");
    let toml = std::fs::read_to_string(&toml_path).unwrap();
    let blocks: Vec<&str> = toml.split("[[recording]]").collect();
    let turntable = blocks
        .iter()
        .position(|b| b.contains("kind = \"turntable\""))
        .unwrap();
    let file = blocks[turntable]
        .lines()
        .find_map(|l| l.strip_prefix("file = \""))
        .unwrap()
        .trim_end_matches('"')
        .to_string();
    let mut relabelled = blocks.clone();
    let entry = format!("\nfile = \"{file}\"\nkind = \"static\"\n\n");
    relabelled[turntable] = &entry;
    std::fs::write(&toml_path, relabelled.join("[[recording]]")).unwrap();
    let csv = camp.join(&file);
    let text: String = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .map(|l| l.split(',').take(4).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    assert!(
        text.starts_with("t_s,ax_mps2,ay_mps2,az_mps2\n"),
        "{}",
        &text[..40]
    );
    std::fs::write(&csv, text).unwrap();
    let before = tree(dir.path());
    let out = dir.path().join("cal");
    let (code, err) = run(&[
        os("calibrate"),
        os("--campaign"),
        toml_path.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&file) && err.contains("`kind`: listed as `static`"),
        "{err}"
    );
    assert!(
        err.contains("turn at 33.") && err.contains("kind = \"turntable\""),
        "{err}"
    );
    assert!(!out.exists(), "no output folder");
    assert_eq!(tree(dir.path()), before, "no file changed");
}

#[test]
fn a_file_in_g_read_as_mps2_stops_correct_and_names_the_unit() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, model) = crate::harness::linear_model(dir.path());
    // The same values (g) under a plain header, which reads as m/s².
    let text = std::fs::read_to_string(&rec).unwrap();
    assert!(text.starts_with("t_s,ax_g,ay_g,az_g"), "{}", &text[..40]);
    let plain = dir.path().join("plain.csv");
    std::fs::write(&plain, text.replacen("t_s,ax_g,ay_g,az_g", "t,ax,ay,az", 1)).unwrap();
    let out = dir.path().join("corrected.csv");
    std::fs::write(&out, "an earlier file\n").unwrap();
    let before = tree(dir.path());
    let (code, err) = run(&[
        os("correct"),
        os("--model"),
        model.as_os_str(),
        plain.as_os_str(),
        os("-o"),
        out.as_os_str(),
        os("--force"),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("plain.csv: the first 200 rows read 1.0"), "{err}");
    assert!(err.contains("look like g, read as m/s²"), "{err}");
    assert!(err.contains("`--accel-unit` g"), "{err}");
    assert_eq!(tree(dir.path()), before, "no file changed");
    // Stated, the same file is corrected.
    let (code, err) = run(&[
        os("correct"),
        os("--model"),
        model.as_os_str(),
        plain.as_os_str(),
        os("--accel-unit"),
        os("g"),
        os("-o"),
        out.as_os_str(),
        os("--force"),
    ]);
    assert_eq!(code, 0, "{err}");
    let corrected = std::fs::read_to_string(&out).unwrap();
    assert!(
        corrected.lines().skip(1).all(|l| l.ends_with(",1,ok")),
        "{}",
        &corrected[..300]
    );
}

#[test]
fn a_linear_map_that_ignores_z_is_refused_and_saves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, _) = crate::harness::linear_model(dir.path());
    let reference = dir.path().join("ref.csv");
    let model = dir.path().join("linear.json");
    let before = tree(dir.path());
    let (code, err) = run(&[
        os("train"),
        os("--kind"),
        os("linear"),
        os("--data"),
        rec.as_os_str(),
        os("--reference"),
        reference.as_os_str(),
        os("-o"),
        model.as_os_str(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("rec.csv: nothing saved (--correct-axes"), "{err}");
    assert!(
        err.contains("measured z barely moves in the training data"),
        "{err}"
    );
    assert!(err.contains("so it reads about 9.8"), "{err}");
    assert!(err.contains("leave z out of the corrected axes"), "{err}");
    assert_eq!(
        tree(dir.path()),
        before,
        "the earlier model and the inputs are kept"
    );
}

#[test]
fn a_corrected_value_beyond_any_sensor_is_refused_with_empty_values() {
    let dir = tempfile::tempdir().unwrap();
    let (rec, model) = crate::harness::linear_model(dir.path());
    let edited = edited_model(dir.path(), &model, 1e308);
    let out = dir.path().join("corrected.csv");
    let before = tree(dir.path());
    let (code, err) = run(&[
        os("correct"),
        os("--model"),
        edited.as_os_str(),
        rec.as_os_str(),
        os("-o"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 3, "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let ax = header.iter().position(|h| *h == "ax_corrected_g").unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(
        rows.len(),
        std::fs::read_to_string(&rec).unwrap().lines().count() - 1
    );
    for row in &rows {
        let fields: Vec<&str> = row.split(',').collect();
        assert!(!row.ends_with(",ok"), "{row}");
        assert!(fields[ax].is_empty(), "{row}");
        assert!(
            row.contains("refused: line") && row.contains("the corrected ax is"),
            "{row}"
        );
        assert!(row.contains("beyond ±500 g"), "{row}");
    }
    assert!(err.contains("beyond ±500 g"), "{err}");
    let mut after = tree(dir.path());
    after.retain(|(p, _)| p != &out && !crate::harness::is_manifest(p.file_name().unwrap()));
    let mut before = before;
    before.retain(|(p, _)| !crate::harness::is_manifest(p.file_name().unwrap()));
    assert_eq!(after, before, "no input changed");
}

#[test]
fn export_refuses_a_coefficient_float_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let (_, model) = crate::harness::linear_model(dir.path());
    let edited = edited_model(dir.path(), &model, 1e308);
    let out = dir.path().join("firmware");
    let before = tree(dir.path());
    let (code, err) = run(&[
        os("export"),
        os("--model"),
        edited.as_os_str(),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("edited.json: cannot export: lin_matrix[0][0]:"),
        "{err}"
    );
    assert!(err.contains("1e308 is not a finite float"), "{err}");
    assert!(err.contains("export double only"), "{err}");
    assert!(!out.exists(), "nothing written");
    assert_eq!(tree(dir.path()), before, "no file changed");
    // Double holds it.
    let (code, err) = run(&[
        os("export"),
        os("--model"),
        edited.as_os_str(),
        os("--precision"),
        os("double"),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    let header = std::fs::read_to_string(out.join("spincal_f64.c")).unwrap();
    assert!(!header.contains("inf"), "no infinity written");
}
