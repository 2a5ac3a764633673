//! A trained map held against what its training data moved: an input axis that the data hold
//! still (within its noise) teaches the map nothing about that axis, and a least-squares or LM
//! fit then makes the axis's output a constant (a linear map trained on one flat turntable run
//! gives z = 9.805 m/s² whatever z reads). Such a map is refused by name, with the recording that
//! would teach it.

use crate::correctors::corrector::{Axis, Corrector};
use crate::correctors::division::Division;
use crate::correctors::model_file::CorrectorModel;
use crate::input::recording::Recording;

/// An input axis counts as moved by the training data when its standard deviation over the
/// training part exceeds this many times its white noise's (from first differences): noise and a
/// slow bias drift stay near 1–2, a turntable's or a pose sequence's excitation is hundreds.
pub const EXCITED_OVER_NOISE: f64 = 3.0;

/// A corrected axis whose change per unit change of its own reading (the map's steady gain) is
/// below this ignores that reading: a calibration's gain is 1 within a few per cent, and a map
/// fitted to noise alone has a gain near 0.
pub const IGNORED_GAIN: f64 = 0.5;

/// A trained map whose output ignores an input axis the training data did not move.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("measured {axis} barely moves in the training data (sd {sd_mps2:.4} m/s² against its noise of {noise_mps2:.4} m/s²), and the trained map ignores it: corrected {axis} changes by {gain:.3} per unit of measured {axis}, so it reads about {level_mps2:.3} m/s² whatever {axis} reads; train on data that move {axis} (a turntable run with {axis} across the spindle, or still poses with {axis} up, down and level), or train only the axes the data move (leave {axis} out of the corrected axes)")]
pub struct IgnoredInput {
    pub axis: Axis,
    /// The axis's standard deviation over the training part, m/s².
    pub sd_mps2: f64,
    /// Its white noise's standard deviation (first differences / √2), m/s².
    pub noise_mps2: f64,
    /// d corrected / d measured on that axis, steady state, at the training data's mean.
    pub gain: f64,
    /// The corrected axis at the training data's mean, m/s².
    pub level_mps2: f64,
}

/// Checks a freshly trained linear map or network (`model`, with its training summary) against
/// `measured`, the recording it was trained on: refused when an input axis is not moved by the
/// training part ([`EXCITED_OVER_NOISE`]) and the map ignores it ([`IGNORED_GAIN`]). Other kinds,
/// and models without a training summary, pass.
pub fn check_inputs_used(model: &CorrectorModel, measured: &Recording) -> Result<(), IgnoredInput> {
    let (axes, division) = match model {
        CorrectorModel::Linear(m) => (&m.axes, m.training.as_ref().map(|t| &t.division)),
        CorrectorModel::Ann(m) => (&m.axes, m.training.as_ref().map(|t| &t.division)),
        _ => return Ok(()),
    };
    let Some(division) = division else {
        return Ok(());
    };
    let mean: [f64; 3] = std::array::from_fn(|k| spread(&measured.accel_mps2[k], division).0);
    for &axis in axes {
        let (_, sd, noise) = spread(&measured.accel_mps2[axis.index()], division);
        if sd > EXCITED_OVER_NOISE * noise {
            continue;
        }
        // The step is one the data could show: inside the training range where there is one.
        let step = (2.0 * sd).max(1e-3);
        let level = steady_output(model, mean, axis);
        let mut moved = mean;
        moved[axis.index()] += step;
        let gain = (steady_output(model, moved, axis) - level) / step;
        if gain.abs() < IGNORED_GAIN || !gain.is_finite() {
            return Err(IgnoredInput {
                axis,
                sd_mps2: sd,
                noise_mps2: noise,
                gain,
                level_mps2: level,
            });
        }
    }
    Ok(())
}

/// (mean, standard deviation, white-noise standard deviation) of `values` over the division's
/// training part (differences taken within each block only).
fn spread(values: &[f64], division: &Division) -> (f64, f64, f64) {
    let (mut n, mut sum, mut sum_sq, mut diff_sq, mut diffs) = (0.0f64, 0.0, 0.0, 0.0, 0.0f64);
    for range in &division.train {
        let block = &values[range.start.min(values.len())..range.end.min(values.len())];
        for &v in block {
            n += 1.0;
            sum += v;
            sum_sq += v * v;
        }
        for w in block.windows(2) {
            diff_sq += (w[1] - w[0]).powi(2);
            diffs += 1.0;
        }
    }
    if n < 2.0 {
        return (sum / n.max(1.0), 0.0, 0.0);
    }
    let mean = sum / n;
    let variance = ((sum_sq - n * mean * mean) / (n - 1.0)).max(0.0);
    let noise = (diff_sq / (2.0 * diffs.max(1.0))).sqrt();
    (mean, variance.sqrt(), noise)
}

/// The corrected `axis` once the model's delay history holds `input` throughout.
fn steady_output(model: &CorrectorModel, input: [f64; 3], axis: Axis) -> f64 {
    let mut stream = model.stream();
    let mut out = input;
    for _ in 0..=model.warmup_samples() {
        out = stream.correct_sample(input).accel_mps2;
    }
    out[axis.index()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::correctors::division::DivisionMode;
    use crate::correctors::linear::LinearModel;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A flat turntable run (x, y turn, z holds gravity with noise) and its reference.
    fn flat_run(seed: u64, z_moves: bool) -> (Recording, Recording) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 2000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 / 100.0).collect();
        let mut truth: [Vec<f64>; 3] = Default::default();
        let mut measured: [Vec<f64>; 3] = Default::default();
        for &t in &time_s {
            let w = 2.0 * std::f64::consts::PI * 0.55 * t;
            let z = if z_moves { 9.8 * (0.3 * t).cos() } else { 9.8 };
            let a = [0.8 * w.sin(), 0.8 * w.cos(), z];
            for k in 0..3 {
                truth[k].push(a[k]);
                let noise: f64 = rng.gen_range(-0.02..0.02);
                measured[k].push(1.01 * a[k] + 0.05 + noise);
            }
        }
        let rec = |accel_mps2| Recording {
            time_s: time_s.clone(),
            accel_mps2,
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        (rec(measured), rec(truth))
    }

    #[test]
    fn a_linear_map_that_ignores_an_unmoved_axis_is_refused_by_name() {
        let (measured, reference) = flat_run(3, false);
        let model = LinearModel::fit(&measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap();
        let model = CorrectorModel::Linear(Box::new(model));
        let err = check_inputs_used(&model, &measured).unwrap_err();
        assert_eq!(err.axis, Axis::Z);
        assert!(err.gain.abs() < IGNORED_GAIN, "{err:?}");
        assert!((err.level_mps2 - 9.8).abs() < 0.01, "{err:?}");
        assert!(
            err.to_string().contains("train only the axes the data move"),
            "{err}"
        );
        // The axes the run moves pass; so does z once the data move it.
        let xy = LinearModel::fit(
            &measured,
            &reference,
            &[Axis::X, Axis::Y],
            DivisionMode::Contiguous,
        )
        .unwrap();
        assert!(check_inputs_used(&CorrectorModel::Linear(Box::new(xy)), &measured).is_ok());
        let (measured, reference) = flat_run(3, true);
        let model = LinearModel::fit(&measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap();
        assert!(check_inputs_used(&CorrectorModel::Linear(Box::new(model)), &measured).is_ok());
    }

    #[test]
    fn an_unmoved_axis_the_map_passes_through_is_kept() {
        // z unmoved but the reference is the reading itself on z: the map follows it (gain 1).
        let (measured, mut reference) = flat_run(5, false);
        reference.accel_mps2[2] = measured.accel_mps2[2].clone();
        let model = LinearModel::fit(&measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap();
        assert!(check_inputs_used(&CorrectorModel::Linear(Box::new(model)), &measured).is_ok());
    }
}
