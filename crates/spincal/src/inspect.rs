//! A quick look at a recording: rate, gaps, saturation.

// Axis loops index several parallel per-axis arrays at once; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use serde::Serialize;

use crate::recording::{median_interval, Recording};

/// A gap: two consecutive samples further apart than 1.5 nominal intervals.
#[derive(Debug, Clone, Serialize)]
pub struct Gap {
    /// Index of the sample after the gap.
    pub index: usize,
    pub t_s: f64,
    pub length_s: f64,
}

/// Samples sitting at an axis's extreme value (a clipped sensor repeats its rail value).
#[derive(Debug, Clone, Serialize)]
pub struct Saturation {
    pub axis: char,
    pub value: f64,
    pub samples: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct Inspection {
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
    pub gaps: Vec<Gap>,
    /// Total number of gaps (only the first 20 are listed).
    pub gap_count: usize,
    pub saturation: Vec<Saturation>,
    pub accel_min: [f64; 3],
    pub accel_max: [f64; 3],
    pub has_gyro: bool,
}

/// Least number of samples at exactly the extreme value for it to count as a rail.
const RAIL_SAMPLES: usize = 3;

/// Summarises a recording.
pub fn inspect(recording: &Recording) -> Inspection {
    let t = &recording.time_s;
    let dt = median_interval(t);
    let mut gaps = Vec::new();
    let mut gap_count = 0;
    for i in 1..t.len() {
        let d = t[i] - t[i - 1];
        if d > 1.5 * dt {
            gap_count += 1;
            if gaps.len() < 20 {
                gaps.push(Gap {
                    index: i,
                    t_s: t[i],
                    length_s: d,
                });
            }
        }
    }
    let mut saturation = Vec::new();
    let mut accel_min = [f64::NAN; 3];
    let mut accel_max = [f64::NAN; 3];
    for (a, axis) in recording.accel_mps2.iter().enumerate() {
        if axis.is_empty() {
            continue;
        }
        let lo = axis.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = axis.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        accel_min[a] = lo;
        accel_max[a] = hi;
        for value in [lo, hi] {
            let samples = axis.iter().filter(|&&v| v == value).count();
            if samples >= RAIL_SAMPLES {
                saturation.push(Saturation {
                    axis: ['x', 'y', 'z'][a],
                    value,
                    samples,
                });
            }
        }
    }
    Inspection {
        samples: recording.len(),
        duration_s: recording.duration_s(),
        sample_rate_hz: 1.0 / dt,
        gaps,
        gap_count,
        saturation,
        accel_min,
        accel_max,
        has_gyro: recording.gyro_radps.is_some(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::Source;

    #[test]
    fn finds_gaps_and_rails() {
        let time_s = vec![0.0, 0.01, 0.02, 0.05, 0.06, 0.07];
        let x = vec![1.0, 5.0, 5.0, 5.0, 2.0, 0.0];
        let r = Recording {
            time_s,
            accel_mps2: [x, vec![0.0; 6], vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]],
            gyro_radps: None,
            source: Source::default(),
        };
        let i = inspect(&r);
        assert_eq!(i.gap_count, 1);
        assert_eq!(i.gaps[0].index, 3);
        assert!((i.sample_rate_hz - 100.0).abs() < 1e-6);
        // x rails at 5 (3 samples); y is constant 0 (6 samples at both extremes).
        assert_eq!(i.saturation.len(), 3);
        assert_eq!(i.saturation[0].axis, 'x');
        assert_eq!(i.saturation[0].value, 5.0);
    }
}
