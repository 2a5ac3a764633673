//! The paper protocol's held-out check: every corrector trained on the first recording, scored on
//! each other recording against its reference, and what is saved because of it.

use super::{axes_of, CalibrateError};
use crate::campaign::paper::{CrossRow, PartScore};
use crate::campaign::params::Params;
use crate::campaign::verdict::{compare, push_blocks};
use crate::correctors::corrector::Corrector;
use crate::correctors::linear::LinearModel;
use crate::input::recording::Recording;
use crate::metrics::{fit_percent, rmse};
use crate::progress::{Observer, Progress};
use crate::sysid::SysidModel;

/// The correctors trained on the first recording.
pub(super) struct Trained<'a> {
    pub(super) network: &'a crate::correctors::ann::AnnModel,
    pub(super) linear: &'a LinearModel,
    pub(super) sysid: &'a [(String, Vec<SysidModel>)],
}

/// Cross-condition: every corrector trained on the first recording, scored on each other one
/// against its own reference.
pub(super) fn cross_condition_rows(
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
        let mut block = Vec::new();
        push_blocks(&mut block, &other.time_s, settings.joint.block_s);
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

/// The paper's choice among the correctors a file can hold: `best` (the best on validation),
/// unless another recording shows it significantly worse than no correction; then the other
/// static corrector if that one held; else "none".
pub(super) fn best_unless_worse_elsewhere(best: &str, cross_condition: &[CrossRow]) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;
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
        let mut block = Vec::new();
        push_blocks(&mut block, &time_s, 5.0);
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
}
