//! Scaling (MATLAB's mapminmax), tapped-delay input rows, and the 60/20/20 data division.

use std::ops::Range;

use serde::{Deserialize, Serialize};

/// Per-channel linear map of `[min, max]` onto [−1, 1] (MATLAB's `mapminmax`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scaling {
    pub min: Vec<f64>,
    pub max: Vec<f64>,
}

impl Scaling {
    /// The range of each channel over the samples in `rows`.
    pub fn fit(channels: &[&[f64]], rows: &[Range<usize>]) -> Scaling {
        let mut min = vec![f64::INFINITY; channels.len()];
        let mut max = vec![f64::NEG_INFINITY; channels.len()];
        for (c, channel) in channels.iter().enumerate() {
            for range in rows {
                for &v in &channel[range.clone()] {
                    min[c] = min[c].min(v);
                    max[c] = max[c].max(v);
                }
            }
        }
        Scaling { min, max }
    }

    /// Gain and offset of channel `c`: `scaled = gain · x + offset`. A constant channel maps to 0
    /// (its gain would be infinite).
    #[inline]
    fn gain_offset(&self, c: usize) -> (f64, f64) {
        let span = self.max[c] - self.min[c];
        if span > 0.0 {
            let gain = 2.0 / span;
            (gain, -1.0 - gain * self.min[c])
        } else {
            (0.0, 0.0)
        }
    }

    #[inline]
    pub fn apply(&self, c: usize, x: f64) -> f64 {
        let (gain, offset) = self.gain_offset(c);
        gain * x + offset
    }

    /// The inverse map; a constant channel comes back as its constant.
    #[inline]
    pub fn reverse(&self, c: usize, scaled: f64) -> f64 {
        let span = self.max[c] - self.min[c];
        if span > 0.0 {
            self.min[c] + (scaled + 1.0) * span / 2.0
        } else {
            self.min[c]
        }
    }
}

/// How the samples are split into training, validation and test parts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "mode")]
pub enum DivisionMode {
    /// First 60 % training, next 20 % validation, last 20 % test (the default: time series).
    Contiguous,
    /// Repeating groups of five blocks of `block_len` samples: three training, one validation,
    /// one test.
    Interleaved { block_len: usize },
}

/// Which part a sample belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    Train,
    Validation,
    Test,
}

/// The split of sample indices (into the recording) into the three parts, as sorted disjoint
/// ranges. Samples before `first_sample` (no full delay history) belong to no part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Division {
    pub mode: DivisionMode,
    pub n_samples: usize,
    pub first_sample: usize,
    pub train: Vec<Range<usize>>,
    pub validation: Vec<Range<usize>>,
    pub test: Vec<Range<usize>>,
}

impl Division {
    /// Splits samples `first_sample..n_samples` 60/20/20.
    pub fn new(n_samples: usize, first_sample: usize, mode: DivisionMode) -> Division {
        let mut division = Division {
            mode,
            n_samples,
            first_sample,
            train: Vec::new(),
            validation: Vec::new(),
            test: Vec::new(),
        };
        let usable = n_samples.saturating_sub(first_sample);
        match mode {
            DivisionMode::Contiguous => {
                let train_end = first_sample + usable * 3 / 5;
                let validation_end = first_sample + usable * 4 / 5;
                division.train.push(first_sample..train_end);
                division.validation.push(train_end..validation_end);
                division.test.push(validation_end..n_samples);
            }
            DivisionMode::Interleaved { block_len } => {
                let block_len = block_len.max(1);
                let mut start = first_sample;
                let mut block = 0usize;
                while start < n_samples {
                    let end = (start + block_len).min(n_samples);
                    let part = match block % 5 {
                        0..=2 => &mut division.train,
                        3 => &mut division.validation,
                        _ => &mut division.test,
                    };
                    match part.last_mut() {
                        Some(last) if last.end == start => last.end = end,
                        _ => part.push(start..end),
                    }
                    start = end;
                    block += 1;
                }
            }
        }
        division
    }

    pub fn ranges(&self, part: Part) -> &[Range<usize>] {
        match part {
            Part::Train => &self.train,
            Part::Validation => &self.validation,
            Part::Test => &self.test,
        }
    }

    /// Number of samples in `part`.
    pub fn count(&self, part: Part) -> usize {
        self.ranges(part).iter().map(|r| r.len()).sum()
    }

    /// The part of every sample (`None` for the samples without delay history), for plotting.
    pub fn mask(&self) -> Vec<Option<Part>> {
        let mut mask = vec![None; self.n_samples];
        for part in [Part::Train, Part::Validation, Part::Test] {
            for range in self.ranges(part) {
                mask[range.clone()].fill(Some(part));
            }
        }
        mask
    }
}

/// Network inputs and targets for a set of samples, scaled, row-major.
#[derive(Debug, Clone, Default)]
pub struct Dataset {
    pub n_inputs: usize,
    pub n_outputs: usize,
    /// `len() × n_inputs` values.
    pub inputs: Vec<f64>,
    /// `len() × n_outputs` values.
    pub targets: Vec<f64>,
}

impl Dataset {
    pub fn len(&self) -> usize {
        self.targets.len().checked_div(self.n_outputs).unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Builds the tapped-delay rows for the samples in `rows`. Input row layout: for each measured
    /// channel in order, its value at the sample, then at the sample before, … `delays` back.
    /// Every index in `rows` must be at least `delays`.
    pub fn build(
        measured: &[&[f64]],
        reference: &[&[f64]],
        delays: usize,
        input_scaling: &Scaling,
        output_scaling: &Scaling,
        rows: &[Range<usize>],
    ) -> Dataset {
        let n_rows: usize = rows.iter().map(|r| r.len()).sum();
        let n_inputs = measured.len() * (delays + 1);
        let mut data = Dataset {
            n_inputs,
            n_outputs: reference.len(),
            inputs: Vec::with_capacity(n_rows * n_inputs),
            targets: Vec::with_capacity(n_rows * reference.len()),
        };
        for range in rows {
            for i in range.clone() {
                debug_assert!(i >= delays, "sample {i} has no full delay history");
                for (c, channel) in measured.iter().enumerate() {
                    for lag in 0..=delays {
                        data.inputs.push(input_scaling.apply(c, channel[i - lag]));
                    }
                }
                for (c, channel) in reference.iter().enumerate() {
                    data.targets.push(output_scaling.apply(c, channel[i]));
                }
            }
        }
        data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn divisions_cover_every_usable_sample_once() {
        for mode in [
            DivisionMode::Contiguous,
            DivisionMode::Interleaved { block_len: 7 },
        ] {
            let division = Division::new(1003, 3, mode);
            let mask = division.mask();
            assert!(mask[..3].iter().all(Option::is_none));
            assert!(mask[3..].iter().all(Option::is_some));
            let total =
                division.count(Part::Train) + division.count(Part::Validation) + division.count(Part::Test);
            assert_eq!(total, 1000);
            let train_share = division.count(Part::Train) as f64 / 1000.0;
            assert!(
                (train_share - 0.6).abs() < 0.02,
                "{mode:?}: train share {train_share}"
            );
        }
        let contiguous = Division::new(1000, 0, DivisionMode::Contiguous);
        assert_eq!(contiguous.train, vec![0..600]);
        assert_eq!(contiguous.validation, vec![600..800]);
        assert_eq!(contiguous.test, vec![800..1000]);
    }

    #[test]
    fn scaling_maps_range_onto_unit_interval_and_back() {
        let x = [2.0, 4.0, 3.0];
        let all = 0..3;
        let s = Scaling::fit(&[&x], std::slice::from_ref(&all));
        assert_eq!(s.apply(0, 2.0), -1.0);
        assert_eq!(s.apply(0, 4.0), 1.0);
        assert!((s.reverse(0, s.apply(0, 3.3)) - 3.3).abs() < 1e-15);
    }

    #[test]
    fn delay_rows_hold_current_then_past_samples() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [10.0, 11.0, 12.0, 13.0];
        let unit = Scaling {
            min: vec![-1.0],
            max: vec![1.0],
        };
        let rows = 2..4;
        let d = Dataset::build(&[&x], &[&y], 2, &unit, &unit, std::slice::from_ref(&rows));
        assert_eq!(d.inputs, vec![2.0, 1.0, 0.0, 3.0, 2.0, 1.0]);
        assert_eq!(d.targets, vec![12.0, 13.0]);
    }
}
