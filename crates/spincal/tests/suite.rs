//! The library's integration tests: every file of tests/ as a module of one test binary, so the tests of all files
//! run side by side on the machine's cores and the library is linked once, not once per file.
//! A file of tests/ that is not listed here would never run: `architecture::every_test_file_runs`
//! (in the library's suite) fails then.

mod common;

mod advice;
mod ann;
mod ann_peer;
mod architecture;
#[cfg(feature = "bags")]
mod bags;
mod campaign;
mod campaign_gyro;
mod campaign_real;
mod error_bars;
mod fixture_scripts;
mod fleet;
#[cfg(all(feature = "ulog", feature = "dataflash"))]
mod flight_logs;
mod flight_stacks;
mod gyro_merge;
mod gyro_nominal;
mod gyro_poses;
mod joint_scipy;
mod model_validation;
#[cfg(feature = "phone")]
mod phone;
mod placements;
mod readers_prop;
mod real_imu;
mod sessions;
mod shared_files;
mod still_labels;
mod sysid;
mod sysid_benchmarks;
mod temperature_checks;
mod templates;
mod thermal;
mod turntable_fit;
