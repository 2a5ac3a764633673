//! The whole calibration (SPEC §1): recordings → rotation rate → turntable fit → reference →
//! every corrector trained and compared → the best on validation chosen (never on test).
//!
//! Correctors are trained on the first recording with the 60/20/20 division; with two or more
//! recordings each corrector trained on the first is also tested on the others (cross-condition,
//! SPEC §6). System-identification models map one measured axis to its reference axis (SISO) and
//! are scored by simulation from `init_samples` measured outputs and by one-step prediction; only
//! simulation is available when correcting new data (no reference exists then), so selection uses
//! simulation fit for them. Network and linear correctors are static maps: both kinds coincide.

use std::ops::Range;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::campaign::params::{NetworkChoice, ParamError, Params};
use crate::campaign::verdict::Comparison;
use crate::correctors::ann::{
    architecture_label, reduce_sweep, run_sweep_locally, AnnError, AnnProblem, LmSettings, SweepRow,
    SweepRun, SweepSettings,
};
use crate::correctors::corrector::{Axis, Corrected, Corrector};
use crate::correctors::division::Division;
use crate::correctors::linear::{LinearError, LinearModel};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel};
use crate::input::recording::Recording;
use crate::metrics::{fit_percent, rmse};
use crate::progress::{Observer, Progress};
use crate::sysid::SysidError;
use crate::turntable::fit::fit_turntable;
use crate::turntable::fit::{FitError, TurntableFit};
use crate::turntable::sensitivity::{sensitivity_table, SensitivityInput, SensitivityRow};

mod cross_condition;
mod sysid;

use cross_condition::{cross_condition_rows, saving_decision, Trained};
use sysid::sysid_candidates;

/// Version of the `results.json` layout.
pub(crate) const RESULTS_VERSION: u32 = 1;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    #[error(transparent)]
    Fit(#[from] FitError),
    #[error("network: {0}")]
    Ann(#[from] AnnError),
    #[error("linear corrector: {0}")]
    Linear(#[from] LinearError),
    #[error("{model}: {source}")]
    Sysid {
        model: String,
        #[source]
        source: SysidError,
    },
    #[error(transparent)]
    Params(#[from] ParamError),
}

/// Fit % and RMSE of one prediction kind on one part, per corrected axis and their mean.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PartScore {
    pub fit_percent: Vec<f64>,
    pub fit_percent_mean: f64,
    pub rmse_mps2: Vec<f64>,
    pub rmse_mps2_mean: f64,
}

impl PartScore {
    fn new(fit: Vec<f64>, rmse: Vec<f64>) -> PartScore {
        PartScore {
            fit_percent_mean: fit.iter().sum::<f64>() / fit.len() as f64,
            rmse_mps2_mean: rmse.iter().sum::<f64>() / rmse.len() as f64,
            fit_percent: fit,
            rmse_mps2: rmse,
        }
    }
}

/// One row of the comparison (the paper's Table 2, extended).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ComparisonRow {
    pub model: String,
    pub structure: String,
    /// `static` (network, linear, uncorrected: simulation and one-step coincide) or `dynamic`.
    pub kind: String,
    pub train: PartScore,
    pub validation: PartScore,
    pub test: PartScore,
    /// One-step-prediction scores (dynamic models only).
    pub train_one_step: Option<PartScore>,
    pub test_one_step: Option<PartScore>,
    pub seconds: f64,
    /// Whether this corrector can be saved and applied to new data by `spincal correct`.
    pub savable: bool,
    /// Why the model could not be fitted (its scores are then NaN).
    pub failed: Option<String>,
    /// Why the scores should not be taken at face value: a simulation that diverges, or a model
    /// that fits the validation part above 50 % with its input held constant (it generates the
    /// turntable's sine instead of correcting the sensor). Such rows are not "best overall".
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A corrector trained on the first recording, applied to another one.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CrossRow {
    pub model: String,
    pub trained_on: String,
    pub tested_on: String,
    pub score: PartScore,
    /// Networks only: the share of samples whose input lay more than
    /// [`crate::correctors::ann::EXTRAPOLATION_MARGIN`] of the training range outside it (%).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outside_training_range_percent: Option<f64>,
    /// Against no correction on the same samples, with the campaign verdict's significance rule
    /// (`campaign::verdict`): blocks of `joint.block_s` seconds; no offset term, since each
    /// recording's reference carries its own fitted offset. `None` for the uncorrected row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_uncorrected: Option<Comparison>,
}

/// Where a recording stood, for the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingSummary {
    pub name: String,
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
    pub rpm_from_spectrum: f64,
    pub omega_from_spectrum_radps: f64,
    pub gaps: usize,
    pub saturated_samples: usize,
    pub warnings: Vec<String>,
}

use crate::progress::StageTime;

/// Everything a calibration found: the single source of every number in the report.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CalibrationResult {
    pub results_version: u32,
    pub spincal_version: String,
    pub seed: u64,
    pub axes: Vec<Axis>,
    pub recordings: Vec<RecordingSummary>,
    pub turntable: TurntableFit,
    pub sensitivity: Vec<SensitivityRow>,
    pub division: Division,
    pub network: NetworkChoice,
    pub sweep: Vec<SweepRow>,
    pub network_architecture: String,
    pub comparison: Vec<ComparisonRow>,
    pub cross_condition: Vec<CrossRow>,
    /// The corrector saved (best validation fit % among savable correctors that are no worse than
    /// uncorrected on any other recording), or "none".
    pub chosen: String,
    /// Whether the saved corrector was checked on a recording it was not trained on.
    pub validated_off_training_condition: bool,
    /// What was saved and how far it can be trusted, first in the report and on the terminal.
    pub verdict: String,
    /// The best on validation overall (may be a compare-only model), among rows without warnings.
    pub best_overall: String,
    pub seconds_total: f64,
    /// Where the time went: read (by the caller), turntable fit, network sweep and training,
    /// each corrector, cross-condition scoring, report (by the caller).
    #[serde(default)]
    pub stage_seconds: Vec<StageTime>,
}

/// Signals for the report's plots (not numbers shown as text).
#[derive(Debug, Clone)]
pub struct CalibrationOutput {
    pub result: CalibrationResult,
    /// `None` when every savable corrector was worse than uncorrected on another recording.
    pub saved: Option<CorrectorFile>,
    /// Reference (the turntable's physical acceleration, without sensor offsets) per recording.
    pub references: Vec<Recording>,
    /// The fitted model including offsets and drift (what the sensor should read) per recording.
    pub models: Vec<Recording>,
    /// The chosen corrector applied to the first recording.
    pub corrected: [Vec<f64>; 3],
}

/// Runs every job of a network sweep and returns each job's run exactly once, in any order:
/// [`run_sweep_locally`] on this machine's threads, or a runner that ships [`SweepJobs`](crate::correctors::ann::SweepJobs) to
/// other processes (the Python package's Ray runner). The result does not depend on which.
pub(crate) type SweepRunner<'a> =
    dyn Fn(&AnnProblem, &SweepSettings, &Observer) -> Result<Vec<SweepRun>, AnnError> + Sync + 'a;

/// Runs the whole calibration. `observer` hears about every stage and step.
pub fn calibrate(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
) -> Result<CalibrationOutput, CalibrateError> {
    calibrate_with_runner(recordings, settings, observer, &run_sweep_locally)
}

/// [`calibrate`] with the network sweep's jobs run by `runner`.
pub fn calibrate_with_runner(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
    runner: &SweepRunner,
) -> Result<CalibrationOutput, CalibrateError> {
    settings.check()?;
    let started = Instant::now();
    let refs: Vec<&Recording> = recordings.iter().collect();
    observer(Progress::step("turntable fit", 0, Some(1)));
    let clock = Instant::now();
    let turntable = fit_turntable(&refs, &settings.fit, observer)?;
    let mut stages = vec![stage_time("turntable fit", clock)];
    let sweep_clock = Instant::now();
    let references = with_signal(recordings, |k, t| turntable.reference(k, t));
    let models = with_signal(recordings, |k, t| turntable.model(k, t));
    let (measured, reference) = (&recordings[0], &references[0]);
    let problem = AnnProblem::new(
        measured,
        reference,
        &settings.correct_axes,
        settings.delays,
        settings.division,
    )?;

    let (sweep_rows, hidden, restarts) = choose_network(&problem, settings, observer, runner)?;
    if !sweep_rows.is_empty() {
        stages.push(stage_time("network sweep", sweep_clock));
    }
    let statics = train_static(
        &problem, measured, reference, &hidden, restarts, settings, observer,
    )?;

    let division = problem.division.clone();
    let axes_idx: Vec<usize> = settings.correct_axes.iter().map(|a| a.index()).collect();
    let split = SplitScoring::new(reference, &division, &axes_idx);
    let mut comparison = static_rows(&split, &statics, measured, settings);
    let (sysid_rows, sysid_models) =
        sysid_candidates(settings, measured, reference, &axes_idx, &division, observer);
    comparison.extend(sysid_rows);

    // Selection on validation only.
    let best_overall = best_on_validation(&mut comparison.iter().filter(|r| r.warnings.is_empty()));
    let chosen = best_on_validation(&mut comparison.iter().filter(|r| r.savable));
    // Each corrector's own time, as its comparison row has it.
    for row in comparison.iter().filter(|r| r.seconds > 0.0) {
        stages.push(StageTime {
            stage: format!("corrector {}", row.model),
            seconds: row.seconds,
        });
    }
    let cross_clock = Instant::now();
    let trained = Trained {
        network: &statics.network,
        linear: &statics.linear,
        sysid: &sysid_models,
    };
    let cross_condition =
        cross_condition_rows(recordings, &references, &axes_idx, settings, &trained, observer)?;
    let (chosen, verdict) = saving_decision(&chosen, &cross_condition, recordings.len(), &turntable);
    let (saved, corrected_all) = saved_corrector(&chosen, &statics, measured);
    let sensitivity = first_session_sensitivity(&turntable);
    let summaries = recording_summaries(recordings, &turntable);
    stages.push(stage_time("cross-condition", cross_clock));
    let result = CalibrationResult {
        results_version: RESULTS_VERSION,
        spincal_version: env!("CARGO_PKG_VERSION").to_string(),
        seed: settings.seed,
        axes: settings.correct_axes.clone(),
        recordings: summaries,
        turntable,
        sensitivity,
        division,
        network: settings.network.clone(),
        sweep: sweep_rows,
        network_architecture: architecture_label(&hidden),
        comparison,
        cross_condition,
        chosen,
        validated_off_training_condition: recordings.len() > 1 && saved.is_some(),
        verdict,
        best_overall,
        seconds_total: started.elapsed().as_secs_f64(),
        stage_seconds: stages,
    };
    Ok(CalibrationOutput {
        result,
        saved,
        references,
        models,
        corrected: corrected_all,
    })
}

/// The time since `clock` as stage `stage`'s.
fn stage_time(stage: &str, clock: Instant) -> StageTime {
    StageTime {
        stage: stage.into(),
        seconds: clock.elapsed().as_secs_f64(),
    }
}

/// The two static correctors trained on the first recording, with their training times.
struct StaticCorrectors {
    network: crate::correctors::ann::AnnModel,
    /// The network's inputs, architecture, outputs, delays and restarts, in words.
    network_label: String,
    network_seconds: f64,
    linear: LinearModel,
    linear_seconds: f64,
}

/// Trains the network of architecture `hidden` and the linear corrector on the first recording,
/// `measured` against `reference`.
fn train_static(
    problem: &AnnProblem,
    measured: &Recording,
    reference: &Recording,
    hidden: &[usize],
    restarts: usize,
    settings: &Params,
    observer: &Observer,
) -> Result<StaticCorrectors, CalibrateError> {
    observer(Progress::step("network", 0, Some(1)));
    let clock = Instant::now();
    let network = problem.train(hidden, restarts, settings.seed, &settings.lm)?;
    let network_seconds = clock.elapsed().as_secs_f64();

    observer(Progress::step("linear", 0, Some(1)));
    let clock = Instant::now();
    let linear = LinearModel::fit(measured, reference, &settings.correct_axes, settings.division)?;
    let linear_seconds = clock.elapsed().as_secs_f64();
    let network_label = format!(
        "{}-input [{}] {}-output, {} delays, {} restarts",
        settings.correct_axes.len() * (settings.delays + 1),
        architecture_label(hidden),
        settings.correct_axes.len(),
        settings.delays,
        restarts
    );
    Ok(StaticCorrectors {
        network,
        network_label,
        network_seconds,
        linear,
        linear_seconds,
    })
}

/// The comparison rows of the uncorrected signal and the two static correctors.
fn static_rows(
    split: &SplitScoring,
    statics: &StaticCorrectors,
    measured: &Recording,
    settings: &Params,
) -> Vec<ComparisonRow> {
    let corrected_axes = |c: &dyn Corrector, rec: &Recording| axes_of(&c.correct(rec), split.axes);
    let uncorrected: Vec<Vec<f64>> = split
        .axes
        .iter()
        .map(|&a| measured.accel_mps2[a].clone())
        .collect();
    vec![
        split.row("uncorrected", "measured signal".into(), &uncorrected, 0.0, false),
        split.row(
            "ANN",
            statics.network_label.clone(),
            &corrected_axes(&statics.network, measured),
            statics.network_seconds,
            true,
        ),
        split.row(
            "linear",
            format!("offset + {0}×{0} matrix", settings.correct_axes.len()),
            &corrected_axes(&statics.linear, measured),
            statics.linear_seconds,
            true,
        ),
    ]
}

/// The corrector file of the chosen static corrector (none for "none"), and the first
/// recording as it corrects it.
fn saved_corrector(
    chosen: &str,
    statics: &StaticCorrectors,
    measured: &Recording,
) -> (Option<CorrectorFile>, [Vec<f64>; 3]) {
    let saved = match chosen {
        "ANN" => Some(CorrectorModel::Ann(Box::new(statics.network.clone()))),
        "linear" => Some(CorrectorModel::Linear(Box::new(statics.linear.clone()))),
        _ => None,
    }
    .map(CorrectorFile::new);
    let corrected = match chosen {
        "ANN" => statics.network.correct(measured).accel_mps2,
        "linear" => statics.linear.correct(measured).accel_mps2,
        _ => measured.accel_mps2.clone(),
    };
    (saved, corrected)
}

/// The sensitivity table at the first recording's session.
fn first_session_sensitivity(turntable: &TurntableFit) -> Vec<SensitivityRow> {
    let first = &turntable.recordings[0];
    sensitivity_table(&SensitivityInput {
        radius_m: first.session.radius_m,
        tilt_rad: first.session.tilt_rad,
        omega_radps: first.session.omega_radps,
        beta_rad: turntable.mounting.beta_rad,
        gravity_mps2: turntable.gravity_mps2,
        vary: 0.15,
    })
}

/// The network's architecture: the settings' one, or the best on validation of a sweep run by
/// `runner` (with its rows); and the restarts to train it with.
fn choose_network(
    problem: &AnnProblem,
    settings: &Params,
    observer: &Observer,
    runner: &SweepRunner,
) -> Result<(Vec<SweepRow>, Vec<usize>, usize), CalibrateError> {
    Ok(match &settings.network {
        NetworkChoice::Sweep {
            grid,
            restarts,
            hessian_samples,
        } => {
            let sweep_settings = SweepSettings {
                grid: grid.clone(),
                restarts: *restarts,
                base_seed: settings.seed,
                lm: LmSettings {
                    hessian_samples: *hessian_samples,
                    ..settings.lm.clone()
                },
            };
            let runs = runner(problem, &sweep_settings, observer)?;
            let rows = reduce_sweep(problem, &sweep_settings, runs)?;
            let best = rows
                .iter()
                .min_by(|a, b| a.best_validation_mse.total_cmp(&b.best_validation_mse))
                .map(|r| r.hidden.clone())
                .unwrap_or_else(|| vec![10, 6]);
            (rows, best, *restarts)
        }
        NetworkChoice::Fixed { hidden, restarts } => (Vec::new(), hidden.clone(), *restarts),
    })
}

/// The corrected axes of a corrector's output.
fn axes_of(out: &Corrected, axes: &[usize]) -> Vec<Vec<f64>> {
    axes.iter().map(|&a| out.accel_mps2[a].clone()).collect()
}

/// Scores of full-length estimates on the three parts of the 60/20/20 division, against the
/// reference of the recording trained on.
struct SplitScoring<'a> {
    reference: &'a Recording,
    parts: [Vec<usize>; 3],
    axes: &'a [usize],
}

impl<'a> SplitScoring<'a> {
    fn new(reference: &'a Recording, division: &Division, axes: &'a [usize]) -> SplitScoring<'a> {
        let rows =
            |ranges: &[Range<usize>]| -> Vec<usize> { ranges.iter().flat_map(|r| r.clone()).collect() };
        SplitScoring {
            reference,
            parts: [
                rows(&division.train),
                rows(&division.validation),
                rows(&division.test),
            ],
            axes,
        }
    }

    fn part(&self, estimate: &[Vec<f64>], rows: &[usize]) -> PartScore {
        let mut fits = Vec::new();
        let mut errors = Vec::new();
        for (c, &a) in self.axes.iter().enumerate() {
            let y: Vec<f64> = rows.iter().map(|&i| self.reference.accel_mps2[a][i]).collect();
            let e: Vec<f64> = rows.iter().map(|&i| estimate[c][i]).collect();
            fits.push(fit_percent(&y, &e));
            errors.push(rmse(&y, &e));
        }
        PartScore::new(fits, errors)
    }

    /// The comparison row of a static corrector (simulation and one-step coincide).
    fn row(
        &self,
        model: &str,
        structure: String,
        estimate: &[Vec<f64>],
        seconds: f64,
        savable: bool,
    ) -> ComparisonRow {
        ComparisonRow {
            model: model.to_string(),
            structure,
            kind: "static".into(),
            train: self.part(estimate, &self.parts[0]),
            validation: self.part(estimate, &self.parts[1]),
            test: self.part(estimate, &self.parts[2]),
            train_one_step: None,
            test_one_step: None,
            seconds,
            savable,
            failed: None,
            warnings: Vec::new(),
        }
    }
}

/// The best on validation fit among `rows` (uncorrected and unscored rows aside), or "".
fn best_on_validation(rows: &mut dyn Iterator<Item = &ComparisonRow>) -> String {
    rows.filter(|r| r.model != "uncorrected")
        .filter(|r| r.validation.fit_percent_mean.is_finite())
        .max_by(|a, b| {
            a.validation
                .fit_percent_mean
                .total_cmp(&b.validation.fit_percent_mean)
        })
        .map(|r| r.model.clone())
        .unwrap_or_default()
}

/// Where each recording stood, for the report.
fn recording_summaries(recordings: &[Recording], turntable: &TurntableFit) -> Vec<RecordingSummary> {
    recordings
        .iter()
        .zip(&turntable.recordings)
        .map(|(rec, fit)| RecordingSummary {
            name: rec.source.name.clone(),
            samples: rec.len(),
            duration_s: rec.duration_s(),
            sample_rate_hz: fit.inspection.sample_rate_hz,
            rpm_from_spectrum: fit.rate.rpm,
            omega_from_spectrum_radps: fit.rate.omega_radps,
            gaps: fit.inspection.gaps.len(),
            saturated_samples: fit.inspection.saturation.iter().map(|s| s.samples).sum(),
            warnings: fit.inspection.warnings(&rec.source.name),
        })
        .collect()
}

/// Which of the turntable fit's parameters the recording determines, and the fit's own remedy for
/// those it does not.
fn determined_sentence(turntable: &TurntableFit) -> String {
    let known: Vec<&str> = turntable
        .params
        .iter()
        .filter(|p| p.determined)
        .map(|p| p.name.as_str())
        .collect();
    match &turntable.remedy {
        Some(remedy) => format!("This recording determines {}; {remedy}", known.join(", ")),
        None => format!(
            "This recording determines every parameter of the turntable fit ({}).",
            known.join(", ")
        ),
    }
}

/// Each recording's twin holding another signal (of recording k at times t) at the same samples.
fn with_signal(recordings: &[Recording], signal: impl Fn(usize, &[f64]) -> [Vec<f64>; 3]) -> Vec<Recording> {
    recordings
        .iter()
        .enumerate()
        .map(|(k, rec)| Recording {
            time_s: rec.time_s.clone(),
            accel_mps2: signal(k, &rec.time_s),
            gyro_radps: None,
            temperature_c: None,
            source: rec.source.clone(),
        })
        .collect()
}
