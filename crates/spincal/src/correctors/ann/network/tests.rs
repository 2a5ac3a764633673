//! The network's tests: gradients against finite differences, the vectorised tanh against std,
//! the block passes against the one-sample ones, and Nguyen–Widrow magnitudes.

use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Central differences of the outputs against the backpropagated gradients.
fn check_gradients(inputs: usize, hidden: &[usize], outputs: usize, seed: u64) {
    let layout = Layout::new(inputs, hidden, outputs);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let weights: Vec<f64> = (0..layout.n_params()).map(|_| rng.gen_range(-1.5..1.5)).collect();
    let x: Vec<f64> = (0..inputs).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let mut act = vec![0.0; layout.n_activations()];
    let mut delta = vec![0.0; layout.n_delta()];
    let mut columns = vec![0.0; outputs * layout.n_params()];
    layout.forward(&weights, &x, &mut act);
    layout.output_gradients(&weights, &act, &mut columns, &mut delta);
    let out_at = layout.n_activations() - outputs;
    let h = 1e-6;
    let mut w = weights.clone();
    for p in 0..layout.n_params() {
        w[p] = weights[p] + h;
        layout.forward(&w, &x, &mut act);
        let plus: Vec<f64> = act[out_at..].to_vec();
        w[p] = weights[p] - h;
        layout.forward(&w, &x, &mut act);
        w[p] = weights[p];
        for k in 0..outputs {
            let numeric = (plus[k] - act[out_at + k]) / (2.0 * h);
            let analytic = columns[k * layout.n_params() + p];
            let tolerance = 1e-6 * analytic.abs().max(numeric.abs()).max(1e-3);
            assert!(
                (numeric - analytic).abs() <= tolerance,
                "{inputs}-{hidden:?}-{outputs} param {p} output {k}: backprop {analytic} vs finite difference {numeric}"
            );
        }
    }
}

#[test]
fn vectorised_tanh_is_within_a_few_ulps_of_std() {
    let mut worst = 0u64;
    let mut checked = Vec::new();
    let mut check = |x: f64| {
        checked.push(x);
        let (ours, std) = (tanh(x), x.tanh());
        let ulps = (ours.to_bits() as i64 - std.to_bits() as i64).unsigned_abs();
        assert!(ulps <= 4, "tanh({x:e}): {ours:e} vs std {std:e} ({ulps} ulps)");
        worst = worst.max(ulps);
    };
    for i in -250_000..=250_000 {
        check(i as f64 * 1e-4); // [-25, 25]
    }
    for e in -320..=1 {
        let x = 1.7 * 10f64.powi(e);
        check(x);
        check(-x);
    }
    for x in [
        0.0,
        -0.0,
        19.0,
        19.5,
        20.0,
        709.0,
        f64::MAX,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ] {
        check(x);
    }
    assert!(tanh(f64::NAN).is_nan());
    assert_eq!(tanh(-0.0).to_bits(), (-0.0f64).to_bits());
    // The slice version (whichever vector width this CPU runs) equals the scalar one bit for
    // bit, on every value above, NaN among them, with and without a tail of whole vectors.
    checked.insert(12_345, f64::NAN);
    checked.push(-f64::NAN);
    for trim in [0, 9] {
        let mut v = checked[..checked.len() - trim].to_vec();
        tanh_in_place(&mut v);
        for (x, t) in checked.iter().zip(&v) {
            let expected = tanh(*x);
            assert!(
                t.to_bits() == expected.to_bits() || (t.is_nan() && expected.is_nan()),
                "tanh_in_place({x:e}) = {t:e}, tanh = {expected:e}"
            );
        }
    }
}

#[test]
fn block_passes_equal_the_per_sample_ones_bit_for_bit() {
    for (inputs, hidden, outputs) in [(1, vec![], 1), (2, vec![10, 6], 2), (9, vec![4, 3, 2], 3)] {
        let layout = Layout::new(inputs, &hidden, outputs);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let weights: Vec<f64> = (0..layout.n_params()).map(|_| rng.gen_range(-1.5..1.5)).collect();
        let count = 37;
        let x: Vec<f64> = (0..count * inputs).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let (n_a, n_p) = (layout.n_activations(), layout.n_params());
        let mut block_act = vec![0.0; n_a * count];
        let mut block_delta = vec![0.0; layout.n_delta_block(count)];
        let mut jacobian = vec![f64::NAN; n_p * outputs * count];
        layout.forward_block(&weights, &x, count, &mut block_act);
        layout.jacobian_block(&weights, &block_act, count, &mut jacobian, &mut block_delta);
        let mut act = vec![0.0; n_a];
        let mut delta = vec![0.0; layout.n_delta()];
        let mut columns = vec![0.0; outputs * n_p];
        for s in 0..count {
            layout.forward(&weights, &x[s * inputs..(s + 1) * inputs], &mut act);
            layout.output_gradients(&weights, &act, &mut columns, &mut delta);
            for a in 0..n_a {
                assert_eq!(act[a].to_bits(), block_act[a * count + s].to_bits());
            }
            for k in 0..outputs {
                for p in 0..n_p {
                    let block = jacobian[p * outputs * count + k * count + s];
                    assert_eq!(columns[k * n_p + p].to_bits(), block.to_bits());
                }
            }
        }
    }
}

#[test]
fn backprop_matches_finite_differences() {
    check_gradients(1, &[], 1, 1);
    check_gradients(3, &[5], 1, 2);
    check_gradients(2, &[10, 6], 2, 3);
    check_gradients(9, &[4, 3, 2], 3, 4);
}

#[test]
fn nguyen_widrow_rows_have_the_stated_magnitude() {
    let layout = Layout::new(3, &[8], 1);
    let w = layout.nguyen_widrow(&mut ChaCha8Rng::seed_from_u64(7));
    let expected = 2.0 * 0.7 * 8f64.powf(1.0 / 3.0);
    for i in 0..8 {
        let norm = w[i * 3..i * 3 + 3].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((norm - expected).abs() < 1e-12);
    }
    // Biases run from −magnitude to +magnitude (times the row's sign).
    let biases = &w[24..32];
    assert!((biases[0].abs() - expected).abs() < 1e-12);
    assert!((biases[7].abs() - expected).abs() < 1e-12);
    assert!(w[32..].iter().all(|v| v.abs() <= 1.0));
}
