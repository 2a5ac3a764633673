//! Simulated recordings, campaigns and fleets, with JSON overrides of their defaults.

use std::path::PathBuf;

use pyo3::prelude::*;

use crate::errors::usage;
use crate::recording::PyRecording;
use crate::{errors, json};

/// Merges a JSON object of overrides into a default value (unknown keys refused by serde).
pub(crate) fn with_overrides<T: serde::Serialize + serde::de::DeserializeOwned>(
    default: T,
    overrides: Option<&str>,
    what: &str,
) -> PyResult<T> {
    let Some(text) = overrides else { return Ok(default) };
    let mut base = serde_json::to_value(&default).map_err(|e| usage(format!("{what}: {e}")))?;
    let patch: serde_json::Value = serde_json::from_str(text).map_err(|e| usage(format!("{what}: {e}")))?;
    let (Some(base_map), Some(patch_map)) = (base.as_object_mut(), patch.as_object()) else {
        return Err(usage(format!("{what}: expected a dict of settings")));
    };
    for (k, v) in patch_map {
        base_map.insert(k.clone(), v.clone());
    }
    serde_json::from_value(base).map_err(|e| usage(format!("{what}: {e}")))
}

/// Simulates one turntable session; returns the recording and the truth as JSON.
/// `sensor` and `turntable` are JSON objects overriding the defaults (SensorProfile, TurntableSetup).
#[pyfunction]
#[pyo3(signature = (sensor_json = None, turntable_json = None, seed = 7))]
pub(crate) fn simulate(
    py: Python<'_>,
    sensor_json: Option<&str>,
    turntable_json: Option<&str>,
    seed: u64,
) -> PyResult<(PyRecording, String)> {
    use spincal::simulate::{SensorProfile, TurntableSetup};
    let sensor = with_overrides(SensorProfile::default(), sensor_json, "sensor")?;
    let table = with_overrides(TurntableSetup::default(), turntable_json, "turntable")?;
    let sim = py
        .detach(|| spincal::simulate::simulate(&sensor, &table, seed))
        .map_err(errors::usage_error)?;
    let truth = json(&sim.truth)?;
    Ok((
        PyRecording {
            inner: sim.recording,
            notes: Vec::new(),
            raw_counts: false,
            gyro_counts: false,
        },
        truth,
    ))
}

/// The defaults of the simulator's settings, as JSON: (sensor, turntable, campaign).
#[pyfunction]
pub(crate) fn simulation_defaults() -> PyResult<(String, String, String)> {
    Ok((
        json(&spincal::simulate::SensorProfile::default())?,
        json(&spincal::simulate::TurntableSetup::default())?,
        json(&spincal::simulate::campaign::CampaignSetup::default())?,
    ))
}

/// Simulates a unit's whole campaign into `folder` (campaign.toml, the recordings, their truth);
/// returns the truth as JSON. Refuses to replace files already there.
#[pyfunction]
#[pyo3(signature = (folder, seed = 7, setup_json = None))]
pub(crate) fn simulate_campaign(
    py: Python<'_>,
    folder: PathBuf,
    seed: u64,
    setup_json: Option<&str>,
) -> PyResult<String> {
    use spincal::simulate::campaign::CampaignSetup;
    let setup = with_overrides(CampaignSetup::default(), setup_json, "campaign setup")?;
    let sim = py
        .detach(|| spincal::simulate::campaign::simulate_campaign(&setup, seed))
        .map_err(errors::usage_error)?;
    let truth = serde_json::to_string_pretty(&sim.truth).map_err(|e| usage(e.to_string()))? + "\n";
    py.detach(|| sim.write_folder(&folder, false))
        .map_err(|e| match e {
            spincal::simulate::fleet::WriteError::Exists { .. } => usage(e.to_string()),
            e => errors::output(e),
        })?;
    Ok(truth)
}

/// Simulates a fleet (`setup_json` overrides FleetSetup: units, faulty, spread, fault, campaign)
/// into `folder` (one campaign folder per unit, fleet-truth.json); returns (folders, truth JSON).
#[pyfunction]
#[pyo3(signature = (folder, seed = 7, setup_json = None))]
pub(crate) fn simulate_fleet(
    py: Python<'_>,
    folder: PathBuf,
    seed: u64,
    setup_json: Option<&str>,
) -> PyResult<(Vec<PathBuf>, String)> {
    use spincal::simulate::fleet::FleetSetup;
    let setup = with_overrides(FleetSetup::default(), setup_json, "fleet setup")?;
    let fleet = py
        .detach(|| spincal::simulate::fleet::simulate_fleet(&setup, seed))
        .map_err(errors::usage_error)?;
    let folders = py
        .detach(|| fleet.write_folders(&folder))
        .map_err(errors::usage_error)?;
    Ok((folders, json(&fleet.truth())?))
}
