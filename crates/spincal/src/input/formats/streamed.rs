//! `spincal inspect` on a delimited text file (formats `csv` and `whitespace`) in constant memory:
//! the file is read row by row ([`RowReader`]) as many times as the figures need, never held.
//!
//! Rows go through the same conversion as the whole-file reader, a block of `BLOCK_ROWS` rows
//! at a time ([`Recording::from_table_timed`] on each block), so columns, units and values are
//! the same; time is checked across blocks as [`Recording::check_time`] checks it. The figures are
//! [`inspect`]'s, computed from the rows:
//!
//! - pass 1: samples, first and last time, the smallest positive step, repeated and backward
//!   stamps, each axis's extremes, the windowed rates that [`sample_interval`] takes the median of
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

use std::collections::BTreeSet;
use std::io::BufReader;
use std::path::Path;

use super::{
    check_options, finish, read_path, table_options, whitespace_map, Detection, Format, FormatError, Loaded,
    ReadOptions, RAW_COUNTS_MPS2,
};
use crate::input::inspect::{
    inspect, Gap, Inspection, Saturation, TemperatureSummary, GAP_FACTOR, LISTED_GAPS, RAIL_SAMPLES,
    RANGE_SHARE,
};
use crate::input::recording::{sample_interval, Recording, Source};
use crate::input::table::{Delimiter, RowReader, Table, TableOptions};

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
    if options.accel_scale.is_some_and(|s| !s.is_finite() || s == 0.0) {
        return Ok(None);
    }
    match streamed(path, options, format, detection, range_mps2) {
        Ok(found) => Ok(Some(found)),
        Err(Declined) => Ok(None),
    }
}

/// One sample as inspection sees it.
struct Sample {
    line: usize,
    t: f64,
    /// Acceleration as the file's columns give it in SI (before `accel_scale`).
    raw: [f64; 3],
    /// After `accel_offset` and `accel_scale`.
    accel: [f64; 3],
    temperature: Option<f64>,
}

/// How samples are read: the file, its table options and column map, and the time rule.
struct Reading<'a> {
    path: &'a Path,
    file: String,
    table: TableOptions,
    format: Format,
    options: &'a ReadOptions,
    /// `--retime`: t = t₀ + i·Δt.
    retimed: Option<(f64, f64)>,
    /// Samples seen by the first pass; every later pass must see as many.
    samples: Option<usize>,
}

/// What the first block tells about the recording.
struct Shape {
    source: Source,
    has_gyro: bool,
}

impl Reading<'_> {
    /// Reads every sample in order; the shape of the recording is given once, before the first.
    fn each(&self, shape: &mut Option<Shape>, mut f: impl FnMut(usize, &Sample)) -> Result<usize, Declined> {
        let file = std::fs::File::open(self.path).map_err(|_| Declined)?;
        let mut rows = RowReader::new(BufReader::with_capacity(1 << 20, file), &self.file, &self.table)
            .map_err(|_| Declined)?;
        let width = rows.width();
        let mut map = self.options.columns.clone();
        if self.format == Format::Whitespace {
            map = whitespace_map(map, rows.header.is_empty(), width);
        }
        let rate = self.options.sample_rate_hz;
        let (scale, offset) = (
            self.options.accel_scale.unwrap_or(1.0),
            self.options.accel_offset.unwrap_or([0.0; 3]),
        );
        let scaled = self.options.accel_scale.is_some() || self.options.accel_offset.is_some();
        let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(BLOCK_ROWS); width];
        let mut lines = Vec::with_capacity(BLOCK_ROWS);
        let mut values = Vec::with_capacity(width);
        let (mut index, mut previous) = (0usize, f64::NEG_INFINITY);
        loop {
            let row = rows.next_row(&mut values).map_err(|_| Declined)?;
            if let Some(line) = row {
                for (column, v) in columns.iter_mut().zip(&values) {
                    column.push(*v);
                }
                lines.push(line);
            }
            if lines.len() == BLOCK_ROWS || (row.is_none() && !lines.is_empty()) {
                let table = Table {
                    file: self.file.clone(),
                    delimiter: rows.delimiter,
                    header: rows.header.clone(),
                    metadata: rows.metadata.clone(),
                    columns: std::mem::take(&mut columns),
                    lines: std::mem::take(&mut lines),
                };
                let block = Recording::from_table_timed(&table, &map, rate).map_err(|_| Declined)?;
                if shape.is_none() {
                    let mut source = block.source.clone();
                    source.lines = Vec::new();
                    *shape = Some(Shape {
                        source,
                        has_gyro: block.gyro_radps.is_some(),
                    });
                }
                for i in 0..block.len() {
                    let t = match (rate, self.retimed) {
                        (_, Some((t0, dt))) => t0 + index as f64 * dt,
                        (Some(rate), None) => index as f64 / rate,
                        (None, None) => block.time_s[i],
                    };
                    // Time across blocks, as `check_time` checks it within one.
                    let stamp = if rate.is_some() { t } else { block.time_s[i] };
                    if stamp < previous {
                        return Err(Declined);
                    }
                    previous = stamp;
                    let raw = [0, 1, 2].map(|a| block.accel_mps2[a][i]);
                    let accel = if scaled {
                        [0, 1, 2].map(|a| (raw[a] - offset[a]) * scale)
                    } else {
                        raw
                    };
                    f(
                        index,
                        &Sample {
                            line: table.lines[i],
                            t,
                            raw,
                            accel,
                            temperature: block.temperature_c.as_ref().map(|c| c[i]),
                        },
                    );
                    index += 1;
                }
                let mut reused = table.columns;
                reused.iter_mut().for_each(Vec::clear);
                columns = reused;
                lines = table.lines;
                lines.clear();
            }
            if row.is_none() {
                break;
            }
        }
        if self.samples.is_some_and(|n| n != index) {
            return Err(Declined);
        }
        Ok(index)
    }
}

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
        // Δt from the file's own stamps, as `retime` takes it, before anything else.
        let mut first = None;
        let mut rates = Rates::new();
        let n = src.each(&mut shape, |_, s| {
            first.get_or_insert(s.t);
            rates.push(s.t);
        })?;
        src.samples = Some(n);
        let dt = rates.resolve(&src, &mut shape)?;
        if let (Some(t0), true) = (first, dt.is_finite()) {
            src.retimed = Some((t0, dt));
        }
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
    // The last pass: gaps and flat tops.
    let quantum = p.quantum;
    let gap_threshold = if (quantum / dt - 1.0).abs() > 0.1 {
        (GAP_FACTOR * dt).max(dt + quantum)
    } else {
        GAP_FACTOR * dt
    };
    let (min, max) = (p.min, p.max);
    let mut gaps = Vec::new();
    let mut gap_count = 0;
    let mut last = (f64::NAN, 0usize);
    let mut tops: [Tops; 3] = std::array::from_fn(|_| Tops::default());
    src.each(&mut None, |i, s| {
        if i > 0 {
            let length_s = s.t - last.0;
            if length_s > gap_threshold {
                gap_count += 1;
                if gaps.len() < LISTED_GAPS {
                    gaps.push(Gap {
                        line: s.line,
                        index: i,
                        start_s: last.0,
                        length_s,
                    });
                }
            }
        }
        last = (s.t, s.line);
        for a in 0..3 {
            if min[a] != max[a] {
                tops[a].push(s.line, s.accel[a], min[a], max[a], range_mps2);
            }
        }
    })?;
    let mut saturation = Vec::new();
    let mut constant_axes = Vec::new();
    for a in 0..3 {
        let name = ['x', 'y', 'z'][a];
        if n == 0 {
            continue;
        }
        if min[a] == max[a] {
            constant_axes.push(name);
            continue;
        }
        tops[a].end(min[a], max[a]);
        if let Some((first_line, limit)) = tops[a].first {
            saturation.push(Saturation {
                axis: name,
                samples: tops[a].samples,
                first_line,
                limit_mps2: range_mps2.unwrap_or(limit),
            });
        }
    }
    let inspection = Inspection {
        samples: n,
        duration_s: if n > 0 { p.last - p.first } else { 0.0 },
        sample_rate_hz: 1.0 / dt,
        gaps,
        gap_count,
        repeated_times: p.repeated.0,
        first_repeated_line: p.repeated.1,
        backward_steps: p.backward.0,
        first_backward_line: p.backward.1,
        saturation,
        constant_axes,
        accel_min_mps2: if n > 0 { min } else { [f64::NAN; 3] },
        accel_max_mps2: if n > 0 { max } else { [f64::NAN; 3] },
        has_gyro: shape.has_gyro,
        temperature,
    };
    // The same `Loaded` the whole-file reader gives, without the samples.
    let mut loaded = Loaded::new(
        Recording {
            time_s: Vec::new(),
            accel_mps2: [Vec::new(), Vec::new(), Vec::new()],
            gyro_radps: None,
            temperature_c: None,
            source: shape.source,
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
        return Ok((loaded, inspection));
    }
    if let Some((t0, dt)) = src.retimed {
        loaded.notes.push(format!(
            "re-timed: t = {t0} s + i · {dt:.9} s (from all timestamps)"
        ));
    }
    Ok((loaded, inspection))
}

/// The norm the whole-file reader takes the median of to tell raw counts.
fn norm(a: &[f64; 3]) -> f64 {
    (a[0].powi(2) + a[1].powi(2) + a[2].powi(2)).sqrt()
}

/// The first pass's figures.
struct First {
    first: f64,
    last: f64,
    quantum: f64,
    repeated: (usize, Option<usize>),
    backward: (usize, Option<usize>),
    min: [f64; 3],
    max: [f64; 3],
    rates: Rates,
    norms: Kth,
    has_temperature: bool,
    temperature: Distinct,
}

impl First {
    fn new() -> First {
        First {
            first: f64::NAN,
            last: f64::NAN,
            quantum: f64::INFINITY,
            repeated: (0, None),
            backward: (0, None),
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
            rates: Rates::new(),
            norms: Kth::new(),
            has_temperature: false,
            temperature: Distinct::new(),
        }
    }

    fn push(&mut self, i: usize, s: &Sample) {
        if i == 0 {
            self.first = s.t;
        } else {
            let step = s.t - self.last;
            if step > 0.0 {
                self.quantum = self.quantum.min(step);
            } else if step == 0.0 {
                self.repeated.0 += 1;
                self.repeated.1.get_or_insert(s.line);
            } else if step < 0.0 {
                self.backward.0 += 1;
                self.backward.1.get_or_insert(s.line);
            }
        }
        self.last = s.t;
        for a in 0..3 {
            self.min[a] = self.min[a].min(s.accel[a]);
            self.max[a] = self.max[a].max(s.accel[a]);
        }
        self.rates.push(s.t);
        self.norms.push(norm(&s.raw));
        if let Some(c) = s.temperature {
            self.has_temperature = true;
            self.temperature.push(c);
        }
    }
}

/// [`sample_interval`] from the stamps as they pass: the first 513 kept (below that the windows
/// are shorter than 64 and the stamps are few), then one windowed rate per 64 samples.
struct Rates {
    head: Vec<f64>,
    n: usize,
    /// The stamp at the last multiple of [`WINDOW`].
    anchor: f64,
    kth: Kth,
}

impl Rates {
    fn new() -> Rates {
        Rates {
            head: Vec::new(),
            n: 0,
            anchor: f64::NAN,
            kth: Kth::new(),
        }
    }

    fn push(&mut self, t: f64) {
        if self.head.len() <= 8 * WINDOW {
            self.head.push(t);
        }
        if self.n.is_multiple_of(WINDOW) {
            if self.n > 0 {
                self.kth.push((t - self.anchor) / WINDOW as f64);
            }
            self.anchor = t;
        }
        self.n += 1;
    }

    /// The sampling interval, rereading the stamps as the median search needs.
    fn resolve(&mut self, src: &Reading, shape: &mut Option<Shape>) -> Result<f64, Declined> {
        if self.n <= 8 * WINDOW {
            return Ok(sample_interval(&self.head));
        }
        let rank = ((self.n - 1) / WINDOW / 2) as u64;
        let (mut anchor, kth) = (f64::NAN, &mut self.kth);
        loop {
            if let Some(v) = kth.end_pass(rank) {
                return Ok(v);
            }
            src.each(shape, |i, s| {
                if i.is_multiple_of(WINDOW) {
                    if i > 0 {
                        kth.push((s.t - anchor) / WINDOW as f64);
                    }
                    anchor = s.t;
                }
            })?;
        }
    }
}

/// The order key of `f64::total_cmp`.
fn key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

fn unkey(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// The k-th smallest of values given once per pass, in `total_cmp` order, in bounded memory (see
/// the module documentation).
struct Kth {
    /// Values in play have these top `16 · level` bits of their key.
    prefix: u64,
    level: u32,
    /// The rank within the values in play, once known.
    rank: Option<u64>,
    kept: Vec<f64>,
    count: u64,
    histogram: Vec<u64>,
}

impl Kth {
    fn new() -> Kth {
        Kth {
            prefix: 0,
            level: 0,
            rank: None,
            kept: Vec::new(),
            count: 0,
            histogram: vec![0; 1 << 16],
        }
    }

    fn push(&mut self, x: f64) {
        let k = key(x);
        if self.level > 0 && k >> (64 - 16 * self.level) != self.prefix {
            return;
        }
        if self.kept.len() < KEEP {
            self.kept.push(x);
        }
        self.count += 1;
        self.histogram[((k >> (48 - 16 * self.level)) & 0xffff) as usize] += 1;
    }

    /// After a pass: the value (with `rank` the rank among all values, used on the first call),
    /// or `None` when the values must be given again.
    fn end_pass(&mut self, rank: u64) -> Option<f64> {
        let rank = *self.rank.get_or_insert(rank);
        if self.count == 0 {
            return Some(f64::NAN);
        }
        if self.count as usize <= KEEP {
            let kept = &mut self.kept;
            return Some(*kept.select_nth_unstable_by(rank as usize, f64::total_cmp).1);
        }
        let mut below = 0;
        for (bucket, &c) in self.histogram.iter().enumerate() {
            if below + c > rank {
                self.prefix = self.prefix << 16 | bucket as u64;
                self.level += 1;
                self.rank = Some(rank - below);
                if self.level == 4 {
                    return Some(unkey(self.prefix));
                }
                self.kept.clear();
                self.count = 0;
                self.histogram.iter_mut().for_each(|c| *c = 0);
                return None;
            }
            below += c;
        }
        Some(f64::NAN)
    }

    /// The value of `rank`, rereading with `value` of each sample as needed.
    fn resolve(&mut self, rank: u64, src: &Reading, value: impl Fn(&Sample) -> f64) -> Result<f64, Declined> {
        loop {
            if let Some(v) = self.end_pass(rank) {
                return Ok(v);
            }
            src.each(&mut None, |_, s| self.push(value(s)))?;
        }
    }
}

/// The distinct temperatures, as [`crate::input::inspect::temperature_summary`] counts them
/// (sorted by `total_cmp`, equal values merged: −0 and +0 are one value, −0 when both occur), at
/// most [`KEEP_DISTINCT`] per pass.
struct Distinct {
    /// Keys at or below this were counted on earlier passes.
    floor: Option<u64>,
    set: BTreeSet<u64>,
    full: bool,
    count: usize,
    min: Option<f64>,
    max: f64,
    previous: Option<f64>,
    resolution: f64,
    negative_zero: bool,
}

impl Distinct {
    fn new() -> Distinct {
        Distinct {
            floor: None,
            set: BTreeSet::new(),
            full: false,
            count: 0,
            min: None,
            max: f64::NAN,
            previous: None,
            resolution: f64::INFINITY,
            negative_zero: false,
        }
    }

    fn push(&mut self, c: f64) {
        let c = if c == 0.0 {
            self.negative_zero |= c.is_sign_negative();
            0.0
        } else {
            c
        };
        let k = key(c);
        if self.floor.is_some_and(|f| k <= f) {
            return;
        }
        if self.set.len() < KEEP_DISTINCT {
            self.set.insert(k);
        } else if self.set.last().is_some_and(|&last| k < last) && self.set.insert(k) {
            self.set.pop_last();
            self.full = true;
        } else if self.set.last().is_some_and(|&last| k > last) {
            self.full = true;
        }
    }

    fn resolve(&mut self, src: &Reading) -> Result<Option<TemperatureSummary>, Declined> {
        loop {
            for &k in &self.set {
                let v = unkey(k);
                if let Some(p) = self.previous {
                    self.resolution = self.resolution.min(v - p);
                }
                self.previous = Some(v);
                self.min.get_or_insert(v);
                self.max = v;
                self.count += 1;
            }
            if !self.full {
                break;
            }
            self.floor = self.set.last().copied();
            self.set.clear();
            self.full = false;
            src.each(&mut None, |_, s| {
                if let Some(c) = s.temperature {
                    self.push(c);
                }
            })?;
        }
        let zero = |v: f64| if v == 0.0 && self.negative_zero { -0.0 } else { v };
        Ok(self.min.map(|min| TemperatureSummary {
            min_c: zero(min),
            max_c: zero(self.max),
            resolution_c: if self.resolution.is_finite() {
                self.resolution
            } else {
                0.0
            },
            distinct_values: self.count,
        }))
    }
}

/// One axis's saturated samples, as [`inspect`] finds them: beyond [`RANGE_SHARE`] of a known
/// range, else in runs of [`RAIL_SAMPLES`] or more equal values at the axis's extreme.
#[derive(Default)]
struct Tops {
    samples: usize,
    /// Line and magnitude of the first saturated sample.
    first: Option<(usize, f64)>,
    /// The current run of equal values: its value, first line and length.
    run: Option<(f64, usize, usize)>,
}

impl Tops {
    fn push(&mut self, line: usize, v: f64, min: f64, max: f64, range: Option<f64>) {
        if let Some(range) = range {
            if v.abs() >= RANGE_SHARE * range {
                self.samples += 1;
                self.first.get_or_insert((line, v.abs()));
            }
            return;
        }
        match &mut self.run {
            Some((value, _, length)) if *value == v => *length += 1,
            _ => {
                self.end(min, max);
                self.run = Some((v, line, 1));
            }
        }
    }

    /// Ends the current run.
    fn end(&mut self, min: f64, max: f64) {
        if let Some((v, line, length)) = self.run.take() {
            if (v == max || v == min) && length >= RAIL_SAMPLES {
                self.samples += length;
                self.first.get_or_insert((line, v.abs()));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_keys_follow_total_cmp_and_invert() {
        let values = [-f64::INFINITY, -2.5, -0.0, 0.0, 1e-300, 3.0, f64::MAX];
        for w in values.windows(2) {
            assert!(key(w[0]) < key(w[1]), "{w:?}");
        }
        for v in values {
            assert_eq!(unkey(key(v)).to_bits(), v.to_bits());
        }
    }

    /// The k-th by histogram passes equals the k-th of the sorted values, beyond what is kept.
    #[test]
    fn kth_over_several_passes_is_exact() {
        let n = KEEP * 3 + 17;
        let value = |i: usize| {
            let x = (i as f64 * 0.618_033_988_749_895).fract();
            // Most values in one narrow band, so the first histogram does not settle it.
            if i.is_multiple_of(5) {
                -x * 1e3
            } else {
                9.81 + x * 1e-9
            }
        };
        let mut sorted: Vec<f64> = (0..n).map(value).collect();
        sorted.sort_by(f64::total_cmp);
        for rank in [0, n / 2, n - 1] {
            let mut kth = Kth::new();
            let mut passes = 0;
            let found = loop {
                passes += 1;
                (0..n).for_each(|i| kth.push(value(i)));
                if let Some(v) = kth.end_pass(rank as u64) {
                    break v;
                }
            };
            assert_eq!(found.to_bits(), sorted[rank].to_bits(), "rank {rank}");
            assert!(passes > 1 || rank == 0, "{passes}");
        }
    }

    /// The streamed inspection and the whole-file one agree on `text` read with `options`.
    fn agree(text: &str, options: &ReadOptions) -> Inspection {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rec.csv");
        std::fs::write(&path, text).unwrap();
        let whole = read_path(&path, options).unwrap();
        let expected = inspect(&whole.recording, None);
        let (loaded, found) = stream(&path, options, None).unwrap().expect("streamed");
        assert_eq!(format!("{found:?}"), format!("{expected:?}"));
        assert_eq!(loaded.format, whole.format);
        assert_eq!(loaded.detection, whole.detection);
        assert_eq!(loaded.raw_counts, whole.raw_counts);
        assert_eq!(loaded.notes, whole.notes);
        assert_eq!(loaded.recording.source.columns, whole.recording.source.columns);
        assert_eq!(loaded.recording.source.metadata, whole.recording.source.metadata);
        assert_eq!(loaded.recording.source.format, whole.recording.source.format);
        found
    }

    /// A 100 Hz recording with jitter, a gap, repeated stamps, rails and a temperature of
    /// `distinct` values.
    fn recording(n: usize, distinct: usize) -> String {
        let mut s = String::from("# logger v1\nt_ms,ax_g,ay_g,az_g,gx_dps,gy_dps,gz_dps,temp_c\n");
        for i in 0..n {
            let jitter = if (4995..5005).contains(&i) {
                0.0
            } else {
                ((i * 7919) % 13) as f64 * 0.01
            };
            let t = if (5000..5003).contains(&i) {
                49_990.0
            } else {
                i as f64 * 10.0 + jitter + if i > 20_000 { 70.0 } else { 0.0 }
            };
            let ax = if (300..310).contains(&i) {
                2.0
            } else {
                ((i as f64) * 0.01).sin()
            };
            let temp = 20.0 + (i % distinct) as f64 * 0.001 + (i as f64) * 1e-9;
            s += &format!(
                "{t},{ax},{},{},0.1,-0.2,{},{temp}\n",
                (i % 17) as f64 * 0.01,
                1.0 - (i % 3) as f64 * 1e-3,
                (i % 5) as f64
            );
        }
        s
    }

    #[test]
    fn streamed_inspection_equals_the_whole_file_one() {
        let text = recording(30_000, 50);
        let found = agree(&text, &ReadOptions::default());
        assert_eq!((found.samples, found.gap_count), (30_000, 2));
        assert!(
            found.repeated_times >= 2 && !found.saturation.is_empty(),
            "{found:?}"
        );
        // Distinct temperatures beyond what one pass keeps.
        let found = agree(
            &recording(KEEP_DISTINCT + 5_000, usize::MAX),
            &ReadOptions::default(),
        );
        assert_eq!(found.temperature.unwrap().distinct_values, KEEP_DISTINCT + 5_000);
        // Few samples: the windows are shorter than 64.
        for n in [1, 2, 9, 100, 513, 514, 600] {
            agree(&recording(n, 7), &ReadOptions::default());
        }
        let options = ReadOptions {
            sample_rate_hz: Some(50.0),
            accel_scale: Some(2.0),
            accel_offset: Some([0.5, 0.0, -1.0]),
            ..ReadOptions::default()
        };
        agree(&text, &options);
        agree(
            &text,
            &ReadOptions {
                retime: true,
                ..ReadOptions::default()
            },
        );
        agree(
            &text,
            &ReadOptions {
                retime: true,
                sample_rate_hz: Some(20.0),
                ..ReadOptions::default()
            },
        );
    }

    #[test]
    fn whitespace_files_and_raw_counts_agree() {
        let mut counts = String::new();
        let mut si = String::new();
        for i in 0..40_000 {
            let t = i as f64 * 0.005;
            counts += &format!(
                "{t} {} {} {}\n",
                100 + i % 7,
                -50 + (i % 11) as i64,
                16_000 + (i % 13) as i64
            );
            si += &format!("{t}   {}  {} 9.{}\n", (i % 7) as f64 * 0.01, -0.02, 80 + i % 3);
        }
        let found = agree(&counts, &ReadOptions::default());
        assert_eq!(found.samples, 40_000);
        agree(&si, &ReadOptions::default());
        agree(
            &counts,
            &ReadOptions {
                accel_scale: Some(9.81 / 16384.0),
                ..ReadOptions::default()
            },
        );
    }

    #[test]
    fn a_file_the_stream_refuses_is_read_whole_with_the_same_message() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rec.csv");
        // Time goes backwards across a block boundary; then an empty cell in an unused column.
        let mut text = String::from("t,ax,ay,az,note\n");
        for i in 0..BLOCK_ROWS + 10 {
            let t = if i == BLOCK_ROWS { 0.0 } else { i as f64 * 0.01 };
            text += &format!("{t},0.1,0.2,9.8,1\n");
        }
        std::fs::write(&path, &text).unwrap();
        let options = ReadOptions::default();
        assert!(stream(&path, &options, None).unwrap().is_none());
        let e = inspect_path(&path, &options, None).unwrap_err().to_string();
        assert_eq!(e, read_path(&path, &options).unwrap_err().to_string());
        assert!(e.contains("time goes backwards"), "{e}");
        std::fs::write(&path, "t,ax,ay,az,note\n0,0,0,9.8,1\n0.01,0,0,9.8,\n").unwrap();
        let (_, found) = inspect_path(&path, &options, None).unwrap();
        assert_eq!(found.samples, 2);
    }
}
