//! `spincal._spincal`: the Python extension module. Thin: every function converts its arguments,
//! calls the library and converts the answer; results travel as JSON text (the library's own
//! serialisation, the same as results.json) and signals as numpy arrays. The pure-Python package
//! (`python/spincal`) wraps the JSON in typed result objects and draws progress bars.

use pyo3::prelude::*;

mod analysis;
mod calibration;
mod columns;
mod corrector;
mod errors;
mod fleet;
mod long;
mod params;
mod recording;
mod simulation;

use analysis::{allan, sensitivity};
use calibration::{
    calibrate, calibrate_campaign, campaign_files, fit_turntable, run_sweep_jobs, static_calibration,
    write_outputs, PyCalibration,
};
use corrector::PyCorrector;
use fleet::{calibrate_unit, campaign_inputs, fleet_table, unit_labels};
use recording::read;
pub(crate) use recording::PyRecording;
use simulation::{simulate, simulate_campaign, simulate_fleet, simulation_defaults};

/// JSON text of a serialisable library value.
fn json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| errors::Error::new_err(format!("serialising the result: {e}")))
}

/// The library's version.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _spincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<PyRecording>()?;
    m.add_class::<PyCalibration>()?;
    m.add_class::<PyCorrector>()?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_class::<columns::ColumnPlan>()?;
    m.add("STATUS_NAMES", columns::STATUS_NAMES.to_vec())?;
    m.add_function(wrap_pyfunction!(columns::plan_columns, m)?)?;
    m.add_function(wrap_pyfunction!(columns::corrected_column_names, m)?)?;
    m.add_function(wrap_pyfunction!(columns::recording_from_columns, m)?)?;
    m.add_function(wrap_pyfunction!(params::default_params, m)?)?;
    m.add_function(wrap_pyfunction!(params::resolve_params, m)?)?;
    m.add_function(wrap_pyfunction!(params::sweep_grid, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulation_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(fit_turntable, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(run_sweep_jobs, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_files, m)?)?;
    m.add_function(wrap_pyfunction!(write_outputs, m)?)?;
    m.add_function(wrap_pyfunction!(static_calibration, m)?)?;
    m.add_function(wrap_pyfunction!(allan, m)?)?;
    m.add_function(wrap_pyfunction!(sensitivity, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_inputs, m)?)?;
    m.add_function(wrap_pyfunction!(unit_labels, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_unit, m)?)?;
    m.add_function(wrap_pyfunction!(fleet_table, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_fleet, m)?)?;
    Ok(())
}
