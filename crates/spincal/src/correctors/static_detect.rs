//! Finding still intervals in an accelerometer recording, the way imu_tk does it.
//!
//! The moving variance of each axis over a short window is combined into one magnitude
//! ‖(σ²x, σ²y, σ²z)‖; the sensor counts as still where it is below `threshold_factor` times the same
//! magnitude computed over an initial period that the user promises is still.

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

/// Detector settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StaticOptions {
    /// Length of the initial still period that sets the noise level, s.
    pub init_s: f64,
    /// Moving-variance window, s.
    pub window_s: f64,
    /// Still where the moving-variance magnitude is below this many times the initial one.
    pub threshold_factor: f64,
    /// Shortest interval reported, s.
    pub min_interval_s: f64,
}

impl Default for StaticOptions {
    fn default() -> Self {
        StaticOptions {
            init_s: 3.0,
            window_s: 1.0,
            threshold_factor: 3.0,
            // A pose held for a second is a pose: at 2 s the T265 recording's only two poses
            // with +x up (1.2 s and 2.0 s) were dropped, and the fit extrapolated bias_x.
            min_interval_s: 1.0,
        }
    }
}

/// A still interval `[start, end)` in samples, with its statistics (input units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StillInterval {
    pub start: usize,
    pub end: usize,
    pub t_start_s: f64,
    pub t_end_s: f64,
    /// Per-axis mean over the interval (sensor frame, input units).
    pub mean: [f64; 3],
    /// Per-axis standard deviation over the interval.
    pub std: [f64; 3],
}

impl StillInterval {
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// Builds an interval's statistics from samples `[start, end)`.
    pub fn from_samples(time_s: &[f64], accel: &[Vec<f64>; 3], start: usize, end: usize) -> StillInterval {
        let n = (end - start) as f64;
        let mut mean = [0.0; 3];
        let mut std = [0.0; 3];
        for a in 0..3 {
            let xs = &accel[a][start..end];
            mean[a] = xs.iter().sum::<f64>() / n;
            std[a] = (xs.iter().map(|x| (x - mean[a]).powi(2)).sum::<f64>() / n).sqrt();
        }
        StillInterval {
            start,
            end,
            t_start_s: time_s[start],
            t_end_s: time_s[end - 1],
            mean,
            std,
        }
    }
}

/// Still intervals from section labels: every contiguous run of at least two samples whose label
/// `is_still` accepts (imucal: every section but the `*_rot` turns).
pub fn labelled_intervals(
    time_s: &[f64],
    accel: &[Vec<f64>; 3],
    labels: &[String],
    is_still: impl Fn(&str) -> bool,
) -> Vec<StillInterval> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=labels.len() {
        if i == labels.len() || labels[i] != labels[start] {
            if is_still(&labels[start]) && i - start >= 2 {
                out.push(StillInterval::from_samples(time_s, accel, start, i));
            }
            start = i;
        }
    }
    out
}

/// Detector output.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StaticDetection {
    /// Variance magnitude over the initial period (input units²).
    pub init_variance: f64,
    pub threshold: f64,
    pub window_samples: usize,
    pub intervals: Vec<StillInterval>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StaticDetectError {
    #[error("static detection: {found} samples, at least {needed} needed (window {window_s} s)")]
    TooShort {
        found: usize,
        needed: usize,
        window_s: f64,
    },
    #[error("static detection: option {name} = {value} must be finite and positive")]
    BadOption { name: &'static str, value: f64 },
    #[error("static detection: the initial {init_s} s are not still enough to set a threshold (variance {variance})")]
    NoNoiseLevel { init_s: f64, variance: f64 },
}

/// Finds still intervals. `accel` is per axis, sensor frame, any unit; `time_s` strictly increasing.
pub fn detect_static(
    time_s: &[f64],
    accel: &[Vec<f64>; 3],
    options: &StaticOptions,
) -> Result<StaticDetection, StaticDetectError> {
    for (name, value) in [
        ("init_s", options.init_s),
        ("window_s", options.window_s),
        ("threshold_factor", options.threshold_factor),
        ("min_interval_s", options.min_interval_s),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(StaticDetectError::BadOption { name, value });
        }
    }
    let n = time_s.len();
    let dt = crate::input::recording::sample_interval(time_s);
    let half = if dt.is_finite() && dt > 0.0 {
        ((options.window_s / dt / 2.0).round() as usize).max(1)
    } else {
        1
    };
    let window = 2 * half + 1;
    if n < window + 1 || accel.iter().any(|a| a.len() != n) {
        return Err(StaticDetectError::TooShort {
            found: n,
            needed: window + 1,
            window_s: options.window_s,
        });
    }
    // Prefix sums of values relative to the first sample keep the sums of squares well conditioned
    // for raw counts around 32768.
    let mut sums: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n + 1]);
    let mut squares: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; n + 1]);
    for a in 0..3 {
        let x0 = accel[a][0];
        for i in 0..n {
            let x = accel[a][i] - x0;
            sums[a][i + 1] = sums[a][i] + x;
            squares[a][i + 1] = squares[a][i] + x * x;
        }
    }
    let variance_magnitude = |lo: usize, hi: usize| {
        let m = (hi - lo) as f64;
        let mut total = 0.0;
        for a in 0..3 {
            let mean = (sums[a][hi] - sums[a][lo]) / m;
            let var = ((squares[a][hi] - squares[a][lo]) / m - mean * mean).max(0.0);
            total += var * var;
        }
        total.sqrt()
    };
    let init_end = time_s
        .iter()
        .position(|t| t - time_s[0] >= options.init_s)
        .unwrap_or(n)
        .max(2);
    let init_variance = variance_magnitude(0, init_end);
    if !(init_variance.is_finite() && init_variance > 0.0) {
        return Err(StaticDetectError::NoNoiseLevel {
            init_s: options.init_s,
            variance: init_variance,
        });
    }
    let threshold = options.threshold_factor * init_variance;
    let mut intervals = Vec::new();
    let mut run_start: Option<usize> = None;
    for i in 0..=n {
        let still = i < n && variance_magnitude(i.saturating_sub(half), (i + half + 1).min(n)) < threshold;
        match (still, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(s)) => {
                run_start = None;
                if time_s[i - 1] - time_s[s] >= options.min_interval_s {
                    intervals.push(StillInterval::from_samples(time_s, accel, s, i));
                }
            }
            _ => {}
        }
    }
    Ok(StaticDetection {
        init_variance,
        threshold,
        window_samples: window,
        intervals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn finds_still_stretches_between_motions() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.01).unwrap();
        let fs = 100.0;
        let n = 3000;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
        // Still 0–10 s, moving 10–15 s, still 15–25 s, moving 25–27 s, still 27–30 s.
        let moving = |t: f64| (10.0..15.0).contains(&t) || (25.0..27.0).contains(&t);
        let accel: [Vec<f64>; 3] = std::array::from_fn(|a| {
            time_s
                .iter()
                .map(|&t| {
                    let base = if t < 12.5 {
                        [0.0, 0.0, 9.8][a]
                    } else {
                        [9.8, 0.0, 0.0][a]
                    };
                    let motion = if moving(t) {
                        2.0 * (7.0 * t + a as f64).sin()
                    } else {
                        0.0
                    };
                    base + motion + noise.sample(&mut rng)
                })
                .collect()
        });
        let d = detect_static(&time_s, &accel, &StaticOptions::default()).unwrap();
        assert_eq!(d.intervals.len(), 3, "{:?}", d.intervals);
        let spans: Vec<(f64, f64)> = d.intervals.iter().map(|i| (i.t_start_s, i.t_end_s)).collect();
        for ((a, b), (ea, eb)) in spans.iter().zip([(0.0, 10.0), (15.0, 25.0), (27.0, 29.99)]) {
            assert!((a - ea).abs() < 0.7 && (b - eb).abs() < 0.7, "{spans:?}");
        }
        assert!((d.intervals[1].mean[0] - 9.8).abs() < 0.01);
    }

    #[test]
    fn labelled_runs_become_intervals() {
        let t: Vec<f64> = (0..7).map(|i| i as f64).collect();
        let a = [
            vec![1.0; 7],
            vec![0.0; 7],
            vec![2.0, 2.0, 5.0, 5.0, 5.0, 7.0, 7.0],
        ];
        let labels: Vec<String> = ["p", "p", "rot", "rot", "rot", "a", "a"]
            .map(String::from)
            .to_vec();
        let iv = labelled_intervals(&t, &a, &labels, |l| !l.contains("rot"));
        assert_eq!(iv.len(), 2);
        assert_eq!((iv[1].start, iv[1].end, iv[1].mean[2]), (5, 7, 7.0));
    }

    #[test]
    fn rejects_bad_options_and_short_input() {
        let t = [0.0, 0.01, 0.02];
        let a = [vec![0.0; 3], vec![0.0; 3], vec![1.0; 3]];
        let bad = StaticOptions {
            window_s: -1.0,
            ..Default::default()
        };
        assert!(matches!(
            detect_static(&t, &a, &bad),
            Err(StaticDetectError::BadOption { name: "window_s", .. })
        ));
        assert!(matches!(
            detect_static(&t, &a, &StaticOptions::default()),
            Err(StaticDetectError::TooShort { .. })
        ));
    }
}
