//! Runs the Python package's pytest suite (crates/spincal-py/tests/python) against the extension
//! module this very `cargo test` built, so a failure shows here and the module tested is always
//! the one from the current sources (not whatever wheel is installed in the venv).
//!
//! The package is assembled in a temporary folder (the pure-Python sources plus the freshly built
//! `lib_spincal.so` as `spincal/_spincal.abi3.so`) and put first on `PYTHONPATH`; the venv at the
//! repository root (`bash scripts/setup.sh`) provides numpy, pytest (and pytest-xdist: two
//! processes), pandas, tqdm and ray. The tests compare against the `spincal` binary of the same
//! build, and the Ray tests against the suite's one fleet (`SPINCAL_SUITE_FLEET`, made by the
//! library if the library's tests have not).
//!
//! Without the venv the test is skipped with the reason printed, unless
//! `SPINCAL_REQUIRE_PYTHON=1` (CI), where it fails; pytest's own skips also fail then.

use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "../../spincal/tests/common/suite_fleet.rs"]
mod suite_fleet;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The folder of this build's artifacts (target/release): the test binary lives in its `deps`.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.parent()
        .and_then(Path::parent)
        .expect("the test binary lies in <target>/<profile>/deps")
        .to_path_buf()
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let path = entry.path();
        let name = entry.file_name();
        if path.is_dir() {
            if name != "__pycache__" {
                copy_tree(&path, &to.join(&name));
            }
        } else {
            std::fs::copy(&path, to.join(&name)).unwrap();
        }
    }
}

/// The most recently modified file under `dir`.
fn newest_source(dir: &Path) -> Option<(std::time::SystemTime, PathBuf)> {
    let mut newest: Option<(std::time::SystemTime, PathBuf)> = None;
    for entry in std::fs::read_dir(dir).ok()?.flatten() {
        let path = entry.path();
        let candidate = if path.is_dir() {
            newest_source(&path)
        } else {
            entry
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .map(|t| (t, path))
        };
        if let Some(c) = candidate {
            if newest.as_ref().is_none_or(|n| c.0 > n.0) {
                newest = Some(c);
            }
        }
    }
    newest
}

#[test]
fn pytest_suite_passes_against_this_build() {
    let required = std::env::var("SPINCAL_REQUIRE_PYTHON").is_ok_and(|v| v == "1");
    let python = root().join(".venv/bin/python");
    if !python.exists() {
        assert!(
            !required,
            "SPINCAL_REQUIRE_PYTHON=1 but {} is missing: run `bash scripts/setup.sh`",
            python.display()
        );
        eprintln!(
            "skipped: {} is missing (run `bash scripts/setup.sh` to create the test venv)",
            python.display()
        );
        return;
    }
    // The wheel setup.sh built and installed must import from the venv on its own (what a user
    // gets from `pip install`); the suite below then tests this build's module.
    let installed_package = Command::new(&python)
        .args(["-c", "import spincal, numpy; print(spincal.__version__)"])
        .current_dir(std::env::temp_dir())
        .env_remove("PYTHONPATH")
        .output()
        .expect("running the venv's python");
    if !installed_package.status.success() {
        let why = String::from_utf8_lossy(&installed_package.stderr);
        assert!(
            !required,
            "SPINCAL_REQUIRE_PYTHON=1 but the spincal package is not installed in the venv (run `bash scripts/setup.sh`):\n{why}"
        );
        eprintln!(
            "note: the spincal wheel is not installed in .venv ({why}); testing this build's module anyway"
        );
    }
    let profile = profile_dir();
    let module = profile.join("lib_spincal.so");
    assert!(
        module.exists(),
        "{} was not built by this cargo run (the cdylib of crates/spincal-py)",
        module.display()
    );
    // Cargo does not rebuild a cdylib-only library for an integration test: the module must be
    // newer than every source it is built from (setup.sh's maturin build, or `cargo build`).
    let built = std::fs::metadata(&module).and_then(|m| m.modified()).unwrap();
    for dir in ["crates/spincal-py/src", "crates/spincal/src"] {
        if let Some(newer) = newest_source(&root().join(dir)).filter(|(t, _)| *t > built) {
            panic!(
                "{} is older than {}: rebuild it (`bash scripts/setup.sh`, or `cargo build --release -p spincal-py`)",
                module.display(),
                newer.1.display()
            );
        }
    }
    let cli = profile.join("spincal");
    assert!(
        cli.exists(),
        "{} is missing: the tests compare against the CLI of the same build; run the workspace's tests \
         (`cargo test --release --workspace`) or `cargo build --release -p spincal-cli` first",
        cli.display()
    );

    let package_root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("spincal-py-package");
    let _ = std::fs::remove_dir_all(&package_root);
    let package = package_root.join("spincal");
    copy_tree(&root().join("crates/spincal-py/python/spincal"), &package);
    let installed = package.join("_spincal.abi3.so");
    std::fs::copy(&module, &installed).unwrap();

    // The suite's one fleet, which the Ray tests compare their calibrations with.
    let stored = suite_fleet::suite_fleet();

    let tests = root().join("crates/spincal-py/tests/python");
    let mut command = Command::new(&python);
    command
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs"])
        // Two processes: cargo runs this binary alone, and the tests are mostly one-threaded.
        .args(["-n", "2"])
        .arg(&tests)
        .current_dir(&package_root)
        .env("PYTHONPATH", &package_root)
        .env("SPINCAL_CLI", &cli)
        .env("SPINCAL_EXPECT_MODULE", &installed)
        .env("SPINCAL_SUITE_FLEET", &stored.dir)
        .env("PYTHONDONTWRITEBYTECODE", "1");
    let output = command.output().expect("running the venv's python");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stdout}");
    eprintln!("{stderr}");
    assert!(
        output.status.success(),
        "pytest failed ({}):\n{stdout}\n{stderr}",
        output.status
    );
}
