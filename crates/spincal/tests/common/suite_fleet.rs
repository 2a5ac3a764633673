//! The suite's one simulated fleet: eight units (one faulty) calibrated once by the library and
//! kept under `<target>/suite-fleet`, so that the library's, the CLI's and the Python package's
//! fleet tests judge the same units and compare their own calibrations with this one instead of
//! each calibrating eight units of their own.
//!
//! The folder is stamped with a hash of the library's sources and Cargo.lock: a consumer finding
//! no folder, or one made from other sources, makes it again (`suite_fleet`). The library's fleet
//! test calibrates every run and either stores its result here or, when a fresh one is present,
//! checks it equal to the stored one (`record`).
//!
//! Paths inside results.json and model.json are stored with the units' folder replaced by
//! `<units>`; compare through `normalised`.
//!
//! This file is included by path from the CLI's and the Python package's tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use spincal::fleet::{calibrate_fleet, silent_fleet, FleetSettings, UnitOutcome};
use spincal::simulate::campaign::{CampaignSetup, RunSetup};
use spincal::simulate::fleet::{simulate_fleet, FleetSetup, SimulatedFleet};

/// The fleet's seed.
pub const SEED: u64 = 2026;
/// The faulty unit's index (0-based): `unit-06`.
pub const FAULTY: usize = 5;
/// The units kept as references by the CLI's and Python's tests (a good one and the faulty one).
pub const REFERENCE_UNITS: [&str; 2] = ["unit-01", "unit-06"];

/// The default campaign with 30 s turntable runs, eight units, the sixth faulty.
pub fn setup() -> FleetSetup {
    let base = CampaignSetup::default();
    FleetSetup {
        units: 8,
        campaign: CampaignSetup {
            runs: base
                .runs
                .iter()
                .map(|r| RunSetup {
                    duration_s: 30.0,
                    ..r.clone()
                })
                .collect(),
            ..base
        },
        faulty: vec![FAULTY],
        ..FleetSetup::default()
    }
}

/// The stored fleet.
pub struct SuiteFleet {
    pub dir: PathBuf,
}

impl SuiteFleet {
    /// The folder of unit folders (`unit-01`, …, and `fleet-truth.json`).
    pub fn units(&self) -> PathBuf {
        self.dir.join("units")
    }

    pub fn unit(&self, name: &str) -> PathBuf {
        self.units().join(name)
    }

    /// The campaign setup as `spincal simulate --setup` takes it.
    pub fn setup_json(&self) -> PathBuf {
        self.dir.join("setup.json")
    }

    /// A unit's results.json, normalised, without its wall times.
    pub fn results(&self, unit: &str) -> serde_json::Value {
        comparable_results(&read(
            &self.dir.join("calibrated").join(unit).join("results.json"),
        ))
    }

    /// A unit's model.json, normalised (`None` when nothing was saved).
    pub fn model(&self, unit: &str) -> Option<String> {
        std::fs::read_to_string(self.dir.join("calibrated").join(unit).join("model.json")).ok()
    }

    /// The unit names in fleet order.
    pub fn unit_names(&self) -> Vec<String> {
        (1..=setup().units).map(|k| format!("unit-{k:02}")).collect()
    }
}

/// `text` with `units` (the folder the units were calibrated from) written as `<units>`.
pub fn normalised(text: &str, units: &Path) -> String {
    text.replace(&units.display().to_string(), "<units>")
}

/// results.json's value without `seconds_total` and `stage_seconds` (wall time).
pub fn comparable_results(text: &str) -> serde_json::Value {
    let mut value: serde_json::Value = serde_json::from_str(text).expect("results.json is JSON");
    let object = value.as_object_mut().expect("results.json is an object");
    object.remove("seconds_total");
    object.remove("stage_seconds");
    value
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `<target>`: the test binary lies in `<target>/<profile>/deps`.
fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.ancestors()
        .nth(3)
        .expect("the test binary lies in <target>/<profile>/deps")
        .to_path_buf()
}

fn fixture_dir() -> PathBuf {
    target_dir().join("suite-fleet")
}

/// FNV-1a over the library's sources (paths and bytes, in path order) and Cargo.lock.
pub fn stamp() -> String {
    let library = Path::new(env!("CARGO_MANIFEST_DIR")).join("../spincal");
    let mut files = Vec::new();
    collect(&library.join("src"), &mut files);
    files.sort();
    files.push(library.join("../../Cargo.lock"));
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in files {
        let name = file.strip_prefix(&library).unwrap_or(&file).display().to_string();
        for byte in name.bytes().chain(read_bytes(&file)) {
            hash = (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{hash:016x}")
}

fn read_bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn collect(dir: &Path, files: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            collect(&path, files);
        } else {
            files.push(path);
        }
    }
}

/// The stored fleet when it was made from these sources.
pub fn fresh() -> Option<SuiteFleet> {
    let dir = fixture_dir();
    let stored = std::fs::read_to_string(dir.join("stamp")).ok()?;
    (stored.trim() == stamp()).then_some(SuiteFleet { dir })
}

/// The stored fleet, made (simulated and calibrated, a minute on two cores) when absent or stale.
pub fn suite_fleet() -> SuiteFleet {
    if let Some(fleet) = fresh() {
        return fleet;
    }
    let fleet = simulate_fleet(&setup(), SEED).expect("the suite's fleet simulates");
    let scratch = target_dir().join(format!("suite-fleet.making-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let sources = fleet.write_folders(&scratch).expect("writing the suite's fleet");
    let outcomes = calibrate_fleet(&sources, &FleetSettings::default(), &silent_fleet);
    store(&fleet, &scratch, &outcomes.iter().collect::<Vec<_>>());
    let _ = std::fs::remove_dir_all(&scratch);
    fresh().expect("the suite's fleet was just stored")
}

/// The library's fleet test: `outcomes` (every unit of `fleet`, calibrated from `units`) are
/// checked equal to the stored fleet when a fresh one is present, and stored otherwise.
pub fn record(fleet: &SimulatedFleet, units: &Path, outcomes: &[&UnitOutcome]) {
    let Some(stored) = fresh() else {
        store(fleet, units, outcomes);
        return;
    };
    for outcome in outcomes {
        let cal = outcome.result.as_ref().expect("every unit calibrated");
        let results = normalised(&cal.results_json(), units);
        assert!(
            comparable_results(&results) == stored.results(&outcome.unit),
            "{}: differs from the stored suite fleet ({})",
            outcome.unit,
            stored.dir.display()
        );
        assert_eq!(
            cal.model_json().map(|m| normalised(&m, units)),
            stored.model(&outcome.unit),
            "{}: model.json differs from the stored suite fleet",
            outcome.unit
        );
    }
}

fn store(fleet: &SimulatedFleet, units: &Path, outcomes: &[&UnitOutcome]) {
    assert_eq!(outcomes.len(), fleet.units.len(), "every unit of the fleet");
    let dir = fixture_dir();
    let staging = target_dir().join(format!("suite-fleet.storing-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&staging);
    fleet
        .write_folders(&staging.join("units"))
        .expect("writing the suite's fleet");
    for outcome in outcomes {
        let cal = outcome
            .result
            .as_ref()
            .expect("every unit of the suite's fleet calibrated");
        let folder = staging.join("calibrated").join(&outcome.unit);
        std::fs::create_dir_all(&folder).unwrap();
        std::fs::write(
            folder.join("results.json"),
            normalised(&cal.results_json(), units),
        )
        .unwrap();
        if let Some(model) = cal.model_json() {
            std::fs::write(folder.join("model.json"), normalised(&model, units)).unwrap();
        }
    }
    std::fs::write(
        staging.join("setup.json"),
        serde_json::to_string(&fleet.setup.campaign).unwrap(),
    )
    .unwrap();
    std::fs::write(staging.join("stamp"), stamp()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    // Another test process may have stored it meanwhile: theirs is as good as this one.
    if std::fs::rename(&staging, &dir).is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
}
