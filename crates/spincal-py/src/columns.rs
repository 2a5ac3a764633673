//! Columns handed over by Python (numpy arrays, a DataFrame's columns): which column is which, by
//! the library's own rules; whole recordings built from them with the same checks as every other
//! entry point; and row-by-row correction exactly as `spincal correct` does it.
//!
//! A DataFrame is never written out as text: Python hands its header to [`plan_columns`], which
//! finds time, accel and gyro by the library's column rules (names, `columns=`, units from the
//! name suffixes), then hands only those columns over as arrays, read in place.

use numpy::ndarray::{Array1, Array2, ArrayView1};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;

use spincal::input::recording::TemperatureUnit;
use spincal::input::recording::{ColumnMap, Recording, RecordingError};

use crate::errors::{self, usage, Kind, Place};

/// The header name given to the synthetic time column of a table that has none (time then comes
/// from the sample rate, or is not needed).
const NO_TIME: &str = "(no time column)";

/// Where time, accel and gyro are in a table (0-based positions) and their factors to SI.
#[pyclass(name = "ColumnPlan", module = "spincal._spincal", frozen, get_all)]
#[derive(Debug, Clone)]
pub struct ColumnPlan {
    /// The time column, or None when the table has none.
    pub time: Option<usize>,
    pub accel: [usize; 3],
    pub gyro: Option<[usize; 3]>,
    /// The temperature column, when the table has one, and its unit (`c`, `k`, `f`,
    /// `mpu6050counts`).
    pub temperature: Option<usize>,
    pub temperature_unit: Option<String>,
    pub time_to_s: f64,
    pub accel_to_mps2: f64,
    pub gyro_to_radps: f64,
    /// The acceleration's unit (`mps2`, `g`) and the rate's (`radps`, `dps`; None without gyro
    /// columns), as the corrected columns' names carry them.
    pub accel_unit: String,
    pub gyro_unit: Option<String>,
    /// The names of the columns used, time first (`(no time column)` when absent).
    pub names: Vec<String>,
}

#[pymethods]
impl ColumnPlan {
    fn __repr__(&self) -> String {
        format!(
            "ColumnPlan(time={:?}, accel={:?}, gyro={:?}, names={:?})",
            self.time, self.accel, self.gyro, self.names
        )
    }
}

/// The column map for keyword arguments: `columns` (names or 1-based positions, time first; a
/// time of None means "no time column") and the units.
fn column_map(
    columns: Option<&[Option<String>]>,
    accel_unit: Option<&str>,
    time_unit: Option<&str>,
    gyro_unit: Option<&str>,
) -> PyResult<ColumnMap> {
    let mut map = ColumnMap::default();
    if let Some(keys) = columns {
        if keys.len() != 4 && keys.len() != 7 {
            return Err(usage(format!(
                "columns: expected 4 or 7 entries (time, ax, ay, az[, gx, gy, gz]), got {}",
                keys.len()
            )));
        }
        if let Some(i) = keys[1..].iter().position(Option::is_none) {
            return Err(usage(format!(
                "columns[{}]: only the time column may be None",
                i + 1
            )));
        }
        map.columns = Some(
            keys.iter()
                .map(|k| k.clone().unwrap_or_else(|| NO_TIME.to_string()))
                .collect(),
        );
    }
    map.accel_unit = accel_unit
        .map(|u| {
            spincal::input::recording::AccelUnit::parse(u)
                .ok_or_else(|| usage(format!("accel_unit {u:?}: expected g or mps2")))
        })
        .transpose()?;
    map.time_unit = time_unit
        .map(|u| {
            spincal::input::recording::TimeUnit::parse(u)
                .ok_or_else(|| usage(format!("time_unit {u:?}: expected s, ms or us")))
        })
        .transpose()?;
    map.gyro_unit = gyro_unit
        .map(|u| {
            spincal::input::recording::GyroUnit::parse(u)
                .ok_or_else(|| usage(format!("gyro_unit {u:?}: expected dps or radps")))
        })
        .transpose()?;
    Ok(map)
}

/// The library's plan for a table with header `header`, exactly as `spincal` reads a file with
/// that header line, in the binding's shape.
fn resolve(header: &[String], name: &str, map: &ColumnMap) -> Result<ColumnPlan, RecordingError> {
    let plan = spincal::input::recording::ColumnPlan::new(header, header.len(), name, map)?;
    let time = plan.time_column();
    Ok(ColumnPlan {
        time: (header.get(time).map(String::as_str) != Some(NO_TIME)).then_some(time),
        accel: plan.accel_columns(),
        gyro: plan.gyro_columns(),
        temperature: plan.temperature_column().map(|(c, _)| c),
        temperature_unit: plan.temperature_column().map(|(_, unit)| unit.name().to_string()),
        time_to_s: plan.time_to_s(),
        accel_to_mps2: plan.accel_to_mps2(),
        gyro_to_radps: plan.gyro_to_radps().unwrap_or(1.0),
        accel_unit: plan.accel_unit().suffix().to_string(),
        gyro_unit: plan.gyro_unit().map(|u| u.suffix().to_string()),
        names: plan.names().to_vec(),
    })
}

/// The names of the columns `spincal correct` adds (the library's one rule,
/// `correctors::stream::corrected_column_names`): `axes` the corrected accelerometer axes
/// (`x`, `y`, `z`), their values in `accel_unit`, the gyro's in `gyro_unit` when corrected,
/// the predicted standard deviations and `predicted_better` when `predicted`.
#[pyfunction]
#[pyo3(signature = (axes, accel_unit, gyro_unit = None, predicted = false))]
pub fn corrected_column_names(
    axes: Vec<String>,
    accel_unit: &str,
    gyro_unit: Option<&str>,
    predicted: bool,
) -> PyResult<Vec<String>> {
    use spincal::correctors::corrector::Axis;
    let axes = axes
        .iter()
        .map(|a| Axis::parse(a).ok_or_else(|| usage(format!("axes: {a:?} is not x, y or z"))))
        .collect::<PyResult<Vec<Axis>>>()?;
    Ok(spincal::correctors::stream::corrected_column_names(
        &axes, accel_unit, gyro_unit, predicted,
    ))
}

/// Finds time, accel and gyro among a table's columns by the library's rules (as `spincal` reads a
/// file with this header). With `time_optional`, a table without a time column is accepted (its
/// plan has `time` None).
#[pyfunction]
#[pyo3(signature = (header, *, name = "<DataFrame>", columns = None, accel_unit = None, time_unit = None,
    gyro_unit = None, time_optional = false))]
pub fn plan_columns(
    header: Vec<String>,
    name: &str,
    columns: Option<Vec<Option<String>>>,
    accel_unit: Option<&str>,
    time_unit: Option<&str>,
    gyro_unit: Option<&str>,
    time_optional: bool,
) -> PyResult<ColumnPlan> {
    let map = column_map(columns.as_deref(), accel_unit, time_unit, gyro_unit)?;
    let no_time_named = columns.as_ref().is_some_and(|c| c[0].is_none());
    if no_time_named && !time_optional {
        return Err(usage(
            "columns: the time column is None, so give sample_rate_hz (time = sample number / rate)",
        ));
    }
    let mut with_time = header.clone();
    with_time.push(NO_TIME.to_string());
    let first = if no_time_named {
        resolve(&with_time, name, &map)
    } else {
        resolve(&header, name, &map)
    };
    match first {
        // No time column found: a sample rate can stand in for it.
        Err(RecordingError::AmbiguousColumns { .. } | RecordingError::NoTimeColumn { .. })
            if time_optional && map.columns.is_none() =>
        {
            let mut guessed = header.clone();
            guessed.push("t".to_string());
            let mut plan = resolve(&guessed, name, &map).map_err(|_| ambiguous(&header, name))?;
            if plan.time == Some(header.len()) {
                plan.time = None;
                plan.names[0] = NO_TIME.to_string();
            }
            Ok(plan)
        }
        Err(RecordingError::AmbiguousColumns { .. } | RecordingError::NoTimeColumn { .. }) => {
            Err(ambiguous(&header, name))
        }
        Err(e) => Err(errors::format(e)),
        Ok(plan) => Ok(plan),
    }
}

/// The error for columns that cannot be told apart, in Python's words (not the CLI's flag).
fn ambiguous(header: &[String], name: &str) -> PyErr {
    errors::with_place(
        Kind::Format,
        format!(
            "{name}: cannot tell which columns hold time and acceleration (columns: {}); pass \
             columns=[\"t\", \"ax\", \"ay\", \"az\"] (names or 1-based positions, gx, gy, gz after them \
             for the gyro; None for the time with sample_rate_hz)",
            header.join(", ")
        ),
        &Place {
            path: Some(name.to_string()),
            ..Place::default()
        },
    )
}

/// A value that is not finite, named by row and column (the same words as the library's table
/// reader: "the value is NaN; spincal needs finite numbers").
fn not_finite(name: &str, row: usize, column: &str, position: Option<usize>, value: f64) -> PyErr {
    errors::with_place(
        Kind::Format,
        format!("{name}: row {row}, column {column}: the value is {value}; spincal needs finite numbers"),
        &Place {
            path: Some(name.to_string()),
            row: Some(row),
            column: position.map(|p| p + 1),
            column_name: Some(column.to_string()),
            ..Place::default()
        },
    )
}

/// One column converted to SI, every value checked: finite as given, finite after conversion.
fn converted(
    name: &str,
    column: ArrayView1<'_, f64>,
    factor: f64,
    column_name: &str,
    position: Option<usize>,
) -> PyResult<Vec<f64>> {
    let mut out = Vec::with_capacity(column.len());
    for (row, &v) in column.iter().enumerate() {
        if !v.is_finite() {
            return Err(not_finite(name, row, column_name, position, v));
        }
        let si = v * factor;
        if !si.is_finite() {
            return Err(errors::with_place(
                Kind::Format,
                format!(
                    "{name}: row {row}, column {column_name}: {v:e} is {si} after conversion to SI units (× {factor}); spincal needs finite numbers: check the column's unit or the value"
                ),
                &Place {
                    path: Some(name.to_string()),
                    row: Some(row),
                    column: position.map(|p| p + 1),
                    column_name: Some(column_name.to_string()),
                    ..Place::default()
                },
            ));
        }
        out.push(si);
    }
    Ok(out)
}

type Three<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
);

/// A whole recording from columns: the one path of `recording()` (arrays) and `read()` of a
/// DataFrame. Every value must be finite (the error names the row and column), time must not go
/// backwards; without a time column, time is sample number / `sample_rate_hz`. `temperature` is in
/// the plan's temperature unit (°C without one).
#[pyfunction]
#[pyo3(signature = (time, accel, gyro, plan, *, name, format, sample_rate_hz = None, temperature = None))]
#[allow(clippy::too_many_arguments)]
pub fn recording_from_columns(
    time: Option<PyReadonlyArray1<'_, f64>>,
    accel: Three<'_>,
    gyro: Option<Three<'_>>,
    plan: &ColumnPlan,
    name: &str,
    format: &str,
    sample_rate_hz: Option<f64>,
    temperature: Option<PyReadonlyArray1<'_, f64>>,
) -> PyResult<crate::PyRecording> {
    let accel = [accel.0.as_array(), accel.1.as_array(), accel.2.as_array()];
    let gyro = gyro
        .as_ref()
        .map(|g| [g.0.as_array(), g.1.as_array(), g.2.as_array()]);
    let n = accel[0].len();
    let mut lengths: Vec<(&str, usize)> = (0..3)
        .map(|a| (plan.names[1 + a].as_str(), accel[a].len()))
        .collect();
    if let Some(g) = &gyro {
        lengths.extend((0..3).map(|a| (plan.names.get(4 + a).map_or("gyro", String::as_str), g[a].len())));
    }
    if let Some(t) = &time {
        lengths.push((plan.names[0].as_str(), t.as_array().len()));
    }
    let temperature_name = match plan.temperature {
        Some(_) => plan.names.last().cloned().unwrap_or_default(),
        None => "temperature".to_string(),
    };
    if let Some(t) = &temperature {
        lengths.push((temperature_name.as_str(), t.as_array().len()));
    }
    if let Some((column, len)) = lengths.iter().find(|(_, len)| *len != n) {
        return Err(usage(format!(
            "{name}: {column} has {len} rows, {} has {n}: every column needs one value per row",
            plan.names[1]
        )));
    }
    if plan.gyro.is_some() != gyro.is_some() {
        return Err(usage(format!(
            "{name}: the gyro columns were {} the plan",
            if gyro.is_some() {
                "given but are not in"
            } else {
                "planned but not given to"
            }
        )));
    }
    let time_s = match (sample_rate_hz, &time) {
        (Some(rate), _) => {
            if !(rate.is_finite() && rate > 0.0) {
                return Err(usage(format!(
                    "sample_rate_hz = {rate}: must be a positive number of samples per second"
                )));
            }
            (0..n).map(|i| i as f64 / rate).collect()
        }
        (None, Some(t)) => converted(name, t.as_array(), plan.time_to_s, &plan.names[0], plan.time)?,
        (None, None) => {
            return Err(usage(format!(
                "{name}: no time column: give one, or sample_rate_hz (time = sample number / rate)"
            )))
        }
    };
    let accel_mps2: [Vec<f64>; 3] = [
        converted(
            name,
            accel[0],
            plan.accel_to_mps2,
            &plan.names[1],
            Some(plan.accel[0]),
        )?,
        converted(
            name,
            accel[1],
            plan.accel_to_mps2,
            &plan.names[2],
            Some(plan.accel[1]),
        )?,
        converted(
            name,
            accel[2],
            plan.accel_to_mps2,
            &plan.names[3],
            Some(plan.accel[2]),
        )?,
    ];
    let gyro_radps = match (&gyro, plan.gyro) {
        (Some(g), Some(p)) => Some([
            converted(name, g[0], plan.gyro_to_radps, &plan.names[4], Some(p[0]))?,
            converted(name, g[1], plan.gyro_to_radps, &plan.names[5], Some(p[1]))?,
            converted(name, g[2], plan.gyro_to_radps, &plan.names[6], Some(p[2]))?,
        ]),
        _ => None,
    };
    if let Some(i) = (1..n).find(|&i| time_s[i] < time_s[i - 1]) {
        return Err(errors::with_place(
            Kind::Format,
            format!(
                "{name}: row {i}, column {}: time goes backwards ({} s, then {} s)",
                plan.names[0],
                time_s[i - 1],
                time_s[i]
            ),
            &Place {
                path: Some(name.to_string()),
                row: Some(i),
                column: plan.time.map(|p| p + 1),
                column_name: Some(plan.names[0].clone()),
                ..Place::default()
            },
        ));
    }
    let temperature_c = match &temperature {
        Some(t) => {
            let unit = plan
                .temperature_unit
                .as_deref()
                .and_then(TemperatureUnit::parse)
                .unwrap_or(TemperatureUnit::C);
            let values = converted(name, t.as_array(), 1.0, &temperature_name, plan.temperature)?;
            Some(values.into_iter().map(|v| unit.to_celsius(v)).collect())
        }
        None => None,
    };
    let mut names = plan.names.clone();
    if plan.time.is_none() {
        names[0] = "(sample number / rate)".to_string();
    }
    if plan.temperature.is_none() && temperature.is_some() {
        names.push(temperature_name.clone());
    }
    Ok(crate::PyRecording {
        inner: Recording {
            time_s,
            accel_mps2,
            gyro_radps,
            temperature_c,
            source: spincal::input::recording::Source {
                name: name.to_string(),
                format: format.to_string(),
                columns: names,
                ..Default::default()
            },
        },
        notes: Vec::new(),
        raw_counts: false,
        gyro_counts: false,
    })
}

/// What each row's `status` code means: `spincal correct`'s status column.
pub const STATUS_NAMES: [&str; 7] = [
    "ok",
    "physics-only",
    "outside-range",
    "no-temperature",
    "outside-temperature-range",
    "suspect-temperature",
    "refused",
];

/// The code of a refused row (the last of [`STATUS_NAMES`]).
const REFUSED: u8 = 6;

/// Corrected rows: accel (n, 3) m/s² (every axis; uncorrected ones pass through), gyro (n, 3)
/// rad/s or None, valid (n,), outside the training range (n,), status code (n,) (an index into
/// [`STATUS_NAMES`]), for every refused row (row, reason), and, for a model whose covariance
/// predicts its error, the predicted standard deviation (n, 3) m/s² and `predicted_better` (n,).
pub type CorrectedColumns<'py> = (
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, PyArray2<f64>>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray1<u8>>,
    Vec<(usize, String)>,
    Option<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<bool>>)>,
);

/// (n, 3) from three columns stored one after another: a Fortran-ordered view, each column contiguous.
fn three_columns(py: Python<'_>, flat: Vec<f64>, n: usize) -> Bound<'_, PyArray2<f64>> {
    Array2::from_shape_vec((3, n), flat)
        .expect("three columns of n values")
        .reversed_axes()
        .into_pyarray(py)
}

/// Corrects rows exactly as `spincal correct` does, through the same library row corrector
/// ([`spincal::correctors::rows::RowCorrector`]): a row with a value that is not finite (as given
/// or after conversion to SI) or whose time goes backwards is refused (status `refused`, valid
/// False, corrected values NaN) and never reaches the corrector; a row whose corrected value is not
/// finite is refused after it.
#[allow(clippy::too_many_arguments)]
pub fn correct_rows<'py>(
    py: Python<'py>,
    file: &spincal::correctors::model_file::CorrectorFile,
    time: Option<ArrayView1<'_, f64>>,
    accel: [ArrayView1<'_, f64>; 3],
    gyro: Option<[ArrayView1<'_, f64>; 3]>,
    temperature: Option<ArrayView1<'_, f64>>,
    plan: &ColumnPlan,
) -> PyResult<CorrectedColumns<'py>> {
    use spincal::correctors::rows::{RowCorrector, RowOutcome, RowStatus, RowValue, UnitFactors};
    let n = accel[0].len();
    let columns_given = accel
        .iter()
        .chain(gyro.iter().flatten())
        .chain(time.iter())
        .chain(temperature.iter());
    if let Some(bad) = columns_given.map(|c| c.len()).find(|&len| len != n) {
        return Err(usage(format!(
            "the columns differ in length ({bad} and {n} rows): every column needs one value per row"
        )));
    }
    let units = UnitFactors {
        time_to_s: plan.time_to_s,
        accel_to_mps2: plan.accel_to_mps2,
        gyro_to_radps: plan.gyro_to_radps,
    };
    // The gyro is corrected when the model calibrates it and the data has it, as by the CLI.
    let model_error = |e: spincal::correctors::rows::SingularGyro| {
        errors::with_place(Kind::Model, e.to_string(), &Place::default())
    };
    let corrects_gyro = RowCorrector::new(file, units, gyro.is_some())
        .map_err(model_error)?
        .corrects_gyro();
    let gyro = gyro.filter(|_| corrects_gyro);
    let names = &plan.names;
    // Arrays come in °C; a frame's column in the unit its plan found.
    let temperature_unit = plan
        .temperature_unit
        .as_deref()
        .and_then(TemperatureUnit::parse)
        .unwrap_or(TemperatureUnit::C);
    // The unit checked from the first rows, as `spincal correct` does, before any row.
    if let (Some(_), Some(t)) = (&file.thermal, &temperature) {
        let first: Vec<f64> = t
            .iter()
            .take(spincal::thermal::checks::UNIT_CHECK_ROWS)
            .map(|&v| temperature_unit.to_celsius(v))
            .collect();
        spincal::thermal::checks::check_unit("the data", "temperature", &first, temperature_unit)
            .map_err(|e| usage(e.to_string()))?;
    }
    let run = || {
        // Made here: the stream's state stays on the thread that runs without the GIL.
        let mut corrector = RowCorrector::new(file, units, gyro.is_some())?;
        let mut out = vec![f64::NAN; 3 * n];
        let mut gyro_out = gyro.map(|_| vec![f64::NAN; 3 * n]);
        let mut valid = Array1::<bool>::from_elem(n, false);
        let mut outside = Array1::<bool>::from_elem(n, false);
        let mut status = Array1::<u8>::from_elem(n, REFUSED);
        let mut refusals = Vec::new();
        let mut predicted = corrector
            .predicts_error()
            .then(|| (vec![f64::NAN; 3 * n], Array1::<bool>::from_elem(n, false)));
        let value_name = |v: RowValue| {
            let k = match v {
                RowValue::Time => 0,
                RowValue::Accel(a) => a + 1,
                RowValue::Gyro(a) => a + 4,
            };
            format!("column {}", names[k])
        };
        for i in 0..n {
            let outcome = corrector.correct(
                time.map(|t| t[i]),
                [accel[0][i], accel[1][i], accel[2][i]],
                gyro.map(|g| [g[0][i], g[1][i], g[2][i]]),
                temperature.map(|t| temperature_unit.to_celsius(t[i])),
                value_name,
            );
            match outcome {
                RowOutcome::Refused(reason) => refusals.push((i, reason)),
                RowOutcome::Corrected {
                    accel_mps2,
                    gyro_radps,
                    valid: row_valid,
                    status: row_status,
                    predicted: row_predicted,
                } => {
                    if let (Some((sd, better)), Some(p)) = (predicted.as_mut(), row_predicted) {
                        for a in 0..3 {
                            sd[a * n + i] = p.sd_mps2[a];
                        }
                        better[i] = p.better;
                    }
                    for a in 0..3 {
                        out[a * n + i] = accel_mps2[a];
                    }
                    if let (Some(g), Some(rate)) = (gyro_out.as_mut(), gyro_radps) {
                        for a in 0..3 {
                            g[a * n + i] = rate[a];
                        }
                    }
                    valid[i] = row_valid;
                    outside[i] = matches!(row_status, RowStatus::PhysicsOnly | RowStatus::OutsideRange);
                    status[i] = match row_status {
                        RowStatus::Ok => 0,
                        RowStatus::PhysicsOnly => 1,
                        RowStatus::OutsideRange => 2,
                        RowStatus::NoTemperature => 3,
                        RowStatus::OutsideTemperatureRange => 4,
                        RowStatus::SuspectTemperature => 5,
                    };
                }
            }
        }
        Ok((out, gyro_out, valid, outside, status, refusals, predicted))
    };
    let (out, gyro_out, valid, outside, status, refusals, predicted) = py.detach(run).map_err(model_error)?;
    Ok((
        three_columns(py, out, n),
        gyro_out.map(|g| three_columns(py, g, n)),
        valid.into_pyarray(py),
        outside.into_pyarray(py),
        status.into_pyarray(py),
        refusals,
        predicted.map(|(sd, better)| (three_columns(py, sd, n), better.into_pyarray(py))),
    ))
}
