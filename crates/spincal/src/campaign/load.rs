//! Reading a campaign's recordings (and their truth files) from disk.

use crate::campaign::file::{Campaign, EntryKind};
use crate::campaign::prepare::UnitRecording;
use crate::input::formats::{read_path, FormatError, ReadOptions};
use crate::input::recording::ColumnMap;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    #[error("{campaign}:{line}: `file`: {source}")]
    Recording {
        campaign: String,
        line: usize,
        #[source]
        source: Box<FormatError>,
    },
    #[error("{campaign}:{line}: `truth`: {source}")]
    Truth {
        campaign: String,
        line: usize,
        #[source]
        source: Box<FormatError>,
    },
    #[error("{campaign}:{line}: `truth`: {truth} has {found} samples but the recording has {expected}")]
    TruthLength {
        campaign: String,
        line: usize,
        truth: String,
        found: usize,
        expected: usize,
    },
    #[error("{campaign}:{line}: `columns`: {message}")]
    Columns {
        campaign: String,
        line: usize,
        message: String,
    },
    #[error("{campaign}:{line}: `file`: {file} holds raw counts; give `accel_unit` or convert it first")]
    RawCounts {
        campaign: String,
        line: usize,
        file: String,
    },
}

/// Reads every recording of the campaign (formats detected as the CLI does).
pub fn load_campaign(campaign: &Campaign) -> Result<Vec<UnitRecording>, LoadError> {
    let name = campaign.path.display().to_string();
    let mut out = Vec::with_capacity(campaign.recordings.len());
    for entry in &campaign.recordings {
        let mut columns = ColumnMap {
            accel_unit: entry.accel_unit,
            ..ColumnMap::default()
        };
        if let Some(spec) = &entry.columns {
            columns = columns.with_columns(spec).map_err(|e| LoadError::Columns {
                campaign: name.clone(),
                line: entry.line,
                message: e.to_string(),
            })?;
        }
        let options = ReadOptions {
            columns,
            ..ReadOptions::default()
        };
        let loaded = read_path(&entry.file, &options).map_err(|source| LoadError::Recording {
            campaign: name.clone(),
            line: entry.line,
            source: Box::new(source),
        })?;
        if loaded.raw_counts {
            return Err(LoadError::RawCounts {
                campaign: name.clone(),
                line: entry.line,
                file: entry.file.display().to_string(),
            });
        }
        let recording = loaded.recording;
        let truth = match &entry.truth {
            None => None,
            Some(path) => {
                let t = read_path(path, &ReadOptions::default()).map_err(|source| LoadError::Truth {
                    campaign: name.clone(),
                    line: entry.line,
                    source: Box::new(source),
                })?;
                if t.recording.len() != recording.len() {
                    return Err(LoadError::TruthLength {
                        campaign: name.clone(),
                        line: entry.line,
                        truth: path.display().to_string(),
                        found: t.recording.len(),
                        expected: recording.len(),
                    });
                }
                Some(t.recording.accel_mps2)
            }
        };
        out.push(UnitRecording {
            name: entry.file.display().to_string(),
            recording,
            turntable: match &entry.kind {
                EntryKind::Static => None,
                EntryKind::Turntable(t) => Some(t.clone()),
            },
            truth,
            floor_mps2: entry.noise_floor_mps2,
        });
    }
    Ok(out)
}
