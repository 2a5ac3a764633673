//! The gyroscope beside a recording: the recording's own gyro columns, or a second file (imu_tk's
//! layout `t gx gy gz`, or any file of the session with gyro columns). The one rule for every
//! caller (a campaign entry's `gyro_file`, the commands' `--gyro-file`, `correct`'s stream): a
//! second file with its own time column is merged on time (interpolated onto the recording's
//! times, or, sampled beside them, taken sample for sample: [`crate::input::recording::Bracket::beside`]);
//! one without a time column (its time
//! synthesised from a sample rate) is taken sample for sample and must be as long. It is read with
//! the recording's reading flags that concern it ([`gyro_read_options`]).

use std::path::Path;

use crate::input::formats::{self, Format, FormatError, Loaded, ReadOptions};
use crate::input::recording::{gyro_only_map, ColumnMap, Recording, RecordingError};
use crate::input::table::{display_name, RowReader};

/// A gyro reading above this (rad/s, mean of an axis over the file) is taken for raw counts: no
/// handheld or turntable session turns that fast for long.
pub(crate) const GYRO_COUNTS_RADPS: f64 = 50.0;

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
        "{file}: {found} samples, but the recording has {expected}; a gyro file without a time column is taken sample for sample and must be as long (give it a time column to merge it on time)"
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
    #[error("{recording} has gyro columns already; a gyro file ({file}) is for a recording without them")]
    GyroTwice { file: String, recording: String },
    #[error("{file}: the model calibrates no gyroscope, so the gyro file has nothing to correct")]
    NotUsed { file: String },
}

/// The gyro of `loaded` (read from `recording_name` with `options`): from `gyro_file` when given
/// (attached by [`attach_gyro_file`], which may drop the recording's samples outside the gyro's
/// span), else its own gyro columns; `None` when it has none. Returns the note of a merge on time.
pub fn gyro_columns(
    gyro_file: Option<&Path>,
    loaded: &mut Loaded,
    recording_name: &str,
    options: &ReadOptions,
) -> Result<(Option<GyroColumns>, Option<String>), GyroFileError> {
    match gyro_file {
        Some(path) => {
            let note = attach_gyro_file(loaded, path, options)?;
            let name = path.display().to_string();
            Ok((
                GyroColumns::of(&loaded.recording, loaded.gyro_counts, &name),
                note,
            ))
        }
        None => Ok((
            GyroColumns::of(&loaded.recording, loaded.gyro_counts, recording_name),
            None,
        )),
    }
}

/// How a gyro file beside a recording read with `recording` is read: the same format, separator,
/// time unit, sample rate, re-timing and gyro unit and scale; not the recording's column choice
/// nor its accelerometer's unit, scale or offset.
pub fn gyro_read_options(recording: &ReadOptions) -> ReadOptions {
    let mut columns = ColumnMap {
        time_unit: recording.columns.time_unit,
        gyro_unit: recording.columns.gyro_unit,
        ..ColumnMap::default()
    };
    columns.table.delimiter = recording.columns.table.delimiter;
    ReadOptions {
        format: recording.format,
        columns,
        gyro_scale: recording.gyro_scale,
        sample_rate_hz: recording.sample_rate_hz,
        retime: recording.retime,
        ..ReadOptions::default()
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

/// A gyro file as read: its times, its three value columns in rad/s (or counts) and whether
/// they are raw counts, and whether the times are the file's own.
pub(crate) struct GyroFile {
    pub(crate) time_s: Vec<f64>,
    pub(crate) values: [Vec<f64>; 3],
    pub(crate) counts: bool,
    /// The file has a time column (not synthesised from a sample rate).
    pub(crate) timed: bool,
}

/// Reads a gyro file with `options` (from [`gyro_read_options`]): its gyro columns, or, when it
/// has none (imu_tk's `t gx gy gz`), the three it was read as acceleration, in the gyro's unit and
/// scale.
pub(crate) fn read_gyro_file(path: &Path, options: &ReadOptions) -> Result<GyroFile, GyroFileError> {
    let read = formats::read_path(path, options);
    // A header of time and gyro columns alone: read them in the places of time and acceleration,
    // by the column rules a recording's header is read with.
    let gyro_only = match &read {
        Err(FormatError::Recording(RecordingError::AmbiguousColumns { .. })) => {
            gyro_only_options(path, options)
        }
        _ => None,
    };
    let (loaded, options) = match &gyro_only {
        Some(gyro_only) => (formats::read_path(path, gyro_only)?, gyro_only),
        None => (read?, options),
    };
    let timed =
        options.sample_rate_hz.is_none() && !matches!(loaded.format, Format::Imucal | Format::Mpu6050);
    let g = loaded.recording;
    let (values, reader_counts) = match g.gyro_radps {
        Some(values) => (values, loaded.gyro_counts),
        None => {
            let unit = options.columns.gyro_unit.map_or(1.0, |u| u.to_si());
            let k = unit * options.gyro_scale.unwrap_or(1.0);
            let mut values = g.accel_mps2;
            if k != 1.0 {
                values.iter_mut().flatten().for_each(|v| *v *= k);
            }
            (values, loaded.raw_counts && options.gyro_scale.is_none())
        }
    };
    Ok(GyroFile {
        time_s: g.time_s,
        counts: reader_counts || beyond_any_rate(&values),
        values,
        timed,
    })
}

/// `options` for a delimited file whose header names time and three gyro columns and no
/// acceleration ([`gyro_only_map`]); `None` for any other file.
fn gyro_only_options(path: &Path, options: &ReadOptions) -> Option<ReadOptions> {
    let file = std::fs::File::open(path).ok()?;
    let reader = RowReader::new(
        std::io::BufReader::new(file),
        &display_name(path),
        &options.columns.table,
    )
    .ok()?;
    let columns = gyro_only_map(&reader.header, options.columns.clone());
    columns.columns.is_some().then(|| ReadOptions {
        columns,
        ..options.clone()
    })
}

/// A gyroscope at least this many of its median intervals from its neighbours is a dropped
/// stretch: a recording sample inside it gets no interpolated value.
pub const GYRO_GAP_INTERVALS: f64 = 3.0;

/// `loaded` with the gyro of the file at `path` (read with `options`, the recording's reading
/// options: [`gyro_read_options`] is applied here). A file without a time column is taken sample
/// for sample and must be as long; one with its own times is merged on time (one clock):
/// the gyro interpolated linearly onto the recording's times (the k-th sample taken as it is
/// while each pair lies within half the gyro's interval, `Bracket::beside`, the rule of
/// `correct`'s stream), and the recording's samples outside
/// the gyro's span or in its gaps dropped (labels with them), with a note in
/// `source.time_notes`, also returned. Refused when fewer than half the samples are covered (the
/// files are likely on different clocks), naming both spans, and when the recording has gyro
/// columns of its own. Sets `loaded.gyro_counts`.
pub fn attach_gyro_file(
    loaded: &mut Loaded,
    path: &Path,
    options: &ReadOptions,
) -> Result<Option<String>, GyroFileError> {
    let file = path.display().to_string();
    if loaded.recording.gyro_radps.is_some() {
        return Err(GyroFileError::GyroTwice {
            file,
            recording: loaded.recording.source.name.clone(),
        });
    }
    let gyro = read_gyro_file(path, &gyro_read_options(options))?;
    loaded.gyro_counts = gyro.counts;
    let recording = &mut loaded.recording;
    if !gyro.timed {
        if gyro.time_s.len() != recording.len() {
            return Err(GyroFileError::Length {
                file,
                found: gyro.time_s.len(),
                expected: recording.len(),
            });
        }
        recording.gyro_radps = Some(gyro.values);
        return Ok(None);
    }
    // A gyro sampled beside the recording is taken sample for sample, by the rule `correct`'s
    // stream follows (`Bracket::beside`, half the gyro's interval).
    let interval = crate::input::recording::sample_interval(&gyro.time_s);
    let widest = GYRO_GAP_INTERVALS * interval;
    let bracket = crate::input::recording::Bracket::new(widest).beside(0.5 * interval);
    let (keep, at_times, paired) =
        crate::input::recording::merge_onto(&recording.time_s, &gyro.time_s, &gyro.values, bracket);
    if paired == recording.len() {
        recording.gyro_radps = Some(at_times);
        return Ok(None);
    }
    let covered = keep.iter().filter(|k| **k).count();
    if 2 * covered < recording.len() || covered < 2 {
        let ((gyro_from_s, gyro_to_s), (from_s, to_s)) = (span(&gyro.time_s), span(&recording.time_s));
        return Err(GyroFileError::NoOverlap {
            file,
            covered,
            samples: recording.len(),
            gyro_from_s,
            gyro_to_s,
            from_s,
            to_s,
        });
    }
    let note = format!(
        "{file}: the gyroscope ({} samples, {:.1} Hz) interpolated linearly onto the recording's {} timestamps ({:.1} Hz){}; {} samples outside its span or in its gaps (> {GYRO_GAP_INTERVALS} intervals) dropped",
        gyro.time_s.len(),
        1.0 / interval,
        recording.len(),
        recording.sample_rate_hz(),
        beside_note(paired),
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
    merged.source.time_notes.push(note.clone());
    *recording = merged;
    if let Some(labels) = &mut loaded.labels {
        let mut k = keep.iter();
        labels.retain(|_| k.next().copied().unwrap_or(false));
    }
    Ok(Some(note))
}

/// Words for the first `paired` targets taken sample for sample, when any.
pub(crate) fn beside_note(paired: usize) -> String {
    if paired == 0 {
        String::new()
    } else {
        format!(" (the first {paired} taken sample for sample: each within half an interval of its row)")
    }
}

/// The first and last of `t` (NaN when empty).
fn span(t: &[f64]) -> (f64, f64) {
    (
        t.first().copied().unwrap_or(f64::NAN),
        t.last().copied().unwrap_or(f64::NAN),
    )
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

    fn recording(n: usize, rate_hz: f64, start_s: f64) -> Loaded {
        let recording = Recording {
            time_s: (0..n).map(|i| start_s + i as f64 / rate_hz).collect(),
            accel_mps2: [vec![0.0; n], vec![0.0; n], vec![9.81; n]],
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        };
        Loaded::new(recording, Format::Csv, false)
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
        let mut loaded = recording(1000, 100.0, 0.0);
        let note = attach_gyro_file(&mut loaded, &gyro, &ReadOptions::default()).unwrap();
        let merged = loaded.recording;
        assert!(!loaded.gyro_counts);
        assert_eq!(merged.len(), 1000 - 50, "{note:?}");
        assert!(note.unwrap().contains("50 samples outside its span"));
        assert_eq!(merged.source.time_notes.len(), 1);
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
        let e =
            attach_gyro_file(&mut recording(1000, 100.0, 0.0), &far, &ReadOptions::default()).unwrap_err();
        assert!(matches!(e, GyroFileError::NoOverlap { covered: 0, .. }), "{e}");
        assert!(e.to_string().contains("20.000–29.995 s"), "{e}");
        // Without a time of its own (time from a sample rate): sample for sample, no note, and
        // its length must match.
        let untimed = write(
            dir.path(),
            "untimed.csv",
            (0..1000).map(|i| format!("{i} 0.5 0 0")),
        );
        let rate = ReadOptions {
            sample_rate_hz: Some(100.0),
            ..Default::default()
        };
        let mut loaded = recording(1000, 100.0, 0.0);
        let note = attach_gyro_file(&mut loaded, &untimed, &rate).unwrap();
        assert_eq!((loaded.recording.len(), note), (1000, None));
        assert_eq!(loaded.recording.gyro_radps.unwrap()[0][999], 0.5);
        let e = attach_gyro_file(&mut recording(999, 100.0, 0.0), &untimed, &rate).unwrap_err();
        assert!(
            matches!(
                e,
                GyroFileError::Length {
                    found: 1000,
                    expected: 999,
                    ..
                }
            ),
            "{e}"
        );
        // A recording with gyro columns of its own takes no second one.
        let mut own = recording(1000, 100.0, 0.0);
        own.recording.gyro_radps = Some(std::array::from_fn(|_| vec![0.0; 1000]));
        let e = attach_gyro_file(&mut own, &gyro, &ReadOptions::default()).unwrap_err();
        assert!(matches!(e, GyroFileError::GyroTwice { .. }), "{e}");
    }
}
