//! What every reader shares: its options checked, the table read, raw counts scaled, time
//! rebuilt, the result wrapped as [`Loaded`].

use super::mat;
use super::{Detection, Format, FormatError, Loaded, ReadOptions};
use crate::input::recording::Recording;
use crate::input::table::{Delimiter, Table, TableOptions};

pub(super) fn check_options(options: &ReadOptions) -> Result<(), FormatError> {
    if let Some(rate) = options.sample_rate_hz {
        if !(rate.is_finite() && rate > 0.0) {
            return Err(FormatError::BadOption {
                name: "sample_rate_hz",
                value: rate.to_string(),
                why: "must be a finite positive rate in Hz",
            });
        }
    }
    if let Some(offset) = options.accel_offset {
        if offset.iter().any(|v| !v.is_finite()) {
            return Err(FormatError::BadOption {
                name: "accel_offset",
                value: format!("{offset:?}"),
                why: "every offset must be finite",
            });
        }
    }
    Ok(())
}

/// What every reader's result goes through: detection kept, scale and offset, re-timing.
pub(super) fn finish(
    mut loaded: Loaded,
    detection: Option<Detection>,
    options: &ReadOptions,
) -> Result<Loaded, FormatError> {
    loaded.detection = detection;
    loaded.recording.source.format = loaded.format.name().into();
    if let Some(left_out) = loaded.recording.source.incomplete_rows.describe() {
        loaded.notes.push(left_out);
    }
    loaded
        .notes
        .extend(loaded.recording.source.time_notes.iter().cloned());
    if let (Some(rate), Format::Csv | Format::Whitespace | Format::Phyphox | Format::Mat) =
        (options.sample_rate_hz, loaded.format)
    {
        // The rate given won over the file's time column (a sample index, or a coarse clock).
        let column = loaded
            .recording
            .source
            .columns
            .first()
            .cloned()
            .unwrap_or_default();
        loaded.notes.push(format!(
            "time = sample number / {rate} Hz (`sample_rate_hz` given; the `{column}` column is not used)"
        ));
    }
    apply_scale(&mut loaded, options)?;
    if options.retime {
        retime(&mut loaded);
    }
    Ok(loaded)
}

/// Reads the columns `keys` (header names or 1-based indices) of a numeric table in any tabular
/// format: a MAT-file (by its first bytes) or delimited text. Only those columns are kept, in that
/// order, so an empty cell elsewhere in a text file is no error.
pub fn read_table(
    bytes: &[u8],
    file: &str,
    options: &TableOptions,
    keys: &[&str],
) -> Result<Table, FormatError> {
    let table = if mat::is_mat(bytes) {
        mat::table(&mat::parse(bytes, file)?, file)?
    } else {
        return Ok(Table::parse_columns(bytes, file, options, keys)?);
    };
    let picked: Vec<usize> = keys
        .iter()
        .map(|k| {
            table.column_index(k).ok_or_else(|| FormatError::MissingColumn {
                file: file.into(),
                name: k.to_string(),
                available: table.header.join(", "),
            })
        })
        .collect::<Result<_, _>>()?;
    Ok(Table {
        header: picked.iter().map(|&c| table.header[c].clone()).collect(),
        columns: picked.iter().map(|&c| table.columns[c].clone()).collect(),
        ..table
    })
}

/// A MAT-file: its numeric variables as a table, then the columns as for `csv`.
pub(super) fn read_mat(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let parsed = mat::parse(bytes, file)?;
    let table = mat::table(&parsed, file)?;
    let recording = Recording::from_table_timed(&table, &options.columns, options.sample_rate_hz)?;
    let mut l = Loaded::new(recording, Format::Mat, false);
    for s in &parsed.skipped {
        l.notes.push(format!("variable '{}' skipped: {}", s.name, s.why));
    }
    Ok(l)
}

/// Evenly spaced timestamps at the rate all the stamps give, from the first stamp.
pub(super) fn retime(loaded: &mut Loaded) {
    let t = &mut loaded.recording.time_s;
    let dt = crate::input::recording::sample_interval(t);
    if let (Some(&t0), true) = (t.first(), dt.is_finite()) {
        for (i, v) in t.iter_mut().enumerate() {
            *v = t0 + i as f64 * dt;
        }
        loaded.notes.push(format!(
            "re-timed: t = {t0} s + i · {dt:.9} s (from all timestamps)"
        ));
    }
}

impl Loaded {
    pub(crate) fn new(recording: Recording, format: Format, raw_counts: bool) -> Loaded {
        Loaded {
            recording,
            format,
            detection: None,
            raw_counts,
            gyro_counts: false,
            labels: None,
            gx1: None,
            flight: None,
            notes: Vec::new(),
        }
    }
}

pub(super) fn apply_scale(loaded: &mut Loaded, options: &ReadOptions) -> Result<(), FormatError> {
    apply_gyro_scale(loaded, options)?;
    if options.accel_scale.is_none() && options.accel_offset.is_none() {
        return Ok(());
    }
    let scale = options.accel_scale.unwrap_or(1.0);
    if !scale.is_finite() || scale == 0.0 {
        return Err(FormatError::BadScale(scale));
    }
    let offset = options.accel_offset.unwrap_or([0.0; 3]);
    for (axis, b) in loaded.recording.accel_mps2.iter_mut().zip(offset) {
        axis.iter_mut().for_each(|v| *v = (*v - b) * scale);
    }
    if options.accel_scale.is_some() {
        loaded.raw_counts = false;
    }
    loaded
        .notes
        .push(format!("accel = (value − {offset:?}) × {scale} applied"));
    Ok(())
}

/// The gyro columns times `gyro_scale` (as `accel_scale`: per count, or per file unit).
fn apply_gyro_scale(loaded: &mut Loaded, options: &ReadOptions) -> Result<(), FormatError> {
    let Some(scale) = options.gyro_scale else {
        return Ok(());
    };
    if !scale.is_finite() || scale == 0.0 {
        return Err(FormatError::BadScale(scale));
    }
    match &mut loaded.recording.gyro_radps {
        Some(gyro) => {
            gyro.iter_mut().flatten().for_each(|v| *v *= scale);
            loaded.gyro_counts = false;
            loaded
                .notes
                .push(format!("gyro = value × {scale:e} rad/s applied"));
        }
        None => loaded
            .notes
            .push("a gyro scale was given but the file has no gyro columns".into()),
    }
    Ok(())
}

pub(super) fn table_options(options: &ReadOptions, default: Option<Delimiter>) -> TableOptions {
    let mut table = options.columns.table.clone();
    table.delimiter = table.delimiter.or(default);
    table
}
