//! One pass over the file: rows read a block at a time, converted as the whole-file reader
//! converts them, handed on as samples.

use std::io::BufReader;
use std::path::Path;

use super::{whitespace_map, Declined, Format, ReadOptions, BLOCK_ROWS};
use crate::input::recording::{Recording, Source};
use crate::input::table::{RowReader, Table, TableOptions};

/// One sample as inspection sees it.
pub(super) struct Sample {
    pub(super) line: usize,
    pub(super) t: f64,
    /// Acceleration as the file's columns give it in SI (before `accel_scale`).
    pub(super) raw: [f64; 3],
    /// After `accel_offset` and `accel_scale`.
    pub(super) accel: [f64; 3],
    pub(super) temperature: Option<f64>,
    /// The gyro, rad/s, when the file has one.
    pub(super) gyro: Option<[f64; 3]>,
}

/// How samples are read: the file, its table options and column map, and the time rule.
pub(super) struct Reading<'a> {
    pub(super) path: &'a Path,
    pub(super) file: String,
    pub(super) table: TableOptions,
    pub(super) format: Format,
    pub(super) options: &'a ReadOptions,
    /// `--retime`: t = t₀ + i·Δt.
    pub(super) retimed: Option<(f64, f64)>,
    /// Samples seen by the first pass; every later pass must see as many.
    pub(super) samples: Option<usize>,
}

/// What the first block tells about the recording.
pub(super) struct Shape {
    pub(super) source: Source,
    pub(super) has_gyro: bool,
}

impl Reading<'_> {
    /// Reads every sample in order; the shape of the recording is given once, before the first.
    pub(super) fn each(
        &self,
        shape: &mut Option<Shape>,
        mut f: impl FnMut(usize, &Sample),
    ) -> Result<usize, Declined> {
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
                            gyro: block.gyro_radps.as_ref().map(|g| [g[0][i], g[1][i], g[2][i]]),
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
