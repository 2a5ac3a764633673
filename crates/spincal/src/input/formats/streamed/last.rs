//! The last pass: gaps (against the median interval and the clock's tick) and flat tops (against
//! each axis's extremes).

use super::reading::Reading;
use super::Declined;
use crate::input::inspect::{
    gyro_rails, Gap, GyroSaturation, Saturation, GAP_FACTOR, LISTED_GAPS, RAIL_SAMPLES, RANGE_SHARE,
};

/// One axis's saturated samples, as [`inspect`] finds them: beyond [`RANGE_SHARE`] of a known
/// range, else in runs of [`RAIL_SAMPLES`] or more equal values at the axis's extreme.
#[derive(Default)]
pub(super) struct Tops {
    pub(super) samples: usize,
    /// Line and magnitude of the first saturated sample.
    pub(super) first: Option<(usize, f64)>,
    /// The current run of equal values: its value, first line and length.
    pub(super) run: Option<(f64, usize, usize)>,
}

impl Tops {
    pub(super) fn push(&mut self, line: usize, v: f64, min: f64, max: f64, range: Option<f64>) {
        if let Some(range) = range {
            if v.abs() >= RANGE_SHARE * range {
                self.samples += 1;
                self.first.get_or_insert((line, v.abs()));
            }
            return;
        }
        match &mut self.run {
            Some((value, _, length)) if *value == v => *length += 1,
            _ => {
                self.end(min, max);
                self.run = Some((v, line, 1));
            }
        }
    }

    /// Ends the current run.
    pub(super) fn end(&mut self, min: f64, max: f64) {
        if let Some((v, line, length)) = self.run.take() {
            if (v == max || v == min) && length >= RAIL_SAMPLES {
                self.samples += length;
                self.first.get_or_insert((line, v.abs()));
            }
        }
    }
}

/// What the last pass found: the first gaps, their count, and each axis's flat tops.
pub(super) struct LastPass {
    pub(super) gaps: Vec<Gap>,
    pub(super) gap_count: usize,
    pub(super) tops: [Tops; 3],
    /// The gyro's flat tops at its rails ([`gyro_rails`]).
    pub(super) gyro_tops: [Tops; 3],
}

/// Reads the file once more for gaps (steps over the threshold that the median interval `dt` and
/// the clock's tick `quantum` set) and flat tops at each axis's `extremes` (min, max).
pub(super) fn last_pass(
    src: &Reading,
    quantum: f64,
    dt: f64,
    extremes: ([f64; 3], [f64; 3]),
    gyro_extremes: ([f64; 3], [f64; 3]),
    range_mps2: Option<f64>,
) -> Result<LastPass, Declined> {
    let rails: [(f64, f64); 3] = std::array::from_fn(|a| gyro_rails(gyro_extremes.0[a], gyro_extremes.1[a]));
    let mut gyro_tops: [Tops; 3] = std::array::from_fn(|_| Tops::default());
    let gap_threshold = if (quantum / dt - 1.0).abs() > 0.1 {
        (GAP_FACTOR * dt).max(dt + quantum)
    } else {
        GAP_FACTOR * dt
    };
    let (min, max) = extremes;
    let mut gaps = Vec::new();
    let mut gap_count = 0;
    let mut last = (f64::NAN, 0usize);
    let mut tops: [Tops; 3] = std::array::from_fn(|_| Tops::default());
    src.each(&mut None, |i, s| {
        if i > 0 {
            let length_s = s.t - last.0;
            if length_s > gap_threshold {
                gap_count += 1;
                if gaps.len() < LISTED_GAPS {
                    gaps.push(Gap {
                        line: s.line,
                        index: i,
                        start_s: last.0,
                        length_s,
                    });
                }
            }
        }
        last = (s.t, s.line);
        for a in 0..3 {
            if min[a] != max[a] {
                tops[a].push(s.line, s.accel[a], min[a], max[a], range_mps2);
            }
        }
        if let Some(g) = s.gyro {
            for a in 0..3 {
                gyro_tops[a].push(s.line, g[a], rails[a].0, rails[a].1, None);
            }
        }
    })?;
    for a in 0..3 {
        gyro_tops[a].end(rails[a].0, rails[a].1);
    }
    Ok(LastPass {
        gaps,
        gap_count,
        tops,
        gyro_tops,
    })
}

/// Each gyro axis's saturation from its flat tops (ended by [`last_pass`]).
pub(super) fn gyro_findings(tops: &[Tops; 3]) -> Vec<GyroSaturation> {
    (0..3)
        .filter_map(|a| {
            let (first_line, limit) = tops[a].first?;
            Some(GyroSaturation {
                axis: ['x', 'y', 'z'][a],
                samples: tops[a].samples,
                first_line,
                limit_dps: limit.to_degrees(),
            })
        })
        .collect()
}

/// Each axis's saturation (from its flat tops) or its being constant, over `n` samples.
pub(super) fn axis_findings(
    tops: &mut [Tops; 3],
    extremes: ([f64; 3], [f64; 3]),
    n: usize,
    range_mps2: Option<f64>,
) -> (Vec<Saturation>, Vec<char>) {
    let (min, max) = extremes;
    let mut saturation = Vec::new();
    let mut constant_axes = Vec::new();
    for a in 0..3 {
        let name = ['x', 'y', 'z'][a];
        if n == 0 {
            continue;
        }
        if min[a] == max[a] {
            constant_axes.push(name);
            continue;
        }
        tops[a].end(min[a], max[a]);
        if let Some((first_line, limit)) = tops[a].first {
            saturation.push(Saturation {
                axis: name,
                samples: tops[a].samples,
                first_line,
                limit_mps2: range_mps2.unwrap_or(limit),
            });
        }
    }
    (saturation, constant_axes)
}
