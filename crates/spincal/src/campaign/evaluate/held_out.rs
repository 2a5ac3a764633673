//! The held-out mode: each condition of a campaign left out of training in turn and every
//! candidate scored on it, by physics and (simulations only) against truth.

use rayon::prelude::*;

use super::{Condition, Evaluation};
use crate::campaign::candidate::{Candidate, Trained, TrainingSet};
use crate::campaign::choice::HeldOutScore;
use crate::campaign::joint::JointSettings;
use crate::campaign::prepare::{Prepared, UnitRecording};
use crate::campaign::verdict::{
    compare, condition_samples, predicted_mean_square, predicted_ratio, rms_and_floor, sample_errors,
    ConditionSamples, Prediction, SampleErrors, Segment,
};
use crate::progress::{Observer, Progress};
use crate::turntable::fit::RadiusPrior;

/// Each condition of a campaign held out in turn: every candidate trained on the rest and scored
/// on it by physics, and against truth where a simulation carries it.
pub struct HeldOutEvaluation<'a> {
    pub prepared: &'a Prepared,
    pub units: &'a [UnitRecording],
    pub joint: &'a JointSettings,
    pub conditions: &'a [Condition],
    /// The spread of the per-run bias offsets, which a comparison allows for, m/s².
    pub offset_sd: f64,
    /// Per run, the radius its physics check takes: the stated one, else its placement's as the
    /// joint fit found it from the placement's runs.
    pub radii: &'a [Option<RadiusPrior>],
}

impl Evaluation for HeldOutEvaluation<'_> {
    type Scores = Vec<HeldOutScore>;

    /// Every candidate on every condition, condition by condition.
    fn score(&self, candidates: &[Box<dyn Candidate + Sync>], observer: &Observer) -> Vec<HeldOutScore> {
        let conditions = self.conditions;
        // Conditions are independent: in parallel, collected in order (the same result on any
        // number of threads).
        let done = std::sync::atomic::AtomicUsize::new(0);
        let total = conditions.len();
        let per_condition: Vec<Vec<HeldOutScore>> = conditions
            .par_iter()
            .map(|condition| {
                let rows = self.condition(condition, candidates);
                let finished = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                observer(Progress::step("held-out conditions", finished, Some(total)));
                rows
            })
            .collect();
        per_condition.into_iter().flatten().collect()
    }
}

impl HeldOutEvaluation<'_> {
    /// Every candidate trained without the condition and scored on it.
    fn condition(
        &self,
        condition: &Condition,
        candidates: &[Box<dyn Candidate + Sync>],
    ) -> Vec<HeldOutScore> {
        let prepared = self.prepared;
        let training = TrainingSet::new(
            subset(&prepared.runs, &condition.runs),
            subset(&prepared.poses, &condition.poses),
            self.joint,
        );
        let samples = condition_samples(
            &condition.runs,
            &condition.poses,
            prepared,
            self.units,
            self.joint,
        );
        let uncorrected = errors_on(None, condition, prepared, self.units, self.joint, self.radii);
        candidates
            .iter()
            .map(|cand| {
                let row = HeldOutScore {
                    condition: condition.label.clone(),
                    candidate: cand.name(),
                    physics: None,
                    truth: None,
                    predicted: None,
                    floor_mps2: None,
                    gain_error: None,
                    note: None,
                };
                match &uncorrected {
                    Ok(uncorrected) => {
                        self.candidate(row, cand.as_ref(), condition, &training, &samples, uncorrected)
                    }
                    Err(e) => HeldOutScore {
                        note: Some(format!("the uncorrected signal could not be scored: {e}")),
                        ..row
                    },
                }
            })
            .collect()
    }

    /// One candidate's `row`: trained on `training`, its errors on the condition against the
    /// uncorrected signal's (`measured`, `uncorrected`).
    fn candidate(
        &self,
        mut row: HeldOutScore,
        cand: &(dyn Candidate + Sync),
        condition: &Condition,
        training: &TrainingSet,
        samples: &ConditionSamples,
        (measured, uncorrected): &(Vec<Segment>, SampleErrors),
    ) -> HeldOutScore {
        let offset_sd = self.offset_sd;
        let scored = cand
            .train(training, &crate::progress::silent)
            .map_err(|e| format!("training failed: {e}"))
            .and_then(|model| {
                errors_on(
                    Some(&model),
                    condition,
                    self.prepared,
                    self.units,
                    self.joint,
                    self.radii,
                )
                .map(|scored| (model, scored))
                .map_err(|e| format!("scoring failed: {e}"))
            });
        match scored {
            Ok((model, (segments, errors))) => {
                row.gain_error = model.gain_error(&mean_readings(measured));
                row.physics = compare(&errors.physics, &uncorrected.physics, &samples.block, offset_sd);
                if let (Some(t), Some(u)) = (&errors.truth, &uncorrected.truth) {
                    row.truth = compare(t, u, &samples.block, offset_sd);
                    row.floor_mps2 = rms_and_floor(t, samples.random.as_deref()).and_then(|r| r.1);
                }
                if let Some((sensor, covariance)) = model.physical_part() {
                    let ms = predicted_mean_square(sensor, covariance, measured);
                    row.predicted =
                        predicted_ratio(&segments, measured, &errors.physics, ms).map(|ratio| Prediction {
                            predicted_rms_mps2: ms.sqrt(),
                            ratio,
                        });
                }
                if row.physics.is_none() {
                    row.note = Some("no sample could be scored".into());
                }
            }
            Err(e) => row.note = Some(e),
        }
        row
    }
}

/// The held-out recording's signals after a trained candidate (identity for `None`), and which
/// samples it could correct.
fn apply_trained(
    trained: Option<&Trained>,
    accel: &[Vec<f64>; 3],
) -> Result<([Vec<f64>; 3], Vec<bool>), String> {
    match trained {
        None => Ok((accel.clone(), vec![true; accel[0].len()])),
        Some(trained) => trained.correct(accel).map(|c| (c.accel_mps2, c.valid)),
    }
}

/// A trained candidate's output (identity for `None`) on a condition's runs, then its poses'
/// windows, with which samples it could correct.
fn condition_signals(
    trained: Option<&Trained>,
    condition: &Condition,
    prepared: &Prepared,
    units: &[UnitRecording],
) -> Result<Vec<Segment>, String> {
    let mut out = Vec::with_capacity(condition.runs.len() + condition.poses.len());
    for &i in &condition.runs {
        let (accel, valid) = apply_trained(trained, &prepared.runs[i].accel_mps2)?;
        out.push(Segment { accel, valid });
    }
    for &p in &condition.poses {
        let origin = &prepared.pose_origin[p];
        let accel = &units[origin.recording].recording.accel_mps2;
        let window: [Vec<f64>; 3] = std::array::from_fn(|k| accel[k][origin.start..origin.end].to_vec());
        let (accel, valid) = apply_trained(trained, &window)?;
        out.push(Segment { accel, valid });
    }
    Ok(out)
}

/// A signal on a held-out condition and its per-sample errors.
fn errors_on(
    trained: Option<&Trained>,
    condition: &Condition,
    prepared: &Prepared,
    units: &[UnitRecording],
    joint: &JointSettings,
    radii: &[Option<RadiusPrior>],
) -> Result<(Vec<Segment>, SampleErrors), String> {
    let segments = condition_signals(trained, condition, prepared, units)?;
    let errors = sample_errors(
        &segments,
        &condition.runs,
        &condition.poses,
        prepared,
        units,
        joint,
        radii,
    )?;
    Ok((segments, errors))
}

/// Each segment's mean reading.
fn mean_readings(segments: &[Segment]) -> Vec<[f64; 3]> {
    segments
        .iter()
        .filter(|s| !s.accel[0].is_empty())
        .map(|s| std::array::from_fn(|k| s.accel[k].iter().sum::<f64>() / s.accel[k].len() as f64))
        .collect()
}

fn subset<T: Clone>(items: &[T], skip: &[usize]) -> Vec<T> {
    items
        .iter()
        .enumerate()
        .filter(|(i, _)| !skip.contains(i))
        .map(|(_, v)| v.clone())
        .collect()
}
