//! The command-line tool's integration tests: every file of tests/ as a module of one test binary, so the tests of all files
//! run side by side on the machine's cores and the library is linked once, not once per file.
//! A file of tests/ that is not listed here would never run: `architecture::every_test_file_runs`
//! (in the library's suite) fails then.

mod common;
mod harness;
#[path = "../../spincal/tests/common/suite_fleet.rs"]
mod suite_fleet;
mod support;

mod ann_cli;
mod architecture;
mod bags_cli;
mod bounded;
mod browser;
mod campaign_cli;
mod demo;
mod determinism;
mod exports;
mod firmware;
mod first_contact;
mod fit_cli;
mod fleet_cli;
mod flight_cli;
mod gyro_file_cli;
mod gyro_poses;
mod help_examples;
mod hostile;
mod hostile_models;
mod io_commands;
mod labels_cli;
mod outputs;
mod phone_cli;
mod phone_recipe;
mod real_files;
mod resources;
mod strobe;
mod temperature_cli;
mod thermal_cli;
