//! What a campaign saves: each candidate summarised over the held-out conditions (eligible only
//! when shown no worse than no correction on each, within a margin, with a gain near one and, for the physical
//! family, no predicted loss), the choice made without truth, what truth would have chosen, and
//! the verdict in words.

use crate::campaign::candidate::{candidate, CandidateKind, Trained, TrainingSet};
use crate::campaign::gyro::GyroFit;
use crate::campaign::joint::{Advice, JointFit};
use crate::campaign::params::Params;
use crate::campaign::prepare::Prepared;
use crate::campaign::thermal::CampaignThermal;
use crate::campaign::verdict::{
    combined, pooled_upper_ratio, Comparison, Pooled, Prediction, NON_INFERIORITY_MARGIN, NO_WORSE_CONFIDENCE,
};
use crate::correctors::model_file::{CorrectorFile, CorrectorModel, Uncorrected};
use crate::progress::{Observer, Progress};
use serde::{Deserialize, Serialize};

/// One candidate's error on one held-out condition.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct HeldOutScore {
    pub condition: String,
    pub candidate: String,
    /// Against physics, no truth needed (what decides); `None` when training or scoring failed.
    pub physics: Option<Comparison>,
    /// Against the true specific force on the same samples (simulations only).
    pub truth: Option<Comparison>,
    /// The physical family's figure with its covariance's prediction (see `verdict::Prediction`).
    pub predicted: Option<Prediction>,
    /// The random floor (drift + white noise) on those samples, m/s² (simulations only).
    pub floor_mps2: Option<[f64; 3]>,
    /// A static corrector's largest departure of ∂output/∂input from the identity at the
    /// condition's mean readings (`Trained::gain_error`); above [`MAX_GAIN_ERROR`] it is not
    /// eligible.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gain_error: Option<f64>,
    pub note: Option<String>,
}

/// One candidate over every held-out condition.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CandidateSummary {
    pub candidate: String,
    pub description: String,
    /// Mean over conditions of the residual RMS against physics (all axes), m/s².
    pub mean_rms_mps2: Option<f64>,
    /// Worst ratio of its residual RMS to the uncorrected one's against physics.
    pub worst_ratio_to_uncorrected: Option<f64>,
    /// The ratio's upper confidence bound pooled over the conditions
    /// (`verdict::pooled_upper_ratio`): saving needs it at most 1 + the margin.
    #[serde(default)]
    pub pooled_upper_ratio: Option<f64>,
    /// Its mean-square difference from uncorrected pooled over the conditions, with its standard
    /// error: what separates candidates.
    #[serde(default)]
    pub pooled: Option<Pooled>,
    /// Mean over conditions of the RMS error against truth (simulations), m/s².
    pub mean_truth_rms_mps2: Option<f64>,
    /// Worst ratio to uncorrected against truth (simulations).
    pub worst_truth_ratio: Option<f64>,
    /// Never significantly worse than uncorrected against physics and trained on every condition.
    pub eligible: bool,
    /// Why the candidate's own properties rule it out whatever its scores (its gain, its
    /// covariance's prediction): the truth check applies these too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_check: Option<String>,
    pub why_not: Option<String>,
}

/// What truth would have chosen (simulations): the check of the truth-free verdict.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TruthCheck {
    /// The candidate the same rule gives with truth-based scores.
    pub would_save: Option<String>,
    /// The truth-free choice is truth's, or within 10 % of its mean error against truth, or both
    /// save nothing.
    pub agrees: bool,
}

/// What the saved corrector's verdict and file carry beside the corrector itself.
pub(super) struct Found<'a> {
    pub(super) n_conditions: usize,
    pub(super) truth_check: Option<&'a TruthCheck>,
    pub(super) thermal: Option<&'a CampaignThermal>,
    pub(super) gyro: Option<&'a GyroFit>,
}

/// The chosen candidate trained on every recording: the corrector file and the verdict, or why
/// nothing was saved.
pub(super) fn save_best(
    best: &CandidateSummary,
    settings: &Params,
    prepared: &Prepared,
    joint: &JointFit,
    found: &Found,
    observer: &Observer,
) -> (Option<CorrectorFile>, String) {
    let kind = settings
        .candidates
        .iter()
        .copied()
        .find(|k| k.name() == best.candidate)
        .unwrap_or(CandidateKind::PhysicalLinear);
    // Every recording's joint fit is the one made above: the final training reuses it.
    let training = TrainingSet::with_fit(
        prepared.runs.clone(),
        prepared.poses.clone(),
        &settings.joint,
        joint.clone(),
    );
    observer(Progress::step("final training", 0, Some(1)));
    match candidate(kind).train(&training, observer) {
        Ok(Trained::Dynamic(_)) => (
            None,
            format!("{NOTHING_SAVED}: {} cannot be saved as a corrector", kind.name()),
        ),
        Ok(Trained::Corrector(model)) => {
            let verdict = format!(
                "Saved {} ({}), validated on {} conditions it never trained on: judged by physics alone (still poses' |f| against gravity, turntable runs against a rigid platter's motion with no sensor freedom), it leaves {:.4} m/s² mean RMS, at worst {:.2}× the uncorrected residual, and, pooled over them, is shown no worse (at most {:.2}× at {:.0} % confidence, within the {:.0} % margin). Trained on every recording of the campaign.{}",
                kind.name(),
                kind.describe(),
                found.n_conditions,
                best.mean_rms_mps2.unwrap_or(f64::NAN),
                best.worst_ratio_to_uncorrected.unwrap_or(f64::NAN),
                best.pooled_upper_ratio.unwrap_or(f64::NAN),
                100.0 * NO_WORSE_CONFIDENCE,
                100.0 * NON_INFERIORITY_MARGIN,
                truth_sentence(found.truth_check)
            );
            let mut file = CorrectorFile::new(model);
            file.thermal = found.thermal.map(|t| {
                let mut model = t.fit.model.clone();
                // Its directions move a physical corrector's parameters; the other kinds have none.
                if matches!(file.corrector, CorrectorModel::Physical(_)) {
                    model.uncertainty = t.uncertainty.clone();
                }
                model
            });
            let verdict = verdict + &thermal_sentence(found.thermal) + &with_gyro(&mut file, found.gyro);
            (Some(file), verdict)
        }
        Err(e) => (
            None,
            format!(
                "{NOTHING_SAVED}: the final training of {} failed: {e}",
                kind.name()
            ),
        ),
    }
}

/// The gyro part of `file`: only the terms the campaign determines (the rest at nominal), nothing
/// when none is; returns what the verdict says of it.
fn with_gyro(file: &mut CorrectorFile, gyro: Option<&GyroFit>) -> String {
    file.gyro = gyro.and_then(GyroFit::saved_model).cloned();
    gyro.map(GyroFit::nominal_sentence).unwrap_or_default()
}

/// How a verdict that saves no file opens.
pub(super) const NOTHING_SAVED: &str = "Nothing saved";

/// Where no accelerometer corrector is saved: the gyro part the campaign determines, alone (format
/// 3, the accelerometer left as read), and `verdict` (why nothing else was saved) with its
/// sentence on it, opening with what was saved since a file now is; `None` when the campaign
/// determines no gyro term.
pub(super) fn save_gyro_alone(gyro: Option<&GyroFit>, verdict: &str) -> Option<(CorrectorFile, String)> {
    gyro.and_then(GyroFit::saved_model)?;
    let mut file = CorrectorFile::new(CorrectorModel::Uncorrected(Box::new(Uncorrected {
        reason: "no accelerometer correction was shown to help on the campaign's held-out conditions".into(),
    })));
    let sentence = with_gyro(&mut file, gyro);
    let why = verdict.strip_prefix(NOTHING_SAVED).map_or_else(
        || verdict.to_string(),
        |rest| format!("No accelerometer correction saved{rest}"),
    );
    Some((
        file,
        format!("{why} Saved the gyroscope's calibration alone (the accelerometer left as read: kind `uncorrected`).{sentence}"),
    ))
}

/// Why no candidate was saved although there were conditions to hold out; `set_aside`: the
/// physical family's member the terms rule set aside and why; `prior_is_bound`: which sensor
/// priors a datasheet bounds (`JointSettings::sensor_prior_is_bound`).
pub(super) fn nothing_saved_verdict(
    summaries: &[CandidateSummary],
    set_aside: Option<(&str, String)>,
    prepared: &Prepared,
    undetermined: &[Advice],
    prior_is_bound: [bool; 4],
    truth_check: Option<&TruthCheck>,
) -> String {
    let reasons: Vec<String> = summaries
        .iter()
        .map(|s| {
            let why = match (&s.why_not, &set_aside) {
                (Some(why), _) => why.as_str(),
                (None, Some((name, why))) if *name == s.candidate => why.as_str(),
                (None, _) => "eligible, but not chosen",
            };
            format!("{}: {why}", s.candidate)
        })
        .collect();
    // A held-out group of poses that defeats every corrector: the rest could not pin the
    // sensor down without it.
    let poses_failed = reasons.iter().any(|r| r.contains("on \"poses "));
    // A physical model whose own covariance predicts it worse: the campaign left undetermined
    // what it would correct.
    let unknown = reasons.iter().any(|r| r.contains("does not determine"));
    let next = if poses_failed {
        format!(
            " Record next: more still poses ({} now; twelve, the six faces and six edges, leave each held-out third determined).",
            prepared.poses.len()
        )
    } else if unknown {
        let mut advice: Vec<&str> = undetermined.iter().map(|a| a.sentence.as_str()).collect();
        advice.dedup();
        advice.truncate(3);
        format!(" Record next: {}.", advice.join("; "))
    } else {
        String::new()
    };
    let datasheet = if unknown {
        datasheet_sentence(prior_is_bound)
    } else {
        String::new()
    };
    format!(
        "{NOTHING_SAVED}: no candidate holds on every held-out condition, judged without truth ({}).{next}{datasheet}{}",
        reasons.join("; "),
        truth_sentence(truth_check)
    )
}

/// Where the recordings leave terms to their priors, the datasheet keys the campaign file lacks:
/// with them the terms take the part's bounds, not a generic part's widths (on a phone's seven
/// poses the error bars' RMS went from 0.57, too wide, to 0.99; bench/accuracy/RESULTS.md).
fn datasheet_sentence(prior_is_bound: [bool; 4]) -> String {
    let missing: Vec<&str> = ["zero_g_offset_mg", "sensitivity_tolerance_pct", "cross_axis_pct"]
        .into_iter()
        .zip(prior_is_bound)
        .filter(|(_, bound)| !bound)
        .map(|(key, _)| key)
        .collect();
    if missing.is_empty() {
        return String::new();
    }
    format!(
        " Or state the accelerometer's datasheet figures in the campaign file ({}): what these recordings leave undetermined then rests on the part's bounds, not on a generic part's wider widths.",
        missing.join(", ")
    )
}

/// What the saved model does about temperature, for the verdict.
fn thermal_sentence(thermal: Option<&CampaignThermal>) -> String {
    let Some(t) = thermal else {
        return String::new();
    };
    let [lo, hi] = t.fit.model.fitted_range_c;
    // The lag's identifiability (ThermalFit::lag_rate_r2): said only where it fails.
    let lag_note = match t.fit.lag_rate_r2 {
        Some(r2) if !t.fit.lag_determined => format!(
            ", not determined by these recordings: their temperature changes along one curve (R² {r2:.3} of rate on temperature), so it holds for recordings that warm the same way; still poses at a steady temperature at each end of the range would determine it"
        ),
        _ => String::new(),
    };
    format!(
        " Corrected for temperature first (bias orders {:?}, gain orders {:?} per axis, each term kept by the Wald test at false-alarm {:e}; sensor lag {:.0} s{lag_note}) over die temperatures {lo:.1}–{hi:.1} °C: rows outside that range, or without a temperature, are corrected as at {:.1} °C and marked.{}",
        t.fit.terms.bias_orders,
        t.fit.terms.scale_orders,
        crate::metrics::TERM_FALSE_ALARM,
        t.fit.model.lag_s,
        t.fit.model.reference_c,
        undetermined_thermal_terms(&t.fit.terms)
    )
}

/// The thermal terms the recordings could not test at all (the fit with them singular: no
/// standard error), what the model does instead, and what would determine them. A warm-up in one
/// orientation and still poses at two temperatures determine the gain only at those two (a
/// quadratic gain is then measured on bench/thermal/campaign.sh to leave 0.07 % mid-range).
fn undetermined_thermal_terms(terms: &crate::thermal::ThermalTerms) -> String {
    let mut named: Vec<(String, usize, Vec<&str>)> = Vec::new();
    // A term tested again at lower orders of the others (where the fit is no longer singular)
    // was determined after all.
    let tested = |t: &crate::thermal::TermTest| {
        terms
            .tests
            .iter()
            .any(|u| u.z.is_finite() && u.part == t.part && u.axis == t.axis && u.order == t.order)
    };
    for test in terms.tests.iter().filter(|t| !t.z.is_finite() && !tested(t)) {
        let axis = ["x", "y", "z"][test.axis.min(2)];
        match named
            .iter_mut()
            .find(|(part, order, _)| *part == test.part && *order == test.order)
        {
            Some((_, _, axes)) if !axes.contains(&axis) => axes.push(axis),
            Some(_) => {}
            None => named.push((test.part.clone(), test.order, vec![axis])),
        }
    }
    if named.is_empty() {
        return String::new();
    }
    let list: Vec<String> = named
        .iter()
        .map(|(part, order, axes)| format!("{part} order {order} on {}", axes.join(", ")))
        .collect();
    let gain = named.iter().any(|(part, _, _)| part == "gain");
    format!(
        " Not determined by these recordings (the fit with them has no standard error), so left out: {}.{}",
        list.join("; "),
        if gain {
            " Between the still poses' temperatures the gain then changes as the orders kept say, and the rows' error bars do not hold what a curvature would add; still poses in several orientations at a temperature in between would determine it."
        } else {
            ""
        }
    )
}

pub(super) fn no_conditions_verdict(prepared: &Prepared, undetermined: &[Advice]) -> String {
    let mut next = vec![
        "a turntable run at a second speed or radius (e.g. 45 rpm, or the sensor at another radius)"
            .to_string(),
    ];
    if prepared.poses.len() < 6 {
        next.push("six still poses (each face up in turn, a few seconds each)".into());
    }
    for advice in undetermined.iter().take(3) {
        if !next.contains(&advice.sentence) {
            next.push(advice.sentence.clone());
        }
    }
    format!(
        "{NOTHING_SAVED}: with no second condition to hold out, no corrector can be shown to hold on data it never saw. Record next: {}.",
        next.join("; ")
    )
}

/// Among candidates physics cannot tell apart, the order of preference: a model whose held-out
/// error its covariance predicts (the physical family) before one whose error cannot be stated,
/// and fewer parameters before more.
fn preference(candidate: &str) -> usize {
    [
        CandidateKind::PhysicalLinear,
        CandidateKind::Physical,
        CandidateKind::Linear,
        CandidateKind::PhysicalAnn,
        CandidateKind::Arx,
    ]
    .iter()
    .position(|k| k.name() == candidate)
    .unwrap_or(usize::MAX)
}

/// The choice made without truth: the most preferred eligible candidate (see [`preference`])
/// that no other eligible one beats by more than the noise can explain — by more than the normal
/// quantile at [`NO_WORSE_CONFIDENCE`] times the sum of the two pooled standard errors (a bound on
/// their difference's). `set_aside` (the physical family's member the terms rule rejects) is
/// never chosen.
pub(super) fn choose_by_physics<'a>(
    summaries: &'a [CandidateSummary],
    set_aside: Option<&str>,
) -> Option<&'a CandidateSummary> {
    let z = crate::metrics::student_t_quantile(NO_WORSE_CONFIDENCE, 1e6);
    let mut eligible: Vec<(&CandidateSummary, Pooled)> = summaries
        .iter()
        .filter(|s| s.eligible && Some(s.candidate.as_str()) != set_aside)
        .filter_map(|s| s.pooled.map(|p| (s, p)))
        .collect();
    eligible.sort_by_key(|(s, _)| preference(&s.candidate));
    eligible
        .iter()
        .find(|(_, mine)| {
            !eligible
                .iter()
                .any(|(_, other)| other.difference + z * (other.se + mine.se) < mine.difference)
        })
        .map(|(s, _)| *s)
}

/// The eligible summary with the lowest `mean`, if any.
fn choose(
    summaries: &[CandidateSummary],
    eligible: impl Fn(&CandidateSummary) -> bool,
    mean: impl Fn(&CandidateSummary) -> Option<f64>,
) -> Option<&CandidateSummary> {
    summaries.iter().filter(|s| eligible(s)).min_by(|a, b| {
        mean(a)
            .unwrap_or(f64::INFINITY)
            .total_cmp(&mean(b).unwrap_or(f64::INFINITY))
    })
}

/// The same rule on truth-based scores, when every score has them.
pub(super) fn truth_check(
    summaries: &[CandidateSummary],
    held_out: &[HeldOutScore],
    chosen: Option<&CandidateSummary>,
    n_conditions: usize,
    set_aside: Option<&str>,
) -> Option<TruthCheck> {
    if n_conditions == 0 || held_out.iter().any(|h| h.physics.is_some() && h.truth.is_none()) {
        return None;
    }
    // The same rule as the choice's, on the truth-based comparisons.
    let truth_eligible = |s: &CandidateSummary| {
        let rows: Vec<&HeldOutScore> = held_out.iter().filter(|h| h.candidate == s.candidate).collect();
        let truths: Vec<&Comparison> = rows.iter().filter_map(|h| h.truth.as_ref()).collect();
        s.why_not.as_deref() != Some(UNSAVABLE)
            && s.model_check.is_none()
            && Some(s.candidate.as_str()) != set_aside
            && rows.len() == n_conditions
            && truths.len() == n_conditions
            && !truths.iter().any(|t| t.worse_beyond_margin())
            && pooled_upper_ratio(&truths).is_some_and(|u| u <= 1.0 + NON_INFERIORITY_MARGIN)
    };
    let would = choose(summaries, truth_eligible, |s| s.mean_truth_rms_mps2);
    let agrees = match (chosen, would) {
        (None, None) => true,
        (Some(c), Some(w)) => {
            c.candidate == w.candidate
                || matches!((c.mean_truth_rms_mps2, w.mean_truth_rms_mps2), (Some(c), Some(w)) if c <= 1.1 * w)
        }
        _ => false,
    };
    Some(TruthCheck {
        would_save: would.map(|w| w.candidate.clone()),
        agrees,
    })
}

fn truth_sentence(check: Option<&TruthCheck>) -> String {
    match check {
        None => String::new(),
        Some(c) => format!(
            " Checked against the simulation's truth, which the verdict did not use: truth would have saved {}{}.",
            c.would_save.as_deref().unwrap_or("nothing"),
            if c.agrees { " (agrees)" } else { " (disagrees)" }
        ),
    }
}

/// The largest departure of a static corrector's gain from the identity that a sensor's static
/// errors explain: scale and cross-axis errors of a few per cent, a nonlinearity far smaller.
pub const MAX_GAIN_ERROR: f64 = 0.2;

/// The largest predicted figure (`verdict::Prediction::ratio`) a physical-family corrector may
/// have on a held-out condition: beyond it, what the data leave undetermined is predicted to cost
/// more than the correction gains (a held-out run's refit cannot see that part).
pub const MAX_PREDICTED_RATIO: f64 = 1.1;

const UNSAVABLE: &str = "scored only: no corrector file holds a dynamic model";

/// The first held-out condition where a candidate's covariance predicts it worse than
/// [`MAX_PREDICTED_RATIO`] times no correction, with that figure.
fn predicted_harm<'a>(rows: &[&'a HeldOutScore]) -> Option<(f64, &'a str)> {
    rows.iter().find_map(|row| {
        row.predicted
            .as_ref()
            .filter(|p| p.ratio > MAX_PREDICTED_RATIO || p.ratio.is_nan())
            .map(|p| (p.ratio, row.condition.as_str()))
    })
}

/// A candidate with no covariance of its own (linear-12) fits, from the same folds, an affine map
/// with at least the freedom of `physical-linear`: it cannot be better determined by them. Where
/// physical-linear's covariance predicts a loss on a held-out condition, the campaign does not
/// determine what linear-12 corrects either, and it is ruled out by the same check; without this,
/// having no covariance would let it pass a check the physical model fails.
pub(super) fn share_determination(summaries: &mut [CandidateSummary], held_out: &[HeldOutScore]) {
    let rows: Vec<&HeldOutScore> = held_out
        .iter()
        .filter(|h| h.candidate == CandidateKind::PhysicalLinear.name())
        .collect();
    let Some((ratio, condition)) = predicted_harm(&rows) else {
        return;
    };
    for s in summaries
        .iter_mut()
        .filter(|s| s.candidate == CandidateKind::Linear.name() && s.model_check.is_none())
    {
        let reason = format!(
            "physical-linear, whose affine map it contains, is predicted by its parameters' covariance to leave {ratio:.2}× the uncorrected error on \"{condition}\": the campaign does not determine what it corrects, and linear-12 has no covariance to show otherwise"
        );
        s.model_check = Some(reason.clone());
        s.why_not = Some(reason);
        s.eligible = false;
    }
}

pub(super) fn summarise(
    kind: CandidateKind,
    held_out: &[HeldOutScore],
    n_conditions: usize,
) -> CandidateSummary {
    let rows: Vec<&HeldOutScore> = held_out.iter().filter(|h| h.candidate == kind.name()).collect();
    let (mut why_not, mut model_check) = (None, None);
    let (mut sum, mut truth_sum) = (0.0, Some(0.0));
    let (mut worst, mut worst_truth): (Option<f64>, Option<f64>) = (None, None);
    for row in &rows {
        match &row.physics {
            None => {
                why_not.get_or_insert(format!("not scored on \"{}\"", row.condition));
            }
            Some(p) => {
                if let Some(gain) = row.gain_error.filter(|&g| g > MAX_GAIN_ERROR || g.is_nan()) {
                    model_check.get_or_insert(format!(
                        "its gain ∂output/∂input departs from one by {gain:.2} on \"{}\": it discards or amplifies a reading that its training held still, which the held-out data cannot check",
                        row.condition
                    ));
                }
                if let Some((ratio, condition)) = predicted_harm(&[*row]) {
                    model_check.get_or_insert(format!(
                        "its parameters' covariance predicts {ratio:.2}× the uncorrected error on \"{condition}\": the campaign does not determine what it corrects"
                    ));
                }
                sum += combined(p.rms_mps2);
                worst = Some(worst.map_or(p.ratio, |w| w.max(p.ratio)));
                // Significantly worse by less than the margin is still no worse: the burden of
                // proof is the bound's, not this test's.
                if p.ratio.is_nan() || p.worse_beyond_margin() {
                    why_not.get_or_insert(format!(
                        "{:.2}× (± {:.2}) the uncorrected residual on \"{}\", significantly worse",
                        p.ratio, p.ratio_se, row.condition
                    ));
                }
            }
        }
        truth_sum = match (truth_sum, &row.truth) {
            (Some(t), Some(c)) => {
                worst_truth = Some(worst_truth.map_or(c.ratio, |w| w.max(c.ratio)));
                Some(t + combined(c.rms_mps2))
            }
            _ => None,
        };
    }
    // The candidate's own properties come first in the reasons, as they are checked first.
    if let Some(reason) = &model_check {
        why_not = Some(reason.clone());
    }
    let complete = rows.len() == n_conditions && n_conditions > 0 && rows.iter().all(|r| r.physics.is_some());
    let comparisons: Vec<&Comparison> = rows.iter().filter_map(|r| r.physics.as_ref()).collect();
    let pooled_upper_ratio = pooled_upper_ratio(&comparisons);
    let pooled = Pooled::of(&comparisons);
    if complete && pooled_upper_ratio.is_none_or(|u| u > 1.0 + NON_INFERIORITY_MARGIN) {
        // What limits the test decides what would sharpen it: the samples' noise averages down
        // over time, a recording's own bias offset only over more recordings.
        let remedy = if pooled.is_some_and(|p| p.offset_share > 0.5) {
            "more held-out recordings would show it, longer ones would not: most of the test's uncertainty is each recording's own bias offset (the spread between power-on sessions)"
        } else {
            "longer or more held-out recordings would show it"
        };
        why_not.get_or_insert(format!(
            "not shown no worse than uncorrected: pooled over the {n_conditions} held-out conditions its residual is possibly up to {:.2}× the uncorrected one ({:.0} % bound) where saving needs at most {:.2}×; {remedy}",
            pooled_upper_ratio.unwrap_or(f64::NAN),
            100.0 * NO_WORSE_CONFIDENCE,
            1.0 + NON_INFERIORITY_MARGIN
        ));
    }
    if n_conditions == 0 {
        why_not = Some("no held-out condition".into());
    }
    if !kind.savable() {
        why_not = Some(UNSAVABLE.into());
    }
    CandidateSummary {
        candidate: kind.name().to_string(),
        description: kind.describe().to_string(),
        mean_rms_mps2: complete.then(|| sum / n_conditions as f64),
        worst_ratio_to_uncorrected: worst,
        pooled_upper_ratio,
        pooled,
        mean_truth_rms_mps2: truth_sum.filter(|_| complete).map(|t| t / n_conditions as f64),
        worst_truth_ratio: worst_truth,
        eligible: complete && why_not.is_none(),
        why_not,
        model_check,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clear gain on one condition: corrected at half the uncorrected residual, tight.
    fn gain() -> Comparison {
        Comparison {
            rms_mps2: [0.02; 3],
            uncorrected_rms_mps2: [0.04; 3],
            ratio: 0.5,
            ratio_se: 0.01,
            worse: false,
            upper_ratio: 0.52,
            shown_no_worse: true,
            samples: 4000,
            blocks: 40,
            offset_share: 0.0,
        }
    }

    fn scores(physical_predicted_ratio: f64) -> Vec<HeldOutScore> {
        let mut rows = Vec::new();
        for condition in ["poses 1, 4, 7", "radius 0.090 m"] {
            for (kind, predicted) in [
                (CandidateKind::PhysicalLinear, Some(physical_predicted_ratio)),
                (CandidateKind::Linear, None),
            ] {
                rows.push(HeldOutScore {
                    condition: condition.into(),
                    candidate: kind.name().into(),
                    physics: Some(gain()),
                    truth: None,
                    predicted: predicted.map(|ratio| Prediction {
                        predicted_rms_mps2: 0.03,
                        ratio,
                    }),
                    floor_mps2: None,
                    gain_error: Some(0.01),
                    note: None,
                });
            }
        }
        rows
    }

    fn summaries(held_out: &[HeldOutScore]) -> Vec<CandidateSummary> {
        let mut s: Vec<CandidateSummary> = [CandidateKind::PhysicalLinear, CandidateKind::Linear]
            .iter()
            .map(|&k| summarise(k, held_out, 2))
            .collect();
        share_determination(&mut s, held_out);
        s
    }

    /// Terms with no standard error are named once per part and order, with the axes; a gain
    /// among them brings what would determine it; tested terms bring nothing.
    #[test]
    fn the_verdict_names_the_thermal_terms_no_recording_could_test() {
        use crate::thermal::{TermTest, ThermalTerms};
        let test = |part: &str, axis: usize, order: usize, z: f64| TermTest {
            part: part.into(),
            axis,
            order,
            z,
            kept: false,
        };
        let mut terms = ThermalTerms {
            tests: (0..3)
                .flat_map(|k| [test("bias", k, 3, f64::NAN), test("gain", k, 2, f64::NAN)])
                .chain([
                    test("bias", 0, 2, -58.0),
                    test("gain", 2, 1, -1.4),
                    test("bias", 1, 3, 4.1),
                ])
                .collect(),
            ..ThermalTerms::default()
        };
        let sentence = undetermined_thermal_terms(&terms);
        assert!(
            sentence.contains("bias order 3 on x, z; gain order 2 on x, y, z.")
                && sentence.contains("at a temperature in between"),
            "{sentence}"
        );
        terms.tests.retain(|t| t.part == "bias" || t.z.is_finite());
        let sentence = undetermined_thermal_terms(&terms);
        assert!(
            sentence.contains("bias order 3 on x, z.") && !sentence.contains("in between"),
            "{sentence}"
        );
        terms.tests.retain(|t| t.z.is_finite());
        assert_eq!(undetermined_thermal_terms(&terms), "");
    }

    #[test]
    fn linear_12_is_ruled_out_where_physical_linear_is_predicted_to_lose() {
        let held_out = scores(1.25);
        let s = summaries(&held_out);
        assert!(!s[0].eligible && !s[1].eligible, "{s:#?}");
        let why = s[1].why_not.as_deref().unwrap();
        assert!(
            why.contains("physical-linear") && why.contains("1.25×") && why.contains("poses 1, 4, 7"),
            "{why}"
        );
        assert!(choose_by_physics(&s, None).is_none());
    }

    #[test]
    fn linear_12_stays_eligible_where_the_campaign_determines_the_sensor() {
        let held_out = scores(0.6);
        let s = summaries(&held_out);
        assert!(s[0].eligible && s[1].eligible, "{s:#?}");
        assert!(s[1].model_check.is_none());
        assert_eq!(choose_by_physics(&s, None).unwrap().candidate, "physical-linear");
    }

    #[test]
    fn the_verdict_names_only_the_datasheet_figures_the_file_lacks() {
        let all = datasheet_sentence([false; 4]);
        for key in ["zero_g_offset_mg", "sensitivity_tolerance_pct", "cross_axis_pct"] {
            assert!(all.contains(key), "{all}");
        }
        let one = datasheet_sentence([true, false, true, false]);
        assert!(
            one.contains("(sensitivity_tolerance_pct)") && !one.contains("zero_g"),
            "{one}"
        );
        assert_eq!(datasheet_sentence([true, true, true, false]), "");
    }
}
