//! What the joint fit takes: turntable runs and still poses, and the noise figures read from them.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::{Deserialize, Serialize};

use super::start::Demodulated;
use crate::campaign::file::TurntableEntry;

/// One turntable run, ready for the fit. Made by [`RunInput::new`]; its readings are not edited
/// afterwards (a corrected copy is [`RunInput::with_readings`]), because every fit of the run
/// shares the demodulation of those readings.
#[derive(Debug, Clone)]
pub struct RunInput {
    pub name: String,
    /// Seconds; any origin.
    pub time_s: Vec<f64>,
    pub accel_mps2: [Vec<f64>; 3],
    /// Samples the fit uses (false: saturated or otherwise unusable).
    pub keep: Vec<bool>,
    pub entry: TurntableEntry,
    /// Gyro x, y, z, rad/s, when recorded (`campaign::gyro` calibrates it; this fit ignores it).
    pub gyro_radps: Option<[Vec<f64>; 3]>,
    /// The power-on session whose bias offset the run shares (its offset is tied to that
    /// session's), when the campaign names one; `None`: an offset of its own.
    pub session: Option<usize>,
    /// The demodulation behind the run's starting geometry, found by its first fit (a campaign's
    /// held-out folds fit each run many times).
    demodulated: std::sync::OnceLock<Demodulated>,
}

impl RunInput {
    pub fn new(
        name: String,
        time_s: Vec<f64>,
        accel_mps2: [Vec<f64>; 3],
        keep: Vec<bool>,
        entry: TurntableEntry,
        gyro_radps: Option<[Vec<f64>; 3]>,
    ) -> RunInput {
        RunInput {
            name,
            time_s,
            accel_mps2,
            keep,
            entry,
            gyro_radps,
            session: None,
            demodulated: std::sync::OnceLock::new(),
        }
    }

    /// The same run, in power-on session `session`.
    pub fn in_session(mut self, session: Option<usize>) -> RunInput {
        self.session = session;
        self
    }

    /// The same run with other readings and samples kept (a corrector's output, say).
    pub fn with_readings(&self, accel_mps2: [Vec<f64>; 3], keep: Vec<bool>) -> RunInput {
        RunInput::new(
            self.name.clone(),
            self.time_s.clone(),
            accel_mps2,
            keep,
            self.entry.clone(),
            self.gyro_radps.clone(),
        )
        .in_session(self.session)
    }

    /// The run's demodulation in the mounting frame of its entry, found once.
    pub(super) fn demodulated(&self) -> Demodulated {
        let key = (self.entry.out, self.entry.up, self.entry.rpm.to_bits());
        match self.demodulated.get() {
            Some(found) if found.key == key => *found,
            Some(_) => Demodulated::of(self, key),
            None => *self.demodulated.get_or_init(|| Demodulated::of(self, key)),
        }
    }
}

/// One still pose, ready for the fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoseInput {
    pub name: String,
    pub mean_mps2: [f64; 3],
    /// Standard error of the mean per axis, m/s².
    pub sigma_mean_mps2: [f64; 3],
    pub samples: usize,
    /// Middle of the pose on its recording's clock, s.
    pub time_s: f64,
    /// Its power-on session (0, 1, …): a still recording's own, or the one the campaign names;
    /// poses of one session share a bias offset.
    pub session: usize,
    /// The gyro's mean over the pose and its standard error, rad/s, when recorded.
    #[serde(default)]
    pub gyro_mean_radps: Option<[f64; 3]>,
    #[serde(default)]
    pub gyro_sigma_mean_radps: Option<[f64; 3]>,
    /// How the reading moved within the pose, when its samples were seen: the bias's random walk
    /// between poses is measured from it.
    #[serde(default)]
    pub wander: Option<PoseWander>,
}

/// Within one still pose: its length, the second half's mean minus the first's, and the white
/// noise per sample (from first differences).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWander {
    pub duration_s: f64,
    pub half_difference_mps2: [f64; 3],
    pub noise_sd_mps2: [f64; 3],
    pub samples: usize,
}

/// The bias's random-walk rate, (m/s²)²/s, from the poses' half-to-half differences: for a random
/// walk of rate D the halves' means of a window of length 2h differ with variance 2Dh/3 (twice the
/// Allan variance at h), and white noise adds 4σ²/n. Pooled over the three axes (one die's bias
/// wanders alike on each; 3 differences per pose instead of 1). `None` from fewer than three poses
/// with their samples.
pub fn bias_random_walk(poses: &[PoseInput]) -> Option<f64> {
    let seen: Vec<&PoseWander> = poses.iter().filter_map(|p| p.wander.as_ref()).collect();
    if seen.len() < 3 {
        return None;
    }
    // Each pose adds 2h/3 per axis with h half its length: its whole length over the three axes.
    let weight: f64 = seen.iter().map(|w| w.duration_s).sum();
    if !weight.is_finite() || weight <= 0.0 {
        return None;
    }
    let excess: f64 = seen
        .iter()
        .flat_map(|w| {
            (0..3).map(|k| {
                w.half_difference_mps2[k].powi(2) - 4.0 * w.noise_sd_mps2[k].powi(2) / w.samples.max(1) as f64
            })
        })
        .sum();
    Some((excess / weight).max(0.0))
}

/// Noise per axis from first differences (white noise survives differencing; slow motion does
/// not), m/s².
pub fn difference_noise(accel: &[Vec<f64>; 3], keep: &[bool]) -> [f64; 3] {
    std::array::from_fn(|k| {
        let a = &accel[k];
        let (mut sum, mut n) = (0.0f64, 0.0f64);
        for s in 1..a.len() {
            if keep[s] && keep[s - 1] {
                let d = a[s] - a[s - 1];
                sum += d * d;
                n += 1.0;
            }
        }
        (sum / n.max(1.0) / 2.0).sqrt().max(1e-6)
    })
}
