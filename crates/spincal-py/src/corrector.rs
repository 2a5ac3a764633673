//! The Corrector class: a saved model loaded and applied to readings.

use std::path::PathBuf;

use numpy::PyReadonlyArray1;
use pyo3::prelude::*;

use spincal::correctors::corrector::Corrector;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel};

use crate::{columns, errors, json};

/// A saved corrector (model.json) of any kind: ann, linear, static, physical.
#[pyclass(name = "Corrector", module = "spincal._spincal", frozen)]
pub(crate) struct PyCorrector {
    pub(crate) file: CorrectorFile,
}

#[pymethods]
impl PyCorrector {
    /// Loads model.json (refused when invalid or of another format version).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyCorrector> {
        let file = py
            .detach(|| CorrectorFile::read_path(&path))
            .map_err(errors::model)?;
        Ok(PyCorrector { file })
    }
    /// A corrector from model.json's text (`name` names it in errors).
    #[staticmethod]
    #[pyo3(signature = (text, name = "<model>"))]
    fn from_json(text: &str, name: &str) -> PyResult<PyCorrector> {
        let file = CorrectorFile::from_json(text, name).map_err(errors::model)?;
        Ok(PyCorrector { file })
    }
    /// model.json's text.
    fn to_json(&self) -> String {
        self.file.to_json()
    }
    /// Writes model.json; an existing file that spincal did not write is refused unless `force`.
    #[pyo3(signature = (path, force = false))]
    fn save(&self, path: PathBuf, force: bool) -> PyResult<()> {
        spincal::output::claim_outputs(&[&path], force).map_err(errors::usage_error)?;
        self.file.write_path(&path).map_err(errors::output)
    }
    /// `ann`, `linear`, `static` or `physical`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.file.corrector.kind()
    }
    /// The axes it changes (the others pass through).
    #[getter]
    fn axes(&self) -> Vec<&'static str> {
        self.file
            .corrector
            .corrected_axes()
            .iter()
            .map(|a| a.name())
            .collect()
    }
    /// Samples at the start without a full delay history (returned unchanged, valid = False).
    #[getter]
    fn warmup_samples(&self) -> usize {
        self.file.corrector.warmup_samples()
    }
    fn __repr__(&self) -> String {
        format!(
            "Corrector(kind={:?}, axes={:?}, warmup_samples={})",
            self.kind(),
            self.axes(),
            self.warmup_samples()
        )
    }
    /// Whether the model corrects the accelerometer for temperature (rows then need one).
    #[getter]
    fn has_thermal(&self) -> bool {
        self.file.thermal.is_some()
    }
    /// True when the file also calibrates the gyroscope (applied to gyro columns by `correct`).
    #[getter]
    fn has_gyro(&self) -> bool {
        self.file.gyro.is_some()
    }
    /// Corrects rows in time order exactly as `spincal correct` does: accel x, y, z and (optional)
    /// gyro x, y, z, time and temperature columns as 1-D arrays in the units `plan` states (read
    /// in place, whatever their strides). See `columns::correct_rows`.
    #[pyo3(signature = (accel, gyro, time, temperature, plan))]
    fn correct_columns<'py>(
        &self,
        py: Python<'py>,
        accel: (
            PyReadonlyArray1<'py, f64>,
            PyReadonlyArray1<'py, f64>,
            PyReadonlyArray1<'py, f64>,
        ),
        gyro: Option<(
            PyReadonlyArray1<'py, f64>,
            PyReadonlyArray1<'py, f64>,
            PyReadonlyArray1<'py, f64>,
        )>,
        time: Option<PyReadonlyArray1<'py, f64>>,
        temperature: Option<PyReadonlyArray1<'py, f64>>,
        plan: &columns::ColumnPlan,
    ) -> PyResult<columns::CorrectedColumns<'py>> {
        let accel = [accel.0.as_array(), accel.1.as_array(), accel.2.as_array()];
        let gyro = gyro
            .as_ref()
            .map(|g| [g.0.as_array(), g.1.as_array(), g.2.as_array()]);
        let time = time.as_ref().map(|t| t.as_array());
        let temperature = temperature.as_ref().map(|t| t.as_array());
        columns::correct_rows(py, &self.file, time, accel, gyro, temperature, plan)
    }
    /// Corrects the file `input` into the file `output` through the library's streaming pipeline
    /// (the CLI's `spincal correct`, to the bit): delimited text in constant memory, other formats
    /// read whole. An output that is the input, or an existing file spincal did not write, is
    /// refused unless `force`. `gyro_file`: the gyroscope from a second file, merged on time
    /// inside the stream (the CLI's `--gyro-file`). Returns the summary as JSON text.
    #[pyo3(signature = (input, output, *, format = None, columns = None, accel_unit = None, time_unit = None,
        gyro_unit = None, sample_rate_hz = None, accel_scale = None, retime = false, gyro_file = None, force = false))]
    #[allow(clippy::too_many_arguments)]
    fn correct_file(
        &self,
        py: Python<'_>,
        input: PathBuf,
        output: PathBuf,
        format: Option<&str>,
        columns: Option<&str>,
        accel_unit: Option<&str>,
        time_unit: Option<&str>,
        gyro_unit: Option<&str>,
        sample_rate_hz: Option<f64>,
        accel_scale: Option<f64>,
        retime: bool,
        gyro_file: Option<PathBuf>,
        force: bool,
    ) -> PyResult<String> {
        use spincal::correctors::stream::{correct_to_path, CorrectError};
        let options = crate::recording::read_options(
            format,
            columns,
            accel_unit,
            time_unit,
            gyro_unit,
            sample_rate_hz,
            accel_scale,
            retime,
        )?;
        let inputs: Vec<&std::path::Path> = std::iter::once(input.as_path())
            .chain(gyro_file.as_deref())
            .collect();
        spincal::output::check_outputs(&inputs, &[&output]).map_err(errors::usage_error)?;
        spincal::output::claim_outputs(&[&output], force).map_err(errors::usage_error)?;
        let summary = py
            .detach(|| correct_to_path(&self.file, &input, &options, gyro_file.as_deref(), &output))
            .map_err(|e| match e {
                CorrectError::Format(e) => errors::format(*e),
                CorrectError::Table(e) => errors::format(*e),
                CorrectError::Columns(e) => errors::format(*e),
                CorrectError::Open { .. } => errors::format(e),
                CorrectError::Model(e) => errors::model(e),
                CorrectError::Gyro(e) => errors::usage_error(*e),
                CorrectError::Output(e) => errors::output(e),
                e if e.is_usage() => errors::usage_error(e),
                e => errors::output(e),
            })?;
        // What the CLI prints, as data: its warnings and the refusals' sentence.
        let mut value = serde_json::to_value(&summary).map_err(errors::output)?;
        value["warnings"] = serde_json::json!(summary.warnings());
        value["refusals"] = serde_json::json!(summary.refusals());
        json(&value)
    }
    /// The static calibration's JSON when this is one (for Allan deviation of calibrated data).
    fn static_json(&self) -> PyResult<Option<String>> {
        match &self.file.corrector {
            CorrectorModel::Static(cal) => Ok(Some(json(cal)?)),
            _ => Ok(None),
        }
    }
}
