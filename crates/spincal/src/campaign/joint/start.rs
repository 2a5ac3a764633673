//! Starting values of a run's geometry, from demodulating its horizontal readings.

use super::input::RunInput;
use super::kinematics::mounting_matrix;
use super::layout::{mid_time, RUN_PARAMS};
use crate::campaign::file::SignedAxis;
use crate::optim::golden_section_max;
use crate::turntable::model::Direction;

/// What demodulating a run's horizontal readings (in its mounting frame) finds: the rate, the
/// rotation sense, the rotating part's amplitude and phase, and the constant part. `key`: the
/// entry's mounting and nominal rpm it was found with.
#[derive(Debug, Clone, Copy)]
pub(super) struct Demodulated {
    pub(super) key: (SignedAxis, SignedAxis, u64),
    rate_radps: f64,
    sigma: f64,
    amplitude: f64,
    phase: f64,
    constant: [f64; 2],
}

impl Demodulated {
    pub(super) fn of(run: &RunInput, key: (SignedAxis, SignedAxis, u64)) -> Demodulated {
        let q = mounting_matrix(run.entry.out, run.entry.up);
        let mut time = Vec::with_capacity(run.time_s.len());
        let mut horizontal = Vec::with_capacity(run.time_s.len());
        for (s, &t) in run.time_s.iter().enumerate() {
            if !run.keep[s] {
                continue;
            }
            let a = [run.accel_mps2[0][s], run.accel_mps2[1][s], run.accel_mps2[2][s]];
            // Qᵀ a: the readings along out, up × out and up.
            let m: [f64; 3] = std::array::from_fn(|c| (0..3).map(|r| q[r][c] * a[r]).sum());
            time.push(t);
            horizontal.push([m[0], m[1]]);
        }
        let nominal = run.entry.rpm * 2.0 * std::f64::consts::PI / 60.0;
        let (rate_radps, sigma, amplitude, phase) = demodulate(&time, &horizontal, nominal);
        let n = horizontal.len().max(1) as f64;
        let constant = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
        Demodulated {
            key,
            rate_radps,
            sigma,
            amplitude,
            phase,
            constant,
        }
    }
}

/// Samples between exact re-anchorings of the demodulation scan's phasor.
const SCAN_BLOCK: usize = 64;

/// The rotation rate and sense that best demodulate the horizontal readings (mounting frame
/// m_x + i m_y = G e^{i(ψ − σωτ)} + constant), scanned within ±25 % of the nominal rate and then
/// refined by golden section. Returns (ω, σ, amplitude G, ψ).
pub(crate) fn demodulate(
    time_s: &[f64],
    horizontal: &[[f64; 2]],
    nominal_radps: f64,
) -> (f64, f64, f64, f64) {
    let n = horizontal.len().max(1) as f64;
    let mid = mid_time(time_s);
    let mean = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
    let amplitude = |w: f64, sigma: f64| -> (f64, f64) {
        let (mut re, mut im) = (0.0, 0.0);
        for (h, &t) in horizontal.iter().zip(time_s) {
            let (x, y) = (h[0] - mean[0], h[1] - mean[1]);
            let (sn, cs) = (sigma * w * (t - mid)).sin_cos();
            re += x * cs - y * sn;
            im += x * sn + y * cs;
        }
        ((re * re + im * im).sqrt() / n, im.atan2(re))
    };
    let span = match (time_s.first(), time_s.last()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => 1.0,
    };
    let step = 0.5 / span;
    let (lo, hi) = (0.75 * nominal_radps, 1.25 * nominal_radps);
    // The coarse scan advances the phasor by the median step and re-anchors it exactly every
    // SCAN_BLOCK samples (one sin_cos per block, not per sample), and sums both senses at once;
    // the refinement below is exact.
    let dt = crate::input::recording::sample_interval(time_s);
    let centred: Vec<[f64; 2]> = horizontal
        .iter()
        .map(|h| [h[0] - mean[0], h[1] - mean[1]])
        .collect();
    let scan = |w: f64| -> [f64; 2] {
        let (step_s, step_c) = (w * dt).sin_cos();
        let (mut pos, mut neg) = ([0.0f64; 2], [0.0f64; 2]);
        for (block, chunk) in centred.chunks(SCAN_BLOCK).enumerate() {
            let (mut sn, mut cs) = (w * (time_s[block * SCAN_BLOCK] - mid)).sin_cos();
            for h in chunk {
                let (x, y) = (h[0], h[1]);
                pos[0] += x * cs - y * sn;
                pos[1] += x * sn + y * cs;
                neg[0] += x * cs + y * sn;
                neg[1] += y * cs - x * sn;
                (sn, cs) = (sn * step_c + cs * step_s, cs * step_c - sn * step_s);
            }
        }
        [pos[0].hypot(pos[1]) / n, neg[0].hypot(neg[1]) / n]
    };
    let mut best = (0.0, nominal_radps, 1.0);
    let mut w = lo;
    while w <= hi {
        let [a_pos, a_neg] = if dt.is_finite() && dt > 0.0 {
            scan(w)
        } else {
            [amplitude(w, 1.0).0, amplitude(w, -1.0).0]
        };
        for (a, sigma) in [(a_pos, 1.0), (a_neg, -1.0)] {
            if a > best.0 {
                best = (a, w, sigma);
            }
        }
        w += step;
    }
    let (_, w0, sigma) = best;
    let w = golden_section_max(|w| amplitude(w, sigma).0, w0 - step, w0 + step, 40);
    let (g, psi) = amplitude(w, sigma);
    (w, sigma, g, psi)
}

/// Starting values of a run's geometry from its readings in its mounting frame, and the rotation
/// sense σ (given, or found by demodulation).
pub fn run_start(run: &RunInput, gravity: f64) -> ([f64; RUN_PARAMS], f64) {
    let found = run.demodulated();
    let sigma = run.entry.direction.map_or(found.sigma, Direction::sign);
    let [cx, cy] = found.constant;
    let tilt = (found.amplitude / gravity).clamp(0.0, 0.5).asin();
    // The constant is −ω² r turned by β; with no centripetal level β is left at 0.
    let beta = if (cx * cx + cy * cy).sqrt() > 1e-3 {
        (-cy).atan2(-cx)
    } else {
        0.0
    };
    let mut start = [0.0; RUN_PARAMS];
    start[0] = run.entry.radius_m;
    start[1] = found.rate_radps;
    start[2] = tilt.max(1e-4);
    start[3] = found.phase - beta;
    start[4] = beta;
    (start, sigma)
}
