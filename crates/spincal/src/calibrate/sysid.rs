//! The paper protocol's system-identification candidates: one SISO model per axis, fitted and
//! scored on the 60/20/20 division, with warnings where a row's fit says nothing.

use std::ops::Range;

use crate::campaign::paper::{ComparisonRow, PartScore};
use crate::campaign::params::Params;
use crate::correctors::corrector::Axis;
use crate::correctors::division::Division;
use crate::input::recording::Recording;
use crate::progress::{Observer, Progress};
use crate::sysid::{fit_and_score, score, ModelSpec, Scores, SysidError, SysidModel};

/// System identification, one SISO model per axis, each started from the seed of every random
/// choice: a comparison row per model (a model that cannot be fitted to this data is reported
/// with its reason, not fatal) and the fitted ones.
pub(super) fn sysid_candidates(
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
