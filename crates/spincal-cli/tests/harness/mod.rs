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

/// Runs a command that must fail; returns its stderr.
pub fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(!out.status.success(), "{cmd:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
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

pub fn shared(relative: &str) -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(relative);
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "skipped: {} is absent (../shared/data is not beside this clone)",
            path.display()
        );
        None
    }
}
