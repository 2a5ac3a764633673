//! The command-line tool's integration tests: every file of tests/ as a module of one test binary, so the tests of all files
//! run side by side on the machine's cores and the library is linked once, not once per file.
//! A file of tests/ that is not listed here would never run: `every_test_file_is_in_the_suite`
//! fails then.

mod common;
mod harness;
mod support;

mod ann_cli;
mod bags_cli;
mod browser;
mod campaign_cli;
mod demo;
mod determinism;
mod exports;
mod firmware;
mod fit_cli;
mod fleet_cli;
mod gyro_poses;
mod help_examples;
mod hostile;
mod hostile_models;
mod io_commands;
mod strobe;

/// Files of tests/ that are test binaries of their own (declared in Cargo.toml).
const OWN_BINARIES: [&str; 0] = [];

#[test]
fn every_test_file_is_in_the_suite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        let Some(module) = name.strip_suffix(".rs") else {
            continue;
        };
        if name != "suite.rs"
            && !OWN_BINARIES.contains(&name.as_str())
            && !suite.contains(&format!("\nmod {module};"))
        {
            missing.push(name);
        }
    }
    assert!(
        missing.is_empty(),
        "tests/{missing:?} would never run: add `mod …;` to tests/suite.rs"
    );
}
