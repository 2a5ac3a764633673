//! Correctors and their saved file format.
//!
//! A corrector maps measured acceleration to corrected acceleration, sample by sample
//! ([`Corrector::stream`]), keeping whatever delay history it needs. Saved models are JSON:
//! `{"format_version": 1, "spincal_version": "…", "corrector": {"kind": "ann", …}}`. A new kind
//! of corrector is one more variant of [`CorrectorModel`] and one more arm in its `Corrector`
//! impl; the format version changes only when existing kinds change incompatibly.

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::ann::AnnModel;
use crate::linear::LinearModel;
use crate::recording::Recording;
use crate::static_cal::StaticCalibration;

/// The corrector file format this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

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

/// One corrected sample: all three axes (uncorrected axes pass through) and whether the corrector
/// had its full history. An invalid sample carries the measured values unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrectedSample {
    pub accel_mps2: [f64; 3],
    pub valid: bool,
    /// An input lay beyond the range the corrector was trained on, by more than
    /// [`crate::ann::EXTRAPOLATION_MARGIN`] of that range (networks only: a tanh network's output
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
        let mut stream = self.stream();
        let n = recording.len();
        let mut out = Corrected {
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            valid: vec![false; n],
            outside_training_range: 0,
        };
        for i in 0..n {
            let a = &recording.accel_mps2;
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

/// Every kind of saved corrector, tagged by `kind`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum CorrectorModel {
    Ann(Box<AnnModel>),
    Linear(Box<LinearModel>),
    /// Offsets, scale and misalignment from still poses (`spincal static`).
    Static(Box<StaticCalibration>),
}

impl CorrectorModel {
    fn inner(&self) -> &dyn Corrector {
        match self {
            CorrectorModel::Ann(m) => m.as_ref(),
            CorrectorModel::Linear(m) => m.as_ref(),
            CorrectorModel::Static(m) => m.as_ref(),
        }
    }

    /// The `kind` tag as written in the file.
    pub fn kind(&self) -> &'static str {
        match self {
            CorrectorModel::Ann(_) => "ann",
            CorrectorModel::Linear(_) => "linear",
            CorrectorModel::Static(_) => "static",
        }
    }
}

impl Corrector for CorrectorModel {
    fn corrected_axes(&self) -> Vec<Axis> {
        self.inner().corrected_axes()
    }

    fn warmup_samples(&self) -> usize {
        self.inner().warmup_samples()
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        self.inner().stream()
    }
}

/// What can go wrong reading or writing a corrector file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CorrectorError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: cannot write: {source}")]
    Write {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: not a spincal corrector file: {source}")]
    Parse {
        file: String,
        #[source]
        source: serde_json::Error,
    },
    #[error("{file}: no format_version field; not a spincal corrector file")]
    MissingVersion { file: String },
    #[error("{file}: corrector file format_version {found}, but this spincal reads format_version {supported}; retrain the corrector or use a matching spincal")]
    Version {
        file: String,
        found: u64,
        supported: u32,
    },
}

/// A saved corrector: the format version, the writing spincal version, the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CorrectorFile {
    pub format_version: u32,
    pub spincal_version: String,
    pub corrector: CorrectorModel,
}

impl CorrectorFile {
    pub fn new(corrector: CorrectorModel) -> CorrectorFile {
        CorrectorFile {
            format_version: FORMAT_VERSION,
            spincal_version: env!("CARGO_PKG_VERSION").to_string(),
            corrector,
        }
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("corrector models serialise")
    }

    /// Parses a file's text; `file` names it in errors. The version is checked before anything
    /// else, so a file from another version is refused by version, not by a field error.
    pub fn from_json(text: &str, file: &str) -> Result<CorrectorFile, CorrectorError> {
        let parse = |source| CorrectorError::Parse {
            file: file.to_string(),
            source,
        };
        let value: serde_json::Value = serde_json::from_str(text).map_err(parse)?;
        let found = value
            .get("format_version")
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| CorrectorError::MissingVersion {
                file: file.to_string(),
            })?;
        if found != u64::from(FORMAT_VERSION) {
            return Err(CorrectorError::Version {
                file: file.to_string(),
                found,
                supported: FORMAT_VERSION,
            });
        }
        serde_json::from_value(value).map_err(parse)
    }

    pub fn read_path(path: &Path) -> Result<CorrectorFile, CorrectorError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CorrectorError::Read {
            file: file.clone(),
            source,
        })?;
        CorrectorFile::from_json(&text, &file)
    }

    pub fn write_path(&self, path: &Path) -> Result<(), CorrectorError> {
        std::fs::write(path, self.to_json() + "\n").map_err(|source| CorrectorError::Write {
            file: path.display().to_string(),
            source,
        })
    }
}

/// A static calibration is a memoryless map of all three axes.
impl Corrector for StaticCalibration {
    fn corrected_axes(&self) -> Vec<Axis> {
        Axis::ALL.to_vec()
    }

    fn warmup_samples(&self) -> usize {
        0
    }

    fn stream(&self) -> Box<dyn SampleCorrector + '_> {
        Box::new(StaticStream(self))
    }
}

struct StaticStream<'a>(&'a StaticCalibration);

impl SampleCorrector for StaticStream<'_> {
    fn correct_sample(&mut self, accel_mps2: [f64; 3]) -> CorrectedSample {
        CorrectedSample {
            accel_mps2: self.0.apply(&accel_mps2),
            valid: true,
            outside_training_range: false,
        }
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

    #[test]
    fn other_format_version_is_refused_by_name() {
        let text = r#"{"format_version": 7, "corrector": {"kind": "future"}}"#;
        let err = CorrectorFile::from_json(text, "old.json").unwrap_err();
        let message = err.to_string();
        assert!(message.contains("old.json"), "{message}");
        assert!(message.contains("format_version 7"), "{message}");
        assert!(
            message.contains(&format!("format_version {FORMAT_VERSION}")),
            "{message}"
        );
    }
}
