//! The Recording class and reading recordings from files or bytes.

use std::path::PathBuf;

use numpy::ndarray::{Array2, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use spincal::input::formats::{Format, ReadOptions};
use spincal::input::recording::{AccelUnit, Recording, RecordingError};
use spincal::input::recording::{GyroUnit, TimeUnit};

use crate::errors::{self, usage};

/// A time series of one IMU session in SI units (s, m/s², rad/s), as read or simulated.
#[pyclass(name = "Recording", module = "spincal._spincal", frozen)]
pub(crate) struct PyRecording {
    pub(crate) inner: Recording,
    pub(crate) notes: Vec<String>,
    pub(crate) raw_counts: bool,
    /// The gyro columns hold raw counts (the reader said so).
    pub(crate) gyro_counts: bool,
}

#[pymethods]
impl PyRecording {
    /// Sample times, s (a copy).
    #[getter]
    fn time<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.time_s)
    }
    /// Accelerometer x, y, z in m/s², shape (n, 3).
    #[getter]
    fn accel<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        columns_to_array(py, &self.inner.accel_mps2)
    }
    /// Gyroscope x, y, z in rad/s, shape (n, 3), or None when not recorded.
    #[getter]
    fn gyro<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.inner.gyro_radps.as_ref().map(|g| columns_to_array(py, g))
    }
    /// The sensor's reported temperature in °C, shape (n,), or None when the file has none.
    #[getter]
    fn temperature<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .temperature_c
            .as_deref()
            .map(|t| PyArray1::from_slice(py, t))
    }
    /// The file name (or what the recording was made from).
    #[getter]
    fn name(&self) -> String {
        self.inner.source.name.clone()
    }
    /// The format read (`csv`, `phyphox`, `3dm-gx1`, …).
    #[getter]
    fn format(&self) -> String {
        self.inner.source.format.clone()
    }
    /// The columns used, as named in the file (t, ax, ay, az[, gx, gy, gz][, temperature]).
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.inner.source.columns.clone()
    }
    /// Metadata lines skipped before the data.
    #[getter]
    fn metadata(&self) -> Vec<String> {
        self.inner.source.metadata.clone()
    }
    /// What the reader wants you to know (synthesised time, dropped gyro counts …).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }
    /// True when the acceleration holds raw counts (no scale was given for a raw-count format).
    #[getter]
    fn raw_counts(&self) -> bool {
        self.raw_counts
    }
    /// Mean sample rate, Hz.
    #[getter]
    fn sample_rate_hz(&self) -> f64 {
        self.inner.sample_rate_hz()
    }
    /// First to last sample, s.
    #[getter]
    fn duration_s(&self) -> f64 {
        self.inner.duration_s()
    }
    fn __len__(&self) -> usize {
        self.inner.len()
    }
    fn __repr__(&self) -> String {
        format!(
            "Recording(name={:?}, format={:?}, samples={}, duration_s={:.3}, gyro={})",
            self.inner.source.name,
            self.inner.source.format,
            self.inner.len(),
            self.inner.duration_s(),
            self.inner.gyro_radps.is_some()
        )
    }
    /// Writes the recording as spincal's CSV (`t_s,ax_g,ay_g,az_g` for unit "g", or m/s²).
    /// An existing file that spincal did not write is refused unless `force`.
    #[pyo3(signature = (path, unit = "g", force = false))]
    fn write_csv(&self, path: PathBuf, unit: &str, force: bool) -> PyResult<()> {
        let unit =
            AccelUnit::parse(unit).ok_or_else(|| usage(format!("unit {unit:?}: expected g or mps2")))?;
        spincal::output::claim_outputs(&[&path], force).map_err(errors::usage_error)?;
        self.inner.write_csv_path(&path, unit).map_err(errors::output)
    }
}

/// Three columns as one (n, 3) array: one copy into a (3, n) block, returned transposed (a
/// Fortran-ordered (n, 3) view of it, no second copy).
pub(crate) fn columns_to_array<'py>(py: Python<'py>, columns: &[Vec<f64>; 3]) -> Bound<'py, PyArray2<f64>> {
    let n = columns[0].len();
    let mut flat = Vec::with_capacity(3 * n);
    for c in columns {
        flat.extend_from_slice(c);
    }
    let block = Array2::from_shape_vec((3, n), flat).expect("three columns of equal length");
    block.reversed_axes().into_pyarray(py)
}

/// An (n, 3) array as three columns (any strides); every value must be a finite number (the
/// error names the row and column, as for every other entry point).
pub(crate) fn array_to_columns(view: ArrayView2<'_, f64>, what: &str) -> PyResult<[Vec<f64>; 3]> {
    if view.ncols() != 3 {
        return Err(usage(format!(
            "{what}: expected an (n, 3) array, got shape {:?}",
            view.shape()
        )));
    }
    if let Some(((row, column), value)) = view.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(errors::with_place(
            errors::Kind::Format,
            format!("{what}[{row}, {column}]: the value is {value}; spincal needs finite numbers"),
            &errors::Place {
                row: Some(row),
                column: Some(column + 1),
                ..errors::Place::default()
            },
        ));
    }
    Ok(std::array::from_fn(|a| view.column(a).to_vec()))
}

pub(crate) fn parse_format(name: Option<&str>) -> PyResult<Option<Format>> {
    name.map(|f| Format::parse(f).ok_or_else(|| usage(format!("format {f:?} is not one spincal reads"))))
        .transpose()
}

/// Builds the library's read options from keyword arguments.
#[allow(clippy::too_many_arguments)]
pub(crate) fn read_options(
    format: Option<&str>,
    columns: Option<&str>,
    accel_unit: Option<&str>,
    time_unit: Option<&str>,
    gyro_unit: Option<&str>,
    sample_rate_hz: Option<f64>,
    accel_scale: Option<f64>,
    retime: bool,
) -> PyResult<ReadOptions> {
    let mut options = ReadOptions {
        format: parse_format(format)?,
        sample_rate_hz,
        accel_scale,
        retime,
        ..ReadOptions::default()
    };
    if let Some(spec) = columns {
        options.columns = options.columns.with_columns(spec).map_err(errors::usage_error)?;
    }
    options.columns.accel_unit = accel_unit
        .map(|u| AccelUnit::parse(u).ok_or_else(|| usage(format!("accel_unit {u:?}: expected g or mps2"))))
        .transpose()?;
    options.columns.time_unit = time_unit
        .map(|u| {
            TimeUnit::parse(u).ok_or_else(|| usage(format!("time_unit {u:?}: expected s, ms, us or ns")))
        })
        .transpose()?;
    options.columns.gyro_unit = gyro_unit
        .map(|u| GyroUnit::parse(u).ok_or_else(|| usage(format!("gyro_unit {u:?}: expected dps or radps"))))
        .transpose()?;
    Ok(options)
}

/// A reading error; columns that cannot be told apart are explained in Python's words.
fn read_error(e: spincal::input::formats::FormatError) -> PyErr {
    use spincal::input::formats::FormatError as F;
    match e {
        F::Recording(RecordingError::AmbiguousColumns { file, available }) => errors::with_place(
            errors::Kind::Format,
            format!(
                "{file}: cannot tell which columns hold time and acceleration (columns: {available}); pass \
                 columns=[\"t\", \"ax\", \"ay\", \"az\"] (names or 1-based positions, gx, gy, gz after them for the gyro)"
            ),
            &errors::Place {
                path: Some(file),
                ..errors::Place::default()
            },
        ),
        F::Recording(RecordingError::NoTimeColumn { file, available, accel }) => errors::with_place(
            errors::Kind::Format,
            format!(
                "{file}: no time column among {available} (the acceleration is in {accel}); pass \
                 columns=[\"T\", ...] naming it (time_unit=\"ms\", \"us\" or \"ns\" if it is not in s), or \
                 sample_rate_hz=HZ when the file has none"
            ),
            &errors::Place {
                path: Some(file),
                ..errors::Place::default()
            },
        ),
        e => errors::format(e),
    }
}

/// Reads a recording in any supported format from a path or from bytes (`name` names it in errors).
#[pyfunction]
#[pyo3(signature = (source, *, name = None, format = None, columns = None, accel_unit = None, time_unit = None,
    gyro_unit = None, sample_rate_hz = None, accel_scale = None, retime = false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn read(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    name: Option<String>,
    format: Option<&str>,
    columns: Option<&str>,
    accel_unit: Option<&str>,
    time_unit: Option<&str>,
    gyro_unit: Option<&str>,
    sample_rate_hz: Option<f64>,
    accel_scale: Option<f64>,
    retime: bool,
) -> PyResult<PyRecording> {
    let options = read_options(
        format,
        columns,
        accel_unit,
        time_unit,
        gyro_unit,
        sample_rate_hz,
        accel_scale,
        retime,
    )?;
    let loaded = if let Ok(bytes) = source.cast::<PyBytes>() {
        let data = bytes.as_bytes();
        let name = name.unwrap_or_else(|| "<bytes>".to_string());
        py.detach(|| spincal::input::formats::read_bytes(data, &name, &options))
    } else {
        let path: PathBuf = source.extract()?;
        py.detach(|| spincal::input::formats::read_path(&path, &options))
    }
    .map_err(read_error)?;
    let mut recording = loaded.recording;
    recording.source.format = loaded.format.name().to_string();
    Ok(PyRecording {
        inner: recording,
        notes: loaded.notes,
        raw_counts: loaded.raw_counts,
        gyro_counts: loaded.gyro_counts,
    })
}
