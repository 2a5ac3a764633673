//! The paper's protocol (SPEC §1) on the campaign spine. Its recordings are a campaign of
//! turntable runs without poses, calibrated by `campaign::select::calibrate_campaign`: held-out
//! conditions decide what is saved, and the result is the campaign's envelope. Beside it the
//! paper's own figures are computed and reported (`campaign::paper::PaperProtocol`): recordings
//! → rotation rate → turntable fit → reference → the network's architecture (a sweep, or the
//! settings') → the paper's candidates (`campaign::series_candidates`) through the evaluation's
//! split mode (`campaign::evaluate::SplitEvaluation`: the 60/20/20 division of the first
//! recording, the best on validation named, never on test; with two or more recordings each
//! corrector also tested on the others, SPEC §6).

use std::time::Instant;

use crate::campaign::evaluate::{Evaluation, SplitError, SplitEvaluation};
use crate::campaign::file::{SignedAxis, TurntableEntry};
use crate::campaign::paper::{ComparisonRow, CrossRow, PaperProtocol, PaperSignals, RecordingSummary};
use crate::campaign::params::{NetworkChoice, ParamError, Params};
use crate::campaign::prepare::UnitRecording;
use crate::campaign::select::{calibrate_campaign, CampaignCalError, CampaignOutput};
use crate::campaign::series_candidates::paper_candidates;
use crate::correctors::ann::{
    architecture_label, reduce_sweep, run_sweep_locally, AnnError, AnnProblem, LmSettings, SweepRow,
    SweepRun, SweepSettings,
};
use crate::correctors::corrector::Corrector;
use crate::input::recording::Recording;
use crate::progress::{Observer, Progress, StageTime};
use crate::turntable::fit::fit_turntable;
use crate::turntable::fit::RadiusPrior;
use crate::turntable::fit::{FitError, TurntableFit};
use crate::turntable::sensitivity::{sensitivity_table, SensitivityInput, SensitivityRow};

/// Version of the paper figures' layout in `results.json` (2: under the campaign envelope's
/// `paper`, the saving decision the envelope's).
pub(crate) const RESULTS_VERSION: u32 = 2;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    #[error(transparent)]
    Fit(#[from] FitError),
    #[error("network: {0}")]
    Ann(#[from] AnnError),
    #[error(transparent)]
    Split(#[from] SplitError),
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error(transparent)]
    Campaign(#[from] CampaignCalError),
}

/// Runs every job of a network sweep and returns each job's run exactly once, in any order:
/// [`run_sweep_locally`] on this machine's threads, or a runner that ships [`SweepJobs`](crate::correctors::ann::SweepJobs) to
/// other processes (the Python package's Ray runner). The result does not depend on which.
pub(crate) type SweepRunner<'a> =
    dyn Fn(&AnnProblem, &SweepSettings, &Observer) -> Result<Vec<SweepRun>, AnnError> + Sync + 'a;

/// The paper's figures alone (`spincal compare`): no held-out conditions, nothing saved.
pub fn paper_protocol(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
) -> Result<PaperProtocol, CalibrateError> {
    settings.check()?;
    Ok(paper_figures(recordings, settings, observer, &run_sweep_locally)?.0)
}

/// Runs the whole calibration. `observer` hears about every stage and step.
pub fn calibrate(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
) -> Result<CampaignOutput, CalibrateError> {
    calibrate_with_runner(recordings, settings, observer, &run_sweep_locally)
}

/// [`calibrate`] with the network sweep's jobs run by `runner`: the paper's figures, then the
/// recordings as a campaign of turntable runs through the spine, which decides what is saved.
pub fn calibrate_with_runner(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
    runner: &SweepRunner,
) -> Result<CampaignOutput, CalibrateError> {
    settings.check()?;
    let started = Instant::now();
    let (paper, references, models) = paper_figures(recordings, settings, observer, runner)?;
    let units = paper_units(recordings, &paper.turntable, settings);
    let spine = Params {
        joint: crate::campaign::joint::JointSettings {
            gravity_mps2: paper.turntable.gravity_mps2,
            ..settings.joint.clone()
        },
        ..settings.clone()
    };
    // Named after the first recording's folder: apps give every export the same file name.
    let unit = recordings.first().map_or_else(String::new, |r| {
        crate::campaign::unit_name::unit_name(std::path::Path::new(&r.source.name))
    });
    let mut output = calibrate_campaign(&unit, &units, &spine, observer)?;
    let r = &mut output.result;
    r.verdict = paper_verdict(
        &r.verdict,
        recordings.len(),
        &paper,
        settings.fit.radius.is_some(),
    );
    r.stage_seconds.splice(0..0, paper.stage_seconds.iter().cloned());
    r.seconds_total = started.elapsed().as_secs_f64();
    let corrected = match &output.saved {
        Some(file) => file.corrector.correct(&recordings[0]).accel_mps2,
        None => recordings[0].accel_mps2.clone(),
    };
    output.result.paper = Some(Box::new(paper));
    output.paper_signals = Some(Box::new(PaperSignals {
        recordings: recordings.to_vec(),
        references,
        models,
        corrected,
    }));
    Ok(output)
}

/// The radius tolerance given to a run when no ruler was named (`fit.radius`), relative to the
/// turntable fit's radius: scale errors in the platter plane below it are invisible then.
pub const UNMEASURED_RADIUS_TOLERANCE: f64 = 0.05;

/// The recordings as a campaign's turntable runs: the speed measured from the spectrum, the axis
/// nearest gravity `up` (the run's in-plane angle is fitted, so `out` is any axis across it),
/// and the radius the settings name or, without one, the turntable fit's within
/// [`UNMEASURED_RADIUS_TOLERANCE`].
fn paper_units(recordings: &[Recording], turntable: &TurntableFit, settings: &Params) -> Vec<UnitRecording> {
    recordings
        .iter()
        .zip(&turntable.recordings)
        .map(|(recording, fit)| {
            let mean: [f64; 3] = std::array::from_fn(|k| {
                recording.accel_mps2[k].iter().sum::<f64>() / recording.len().max(1) as f64
            });
            let up = SignedAxis::nearest(mean);
            let out = SignedAxis {
                axis: (up.axis + 1) % 3,
                sign: 1,
            };
            let (radius_m, radius_tol_m) = match &settings.fit.radius {
                Some(prior) => (prior.value_m, prior.tolerance_m),
                None => (
                    fit.session.radius_m,
                    UNMEASURED_RADIUS_TOLERANCE * fit.session.radius_m.abs(),
                ),
            };
            UnitRecording {
                name: recording.source.name.clone(),
                recording: recording.clone(),
                turntable: Some(TurntableEntry {
                    rpm: fit.rate.rpm,
                    radius: Some(RadiusPrior {
                        value_m: radius_m,
                        tolerance_m: radius_tol_m,
                    }),
                    out,
                    up,
                    direction: None,
                    placement: None,
                    centre: None,
                }),
                truth: None,
                floor_mps2: None,
                random_mps2: None,
                session: None,
            }
        })
        .collect()
}

/// The spine's verdict with what the paper's protocol adds: which turntable parameters one
/// recording determines, and how far the radius was known.
fn paper_verdict(spine: &str, recordings: usize, paper: &PaperProtocol, ruler: bool) -> String {
    let mut verdict = spine.to_string();
    if recordings == 1 {
        verdict.push(' ');
        verdict.push_str(&paper.determined);
    }
    if !ruler {
        verdict.push_str(&format!(
            " No radius was given (fit.radius), so each run's radius is the turntable fit's within {:.0} %: a scale error of the axes in the platter plane below that is not seen.",
            100.0 * UNMEASURED_RADIUS_TOLERANCE
        ));
    }
    verdict
}

/// The paper's figures: the turntable fit, then the paper's candidates (its network, linear map
/// and system-identification models) through the split evaluation on the first recording and
/// the cross-condition scores; with each recording's reference and fitted model.
fn paper_figures(
    recordings: &[Recording],
    settings: &Params,
    observer: &Observer,
    runner: &SweepRunner,
) -> Result<(PaperProtocol, Vec<Recording>, Vec<Recording>), CalibrateError> {
    let refs: Vec<&Recording> = recordings.iter().collect();
    observer(Progress::step("turntable fit", 0, Some(1)));
    let clock = Instant::now();
    let turntable = fit_turntable(&refs, &settings.fit, observer)?;
    let mut stages = vec![stage_time("turntable fit", clock)];
    let sweep_clock = Instant::now();
    let references = with_signal(recordings, |k, t| turntable.reference(k, t));
    let models = with_signal(recordings, |k, t| turntable.model(k, t));
    let problem = AnnProblem::new(
        &recordings[0],
        &references[0],
        &settings.correct_axes,
        settings.delays,
        settings.division,
    )?;
    let (sweep_rows, hidden, restarts) = choose_network(&problem, settings, observer, runner)?;
    if !sweep_rows.is_empty() {
        stages.push(stage_time("network sweep", sweep_clock));
    }
    let division = problem.division.clone();
    let axes: Vec<usize> = settings.correct_axes.iter().map(|a| a.index()).collect();
    let scores = SplitEvaluation {
        recordings,
        references: &references,
        division: &division,
        axes: &axes,
        init_samples: settings.init_samples,
        delays: settings.delays,
        joint: &settings.joint,
    }
    .score(&paper_candidates(settings, &hidden, restarts), observer)?;
    // Each corrector's own time, as its comparison row has it.
    for row in scores.comparison.iter().filter(|r| r.seconds > 0.0) {
        stages.push(StageTime {
            stage: format!("corrector {}", row.model),
            seconds: row.seconds,
        });
    }
    stages.push(StageTime {
        stage: "cross-condition".into(),
        seconds: scores.cross_condition_seconds,
    });
    // Selection on validation only.
    let comparison = scores.comparison;
    let best_overall = best_on_validation(&mut comparison.iter().filter(|r| r.warnings.is_empty()));
    let best_savable = best_on_validation(&mut comparison.iter().filter(|r| r.savable));
    let paper = PaperProtocol {
        results_version: RESULTS_VERSION,
        seed: settings.seed,
        axes: settings.correct_axes.clone(),
        recordings: recording_summaries(recordings, &turntable),
        sensitivity: first_session_sensitivity(&turntable),
        determined: determined_sentence(&turntable),
        turntable,
        division,
        network: settings.network.clone(),
        sweep: sweep_rows,
        network_architecture: architecture_label(&hidden),
        best_on_validation: best_unless_worse_elsewhere(&best_savable, &scores.cross_condition),
        comparison,
        cross_condition: scores.cross_condition,
        best_overall,
        stage_seconds: stages,
    };
    Ok((paper, references, models))
}

/// The time since `clock` as stage `stage`'s.
fn stage_time(stage: &str, clock: Instant) -> StageTime {
    StageTime {
        stage: stage.into(),
        seconds: clock.elapsed().as_secs_f64(),
    }
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

/// The paper's choice among the correctors a file can hold: `best` (the best on validation),
/// unless another recording shows it significantly worse than no correction; then the other
/// static corrector if that one held; else "none".
fn best_unless_worse_elsewhere(best: &str, cross_condition: &[CrossRow]) -> String {
    let worse_elsewhere = |model: &str| {
        cross_condition
            .iter()
            .filter(|r| r.model == model)
            .any(|r| r.against_uncorrected.as_ref().is_some_and(|c| c.worse))
    };
    let other = if best == "ANN" { "linear" } else { "ANN" };
    match (worse_elsewhere(best), worse_elsewhere(other)) {
        (false, _) => best.to_string(),
        (true, false) => other.to_string(),
        (true, true) => "none".to_string(),
    }
}
