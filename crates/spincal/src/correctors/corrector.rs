//! What every corrector is: a map from measured to corrected acceleration, sample by sample
//! ([`Corrector::stream`]), keeping whatever delay history it needs. The kinds live beside this
//! module; the saved file that holds any of them is [`crate::correctors::model_file`].

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::input::recording::Recording;

/// An accelerometer axis in the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// 0 for x, 1 for y, 2 for z.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }

    pub fn parse(text: &str) -> Option<Axis> {
        match text.trim().to_ascii_lowercase().as_str() {
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            "z" => Some(Axis::Z),
            _ => None,
        }
    }

    /// Parses a list such as `x,y` (or `xy`).
    pub fn parse_list(text: &str) -> Option<Vec<Axis>> {
        let parts: Vec<&str> = if text.contains(',') {
            text.split(',').collect()
        } else {
            text.trim().split_inclusive(|_| true).collect()
        };
        parts.into_iter().map(Axis::parse).collect()
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A corrector that contradicts its own structure (a damaged or hand-edited file, or a model
/// built by hand): the field, as a path below the corrector object in the saved file
/// (`network.weights`, `axes[1]`, `matrix[0][2]`), and what is wrong with it. Every kind checks
/// everything its application relies on, so a model that passes never panics when applied.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct ModelError {
    pub field: String,
    pub reason: String,
}

impl ModelError {
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> ModelError {
        ModelError {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// The same error seen from the enclosing object: the field becomes `prefix.field` (or
    /// `prefix[i]…` for an index).
    pub fn within(mut self, prefix: &str) -> ModelError {
        self.field = join_field(prefix, &self.field);
        self
    }
}

/// `prefix` and `field` joined as a path: `a` + `b` → `a.b`, `a` + `[1]` → `a[1]`.
pub(crate) fn join_field(prefix: &str, field: &str) -> String {
    if prefix.is_empty() {
        field.to_string()
    } else if field.is_empty() {
        prefix.to_string()
    } else if field.starts_with('[') {
        format!("{prefix}{field}")
    } else {
        format!("{prefix}.{field}")
    }
}

/// Every value finite; the error names the first that is not (`field[i]`).
pub(crate) fn check_finite(field: &str, values: &[f64]) -> Result<(), ModelError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(ModelError::new(
            format!("{field}[{i}]"),
            format!("{} is not a finite number", values[i]),
        )),
        None => Ok(()),
    }
}

/// A list of `found` entries where `needed` are required; `why` completes "but … need N", e.g.
/// `2 axes`.
pub(crate) fn check_len(field: &str, found: usize, needed: usize, why: &str) -> Result<(), ModelError> {
    if found == needed {
        Ok(())
    } else {
        Err(ModelError::new(
            field,
            format!(
                "{found} {}, but {why} need {needed}",
                if found == 1 { "value" } else { "values" }
            ),
        ))
    }
}

/// "1 axis", "2 axes": for messages.
pub(crate) fn axes_phrase(n: usize) -> String {
    if n == 1 {
        "1 axis".into()
    } else {
        format!("{n} axes")
    }
}

/// A model's corrected axes: at least one, none twice.
pub(crate) fn check_model_axes(field: &str, axes: &[Axis]) -> Result<(), ModelError> {
    if axes.is_empty() {
        return Err(ModelError::new(
            field,
            "no axes: a corrector corrects one or more of x, y, z",
        ));
    }
    for (i, a) in axes.iter().enumerate() {
        if let Some(first) = axes[..i].iter().position(|b| b == a) {
            return Err(ModelError::new(
                format!("{field}[{i}]"),
                format!("axis {a} is listed twice (also at [{first}])"),
            ));
        }
    }
    Ok(())
}

/// One corrected sample: all three axes (uncorrected axes pass through) and whether the corrector
/// had its full history. An invalid sample carries the measured values unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrectedSample {
    pub accel_mps2: [f64; 3],
    pub valid: bool,
    /// An input lay beyond the range the corrector was trained on, by more than
    /// [`crate::correctors::ann::EXTRAPOLATION_MARGIN`] of that range (networks only: a tanh network's output
    /// there is an extrapolation; linear and static corrections hold everywhere).
    pub outside_training_range: bool,
}

/// Streaming application with per-stream state (delay history).
pub trait SampleCorrector {
    /// Corrects one sample (sensor frame, m/s²); samples must arrive in time order.
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample;
}

/// A whole recording after correction.
#[derive(Debug, Clone, PartialEq)]
pub struct Corrected {
    pub accel_mps2: [Vec<f64>; 3],
    pub valid: Vec<bool>,
    /// How many samples were flagged [`CorrectedSample::outside_training_range`].
    pub outside_training_range: usize,
}

/// Anything that corrects accelerometer samples.
pub trait Corrector {
    /// The axes it changes; the others pass through.
    fn corrected_axes(&self) -> Vec<Axis>;
    /// Samples at the start that lack a full history (marked invalid, never dropped).
    fn warmup_samples(&self) -> usize;
    /// A fresh streaming state.
    fn stream(&self) -> Box<dyn SampleCorrector + '_>;

    /// Corrects a whole recording by streaming it.
    fn correct(&self, recording: &Recording) -> Corrected {
        self.correct_accel(&recording.accel_mps2)
    }

    /// Corrects accelerometer axes (m/s², one series each, in time order) by streaming them.
    fn correct_accel(&self, a: &[Vec<f64>; 3]) -> Corrected {
        let mut stream = self.stream();
        let n = a[0].len();
        let mut out = Corrected {
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            valid: vec![false; n],
            outside_training_range: 0,
        };
        for i in 0..n {
            let sample = stream.correct_sample([a[0][i], a[1][i], a[2][i]]);
            for c in 0..3 {
                out.accel_mps2[c][i] = sample.accel_mps2[c];
            }
            out.valid[i] = sample.valid;
            out.outside_training_range += usize::from(sample.outside_training_range);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_lists_parse() {
        assert_eq!(Axis::parse_list("x,y"), Some(vec![Axis::X, Axis::Y]));
        assert_eq!(Axis::parse_list("xyz"), Some(Axis::ALL.to_vec()));
        assert_eq!(Axis::parse_list("x,w"), None);
    }
}
