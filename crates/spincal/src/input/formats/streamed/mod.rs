//! `spincal inspect` on a delimited text file (formats `csv` and `whitespace`) in constant memory:
//! the file is read row by row ([`RowReader`](crate::input::table::RowReader)) as many times as the figures need, never held.
//!
//! Rows go through the same conversion as the whole-file reader, a block of `BLOCK_ROWS` rows
//! at a time ([`Recording::from_table_timed`] on each block), so columns, units and values are
//! the same; time is checked across blocks as [`Recording::check_time`] checks it. The figures are
//! [`inspect`]'s, computed from the rows:
//!
//! - pass 1: samples, first and last time, the smallest positive step, repeated and backward
//!   stamps, each axis's extremes, the windowed rates that `sample_interval` takes the median of
//!   (one per 64 samples), the norms whose median tells raw counts in a whitespace file, the
//!   temperature's distinct values;
//! - medians are exact, not estimated: each is the k-th smallest value in `f64::total_cmp` order,
//!   found by `Kth`: the values are kept when at most `KEEP` of them are in play, else a
//!   histogram of 2¹⁶ buckets on the next 16 bits of their order key narrows the range and the
//!   file is read again (at most four such passes for 64-bit keys; a 1 GB recording's rates, one
//!   per 64 samples, fit in the first). The temperature's distinct values are counted the same
//!   way: at most `KEEP_DISTINCT` per pass, the smallest first.
//! - the last pass: gaps (they need the median interval and the clock's tick) and flat tops
//!   (they need each axis's extremes).
//!
//! A file this reader refuses for any reason (a bad row, time going backwards, a file that changes
//! between passes, a pipe) is read again by the whole-file reader, so every message is the one that
//! reader gives: the two differ only there (the streaming reader refuses an empty cell in a column
//! that is not used; the whole-file reader reads past it).

use std::path::Path;

use super::{
    check_options, finish, read_path, table_options, whitespace_map, Detection, Format, FormatError, Loaded,
    ReadOptions, RAW_COUNTS_MPS2,
};
use crate::input::inspect::{inspect, Inspection};
use crate::input::recording::{Recording, Source};
use crate::input::table::Delimiter;

mod first;
mod last;
mod median;
mod reading;

use first::{norm, First, Rates};
use last::{axis_findings, gyro_findings, last_pass};
use reading::{Reading, Shape};

/// Rows converted at a time.
pub(crate) const BLOCK_ROWS: usize = 1 << 14;

/// Values a median search keeps in memory (2 MiB); beyond, it narrows by histogram and rereads.
pub(crate) const KEEP: usize = 1 << 18;

/// Distinct temperatures counted per pass.
pub(crate) const KEEP_DISTINCT: usize = 1 << 16;

/// Windows of [`sample_interval`] once a recording has 513 samples or more.
const WINDOW: usize = 64;

/// Reads `path` and inspects it ([`inspect`] with `range_mps2`). A delimited text file (format
/// `csv` or `whitespace`, given or detected) in a regular file is streamed in constant memory; the
/// returned [`Loaded`] then carries the recording's `source` (name, format, columns, metadata) and
/// no samples. Any other file is read whole by [`read_path`] and inspected.
pub fn inspect_path(
    path: &Path,
    options: &ReadOptions,
    range_mps2: Option<f64>,
) -> Result<(Loaded, Inspection), FormatError> {
    // A FIFO or device is refused before anything opens it (opening a FIFO blocks); a
    // streamed text file may be of any size, the whole-file reader's limit applies to the rest.
    crate::input::limits::check_file(path, None).map_err(|source| FormatError::Io {
        file: path.display().to_string(),
        source,
    })?;
    if let Some(found) = stream(path, options, range_mps2)? {
        return Ok(found);
    }
    let loaded = read_path(path, options)?;
    let inspection = inspect(&loaded.recording, range_mps2);
    Ok((loaded, inspection))
}

/// Why the streaming reader gave the file back to the whole-file reader.
struct Declined;

/// `Ok(None)`: not a streamable file, or declined; the caller reads it whole.
fn stream(
    path: &Path,
    options: &ReadOptions,
    range_mps2: Option<f64>,
) -> Result<Option<(Loaded, Inspection)>, FormatError> {
    // A file that cannot be read is the whole-file reader's to refuse, with its message.
    let Ok(Some((format, detection))) = super::delimited_text_format(path, options.format) else {
        return Ok(None);
    };
    // The whole-file reader's own errors for bad options and a bad scale.
    check_options(options)?;
    // A gyro scale is the whole-file reader's to apply.
    if options.accel_scale.is_some_and(|s| !s.is_finite() || s == 0.0) || options.gyro_scale.is_some() {
        return Ok(None);
    }
    match streamed(path, options, format, detection, range_mps2) {
        Ok(found) => Ok(Some(found)),
        Err(Declined) => Ok(None),
    }
}

/// Inspects a delimited text file in passes: re-timing first when asked, then pass 1, the
/// medians, and the last pass.
fn streamed(
    path: &Path,
    options: &ReadOptions,
    format: Format,
    detection: Option<Detection>,
    range_mps2: Option<f64>,
) -> Result<(Loaded, Inspection), Declined> {
    let default = (format == Format::Whitespace).then_some(Delimiter::Whitespace);
    let mut src = Reading {
        path,
        file: path.display().to_string(),
        table: table_options(options, default),
        format,
        options,
        retimed: None,
        samples: None,
    };
    let mut shape = None;
    if options.retime {
        retime(&mut src, &mut shape)?;
    }
    // Pass 1.
    let mut p = First::new();
    let n = src.each(&mut shape, |i, s| p.push(i, s))?;
    src.samples = Some(n);
    let Some(shape) = shape else {
        return Err(Declined);
    };
    let dt = p.rates.resolve(&src, &mut None)?;
    let raw_counts = format == Format::Whitespace && {
        let mut norms = p.norms;
        n > 0 && norms.resolve((n / 2) as u64, &src, |s| norm(&s.raw))? > RAW_COUNTS_MPS2
    };
    let temperature = if p.has_temperature {
        p.temperature.resolve(&src)?
    } else {
        None
    };
    let (min, max) = (p.min, p.max);
    let mut last = last_pass(
        &src,
        p.quantum,
        dt,
        (min, max),
        (p.gyro_min, p.gyro_max),
        range_mps2,
    )?;
    let (saturation, constant_axes) = axis_findings(&mut last.tops, (min, max), n, range_mps2);
    let gyro_saturation = gyro_findings(&last.gyro_tops);
    let inspection = Inspection {
        samples: n,
        duration_s: if n > 0 { p.last - p.first } else { 0.0 },
        sample_rate_hz: 1.0 / dt,
        gaps: last.gaps,
        gap_count: last.gap_count,
        repeated_times: p.repeated.0,
        first_repeated_line: p.repeated.1,
        backward_steps: p.backward.0,
        first_backward_line: p.backward.1,
        saturation,
        gyro_saturation,
        constant_axes,
        accel_min_mps2: if n > 0 { min } else { [f64::NAN; 3] },
        accel_max_mps2: if n > 0 { max } else { [f64::NAN; 3] },
        has_gyro: shape.has_gyro,
        temperature,
    };
    let loaded = loaded_without_samples(shape.source, format, raw_counts, detection, options, src.retimed)?;
    Ok((loaded, inspection))
}

/// `--retime`: Δt from the file's own stamps, as `retime` takes it, before anything else.
fn retime(src: &mut Reading, shape: &mut Option<Shape>) -> Result<(), Declined> {
    let mut first = None;
    let mut rates = Rates::new();
    let n = src.each(shape, |_, s| {
        first.get_or_insert(s.t);
        rates.push(s.t);
    })?;
    src.samples = Some(n);
    let dt = rates.resolve(src, shape)?;
    if let (Some(t0), true) = (first, dt.is_finite()) {
        src.retimed = Some((t0, dt));
    }
    Ok(())
}

/// The same `Loaded` the whole-file reader gives, without the samples.
fn loaded_without_samples(
    source: Source,
    format: Format,
    raw_counts: bool,
    detection: Option<Detection>,
    options: &ReadOptions,
    retimed: Option<(f64, f64)>,
) -> Result<Loaded, Declined> {
    let mut loaded = Loaded::new(
        Recording {
            time_s: Vec::new(),
            accel_mps2: [Vec::new(), Vec::new(), Vec::new()],
            gyro_radps: None,
            temperature_c: None,
            source,
        },
        format,
        raw_counts,
    );
    if raw_counts {
        loaded
            .notes
            .push("values look like raw counts (|a| ≫ 20 g): pass --accel-scale to convert".into());
    }
    // `finish` adds the notes for the rate, the scale and re-timing; re-timing and the scale were
    // applied above, sample by sample, so they are asked of it with no samples to change.
    let mut loaded = finish(loaded, detection, options).map_err(|_| Declined)?;
    if !options.retime {
        return Ok(loaded);
    }
    if let Some((t0, dt)) = retimed {
        loaded.notes.push(format!(
            "re-timed: t = {t0} s + i · {dt:.9} s (from all timestamps)"
        ));
    }
    Ok(loaded)
}

#[cfg(test)]
mod tests;
