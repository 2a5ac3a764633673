//! An accelerometer and a gyroscope recorded on their own sample clocks, made one recording.
//!
//! The rule: the accelerometer's timestamps are the recording's; the gyroscope is linearly
//! interpolated onto each of them from the two gyroscope samples around it. An accelerometer
//! sample before the first or after the last gyroscope sample, or inside a gyroscope gap wider
//! than [`PAIR_GAP_INTERVALS`] median gyroscope intervals, is dropped (never extrapolated), and
//! the notes say how many. Interpolation, not the nearest sample, so that a 1 % rate difference
//! between the two clocks does not turn into a sawtooth of up to one gyroscope period in time.

use super::super::{Format, FormatError, Loaded};
use super::text::Stream;
use super::PhoneError;
use crate::input::recording::{interpolate_onto, sample_interval, Recording, RecordingError, Source};
use crate::input::table::Location;

/// An accelerometer sample is dropped when the gyroscope samples around it are further apart
/// than this many median gyroscope intervals (a dropped gyroscope stretch, not jitter).
pub const PAIR_GAP_INTERVALS: f64 = 3.0;

/// Time must not go backwards within a stream (equal stamps are kept, as for any recording).
fn check_order(s: &Stream) -> Result<(), FormatError> {
    for i in 1..s.len() {
        if s.time_s[i] < s.time_s[i - 1] {
            return Err(RecordingError::TimeNotIncreasing {
                at: Location {
                    file: s.file.clone(),
                    line: s.lines.get(i).copied().unwrap_or(i + 1),
                    column: None,
                    column_name: None,
                },
                previous: s.time_s[i - 1],
                current: s.time_s[i],
            }
            .into());
        }
    }
    Ok(())
}

/// The recording of `accel` (and `gyro`, interpolated onto the accelerometer's times), named
/// `name`, read as `format`, with the reader's `notes` and the pairing's.
pub(crate) fn merge(
    accel: Stream,
    gyro: Option<Stream>,
    name: &str,
    format: Format,
    mut notes: Vec<String>,
) -> Result<Loaded, FormatError> {
    check_order(&accel)?;
    if accel.len() < 2 {
        return Err(RecordingError::TooShort {
            file: accel.file.clone(),
            found: accel.len(),
            needed: 2,
        }
        .into());
    }
    let mut columns = accel.columns.clone();
    let (keep, gyro_radps) = match &gyro {
        None => (vec![true; accel.len()], None),
        Some(g) => {
            check_order(g)?;
            let (keep, values) = interpolate(&accel, g)?;
            columns.extend(g.columns.iter().skip(1).cloned());
            let dropped = keep.iter().filter(|k| !**k).count();
            notes.push(format!(
                "gyroscope ({}: {} samples, {:.1} Hz) interpolated linearly onto the accelerometer's {} timestamps ({:.1} Hz){}",
                g.file,
                g.len(),
                1.0 / sample_interval(&g.time_s),
                accel.len(),
                1.0 / sample_interval(&accel.time_s),
                if dropped > 0 {
                    format!(
                        "; {dropped} accelerometer samples outside the gyroscope's span or in its gaps (> {PAIR_GAP_INTERVALS} intervals) dropped"
                    )
                } else {
                    String::new()
                }
            ));
            (keep, Some(values))
        }
    };
    let pick = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    let recording = Recording {
        time_s: pick(&accel.time_s),
        accel_mps2: std::array::from_fn(|a| pick(&accel.xyz[a])),
        gyro_radps: gyro_radps.map(|g: [Vec<f64>; 3]| std::array::from_fn(|a| pick(&g[a]))),
        temperature_c: None,
        source: Source {
            name: name.into(),
            format: format.name().into(),
            columns,
            metadata: Vec::new(),
            lines: accel
                .lines
                .iter()
                .zip(&keep)
                .filter(|(_, k)| **k)
                .map(|(l, _)| *l)
                .collect(),
            incomplete_rows: Default::default(),
            time_notes: Vec::new(),
        },
    };
    if recording.len() < 2 {
        let g = gyro.as_ref();
        return Err(PhoneError::NoOverlap {
            accel: accel.file.clone(),
            gyro: g.map(|g| g.file.clone()).unwrap_or_default(),
            accel_span: accel.span(),
            gyro_span: g.map(Stream::span).unwrap_or_default(),
            why: "",
        }
        .into());
    }
    let mut l = Loaded::new(recording, format, false);
    l.notes = notes;
    Ok(l)
}

/// The gyroscope at each accelerometer time, and which accelerometer samples have one.
fn interpolate(accel: &Stream, gyro: &Stream) -> Result<(Vec<bool>, [Vec<f64>; 3]), FormatError> {
    let widest = PAIR_GAP_INTERVALS * sample_interval(&gyro.time_s);
    Ok(interpolate_onto(&accel.time_s, &gyro.time_s, &gyro.xyz, widest))
}

/// Reads the accelerometer of one phyphox zip and the gyroscope of another, put on one clock by
/// their `meta/time.csv` (experiment time → Unix time → the accelerometer's experiment time).
/// Refused when either has no time reference or when their spans do not overlap.
#[cfg(feature = "phone")]
pub fn read_pair(
    accel_path: &std::path::Path,
    gyro_path: &std::path::Path,
    options: &super::super::ReadOptions,
) -> Result<Loaded, FormatError> {
    use super::phyphox::{sets, TimeReference};
    let load = |path: &std::path::Path| -> Result<(String, super::text::Members), FormatError> {
        let file = path.display().to_string();
        let bytes = crate::input::table::read_file(path).map_err(|source| FormatError::Io {
            file: file.clone(),
            source,
        })?;
        Ok((file.clone(), super::archive::members(&bytes, &file)?))
    };
    let (accel_file, accel_members) = load(accel_path)?;
    let (gyro_file, gyro_members) = load(gyro_path)?;
    let accel_sets = sets(&accel_members)?;
    let gyro_sets = sets(&gyro_members)?;
    let accel = accel_sets.accel.ok_or_else(|| PhoneError::NoAccelerometer {
        file: accel_file.clone(),
        found: accel_members.listing(),
        hint: "the first export must hold the accelerometer",
    })?;
    let gyro = gyro_sets.gyro.ok_or_else(|| FormatError::MissingColumn {
        file: gyro_file.clone(),
        name: "Gyroscope x (rad/s)".into(),
        available: gyro_members.listing(),
    })?;
    let accel_ref = TimeReference::read(&accel_members)?.ok_or(PhoneError::NoTimeReference {
        file: accel_file.clone(),
    })?;
    let gyro_ref = TimeReference::read(&gyro_members)?.ok_or(PhoneError::NoTimeReference {
        file: gyro_file.clone(),
    })?;
    // Both spans in Unix time.
    let unix_span = |s: &Stream, r: &TimeReference| match (s.time_s.first(), s.time_s.last()) {
        (Some(&a), Some(&b)) => (r.unix_time_of(a), r.unix_time_of(b)),
        _ => (f64::NAN, f64::NAN),
    };
    let (a0, a1) = unix_span(&accel, &accel_ref);
    let (g0, g1) = unix_span(&gyro, &gyro_ref);
    let overlap = a1.min(g1) - a0.max(g0);
    if overlap.is_nan() || overlap <= 0.0 {
        return Err(PhoneError::NoOverlap {
            accel: accel_file,
            gyro: gyro_file,
            accel_span: format!("Unix time {a0:.3} … {a1:.3} s"),
            gyro_span: format!("{g0:.3} … {g1:.3} s"),
            why: " by their meta/time.csv: they are not of one session",
        }
        .into());
    }
    // The gyroscope's times on the accelerometer's experiment clock; samples taken while the
    // accelerometer's experiment was paused have no such time and are left out.
    let mut moved = gyro.clone();
    let mut keep = Vec::with_capacity(gyro.len());
    moved.time_s.clear();
    for &t in &gyro.time_s {
        let on_accel = accel_ref.experiment_time_at(gyro_ref.unix_time_of(t));
        keep.push(on_accel.is_some());
        moved.time_s.extend(on_accel);
    }
    let pick = |v: &[f64]| -> Vec<f64> {
        v.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    moved.xyz = std::array::from_fn(|a| pick(&gyro.xyz[a]));
    moved.lines = gyro
        .lines
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(l, _)| *l)
        .collect();
    let _ = options;
    let notes = vec![format!(
        "two exports put on one clock by their meta/time.csv (system time, whole milliseconds): {} from {accel_file}, {} from {gyro_file}",
        accel_ref.file, gyro_ref.file
    )];
    merge(accel, Some(moved), &accel_file, Format::PhyphoxZip, notes)
}
