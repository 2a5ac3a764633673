//! A turntable recording cut at its logging gaps into segments, each with its own phase (issue 47
//! item 3): across a gap the platter's angle is not known, because a record player's speed
//! wanders by a few tenths of a percent and nothing is recorded to follow it.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::input::recording::Recording;

/// A step between samples longer than this many revolutions splits the recording. A speed that
/// wanders by 0.3 % (a belt-drive record player's drift) loses 2π·2·0.003 ≈ 0.04 rad of phase
/// over two revolutions, below what a tilt of a few milliradians lets a fit resolve; over a
/// longer gap the loss grows past it.
pub const GAP_SPLIT_REVOLUTIONS: f64 = 2.0;
/// A segment shorter than this many revolutions (or than [`MIN_SEGMENT_SAMPLES`]) cannot fix its
/// own phase and speed: its samples are left out of the fit.
pub const MIN_SEGMENT_REVOLUTIONS: f64 = 5.0;
/// The fewest samples a segment may have.
pub const MIN_SEGMENT_SAMPLES: usize = 100;

/// One gap that split a recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// The last sample before the gap (index into the recording) and its source line.
    pub after_sample: usize,
    pub line: usize,
    /// Time of that sample, s, and the gap's length, s.
    pub at_s: f64,
    pub length_s: f64,
}

/// A recording's segments between its gaps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhaseSegments {
    /// The recording (its source name).
    pub recording: String,
    /// Samples `[start, end)` of each segment long enough to fit, in time order.
    pub ranges: Vec<Range<usize>>,
    pub gaps: Vec<Gap>,
    /// Samples in segments too short to fit, left out.
    pub left_out: usize,
}

impl PhaseSegments {
    /// Whether the recording is cut (or loses samples) at all.
    pub fn is_split(&self) -> bool {
        !self.gaps.is_empty()
    }

    /// One sentence for the terminal and the report, when the recording was cut.
    pub fn sentence(&self) -> Option<String> {
        if !self.is_split() {
            return None;
        }
        let gaps: Vec<String> = self
            .gaps
            .iter()
            .map(|g| format!("{:.1} s after line {}", g.length_s, g.line))
            .collect();
        let mut out = format!(
            "{}: cut at {} gap{} ({}) into {} segment{}, each with its own phase and speed (the platter's angle across a gap is not known)",
            self.recording,
            self.gaps.len(),
            if self.gaps.len() == 1 { "" } else { "s" },
            gaps.join(", "),
            self.ranges.len(),
            if self.ranges.len() == 1 { "" } else { "s" },
        );
        if self.left_out > 0 {
            out.push_str(&format!(
                "; {} samples in segments shorter than {MIN_SEGMENT_REVOLUTIONS} revolutions are left out",
                self.left_out
            ));
        }
        out.push('.');
        Some(out)
    }
}

/// Cuts `recording` at every step longer than [`GAP_SPLIT_REVOLUTIONS`] revolutions at
/// `omega_radps`, keeping the segments of at least [`MIN_SEGMENT_REVOLUTIONS`] revolutions and
/// [`MIN_SEGMENT_SAMPLES`] samples. A recording without such a gap is one segment, whatever its
/// length.
pub fn phase_segments(recording: &Recording, omega_radps: f64) -> PhaseSegments {
    let time = &recording.time_s;
    let n = time.len();
    let revolution_s = std::f64::consts::TAU / omega_radps.abs().max(1e-9);
    let mut gaps = Vec::new();
    let mut cuts = vec![0];
    for i in 1..n {
        let step = time[i] - time[i - 1];
        if step > GAP_SPLIT_REVOLUTIONS * revolution_s {
            gaps.push(Gap {
                after_sample: i - 1,
                line: recording.location(i - 1).line,
                at_s: time[i - 1],
                length_s: step,
            });
            cuts.push(i);
        }
    }
    cuts.push(n);
    if gaps.is_empty() {
        let whole: Range<usize> = 0..n;
        return PhaseSegments {
            recording: recording.source.name.clone(),
            ranges: vec![whole],
            gaps,
            left_out: 0,
        };
    }
    let (mut ranges, mut left_out) = (Vec::new(), 0);
    for pair in cuts.windows(2) {
        let range = pair[0]..pair[1];
        let span = time[range.end - 1] - time[range.start];
        if range.len() >= MIN_SEGMENT_SAMPLES && span >= MIN_SEGMENT_REVOLUTIONS * revolution_s {
            ranges.push(range);
        } else {
            left_out += range.len();
        }
    }
    PhaseSegments {
        recording: recording.source.name.clone(),
        ranges,
        gaps,
        left_out,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recording(time_s: Vec<f64>) -> Recording {
        let n = time_s.len();
        Recording {
            time_s,
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![9.81; n]],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        }
    }

    #[test]
    fn a_gap_longer_than_two_revolutions_cuts_and_a_short_one_does_not() {
        let omega = 45.0 * std::f64::consts::TAU / 60.0; // 1.333 s per revolution
                                                         // 60 s at 100 Hz, 2 s missing at 20 s (1.5 revolutions), 300 s missing at 40 s.
        let time: Vec<f64> = (0..6000)
            .map(|i| i as f64 * 0.01)
            .filter(|t| !(20.0..22.0).contains(t))
            .map(|t| if t >= 40.0 { t + 300.0 } else { t })
            .collect();
        let cut_at = time.iter().position(|&t| t >= 340.0).unwrap();
        let segments = phase_segments(&recording(time.clone()), omega);
        assert_eq!(segments.ranges, vec![0..cut_at, cut_at..time.len()]);
        assert_eq!(segments.gaps.len(), 1);
        assert_eq!(segments.gaps[0].after_sample, cut_at - 1);
        assert!((segments.gaps[0].length_s - 300.01).abs() < 1e-6);
        assert_eq!(segments.left_out, 0);
        let sentence = segments.sentence().unwrap();
        assert!(sentence.contains("300.0 s after line"), "{sentence}");
    }

    #[test]
    fn a_segment_too_short_to_fit_is_left_out_and_an_unbroken_recording_is_whole() {
        let omega = 33.333 * std::f64::consts::TAU / 60.0; // 1.8 s per revolution
                                                           // 30 s, a 10 s gap, 3 s (under five revolutions), a 10 s gap, 30 s.
        let mut time: Vec<f64> = (0..3000).map(|i| i as f64 * 0.01).collect();
        time.extend((0..300).map(|i| 40.0 + i as f64 * 0.01));
        time.extend((0..3000).map(|i| 53.0 + i as f64 * 0.01));
        let segments = phase_segments(&recording(time.clone()), omega);
        assert_eq!(segments.ranges, vec![0..3000, 3300..6300]);
        assert_eq!(segments.gaps.len(), 2);
        assert_eq!(segments.left_out, 300);
        assert!(segments.sentence().unwrap().contains("300 samples"));
        let whole = phase_segments(&recording((0..500).map(|i| i as f64 * 0.01).collect()), omega);
        assert_eq!(whole.ranges, vec![0..500]);
        assert!(!whole.is_split() && whole.sentence().is_none());
    }
}
