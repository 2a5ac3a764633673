//! What the CLI tests that call the built binary and the test venv share: running the binary,
//! finding the venv's python and the shared data (each skipped with a printed reason when absent;
//! CI's SPINCAL_REQUIRE_PYTHON=1 makes a missing venv fail).

// Each test crate uses its own subset.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn spincal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_spincal"))
}

pub fn run(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(
        out.status.success(),
        "{:?} failed:\n{}\n{}",
        cmd,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs a command that must succeed; returns its stdout and stderr (warnings).
pub fn run_with_stderr(cmd: &mut Command) -> (String, String) {
    let out = cmd.output().expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{cmd:?} failed:\n{stderr}");
    (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
}

/// Runs a command that must fail; returns its stderr.
pub fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(!out.status.success(), "{cmd:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Whether a file in an output folder is spincal's record of what it wrote there
/// (`spincal::output::MANIFEST`), which listings of a folder's outputs leave out.
pub fn is_manifest(name: &std::ffi::OsStr) -> bool {
    name == spincal::output::MANIFEST
}

/// The names in `dir` (the manifest left out), sorted: what a test lists as a folder's files.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| !is_manifest(n))
        .map(|n| n.to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The test venv's python (scripts/setup.sh makes it). `None` with a printed reason when absent,
/// unless SPINCAL_REQUIRE_PYTHON=1 (CI), where absence fails.
pub fn venv_python() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = root.join(".venv/bin/python");
    if python.exists() {
        return Some(python);
    }
    let required = std::env::var("SPINCAL_REQUIRE_PYTHON").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "SPINCAL_REQUIRE_PYTHON=1 but {} is absent: run scripts/setup.sh",
        python.display()
    );
    eprintln!("skipped: {} is absent (run scripts/setup.sh)", python.display());
    None
}

/// A file under the shared data folder: `$SPINCAL_SHARED_DATA`, or `../shared/data` beside the
/// clone. `None` with a printed reason when it is absent (a user's clone); with
/// `SPINCAL_REQUIRE_DATA=1` (CI) a missing file fails the test instead.
pub fn shared(relative: &str) -> Option<PathBuf> {
    let root = std::env::var_os("SPINCAL_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let path = root.join(relative);
    if path.exists() {
        return Some(path);
    }
    assert!(
        std::env::var("SPINCAL_REQUIRE_DATA").as_deref() != Ok("1"),
        "SPINCAL_REQUIRE_DATA=1 but {} is absent: put the shared data beside the clone or set SPINCAL_SHARED_DATA",
        path.display()
    );
    eprintln!(
        "skipped: {} is absent (set SPINCAL_SHARED_DATA to the shared data folder)",
        path.display()
    );
    None
}

/// A linear corrector trained on a 10 s simulated recording in `dir`: the recording
/// (`rec.csv`, with `ref.csv` from its turntable fit) and the model (`linear.json`).
pub fn linear_model(dir: &Path) -> (PathBuf, PathBuf) {
    let (rec, reference, model) = (dir.join("rec.csv"), dir.join("ref.csv"), dir.join("linear.json"));
    run(spincal()
        .args(["simulate", "--duration", "10", "--quiet", "-o"])
        .arg(&rec));
    run(spincal()
        .args(["fit", "--quiet"])
        .arg(&rec)
        .arg("--reference-csv")
        .arg(&reference));
    run(spincal()
        // x and y: a flat run leaves z at gravity, which a map cannot learn (refused).
        .args([
            "train",
            "--kind",
            "linear",
            "--correct-axes",
            "x,y",
            "--quiet",
            "--data",
        ])
        .arg(&rec)
        .arg("--reference")
        .arg(&reference)
        .arg("-o")
        .arg(&model));
    (rec, model)
}

/// The default campaign with 20 s turntable runs (a test's time), written as `setup.json` in
/// `dir` for `spincal simulate --setup`.
pub fn short_campaign_setup(dir: &Path) -> PathBuf {
    use spincal::simulate::campaign::{CampaignSetup, RunSetup};
    let base = CampaignSetup::default();
    let setup = CampaignSetup {
        runs: base
            .runs
            .iter()
            .map(|r| RunSetup {
                duration_s: 20.0,
                ..r.clone()
            })
            .collect(),
        ..base
    };
    let path = dir.join("setup.json");
    std::fs::write(&path, serde_json::to_string(&setup).unwrap()).unwrap();
    path
}
