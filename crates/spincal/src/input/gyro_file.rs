//! The gyroscope beside a recording: the recording's own gyro columns, or a second file sampled
//! beside it (imu_tk's layout, `t gx gy gz`), and whether the values are raw counts.

use std::path::Path;

use crate::input::formats::{self, FormatError, Loaded, ReadOptions};
use crate::input::recording::Recording;

/// A gyro reading above this (rad/s, mean of an axis over the file) is taken for raw counts: no
/// handheld or turntable session turns that fast for long.
const GYRO_COUNTS_RADPS: f64 = 50.0;

/// Gyro readings sampled beside a recording.
#[derive(Debug, Clone)]
pub struct GyroColumns {
    pub values: [Vec<f64>; 3],
    /// Raw counts rather than rad/s (the reader says so, or the values are far beyond any rate).
    pub counts: bool,
    /// Where they came from, for messages.
    pub source: String,
}

impl From<FormatError> for GyroFileError {
    fn from(e: FormatError) -> Self {
        GyroFileError::Read(Box::new(e))
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GyroFileError {
    // Boxed: a reader's error is large, and this one is returned often.
    #[error(transparent)]
    Read(Box<FormatError>),
    #[error(
        "{file}: {found} samples, but the recording has {expected}; the gyro file must sample beside it"
    )]
    Length {
        file: String,
        found: usize,
        expected: usize,
    },
    #[error("{file}: sample {sample} is at {at_s} s, the recording's at {expected_s} s; the gyro file must sample beside it")]
    Time {
        file: String,
        sample: usize,
        at_s: f64,
        expected_s: f64,
    },
}

/// The gyro of `loaded` (read from `recording_name`): from `gyro_file` when given (sample for
/// sample beside it, re-timed as the recording was with `retime`), else its own gyro columns;
/// `None` when it has none.
pub fn gyro_columns(
    gyro_file: Option<&Path>,
    loaded: &Loaded,
    recording_name: &str,
    retime: bool,
) -> Result<Option<GyroColumns>, GyroFileError> {
    let rec = &loaded.recording;
    match gyro_file {
        Some(path) => {
            let (values, counts) = read_beside(path, rec, retime)?;
            Ok(Some(GyroColumns::new(values, counts, path.display().to_string())))
        }
        None => Ok(GyroColumns::of(rec, loaded.gyro_counts, recording_name)),
    }
}

impl GyroColumns {
    /// A recording's own gyro columns (`None` when it has none); `reader_counts`: the reader
    /// took them for raw counts.
    pub fn of(recording: &Recording, reader_counts: bool, name: &str) -> Option<GyroColumns> {
        let values = recording.gyro_radps.clone()?;
        Some(GyroColumns::new(values, reader_counts, name.to_string()))
    }

    /// Raw counts when the reader says so, or when an axis's mean is beyond any rate.
    fn new(values: [Vec<f64>; 3], reader_counts: bool, source: String) -> GyroColumns {
        let looks_like_counts = values.iter().any(|axis| {
            let mean = axis.iter().sum::<f64>() / axis.len().max(1) as f64;
            mean.abs() > GYRO_COUNTS_RADPS
        });
        GyroColumns {
            values,
            counts: reader_counts || looks_like_counts,
            source,
        }
    }
}

/// A gyro file's three value columns, checked to sample beside `rec` (the same number of
/// samples at the same times, within half a sample), and whether the reader took them for raw
/// counts.
fn read_beside(path: &Path, rec: &Recording, retime: bool) -> Result<([Vec<f64>; 3], bool), GyroFileError> {
    let options = ReadOptions {
        retime,
        ..Default::default()
    };
    let loaded = formats::read_path(path, &options)?;
    let g = loaded.recording;
    let file = path.display().to_string();
    if g.len() != rec.len() {
        return Err(GyroFileError::Length {
            file,
            found: g.len(),
            expected: rec.len(),
        });
    }
    let half = 0.5 / rec.sample_rate_hz();
    if let Some(i) = (0..g.len()).find(|&i| (g.time_s[i] - rec.time_s[i]).abs() > half.max(0.011)) {
        return Err(GyroFileError::Time {
            file,
            sample: i + 1,
            at_s: g.time_s[i],
            expected_s: rec.time_s[i],
        });
    }
    // Its three value columns are the gyro whatever the reader took them for.
    let counts = loaded.raw_counts || loaded.gyro_counts;
    Ok((g.gyro_radps.unwrap_or(g.accel_mps2), counts))
}
