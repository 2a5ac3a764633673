//! A table held in memory: its head read like the streaming reader, then its rows parsed in
//! windows and, for large inputs, in parallel chunks.

use super::fast::{fast_row, Fast};
use super::mapped::{advise_huge_pages, advise_mapped, Paging};
use super::reader::{is_skippable, PendingLine, RowReader};
use super::{Delimiter, Location, TableError, TableOptions};

/// The start of a table held in memory, read line by line like [`RowReader`] does (metadata,
/// header, separator, width and the first data row); [`TableHead::rows`] then parses the rest.
#[derive(Debug)]
pub(crate) struct TableHead<'a> {
    file: String,
    pub(crate) delimiter: Delimiter,
    pub(crate) header: Vec<String>,
    pub(crate) metadata: Vec<(usize, String)>,
    width: usize,
    /// The data lines read ahead while looking for the header: (line, text, ended by a newline).
    pending: Vec<PendingLine>,
    /// The bytes after them.
    rest: &'a [u8],
}

/// Rows parsed by [`TableHead::rows`]: the chosen columns and the 1-based line of every row.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Rows {
    pub(crate) columns: Vec<Vec<f64>>,
    pub(crate) lines: Vec<usize>,
    /// Rows left out because a chosen column was empty (only when asked to skip them, see
    /// [`TableHead::rows_skipping_incomplete`]).
    pub(crate) incomplete: Incomplete,
}

/// Rows that lack a value in a chosen column: how many, and the first (line, 1-based column).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Incomplete {
    pub count: usize,
    pub first: Option<(usize, usize)>,
}

impl Incomplete {
    /// What was left out, for a note or a warning; `None` when nothing was.
    pub fn describe(&self) -> Option<String> {
        let (line, column) = self.first?;
        let rows = if self.count == 1 { "row lacks" } else { "rows lack" };
        Some(format!(
            "{} {rows} a value in a column used and {} left out (the first at line {line}, column {column})",
            self.count,
            if self.count == 1 { "was" } else { "were" }
        ))
    }

    pub(super) fn add(&mut self, line: usize, column: usize) {
        self.count += 1;
        self.first.get_or_insert((line, column + 1));
    }

    /// Adds the rows of a later stretch of the file.
    fn merge(&mut self, later: Incomplete) {
        self.count += later.count;
        if self.first.is_none() {
            self.first = later.first;
        }
    }
}

/// Which cells a data row must hold. A column not `used` may hold anything (text, nothing); in a
/// used one (every column when `used` is empty) a number is required, except that an empty cell
/// makes the row incomplete rather than wrong when `skip_incomplete` (a logger's packet of another
/// kind, interleaved).
#[derive(Debug, Clone, Copy)]
pub(super) struct Need<'a> {
    pub(super) used: &'a [bool],
    pub(super) skip_incomplete: bool,
}

impl Need<'_> {
    fn is_used(&self, column: usize) -> bool {
        self.used.get(column) != Some(&false)
    }
}

/// What [`check_row`] found in a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Checked {
    Row,
    /// A used column (0-based) is empty: the row is skipped and counted.
    Incomplete {
        column: usize,
    },
}

/// Below this many bytes per chunk a parallel split costs more than it gains.
const MIN_CHUNK_BYTES: usize = 1 << 20;

/// Bytes parsed at a time: a mapped file's pages are resident one window at a time.
pub(super) const WINDOW_BYTES: usize = 16 << 20;

impl<'a> TableHead<'a> {
    pub(crate) fn new(bytes: &'a [u8], file: &str, options: &TableOptions) -> Result<Self, TableError> {
        let RowReader {
            reader: rest,
            file,
            delimiter,
            header,
            metadata,
            width,
            pending,
            ..
        } = RowReader::new(bytes, file, options)?;
        Ok(TableHead {
            file,
            delimiter,
            header,
            metadata,
            width,
            pending: pending.into(),
            rest,
        })
    }

    /// Number of fields per row.
    pub(crate) fn width(&self) -> usize {
        self.width
    }

    /// Parses every data row. Output column `k` is file column `targets[k].0` times `targets[k].1`
    /// (units applied while parsing). A chosen column must hold a finite number in every row (an
    /// empty cell, text or a non-finite value is a located error); the other columns may hold
    /// anything, or nothing. The input is parsed a window of `WINDOW_BYTES` at a time (a mapped
    /// file's pages are given back after each), large windows in chunks in parallel; the result
    /// does not depend on the thread count.
    pub(crate) fn rows(&self, targets: &[(usize, f64)]) -> Result<Rows, TableError> {
        self.parse_rows(targets, false, Self::chunks_for_threads(), WINDOW_BYTES)
    }

    /// [`TableHead::rows`], except that a row with an empty cell in a chosen column is left out
    /// and counted in [`Rows::incomplete`] (a logger's packets of other kinds, interleaved).
    pub(crate) fn rows_skipping_incomplete(&self, targets: &[(usize, f64)]) -> Result<Rows, TableError> {
        self.parse_rows(targets, true, Self::chunks_for_threads(), WINDOW_BYTES)
    }

    /// How many chunks a window of so many bytes is parsed in.
    fn chunks_for_threads() -> impl Fn(usize) -> usize {
        let threads = rayon::current_num_threads();
        move |bytes: usize| {
            if threads > 1 {
                // A few chunks per thread even out lines of different lengths and a busy core.
                (bytes / MIN_CHUNK_BYTES).clamp(1, 4 * threads)
            } else {
                1
            }
        }
    }

    /// [`TableHead::rows`] with the number of chunks per window given (tests check that it does
    /// not matter).
    #[cfg(test)]
    pub(super) fn rows_in_chunks(&self, targets: &[(usize, f64)], chunks: usize) -> Result<Rows, TableError> {
        self.parse_rows(targets, false, |_| chunks, WINDOW_BYTES)
    }

    /// [`TableHead::rows`] with the chunks per window and the window's size given (tests check that
    /// neither matters).
    #[cfg(test)]
    pub(super) fn rows_in_windows(
        &self,
        targets: &[(usize, f64)],
        chunks: impl Fn(usize) -> usize,
        window_bytes: usize,
    ) -> Result<Rows, TableError> {
        self.parse_rows(targets, false, chunks, window_bytes)
    }

    fn parse_rows(
        &self,
        targets: &[(usize, f64)],
        skip_incomplete: bool,
        chunks: impl Fn(usize) -> usize,
        window_bytes: usize,
    ) -> Result<Rows, TableError> {
        let mut used = vec![false; self.width];
        for &(c, _) in targets {
            used[c] = true;
        }
        let need = Need {
            used: &used,
            skip_incomplete,
        };
        let located = |line: usize, fault: Fault| fault.locate(&self.file, line, &self.header, self.width);
        // Rows per byte from the first 64 KiB, to allocate the columns once (capacity that is
        // never written costs no memory).
        let sample = &self.rest[..self.rest.len().min(1 << 16)];
        let per_sample = memchr::memchr_iter(b'\n', sample).count() + 1;
        let rows = self.rest.len() / sample.len().max(1) * per_sample + per_sample + 1;
        let mut out = Rows {
            columns: targets.iter().map(|_| Vec::with_capacity(rows)).collect(),
            lines: Vec::with_capacity(rows),
            incomplete: Incomplete::default(),
        };
        for column in &mut out.columns {
            advise_huge_pages(column);
        }
        advise_huge_pages(&mut out.lines);
        let mut row = Vec::with_capacity(self.width);
        let mut base = 0;
        for pending in &self.pending {
            base = pending.line;
            let checked = check_row(
                &pending.text,
                self.delimiter,
                self.width,
                pending.ended,
                need,
                &mut row,
            )
            .map_err(|fault| located(pending.line, fault))?;
            match checked {
                Checked::Row => {
                    for (column, &(c, scale)) in out.columns.iter_mut().zip(targets) {
                        column.push(row[c] * scale);
                    }
                    out.lines.push(pending.line);
                }
                Checked::Incomplete { column } => out.incomplete.add(pending.line, column),
            }
        }
        let mut rest = self.rest;
        while !rest.is_empty() {
            let window = &rest[..line_end_after(rest, window_bytes.max(1))];
            rest = &rest[window.len()..];
            advise_mapped(window, Paging::Ahead);
            // No UTF-8 check of the whole window: a row the fast path takes is ASCII, a comment it
            // skips is checked, and every other line is checked where it is parsed, so a line that
            // is not text is the error at its own line, after the rows before it.
            let pieces = split_at_lines(window, chunks(window.len()).max(1));
            base = if pieces.len() == 1 {
                // One chunk writes straight into the result, numbering lines as it goes.
                let mut incomplete = Incomplete::default();
                let n_lines = self
                    .parse_chunk(window, base, need, &mut incomplete, |row, line| {
                        for (column, &(c, scale)) in out.columns.iter_mut().zip(targets) {
                            column.push(row[c] * scale);
                        }
                        out.lines.push(line);
                    })
                    .map_err(|(line, fault)| located(line, fault))?;
                out.incomplete.merge(incomplete);
                base + n_lines
            } else {
                self.append_in_parallel(&pieces, targets, need, base, &mut out)
                    .map_err(|(line, fault)| located(line, fault))?
            };
            advise_mapped(window, Paging::Done);
        }
        Ok(out)
    }

    /// Parses the pieces (whole lines after line `base`) in parallel and appends their rows to
    /// `out`, each piece into its own stretch (as long as its lines, an upper bound on its rows),
    /// then closes the gaps left by blank and comment lines. Returns the last line read.
    fn append_in_parallel(
        &self,
        pieces: &[&[u8]],
        targets: &[(usize, f64)],
        need: Need<'_>,
        base: usize,
        out: &mut Rows,
    ) -> Result<usize, (usize, Fault)> {
        use rayon::prelude::*;
        let counts: Vec<usize> = pieces
            .par_iter()
            .map(|p| memchr::memchr_iter(b'\n', p).count() + usize::from(!p.ends_with(b"\n")))
            .collect();
        let start = out.lines.len();
        let total = start + counts.iter().sum::<usize>();
        for column in out.columns.iter_mut() {
            column.resize(total, 0.0);
        }
        out.lines.resize(total, 0);
        let mut column_rests: Vec<&mut [f64]> = out.columns.iter_mut().map(|c| &mut c[start..]).collect();
        let mut line_rest = &mut out.lines[start..];
        let mut stretches = Vec::with_capacity(pieces.len());
        for &n in &counts {
            let mut piece_columns = Vec::with_capacity(targets.len());
            for rest in column_rests.iter_mut() {
                let (head, tail) = std::mem::take(rest).split_at_mut(n);
                *rest = tail;
                piece_columns.push(head);
            }
            let (head, tail) = std::mem::take(&mut line_rest).split_at_mut(n);
            line_rest = tail;
            stretches.push((piece_columns, head));
        }
        type Parsed = Result<(usize, usize, Incomplete), (usize, Fault)>;
        let parsed: Vec<Parsed> = pieces
            .par_iter()
            .zip(stretches.into_par_iter())
            .map(|(piece, (mut piece_columns, piece_lines))| {
                let mut i = 0;
                let mut incomplete = Incomplete::default();
                let n_lines = self.parse_chunk(piece, 0, need, &mut incomplete, |row, line| {
                    for (column, &(c, scale)) in piece_columns.iter_mut().zip(targets) {
                        column[i] = row[c] * scale;
                    }
                    piece_lines[i] = line;
                    i += 1;
                })?;
                Ok((n_lines, i, incomplete))
            })
            .collect();
        // In file order: the first piece with a fault holds the file's first fault, and the pieces
        // before it give its line.
        let (mut base, mut write, mut read) = (base, start, start);
        for (result, n) in parsed.into_iter().zip(counts) {
            let (n_lines, rows, mut incomplete) = result.map_err(|(line, fault)| (base + line, fault))?;
            if let Some((line, _)) = incomplete.first.as_mut() {
                *line += base;
            }
            out.incomplete.merge(incomplete);
            if read != write {
                for column in out.columns.iter_mut() {
                    column.copy_within(read..read + rows, write);
                }
                out.lines.copy_within(read..read + rows, write);
            }
            for line in &mut out.lines[write..write + rows] {
                *line += base;
            }
            base += n_lines;
            write += rows;
            read += n;
        }
        for column in out.columns.iter_mut() {
            column.truncate(write);
        }
        out.lines.truncate(write);
        Ok(base)
    }

    /// Parses the whole lines in `piece`, numbered from `base + 1`, handing each row and its line to
    /// `emit` and counting incomplete rows in `incomplete`; returns the number of lines, or the
    /// first fault with its line. Cells of columns not used read as NaN, never handed on.
    fn parse_chunk(
        &self,
        piece: &[u8],
        base: usize,
        need: Need<'_>,
        incomplete: &mut Incomplete,
        mut emit: impl FnMut(&[f64], usize),
    ) -> Result<usize, (usize, Fault)> {
        let mut row = vec![0.0; self.width];
        let mut careful = Vec::with_capacity(self.width);
        let mut p = 0;
        let mut line = base;
        while p < piece.len() {
            line += 1;
            let rest = &piece[p..];
            match fast_row(rest, self.delimiter, &mut row) {
                Fast::Row(used) => p += used,
                Fast::Skip(used) => {
                    p += used;
                    continue;
                }
                Fast::Slow => {
                    let (end, has_newline) = match memchr::memchr(b'\n', rest) {
                        Some(end) => (end, true),
                        None => (rest.len(), false),
                    };
                    p += end + usize::from(has_newline);
                    let text = std::str::from_utf8(&rest[..end]).map_err(|_| (line, Fault::NotText))?;
                    let text = text.trim_end_matches(['\n', '\r']);
                    if is_skippable(text) {
                        continue;
                    }
                    let checked =
                        check_row(text, self.delimiter, self.width, has_newline, need, &mut careful)
                            .map_err(|fault| (line, fault))?;
                    if let Checked::Incomplete { column } = checked {
                        incomplete.add(line, column);
                        continue;
                    }
                    row.copy_from_slice(&careful);
                }
            }
            emit(&row, line);
        }
        Ok(line - base)
    }
}

/// The length of `bytes`' first stretch of about `size` bytes that ends after a newline (or at
/// the end).
fn line_end_after(bytes: &[u8], size: usize) -> usize {
    if bytes.len() <= size {
        return bytes.len();
    }
    memchr::memchr(b'\n', &bytes[size..]).map_or(bytes.len(), |e| size + e + 1)
}

/// Splits `bytes` into at most `chunks` pieces of about equal size, each ending after a newline
/// (the last one at the end).
fn split_at_lines(bytes: &[u8], chunks: usize) -> Vec<&[u8]> {
    let mut pieces = Vec::with_capacity(chunks);
    let mut start = 0;
    for k in 1..chunks {
        let target = (bytes.len() * k / chunks).max(start);
        let end = start + line_end_after(&bytes[start..], target - start);
        if end == bytes.len() {
            break;
        }
        pieces.push(&bytes[start..end]);
        start = end;
    }
    pieces.push(&bytes[start..]);
    pieces.retain(|p| !p.is_empty());
    if pieces.is_empty() {
        pieces.push(&bytes[..0]);
    }
    pieces
}

/// What is wrong with one data line; [`Fault::locate`] adds the file and line.
#[derive(Debug)]
pub(super) enum Fault {
    Ragged { found: usize },
    Truncated { found: usize },
    EmptyCell { column: usize },
    NotANumber { column: usize, text: String },
    NonFinite { column: usize, text: String },
    NotText,
}

impl Fault {
    pub(super) fn locate(self, file: &str, line: usize, header: &[String], width: usize) -> TableError {
        let at = |column: Option<usize>| Location {
            file: file.to_string(),
            line,
            column: column.map(|c| c + 1),
            column_name: column.and_then(|c| header.get(c).cloned()),
        };
        match self {
            Fault::Ragged { found } => TableError::Ragged {
                at: at(None),
                expected: width,
                found,
            },
            Fault::Truncated { found } => TableError::Truncated {
                file: file.to_string(),
                line,
                expected: width,
                found,
            },
            Fault::EmptyCell { column } => TableError::EmptyCell { at: at(Some(column)) },
            Fault::NotANumber { column, text } => TableError::NotANumber {
                at: at(Some(column)),
                text,
            },
            Fault::NonFinite { column, text } => TableError::NonFinite {
                at: at(Some(column)),
                text,
            },
            Fault::NotText => TableError::NotText {
                file: file.to_string(),
                line,
            },
        }
    }
}

/// Parses one data line the careful way: any Unicode spacing, every fault named. It decides every
/// line the byte-level [`fast_row`] declines, so both paths give the same values and errors. A
/// cell of a column `need` does not use reads as NaN whatever it holds.
pub(super) fn check_row(
    text: &str,
    delimiter: Delimiter,
    width: usize,
    has_newline: bool,
    need: Need<'_>,
    values: &mut Vec<f64>,
) -> Result<Checked, Fault> {
    let mut fields = Vec::with_capacity(width);
    delimiter.split_row(text, Some(width), &mut fields);
    if fields.len() != width {
        if !has_newline && fields.len() < width {
            return Err(Fault::Truncated { found: fields.len() });
        }
        return Err(Fault::Ragged { found: fields.len() });
    }
    values.clear();
    let mut checked = Checked::Row;
    for (c, field) in fields.iter().enumerate() {
        if !need.is_used(c) {
            values.push(field.parse::<f64>().unwrap_or(f64::NAN));
            continue;
        }
        if field.is_empty() {
            if need.skip_incomplete {
                if checked == Checked::Row {
                    checked = Checked::Incomplete { column: c };
                }
                values.push(f64::NAN);
                continue;
            }
            return Err(Fault::EmptyCell { column: c });
        }
        match field.parse::<f64>() {
            Ok(v) if v.is_finite() => values.push(v),
            Ok(_) => {
                return Err(Fault::NonFinite {
                    column: c,
                    text: field.to_string(),
                })
            }
            Err(_) => {
                return Err(Fault::NotANumber {
                    column: c,
                    text: field.to_string(),
                })
            }
        }
    }
    Ok(checked)
}
