//! Scaling (MATLAB's mapminmax) and tapped-delay input rows.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{axes_phrase, check_finite, check_len, ModelError};

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

    /// A saved scaling of `n_channels` channels: one finite `min ≤ max` per channel, with a
    /// finite span (else the map is not invertible in floating point). Fields relative to the
    /// scaling.
    pub fn check(&self, n_channels: usize) -> Result<(), ModelError> {
        let why = axes_phrase(n_channels);
        check_len("min", self.min.len(), n_channels, &why)?;
        check_len("max", self.max.len(), n_channels, &why)?;
        check_finite("min", &self.min)?;
        check_finite("max", &self.max)?;
        for (c, (lo, hi)) in self.min.iter().zip(&self.max).enumerate() {
            if lo > hi {
                return Err(ModelError::new(
                    format!("min[{c}]"),
                    format!("{lo} is above max[{c}] {hi}"),
                ));
            }
            if !(hi - lo).is_finite() {
                return Err(ModelError::new(
                    format!("max[{c}]"),
                    format!("the range {lo} … {hi} is wider than a 64-bit float holds"),
                ));
            }
        }
        Ok(())
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
