//! What every corrector shares before training: the axes and the two recordings paired sample
//! by sample, and the 60/20/20 division of the samples into training, validation and test parts.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::correctors::corrector::{axes_phrase, check_len, Axis, ModelError};
use crate::input::recording::Recording;

/// Why measured and reference data cannot be used together.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PairingError {
    #[error("no axes chosen: pick one or more of x, y, z")]
    NoAxes,
    #[error("axis {0} is listed twice")]
    RepeatedAxis(Axis),
    #[error("the measured recording has {measured} samples and the reference {reference}: they must be the same samples")]
    LengthMismatch { measured: usize, reference: usize },
    #[error("sample {index}: measured time {measured} s differs from reference time {reference} s")]
    TimeMismatch {
        index: usize,
        measured: f64,
        reference: f64,
    },
}

/// At least one axis, none twice.
pub(crate) fn check_axes(axes: &[Axis]) -> Result<(), PairingError> {
    if axes.is_empty() {
        return Err(PairingError::NoAxes);
    }
    for (i, a) in axes.iter().enumerate() {
        if axes[..i].contains(a) {
            return Err(PairingError::RepeatedAxis(*a));
        }
    }
    Ok(())
}

/// The two recordings must hold the same samples; times agree to 1 µs or 1e-6 relative.
pub(crate) fn check_pairing(measured: &Recording, reference: &Recording) -> Result<(), PairingError> {
    if measured.len() != reference.len() {
        return Err(PairingError::LengthMismatch {
            measured: measured.len(),
            reference: reference.len(),
        });
    }
    for (index, (&a, &b)) in measured.time_s.iter().zip(&reference.time_s).enumerate() {
        if (a - b).abs() > 1e-6 * a.abs().max(1.0) {
            return Err(PairingError::TimeMismatch {
                index,
                measured: a,
                reference: b,
            });
        }
    }
    Ok(())
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

    /// A saved division that contradicts itself: `first_sample` as the corrector needs (its
    /// delays), every range inside `first_sample..n_samples` and in order, so that
    /// [`Division::mask`] and [`Division::count`] cannot fail. Fields relative to the division.
    pub fn check(&self, first_sample: usize) -> Result<(), ModelError> {
        if self.first_sample != first_sample {
            return Err(ModelError::new(
                "first_sample",
                format!(
                    "{}, but the corrector's delays make it {first_sample}",
                    self.first_sample
                ),
            ));
        }
        if self.first_sample > self.n_samples {
            return Err(ModelError::new(
                "first_sample",
                format!("{} is beyond n_samples {}", self.first_sample, self.n_samples),
            ));
        }
        for (name, ranges) in [
            ("train", &self.train),
            ("validation", &self.validation),
            ("test", &self.test),
        ] {
            let mut previous_end = self.first_sample;
            for (i, r) in ranges.iter().enumerate() {
                if r.start < previous_end || r.end < r.start || r.end > self.n_samples {
                    return Err(ModelError::new(
                        format!("{name}[{i}]"),
                        format!(
                            "samples {}..{} do not lie in order within {}..{} (n_samples)",
                            r.start, r.end, self.first_sample, self.n_samples
                        ),
                    ));
                }
                previous_end = r.end;
            }
        }
        Ok(())
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

/// Fit % (SPEC §4, original units) of each axis on each part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartFits {
    pub train: Vec<f64>,
    pub validation: Vec<f64>,
    pub test: Vec<f64>,
}

impl PartFits {
    pub fn get(&self, part: Part) -> &[f64] {
        match part {
            Part::Train => &self.train,
            Part::Validation => &self.validation,
            Part::Test => &self.test,
        }
    }

    /// One fit per axis in every part (fields relative to the fits).
    pub fn check(&self, n_axes: usize) -> Result<(), ModelError> {
        let why = axes_phrase(n_axes);
        check_len("train", self.train.len(), n_axes, &why)?;
        check_len("validation", self.validation.len(), n_axes, &why)?;
        check_len("test", self.test.len(), n_axes, &why)
    }

    /// Mean over axes of one part's fit %.
    pub fn mean(&self, part: Part) -> f64 {
        let v = self.get(part);
        v.iter().sum::<f64>() / v.len() as f64
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
}
