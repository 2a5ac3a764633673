//! Noise and design figures: Allan deviation of a still recording and the turntable's sensitivity.

use numpy::PyReadonlyArray2;
use pyo3::prelude::*;

use spincal::input::recording::Recording;

use crate::errors::usage;
use crate::recording::array_to_columns;
use crate::{errors, json};

/// The noise of a still recording, as `spincal allan` measures it (the library's
/// `analyse_still`): an (n, 3) array sampled every `dt_s`, motion refused; returns JSON with the
/// curve (`curve`), the noise parameters (`noise`: density, bias instability, random walk) and
/// the samples used.
#[pyfunction]
#[pyo3(signature = (accel, dt_s, *, per_decade = 10))]
pub(crate) fn allan(
    py: Python<'_>,
    accel: PyReadonlyArray2<'_, f64>,
    dt_s: f64,
    per_decade: usize,
) -> PyResult<String> {
    use spincal::allan::{analyse_still, AllanSettings, StillNoise};
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(usage(format!(
            "dt_s = {dt_s}: must be a positive number of seconds"
        )));
    }
    let axes = array_to_columns(accel.as_array(), "accel")?;
    let n = axes[0].len();
    let recording = Recording {
        time_s: (0..n).map(|i| i as f64 * dt_s).collect(),
        accel_mps2: axes,
        gyro_radps: None,
        temperature_c: None,
        source: Default::default(),
    };
    let settings = AllanSettings {
        per_decade,
        ..AllanSettings::default()
    };
    let input = StillNoise {
        recording: &recording,
        name: "accel",
        raw_counts: false,
        gyro: None,
        calibration: None,
    };
    let analysis = py.detach(|| analyse_still(&input, &settings).map_err(errors::fit))?;
    let mut value = serde_json::to_value(&analysis).map_err(|e| usage(e.to_string()))?;
    // Python's name for the read-offs.
    if let Some(object) = value.as_object_mut() {
        if let Some(params) = object.remove("params") {
            object.insert("noise".into(), params);
        }
    }
    json(&value)
}

/// The paper's Table 1 at any nominal values: each parameter moved by ±`vary_percent`.
#[pyfunction]
#[pyo3(signature = (*, radius_m = 0.10, tilt_deg = 5.0, rpm = 33.3, beta_deg = 0.0,
    gravity_mps2 = spincal::input::recording::STANDARD_GRAVITY, vary_percent = 15.0))]
pub(crate) fn sensitivity(
    radius_m: f64,
    tilt_deg: f64,
    rpm: f64,
    beta_deg: f64,
    gravity_mps2: f64,
    vary_percent: f64,
) -> PyResult<String> {
    if !(vary_percent > 0.0 && vary_percent < 100.0) {
        return Err(usage(format!(
            "vary_percent = {vary_percent}: expected a percentage in (0, 100)"
        )));
    }
    for (name, v) in [
        ("radius_m", radius_m),
        ("rpm", rpm),
        ("gravity_mps2", gravity_mps2),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(usage(format!("{name} = {v}: must be a positive number")));
        }
    }
    let rows = spincal::turntable::sensitivity::sensitivity_table(
        &spincal::turntable::sensitivity::SensitivityInput {
            radius_m,
            tilt_rad: tilt_deg.to_radians(),
            omega_radps: rpm * 2.0 * std::f64::consts::PI / 60.0,
            beta_rad: beta_deg.to_radians(),
            gravity_mps2,
            vary: vary_percent / 100.0,
        },
    );
    json(&rows)
}
