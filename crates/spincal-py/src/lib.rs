//! `spincal._spincal`: the Python extension module. Thin: every function converts its arguments,
//! calls the library and converts the answer; results travel as JSON text (the library's own
//! serialisation, the same as results.json) and signals as numpy arrays. The pure-Python package
//! (`python/spincal`) wraps the JSON in typed result objects and draws progress bars.

use std::path::{Path, PathBuf};

use numpy::ndarray::{Array2, ArrayView2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use spincal::calibrate::CalibrationOutput;
use spincal::campaign::params::Params;
use spincal::campaign::{Campaign, CampaignOutput};
use spincal::correctors::corrector::Corrector;
use spincal::input::formats::{Format, ReadOptions};
use spincal::input::gyro_file::GyroColumns;
use spincal::input::recording::{GyroUnit, TimeUnit};
use spincal::sysid::{ModelKind, ModelSpec};
use spincal::{AccelUnit, CorrectorFile, CorrectorModel, Recording, RecordingError};

mod columns;
mod errors;
mod long;
mod params;

use errors::usage;

/// JSON text of a serialisable library value.
fn json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| errors::Error::new_err(format!("serialising the result: {e}")))
}

/// A time series of one IMU session in SI units (s, m/s², rad/s), as read or simulated.
#[pyclass(name = "Recording", module = "spincal._spincal", frozen)]
pub(crate) struct PyRecording {
    inner: Recording,
    notes: Vec<String>,
    raw_counts: bool,
    /// The gyro columns hold raw counts (the reader said so).
    gyro_counts: bool,
}

/// Three columns as one (n, 3) array: one copy into a (3, n) block, returned transposed (a
/// Fortran-ordered (n, 3) view of it, no second copy).
fn columns_to_array<'py>(py: Python<'py>, columns: &[Vec<f64>; 3]) -> Bound<'py, PyArray2<f64>> {
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
fn array_to_columns(view: ArrayView2<'_, f64>, what: &str) -> PyResult<[Vec<f64>; 3]> {
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
    #[pyo3(signature = (path, unit = "g"))]
    fn write_csv(&self, path: PathBuf, unit: &str) -> PyResult<()> {
        let unit =
            AccelUnit::parse(unit).ok_or_else(|| usage(format!("unit {unit:?}: expected g or mps2")))?;
        self.inner.write_csv_path(&path, unit).map_err(errors::output)
    }
}

fn parse_format(name: Option<&str>) -> PyResult<Option<Format>> {
    name.map(|f| Format::parse(f).ok_or_else(|| usage(format!("format {f:?} is not one spincal reads"))))
        .transpose()
}

/// Builds the library's read options from keyword arguments.
#[allow(clippy::too_many_arguments)]
fn read_options(
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
fn read(
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

/// Merges a JSON object of overrides into a default value (unknown keys refused by serde).
fn with_overrides<T: serde::Serialize + serde::de::DeserializeOwned>(
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
fn simulate(
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
fn simulation_defaults() -> PyResult<(String, String, String)> {
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
fn simulate_campaign(
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

fn write_text(path: &Path, text: &str) -> PyResult<()> {
    spincal::output::write_file(path, |out| std::io::Write::write_all(out, text.as_bytes()))
        .map_err(errors::output)
}

fn inner_recordings(recordings: &[PyRef<'_, PyRecording>]) -> PyResult<Vec<Recording>> {
    if recordings.is_empty() {
        return Err(usage("no recordings given: pass at least one recording"));
    }
    Ok(recordings.iter().map(|r| r.inner.clone()).collect())
}

/// Fits the turntable model to recordings; returns the fit as JSON and the reference (the
/// turntable's physical acceleration, m/s²) per recording as (n, 3) arrays. `params_json` changes
/// the library's settings as for [`calibrate`]; only its `fit` part is used.
#[pyfunction]
#[pyo3(signature = (recordings, *, params_json = None, progress = None))]
fn fit_turntable<'py>(
    py: Python<'py>,
    recordings: Vec<PyRef<'py, PyRecording>>,
    params_json: Option<&str>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(String, Vec<Bound<'py, PyArray2<f64>>>)> {
    let options = params::params_from(params_json)?.fit;
    let recordings = inner_recordings(&recordings)?;
    let (fit, references) = long::run(py, progress.as_ref(), |observer| {
        let refs: Vec<&Recording> = recordings.iter().collect();
        let fit = spincal::turntable::fit_turntable(&refs, &options, observer)?;
        let references: Vec<[Vec<f64>; 3]> = recordings
            .iter()
            .enumerate()
            .map(|(k, r)| fit.reference(k, &r.time_s))
            .collect();
        Ok::<_, spincal::turntable::FitError>((fit, references))
    })?
    .map_err(errors::fit)?;
    Ok((
        json(&fit)?,
        references.iter().map(|c| columns_to_array(py, c)).collect(),
    ))
}

/// A finished calibration: results (JSON), the saved corrector, and the report.
#[pyclass(name = "Calibration", module = "spincal._spincal", frozen)]
struct PyCalibration {
    output: CalibrationOutput,
    recordings: Vec<Recording>,
}

#[pymethods]
impl PyCalibration {
    /// results.json's content.
    fn result_json(&self) -> PyResult<String> {
        json(&self.output.result)
    }
    /// The saved corrector (model.json), or None when every corrector was worse than uncorrected
    /// on another recording (the verdict says why).
    fn corrector(&self) -> Option<PyCorrector> {
        self.output.saved.clone().map(|file| PyCorrector { file })
    }
    /// The reference (turntable physics, m/s²) per recording, (n, 3) each.
    fn references<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray2<f64>>> {
        self.output
            .references
            .iter()
            .map(|r| columns_to_array(py, &r.accel_mps2))
            .collect()
    }
    /// The chosen corrector applied to the first recording, (n, 3) m/s².
    fn corrected<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        columns_to_array(py, &self.output.corrected)
    }
    /// Writes model.json, results.json and report.html into `folder` (created), as the CLI does.
    fn write(&self, py: Python<'_>, folder: PathBuf) -> PyResult<()> {
        std::fs::create_dir_all(&folder)
            .map_err(|e| errors::OutputError::new_err(format!("{}: cannot create: {e}", folder.display())))?;
        if let Some(saved) = &self.output.saved {
            saved
                .write_path(&folder.join("model.json"))
                .map_err(errors::output)?;
        }
        let results =
            serde_json::to_string_pretty(&self.output.result).map_err(|e| usage(e.to_string()))? + "\n";
        write_text(&folder.join("results.json"), &results)?;
        let html = py
            .detach(|| spincal::report::render_report(&self.output, &self.recordings))
            .map_err(|e| errors::Error::new_err(format!("report: {e}")))?;
        write_text(&folder.join("report.html"), &html)
    }
}

/// Calibrates from turntable recordings (SPEC §1): the library's `Params` defaults (what
/// `spincal calibrate` runs) with the changes of `params_json`, a JSON object nested as `Params`
/// serialises; `sysid` replaces the orders of the named system-identification models
/// (`[("arx", [6, 8, 1])]`), which the library turns into full model specifications.
#[pyfunction]
#[pyo3(signature = (recordings, *, params_json = None, sysid = None, progress = None, sweep_runner = None))]
fn calibrate<'py>(
    py: Python<'py>,
    recordings: Vec<PyRef<'py, PyRecording>>,
    params_json: Option<&str>,
    sysid: Option<Vec<(String, Vec<usize>)>>,
    progress: Option<Bound<'py, PyAny>>,
    sweep_runner: Option<Py<PyAny>>,
) -> PyResult<PyCalibration> {
    let mut settings = params::params_from(params_json)?;
    for (kind, orders) in sysid.unwrap_or_default() {
        let parsed = match kind.to_ascii_lowercase().as_str() {
            "arx" => ModelKind::Arx,
            "bj" => ModelKind::Bj,
            "narx" => ModelKind::Narx,
            "hw" => ModelKind::Hw,
            other => {
                return Err(usage(format!(
                    "sysid model {other:?}: expected arx, bj, narx or hw"
                )))
            }
        };
        let spec =
            ModelSpec::new(parsed, &orders).map_err(|e| usage(format!("{kind} orders {orders:?}: {e}")))?;
        match settings.sysid.iter_mut().find(|s| s.kind == parsed) {
            Some(slot) => *slot = spec,
            None => settings.sysid.push(spec),
        }
    }
    let recordings = inner_recordings(&recordings)?;
    // A Python exception from the sweep runner, raised as itself once the library has stopped.
    let runner_failure: std::sync::Mutex<Option<PyErr>> = std::sync::Mutex::new(None);
    let outcome = long::run(py, progress.as_ref(), |observer| match &sweep_runner {
        None => spincal::calibrate::calibrate(&recordings, &settings, observer),
        Some(runner) => {
            let remote = |problem: &spincal::correctors::ann::AnnProblem,
                          sweep: &spincal::correctors::ann::SweepSettings,
                          _: &spincal::progress::Observer| {
                let jobs = spincal::correctors::ann::SweepJobs::new(problem, sweep);
                call_sweep_runner(runner, &jobs).map_err(|e| {
                    let message = e.to_string();
                    if let Ok(mut slot) = runner_failure.lock() {
                        slot.get_or_insert(e);
                    }
                    spincal::correctors::ann::AnnError::SweepExchange(format!(
                        "the sweep runner failed: {message}"
                    ))
                })
            };
            spincal::calibrate::calibrate_with_runner(&recordings, &settings, observer, &remote)
        }
    })?;
    if let Some(e) = runner_failure.into_inner().ok().flatten() {
        return Err(e);
    }
    let output = outcome.map_err(errors::fit)?;
    Ok(PyCalibration { output, recordings })
}

/// Hands a sweep's jobs to a Python runner, `runner(jobs_json, n_jobs) -> [run_json, ...]`, and
/// reads its runs back.
fn call_sweep_runner(
    runner: &Py<PyAny>,
    jobs: &spincal::correctors::ann::SweepJobs,
) -> PyResult<Vec<spincal::correctors::ann::SweepRun>> {
    let texts: Vec<String> =
        Python::attach(|py| runner.call1(py, (jobs.to_json(), jobs.len()))?.extract(py))?;
    texts
        .iter()
        .map(|text| spincal::correctors::ann::SweepRun::from_json(text))
        .collect::<Result<_, _>>()
        .map_err(errors::fit)
}

/// A worker's part of a distributed sweep: runs `jobs` (indices) of the sweep `jobs_json` (from
/// a `sweep_runner` of [`calibrate`]) one after another on this thread; returns each run's JSON.
/// The runs are those the local sweep makes, bit for bit.
#[pyfunction]
#[pyo3(signature = (jobs_json, jobs, *, progress = None))]
fn run_sweep_jobs(
    py: Python<'_>,
    jobs_json: &str,
    jobs: Vec<usize>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<Vec<String>> {
    let sweep = spincal::correctors::ann::SweepJobs::from_json(jobs_json).map_err(errors::usage_error)?;
    let total = jobs.len();
    long::run(py, progress.as_ref(), |observer| {
        let problem = sweep.problem();
        let mut runs = Vec::with_capacity(total);
        for (done, &job) in jobs.iter().enumerate() {
            observer(spincal::progress::Progress::step(
                "network sweep",
                done,
                Some(total),
            ));
            runs.push(spincal::correctors::ann::run_sweep_job(&problem, &sweep.settings, job)?.to_json());
        }
        Ok(runs)
    })?
    .map_err(|e: spincal::correctors::ann::AnnError| errors::usage_error(e))
}

/// A finished campaign calibration.
#[pyclass(name = "CampaignCalibration", module = "spincal._spincal", frozen)]
struct PyCampaignCalibration {
    output: CampaignOutput,
}

#[pymethods]
impl PyCampaignCalibration {
    /// results.json's content.
    fn result_json(&self) -> PyResult<String> {
        json(&self.output.result)
    }
    /// The saved corrector, or None when no corrector held on every held-out condition.
    fn corrector(&self) -> Option<PyCorrector> {
        self.output.saved.clone().map(|file| PyCorrector { file })
    }
}

/// Every file `spincal calibrate --campaign` writes, from a campaign's results.json and
/// model.json texts: [(name, content)] for model.json (when given), results.json, report.html,
/// imucal.json and imu_tk_*.calib.
#[pyfunction]
#[pyo3(signature = (results_json, model_json = None))]
fn campaign_files(
    py: Python<'_>,
    results_json: &str,
    model_json: Option<&str>,
) -> PyResult<Vec<(String, String)>> {
    let result: spincal::campaign::CampaignResult = serde_json::from_str(results_json)
        .map_err(|e| usage(format!("results.json is not a campaign result: {e}")))?;
    let model = model_json
        .map(|m| CorrectorFile::from_json(m, "model.json"))
        .transpose()
        .map_err(errors::model)?;
    let files = py
        .detach(|| spincal::report::campaign::campaign_files(&result, model.as_ref()))
        .map_err(|e| errors::Error::new_err(format!("drawing report.html: {e}")))?;
    Ok(files
        .into_iter()
        .map(|(name, text)| (name.to_string(), text))
        .collect())
}

/// Calibrates one unit from its campaign file (TOML), as `spincal calibrate --campaign`.
#[pyfunction]
#[pyo3(signature = (campaign, *, progress = None))]
fn calibrate_campaign(
    py: Python<'_>,
    campaign: PathBuf,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<PyCampaignCalibration> {
    use spincal::campaign::run::{calibrate_campaign_file, CampaignRunError};
    let campaign = Campaign::read_path(&campaign).map_err(errors::format)?;
    let output = long::run(py, progress.as_ref(), |observer| {
        calibrate_campaign_file(&campaign, &Params::default(), observer)
    })?
    .map_err(|e| match e {
        CampaignRunError::Load(e) => errors::format(e),
        e => errors::fit(e),
    })?;
    Ok(PyCampaignCalibration { output })
}

/// A saved corrector (model.json) of any kind: ann, linear, static, physical.
#[pyclass(name = "Corrector", module = "spincal._spincal", frozen)]
struct PyCorrector {
    file: CorrectorFile,
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
    /// Writes model.json.
    fn save(&self, path: PathBuf) -> PyResult<()> {
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
    /// The static calibration's JSON when this is one (for Allan deviation of calibrated data).
    fn static_json(&self) -> PyResult<Option<String>> {
        match &self.file.corrector {
            CorrectorModel::Static(cal) => Ok(Some(json(cal)?)),
            _ => Ok(None),
        }
    }
}

/// Classic calibration from still poses, as `spincal static` runs it (the library's
/// `calibrate_static`): detection, the 6, 9 or 12-parameter fit, and the recording's own gyro
/// when it has one. Settings not given are the library's defaults. Returns (report JSON, the
/// static corrector with its gyro model).
#[pyfunction]
#[pyo3(signature = (recording, *, parameters = 9, gravity_mps2 = None, init_s = None,
    window_s = None, threshold_factor = None, min_interval_s = None))]
#[allow(clippy::too_many_arguments)]
fn static_calibration(
    py: Python<'_>,
    recording: PyRef<'_, PyRecording>,
    parameters: usize,
    gravity_mps2: Option<f64>,
    init_s: Option<f64>,
    window_s: Option<f64>,
    threshold_factor: Option<f64>,
    min_interval_s: Option<f64>,
) -> PyResult<(String, PyCorrector)> {
    use spincal::correctors::static_cal::StaticModel;
    use spincal::static_calibration::{calibrate_static, StaticSettings, StillRecording};
    let model = StaticModel::from_n_params(parameters)
        .ok_or_else(|| usage(format!("parameters = {parameters}: expected 6, 9 or 12")))?;
    let defaults = StaticSettings::default();
    let settings = StaticSettings {
        model,
        gravity_mps2: gravity_mps2.unwrap_or(defaults.gravity_mps2),
        detection: spincal::correctors::static_detect::StaticOptions {
            init_s: init_s.unwrap_or(defaults.detection.init_s),
            window_s: window_s.unwrap_or(defaults.detection.window_s),
            threshold_factor: threshold_factor.unwrap_or(defaults.detection.threshold_factor),
            min_interval_s: min_interval_s.unwrap_or(defaults.detection.min_interval_s),
        },
        ..defaults
    };
    let rec = &recording.inner;
    let gyro = GyroColumns::of(rec, recording.gyro_counts, &rec.source.name);
    let input = StillRecording {
        recording: rec,
        raw_counts: recording.raw_counts,
        labels: None,
        gyro: gyro.as_ref(),
        gyro_required: false,
    };
    let calibration = py.detach(|| calibrate_static(&input, &settings).map_err(errors::fit))?;
    let corrector = PyCorrector {
        file: calibration.corrector_file(),
    };
    Ok((json(&calibration)?, corrector))
}

/// The noise of a still recording, as `spincal allan` measures it (the library's
/// `analyse_still`): an (n, 3) array sampled every `dt_s`, motion refused; returns JSON with the
/// curve (`curve`), the noise parameters (`noise`: density, bias instability, random walk) and
/// the samples used.
#[pyfunction]
#[pyo3(signature = (accel, dt_s, *, per_decade = 10))]
fn allan(py: Python<'_>, accel: PyReadonlyArray2<'_, f64>, dt_s: f64, per_decade: usize) -> PyResult<String> {
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
    gravity_mps2 = spincal::STANDARD_GRAVITY, vary_percent = 15.0))]
fn sensitivity(
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

/// A fleet error as the right exception: files and campaign entries → FormatError, the
/// calibration → FitError.
fn fleet_error(e: spincal::fleet::FleetError) -> PyErr {
    use spincal::campaign::run::CampaignRunError as R;
    use spincal::fleet::FleetError as F;
    match &e {
        F::NoCampaign { .. } | F::Campaign(_) | F::Run(R::Load(_)) => errors::format(e),
        F::Run(R::Calibration { .. }) => errors::fit(e),
        _ => errors::Error::new_err(e.to_string()),
    }
}

/// A unit's campaign file and every file it reads (campaign file, recordings, truth files), so a
/// driver can ship them to a worker: (campaign file, [inputs]).
#[pyfunction]
fn campaign_inputs(source: PathBuf) -> PyResult<(PathBuf, Vec<PathBuf>)> {
    let path = spincal::fleet::campaign_path(&source).map_err(fleet_error)?;
    let campaign = Campaign::read_path(&path).map_err(errors::format)?;
    Ok((path, campaign.inputs()))
}

/// The unit label of each source, unique in the fleet (a folder's name, …).
#[pyfunction]
fn unit_labels(sources: Vec<PathBuf>) -> Vec<String> {
    spincal::fleet::unit_labels(&sources)
}

/// Calibrates one unit (a campaign file or a folder holding campaign.toml) on one thread, as
/// `spincal calibrate --campaign`: returns (unit, results.json text, model.json text or None).
#[pyfunction]
#[pyo3(signature = (source, *, progress = None))]
fn calibrate_unit(
    py: Python<'_>,
    source: PathBuf,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(String, String, Option<String>)> {
    let settings = spincal::fleet::FleetSettings::default();
    let unit = long::run(py, progress.as_ref(), |observer| {
        spincal::fleet::calibrate_unit(&source, &settings, observer)
    })?
    .map_err(fleet_error)?;
    Ok((unit.unit.clone(), unit.results_json(), unit.model_json()))
}

/// One unit's outcome as the driver has it: (label, source, results.json or None, model.json or
/// None, error message or None).
type OutcomeTuple = (String, PathBuf, Option<String>, Option<String>, Option<String>);

/// The fleet table (every sensor parameter with its standard error per unit, fleet statistics,
/// outliers) from the units' outcomes; `outliers_json` overrides the library's OutlierSettings.
/// Returns (table JSON, table CSV, fleet.html).
#[pyfunction]
#[pyo3(signature = (outcomes, *, outliers_json = None))]
fn fleet_table(
    outcomes: Vec<OutcomeTuple>,
    outliers_json: Option<&str>,
) -> PyResult<(String, String, String)> {
    use spincal::fleet::{OutlierSettings, UnitCalibration, UnitOutcome};
    let settings = with_overrides(OutlierSettings::default(), outliers_json, "outlier settings")?;
    let mut units = Vec::with_capacity(outcomes.len());
    for (label, source, results, model, error) in outcomes {
        let result = match (results, error) {
            (Some(text), None) => {
                let result: spincal::campaign::CampaignResult = serde_json::from_str(&text)
                    .map_err(|e| usage(format!("{label}: results.json is not a campaign result: {e}")))?;
                let model = model
                    .map(|m| CorrectorFile::from_json(&m, &format!("{label}/model.json")))
                    .transpose()
                    .map_err(errors::model)?;
                Ok(UnitCalibration {
                    unit: result.unit.clone(),
                    campaign: source.clone(),
                    inputs: Vec::new(),
                    result,
                    model,
                })
            }
            (_, Some(message)) => Err(message),
            (None, None) => return Err(usage(format!("{label}: neither a result nor an error"))),
        };
        units.push(UnitOutcome {
            unit: label,
            source,
            result,
        });
    }
    let table = spincal::fleet::fleet_table(&units, &settings);
    let html = spincal::report::fleet::fleet_html(&table)
        .map_err(|e| errors::Error::new_err(format!("drawing fleet.html: {e}")))?;
    Ok((json(&table)?, table.to_csv(), html))
}

/// Simulates a fleet (`setup_json` overrides FleetSetup: units, faulty, spread, fault, campaign)
/// into `folder` (one campaign folder per unit, fleet-truth.json); returns (folders, truth JSON).
#[pyfunction]
#[pyo3(signature = (folder, seed = 7, setup_json = None))]
fn simulate_fleet(
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
    m.add_class::<PyCampaignCalibration>()?;
    m.add_class::<PyCorrector>()?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_class::<columns::ColumnPlan>()?;
    m.add("STATUS_NAMES", columns::STATUS_NAMES.to_vec())?;
    m.add_function(wrap_pyfunction!(columns::plan_columns, m)?)?;
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
