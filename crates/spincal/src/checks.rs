//! Checks of a recording before fitting: gaps, saturation, length.

use serde::{Deserialize, Serialize};

use crate::recording::{median_interval, Recording, STANDARD_GRAVITY};

/// A gap: a sample interval longer than 1.5 times the median.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// 1-based source line (or sample number) of the sample after the gap.
    pub line: usize,
    pub start_s: f64,
    pub length_s: f64,
}

/// Samples at the sensor's range limit on one axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Saturation {
    pub axis: char,
    pub samples: usize,
    /// Line (or sample number) of the first saturated sample.
    pub first_line: usize,
    /// The limit that was hit, m/s².
    pub limit_mps2: f64,
}

/// What [`inspect`] found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Inspection {
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
    pub gaps: Vec<Gap>,
    pub saturation: Vec<Saturation>,
}

impl Inspection {
    /// One line per finding, for people.
    pub fn warnings(&self, file: &str) -> Vec<String> {
        let mut out = Vec::new();
        if !self.gaps.is_empty() {
            let longest = self.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max);
            let first = &self.gaps[0];
            out.push(format!(
                "{file}:{}: {} gap(s) in time, the first of {:.4} s at t = {:.4} s, the longest {:.4} s",
                first.line,
                self.gaps.len(),
                first.length_s,
                first.start_s,
                longest
            ));
        }
        for s in &self.saturation {
            out.push(format!(
                "{file}:{}: {} sample(s) of a{} at the range limit {:.4} g (saturated)",
                s.first_line,
                s.samples,
                s.axis,
                s.limit_mps2 / STANDARD_GRAVITY
            ));
        }
        out
    }
}

/// Finds gaps and saturated samples.
///
/// With `range_mps2` given, a sample at or beyond 99.9 % of it is saturated; without, an axis is
/// saturated where three or more successive samples sit exactly at its extreme value (a flat top).
pub fn inspect(recording: &Recording, range_mps2: Option<f64>) -> Inspection {
    let dt = median_interval(&recording.time_s);
    let gaps = recording
        .time_s
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] - w[0] > 1.5 * dt)
        .map(|(i, w)| Gap {
            line: recording.location(i + 1).line,
            start_s: w[0],
            length_s: w[1] - w[0],
        })
        .collect();
    let mut saturation = Vec::new();
    for (k, axis) in recording.accel_mps2.iter().enumerate() {
        let name = ['x', 'y', 'z'][k];
        let hits: Vec<(usize, f64)> = match range_mps2 {
            Some(range) => axis
                .iter()
                .enumerate()
                .filter(|(_, v)| v.abs() >= 0.999 * range)
                .map(|(i, v)| (i, v.abs()))
                .collect(),
            None => flat_tops(axis),
        };
        if let Some(&(first, limit)) = hits.first() {
            saturation.push(Saturation {
                axis: name,
                samples: hits.len(),
                first_line: recording.location(first).line,
                limit_mps2: range_mps2.unwrap_or(limit),
            });
        }
    }
    Inspection {
        samples: recording.len(),
        duration_s: recording.duration_s(),
        sample_rate_hz: 1.0 / dt,
        gaps,
        saturation,
    }
}

/// Samples inside runs of ≥ 3 equal values at the axis maximum or minimum.
fn flat_tops(axis: &[f64]) -> Vec<(usize, f64)> {
    let max = axis.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = axis.iter().copied().fold(f64::INFINITY, f64::min);
    let mut hits = Vec::new();
    let mut i = 0;
    while i < axis.len() {
        let v = axis[i];
        let mut j = i;
        while j < axis.len() && axis[j] == v {
            j += 1;
        }
        if (v == max || v == min) && j - i >= 3 && max > min {
            hits.extend((i..j).map(|k| (k, v.abs())));
        }
        i = j;
    }
    hits.sort_unstable_by_key(|h| h.0);
    hits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::ColumnMap;

    fn read(text: &str) -> Recording {
        Recording::read_csv(text.as_bytes(), "rec.csv", &ColumnMap::default()).unwrap()
    }

    #[test]
    fn reports_gaps_with_their_line() {
        let r = read("t,ax,ay,az\n0,0,0,1\n0.01,0,0,1\n0.02,0,0,1\n0.05,0,0,1\n0.06,0,0,1\n");
        let found = inspect(&r, None);
        assert_eq!(found.gaps.len(), 1);
        assert_eq!(
            found.warnings("rec.csv"),
            ["rec.csv:5: 1 gap(s) in time, the first of 0.0300 s at t = 0.0200 s, the longest 0.0300 s"]
        );
    }

    #[test]
    fn reports_saturation_by_range_and_by_flat_top() {
        let g = STANDARD_GRAVITY;
        let text = format!(
            "t,ax_g,ay_g,az_g\n0,0.1,0,1\n0.01,5,0,1\n0.02,5,0,1\n0.03,5,0,1\n0.04,0.2,0,{}\n",
            1.0
        );
        let r = read(&text);
        let by_range = inspect(&r, Some(5.0 * g));
        assert_eq!(
            by_range.warnings("rec.csv"),
            ["rec.csv:3: 3 sample(s) of ax at the range limit 5.0000 g (saturated)"]
        );
        let by_shape = inspect(&r, None);
        assert_eq!(by_shape.saturation.len(), 1, "{by_shape:?}");
        assert_eq!(by_shape.saturation[0].samples, 3);
    }
}
