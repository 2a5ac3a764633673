//! The gyroscope beside a recording: the recording's own gyro columns, or a second file sampled
//! beside it (imu_tk's layout, `t gx gy gz`) or on its own samples of the same clock (merged on
//! time), and whether the values are raw counts.

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
    #[error("{file}: {covered} of the recording's {samples} samples fall within the gyro file's span ({gyro_from_s:.3}–{gyro_to_s:.3} s; the recording's {from_s:.3}–{to_s:.3} s) outside its gaps; the two files must be on one clock and overlap for at least half the recording")]
    NoOverlap {
        file: String,
        covered: usize,
        samples: usize,
        gyro_from_s: f64,
        gyro_to_s: f64,
        from_s: f64,
        to_s: f64,
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
        GyroColumns {
            counts: reader_counts || beyond_any_rate(&values),
            values,
            source,
        }
    }
}

/// Whether an axis's mean is beyond any rate a session turns at for long (raw counts).
fn beyond_any_rate(values: &[Vec<f64>; 3]) -> bool {
    values.iter().any(|axis| {
        let mean = axis.iter().sum::<f64>() / axis.len().max(1) as f64;
        mean.abs() > GYRO_COUNTS_RADPS
    })
}

/// A gyro file as read: its times, its three value columns (the gyro whatever the reader took
/// them for) and whether the reader took them for raw counts.
struct GyroFile {
    time_s: Vec<f64>,
    values: [Vec<f64>; 3],
    reader_counts: bool,
}

/// Reads a gyro file with the recording's re-timing.
fn read_gyro_file(path: &Path, retime: bool) -> Result<GyroFile, GyroFileError> {
    let options = ReadOptions {
        retime,
        ..Default::default()
    };
    let loaded = formats::read_path(path, &options)?;
    let g = loaded.recording;
    Ok(GyroFile {
        time_s: g.time_s,
        values: g.gyro_radps.unwrap_or(g.accel_mps2),
        reader_counts: loaded.raw_counts || loaded.gyro_counts,
    })
}

/// The first of as many samples as `rec` whose time is off the recording's by more than half a
/// sample (at least 11 ms); `None` when the file samples beside it.
fn first_sample_off_time(time_s: &[f64], rec: &Recording) -> Option<usize> {
    let half = 0.5 / rec.sample_rate_hz();
    (0..time_s.len()).find(|&i| (time_s[i] - rec.time_s[i]).abs() > half.max(0.011))
}

/// A gyro file's three value columns, checked to sample beside `rec` (the same number of
/// samples at the same times, within half a sample), and whether the reader took them for raw
/// counts.
fn read_beside(path: &Path, rec: &Recording, retime: bool) -> Result<([Vec<f64>; 3], bool), GyroFileError> {
    let GyroFile {
        time_s,
        values,
        reader_counts,
    } = read_gyro_file(path, retime)?;
    let file = path.display().to_string();
    if time_s.len() != rec.len() {
        return Err(GyroFileError::Length {
            file,
            found: time_s.len(),
            expected: rec.len(),
        });
    }
    if let Some(i) = first_sample_off_time(&time_s, rec) {
        return Err(GyroFileError::Time {
            file,
            sample: i + 1,
            at_s: time_s[i],
            expected_s: rec.time_s[i],
        });
    }
    Ok((values, reader_counts))
}

/// A gyroscope at least this many of its median intervals from its neighbours is a dropped
/// stretch: a recording sample inside it gets no interpolated value.
pub const GYRO_GAP_INTERVALS: f64 = 3.0;

/// `recording` with the gyro of `path`: sample for sample when the file samples beside it, else
/// merged on time (one clock): the gyro interpolated linearly onto the recording's times, and the
/// recording's samples outside the gyro's span or in its gaps dropped. Refused when fewer than
/// half the samples are covered (the files are likely on different clocks). Returns the merged
/// recording, whether the gyro values are raw counts, and a note when merged on time.
pub fn attach_gyro_file(
    recording: Recording,
    path: &Path,
    retime: bool,
) -> Result<(Recording, bool, Option<String>), GyroFileError> {
    let GyroFile {
        time_s,
        values,
        reader_counts,
    } = read_gyro_file(path, retime)?;
    let counts = reader_counts || beyond_any_rate(&values);
    if time_s.len() == recording.len() && first_sample_off_time(&time_s, &recording).is_none() {
        let mut merged = recording;
        merged.gyro_radps = Some(values);
        return Ok((merged, counts, None));
    }
    let interval = crate::input::recording::sample_interval(&time_s);
    let widest = GYRO_GAP_INTERVALS * interval;
    let (keep, at_times) =
        crate::input::recording::interpolate_onto(&recording.time_s, &time_s, &values, widest);
    let covered = keep.iter().filter(|k| **k).count();
    let span = |t: &[f64]| {
        (
            t.first().copied().unwrap_or(f64::NAN),
            t.last().copied().unwrap_or(f64::NAN),
        )
    };
    if 2 * covered < recording.len() || covered < 2 {
        let ((gyro_from_s, gyro_to_s), (from_s, to_s)) = (span(&time_s), span(&recording.time_s));
        return Err(GyroFileError::NoOverlap {
            file: path.display().to_string(),
            covered,
            samples: recording.len(),
            gyro_from_s,
            gyro_to_s,
            from_s,
            to_s,
        });
    }
    let note = format!(
        "{}: the gyroscope ({} samples, {:.1} Hz) interpolated linearly onto the recording's {} timestamps ({:.1} Hz); {} samples outside its span or in its gaps (> {GYRO_GAP_INTERVALS} intervals) dropped",
        path.display(),
        time_s.len(),
        1.0 / interval,
        recording.len(),
        recording.sample_rate_hz(),
        recording.len() - covered
    );
    let mut merged = recording.select(&keep);
    merged.gyro_radps = Some(std::array::from_fn(|a| {
        at_times[a]
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(v, _)| *v)
            .collect()
    }));
    Ok((merged, counts, Some(note)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, rows: impl Iterator<Item = String>) -> std::path::PathBuf {
        let path = dir.join(name);
        // imu_tk's layout: `t gx gy gz`, whitespace, no header.
        let mut text = String::new();
        for row in rows {
            text.push_str(&row);
            text.push('\n');
        }
        std::fs::write(&path, text).unwrap();
        path
    }

    fn recording(n: usize, rate_hz: f64, start_s: f64) -> Recording {
        Recording {
            time_s: (0..n).map(|i| start_s + i as f64 / rate_hz).collect(),
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![9.81; n]],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        }
    }

    /// A gyro at 200 Hz starting 0.5 s late, beside an accelerometer at 100 Hz: the accelerometer's
    /// first 0.5 s are dropped and a linear gyro signal is interpolated exactly.
    #[test]
    fn a_gyro_on_its_own_samples_of_one_clock_is_merged_on_time() {
        let dir = tempfile::tempdir().unwrap();
        let gyro = write(
            dir.path(),
            "gyro.csv",
            (0..2000).map(|i| {
                let t = 0.5 + i as f64 / 200.0;
                format!("{t:.6} {:.9} 0.01 -0.02", 0.1 * t)
            }),
        );
        let (merged, counts, note) = attach_gyro_file(recording(1000, 100.0, 0.0), &gyro, false).unwrap();
        assert!(!counts);
        assert_eq!(merged.len(), 1000 - 50, "{note:?}");
        assert!(note.unwrap().contains("50 samples outside its span"));
        let g = merged.gyro_radps.unwrap();
        for (t, v) in merged.time_s.iter().zip(&g[0]) {
            assert!((v - 0.1 * t).abs() < 1e-8, "{t}: {v}");
        }
        // On another clock (starting 20 s later): refused with both spans.
        let far = write(
            dir.path(),
            "far.csv",
            (0..2000).map(|i| format!("{:.6} 0 0 0", 20.0 + i as f64 / 200.0)),
        );
        let e = attach_gyro_file(recording(1000, 100.0, 0.0), &far, false).unwrap_err();
        assert!(matches!(e, GyroFileError::NoOverlap { covered: 0, .. }), "{e}");
        assert!(e.to_string().contains("20.000–29.995 s"), "{e}");
        // Sample for sample beside it: attached as it is, no note.
        let beside = write(
            dir.path(),
            "beside.csv",
            (0..1000).map(|i| format!("{:.6} 0.5 0 0", i as f64 / 100.0)),
        );
        let (merged, _, note) = attach_gyro_file(recording(1000, 100.0, 0.0), &beside, false).unwrap();
        assert_eq!((merged.len(), note), (1000, None));
    }
}
