//! What is in a recording before anything is fitted: rate, gaps, saturation, constant axes.
//!
//! One module and one set of rules serve both `spincal inspect` and the fit's warnings, so the
//! two never disagree about the same file.

use serde::{Deserialize, Serialize};

use crate::input::recording::{sample_interval, time_quantum, Recording, STANDARD_GRAVITY};

/// A sample interval longer than this many sampling intervals is a gap (or, with a clock coarser
/// than the rate, longer than one interval plus one tick).
pub(crate) const GAP_FACTOR: f64 = 1.5;

/// Least number of successive samples at exactly an axis's extreme for it to count as a rail
/// (a clipped sensor repeats its rail value).
pub(crate) const RAIL_SAMPLES: usize = 3;

/// With a known range, a sample at or beyond this share of it is saturated.
pub(crate) const RANGE_SHARE: f64 = 0.999;

/// A gyro axis's flat top counts as its rail only at or beyond this rate, deg/s: no MEMS gyro's
/// full scale is narrower (the narrowest in common use are ±75–125 °/s), while a still gyro's
/// quantised extremes repeat well below it.
pub(crate) const SMALLEST_GYRO_RANGE_DPS: f64 = 60.0;

/// A turntable run whose gyro is saturated in more than this share of its samples gives the
/// gyro fit too little of the run (and what is left is where the rate dipped): it is refused.
pub const GYRO_SATURATED_SHARE: f64 = 0.5;

/// Gaps listed individually; the rest are only counted.
pub(crate) const LISTED_GAPS: usize = 20;

/// A gap: a sample interval longer than `GAP_FACTOR` times the median.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// 1-based source line (or sample number) of the sample after the gap.
    pub line: usize,
    /// Index of the sample after the gap.
    pub index: usize,
    /// Time of the sample before the gap, s.
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
    /// The limit that was hit, m/s² (the rail value's magnitude when no range was given).
    pub limit_mps2: f64,
}

/// Samples of one gyro axis pinned at its rail: a flat top of 3 or more equal readings at the
/// axis's extreme, at least 60 °/s from zero (no gyro's range is narrower; a whole
/// recording at one such value included: a platter turning faster than the range).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GyroSaturation {
    pub axis: char,
    pub samples: usize,
    /// Line (or sample number) of the first saturated sample.
    pub first_line: usize,
    /// The rail's magnitude, deg/s: the gyro's range is about ± this.
    pub limit_dps: f64,
}

/// What [`inspect`] found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Inspection {
    pub samples: usize,
    pub duration_s: f64,
    pub sample_rate_hz: f64,
    /// The first gaps (at most 20); [`Inspection::gap_count`] counts them all.
    pub gaps: Vec<Gap>,
    pub gap_count: usize,
    /// Samples whose timestamp repeats the previous one (coarse timestamps), and the first line.
    pub repeated_times: usize,
    pub first_repeated_line: Option<usize>,
    /// Steps where time goes backwards (a reset or wrapped timer), and the first line.
    pub backward_steps: usize,
    pub first_backward_line: Option<usize>,
    pub saturation: Vec<Saturation>,
    /// The gyro's saturated axes (empty without a gyro).
    #[serde(default)]
    pub gyro_saturation: Vec<GyroSaturation>,
    /// Axes whose every sample has the same value (a dead or disconnected channel).
    pub constant_axes: Vec<char>,
    pub accel_min_mps2: [f64; 3],
    pub accel_max_mps2: [f64; 3],
    pub has_gyro: bool,
    /// The reported temperature, when the recording has one.
    pub temperature: Option<TemperatureSummary>,
}

/// A temperature column's range and resolution.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TemperatureSummary {
    pub min_c: f64,
    pub max_c: f64,
    /// The smallest step between distinct reported values, °C (1 for a sensor in whole degrees).
    pub resolution_c: f64,
    /// How many distinct values it takes.
    pub distinct_values: usize,
}

/// Range and resolution of a temperature column; `None` when it is empty.
pub(crate) fn temperature_summary(temperature_c: &[f64]) -> Option<TemperatureSummary> {
    let mut values: Vec<f64> = temperature_c.to_vec();
    values.sort_by(f64::total_cmp);
    values.dedup();
    let (&min_c, &max_c) = (values.first()?, values.last()?);
    let resolution_c = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    Some(TemperatureSummary {
        min_c,
        max_c,
        resolution_c: if resolution_c.is_finite() {
            resolution_c
        } else {
            0.0
        },
        distinct_values: values.len(),
    })
}

impl GyroSaturation {
    /// The finding in words, out of `total` samples.
    pub fn describe(&self, total: usize) -> String {
        format!(
            "{} of {} samples ({:.1} %) of g{} pinned at {:.2} °/s: the gyro is saturated (its range is about ±{:.0} °/s; turn slower or set a wider gyro range)",
            self.samples,
            total,
            100.0 * self.samples as f64 / total.max(1) as f64,
            self.axis,
            self.limit_dps,
            self.limit_dps
        )
    }
}

impl Inspection {
    /// Total samples found saturated, over all axes.
    pub fn saturated_samples(&self) -> usize {
        self.saturation.iter().map(|s| s.samples).sum()
    }

    /// One line per finding, for people.
    pub fn warnings(&self, file: &str) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(first) = self.gaps.first() {
            let longest = self.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max);
            out.push(format!(
                "{file}:{}: {} gap(s) in time, the first of {:.4} s at t = {:.4} s, the longest listed {:.4} s",
                first.line, self.gap_count, first.length_s, first.start_s, longest
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
        for s in &self.gyro_saturation {
            out.push(format!("{file}:{}: {}", s.first_line, s.describe(self.samples)));
        }
        if let Some(line) = self.first_repeated_line {
            out.push(format!(
                "{file}:{line}: {} sample(s) repeat the previous timestamp (coarse timestamps); the rate comes from all timestamps",
                self.repeated_times
            ));
        }
        if let Some(line) = self.first_backward_line {
            out.push(format!(
                "{file}:{line}: time goes backwards {} time(s) (a reset or wrapped timer?)",
                self.backward_steps
            ));
        }
        for axis in &self.constant_axes {
            out.push(format!(
                "{file}: a{axis} is constant (a dead or disconnected channel?)"
            ));
        }
        out
    }
}

/// Finds gaps, saturated samples and constant axes.
///
/// With `range_mps2` given, a sample at or beyond `RANGE_SHARE` of it is saturated; without,
/// an axis is saturated where `RAIL_SAMPLES` or more successive samples sit exactly at its
/// extreme value (a flat top). A constant axis is reported as constant, not as saturated.
pub fn inspect(recording: &Recording, range_mps2: Option<f64>) -> Inspection {
    let dt = sample_interval(&recording.time_s);
    let quantum = time_quantum(&recording.time_s);
    // A clock whose tick differs from the interval (finer: a GX1's 1-or-2-tick steps; coarser: a
    // T265's repeated 10 ms stamps at 5 ms) steps by up to one tick more than the interval.
    let gap_threshold = if (quantum / dt - 1.0).abs() > 0.1 {
        (GAP_FACTOR * dt).max(dt + quantum)
    } else {
        GAP_FACTOR * dt
    };
    let mut gaps = Vec::new();
    let mut gap_count = 0;
    let (mut repeated_times, mut first_repeated_line) = (0, None);
    let (mut backward_steps, mut first_backward_line) = (0, None);
    for (i, w) in recording.time_s.windows(2).enumerate() {
        let length_s = w[1] - w[0];
        if length_s == 0.0 {
            repeated_times += 1;
            first_repeated_line.get_or_insert(recording.location(i + 1).line);
        } else if length_s < 0.0 {
            backward_steps += 1;
            first_backward_line.get_or_insert(recording.location(i + 1).line);
        }
        if length_s > gap_threshold {
            gap_count += 1;
            if gaps.len() < LISTED_GAPS {
                gaps.push(Gap {
                    line: recording.location(i + 1).line,
                    index: i + 1,
                    start_s: w[0],
                    length_s,
                });
            }
        }
    }
    let mut saturation = Vec::new();
    let mut constant_axes = Vec::new();
    let mut accel_min_mps2 = [f64::NAN; 3];
    let mut accel_max_mps2 = [f64::NAN; 3];
    for (k, axis) in recording.accel_mps2.iter().enumerate() {
        let name = ['x', 'y', 'z'][k];
        if axis.is_empty() {
            continue;
        }
        let (min, max) = extremes(axis);
        accel_min_mps2[k] = min;
        accel_max_mps2[k] = max;
        if min == max {
            constant_axes.push(name);
            continue;
        }
        let hits = saturated_samples(axis, min, max, range_mps2);
        if let Some(&(first, limit)) = hits.first() {
            saturation.push(Saturation {
                axis: name,
                samples: hits.len(),
                first_line: recording.location(first).line,
                limit_mps2: range_mps2.unwrap_or(limit),
            });
        }
    }
    let gyro_saturation = recording
        .gyro_radps
        .as_ref()
        .map(|gyro| {
            (0..3)
                .filter_map(|k| {
                    let hits = gyro_flat_tops(&gyro[k]);
                    let &(first, limit) = hits.first()?;
                    Some(GyroSaturation {
                        axis: ['x', 'y', 'z'][k],
                        samples: hits.len(),
                        first_line: recording.location(first).line,
                        limit_dps: limit.to_degrees(),
                    })
                })
                .collect()
        })
        .unwrap_or_default();
    Inspection {
        samples: recording.len(),
        duration_s: recording.duration_s(),
        sample_rate_hz: 1.0 / dt,
        gaps,
        gap_count,
        repeated_times,
        first_repeated_line,
        backward_steps,
        first_backward_line,
        saturation,
        gyro_saturation,
        constant_axes,
        accel_min_mps2,
        accel_max_mps2,
        has_gyro: recording.gyro_radps.is_some(),
        temperature: recording.temperature_c.as_deref().and_then(temperature_summary),
    }
}

/// Which samples are saturated on any axis, by the same rule as [`inspect`]; the fit leaves them
/// out (a clipped sample carries the rail, not the motion).
pub(crate) fn saturated_mask(recording: &Recording, range_mps2: Option<f64>) -> Vec<bool> {
    let mut mask = vec![false; recording.len()];
    for axis in &recording.accel_mps2 {
        if axis.is_empty() {
            continue;
        }
        let (min, max) = extremes(axis);
        if min == max {
            continue;
        }
        for (i, _) in saturated_samples(axis, min, max, range_mps2) {
            mask[i] = true;
        }
    }
    mask
}

/// The gyro's extremes as rails: an extreme nearer zero than [`SMALLEST_GYRO_RANGE_DPS`] is no
/// rail (NaN never equals a reading). A constant axis keeps its value as both.
pub(crate) fn gyro_rails(min_radps: f64, max_radps: f64) -> (f64, f64) {
    let floor = SMALLEST_GYRO_RANGE_DPS.to_radians();
    let rail = |v: f64| if v.abs() >= floor { v } else { f64::NAN };
    (rail(min_radps), rail(max_radps))
}

/// One gyro axis's saturated samples (rad/s): flat tops at a rail ([`gyro_rails`]).
fn gyro_flat_tops(axis: &[f64]) -> Vec<(usize, f64)> {
    if axis.is_empty() {
        return Vec::new();
    }
    let (min, max) = extremes(axis);
    let (min, max) = gyro_rails(min, max);
    flat_tops(axis, min, max)
}

/// Each saturated gyro axis and its rail, deg/s, by the rule of [`inspect`].
pub(crate) fn gyro_rails_hit(gyro_radps: &[Vec<f64>; 3]) -> Vec<(char, f64)> {
    (0..3)
        .filter_map(|k| {
            let &(_, rail) = gyro_flat_tops(&gyro_radps[k]).first()?;
            Some((['x', 'y', 'z'][k], rail.to_degrees()))
        })
        .collect()
}

/// Which samples have a saturated gyro axis, by the rule of [`inspect`]; the gyro fit leaves them
/// out (a pinned reading carries the rail, not the rate).
pub(crate) fn gyro_saturated_mask(gyro_radps: &[Vec<f64>; 3]) -> Vec<bool> {
    let mut mask = vec![false; gyro_radps[0].len()];
    for axis in gyro_radps {
        for (i, _) in gyro_flat_tops(axis) {
            if let Some(m) = mask.get_mut(i) {
                *m = true;
            }
        }
    }
    mask
}

/// The saturated samples of one non-constant axis and the magnitude each sits at: beyond
/// [`RANGE_SHARE`] of a known range, else on a flat top at the axis's extreme.
fn saturated_samples(axis: &[f64], min: f64, max: f64, range_mps2: Option<f64>) -> Vec<(usize, f64)> {
    match range_mps2 {
        Some(range) => axis
            .iter()
            .enumerate()
            .filter(|(_, v)| v.abs() >= RANGE_SHARE * range)
            .map(|(i, v)| (i, v.abs()))
            .collect(),
        None => flat_tops(axis, min, max),
    }
}

/// The least and greatest value, ignoring NaN.
fn extremes(axis: &[f64]) -> (f64, f64) {
    let min = axis.iter().copied().fold(f64::INFINITY, f64::min);
    let max = axis.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (min, max)
}

/// Samples inside runs of ≥ [`RAIL_SAMPLES`] equal values at the axis maximum or minimum.
fn flat_tops(axis: &[f64], min: f64, max: f64) -> Vec<(usize, f64)> {
    let mut hits = Vec::new();
    let mut i = 0;
    while i < axis.len() {
        let v = axis[i];
        let mut j = i + 1;
        while j < axis.len() && axis[j] == v {
            j += 1;
        }
        if (v == max || v == min) && j - i >= RAIL_SAMPLES {
            hits.extend((i..j).map(|k| (k, v.abs())));
        }
        i = j;
    }
    hits
}

/// What is wrong with a recording's time column for a turntable fit, and the reading flag that
/// fixes it, or `None` when the clock looks like one: every stamp equal (not a clock), steps of
/// exactly 1 in whole numbers (a sample index), steps of half a second or more (milliseconds read
/// as seconds, or a sample index), steps under 10 µs (seconds read as milliseconds or
/// microseconds). The same rule for every command that fits a turntable.
pub(crate) fn time_advice(recording: &Recording) -> Option<String> {
    let t = &recording.time_s;
    if t.len() < 2 {
        return None;
    }
    if recording.duration_s() == 0.0 {
        return Some(format!(
            "every timestamp is {}: the time column is not a clock; give the sample rate (`sample_rate_hz`: time = sample number / rate)",
            t[0]
        ));
    }
    let dt = sample_interval(t);
    if dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let whole = t.iter().all(|v| v.fract() == 0.0);
    if whole && dt == 1.0 {
        return Some(
            "the time column counts 0, 1, 2, … in steps of exactly 1: a sample index, not seconds; give the sample rate (`sample_rate_hz`: time = sample number / rate)"
                .to_string(),
        );
    }
    if dt >= 0.5 {
        return Some(format!(
            "the time column steps by {dt} s ({:.3} Hz), too slow for a turntable recording: if it counts milliseconds give `time_unit` ms (microseconds: us); if it counts samples, give `sample_rate_hz`",
            1.0 / dt
        ));
    }
    if dt < 1e-5 {
        return Some(format!(
            "the time column steps by {dt:e} s ({:.0} Hz), faster than an IMU logs: if it counts seconds give `time_unit` s (milliseconds: ms); or give `sample_rate_hz`",
            1.0 / dt
        ));
    }
    None
}

/// How a time column's repeated stamps could spoil a rate: `Some` advice when more than a tenth of
/// the steps repeat a stamp (a coarse clock), pointing to `--retime`.
pub(crate) fn repeated_stamps_advice(recording: &Recording) -> Option<String> {
    let t = &recording.time_s;
    let repeats = t.windows(2).filter(|w| w[1] == w[0]).count();
    (t.len() > 1 && repeats * 10 > t.len() - 1).then(|| {
        format!(
            "{repeats} of {} time steps repeat a stamp (a coarse clock); --retime spaces the samples evenly at the rate all the stamps give",
            t.len() - 1
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::recording::{ColumnMap, Source};

    fn read(text: &str) -> Recording {
        Recording::read_csv(text.as_bytes(), "rec.csv", &ColumnMap::default()).unwrap()
    }

    #[test]
    fn temperature_range_and_resolution() {
        let r = read("t,ax,ay,az,temp_c\n0,0,0,9.8,24\n0.01,0,0,9.8,25\n0.02,0,0,9.8,25\n0.03,0,0,9.8,27\n");
        let t = inspect(&r, None).temperature.unwrap();
        assert_eq!(
            (t.min_c, t.max_c, t.resolution_c, t.distinct_values),
            (24.0, 27.0, 1.0, 3)
        );
        let r = read("t,ax,ay,az,temp_k\n0,0,0,9.8,300\n0.01,0,0,9.8,300.5\n");
        let t = inspect(&r, None).temperature.unwrap();
        assert!((t.min_c - 26.85).abs() < 1e-9 && (t.resolution_c - 0.5).abs() < 1e-9);
        assert_eq!(
            inspect(&read("t,ax,ay,az\n0,0,0,9.8\n0.01,0,0,9.8\n"), None).temperature,
            None
        );
    }

    #[test]
    fn reports_gaps_with_their_line_and_index() {
        let r = read("t,ax,ay,az\n0,0.1,0.5,1\n0.01,0.2,0.4,1.1\n0.02,0.3,0.3,1.2\n0.05,0.4,0.2,1.3\n0.06,0.5,0.1,1.4\n");
        let found = inspect(&r, None);
        assert_eq!(found.gap_count, 1);
        assert_eq!(found.gaps[0].index, 3);
        assert_eq!(
            found.warnings("rec.csv"),
            ["rec.csv:5: 1 gap(s) in time, the first of 0.0300 s at t = 0.0200 s, the longest listed 0.0300 s"]
        );
        assert!((found.sample_rate_hz - 100.0).abs() < 1e-6);
    }

    #[test]
    fn reports_saturation_by_range_and_by_flat_top() {
        let g = STANDARD_GRAVITY;
        let text =
            "t,ax_g,ay_g,az_g\n0,0.1,0,1\n0.01,5,0.1,1.01\n0.02,5,0,0.99\n0.03,5,0,1.02\n0.04,0.2,0,1.1\n";
        let r = read(text);
        let by_range = inspect(&r, Some(5.0 * g));
        assert_eq!(
            by_range.warnings("rec.csv"),
            ["rec.csv:3: 3 sample(s) of ax at the range limit 5.0000 g (saturated)"]
        );
        let by_shape = inspect(&r, None);
        // ax rails at 5 g for three samples; ay sits at its minimum 0 for three samples too.
        assert_eq!(by_shape.saturation.len(), 2, "{by_shape:?}");
        assert_eq!(
            (by_shape.saturation[0].axis, by_shape.saturation[0].samples),
            ('x', 3)
        );
        assert_eq!(by_shape.saturation[1].axis, 'y');
        assert_eq!(by_shape.saturated_samples(), 6);
    }

    /// A gyro pinned at an MPU-6050's ±250 °/s (code 32767 at 131 LSB per °/s) for part of a
    /// run, and for all of one: each found with its rail; a still, coarsely quantised gyro whose
    /// extremes repeat is not.
    #[test]
    fn a_pinned_gyro_is_saturated_with_its_range_and_a_quantised_still_one_is_not() {
        let rail = (32767.0f64 / 131.0).to_radians();
        let n = 400;
        let time_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        // z spins up through the rail and stays there from sample 300; y is pinned throughout;
        // x is a still gyro in 1-count steps (0.0076 °/s) whose extremes repeat.
        let z: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.9f64.to_radians()).min(rail))
            .collect();
        let x: Vec<f64> = (0..n)
            .map(|i| [0.0, 1.0, 1.0, 1.0, 0.0, -1.0, -1.0, -1.0][i % 8] / 131.0f64.to_degrees())
            .collect();
        let r = Recording {
            time_s,
            accel_mps2: [
                vec![0.1; n],
                vec![0.2; n],
                (0..n).map(|i| 9.8 + 1e-3 * (i % 3) as f64).collect(),
            ],
            gyro_radps: Some([x, vec![-rail; n], z]),
            temperature_c: None,
            source: Source::default(),
        };
        let found = inspect(&r, None);
        let pinned: Vec<(char, usize)> = found
            .gyro_saturation
            .iter()
            .map(|s| (s.axis, s.samples))
            .collect();
        let first_pinned = (rail.to_degrees() / 0.9).ceil() as usize;
        assert_eq!(pinned, [('y', n), ('z', n - first_pinned)], "{found:?}");
        for s in &found.gyro_saturation {
            assert!((s.limit_dps - 250.13).abs() < 0.01, "{s:?}");
        }
        let mask = gyro_saturated_mask(r.gyro_radps.as_ref().unwrap());
        assert_eq!(mask.iter().filter(|&&m| m).count(), n);
        let warnings = found.warnings("run.csv");
        assert!(
            warnings.iter().any(|w| w.ends_with(
                ": 400 of 400 samples (100.0 %) of gy pinned at 250.13 °/s: the gyro is saturated (its range is about ±250 °/s; turn slower or set a wider gyro range)"
            )),
            "{warnings:?}"
        );
        assert_eq!(gyro_rails_hit(r.gyro_radps.as_ref().unwrap()).len(), 2);
    }

    #[test]
    fn a_constant_axis_is_constant_not_saturated_and_named() {
        let r = Recording {
            time_s: vec![0.0, 0.01, 0.02, 0.03],
            accel_mps2: [vec![1.0, 2.0, 3.0, 4.0], vec![0.0; 4], vec![9.8; 4]],
            gyro_radps: None,
            temperature_c: None,
            source: Source::default(),
        };
        let found = inspect(&r, None);
        assert!(found.saturation.is_empty(), "{found:?}");
        assert_eq!(found.constant_axes, ['y', 'z']);
        assert_eq!(found.accel_min_mps2[2], 9.8);
        assert!(found.warnings("f")[0].contains("ay is constant"));
        assert!(found.warnings("f")[1].contains("az is constant"));
    }
}
