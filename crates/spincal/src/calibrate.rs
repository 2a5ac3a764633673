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
use crate::campaign::verdict::{compare, Comparison};
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
use crate::sysid::{fit_and_score, score, ModelSpec, Scores, SysidError, SysidModel};
use crate::turntable::fit::fit_turntable;
use crate::turntable::fit::{FitError, TurntableFit};
use crate::turntable::sensitivity::{sensitivity_table, SensitivityInput, SensitivityRow};

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

/// System identification, one SISO model per axis, each started from the seed of every random
/// choice: a comparison row per model (a model that cannot be fitted to this data is reported
/// with its reason, not fatal) and the fitted ones.
fn sysid_candidates(
    settings: &Params,
    measured: &Recording,
    reference: &Recording,
    axes_idx: &[usize],
    division: &Division,
    observer: &Observer,
) -> (Vec<ComparisonRow>, Vec<(String, Vec<SysidModel>)>) {
    let mut rows = Vec::new();
    let mut models = Vec::new();
    for (m, spec) in settings.sysid.iter().enumerate() {
        let spec = &ModelSpec {
            seed: settings.seed,
            ..spec.clone()
        };
        observer(Progress::step(
            "system identification",
            m,
            Some(settings.sysid.len()),
        ));
        let name = spec.kind.name().to_string();
        match fit_sysid_per_axis(
            spec,
            measured,
            reference,
            axes_idx,
            division,
            settings.init_samples,
        ) {
            Ok((row, fitted)) => {
                rows.push(row);
                models.push((name, fitted));
            }
            Err(source) => {
                let nan = || PartScore::new(vec![f64::NAN; axes_idx.len()], vec![f64::NAN; axes_idx.len()]);
                rows.push(ComparisonRow {
                    model: name,
                    structure: format!("{:?}", spec.orders),
                    kind: "dynamic".into(),
                    train: nan(),
                    validation: nan(),
                    test: nan(),
                    train_one_step: None,
                    test_one_step: None,
                    seconds: 0.0,
                    savable: false,
                    failed: Some(source.to_string()),
                    warnings: Vec::new(),
                });
            }
        }
    }
    (rows, models)
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

/// The correctors trained on the first recording.
struct Trained<'a> {
    network: &'a crate::correctors::ann::AnnModel,
    linear: &'a LinearModel,
    sysid: &'a [(String, Vec<SysidModel>)],
}

/// Cross-condition: every corrector trained on the first recording, scored on each other one
/// against its own reference.
fn cross_condition_rows(
    recordings: &[Recording],
    references: &[Recording],
    axes_idx: &[usize],
    settings: &Params,
    trained: &Trained<'_>,
    observer: &Observer,
) -> Result<Vec<CrossRow>, CalibrateError> {
    let measured = &recordings[0];
    let mut cross_condition = Vec::new();
    for (k, other) in recordings.iter().enumerate().skip(1) {
        observer(Progress::step(
            "cross-condition",
            k - 1,
            Some(recordings.len() - 1),
        ));
        let other_ref = &references[k];
        let block = time_blocks(&other.time_s, settings.joint.block_s);
        let raw: Vec<Vec<f64>> = axes_idx.iter().map(|&a| other.accel_mps2[a].clone()).collect();
        let raw_residuals = residuals(&raw, other_ref, axes_idx, settings.delays);
        // Each corrector scored from sample `from` on, and against no correction on those samples.
        let row = |model: &str, estimate: &[Vec<f64>], from: usize| {
            let mut fits = Vec::new();
            let mut errors = Vec::new();
            for (c, &a) in axes_idx.iter().enumerate() {
                let y = &other_ref.accel_mps2[a][from..];
                let e = &estimate[c][from..];
                fits.push(fit_percent(y, e));
                errors.push(rmse(y, e));
            }
            let against_uncorrected = (model != "uncorrected").then(|| {
                let own = residuals(estimate, other_ref, axes_idx, from);
                compare(&own, &raw_residuals, &block, 0.0)
            });
            CrossRow {
                model: model.to_string(),
                trained_on: measured.source.name.clone(),
                tested_on: other.source.name.clone(),
                score: PartScore::new(fits, errors),
                outside_training_range_percent: None,
                against_uncorrected: against_uncorrected.flatten(),
            }
        };
        cross_condition.push(row("uncorrected", &raw, settings.delays));
        let by_network = trained.network.correct(other);
        cross_condition.push(CrossRow {
            outside_training_range_percent: Some(
                100.0 * by_network.outside_training_range as f64 / other.len().max(1) as f64,
            ),
            ..row("ANN", &axes_of(&by_network, axes_idx), settings.delays)
        });
        cross_condition.push(row(
            "linear",
            &axes_of(&trained.linear.correct(other), axes_idx),
            settings.delays,
        ));
        for (name, models) in trained.sysid {
            let mut estimate = Vec::new();
            for (c, &a) in axes_idx.iter().enumerate() {
                let sim = models[c]
                    .simulate(
                        &[&other.accel_mps2[a]],
                        crate::sysid::SimInit::Measured {
                            y: &other_ref.accel_mps2[a],
                            n: settings.init_samples,
                        },
                    )
                    .map_err(|source| CalibrateError::Sysid {
                        model: name.clone(),
                        source,
                    })?;
                estimate.push(sim);
            }
            cross_condition.push(row(name, &estimate, settings.init_samples.max(settings.delays)));
        }
    }
    Ok(cross_condition)
}

/// Block number per sample: whole blocks of `block_s` seconds from the first sample.
fn time_blocks(time_s: &[f64], block_s: f64) -> Vec<usize> {
    let start = time_s.first().copied().unwrap_or(0.0);
    time_s
        .iter()
        .map(|t| ((t - start) / block_s).floor().max(0.0) as usize)
        .collect()
}

/// Per-sample residuals of `estimate` (one series per corrected axis) against the reference, from
/// sample `from` on; uncorrected axes count as zero, a non-finite residual as no sample.
fn residuals(
    estimate: &[Vec<f64>],
    reference: &Recording,
    axes_idx: &[usize],
    from: usize,
) -> Vec<Option<[f64; 3]>> {
    (0..reference.len())
        .map(|s| {
            if s < from {
                return None;
            }
            let mut e = [0.0; 3];
            for (c, &a) in axes_idx.iter().enumerate() {
                e[a] = estimate[c][s] - reference.accel_mps2[a][s];
            }
            e.iter().all(|v| v.is_finite()).then_some(e)
        })
        .collect()
}

/// What is saved, and the verdict: the best on validation unless another recording shows it
/// worse than no correction; then the other static corrector if that one held; else nothing.
fn saving_decision(
    chosen: &str,
    cross_condition: &[CrossRow],
    recordings: usize,
    turntable: &TurntableFit,
) -> (String, String) {
    // Worse only where the difference is significant against its own uncertainty.
    let worse_elsewhere = |model: &str| -> Option<String> {
        cross_condition.iter().filter(|r| r.model == model).find_map(|r| {
            let c = r.against_uncorrected.as_ref()?;
            c.worse.then(|| {
                format!(
                    "{model} makes {} worse than uncorrected ({:.2}× ± {:.2} the uncorrected RMS error, significant over {} blocks)",
                    r.tested_on, c.ratio, c.ratio_se, c.blocks
                )
            })
        })
    };
    let other = if chosen == "ANN" { "linear" } else { "ANN" };
    let validated = recordings > 1;
    match (worse_elsewhere(chosen), worse_elsewhere(other)) {
        (None, _) if validated => {
            // Where a network was not applied (outside its training range), "no worse" is only
            // "unchanged": say how much of the other recordings that was.
            let outside: Vec<String> = cross_condition
                .iter()
                .filter(|r| r.model == chosen)
                .filter_map(|r| {
                    r.outside_training_range_percent
                        .filter(|&p| p > 0.0)
                        .map(|p| format!("{p:.0} % of {}", r.tested_on))
                })
                .collect();
            let caveat = if outside.is_empty() {
                String::new()
            } else {
                format!(
                    " It was not applied outside its training range ({}): those readings pass through uncorrected; a campaign (`spincal calibrate --campaign`) calibrates what one speed cannot.",
                    outside.join(", ")
                )
            };
            (
                chosen.to_string(),
                format!(
                    "Saved {chosen}: the best on validation, and no worse than uncorrected on the {} other recording(s) it never trained on.{caveat}",
                    recordings - 1
                ),
            )
        }
        (None, _) => (
            chosen.to_string(),
            format!(
                "Saved {chosen}, NOT validated off its training condition: with one recording, nothing shows it holds at another speed, radius or mounting (a network extrapolates outside its training range). {} Record a second session at another speed or radius and calibrate both, or calibrate a campaign (`spincal calibrate --campaign`).",
                determined_sentence(turntable)
            ),
        ),
        (Some(why), None) => (
            other.to_string(),
            format!("Saved {other}, not {chosen}: {why}; {other} is no worse than uncorrected on every other recording."),
        ),
        (Some(why), Some(why_other)) => (
            "none".to_string(),
            format!(
                "Nothing saved: {why}; {why_other}. A corrector trained on one condition does not carry to the others: calibrate a campaign (`spincal calibrate --campaign`) with still poses and runs at several speeds and radii."
            ),
        ),
    }
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

/// Fits one SISO model per corrected axis on the training block and scores it (simulation and
/// one-step) on the three blocks.
fn fit_sysid_per_axis(
    spec: &ModelSpec,
    measured: &Recording,
    reference: &Recording,
    axes_idx: &[usize],
    division: &Division,
    init_samples: usize,
) -> Result<(ComparisonRow, Vec<SysidModel>), SysidError> {
    let mut per_part: [Vec<(f64, f64, f64, f64)>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    let mut seconds = 0.0;
    let mut structure = String::new();
    let mut fitted = Vec::new();
    let mut warnings = Vec::new();
    let blocks = [&division.train[0], &division.validation[0], &division.test[0]];
    for &a in axes_idx {
        let u = measured.accel_mps2[a].as_slice();
        let y = reference.accel_mps2[a].as_slice();
        let scored = fit_and_score(
            spec,
            &[u],
            y,
            blocks[0].clone(),
            None,
            init_samples,
            &crate::progress::silent,
        )?;
        seconds += scored.seconds;
        structure = scored.structure.clone();
        let mut parts = Vec::new();
        for (p, (range, part)) in blocks.iter().zip(["training", "validation", "test"]).enumerate() {
            let range = (*range).clone();
            let s = score(
                &scored.fitted.model,
                &[&u[range.clone()]],
                &y[range.clone()],
                init_samples,
            )?;
            per_part[p].push((
                s.simulation.fit_percent,
                s.simulation.rmse,
                s.one_step.fit_percent,
                s.one_step.rmse,
            ));
            parts.push((part, range, s));
        }
        warnings.extend(sysid_warnings(
            &scored.fitted.model,
            a,
            u,
            y,
            &parts,
            init_samples,
        )?);
        fitted.push(scored.fitted.model);
    }
    let collect = |p: usize, one_step: bool| {
        let fits = per_part[p]
            .iter()
            .map(|s| if one_step { s.2 } else { s.0 })
            .collect();
        let errors = per_part[p]
            .iter()
            .map(|s| if one_step { s.3 } else { s.1 })
            .collect();
        PartScore::new(fits, errors)
    };
    let row = ComparisonRow {
        model: spec.kind.name().to_string(),
        structure,
        kind: "dynamic".into(),
        train: collect(0, false),
        validation: collect(1, false),
        test: collect(2, false),
        train_one_step: Some(collect(0, true)),
        test_one_step: Some(collect(2, true)),
        seconds,
        savable: false,
        failed: None,
        warnings,
    };
    Ok((row, fitted))
}

/// Above this error RMS, in units of the reference's spread, a simulation has diverged.
const DIVERGED_SPREAD_RATIO: f64 = 10.0;
/// A model that reaches this validation fit (%) with its input held constant explains most of
/// the reference without the sensor: it generates the signal instead of correcting it.
const INPUT_FREE_FIT_PERCENT: f64 = 50.0;

/// The warnings of [`ComparisonRow::warnings`] for one axis's fitted dynamic model.
fn sysid_warnings(
    model: &SysidModel,
    axis: usize,
    u: &[f64],
    y: &[f64],
    parts: &[(&str, Range<usize>, Scores)],
    init_samples: usize,
) -> Result<Vec<String>, SysidError> {
    let axis_name = Axis::ALL[axis].name();
    let mut warnings = Vec::new();
    for (part, range, scores) in parts {
        let y = &y[range.clone()];
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let spread = (y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / y.len() as f64).sqrt();
        let error = scores.simulation.rmse;
        if !error.is_finite() || error > DIVERGED_SPREAD_RATIO * spread {
            warnings.push(format!(
                "the {axis_name} simulation diverges on the {part} part (error RMS {error:.3} m/s², {:.0}× \
                 the reference's spread)",
                error / spread
            ));
        }
    }
    if let Some((_, range, scores)) = parts.iter().find(|(part, _, _)| *part == "validation") {
        let u = &u[range.clone()];
        let held = vec![u.iter().sum::<f64>() / u.len() as f64; u.len()];
        let without_input = score(model, &[&held], &y[range.clone()], init_samples)?;
        let (with, without) = (
            scores.simulation.fit_percent,
            without_input.simulation.fit_percent,
        );
        if without >= INPUT_FREE_FIT_PERCENT {
            warnings.push(format!(
                "on {axis_name} it reaches {without:.1} % on the validation part with its input held \
                 constant ({with:.1} % with it): it generates the turntable's sine rather than \
                 correcting the sensor"
            ));
        }
    }
    Ok(warnings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sysid::PolyModel;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// Another recording's cross-condition rule, over 20 seeds: a corrector that only adds noise
    /// far below the sensor's (0.0002 against 0.02 m/s²) is "worse" by the plain comparison about
    /// half the time, by the significance rule at most once; one that adds a 0.01 m/s² bias is
    /// worse every time.
    #[test]
    fn cross_condition_worse_only_when_significant() {
        let n = 20_000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let truth: Vec<f64> = time_s.iter().map(|t| (3.5 * t).sin()).collect();
        let reference = Recording {
            time_s: time_s.clone(),
            accel_mps2: [truth.clone(), truth.clone(), vec![9.8; n]],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        let axes = [0, 1];
        let block = time_blocks(&time_s, 5.0);
        let (mut plain_worse, mut significant_worse, mut bias_found) = (0, 0, 0);
        for seed in 0..20 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let noise = Normal::new(0.0, 0.02).unwrap();
            let raw: Vec<Vec<f64>> = axes
                .iter()
                .map(|&a| {
                    reference.accel_mps2[a]
                        .iter()
                        .map(|v| v + noise.sample(&mut rng))
                        .collect()
                })
                .collect();
            let uncorrected = residuals(&raw, &reference, &axes, 0);
            let mut judged = |offset: f64, jitter: f64| {
                let jitter = Normal::new(0.0, jitter).unwrap();
                let estimate: Vec<Vec<f64>> = raw
                    .iter()
                    .map(|axis| {
                        axis.iter()
                            .map(|v| v + offset + jitter.sample(&mut rng))
                            .collect()
                    })
                    .collect();
                compare(
                    &residuals(&estimate, &reference, &axes, 0),
                    &uncorrected,
                    &block,
                    0.0,
                )
                .unwrap()
            };
            let slightly = judged(0.0, 0.0002);
            assert_eq!((slightly.samples, slightly.blocks), (n, 40));
            plain_worse += usize::from(slightly.ratio > 1.0);
            significant_worse += usize::from(slightly.worse);
            bias_found += usize::from(judged(0.01, 0.0).worse);
        }
        assert!(
            plain_worse >= 5,
            "the plain rule called {plain_worse} of 20 worse"
        );
        assert!(
            significant_worse <= 1,
            "the significance rule called {significant_worse} of 20 worse"
        );
        assert_eq!(bias_found, 20);
    }

    /// An ARX model y(t) = −a₁y(t−1) − a₂y(t−2) + b₁u(t−1), scored on one "validation" part.
    fn warnings_for(a: Vec<f64>, b1: f64, u: &[f64], y: &[f64]) -> Vec<String> {
        let model = SysidModel::Poly(PolyModel {
            a,
            b: vec![vec![0.0, b1]],
            c: vec![1.0],
            d: vec![1.0],
            f: vec![vec![1.0]],
            nk: vec![1],
        });
        let range = 0..y.len();
        let scores = score(&model, &[u], y, 2).unwrap();
        sysid_warnings(&model, 0, u, y, &[("validation", range, scores)], 2).unwrap()
    }

    #[test]
    fn sysid_rows_warn_of_divergence_and_of_ignoring_the_input() {
        let w = 2.0 * std::f64::consts::PI * 0.55 / 100.0;
        let y: Vec<f64> = (0..3000).map(|t| (w * t as f64).sin()).collect();
        // The measured input is the reference a sample early, plus a small ripple.
        let u: Vec<f64> = (0..3000)
            .map(|t| (w * (t + 1) as f64).sin() + 0.01 * (0.37 * t as f64).sin())
            .collect();

        // A pure oscillator at the turntable's rate: exact without any input.
        let oscillator = warnings_for(vec![1.0, -2.0 * w.cos(), 1.0], 0.0, &u, &y);
        assert_eq!(oscillator.len(), 1, "{oscillator:?}");
        assert!(oscillator[0].contains("held constant"), "{oscillator:?}");

        // A pole at 1.02: the simulation runs away.
        let unstable = warnings_for(vec![1.0, -1.02], 0.1, &u, &y);
        assert!(
            unstable
                .iter()
                .any(|m| m.contains("diverges on the validation part")),
            "{unstable:?}"
        );

        // y(t) = u(t−1): uses its input, stays bounded, no warning.
        let follower = warnings_for(vec![1.0], 1.0, &u, &y);
        assert!(follower.is_empty(), "{follower:?}");
    }
}
