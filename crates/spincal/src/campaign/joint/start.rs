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

/// The coarse scan's largest phase error within a block, rad: the rate's distance from the
/// nominal one times the block's length. Blocks as long as this lower the scan's amplitudes by
/// less than 1 % (sinc(0.25)), smoothly in the rate.
const BLOCK_PHASE_RAD: f64 = 0.5;

/// Rates between exact re-anchorings of the coarse scan's rotors.
const SCAN_REANCHOR: usize = 64;

/// Newton steps of the refinement before golden section takes over.
const NEWTON_STEPS: usize = 8;

/// The rotation rate and sense that best demodulate the horizontal readings (mounting frame
/// m_x + i m_y = G e^{i(ψ − σωτ)} + constant): the largest |F(w)| = |Σ z e^{iσwτ}| (z the centred
/// readings) on a grid of half a spectral bin within ±25 % of the nominal rate, then the maximum
/// of |F|² near it by Newton's method on the exact sum. Returns (ω, σ, amplitude G, ψ).
pub(crate) fn demodulate(
    time_s: &[f64],
    horizontal: &[[f64; 2]],
    nominal_radps: f64,
) -> (f64, f64, f64, f64) {
    let n = horizontal.len().max(1) as f64;
    let mid = mid_time(time_s);
    let mean = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
    let tau: Vec<f64> = time_s.iter().map(|t| t - mid).collect();
    let centred: Vec<[f64; 2]> = horizontal
        .iter()
        .map(|h| [h[0] - mean[0], h[1] - mean[1]])
        .collect();
    let span = match (time_s.first(), time_s.last()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => 1.0,
    };
    let step = 0.5 / span;
    let (lo, hi) = (0.75 * nominal_radps, 1.25 * nominal_radps);
    let coarse = Baseband::new(&tau, &centred, nominal_radps, 0.25 * nominal_radps.abs());
    let mut best = (0.0, nominal_radps, 1.0);
    let mut w = lo;
    let mut rotor = coarse.rotor(w);
    let mut advance = Vec::new();
    let mut since_anchor = 0;
    while w <= hi {
        let [a_pos, a_neg] = coarse.amplitudes(&rotor, n);
        for (a, sigma) in [(a_pos, 1.0), (a_neg, -1.0)] {
            if a > best.0 {
                best = (a, w, sigma);
            }
        }
        w += step;
        since_anchor += 1;
        if since_anchor == SCAN_REANCHOR {
            rotor = coarse.rotor(w);
            since_anchor = 0;
        } else {
            if advance.is_empty() {
                advance = coarse.rotor(coarse.centre + step);
            }
            for (r, a) in rotor.iter_mut().zip(&advance) {
                *r = [r[0] * a[0] - r[1] * a[1], r[0] * a[1] + r[1] * a[0]];
            }
        }
    }
    let (_, w0, sigma) = best;
    let (a, b) = (w0 - step, w0 + step);
    let w = newton_max(&tau, &centred, sigma, w0, a, b).unwrap_or_else(|| {
        golden_section_max(|w| exact_sum(&tau, &centred, sigma, w).amplitude(n), a, b, 40)
    });
    let at = exact_sum(&tau, &centred, sigma, w);
    (w, sigma, at.amplitude(n), at.f[1].atan2(at.f[0]))
}

/// The centred readings turned down by the nominal rate and summed over short blocks of time,
/// for each sense: Y±_b = Σ_{k∈b} z_k e^{±i c τ_k} at the blocks' mean times T_b. Then
/// F(w, ±1) ≈ Σ_b Y±_b e^{±i (w − c) T_b}: the coarse scan costs the blocks per rate, not the
/// samples.
struct Baseband {
    centre: f64,
    times: Vec<f64>,
    sums: [Vec<[f64; 2]>; 2],
}

impl Baseband {
    /// Blocks of at most BLOCK_PHASE_RAD / `half_width` seconds, `half_width` the largest
    /// distance of a scanned rate from `centre`.
    fn new(tau: &[f64], z: &[[f64; 2]], centre: f64, half_width: f64) -> Baseband {
        let (t0, t1) = tau.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
        let length = BLOCK_PHASE_RAD / half_width;
        let blocks = if length.is_finite() && t1 > t0 {
            (((t1 - t0) / length) as usize + 1).min(tau.len())
        } else {
            1
        };
        let width = if blocks > 1 {
            (t1 - t0) / blocks as f64
        } else {
            f64::INFINITY
        };
        let mut time_sum = vec![0.0; blocks];
        let mut count = vec![0usize; blocks];
        let mut pos = vec![[0.0; 2]; blocks];
        let mut neg = vec![[0.0; 2]; blocks];
        for (&t, &[x, y]) in tau.iter().zip(z) {
            let b = if blocks > 1 {
                (((t - t0) / width) as usize).min(blocks - 1)
            } else {
                0
            };
            let (sn, cs) = (centre * t).sin_cos();
            pos[b][0] += x * cs - y * sn;
            pos[b][1] += x * sn + y * cs;
            neg[b][0] += x * cs + y * sn;
            neg[b][1] += y * cs - x * sn;
            time_sum[b] += t;
            count[b] += 1;
        }
        let used: Vec<usize> = (0..blocks).filter(|&b| count[b] > 0).collect();
        Baseband {
            centre,
            times: used.iter().map(|&b| time_sum[b] / count[b] as f64).collect(),
            sums: [
                used.iter().map(|&b| pos[b]).collect(),
                used.iter().map(|&b| neg[b]).collect(),
            ],
        }
    }

    /// e^{i (w − c) T_b} for each block.
    fn rotor(&self, w: f64) -> Vec<[f64; 2]> {
        self.times
            .iter()
            .map(|&t| {
                let (sn, cs) = ((w - self.centre) * t).sin_cos();
                [cs, sn]
            })
            .collect()
    }

    /// |F(w, +1)| / n and |F(w, −1)| / n from the blocks' rotors at w.
    fn amplitudes(&self, rotor: &[[f64; 2]], n: f64) -> [f64; 2] {
        let (mut pos, mut neg) = ([0.0f64; 2], [0.0f64; 2]);
        for ((r, p), m) in rotor.iter().zip(&self.sums[0]).zip(&self.sums[1]) {
            pos[0] += p[0] * r[0] - p[1] * r[1];
            pos[1] += p[0] * r[1] + p[1] * r[0];
            neg[0] += m[0] * r[0] + m[1] * r[1];
            neg[1] += m[1] * r[0] - m[0] * r[1];
        }
        [pos[0].hypot(pos[1]) / n, neg[0].hypot(neg[1]) / n]
    }
}

/// F(w) = Σ z e^{iσwτ} and its first two derivatives in w, as (re, im) pairs.
struct ExactSum {
    f: [f64; 2],
    d1: [f64; 2],
    d2: [f64; 2],
}

impl ExactSum {
    fn amplitude(&self, n: f64) -> f64 {
        self.f[0].hypot(self.f[1]) / n
    }
}

fn exact_sum(tau: &[f64], z: &[[f64; 2]], sigma: f64, w: f64) -> ExactSum {
    // Σ e, Σ τ e, Σ τ² e with e = z e^{iσwτ}; F' = iσ Σ τ e and F'' = −Σ τ² e.
    let (mut s0, mut s1, mut s2) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
    for (&t, &[x, y]) in tau.iter().zip(z) {
        let (sn, cs) = (sigma * w * t).sin_cos();
        let (re, im) = (x * cs - y * sn, x * sn + y * cs);
        s0 = [s0[0] + re, s0[1] + im];
        s1 = [s1[0] + t * re, s1[1] + t * im];
        s2 = [s2[0] + t * t * re, s2[1] + t * t * im];
    }
    ExactSum {
        f: s0,
        d1: [-sigma * s1[1], sigma * s1[0]],
        d2: [-s2[0], -s2[1]],
    }
}

/// The maximiser of |F(w)|² in [a, b] by Newton's method from `w0`, or `None` where the
/// curvature is not negative, a step leaves [a, b] or the steps do not settle.
fn newton_max(tau: &[f64], z: &[[f64; 2]], sigma: f64, w0: f64, a: f64, b: f64) -> Option<f64> {
    let mut w = w0;
    for _ in 0..NEWTON_STEPS {
        let s = exact_sum(tau, z, sigma, w);
        // P = |F|²: P' = 2 Re(F̄ F'), P'' = 2 (|F'|² + Re(F̄ F'')).
        let slope = s.f[0] * s.d1[0] + s.f[1] * s.d1[1];
        let curvature = s.d1[0] * s.d1[0] + s.d1[1] * s.d1[1] + s.f[0] * s.d2[0] + s.f[1] * s.d2[1];
        if curvature.is_nan() || curvature >= 0.0 {
            return None;
        }
        let next = w - slope / curvature;
        if !(a..=b).contains(&next) {
            return None;
        }
        let moved = (next - w).abs();
        w = next;
        if moved <= 1e-12 * w.abs().max(1e-12) {
            return Some(w);
        }
    }
    None
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
    // Without a stated radius the centripetal level gives it (bias and scale aside).
    start[0] = match run.entry.radius {
        Some(stated) => stated.value_m,
        None => (cx * cx + cy * cy).sqrt() / (found.rate_radps * found.rate_radps).max(1e-9),
    };
    start[1] = found.rate_radps;
    start[2] = tilt.max(1e-4);
    start[3] = found.phase - beta;
    start[4] = beta;
    (start, sigma)
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    use super::*;

    /// A run's horizontal readings in its mounting frame, G e^{i(ψ − σωτ + wow)} plus a constant
    /// and white noise, on a clock with jitter, one gap of 3 s and 5 % of the samples dropped.
    fn readings(seed: u64, rate: f64, sigma: f64, gain: f64, psi: f64) -> (Vec<f64>, Vec<[f64; 2]>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.05).unwrap();
        let jitter = Normal::new(0.0, 0.001).unwrap();
        let (mut time, mut horizontal) = (Vec::new(), Vec::new());
        for k in 0..6000 {
            let t = 0.01 * k as f64 + jitter.sample(&mut rng);
            if (20.0..23.0).contains(&t) || rng.gen::<f64>() < 0.05 {
                continue;
            }
            let tau = t - 30.0;
            let angle = psi - sigma * (rate * tau + 0.003 * (rate * tau).sin());
            time.push(t);
            horizontal.push([
                -0.4 + gain * angle.cos() + noise.sample(&mut rng),
                0.1 + gain * angle.sin() + noise.sample(&mut rng),
            ]);
        }
        (time, horizontal)
    }

    /// The definition, by brute force: the largest exact |F| over the whole band on a grid of a
    /// half the coarse scan's step, refined by golden section.
    fn brute_force(time: &[f64], horizontal: &[[f64; 2]], nominal: f64) -> (f64, f64) {
        let n = horizontal.len() as f64;
        let mid = mid_time(time);
        let tau: Vec<f64> = time.iter().map(|t| t - mid).collect();
        let mean = [0, 1].map(|c| horizontal.iter().map(|h| h[c]).sum::<f64>() / n);
        let z: Vec<[f64; 2]> = horizontal
            .iter()
            .map(|h| [h[0] - mean[0], h[1] - mean[1]])
            .collect();
        let step = 0.25 / (time[time.len() - 1] - time[0]);
        let mut best = (0.0, 0.0, 0.0);
        let mut w = 0.75 * nominal;
        while w <= 1.25 * nominal {
            for sigma in [1.0, -1.0] {
                let a = exact_sum(&tau, &z, sigma, w).amplitude(n);
                if a > best.0 {
                    best = (a, w, sigma);
                }
            }
            w += step;
        }
        let (_, w0, sigma) = best;
        let amplitude = |w: f64| exact_sum(&tau, &z, sigma, w).amplitude(n);
        (golden_section_max(amplitude, w0 - step, w0 + step, 60), sigma)
    }

    #[test]
    fn demodulation_finds_the_largest_exact_amplitude_and_the_truth() {
        let rpm = 2.0 * std::f64::consts::PI / 60.0;
        // (seed, nominal rpm, true rate / nominal, sense): rates off the nominal up to 20 %.
        for (seed, nominal_rpm, factor, sigma) in [
            (1, 100.0 / 3.0, 1.0, 1.0),
            (2, 45.0, 0.82, -1.0),
            (3, 78.0, 1.2, 1.0),
            (4, 100.0 / 3.0, 1.013, -1.0),
        ] {
            let (nominal, rate, gain, psi) = (nominal_rpm * rpm, factor * nominal_rpm * rpm, 0.6, 2.5);
            let (time, horizontal) = readings(seed, rate, sigma, gain, psi);
            let (w, s, g, phase) = demodulate(&time, &horizontal, nominal);
            let (w_brute, s_brute) = brute_force(&time, &horizontal, nominal);
            assert_eq!((s, s_brute), (sigma, sigma), "seed {seed}: sense");
            // Golden section on the flat top of |F| settles to about 1e-9 of the rate.
            assert!(
                (w - w_brute).abs() < 1e-8 * w,
                "seed {seed}: {w} against {w_brute}"
            );
            assert!(
                (w - rate).abs() < 1e-3 * rate,
                "seed {seed}: {w} against the true {rate}"
            );
            assert!((g - gain).abs() < 0.02 * gain, "seed {seed}: amplitude {g}");
            let mid = mid_time(&time);
            // ψ refers to τ = 0 at the clock's middle (30 s in the simulation): move it there.
            let expected = psi - sigma * rate * (mid - 30.0);
            let error = (phase - expected).sin().asin();
            assert!(error.abs() < 0.02, "seed {seed}: phase off by {error}");
        }
    }
}
