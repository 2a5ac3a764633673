//! The saved corrector file: JSON of the form
//! `{"format_version": 1, "spincal_version": "…", "corrector": {"kind": "ann", …}}`.
//!
//! A new kind of corrector is one more variant of [`CorrectorModel`] and one more arm in its
//! `Corrector` impl; the format version changes only when existing kinds change incompatibly.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::correctors::ann::AnnModel;
use crate::correctors::corrector::{Axis, Corrector, SampleCorrector};
use crate::correctors::linear::LinearModel;
use crate::correctors::static_cal::StaticCalibration;

/// The corrector file format this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

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
    /// Writing the file failed (the previous file, if any, is kept).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
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
        crate::output::write_bytes(path, (self.to_json() + "\n").as_bytes())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
