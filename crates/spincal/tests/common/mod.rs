//! Support shared by the integration tests.
#![allow(dead_code)]

pub mod independent;
pub mod joint_bench;
pub mod suite_fleet;
pub mod synthetic;

use std::path::PathBuf;

/// Path of a file under `../shared/data` (or `$SPINCAL_SHARED_DATA`), or `None` with a printed
/// reason when the data is not there (a user's clone); with `SPINCAL_REQUIRE_DATA=1` (CI) a
/// missing file fails the test instead.
pub fn shared_data(relative: &str) -> Option<PathBuf> {
    let root = std::env::var_os("SPINCAL_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data")));
    let path = root.join(relative);
    if path.exists() {
        Some(path)
    } else {
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
}

/// A simulated campaign's recordings as the calibration takes them, with the true specific force
/// and the random floor when `with_truth`.
pub fn campaign_units(
    sim: &spincal::simulate::campaign::SimulatedCampaign,
    with_truth: bool,
) -> Vec<spincal::campaign::prepare::UnitRecording> {
    sim.unit_recordings(with_truth)
}
