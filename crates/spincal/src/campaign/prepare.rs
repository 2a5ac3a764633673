//! From a unit's recordings to the joint fit's inputs: turntable runs cut at their logging gaps
//! (saturated samples left out), still recordings cut into poses.

use serde::{Deserialize, Serialize};

use crate::campaign::file::TurntableEntry;
use crate::campaign::joint::{check_placements, PoseInput, PoseWander, RunInput};
use crate::correctors::static_detect::{detect_static, StaticOptions, StillInterval};
use crate::input::inspect::saturated_mask;
use crate::input::recording::Recording;
use crate::turntable::segments::{
    phase_segments, PhaseSegments, MIN_SEGMENT_REVOLUTIONS, MIN_SEGMENT_SAMPLES,
};

/// One recording of the unit, loaded.
#[derive(Debug, Clone)]
pub struct UnitRecording {
    /// The file (or a simulated name).
    pub name: String,
    pub recording: Recording,
    /// `None`: still poses.
    pub turntable: Option<TurntableEntry>,
    /// The true specific force per sample, m/s², when known (simulations).
    pub truth: Option<[Vec<f64>; 3]>,
    /// RMS per axis of the error no corrector can remove, m/s², when known.
    pub floor_mps2: Option<[f64; 3]>,
    /// That error per sample, m/s², when known: the floor of any subset of samples.
    pub random_mps2: Option<[Vec<f64>; 3]>,
    /// The power-on session, when the campaign names it: recordings of one session share one
    /// bias offset.
    pub session: Option<String>,
}

/// Where a pose or a run came from.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Origin {
    /// Index into the unit's recordings.
    pub recording: usize,
    /// Samples `[start, end)` of that recording.
    pub start: usize,
    pub end: usize,
}

/// The joint fit's inputs and where they came from.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub runs: Vec<RunInput>,
    /// Per run, its recording and samples (a run cut at a logging gap is several runs).
    pub run_origin: Vec<Origin>,
    pub poses: Vec<PoseInput>,
    pub pose_origin: Vec<Origin>,
    /// The runs cut at logging gaps, with where and why.
    pub split_runs: Vec<PhaseSegments>,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PrepareError {
    #[error("{name}: no still interval of at least {min_s} s found (a still recording should hold each pose a few seconds)")]
    NoPose { name: String, min_s: f64 },
    #[error("{name}: {samples} samples; a recording needs at least {needed}")]
    TooShort {
        name: String,
        samples: usize,
        needed: usize,
    },
    #[error("{name}: its {gaps} logging gaps leave no stretch of {MIN_SEGMENT_REVOLUTIONS} revolutions and {MIN_SEGMENT_SAMPLES} samples, so no part of it can be fitted (the platter's angle across a gap is not known); record the run without gaps")]
    NoSegment { name: String, gaps: usize },
    // Boxed: its names would make every campaign error large.
    #[error(transparent)]
    Placement(Box<crate::campaign::joint::PlacementError>),
}

/// Samples at each end of a still interval left out (the hand may still be settling).
const EDGE_FRACTION: f64 = 0.1;
/// Blocks a pose is cut into to estimate the standard error of its mean.
const POSE_BLOCKS: usize = 8;

/// Still intervals of a still recording: the detector's, or the whole recording when it is one
/// short pose the detector cannot set a threshold on. A long file is cut as `spincal static` cuts
/// it (`StaticOptions::default`); a file of one short pose with everything scaled to its length.
pub(crate) fn still_intervals(rec: &Recording, name: &str) -> Result<Vec<StillInterval>, PrepareError> {
    let defaults = StaticOptions::default();
    let options = StaticOptions {
        init_s: (0.3 * rec.duration_s()).clamp(0.5, defaults.init_s),
        window_s: (0.1 * rec.duration_s()).clamp(0.2, defaults.window_s),
        min_interval_s: (0.4 * rec.duration_s()).clamp(0.5, defaults.min_interval_s),
        ..defaults
    };
    let found = detect_static(&rec.time_s, &rec.accel_mps2, &options)
        .map(|d| d.intervals)
        .unwrap_or_default();
    if !found.is_empty() {
        return Ok(found);
    }
    Err(PrepareError::NoPose {
        name: name.to_string(),
        min_s: options.min_interval_s,
    })
}

/// The samples `[start, end)` of a still interval that make its pose (the edges left out).
pub(crate) fn pose_samples(interval: &StillInterval) -> (usize, usize) {
    let edge = ((interval.len() as f64) * EDGE_FRACTION) as usize;
    (interval.start + edge, interval.end - edge)
}

/// Mean per axis over `[start, end)` and its standard error: from block means (coloured noise
/// widens it), never below the white-noise value from first differences, nor below `floor`.
fn mean_and_error(axes: &[Vec<f64>; 3], start: usize, end: usize, floor: f64) -> ([f64; 3], [f64; 3]) {
    let n = end - start;
    let mut mean = [0.0; 3];
    let mut sigma = [0.0; 3];
    for k in 0..3 {
        let xs = &axes[k][start..end];
        mean[k] = xs.iter().sum::<f64>() / n as f64;
        let block = (n / POSE_BLOCKS).max(1);
        let means: Vec<f64> = xs
            .chunks(block)
            .filter(|c| c.len() == block)
            .map(|c| c.iter().sum::<f64>() / block as f64)
            .collect();
        let m = means.len().max(2) as f64;
        let between = means.iter().map(|v| (v - mean[k]).powi(2)).sum::<f64>() / (m - 1.0) / m;
        let diff = difference_variance(xs);
        sigma[k] = between.sqrt().max((diff / n as f64).sqrt()).max(floor);
    }
    (mean, sigma)
}

/// White-noise variance per sample from first differences (a slow drift hardly moves it).
fn difference_variance(xs: &[f64]) -> f64 {
    xs.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (xs.len().max(2) - 1) as f64)
}

/// The reading's movement within `[start, end)`: halves' means and first-difference noise.
fn wander(rec: &Recording, start: usize, end: usize) -> PoseWander {
    let n = end - start;
    let half = start + n / 2;
    let mean = |xs: &[f64]| xs.iter().sum::<f64>() / xs.len().max(1) as f64;
    PoseWander {
        duration_s: rec.time_s[end - 1] - rec.time_s[start],
        half_difference_mps2: std::array::from_fn(|k| {
            let a = &rec.accel_mps2[k];
            mean(&a[half..end]) - mean(&a[start..half])
        }),
        noise_sd_mps2: std::array::from_fn(|k| difference_variance(&rec.accel_mps2[k][start..end]).sqrt()),
        samples: n,
    }
}

fn pose_input(rec: &Recording, name: String, start: usize, end: usize, session: usize) -> PoseInput {
    let (mean, sigma) = mean_and_error(&rec.accel_mps2, start, end, 1e-6);
    let gyro = rec
        .gyro_radps
        .as_ref()
        .map(|g| mean_and_error(g, start, end, 1e-9));
    PoseInput {
        name,
        mean_mps2: mean,
        sigma_mean_mps2: sigma,
        samples: end - start,
        time_s: 0.5 * (rec.time_s[start] + rec.time_s[end - 1]),
        session,
        gyro_mean_radps: gyro.map(|g| g.0),
        gyro_sigma_mean_radps: gyro.map(|g| g.1),
        wander: Some(wander(rec, start, end)),
    }
}

/// Each recording's power-on session: recordings with the same `session` label share one; a
/// still recording without a label is a session of its own; a run without one has `None` (an
/// offset of its own).
pub(crate) fn session_indices(recordings: &[UnitRecording]) -> Vec<Option<usize>> {
    let mut labels: Vec<&str> = Vec::new();
    let mut next = 0;
    recordings
        .iter()
        .map(|unit| match (&unit.session, &unit.turntable) {
            (Some(label), _) => Some(match labels.iter().position(|l| l == label) {
                Some(known) => known,
                None => {
                    labels.push(label);
                    next += 1;
                    next - 1
                }
            }),
            (None, None) => {
                labels.push("");
                next += 1;
                Some(next - 1)
            }
            (None, Some(_)) => None,
        })
        .collect()
}

/// Cuts the unit's recordings into the joint fit's runs and poses.
pub fn prepare(recordings: &[UnitRecording]) -> Result<Prepared, PrepareError> {
    let mut out = Prepared {
        runs: Vec::new(),
        run_origin: Vec::new(),
        poses: Vec::new(),
        pose_origin: Vec::new(),
        split_runs: Vec::new(),
    };
    let sessions = session_indices(recordings);
    for (index, unit) in recordings.iter().enumerate() {
        let rec = &unit.recording;
        match &unit.turntable {
            Some(entry) => {
                if rec.len() < 100 {
                    return Err(PrepareError::TooShort {
                        name: unit.name.clone(),
                        samples: rec.len(),
                        needed: 100,
                    });
                }
                let omega = entry.rpm * std::f64::consts::TAU / 60.0;
                let segments = phase_segments(rec, omega);
                if segments.ranges.is_empty() {
                    return Err(PrepareError::NoSegment {
                        name: unit.name.clone(),
                        gaps: segments.gaps.len(),
                    });
                }
                let saturated = saturated_mask(rec, None);
                let several = segments.ranges.len() > 1;
                for (k, range) in segments.ranges.iter().enumerate() {
                    let (name, entry) = if several {
                        // The segments share the chip's position (one placement), not their phase.
                        let placement = entry.placement.clone().or_else(|| Some(unit.name.clone()));
                        let name = format!(
                            "{} segment {} ({:.1}–{:.1} s)",
                            unit.name,
                            k + 1,
                            rec.time_s[range.start],
                            rec.time_s[range.end - 1]
                        );
                        (
                            name,
                            TurntableEntry {
                                placement,
                                ..entry.clone()
                            },
                        )
                    } else {
                        (unit.name.clone(), entry.clone())
                    };
                    let slice = |v: &[f64]| v[range.clone()].to_vec();
                    out.runs.push(
                        RunInput::new(
                            name,
                            slice(&rec.time_s),
                            std::array::from_fn(|a| slice(&rec.accel_mps2[a])),
                            saturated[range.clone()].iter().map(|s| !s).collect(),
                            entry,
                            rec.gyro_radps
                                .as_ref()
                                .map(|g| std::array::from_fn(|a| slice(&g[a]))),
                        )
                        .in_session(sessions[index]),
                    );
                    out.run_origin.push(Origin {
                        recording: index,
                        start: range.start,
                        end: range.end,
                    });
                }
                if segments.is_split() {
                    out.split_runs.push(PhaseSegments {
                        recording: unit.name.clone(),
                        ..segments
                    });
                }
            }
            None => {
                if rec.len() < 10 {
                    return Err(PrepareError::TooShort {
                        name: unit.name.clone(),
                        samples: rec.len(),
                        needed: 10,
                    });
                }
                let intervals = still_intervals(rec, &unit.name)?;
                let session = sessions[index].unwrap_or_default();
                let several = intervals.len() > 1;
                for (k, interval) in intervals.iter().enumerate() {
                    let (start, end) = pose_samples(interval);
                    let name = if several {
                        format!(
                            "{} pose {} ({:.1}–{:.1} s)",
                            unit.name,
                            k + 1,
                            interval.t_start_s,
                            interval.t_end_s
                        )
                    } else {
                        unit.name.clone()
                    };
                    out.poses.push(pose_input(rec, name, start, end, session));
                    out.pose_origin.push(Origin {
                        recording: index,
                        start,
                        end,
                    });
                }
            }
        }
    }
    let mut pose_sessions: Vec<usize> = out.poses.iter().map(|p| p.session).collect();
    pose_sessions.dedup();
    check_placements(&out.runs, &pose_sessions).map_err(|e| PrepareError::Placement(Box::new(e)))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::joint::bias_random_walk;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// The random-walk rate measured within still poses recovers the simulated one, with white
    /// noise ten times the walk's step on top.
    #[test]
    fn the_bias_random_walk_is_recovered_from_the_poses() {
        let (rate_hz, samples, noise): (f64, usize, f64) = (100.0, 400, 0.02);
        for (seed, d) in [(1u64, 1e-5f64), (2, 3e-6), (3, 0.0)] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let step = (d / rate_hz).sqrt();
            let poses: Vec<PoseInput> = (0..120)
                .map(|p| {
                    let time_s: Vec<f64> = (0..samples).map(|s| s as f64 / rate_hz).collect();
                    let mut walk = [0.0f64; 3];
                    let mut accel: [Vec<f64>; 3] = Default::default();
                    for _ in 0..samples {
                        for k in 0..3 {
                            let z: f64 = StandardNormal.sample(&mut rng);
                            walk[k] += step * z;
                            let e: f64 = StandardNormal.sample(&mut rng);
                            accel[k].push(9.8 * f64::from(k == 2) + walk[k] + noise * e);
                        }
                    }
                    let rec = Recording {
                        time_s,
                        accel_mps2: accel,
                        gyro_radps: None,
                        temperature_c: None,
                        source: Default::default(),
                    };
                    pose_input(&rec, format!("pose {p}"), 0, samples, 0)
                })
                .collect();
            let estimate = bias_random_walk(&poses).unwrap();
            // 360 differences: about ±10 % (one standard error) on the walk's share.
            let tolerance = 0.3 * d + 2e-7;
            assert!((estimate - d).abs() < tolerance, "seed {seed}: {estimate} vs {d}");
        }
    }
}
