//! Held-out verdicts without truth: how far a signal on a held-out condition is from what physics
//! requires of it, sample by sample, and whether a corrector is significantly worse than no
//! correction there. Where a simulation knows the true specific force, the same samples are also
//! scored against it, so that the truth-free figure can be checked against the truth it cannot see.
//!
//! What physics requires, per held-out sample (no sensor parameter is refitted, so nothing can
//! absorb a sensor error but the geometry a real platter has):
//! - **a turntable run**: the best rigid-platter motion of a perfect sensor
//!   (`fit_run_geometry`): the rotation rate (measured from the data), the radius within the
//!   ruler's tolerance (or, where none was stated, within the standard error of the radius the
//!   joint fit found for the run's placement), the platter's tilt, the mount's rotation within its prior, wow; no bias
//!   offset, drift or scale freedom. It sees a scale or bias error along the spindle (the constant
//!   part must be g cos α with sin α fixed by the rotating part's amplitude), a radial error beyond
//!   the radius tolerance times ω², a circle that is not one (scale and cross-axis errors in the
//!   platter's plane) and what varies with the speed. It cannot see a constant error across the
//!   spindle small enough for the mount tilt's prior to absorb, nor a radial one within the ruler's
//!   tolerance.
//! - **a still pose**: gravity's magnitude along the pose's own mean direction. It cannot see an
//!   error perpendicular to gravity.
//!
//! The uncorrected signal gets the same check on the same samples, so a corrector's figure is its
//! RMS residual over the uncorrected one (per sample, noise in, on the footing of the truth-based
//! figure).
//!
//! **The burden of proof.** A corrector is saved only where the held-out evidence *shows* it no
//! worse than no correction: the upper one-sided [`NO_WORSE_CONFIDENCE`] bound of its RMS ratio,
//! pooled over the held-out conditions ([`pooled_upper_ratio`]: the difference of mean squares
//! plus the normal quantile times its standard error, below), at most 1 +
//! [`NON_INFERIORITY_MARGIN`]; and on no condition significantly worse by more than the margin
//! (each condition's own bound, `Comparison::upper_ratio`). Evidence too short or too noisy to show
//! it leaves the corrector unsaved, however good its point estimate: the bound is the test's
//! power, stated.
//!
//! **Significance.** A corrector is "worse than uncorrected" on a condition only when the mean of
//! its squared residual minus the uncorrected one's exceeds Student's t quantile at one-sided
//! probability `WORSE_FALSE_ALARM` (blocks − 1 degrees of freedom) times that difference's
//! standard error. The standard error has two parts: batch means (the difference summed per block
//! of `block_s` seconds of a run, of one second of a still pose), which account for residuals
//! correlated within a block by wow or noise; and the recording's bias offset, which no block sees because it
//! is constant over a recording: an offset δ moves the difference by (2/3) Σ_k δ_k Δ_k, with Δ_k the
//! mean residual difference on axis k and δ_k of the standard deviation the joint fit measured
//! between its recordings' offsets (or the prior `bias_instability_mps2`, whichever is larger).

// Per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use crate::campaign::joint::{fit_run_geometry, JointSettings};
use crate::campaign::prepare::{Prepared, UnitRecording};
use crate::correctors::physical::{propagated_variance, SensorCovariance, SensorModel};
use crate::metrics::student_t_quantile;
use crate::turntable::fit::RadiusPrior;

/// Length of a block within a still pose, s: a pose's noise is nearly white, and what moves it as
/// a whole (the bias between poses) is the offset term's.
const POSE_BLOCK_S: f64 = 1.0;

/// One-sided false-alarm probability of "worse than uncorrected" on one condition.
pub(crate) const WORSE_FALSE_ALARM: f64 = 1e-3;
/// How much worse than no correction a saved corrector may be on a held-out condition, as a share
/// of the uncorrected RMS: within it, "no worse".
pub const NON_INFERIORITY_MARGIN: f64 = 0.02;
/// The one-sided confidence with which "no worse" must be shown on each condition.
pub const NO_WORSE_CONFIDENCE: f64 = 0.95;

/// The samples of one held-out condition in a fixed order (its runs, then its poses) and how they
/// group into blocks for the standard errors.
#[derive(Debug, Clone)]
pub(crate) struct ConditionSamples {
    /// Block number per sample.
    pub block: Vec<usize>,
    /// The random error per sample (drift + white noise), when every recording carries it.
    pub random: Option<Vec<[f64; 3]>>,
}

/// One signal's per-sample errors over a condition's samples; `None` where unusable (saturated,
/// or the corrector could not correct the sample).
#[derive(Debug, Clone)]
pub(crate) struct SampleErrors {
    /// Against physics (see the module documentation).
    pub physics: Vec<Option<[f64; 3]>>,
    /// Against the true specific force, when every recording carries it.
    pub truth: Option<Vec<Option<[f64; 3]>>>,
}

/// A corrected signal per recording segment: the condition's runs, then its poses' windows.
pub(crate) struct Segment {
    pub accel: [Vec<f64>; 3],
    pub valid: Vec<bool>,
}

/// Appends the block number of each sample of one recording segment: blocks of `block_s` seconds
/// (at least 10 samples), numbered on from the last block already in `block`.
pub(crate) fn push_blocks(block: &mut Vec<usize>, time_s: &[f64], block_s: f64) {
    let next = block.last().map_or(0, |b| b + 1);
    let dt = crate::input::recording::sample_interval(time_s);
    let per_block = ((block_s / dt).round() as usize).max(10);
    block.extend((0..time_s.len()).map(|s| next + s / per_block));
}

/// The layout of a condition's samples.
pub(crate) fn condition_samples(
    runs: &[usize],
    poses: &[usize],
    prepared: &Prepared,
    units: &[UnitRecording],
    joint: &JointSettings,
) -> ConditionSamples {
    let mut block = Vec::new();
    let mut random: Option<Vec<[f64; 3]>> = Some(Vec::new());
    for &i in runs {
        let run = &prepared.runs[i];
        let origin = &prepared.run_origin[i];
        let unit = &units[origin.recording];
        push_blocks(&mut block, &run.time_s, joint.block_s);
        random = match (random, &unit.random_mps2) {
            (Some(mut r), Some(u)) => {
                r.extend((origin.start..origin.end).map(|s| [u[0][s], u[1][s], u[2][s]]));
                Some(r)
            }
            _ => None,
        };
    }
    for &p in poses {
        let origin = &prepared.pose_origin[p];
        let unit = &units[origin.recording];
        push_blocks(
            &mut block,
            &unit.recording.time_s[origin.start..origin.end],
            POSE_BLOCK_S,
        );
        random = match (random, &unit.random_mps2) {
            (Some(mut r), Some(u)) => {
                r.extend((origin.start..origin.end).map(|s| [u[0][s], u[1][s], u[2][s]]));
                Some(r)
            }
            _ => None,
        };
    }
    ConditionSamples { block, random }
}

/// Per-sample errors of a signal on a condition: `segments` holds the signal (corrected or not)
/// on the condition's runs, then on its poses' windows, in the order of `runs` and `poses`.
/// `radii`: per run, the radius its physics check takes (else its entry's).
pub(crate) fn sample_errors(
    segments: &[Segment],
    runs: &[usize],
    poses: &[usize],
    prepared: &Prepared,
    units: &[UnitRecording],
    joint: &JointSettings,
    radii: &[Option<RadiusPrior>],
) -> Result<SampleErrors, String> {
    let mut physics = Vec::new();
    let mut truth: Option<Vec<Option<[f64; 3]>>> = Some(Vec::new());
    let mut segment = segments.iter();
    for &i in runs {
        let signal = segment.next().ok_or("a run's signal is missing")?;
        let run = &prepared.runs[i];
        let origin = &prepared.run_origin[i];
        let unit = &units[origin.recording];
        let keep = |s: usize| run.keep[s] && signal.valid[s];
        let mut seen = run.with_readings(signal.accel.clone(), (0..run.keep.len()).map(keep).collect());
        seen.entry.radius = radii.get(i).copied().flatten().or(run.entry.radius);
        let fit = fit_run_geometry(&seen, joint).map_err(|e| format!("{}: {e}", run.name))?;
        let reference = fit.run_reference(0, &run.time_s);
        physics.extend(
            (0..run.time_s.len())
                .map(|s| keep(s).then(|| std::array::from_fn(|k| signal.accel[k][s] - reference[k][s]))),
        );
        truth = match (truth, &unit.truth) {
            (Some(mut t), Some(true_force)) => {
                t.extend((0..run.time_s.len()).map(|s| {
                    keep(s).then(|| {
                        std::array::from_fn(|k| signal.accel[k][s] - true_force[k][origin.start + s])
                    })
                }));
                Some(t)
            }
            _ => None,
        };
    }
    for &p in poses {
        let signal = segment.next().ok_or("a pose's signal is missing")?;
        let origin = &prepared.pose_origin[p];
        let unit = &units[origin.recording];
        let len = origin.end - origin.start;
        let used = (0..len).filter(|&s| signal.valid[s]).count().max(1) as f64;
        let mean: [f64; 3] = std::array::from_fn(|k| {
            (0..len)
                .filter(|&s| signal.valid[s])
                .map(|s| signal.accel[k][s])
                .sum::<f64>()
                / used
        });
        let norm = (mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]).sqrt();
        let g = joint.gravity_mps2;
        let gravity: [f64; 3] = std::array::from_fn(|k| g * mean[k] / norm.max(f64::MIN_POSITIVE));
        physics.extend(
            (0..len)
                .map(|s| signal.valid[s].then(|| std::array::from_fn(|k| signal.accel[k][s] - gravity[k]))),
        );
        truth = match (truth, &unit.truth) {
            (Some(mut t), Some(true_force)) => {
                t.extend((0..len).map(|s| {
                    signal.valid[s].then(|| {
                        std::array::from_fn(|k| signal.accel[k][s] - true_force[k][origin.start + s])
                    })
                }));
                Some(t)
            }
            _ => None,
        };
    }
    Ok(SampleErrors { physics, truth })
}

/// A corrector against no correction on the same samples of one condition.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Comparison {
    /// RMS per axis of the corrector's residual, m/s².
    pub rms_mps2: [f64; 3],
    /// RMS per axis of the uncorrected signal's residual on the same samples, m/s².
    pub uncorrected_rms_mps2: [f64; 3],
    /// Corrected over uncorrected, RMS over the three axes.
    pub ratio: f64,
    /// The ratio's standard error (batch means, delta method).
    pub ratio_se: f64,
    /// Significantly worse than uncorrected (see the module documentation).
    pub worse: bool,
    /// The ratio's upper confidence bound at one-sided [`NO_WORSE_CONFIDENCE`]: the largest loss
    /// against no correction these samples leave possible (their power, stated).
    #[serde(default)]
    pub upper_ratio: f64,
    /// Shown no worse than uncorrected within [`NON_INFERIORITY_MARGIN`]: `upper_ratio` at most
    /// 1 + the margin (what saving requires).
    #[serde(default)]
    pub shown_no_worse: bool,
    pub samples: usize,
    pub blocks: usize,
    /// The share of the difference's variance that the recordings' unknown bias offsets make
    /// (the rest is the samples' noise): where it is most, longer recordings would not sharpen
    /// the test, more of them would.
    #[serde(default)]
    pub offset_share: f64,
}

impl Comparison {
    /// Significantly worse than uncorrected, and not shown within the margin: such a condition
    /// alone keeps a corrector from being saved.
    pub fn worse_beyond_margin(&self) -> bool {
        self.worse && !self.shown_no_worse
    }
}

/// What the corrector's own parameter covariance says about its held-out error (the physical
/// family only: a network's error has no covariance to predict it).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Prediction {
    /// RMS over the axes of the correction's error from its parameters' uncertainty, m/s².
    pub predicted_rms_mps2: f64,
    /// Corrected over uncorrected on the footing of the truth-based figure: the physics residual
    /// plus the predicted error, over the uncorrected signal measured against the corrected
    /// signal's physics reference (which sees what a rigid platter or gravity's magnitude alone
    /// cannot: the part of the correction the geometry would absorb).
    pub ratio: f64,
}

/// The RMS over three axes of per-axis RMS values.
pub fn combined(rms: [f64; 3]) -> f64 {
    ((rms[0] * rms[0] + rms[1] * rms[1] + rms[2] * rms[2]) / 3.0).sqrt()
}

/// Compares `corrected` with `uncorrected` residuals over the samples where both exist.
pub(crate) fn compare(
    corrected: &[Option<[f64; 3]>],
    uncorrected: &[Option<[f64; 3]>],
    block: &[usize],
    offset_sd: f64,
) -> Option<Comparison> {
    let blocks = block.iter().max().map_or(0, |b| b + 1);
    let mut per_block = vec![(0.0f64, 0usize); blocks];
    let (mut sum_c, mut sum_u, mut shift) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    let mut n = 0usize;
    for s in 0..corrected.len().min(uncorrected.len()) {
        let (Some(c), Some(u)) = (corrected[s], uncorrected[s]) else {
            continue;
        };
        let mut d = 0.0;
        for k in 0..3 {
            sum_c[k] += c[k] * c[k];
            sum_u[k] += u[k] * u[k];
            shift[k] += c[k] - u[k];
            d += (c[k] * c[k] - u[k] * u[k]) / 3.0;
        }
        per_block[block[s]].0 += d;
        per_block[block[s]].1 += 1;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let nf = n as f64;
    let rms_mps2 = sum_c.map(|v| (v / nf).sqrt());
    let uncorrected_rms_mps2 = sum_u.map(|v| (v / nf).sqrt());
    let (ms_c, ms_u) = (combined(rms_mps2).powi(2), combined(uncorrected_rms_mps2).powi(2));
    let difference = ms_c - ms_u;
    let used: Vec<(f64, usize)> = per_block.into_iter().filter(|b| b.1 > 0).collect();
    let b = used.len();
    // Batch means: each block's sum about its share of the mean difference.
    let spread: f64 = used
        .iter()
        .map(|&(sum, count)| (sum - count as f64 * difference).powi(2))
        .sum();
    // A recording's bias offset δ (the same in both signals, unknown) moves the difference by
    // (2/3) Σ_k δ_k Δ_k, Δ_k the mean residual difference on axis k.
    let offset_variance =
        4.0 / 9.0 * offset_sd * offset_sd * shift.iter().map(|v| (v / nf).powi(2)).sum::<f64>();
    let (se, offset_share) = if b >= 2 {
        let variance = spread * b as f64 / (b - 1) as f64 / (nf * nf) + offset_variance;
        let share = if variance > 0.0 {
            offset_variance / variance
        } else {
            0.0
        };
        (variance.sqrt(), share)
    } else {
        (f64::INFINITY, 0.0)
    };
    let ratio = (ms_c / ms_u).sqrt();
    let worse = if b >= 2 {
        difference > student_t_quantile(1.0 - WORSE_FALSE_ALARM, (b - 1) as f64) * se
    } else {
        difference > 0.0
    };
    let upper_ratio = if b >= 2 {
        let bound = difference + student_t_quantile(NO_WORSE_CONFIDENCE, (b - 1) as f64) * se;
        (1.0 + bound / ms_u).max(0.0).sqrt()
    } else {
        f64::INFINITY
    };
    Some(Comparison {
        rms_mps2,
        uncorrected_rms_mps2,
        ratio,
        ratio_se: se / (2.0 * ratio.max(f64::MIN_POSITIVE) * ms_u),
        worse,
        upper_ratio,
        shown_no_worse: upper_ratio <= 1.0 + NON_INFERIORITY_MARGIN,
        samples: n,
        blocks: b,
        offset_share,
    })
}

/// The upper one-sided [`NO_WORSE_CONFIDENCE`] bound of the RMS ratio pooled over held-out
/// conditions: the mean over conditions of the mean-square difference (corrected − uncorrected)
/// plus the normal quantile times its standard error (the conditions' errors independent), over
/// the mean uncorrected mean square. `None` without a finite comparison.
pub fn pooled_upper_ratio(comparisons: &[&Comparison]) -> Option<f64> {
    let pooled = Pooled::of(comparisons)?;
    let z = student_t_quantile(NO_WORSE_CONFIDENCE, 1e6);
    let ratio = (1.0 + (pooled.difference + z * pooled.se) / pooled.uncorrected)
        .max(0.0)
        .sqrt();
    ratio.is_finite().then_some(ratio)
}

/// Mean over held-out conditions of a corrector's mean square minus the uncorrected one's, its
/// standard error (conditions independent) and the mean uncorrected mean square, m²/s⁴.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pooled {
    pub difference: f64,
    pub se: f64,
    pub uncorrected: f64,
    /// The share of the variance behind `se` that the recordings' bias offsets make.
    #[serde(default)]
    pub offset_share: f64,
}

impl Pooled {
    pub fn of(comparisons: &[&Comparison]) -> Option<Pooled> {
        let (mut difference, mut uncorrected, mut variance, mut from_offsets) = (0.0, 0.0, 0.0, 0.0);
        for c in comparisons {
            let (ms_c, ms_u) = (
                combined(c.rms_mps2).powi(2),
                combined(c.uncorrected_rms_mps2).powi(2),
            );
            let se = c.ratio_se * 2.0 * c.ratio * ms_u;
            difference += ms_c - ms_u;
            uncorrected += ms_u;
            variance += se * se;
            from_offsets += c.offset_share * se * se;
        }
        let n = comparisons.len() as f64;
        let pooled = Pooled {
            difference: difference / n,
            se: variance.sqrt() / n,
            uncorrected: uncorrected / n,
            offset_share: if variance > 0.0 {
                from_offsets / variance
            } else {
                0.0
            },
        };
        (n > 0.0 && pooled.difference.is_finite() && pooled.se.is_finite()).then_some(pooled)
    }
}

/// RMS per axis of `errors` and of the random floor over the samples where `errors` exist.
pub(crate) fn rms_and_floor(
    errors: &[Option<[f64; 3]>],
    random: Option<&[[f64; 3]]>,
) -> Option<([f64; 3], Option<[f64; 3]>)> {
    let (mut sum, mut floor) = ([0.0f64; 3], [0.0f64; 3]);
    let mut n = 0usize;
    for (s, e) in errors.iter().enumerate() {
        let Some(e) = e else { continue };
        for k in 0..3 {
            sum[k] += e[k] * e[k];
            if let Some(r) = random {
                floor[k] += r[s][k] * r[s][k];
            }
        }
        n += 1;
    }
    (n > 0).then(|| {
        let nf = n as f64;
        (
            sum.map(|v| (v / nf).sqrt()),
            random.map(|_| floor.map(|v| (v / nf).sqrt())),
        )
    })
}

/// Samples per segment at which the covariance's effect is evaluated (evenly spaced).
const PREDICTION_SAMPLES: usize = 200;

/// The mean squared error (per axis) that the sensor parameters' covariance implies for the
/// physical model's correction of the readings `measured` (first order: J Σ Jᵀ, the Jacobian
/// `SensorModel::correct_with_jacobian`'s, the one `correct` writes per row).
pub(crate) fn predicted_mean_square(
    sensor: &SensorModel,
    covariance: &SensorCovariance,
    measured: &[Segment],
) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for segment in measured {
        let len = segment.accel[0].len();
        for s in (0..len).step_by((len / PREDICTION_SAMPLES).max(1)) {
            let m = [segment.accel[0][s], segment.accel[1][s], segment.accel[2][s]];
            if let Some((_, jac)) = sensor.correct_with_jacobian(m) {
                sum += propagated_variance(&jac, covariance).iter().sum::<f64>() / 3.0;
                n += 1;
            }
        }
    }
    sum / n.max(1) as f64
}

/// The figure on the truth-based footing for a corrector whose error its covariance predicts: its
/// physics residual (with the predicted error's mean square added) over the uncorrected signal
/// measured against the corrected signal's own physics reference (`u − c + r_c`), RMS over axes.
pub(crate) fn predicted_ratio(
    corrected: &[Segment],
    uncorrected: &[Segment],
    residual: &[Option<[f64; 3]>],
    predicted_ms: f64,
) -> Option<f64> {
    let (mut sum_c, mut sum_u, mut n) = (0.0, 0.0, 0usize);
    let mut s = 0usize;
    for (c, u) in corrected.iter().zip(uncorrected) {
        for i in 0..c.accel[0].len() {
            if let Some(r) = residual.get(s).copied().flatten() {
                for k in 0..3 {
                    sum_c += r[k] * r[k] / 3.0;
                    let e = u.accel[k][i] - c.accel[k][i] + r[k];
                    sum_u += e * e / 3.0;
                }
                n += 1;
            }
            s += 1;
        }
    }
    (n > 0 && sum_u > 0.0).then(|| ((sum_c / n as f64 + predicted_ms) / (sum_u / n as f64)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residuals(values: &[f64]) -> Vec<Option<[f64; 3]>> {
        values.iter().map(|&v| Some([v, v, v])).collect()
    }

    #[test]
    fn a_corrector_equal_to_uncorrected_is_not_worse_and_a_much_worse_one_is() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 4000;
        let block: Vec<usize> = (0..n).map(|s| s / 100).collect();
        let noise: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let other: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        // Two signals of the same noise level: the difference is noise, never significant.
        let same = compare(&residuals(&noise), &residuals(&other), &block, 0.0).unwrap();
        assert!(!same.worse, "{same:?}");
        assert!((same.ratio - 1.0).abs() < 5.0 * same.ratio_se, "{same:?}");
        // A corrector that adds an offset of half the noise's RMS everywhere is worse.
        let shifted: Vec<f64> = noise.iter().map(|v| v + 0.3).collect();
        let worse = compare(&residuals(&shifted), &residuals(&other), &block, 0.0).unwrap();
        assert!(worse.worse && worse.ratio > 1.05, "{worse:?}");
        // And the reverse is better, not worse.
        let better = compare(&residuals(&other), &residuals(&shifted), &block, 0.0).unwrap();
        assert!(!better.worse && better.ratio < 0.95, "{better:?}");
        // Unusable samples on either side are left out of both.
        let mut gaps = residuals(&noise);
        gaps[0] = None;
        assert_eq!(
            compare(&gaps, &residuals(&other), &block, 0.0).unwrap().samples,
            n - 1
        );
        // An unknown bias offset as large as the shift makes it no longer significant.
        let unsure = compare(&residuals(&shifted), &residuals(&other), &block, 1.0).unwrap();
        assert!(!unsure.worse && unsure.ratio_se > worse.ratio_se, "{unsure:?}");
        // And the offset, not the samples' noise, is then what limits the test.
        assert!(
            unsure.offset_share > 0.9 && worse.offset_share == 0.0,
            "{unsure:?} {worse:?}"
        );
        // Not shown worse is not shown no worse: the unsure one cannot be saved, the better one
        // can, and the worse one's bound lies above its ratio.
        assert!(
            !unsure.shown_no_worse && unsure.upper_ratio > 1.0 + NON_INFERIORITY_MARGIN,
            "{unsure:?}"
        );
        assert!(better.shown_no_worse && better.upper_ratio < 1.0, "{better:?}");
        assert!(
            !worse.shown_no_worse && worse.upper_ratio > worse.ratio,
            "{worse:?}"
        );
    }

    #[test]
    fn the_difference_standard_error_covers_its_spread_over_seeds() {
        // Correlated residuals (an AR(1) per block), equal in level: the z-score of the
        // difference should be about standard normal, so |z| < 3 in nearly every seed.
        use rand::{Rng, SeedableRng};
        let mut beyond = 0;
        for seed in 0..200 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let n = 3000;
            let block: Vec<usize> = (0..n).map(|s| s / 150).collect();
            let series = |rng: &mut rand_chacha::ChaCha8Rng| {
                let mut x = 0.0;
                (0..n)
                    .map(|_| {
                        x = 0.9 * x + rng.gen_range(-1.0..1.0);
                        x
                    })
                    .collect::<Vec<f64>>()
            };
            let (a, b) = (series(&mut rng), series(&mut rng));
            let c = compare(&residuals(&a), &residuals(&b), &block, 0.0).unwrap();
            let z = (c.ratio - 1.0) / c.ratio_se;
            beyond += usize::from(z.abs() > 3.0);
        }
        assert!(beyond <= 6, "{beyond} of 200 beyond 3 standard errors");
    }
}
