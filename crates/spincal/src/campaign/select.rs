//! Calibrating a unit: the joint fit, then every candidate corrector trained on all conditions
//! but one and scored on the one left out, for each condition in turn. The saved corrector is the
//! best on held-out conditions among those shown no worse than no correction on each of
//! them, whose gain stays near one and whose covariance does not predict them worse.
//!
//! Each candidate has one shape (`Candidate::train`: a training set in, a corrector out) and
//! every one is judged (`evaluate::HeldOutEvaluation`) by what physics requires of its output on
//! the held-out samples, with no truth (`verdict`); where a simulation carries the true specific
//! force, the same samples are scored against it too and the choice that truth would have made
//! is reported beside the one made without it.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::campaign::error_map::{error_map, next_pose, ErrorMap};
use crate::campaign::paper::{PaperProtocol, PaperSignals};
use crate::campaign::params::{ParamError, Params};

use crate::campaign::candidate::{candidate, Candidate};
use crate::campaign::checks::{check_poses_still, check_prepared, check_recordings, InputError};
use crate::campaign::choice::{
    choose_by_physics, no_conditions_verdict, nothing_saved_verdict, save_best, save_gyro_alone,
    share_determination, summarise, truth_check, CandidateSummary, Found, HeldOutScore, TruthCheck,
    NOTHING_SAVED,
};
use crate::campaign::evaluate::{conditions, Condition, Evaluation, HeldOutEvaluation};
use crate::campaign::gyro::{fit_gyro, GyroFit};
use crate::campaign::joint::{
    chip_offset, fit_joint, fit_joint_from, placement_fits, Advice, ChipOffset, JointError, JointFit,
    JointSettings, PlacementFit, GEOMETRY,
};
use crate::campaign::prepare::{prepare, PrepareError, Prepared, UnitRecording};
use crate::campaign::thermal::{
    check_temperature_units, propagated_uncertainty, temperature_bands, thermal_stage, CampaignThermal,
};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel, ErrorModel};
use crate::metrics::{term_threshold, TERM_FALSE_ALARM};
use crate::progress::{Observer, Progress};
use crate::turntable::fit::RadiusPrior;
use crate::turntable::segments::PhaseSegments;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignCalError {
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    #[error("joint fit: {0}")]
    Joint(#[from] JointError),
    #[error(transparent)]
    Input(#[from] InputError),
    #[error(transparent)]
    Params(#[from] ParamError),
    /// A temperature column in the wrong unit (named, with the likely one).
    #[error(transparent)]
    Temperature(#[from] crate::thermal::checks::TemperatureError),
}

/// The prior on q of the first, data-only fit, 1/(m/s²): far beyond any datasheet, so that it
/// regularises only what the campaign cannot see at all.
pub(crate) const DATA_ONLY_Q_PRIOR_SD: f64 = 1e-2;

/// Which of the physical family's terms the saved model carries, by one rule on the joint fit's
/// robust covariance (results.json): q is kept on each axis whose |q̂/se| passes the Wald test at
/// [`TERM_FALSE_ALARM`] and held at zero on the others; with none kept, the model without q is
/// the physical family's candidate. A held-out RMS, dominated by the noise, does not decide it.
/// The three misalignment terms are always carried: a consumer part's axes are never exactly
/// orthogonal, and holding an undetermined term at zero left seven-pose campaigns up to 11.8×
/// the oracle where carrying it left 5.7× (bench/accuracy/RESULTS.md).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TermsRule {
    /// q̂/se per axis.
    pub nonlinearity_z: [f64; 3],
    /// The |z| a term must reach.
    pub threshold: f64,
    pub keeps_nonlinearity: bool,
    /// The axes whose q the saved physical model carries.
    #[serde(default)]
    pub nonlinearity_axes: [bool; 3],
    pub rule: String,
}

impl TermsRule {
    /// The rule applied to `joint` (a fit with q on every axis); `None` where it has no q.
    pub fn of(joint: &JointFit) -> Option<TermsRule> {
        if !joint.terms.nonlinearity {
            return None;
        }
        let threshold = term_threshold();
        let nonlinearity_z: [f64; 3] = std::array::from_fn(|k| {
            let q = &joint.sensor_params[9 + k];
            q.std_error
                .map_or(0.0, |se| if se > 0.0 { q.value / se } else { 0.0 })
        });
        let nonlinearity_axes = nonlinearity_z.map(|z| z.abs() >= threshold);
        Some(TermsRule {
            nonlinearity_z,
            threshold,
            keeps_nonlinearity: nonlinearity_axes.contains(&true),
            nonlinearity_axes,
            rule: format!(
                "q is kept on each axis where |q̂/se| ≥ {threshold:.2} (a Wald test at two-sided false-alarm probability {TERM_FALSE_ALARM:e} on the joint fit's robust covariance) and held at zero on the others; with no axis kept, the physical model without q is the family's candidate"
            ),
        })
    }

    /// Why the rule sets its member aside (the candidate summary's `why_not`).
    fn why_set_aside(&self) -> String {
        let z = self.nonlinearity_z.map(|z| format!("{:.1}", z.abs())).join(", ");
        let family = if self.keeps_nonlinearity {
            "physical"
        } else {
            "physical-linear"
        };
        format!(
            "set aside by the terms rule: |q̂/se| per axis {z} against {:.2}, so the physical family's candidate is {family}",
            self.threshold
        )
    }

    /// The physical family's member this rule sets aside.
    fn set_aside(&self) -> crate::campaign::candidate::CandidateKind {
        if self.keeps_nonlinearity {
            crate::campaign::candidate::CandidateKind::PhysicalLinear
        } else {
            crate::campaign::candidate::CandidateKind::Physical
        }
    }
}

/// The priors on the sensor's terms the joint fit took (results.json): where the recordings leave
/// a term undetermined, its error bar is its prior's.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SensorPriors {
    /// Widths about zero: bias (m/s²), scale error, misalignment (rad), q (1/(m/s²)).
    pub width: [f64; 4],
    /// Which widths are a datasheet's bounds (the covariance takes bound/√3); the others are
    /// standard deviations.
    pub is_bound: [bool; 4],
}

/// Who decided the nonlinearity q (results.json).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NonlinearitySource {
    /// "data" (the campaign showed a nonlinearity wider than the prior, which then takes the
    /// width the data show), "prior" (the datasheet's or the default prior holds q), or "not
    /// fitted".
    pub decided_by: String,
    /// The prior's standard deviation used, 1/(m/s²).
    pub prior_sd: f64,
    /// q's standard errors with the data-only prior, 1/(m/s²), where that fit was made.
    pub data_only_se: Option<[f64; 3]>,
    /// The rule, in words.
    pub rule: String,
}

/// The joint fit with q's prior width decided by the data where they can: fitted first with the
/// wide prior [`DATA_ONLY_Q_PRIOR_SD`], the spread of q over the axes is estimated as
/// w² = mean over axes of (q̂² − se²) (the method of moments for a prior's variance). When w
/// exceeds the settings' prior, the data have shown a nonlinearity the prior would suppress: the fit
/// is made with w as the prior ("data"). Otherwise the settings' prior stands ("prior").
fn fit_with_nonlinearity_rule(
    prepared: &Prepared,
    settings: &Params,
    observer: &Observer,
) -> Result<(JointFit, JointSettings, NonlinearitySource), CampaignCalError> {
    let prior = settings.joint.sensor_prior_sd[3];
    let rule = format!(
        "q is first fitted with a prior of {DATA_ONLY_Q_PRIOR_SD:e} /(m/s²); the spread its estimates show beyond their standard errors, w² = mean(q̂² − se²), replaces the prior of {prior:.2e} /(m/s²) (the datasheet's bound, the covariance taking its rectangular spread bound/√3, or 0.5 % FS over ±8 g as a standard deviation) when larger"
    );
    let source = |decided_by: &str, prior_sd: f64, data_only_se: Option<[f64; 3]>| NonlinearitySource {
        decided_by: decided_by.into(),
        prior_sd,
        data_only_se,
        rule: rule.clone(),
    };
    // The spread of the bias offsets found by the first fit holds for every later fit (the final
    // one and each held-out fold's).
    let spread_found = |joint: &JointFit| JointSettings {
        bias_instability_mps2: joint.bias_spread.sd_mps2,
        estimate_bias_spread: false,
        ..settings.joint.clone()
    };
    if !settings.joint.terms.nonlinearity {
        let joint = fit_joint(&prepared.runs, &prepared.poses, &settings.joint, observer)?;
        let found = spread_found(&joint);
        return Ok((joint, found, source("not fitted", prior, None)));
    }
    let mut wide = settings.joint.clone();
    wide.sensor_prior_sd[3] = prior.max(DATA_ONLY_Q_PRIOR_SD);
    wide.sensor_prior_is_bound[3] = false;
    let data_only = fit_joint(&prepared.runs, &prepared.poses, &wide, observer)?;
    let settings_found = spread_found(&data_only);
    let q: [(f64, f64); 3] = std::array::from_fn(|k| {
        let p = &data_only.sensor_params[9 + k];
        (p.value, p.std_error.unwrap_or(f64::INFINITY))
    });
    let se = q.map(|(_, se)| se);
    let spread = q.iter().map(|(v, se)| v * v - se * se).sum::<f64>() / 3.0;
    let width = spread.max(0.0).sqrt();
    let chosen = if width.is_finite() && width > prior {
        let mut chosen = settings_found;
        chosen.sensor_prior_sd[3] = width;
        // The spread the data show is a standard deviation.
        chosen.sensor_prior_is_bound[3] = false;
        chosen
    } else {
        settings_found
    };
    let mut joint = fit_joint_from(
        &prepared.runs,
        &prepared.poses,
        &chosen,
        Some(&data_only),
        observer,
    )?;
    // What the first fit found of the spread, not the given value the second one took.
    joint.bias_spread = data_only.bias_spread;
    let by = if chosen.sensor_prior_sd[3] > prior {
        "data"
    } else {
        "prior"
    };
    Ok((
        joint,
        chosen.clone(),
        source(by, chosen.sensor_prior_sd[3], Some(se)),
    ))
}

/// Everything a campaign calibration found (results.json).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CampaignResult {
    /// The spincal that wrote it (also how a later run knows the file is spincal's).
    #[serde(default)]
    pub spincal_version: String,
    pub unit: String,
    pub recordings: Vec<String>,
    pub joint: JointFit,
    /// Each placement's chip radius: stated, fitted, and whether the runs contradict the
    /// statement.
    #[serde(default)]
    pub placements: Vec<PlacementFit>,
    /// The chip's offset from the device's centre, when runs state the centre they turn about.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chip_offset: Option<ChipOffset>,
    /// The runs cut at logging gaps into segments with their own phase.
    #[serde(default)]
    pub split_runs: Vec<PhaseSegments>,
    /// Sensor parameters the campaign does not determine, each with the still pose that most
    /// reduces its variance.
    pub undetermined: Vec<Advice>,
    /// Whether the data or the prior decided the nonlinearity q.
    pub nonlinearity: NonlinearitySource,
    /// The priors the joint fit held the sensor's terms to.
    #[serde(default)]
    pub sensor_priors: SensorPriors,
    /// Which of the physical family's terms the saved model carries, and why.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terms_rule: Option<TermsRule>,
    /// The gyroscope's calibration, when the runs carry gyro columns.
    pub gyro: Option<GyroFit>,
    /// Why the gyroscope could not be calibrated, when it could not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyro_error: Option<String>,
    /// The thermal model and the recordings it took to the reference temperature, when the
    /// still recordings carry a temperature over a few degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<CampaignThermal>,
    /// Why no thermal model was fitted although the recordings have a temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal_note: Option<String>,
    /// Temperature samples the checks kept out of the thermal fit (glitches, resets, implausible
    /// values, a stuck sensor), each named with its file and line.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub temperature_findings: Vec<crate::thermal::checks::TemperatureFinding>,
    /// How many samples they are.
    #[serde(default)]
    pub temperature_masked_samples: usize,
    pub conditions: Vec<Condition>,
    pub held_out: Vec<HeldOutScore>,
    pub candidates: Vec<CandidateSummary>,
    /// What the rule chooses when scored against truth (simulations only).
    pub truth_check: Option<TruthCheck>,
    /// Where the saved corrector can be trusted: its predicted error over every direction of
    /// gravity (a saved `physical`, `physical-linear` or `linear-12` model, which carry their
    /// parameters' covariance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error_map: Option<ErrorMap>,
    /// The saved corrector's name, if any.
    pub saved: Option<String>,
    /// Whether the saved corrector was judged on a condition it was not trained on (false when
    /// nothing was saved).
    #[serde(default)]
    pub validated_off_training_condition: bool,
    /// One paragraph: what was saved and why, or why nothing was.
    pub verdict: String,
    pub seconds_total: f64,
    /// Where the time went: joint fit, gyro fit, held-out conditions, final training (and read
    /// and report when the caller adds them).
    #[serde(default)]
    pub stage_seconds: Vec<crate::progress::StageTime>,
    /// The paper's figures, where its protocol ran (`calibrate::calibrate`): reported, not what
    /// decided the saving.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper: Option<Box<PaperProtocol>>,
}

/// The result and the corrector file to write (if any).
#[derive(Debug, Clone)]
pub struct CampaignOutput {
    pub result: CampaignResult,
    pub saved: Option<CorrectorFile>,
    /// The paper protocol's signals for the report's plots, where it ran.
    pub paper_signals: Option<Box<PaperSignals>>,
}

impl CampaignResult {
    /// Records how long reading the recordings took, as the first of the stages.
    pub fn add_read_seconds(&mut self, seconds: f64) {
        self.stage_seconds.insert(
            0,
            crate::progress::StageTime {
                stage: "read".into(),
                seconds,
            },
        );
    }
}

/// Calibrates a unit from its recordings.
pub fn calibrate_campaign(
    unit: &str,
    units: &[UnitRecording],
    settings: &Params,
    observer: &Observer,
) -> Result<CampaignOutput, CampaignCalError> {
    let started = Instant::now();
    settings.check()?;
    check_recordings(units)?;
    check_temperature_units(units)?;
    let mut clock = Instant::now();
    // Temperature first: everything after runs on readings taken to the reference temperature.
    let mut stage = thermal_stage(units, &settings.thermal, settings.joint.gravity_mps2);
    let normalised_units = stage.normalised_units.take();
    let units = normalised_units.as_deref().unwrap_or(units);
    let prepared = prepare(units)?;
    check_poses_still(units, &prepared)?;
    check_prepared(&prepared, settings.joint.gravity_mps2)?;
    observer(Progress::step("joint fit", 0, Some(1)));
    let mut stages = Vec::new();
    let mut lap = |name: &str, stages: &mut Vec<crate::progress::StageTime>| {
        stages.push(crate::progress::StageTime {
            stage: name.to_string(),
            seconds: clock.elapsed().as_secs_f64(),
        });
        clock = Instant::now();
    };
    if stage.thermal.is_some() {
        lap("thermal fit", &mut stages);
    }
    let (joint, mut joint_settings, nonlinearity) =
        fit_with_nonlinearity_rule(&prepared, settings, observer)?;
    if let Some(thermal) = stage.thermal.as_mut() {
        thermal.uncertainty = propagated_uncertainty(thermal, &joint, &joint_settings);
    }
    let terms_rule = TermsRule::of(&joint);
    // Every later fit (each fold's, the saved one) carries q only on the axes the rule keeps. The
    // saved model is trained from the campaign's fit with those terms; results.json reports the
    // fit the rule judged.
    let mut saved_from = None;
    if let Some(rule) = terms_rule
        .as_ref()
        .filter(|r| r.keeps_nonlinearity && r.nonlinearity_axes != [true; 3])
    {
        joint_settings.terms.nonlinearity_axes = rule.nonlinearity_axes;
        saved_from = Some(fit_joint_from(
            &prepared.runs,
            &prepared.poses,
            &joint_settings,
            Some(&joint),
            observer,
        )?);
    }
    let settings = &Params {
        joint: joint_settings,
        ..settings.clone()
    };
    lap("joint fit", &mut stages);
    let g = settings.joint.gravity_mps2;
    let undetermined = joint.undetermined(g, settings.determined_tolerance_mps2, &prepared.poses);
    // The gyroscope rides on the joint fit's rates; its failure costs the accelerometer nothing.
    let (gyro, gyro_error) = match fit_gyro(&prepared.runs, &prepared.poses, &joint, &settings.gyro) {
        Ok(fit) => (fit, None),
        Err(e) => (None, Some(e.to_string())),
    };
    lap("gyro fit", &mut stages);
    let placements = placement_fits(&prepared.runs, &joint);
    let chip_offset = chip_offset(&prepared.runs, &joint);
    let radii = check_radii(&prepared, &placements);
    let conditions = held_out_conditions(&prepared, stage.thermal.as_ref());
    let candidates: Vec<Box<dyn Candidate + Sync>> =
        settings.candidates.iter().map(|&k| candidate(k)).collect();
    let held_out = HeldOutEvaluation {
        prepared: &prepared,
        units,
        joint: &settings.joint,
        conditions: &conditions,
        offset_sd: offset_spread(&joint, prepared.runs.len()).max(settings.joint.bias_instability_mps2),
        radii: &radii,
    }
    .score(&candidates, observer);
    lap("held-out conditions", &mut stages);
    let mut summaries: Vec<CandidateSummary> = settings
        .candidates
        .iter()
        .map(|&kind| summarise(kind, &held_out, conditions.len()))
        .collect();
    share_determination(&mut summaries, &held_out);
    // The physical family's member the terms rule sets aside, with the reason.
    let set_aside_why = terms_rule
        .as_ref()
        .map(|r| (r.set_aside().name(), r.why_set_aside()));
    let set_aside = set_aside_why.as_ref().map(|(name, _)| *name);
    let best = choose_by_physics(&summaries, set_aside);
    let truth_check = truth_check(&summaries, &held_out, best, conditions.len(), set_aside);
    let found = Found {
        n_conditions: conditions.len(),
        truth_check: truth_check.as_ref(),
        thermal: stage.thermal.as_ref(),
        gyro: gyro.as_ref(),
    };
    let contradicted: Vec<String> = placements
        .iter()
        .filter(|p| p.contradicted)
        .map(PlacementFit::sentence)
        .collect();
    let (saved, verdict) = match best {
        // A wrong radius moves the in-plane scale, and held-out runs share it: nothing is saved.
        Some(_) if !contradicted.is_empty() => (
            None,
            format!(
                "{NOTHING_SAVED}: {}. Measure the radius to the chip again, or leave `radius_m` out and record a second speed in the same placement so that the runs give it.",
                contradicted.join("; ")
            ),
        ),
        Some(best) => save_best(
            best,
            settings,
            &prepared,
            saved_from.as_ref().unwrap_or(&joint),
            &found,
            observer,
        ),
        None if conditions.is_empty() => (None, no_conditions_verdict(&prepared, &undetermined)),
        None => (
            None,
            nothing_saved_verdict(
                &summaries,
                set_aside_why,
                &prepared,
                &undetermined,
                settings.joint.sensor_prior_is_bound,
                truth_check.as_ref(),
            ),
        ),
    };
    // With no candidate eligible, a contradicted radius is still a cause worth naming first.
    let verdict = if saved.is_none() && best.is_none() && !contradicted.is_empty() {
        format!("{}. {verdict}", contradicted.join("; "))
    } else {
        verdict
    };
    // No accelerometer correction shown to help: the gyro part the campaign determines is saved
    // alone (format 3), where no stated radius is contradicted.
    let gyro_alone = (saved.is_none() && contradicted.is_empty())
        .then(|| save_gyro_alone(gyro.as_ref(), &verdict))
        .flatten();
    let (saved, verdict) = match gyro_alone {
        Some((file, verdict)) => (Some(file), verdict),
        None => (saved, verdict),
    };
    lap("final training", &mut stages);
    let error_map = saved
        .as_ref()
        .and_then(|file| file.corrector.error_model())
        .map(|model| {
            let mut map = error_map(model, settings.joint.gravity_mps2, &prepared.poses);
            if let ErrorModel::Physical(physical) = model {
                map.next_pose = next_pose(&map, physical, &joint, &prepared.poses);
            }
            map
        });
    // The verdict leads with where the saved correction can be trusted.
    let verdict = match &error_map {
        Some(map) => format!("{} {verdict}", map.sentence()),
        None => verdict,
    };
    let accel_saved = saved
        .as_ref()
        .is_some_and(|f| !matches!(f.corrector, CorrectorModel::Uncorrected(_)));
    let validated_off_training_condition = accel_saved && best.is_some() && !conditions.is_empty();
    let saved_name = match &saved {
        Some(file) if !accel_saved => Some(file.corrector.kind().to_string()),
        Some(_) => best.map(|b| b.candidate.clone()),
        None => None,
    };
    Ok(CampaignOutput {
        result: CampaignResult {
            spincal_version: env!("CARGO_PKG_VERSION").to_string(),
            unit: unit.to_string(),
            recordings: units.iter().map(|u| u.name.clone()).collect(),
            joint,
            placements,
            chip_offset,
            split_runs: prepared.split_runs.clone(),
            undetermined,
            nonlinearity,
            sensor_priors: SensorPriors {
                width: settings.joint.sensor_prior_sd,
                is_bound: settings.joint.sensor_prior_is_bound,
            },
            terms_rule,
            gyro,
            gyro_error,
            thermal: stage.thermal,
            thermal_note: stage.note,
            temperature_findings: stage.findings,
            temperature_masked_samples: stage.masked_samples,
            conditions,
            held_out,
            candidates: summaries,
            truth_check,
            error_map,
            validated_off_training_condition,
            saved: saved_name,
            verdict,
            seconds_total: started.elapsed().as_secs_f64(),
            stage_seconds: stages,
            paper: None,
        },
        saved,
        paper_signals: None,
    })
}

/// The held-out groups of [`conditions`], then the temperature bands when a thermal model was
/// fitted.
fn held_out_conditions(prepared: &Prepared, thermal: Option<&CampaignThermal>) -> Vec<Condition> {
    let mut conditions = conditions(prepared);
    if let Some(thermal) = thermal {
        conditions.extend(
            temperature_bands(prepared, &thermal.die_c)
                .into_iter()
                .map(|(label, poses)| Condition {
                    label,
                    runs: Vec::new(),
                    poses,
                }),
        );
    }
    conditions
}

/// Per run, the radius its held-out physics check takes: the stated one, else its placement's
/// as the joint fit found it (within its standard error), from the placement's runs.
fn check_radii(prepared: &Prepared, placements: &[PlacementFit]) -> Vec<Option<RadiusPrior>> {
    prepared
        .runs
        .iter()
        .map(|run| {
            run.entry.radius.or_else(|| {
                let placement = placements.iter().find(|p| p.runs.contains(&run.name))?;
                Some(RadiusPrior {
                    value_m: placement.radius_m,
                    tolerance_m: placement.radius_se_m?,
                })
            })
        })
        .collect()
}

/// The RMS over runs and axes of the joint fit's per-run bias offsets (at each run's middle), m/s².
fn offset_spread(joint: &JointFit, runs: usize) -> f64 {
    let offsets: Vec<f64> = (0..runs)
        .flat_map(|i| joint.run_params(i)[GEOMETRY..GEOMETRY + 3].to_vec())
        .collect();
    (offsets.iter().map(|v| v * v).sum::<f64>() / offsets.len().max(1) as f64).sqrt()
}
