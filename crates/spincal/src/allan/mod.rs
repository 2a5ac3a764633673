//! Noise characterisation of a still recording: overlapping Allan deviation per axis, velocity random
//! walk (noise density) and bias instability, and the simulator sensor profile built from them.
//!
//! σ²(τ) = 1 / (2 τ² (N − 2m)) Σₖ (θₖ₊₂ₘ − 2θₖ₊ₘ + θₖ)², τ = m τ₀, θ the running integral of the
//! signal (IEEE Std 952 overlapping estimator). Noise density N is read where the curve has slope
//! −½: N = σ(τ)·√τ averaged over that stretch (σ at τ = 1 s on the fitted line). Bias instability
//! B = min σ / 0.664 (0.664 = √(2 ln 2 / π), the flicker-floor factor).

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

mod still;
pub use still::{analyse_still, AllanAnalysis, AllanSettings, StillNoise, StillNoiseError};

/// Allan deviation curves of three axes.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AllanCurve {
    pub tau_s: Vec<f64>,
    /// `adev[axis][k]` at `tau_s[k]`, signal units.
    pub adev: [Vec<f64>; 3],
}

/// Read-offs per axis (signal units: m/s² for acceleration).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NoiseParams {
    /// Velocity random walk, m/s²/√Hz (= m/s/√s).
    pub noise_density: [f64; 3],
    /// Bias instability, m/s².
    pub bias_instability: [f64; 3],
    /// τ at the curve minimum, s.
    pub bias_instability_tau_s: [f64; 3],
    /// Whether the curve turns up again after its minimum; when false the minimum is the last point
    /// and the bias instability is only an upper bound (the recording is too short).
    pub floor_reached: [bool; 3],
    /// Points used for the −½ fit per axis (0: fell back to the point of slope nearest −½).
    pub white_points: [usize; 3],
    /// Rate random walk K (σ = K √(τ/3) on the +½ slope): m/s³/√Hz for acceleration, rad/s²/√Hz
    /// for a gyro.
    #[serde(default)]
    pub random_walk: [f64; 3],
    /// Points on the +½ slope used per axis (0: the curve never rose, and K is an upper bound
    /// from its last point).
    #[serde(default)]
    pub random_walk_points: [usize; 3],
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AllanError {
    #[error("Allan deviation needs at least {needed} samples, got {found}")]
    TooShort { found: usize, needed: usize },
    #[error("sample interval must be finite and positive, got {0} s")]
    BadInterval(f64),
    #[error("cannot write {file}: {source}")]
    Write {
        file: String,
        #[source]
        source: std::io::Error,
    },
}

/// Cluster sizes m, about `per_decade` per decade, from 1 to N/10: beyond that fewer than ten
/// independent clusters remain and σ(τ) is too uncertain to read a floor from.
pub(crate) fn cluster_sizes(n: usize, per_decade: usize) -> Vec<usize> {
    let max = n / 10;
    let mut out: Vec<usize> = Vec::new();
    let mut k = 0.0;
    loop {
        let m = 10f64.powf(k / per_decade as f64).round() as usize;
        if m > max {
            break;
        }
        if out.last() != Some(&m) {
            out.push(m);
        }
        k += 1.0;
    }
    out
}

/// Overlapping Allan deviation of one signal sampled every `dt_s` at cluster sizes `ms`.
pub(crate) fn overlapping_adev(y: &[f64], dt_s: f64, ms: &[usize]) -> Vec<f64> {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    // Removing the mean leaves σ unchanged and keeps θ small.
    let mut theta = Vec::with_capacity(y.len() + 1);
    theta.push(0.0);
    let mut acc = 0.0;
    for v in y {
        acc += (v - mean) * dt_s;
        theta.push(acc);
    }
    let n = theta.len();
    ms.iter()
        .map(|&m| {
            let terms = n - 2 * m;
            let sum: f64 = (0..terms)
                .map(|k| {
                    let d = theta[k + 2 * m] - 2.0 * theta[k + m] + theta[k];
                    d * d
                })
                .sum();
            let tau = m as f64 * dt_s;
            (sum / (2.0 * tau * tau * terms as f64)).sqrt()
        })
        .collect()
}

/// Fewest samples for a curve of at least three points (m = 1, 2, 3 ≤ N/10).
pub(crate) const MIN_SAMPLES: usize = 30;

/// Allan deviation of three axes (sensor frame, any unit) sampled every `dt_s`.
pub(crate) fn allan_deviation(
    axes: &[Vec<f64>; 3],
    dt_s: f64,
    per_decade: usize,
) -> Result<AllanCurve, AllanError> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(AllanError::BadInterval(dt_s));
    }
    let n = axes.iter().map(Vec::len).min().unwrap_or(0);
    if n < MIN_SAMPLES {
        return Err(AllanError::TooShort {
            found: n,
            needed: MIN_SAMPLES,
        });
    }
    let ms = cluster_sizes(n, per_decade.max(1));
    Ok(AllanCurve {
        tau_s: ms.iter().map(|&m| m as f64 * dt_s).collect(),
        adev: std::array::from_fn(|a| overlapping_adev(&axes[a][..n], dt_s, &ms)),
    })
}

/// Reads noise density and bias instability off each curve.
pub(crate) fn noise_params(curve: &AllanCurve) -> NoiseParams {
    let mut p = NoiseParams {
        noise_density: [0.0; 3],
        bias_instability: [0.0; 3],
        bias_instability_tau_s: [0.0; 3],
        floor_reached: [false; 3],
        white_points: [0; 3],
        random_walk: [0.0; 3],
        random_walk_points: [0; 3],
    };
    let lt: Vec<f64> = curve.tau_s.iter().map(|t| t.log10()).collect();
    for a in 0..3 {
        let ad = &curve.adev[a];
        let (kmin, &smin) = ad
            .iter()
            .enumerate()
            .min_by(|x, y| x.1.total_cmp(y.1))
            .expect("curve is never empty");
        p.bias_instability[a] = smin / 0.664;
        p.bias_instability_tau_s[a] = curve.tau_s[kmin];
        p.floor_reached[a] = kmin + 1 < ad.len();
        // Local slopes between neighbours, left of the minimum (white noise dominates at short τ).
        let la: Vec<f64> = ad.iter().map(|s| s.log10()).collect();
        let slope = |k: usize| (la[k + 1] - la[k]) / (lt[k + 1] - lt[k]);
        let mut intercepts = Vec::new();
        let mut nearest = (f64::INFINITY, 0usize);
        for k in 0..ad.len().saturating_sub(1) {
            let s = slope(k);
            if (s + 0.5).abs() < nearest.0 {
                nearest = ((s + 0.5).abs(), k);
            }
            if k < kmin.max(1) && (-0.65..=-0.35).contains(&s) {
                intercepts.push(la[k] + 0.5 * lt[k]);
            }
        }
        p.white_points[a] = intercepts.len();
        let log_n = if intercepts.is_empty() {
            la[nearest.1] + 0.5 * lt[nearest.1]
        } else {
            intercepts.iter().sum::<f64>() / intercepts.len() as f64
        };
        p.noise_density[a] = 10f64.powf(log_n);
        // Rate random walk K: σ(τ) = K √(τ/3) on the +½ slope right of the minimum. Where the
        // curve ends before it rises, the last point bounds K from above.
        let mut walk = Vec::new();
        for k in kmin..ad.len().saturating_sub(1) {
            if (0.35..=0.65).contains(&slope(k)) {
                walk.push(la[k] - 0.5 * (lt[k] - 3f64.log10()));
            }
        }
        p.random_walk_points[a] = walk.len();
        let last = ad.len() - 1;
        let log_k = if walk.is_empty() {
            la[last] - 0.5 * (lt[last] - 3f64.log10())
        } else {
            walk.iter().sum::<f64>() / walk.len() as f64
        };
        p.random_walk[a] = 10f64.powf(log_k);
    }
    p
}

/// Writes the curve as CSV: `tau_s,adev_x,adev_y,adev_z`.
pub fn write_curve_csv<W: std::io::Write>(curve: &AllanCurve, mut out: W) -> std::io::Result<()> {
    writeln!(out, "tau_s,adev_x,adev_y,adev_z")?;
    for k in 0..curve.tau_s.len() {
        writeln!(
            out,
            "{},{},{},{}",
            curve.tau_s[k], curve.adev[0][k], curve.adev[1][k], curve.adev[2][k]
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn white_noise_gives_slope_minus_half_and_its_density() {
        // White noise of density N sampled at fs has per-sample σ = N √fs.
        let fs: f64 = 100.0;
        let density = [0.002, 0.004, 0.001];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let axes: [Vec<f64>; 3] = std::array::from_fn(|a| {
            let d = Normal::new(0.0, density[a] * fs.sqrt()).unwrap();
            (0..200_000).map(|_| d.sample(&mut rng)).collect()
        });
        let curve = allan_deviation(&axes, 1.0 / fs, 10).unwrap();
        let p = noise_params(&curve);
        for a in 0..3 {
            let rel = p.noise_density[a] / density[a] - 1.0;
            assert!(
                rel.abs() < 0.05,
                "axis {a}: {} vs {}",
                p.noise_density[a],
                density[a]
            );
            assert!(p.white_points[a] >= 10, "{:?}", p.white_points);
            // Overlapping ADEV at τ = τ₀ is exactly the sample σ / √fs... check σ(τ₀) ≈ N/√τ₀.
            let s0 = curve.adev[a][0] * (curve.tau_s[0]).sqrt();
            assert!((s0 / density[a] - 1.0).abs() < 0.05);
        }
    }

    #[test]
    fn a_bias_step_shows_as_bias_instability_floor() {
        // Bias random walk makes the curve rise after its minimum; the minimum is found, not the end.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let white = Normal::new(0.0, 0.01).unwrap();
        let walk = Normal::new(0.0, 1e-4).unwrap();
        let mut b = 0.0;
        let y: Vec<f64> = (0..100_000)
            .map(|_| {
                b += walk.sample(&mut rng);
                b + white.sample(&mut rng)
            })
            .collect();
        let axes = [y.clone(), y.clone(), y];
        let curve = allan_deviation(&axes, 0.01, 10).unwrap();
        let p = noise_params(&curve);
        let last = *curve.adev[0].last().unwrap();
        assert!(p.bias_instability[0] * 0.664 < last);
        assert!(p.bias_instability_tau_s[0] < *curve.tau_s.last().unwrap());
        assert!(p.floor_reached[0]);
        assert!(matches!(
            allan_deviation(&[vec![1.0; 3], vec![1.0; 3], vec![1.0; 3]], 0.01, 10),
            Err(AllanError::TooShort {
                found: 3,
                needed: MIN_SAMPLES
            })
        ));
    }
}
