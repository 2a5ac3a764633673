//! Calibrations: the turntable fit, the paper's protocol, sweeps, campaigns and static
//! calibration, with their result classes.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::prelude::*;

use spincal::campaign::file::Campaign;
use spincal::campaign::params::Params;
use spincal::campaign::select::CampaignOutput;
use spincal::correctors::model_file::CorrectorFile;
use spincal::input::gyro_file::GyroColumns;
use spincal::input::recording::Recording;
use spincal::sysid::{ModelKind, ModelSpec};

use crate::corrector::PyCorrector;
use crate::errors::usage;
use crate::recording::{columns_to_array, PyRecording};
use crate::{errors, json, long, params};

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
pub(crate) fn fit_turntable<'py>(
    py: Python<'py>,
    recordings: Vec<PyRef<'py, PyRecording>>,
    params_json: Option<&str>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(String, Vec<Bound<'py, PyArray2<f64>>>)> {
    let options = params::params_from(params_json)?.fit;
    let recordings = inner_recordings(&recordings)?;
    let (fit, references) = long::run(py, progress.as_ref(), |observer| {
        let refs: Vec<&Recording> = recordings.iter().collect();
        let fit = spincal::turntable::fit::fit_turntable(&refs, &options, observer)?;
        let references: Vec<[Vec<f64>; 3]> = recordings
            .iter()
            .enumerate()
            .map(|(k, r)| fit.reference(k, &r.time_s))
            .collect();
        Ok::<_, spincal::turntable::fit::FitError>((fit, references))
    })?
    .map_err(errors::fit)?;
    Ok((
        json(&fit)?,
        references.iter().map(|c| columns_to_array(py, c)).collect(),
    ))
}

/// A finished calibration, of a campaign file or of turntable recordings (the paper's protocol):
/// results (JSON: the campaign envelope, with the paper's figures under `paper` where its
/// protocol ran), the saved corrector, the paper's signals where it ran, and the files.
#[pyclass(name = "Calibration", module = "spincal._spincal", frozen)]
pub(crate) struct PyCalibration {
    output: CampaignOutput,
}

impl PyCalibration {
    fn signals(&self) -> PyResult<&spincal::campaign::paper::PaperSignals> {
        self.output
            .paper_signals
            .as_deref()
            .ok_or_else(|| {
                errors::Error::new_err(
                    "references and corrected exist where the paper's protocol ran (spincal.calibrate on recordings); this calibration ran a campaign file",
                )
            })
    }
}

#[pymethods]
impl PyCalibration {
    /// results.json's content.
    fn result_json(&self) -> PyResult<String> {
        json(&self.output.result)
    }
    /// The saved corrector (model.json), or None when no corrector held on every held-out
    /// condition (the verdict says why).
    fn corrector(&self) -> Option<PyCorrector> {
        self.output.saved.clone().map(|file| PyCorrector { file })
    }
    /// The reference (turntable physics, m/s²) per recording, (n, 3) each.
    fn references<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        Ok(self
            .signals()?
            .references
            .iter()
            .map(|r| columns_to_array(py, &r.accel_mps2))
            .collect())
    }
    /// The saved corrector applied to the first recording (the recording itself when nothing
    /// was saved), (n, 3) m/s².
    fn corrected<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(columns_to_array(py, &self.signals()?.corrected))
    }
    /// Every file `spincal calibrate` writes, [(name, content)]: model.json, imucal.json and the
    /// imu_tk files when a corrector was saved, results.json and report.html.
    fn files(&self, py: Python<'_>) -> PyResult<Vec<(String, String)>> {
        let files = py
            .detach(|| {
                spincal::report::campaign::campaign_files(
                    &self.output.result,
                    self.output.saved.as_ref(),
                    self.output.paper_signals.as_deref(),
                )
            })
            .map_err(|e| errors::Error::new_err(format!("drawing report.html: {e}")))?;
        Ok(files
            .into_iter()
            .map(|(name, text)| (name.to_string(), text))
            .collect())
    }
}

/// Calibrates from turntable recordings (SPEC §1): the library's `Params` defaults (what
/// `spincal calibrate` runs) with the changes of `params_json`, a JSON object nested as `Params`
/// serialises; `sysid` replaces the orders of the named system-identification models
/// (`[("arx", [6, 8, 1])]`), which the library turns into full model specifications.
#[pyfunction]
#[pyo3(signature = (recordings, *, params_json = None, sysid = None, progress = None, sweep_runner = None))]
pub(crate) fn calibrate<'py>(
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
    Ok(PyCalibration { output })
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
pub(crate) fn run_sweep_jobs(
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

/// Every file `spincal calibrate --campaign` writes, from a campaign's results.json and
/// model.json texts: [(name, content)] for model.json (when given), results.json, report.html,
/// imucal.json and imu_tk_*.calib.
#[pyfunction]
#[pyo3(signature = (results_json, model_json = None))]
pub(crate) fn campaign_files(
    py: Python<'_>,
    results_json: &str,
    model_json: Option<&str>,
) -> PyResult<Vec<(String, String)>> {
    let result: spincal::campaign::select::CampaignResult = serde_json::from_str(results_json)
        .map_err(|e| usage(format!("results.json is not a campaign result: {e}")))?;
    let model = model_json
        .map(|m| CorrectorFile::from_json(m, "model.json"))
        .transpose()
        .map_err(errors::model)?;
    let files = py
        .detach(|| spincal::report::campaign::campaign_files(&result, model.as_ref(), None))
        .map_err(|e| errors::Error::new_err(format!("drawing report.html: {e}")))?;
    Ok(files
        .into_iter()
        .map(|(name, text)| (name.to_string(), text))
        .collect())
}

/// Writes `files` ([(path, text)]) through the library's writer, as the CLI does: all checked
/// first (no two the same file; each existing one written by spincal with its current content,
/// unless `force`), then each through a temporary file and recorded in its folder's
/// `.spincal-outputs.json`; missing folders are made. Returns the files replaced because of
/// `force`. A refusal is a UsageError and writes nothing.
#[pyfunction]
#[pyo3(signature = (files, force = false))]
pub(crate) fn write_outputs(
    py: Python<'_>,
    files: Vec<(PathBuf, String)>,
    force: bool,
) -> PyResult<Vec<PathBuf>> {
    use spincal::output::OutputError;
    let files: Vec<(&std::path::Path, &[u8])> =
        files.iter().map(|(p, t)| (p.as_path(), t.as_bytes())).collect();
    let replaced = py
        .detach(|| spincal::output::write_outputs(&[], &files, force))
        .map_err(|e| match e {
            OutputError::Io { .. } => errors::output(e),
            e => errors::usage_error(e),
        })?;
    Ok(replaced.into_iter().map(|r| r.path).collect())
}

/// Calibrates one unit from its campaign file (TOML), as `spincal calibrate --campaign`.
#[pyfunction]
#[pyo3(signature = (campaign, *, progress = None))]
pub(crate) fn calibrate_campaign(
    py: Python<'_>,
    campaign: PathBuf,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<PyCalibration> {
    use spincal::campaign::run::{calibrate_campaign_file, CampaignRunError};
    let campaign = Campaign::read_path(&campaign).map_err(errors::format)?;
    let output = long::run(py, progress.as_ref(), |observer| {
        calibrate_campaign_file(&campaign, &Params::default(), observer)
    })?
    .map_err(|e| match e {
        CampaignRunError::Load(e) => errors::format(e),
        e => errors::fit(e),
    })?;
    Ok(PyCalibration { output })
}

/// Classic calibration from still poses, as `spincal static` runs it (the library's
/// `calibrate_static`): detection, the 6, 9 or 12-parameter fit, and the recording's own gyro
/// when it has one. Settings not given are the library's defaults. Returns (report JSON, the
/// static corrector with its gyro model).
#[pyfunction]
#[pyo3(signature = (recording, *, parameters = 9, gravity_mps2 = None, init_s = None,
    window_s = None, threshold_factor = None, min_interval_s = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn static_calibration(
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
