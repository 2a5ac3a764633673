//! Delimited numeric text tables: the one parser behind every CSV-like format spincal reads.
//!
//! A table is: optional metadata lines (reported, not parsed), an optional header line, then rows of
//! numbers. Separators are comma, semicolon, tab or runs of whitespace, detected from the first data
//! line unless given. Lines starting with `#` or `%` and blank lines are skipped anywhere. A trailing
//! separator (e.g. `1.0,2.0,`) is tolerated. Every error names the file, the 1-based line and the
//! 1-based column (with its header name when there is one).

use std::fmt;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// Field separator of a delimited text file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Delimiter {
    Comma,
    Semicolon,
    Tab,
    /// One or more spaces or tabs.
    Whitespace,
}

impl Delimiter {
    /// Parses a user's choice: `comma` `,` `semicolon` `;` `tab` `\t` `whitespace` `space`.
    pub fn parse(text: &str) -> Option<Delimiter> {
        match text {
            "," | "comma" => Some(Delimiter::Comma),
            ";" | "semicolon" => Some(Delimiter::Semicolon),
            "\t" | "\\t" | "tab" => Some(Delimiter::Tab),
            " " | "space" | "whitespace" => Some(Delimiter::Whitespace),
            _ => None,
        }
    }

    /// The separator written by `Delimiter::join`-style writers.
    pub fn as_char(self) -> char {
        match self {
            Delimiter::Comma => ',',
            Delimiter::Semicolon => ';',
            Delimiter::Tab => '\t',
            Delimiter::Whitespace => ' ',
        }
    }

    /// Guesses the separator of one data line: tab, then semicolon, then comma, else whitespace.
    pub fn detect(line: &str) -> Delimiter {
        if line.contains('\t') && !line.contains(',') && !line.contains(';') {
            Delimiter::Tab
        } else if line.contains(';') {
            Delimiter::Semicolon
        } else if line.contains(',') {
            Delimiter::Comma
        } else {
            Delimiter::Whitespace
        }
    }

    /// Splits a line into trimmed fields.
    pub fn split<'a>(self, line: &'a str, out: &mut Vec<&'a str>) {
        out.clear();
        match self {
            Delimiter::Whitespace => out.extend(line.split_whitespace()),
            _ => out.extend(line.split(self.as_char()).map(str::trim)),
        }
    }

    /// Splits like [`Delimiter::split`], then drops one empty field after a trailing separator
    /// when that leaves `width` fields (or always, when `width` is `None`).
    pub fn split_row<'a>(self, line: &'a str, width: Option<usize>, out: &mut Vec<&'a str>) {
        self.split(line, out);
        let trailing = out.len() > 1 && out.last().is_some_and(|s| s.is_empty());
        if trailing && width.is_none_or(|w| out.len() == w + 1) {
            out.pop();
        }
    }
}

impl fmt::Display for Delimiter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Delimiter::Comma => "comma",
            Delimiter::Semicolon => "semicolon",
            Delimiter::Tab => "tab",
            Delimiter::Whitespace => "whitespace",
        })
    }
}

/// Where a cell sits: file, 1-based line and 1-based column, with the column's header name.
#[derive(Debug, Clone, PartialEq)]
pub struct Location {
    pub file: String,
    pub line: usize,
    pub column: Option<usize>,
    pub column_name: Option<String>,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)?;
        if let Some(c) = self.column {
            write!(f, ", column {c}")?;
            if let Some(name) = &self.column_name {
                write!(f, " ({name})")?;
            }
        }
        Ok(())
    }
}

/// Everything that can be wrong with a numeric table.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TableError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: the file is empty")]
    Empty { file: String },
    #[error("{file}: no numeric data rows found ({lines} lines read, none was all numbers)")]
    NoData { file: String, lines: usize },
    #[error("{at}: '{text}' is not a number")]
    NotANumber { at: Location, text: String },
    #[error("{at}: the value is {text}; spincal needs finite numbers")]
    NonFinite { at: Location, text: String },
    #[error("{at}: the cell is empty")]
    EmptyCell { at: Location },
    #[error("{at}: expected {expected} fields, found {found}")]
    Ragged {
        at: Location,
        expected: usize,
        found: usize,
    },
    #[error("{file}: the last line ({line}) has no line ending and only {found} of {expected} fields: the file looks truncated")]
    Truncated {
        file: String,
        line: usize,
        expected: usize,
        found: usize,
    },
    #[error("{file}:{line}: the line is not valid UTF-8 text")]
    NotText { file: String, line: usize },
    #[error("{file}: no header line naming the label column '{name}' was found")]
    NoLabelColumn { file: String, name: String },
    #[error("{file}: no column '{key}' (columns: {available})")]
    NoColumn {
        file: String,
        key: String,
        available: String,
    },
}

/// How to read a table.
#[derive(Debug, Clone, Default)]
pub struct TableOptions {
    /// Separator; detected from the first data line when `None`.
    pub delimiter: Option<Delimiter>,
}

/// A fully read numeric table, column-major.
#[derive(Debug, Clone)]
pub struct Table {
    /// Display name of the source (the path, or `<stdin>`).
    pub file: String,
    pub delimiter: Delimiter,
    /// Header names; empty when the file has no header line.
    pub header: Vec<String>,
    /// Lines before the header/data that were skipped: (1-based line, text).
    pub metadata: Vec<(usize, String)>,
    /// `columns[c][i]` is row `i` of column `c`.
    pub columns: Vec<Vec<f64>>,
    /// 1-based source line of every row, so later checks can name the line.
    pub lines: Vec<usize>,
}

impl Table {
    pub fn n_rows(&self) -> usize {
        self.lines.len()
    }

    pub fn n_columns(&self) -> usize {
        self.columns.len()
    }

    /// Reads a table from a file path (see [`read_file`] and [`Table::parse`]).
    pub fn read_path(path: &Path, options: &TableOptions) -> Result<Table, TableError> {
        let file = path.display().to_string();
        let bytes = read_file(path).map_err(|source| TableError::Io {
            file: file.clone(),
            source,
        })?;
        Table::parse(&bytes, &file, options)
    }

    /// Reads a table from any buffered reader; `file` names the source in errors. The input is read
    /// to its end, then parsed by [`Table::parse`].
    pub fn read<R: BufRead>(mut reader: R, file: &str, options: &TableOptions) -> Result<Table, TableError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).map_err(|source| TableError::Io {
            file: file.to_string(),
            source,
        })?;
        Table::parse(&bytes, file, options)
    }

    /// Parses a table held in memory; `file` names the source in errors.
    pub fn parse(bytes: &[u8], file: &str, options: &TableOptions) -> Result<Table, TableError> {
        let head = TableHead::new(bytes, file, options)?;
        let every: Vec<(usize, f64)> = (0..head.width()).map(|c| (c, 1.0)).collect();
        let rows = head.rows(&every)?;
        Ok(Table {
            file: file.to_string(),
            delimiter: head.delimiter,
            header: head.header,
            metadata: head.metadata,
            columns: rows.columns,
            lines: rows.lines,
        })
    }

    /// Parses only the columns `keys` (header names or 1-based indices), in that order: an empty cell
    /// in any other column is no error (benchmark files leave a constant's column empty after its
    /// first row). The header holds each chosen column's name, or its key when the file has no
    /// header; `lines` are the file's lines, so errors and later checks still name them.
    pub fn parse_columns(
        bytes: &[u8],
        file: &str,
        options: &TableOptions,
        keys: &[&str],
    ) -> Result<Table, TableError> {
        let head = TableHead::new(bytes, file, options)?;
        let mut targets = Vec::with_capacity(keys.len());
        for key in keys {
            let Some(c) = find_column(&head.header, head.width(), key) else {
                // A bad cell anywhere comes first, as in `Table::parse`.
                head.rows(&[])?;
                return Err(TableError::NoColumn {
                    file: file.to_string(),
                    key: key.to_string(),
                    available: if head.header.is_empty() {
                        format!("{} unnamed", head.width())
                    } else {
                        head.header.join(", ")
                    },
                });
            };
            targets.push((c, 1.0));
        }
        let rows = head.rows(&targets)?;
        let header = targets
            .iter()
            .zip(keys)
            .map(|(&(c, _), key)| head.header.get(c).cloned().unwrap_or_else(|| key.to_string()))
            .collect();
        Ok(Table {
            file: file.to_string(),
            delimiter: head.delimiter,
            header,
            metadata: head.metadata,
            columns: rows.columns,
            lines: rows.lines,
        })
    }

    /// Finds a column by header name (case-insensitive) or by 1-based index written as a number.
    pub fn column_index(&self, key: &str) -> Option<usize> {
        find_column(&self.header, self.n_columns(), key)
    }
}

/// The bytes of a file: mapped when it is a large regular file, read whole otherwise.
pub enum FileBytes {
    Mapped(MappedFile),
    Read(Vec<u8>),
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Mapped(file) => &file.map,
            FileBytes::Read(bytes) => bytes,
        }
    }
}

/// Files from this size up are mapped rather than copied into memory.
const MAP_BYTES: u64 = 1 << 20;

/// Opens a file for parsing in memory: a regular file of at least 1 MiB is mapped (no copy), any
/// other (small, pipe, device) is read whole.
pub fn read_file(path: &Path) -> std::io::Result<FileBytes> {
    let mut file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() && meta.len() >= MAP_BYTES {
        // SAFETY: the map is read-only. Another process truncating the file while it is parsed
        // would fault the read (SIGBUS), as in any reader that maps files; spincal's inputs are
        // finished recordings, and the speed of a mapped read is why this is worth it.
        if let Ok(map) = unsafe { memmap2::MmapOptions::new().map(&file) } {
            return Ok(FileBytes::Mapped(MappedFile::new(map)));
        }
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    file.read_to_end(&mut bytes)?;
    Ok(FileBytes::Read(bytes))
}

/// A mapped file whose pages the parser hands back as it finishes with them, so a file larger
/// than memory allows can be read and only a window of it is resident at a time. The address
/// ranges of live maps are kept in `LIVE_MAPS`: parsers see plain byte slices.
pub struct MappedFile {
    map: memmap2::Mmap,
}

/// (start, end) addresses of every live [`MappedFile`].
static LIVE_MAPS: std::sync::Mutex<Vec<(usize, usize)>> = std::sync::Mutex::new(Vec::new());

impl MappedFile {
    fn new(map: memmap2::Mmap) -> MappedFile {
        let start = map.as_ptr() as usize;
        if let Ok(mut live) = LIVE_MAPS.lock() {
            live.push((start, start + map.len()));
        }
        MappedFile { map }
    }
}

impl Drop for MappedFile {
    fn drop(&mut self) {
        // Forgotten before the map goes, so no released range can outlive it.
        let start = self.map.as_ptr() as usize;
        if let Ok(mut live) = LIVE_MAPS.lock() {
            live.retain(|&(s, _)| s != start);
        }
    }
}

/// What to tell the kernel about a stretch of a mapped file.
#[derive(Clone, Copy)]
enum Paging {
    /// About to be read: fault it in at once.
    Ahead,
    /// Read: drop it from this process (the page cache keeps it; touching it again reads it back).
    Done,
}

/// Gives `part`'s whole pages the advice when `part` lies in a live [`MappedFile`]; any other
/// slice (a `Vec`, a test's string) is left alone. Advice only changes residency, never contents.
fn advise_mapped(part: &[u8], paging: Paging) {
    #[cfg(unix)]
    {
        const PAGE: usize = 4096;
        let (start, end) = (part.as_ptr() as usize, part.as_ptr() as usize + part.len());
        let Ok(live) = LIVE_MAPS.lock() else { return };
        if !live.iter().any(|&(s, e)| s <= start && end <= e) {
            return;
        }
        let (first, last) = match paging {
            Paging::Ahead => (start & !(PAGE - 1), end),
            // Only pages wholly inside `part`: its neighbours may still be read.
            Paging::Done => (start.next_multiple_of(PAGE), end & !(PAGE - 1)),
        };
        if first >= last {
            return;
        }
        let advise = |advice: libc::c_int| {
            // SAFETY: the range lies in a live read-only file map (checked under the lock, which
            // `MappedFile::drop` takes before unmapping); these advices leave its contents as
            // they are.
            unsafe { libc::madvise(first as *mut libc::c_void, last - first, advice) == 0 }
        };
        match paging {
            // Linux 5.14+ maps the pages at once; elsewhere, read-ahead at least.
            #[cfg(target_os = "linux")]
            Paging::Ahead => {
                if !advise(libc::MADV_POPULATE_READ) {
                    advise(libc::MADV_WILLNEED);
                }
            }
            #[cfg(not(target_os = "linux"))]
            Paging::Ahead => {
                advise(libc::MADV_WILLNEED);
            }
            Paging::Done => {
                advise(libc::MADV_DONTNEED);
            }
        }
        drop(live);
    }
    #[cfg(not(unix))]
    let _ = (part, paging);
}

/// Asks for transparent huge pages under `v`'s unused capacity (Linux): a column of a large
/// file is then faulted in 2 MiB at a time instead of 4 KiB (about a sixth as many faults per read).
fn advise_huge_pages<T>(v: &mut Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let spare = v.spare_capacity_mut();
        let start = spare.as_ptr() as usize;
        let end = start + std::mem::size_of_val(spare);
        let (first, last) = (start.next_multiple_of(HUGE), end & !(HUGE - 1));
        if first < last {
            // SAFETY: the range lies inside the vector's own allocation, none of it initialised
            // yet; MADV_HUGEPAGE changes how pages are backed, never what they hold.
            unsafe {
                libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

/// The start of a table held in memory, read line by line like [`RowReader`] does (metadata,
/// header, separator, width and the first data row); [`TableHead::rows`] then parses the rest.
#[derive(Debug)]
pub struct TableHead<'a> {
    file: String,
    pub delimiter: Delimiter,
    pub header: Vec<String>,
    pub metadata: Vec<(usize, String)>,
    width: usize,
    /// The data lines read ahead while looking for the header: (line, text, ended by a newline).
    pending: Vec<PendingLine>,
    /// The bytes after them.
    rest: &'a [u8],
}

/// Rows parsed by [`TableHead::rows`]: the chosen columns and the 1-based line of every row.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rows {
    pub columns: Vec<Vec<f64>>,
    pub lines: Vec<usize>,
    /// Rows left out because a chosen column was empty (only when asked to skip them, see
    /// [`TableHead::rows_skipping_incomplete`]).
    pub incomplete: Incomplete,
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

    fn add(&mut self, line: usize, column: usize) {
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
struct Need<'a> {
    used: &'a [bool],
    skip_incomplete: bool,
}

impl Need<'_> {
    fn is_used(&self, column: usize) -> bool {
        self.used.get(column) != Some(&false)
    }
}

/// What [`check_row`] found in a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Checked {
    Row,
    /// A used column (0-based) is empty: the row is skipped and counted.
    Incomplete {
        column: usize,
    },
}

/// Below this many bytes per chunk a parallel split costs more than it gains.
const MIN_CHUNK_BYTES: usize = 1 << 20;

/// Bytes parsed at a time: a mapped file's pages are resident one window at a time.
const WINDOW_BYTES: usize = 16 << 20;

impl<'a> TableHead<'a> {
    pub fn new(bytes: &'a [u8], file: &str, options: &TableOptions) -> Result<Self, TableError> {
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
    pub fn width(&self) -> usize {
        self.width
    }

    /// Parses every data row. Output column `k` is file column `targets[k].0` times `targets[k].1`
    /// (units applied while parsing). A chosen column must hold a finite number in every row (an
    /// empty cell, text or a non-finite value is a located error); the other columns may hold
    /// anything, or nothing. The input is parsed a window of `WINDOW_BYTES` at a time (a mapped
    /// file's pages are given back after each), large windows in chunks in parallel; the result
    /// does not depend on the thread count.
    pub fn rows(&self, targets: &[(usize, f64)]) -> Result<Rows, TableError> {
        self.parse_rows(targets, false, Self::chunks_for_threads(), WINDOW_BYTES)
    }

    /// [`TableHead::rows`], except that a row with an empty cell in a chosen column is left out
    /// and counted in [`Rows::incomplete`] (a logger's packets of other kinds, interleaved).
    pub fn rows_skipping_incomplete(&self, targets: &[(usize, f64)]) -> Result<Rows, TableError> {
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
    #[doc(hidden)]
    pub fn rows_in_chunks(&self, targets: &[(usize, f64)], chunks: usize) -> Result<Rows, TableError> {
        self.parse_rows(targets, false, |_| chunks, WINDOW_BYTES)
    }

    /// [`TableHead::rows`] with the chunks per window and the window's size given (tests check that
    /// neither matters).
    #[doc(hidden)]
    pub fn rows_in_windows(
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
enum Fault {
    Ragged { found: usize },
    Truncated { found: usize },
    EmptyCell { column: usize },
    NotANumber { column: usize, text: String },
    NonFinite { column: usize, text: String },
    NotText,
}

impl Fault {
    fn locate(self, file: &str, line: usize, header: &[String], width: usize) -> TableError {
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
fn check_row(
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

/// What [`fast_row`] made of the start of its input (byte counts include the newline).
enum Fast {
    Row(usize),
    Skip(usize),
    Slow,
}

/// ASCII bytes that `str::trim` and `split_whitespace` remove; other spacing takes the careful path.
#[inline(always)]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Spacing around a field that is not itself the separator `SEP` (0 for runs of spaces).
#[inline(always)]
fn is_padding<const SEP: u8>(b: u8) -> bool {
    is_space(b) && b != SEP
}

/// Reads one line of plain ASCII numbers straight from bytes into `row` (`row.len()` fields), or
/// recognises a blank or comment line (a comment must be UTF-8). Anything else (non-ASCII, a bad
/// or non-finite number, a wrong field count) is `Slow`, for [`check_row`] to decide. fast-float2
/// reads the same decimal syntax as `str::parse` and rounds correctly too, so the values are the
/// same bits.
#[inline]
fn fast_row(input: &[u8], delimiter: Delimiter, row: &mut [f64]) -> Fast {
    let mut p = 0;
    while p < input.len() && is_space(input[p]) {
        p += 1;
    }
    match input.get(p) {
        None => return Fast::Skip(input.len()),
        Some(b'\n') => return Fast::Skip(p + 1),
        Some(b'#' | b'%') => {
            let end = memchr::memchr(b'\n', &input[p..]).map_or(input.len(), |e| p + e + 1);
            // A comment that is not text is the careful path's error.
            return match std::str::from_utf8(&input[p..end]) {
                Ok(_) => Fast::Skip(end),
                Err(_) => Fast::Slow,
            };
        }
        _ => {}
    }
    match delimiter {
        Delimiter::Comma => fast_fields::<b','>(input, p, row),
        Delimiter::Semicolon => fast_fields::<b';'>(input, p, row),
        // Leading tabs are empty fields, not padding.
        Delimiter::Tab => fast_fields::<b'\t'>(input, 0, row),
        Delimiter::Whitespace => fast_fields::<0>(input, p, row),
    }
}

/// The fields of [`fast_row`]; `SEP` is the separator byte, 0 for runs of spaces.
#[inline(always)]
fn fast_fields<const SEP: u8>(input: &[u8], mut p: usize, row: &mut [f64]) -> Fast {
    let pad = is_padding::<SEP>;
    let len = input.len();
    let last = row.len() - 1;
    for (c, slot) in row.iter_mut().enumerate() {
        // Plain decimals by our own reader (its values are finite, and it takes no padding); then
        // padding, and numbers of other forms by fast-float2. Both round correctly.
        let (value, end) = match crate::input::decimal::parse_decimal(&input[p..]) {
            Some((value, used)) => (value, p + used),
            None => match padded_number::<SEP>(input, p) {
                Some(parsed) => parsed,
                None => return Fast::Slow,
            },
        };
        *slot = value;
        p = end;
        if c < last {
            if SEP == 0 {
                // The spaces after it are the next field's padding.
                if p >= len || !is_space(input[p]) {
                    return Fast::Slow;
                }
            } else if p < len && input[p] == SEP {
                p += 1;
            } else {
                while p < len && pad(input[p]) {
                    p += 1;
                }
                if p >= len || input[p] != SEP {
                    return Fast::Slow;
                }
                p += 1;
            }
        }
    }
    while p < len && pad(input[p]) {
        p += 1;
    }
    if SEP != 0 && p < len && input[p] == SEP {
        // One trailing separator (`1,2,`) is tolerated, as by `Delimiter::split_row`.
        p += 1;
        while p < len && pad(input[p]) {
            p += 1;
        }
    }
    match input.get(p) {
        None => Fast::Row(len),
        Some(b'\n') => Fast::Row(p + 1),
        _ => Fast::Slow,
    }
}

/// The finite number at `p` after any padding, read by our reader or by fast-float2, and where it
/// ends; `None` when there is none. Off the common path, so kept out of [`fast_fields`]'s loop.
#[cold]
#[inline(never)]
fn padded_number<const SEP: u8>(input: &[u8], mut p: usize) -> Option<(f64, usize)> {
    let start = p;
    while p < input.len() && is_padding::<SEP>(input[p]) {
        p += 1;
    }
    // Our reader again only if there was padding to skip.
    let (value, used) = (p > start)
        .then(|| crate::input::decimal::parse_decimal(&input[p..]))
        .flatten()
        .or_else(|| fast_float2::parse_partial::<f64, _>(&input[p..]).ok())?;
    value.is_finite().then_some((value, p + used))
}

/// A numeric table with one text column of labels (e.g. imucal's `part`), read by
/// [`read_labelled`]. The label column is not among `table.columns`/`table.header`.
#[derive(Debug, Clone)]
pub struct LabelledTable {
    pub table: Table,
    /// One label per row.
    pub labels: Vec<String>,
    /// Name of the label column as written in the header.
    pub label_name: String,
}

/// Reads a table whose header names a text column `label` (case-insensitive); every other column
/// must be numeric. Lines before the header are metadata. Errors are located like [`Table::read`]'s
/// (columns are counted in the file, label column included).
pub fn read_labelled<R: BufRead>(
    mut reader: R,
    file: &str,
    options: &TableOptions,
    label: &str,
) -> Result<LabelledTable, TableError> {
    let mut buffer = String::new();
    let mut line_no = 0;
    let mut metadata = Vec::new();
    // The header is the first non-skippable line that contains the label name as a field.
    let (delimiter, names, label_index) = loop {
        let Some(_) = read_line(&mut reader, &mut buffer, file, line_no + 1)? else {
            if line_no == 0 {
                return Err(TableError::Empty { file: file.into() });
            }
            return Err(TableError::NoLabelColumn {
                file: file.into(),
                name: label.into(),
            });
        };
        line_no += 1;
        let text = buffer.trim_end_matches(['\n', '\r']);
        if is_skippable(text) {
            continue;
        }
        let delimiter = options.delimiter.unwrap_or_else(|| Delimiter::detect(text));
        let mut fields = Vec::new();
        delimiter.split_row(text, None, &mut fields);
        let names: Vec<String> = fields.iter().map(|s| s.trim_matches('"').to_string()).collect();
        if let Some(i) = names.iter().position(|n| n.eq_ignore_ascii_case(label)) {
            break (delimiter, names, i);
        }
        metadata.push((line_no, text.to_string()));
    };
    let width = names.len();
    let header: Vec<String> = names
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != label_index)
        .map(|(_, n)| n.clone())
        .collect();
    let mut columns = vec![Vec::new(); width - 1];
    let mut lines = Vec::new();
    let mut labels = Vec::new();
    let location = |line: usize, c: usize| Location {
        file: file.to_string(),
        line,
        column: Some(c + 1),
        column_name: names.get(c).cloned(),
    };
    while let Some(has_newline) = read_line(&mut reader, &mut buffer, file, line_no + 1)? {
        line_no += 1;
        let text = buffer.trim_end_matches(['\n', '\r']);
        if is_skippable(text) {
            continue;
        }
        let mut fields = Vec::with_capacity(width);
        delimiter.split_row(text, Some(width), &mut fields);
        if fields.len() != width {
            if !has_newline && fields.len() < width {
                return Err(TableError::Truncated {
                    file: file.into(),
                    line: line_no,
                    expected: width,
                    found: fields.len(),
                });
            }
            return Err(TableError::Ragged {
                at: Location {
                    file: file.into(),
                    line: line_no,
                    column: None,
                    column_name: None,
                },
                expected: width,
                found: fields.len(),
            });
        }
        let mut k = 0;
        for (c, field) in fields.iter().enumerate() {
            if c == label_index {
                labels.push(field.trim_matches('"').to_string());
                continue;
            }
            if field.is_empty() {
                return Err(TableError::EmptyCell {
                    at: location(line_no, c),
                });
            }
            match field.parse::<f64>() {
                Ok(v) if v.is_finite() => columns[k].push(v),
                Ok(_) => {
                    return Err(TableError::NonFinite {
                        at: location(line_no, c),
                        text: field.to_string(),
                    })
                }
                Err(_) => {
                    return Err(TableError::NotANumber {
                        at: location(line_no, c),
                        text: field.to_string(),
                    })
                }
            }
            k += 1;
        }
        lines.push(line_no);
    }
    if lines.is_empty() {
        return Err(TableError::NoData {
            file: file.into(),
            lines: line_no,
        });
    }
    Ok(LabelledTable {
        table: Table {
            file: file.into(),
            delimiter,
            header,
            metadata,
            columns,
            lines,
        },
        labels,
        label_name: names[label_index].clone(),
    })
}

/// Resolves a column key: a header name (case-insensitive) or a 1-based index.
pub fn find_column(header: &[String], n_columns: usize, key: &str) -> Option<usize> {
    let key = key.trim();
    if let Some(i) = header.iter().position(|h| h.eq_ignore_ascii_case(key)) {
        return Some(i);
    }
    match key.parse::<usize>() {
        Ok(i) if (1..=n_columns).contains(&i) => Some(i - 1),
        _ => None,
    }
}

/// One data line from [`RowReader::next_record`].
#[derive(Debug)]
pub enum Record {
    /// The values were read into the caller's buffer.
    Parsed { line: usize },
    /// A column chosen by [`RowReader::choose_columns`] is empty (1-based `column`): a packet of
    /// another kind, say. The buffer holds NaN there.
    Incomplete {
        line: usize,
        column: usize,
        column_name: Option<String>,
    },
    /// The line could not be read as a row; its text and why.
    Refused {
        line: usize,
        text: String,
        error: TableError,
    },
}

/// Streams the rows of a table one at a time, in constant memory.
///
/// Construction reads ahead to the first data row to learn the separator, header and width. Rows
/// are parsed from one reused byte buffer by the same byte-level parser as [`TableHead::rows`].
pub struct RowReader<R: BufRead> {
    reader: R,
    file: String,
    pub delimiter: Delimiter,
    pub header: Vec<String>,
    pub metadata: Vec<(usize, String)>,
    width: usize,
    line_no: usize,
    /// The current line's bytes, reused from line to line.
    bytes: Vec<u8>,
    /// The line in `bytes`.
    current_line: usize,
    /// Data lines read ahead during construction, handed out first.
    pending: std::collections::VecDeque<PendingLine>,
    /// The columns that must hold numbers (every one when empty); see [`RowReader::choose_columns`].
    used: Vec<bool>,
    skip_incomplete: bool,
    /// Incomplete rows skipped by [`RowReader::next_row`].
    pub incomplete: Incomplete,
}

/// A line read ahead of the data, kept as text until the columns that matter are known.
#[derive(Debug, Clone)]
struct PendingLine {
    line: usize,
    text: String,
    /// Whether a newline ended it (a last line without one may be truncated).
    ended: bool,
}

/// Numbers a line under a header needs to be a data row rather than metadata (`rate,100`).
pub const MIN_NUMBERS_IN_A_ROW: usize = 3;

/// How many fields `text` splits into, counting a trailing empty field only when that makes
/// `width` fields.
fn field_count(text: &str, delimiter: Delimiter, width: usize) -> usize {
    let mut fields = Vec::new();
    delimiter.split_row(text, Some(width), &mut fields);
    fields.len()
}

/// The last line of `preamble` that holds only names (no number among at least two fields) and
/// whose field count `fits`.
fn names_line(preamble: &[PendingLine], delimiter: Delimiter, fits: impl Fn(usize) -> bool) -> Option<usize> {
    let mut fields = Vec::new();
    preamble.iter().rposition(|p| {
        delimiter.split_row(&p.text, None, &mut fields);
        fields.len() >= 2 && fields.iter().all(|f| parse_number(f).is_none()) && fits(fields.len())
    })
}

impl<R: BufRead> RowReader<R> {
    /// Reads ahead to the first data row. A data row is a line of numbers, or a line under a header
    /// (a line of names with as many fields) with numbers in at least [`MIN_NUMBERS_IN_A_ROW`] of
    /// its fields: a logger's rows may carry a text column (a state letter, a label) and leave the
    /// columns of other packets empty. Lines before the header are metadata.
    pub fn new(mut reader: R, file: &str, options: &TableOptions) -> Result<Self, TableError> {
        let mut line_no = 0;
        let mut buffer = String::new();
        let mut preamble: Vec<PendingLine> = Vec::new();
        loop {
            let mut fields = Vec::new();
            let ended = read_line(&mut reader, &mut buffer, file, line_no + 1)?;
            let Some(ended) = ended else {
                if line_no == 0 {
                    return Err(TableError::Empty {
                        file: file.to_string(),
                    });
                }
                return Err(TableError::NoData {
                    file: file.to_string(),
                    lines: line_no,
                });
            };
            line_no += 1;
            let text = buffer.trim_end_matches(['\n', '\r']);
            if is_skippable(text) {
                continue;
            }
            let delimiter = options.delimiter.unwrap_or_else(|| Delimiter::detect(text));
            delimiter.split_row(text, None, &mut fields);
            let numbers = fields.iter().filter(|f| parse_number(f).is_some()).count();
            let line = PendingLine {
                line: line_no,
                text: text.to_string(),
                ended,
            };
            let header_at = if numbers == fields.len() {
                // A line of numbers fixes the width; the line before it is the header when it
                // splits into as many fields, else the last line of names that does.
                let width = fields.len();
                let previous = preamble
                    .len()
                    .checked_sub(1)
                    .filter(|&i| field_count(&preamble[i].text, delimiter, width) == width);
                Some((
                    previous.or_else(|| names_line(&preamble, delimiter, |w| w == width)),
                    width,
                ))
            } else if numbers >= MIN_NUMBERS_IN_A_ROW {
                let mut names = Vec::new();
                names_line(&preamble, delimiter, |w| field_count(text, delimiter, w) == w).map(|i| {
                    delimiter.split_row(&preamble[i].text, None, &mut names);
                    (Some(i), names.len())
                })
            } else {
                None
            };
            let Some((header_at, width)) = header_at else {
                preamble.push(line);
                continue;
            };
            let mut header = Vec::new();
            let mut pending = Vec::new();
            if let Some(i) = header_at {
                let mut names = Vec::new();
                delimiter.split_row(&preamble[i].text, Some(width), &mut names);
                header = names.iter().map(|s| s.trim_matches('"').to_string()).collect();
                // Lines between the header and this row are rows too when they are as wide (a
                // packet of another kind); narrower or wider ones stay metadata.
                let after: Vec<PendingLine> = preamble.drain(i..).skip(1).collect();
                for later in after {
                    if field_count(&later.text, delimiter, width) == width {
                        pending.push(later);
                    } else {
                        preamble.push(later);
                    }
                }
            }
            pending.push(line);
            return Ok(RowReader {
                reader,
                file: file.to_string(),
                delimiter,
                header,
                metadata: preamble.into_iter().map(|p| (p.line, p.text)).collect(),
                width,
                line_no,
                bytes: Vec::new(),
                pending: pending.into(),
                current_line: 0,
                used: Vec::new(),
                skip_incomplete: false,
                incomplete: Incomplete::default(),
            });
        }
    }

    /// Only `columns` (0-based) must hold numbers from now on: the others may hold text or
    /// nothing, and a row with an empty cell in one of `columns` comes back as
    /// [`Record::Incomplete`] (from [`RowReader::next_row`]: skipped and counted).
    pub fn choose_columns(&mut self, columns: &[usize]) {
        self.used = vec![false; self.width];
        for &c in columns {
            if let Some(u) = self.used.get_mut(c) {
                *u = true;
            }
        }
        self.skip_incomplete = true;
    }

    /// The text of the line last returned, without its line ending (for writing it out as it was).
    /// Bytes that are not UTF-8 are replaced by U+FFFD.
    pub fn line_text(&self) -> std::borrow::Cow<'_, str> {
        let mut end = self.bytes.len();
        while end > 0 && matches!(self.bytes[end - 1], b'\n' | b'\r') {
            end -= 1;
        }
        String::from_utf8_lossy(&self.bytes[..end])
    }

    fn need(&self) -> Need<'_> {
        Need {
            used: &self.used,
            skip_incomplete: self.skip_incomplete,
        }
    }

    /// Number of fields per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The source name used in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// Reads the next data row into `values`; returns its 1-based line, or `None` at the end.
    /// Incomplete rows (see [`RowReader::choose_columns`]) are skipped and counted in
    /// [`RowReader::incomplete`].
    pub fn next_row(&mut self, values: &mut Vec<f64>) -> Result<Option<usize>, TableError> {
        while let Some(line) = self.next_line(true)? {
            match self.parse_line(values) {
                Ok(Some(Checked::Row)) => return Ok(Some(line)),
                Ok(Some(Checked::Incomplete { column })) => self.incomplete.add(line, column),
                Ok(None) => {}
                Err(fault) => return Err(self.locate(fault)),
            }
        }
        Ok(None)
    }

    /// Reads the next data line, whether or not it parses: a line that cannot be read comes back
    /// as [`Record::Refused`] with its text and the reason, and reading goes on. Only a failure
    /// of the underlying reader is an error.
    pub fn next_record(&mut self, values: &mut Vec<f64>) -> Result<Option<Record>, TableError> {
        while let Some(line) = self.next_line(false)? {
            return Ok(Some(match self.parse_line(values) {
                Ok(Some(Checked::Row)) => Record::Parsed { line },
                Ok(Some(Checked::Incomplete { column })) => Record::Incomplete {
                    line,
                    column: column + 1,
                    column_name: self.header.get(column).cloned(),
                },
                Ok(None) => continue,
                Err(fault) => Record::Refused {
                    line,
                    text: self.line_text().to_string(),
                    error: self.locate(fault),
                },
            }));
        }
        Ok(None)
    }

    /// Puts the next line (read ahead, or from the reader) in the buffer; returns its number.
    /// `strict_text`: bytes that are not UTF-8 are an error here rather than a refused line.
    fn next_line(&mut self, strict_text: bool) -> Result<Option<usize>, TableError> {
        self.bytes.clear();
        if let Some(pending) = self.pending.pop_front() {
            self.bytes.extend_from_slice(pending.text.as_bytes());
            if pending.ended {
                self.bytes.push(b'\n');
            }
            self.current_line = pending.line;
            return Ok(Some(pending.line));
        }
        match self.reader.read_until(b'\n', &mut self.bytes) {
            Ok(0) => Ok(None),
            Ok(_) => {
                self.line_no += 1;
                self.current_line = self.line_no;
                Ok(Some(self.line_no))
            }
            Err(e) if strict_text && e.kind() == std::io::ErrorKind::InvalidData => {
                Err(TableError::NotText {
                    file: self.file.clone(),
                    line: self.line_no + 1,
                })
            }
            Err(source) => Err(TableError::Io {
                file: self.file.clone(),
                source,
            }),
        }
    }

    /// Parses the line in the buffer into `values`; `None` for a blank or comment line.
    fn parse_line(&self, values: &mut Vec<f64>) -> Result<Option<Checked>, Fault> {
        values.resize(self.width, 0.0);
        if let Fast::Row(_) = fast_row(&self.bytes, self.delimiter, values) {
            return Ok(Some(Checked::Row));
        }
        // A fast row is ASCII, so only the other lines need the UTF-8 check.
        let text = std::str::from_utf8(&self.bytes).map_err(|_| Fault::NotText)?;
        let has_newline = text.ends_with('\n');
        let text = text.trim_end_matches(['\n', '\r']);
        if is_skippable(text) {
            return Ok(None);
        }
        check_row(text, self.delimiter, self.width, has_newline, self.need(), values).map(Some)
    }

    fn locate(&self, fault: Fault) -> TableError {
        fault.locate(&self.file, self.current_line, &self.header, self.width)
    }
}

/// Reads one line; `Some(true)` when it ended with a newline, `Some(false)` at an unterminated last
/// line, `None` at end of input.
fn read_line<R: BufRead>(
    reader: &mut R,
    buffer: &mut String,
    file: &str,
    line: usize,
) -> Result<Option<bool>, TableError> {
    buffer.clear();
    match reader.read_line(buffer) {
        Ok(0) => Ok(None),
        Ok(_) => {
            // Spreadsheet exports start with a UTF-8 byte-order mark; it is not part of the text.
            if line == 1 && buffer.starts_with('\u{feff}') {
                buffer.drain(..'\u{feff}'.len_utf8());
            }
            Ok(Some(buffer.ends_with('\n')))
        }
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => Err(TableError::NotText {
            file: file.to_string(),
            line,
        }),
        Err(source) => Err(TableError::Io {
            file: file.to_string(),
            source,
        }),
    }
}

/// Blank lines and comments (`#`, `%`); `%time` opens the header of `rostopic echo -p`'s CSV.
fn is_skippable(text: &str) -> bool {
    let t = text.trim_start();
    t.is_empty() || t.starts_with('#') || (t.starts_with('%') && !t.starts_with("%time"))
}

/// A header-detection parse: a field counts as numeric only when it is a finite or non-finite
/// float literal (so a row of NaNs is still a data row and gets a located error later).
fn parse_number(field: &str) -> Option<f64> {
    field.parse::<f64>().ok()
}

/// Builds a display name for a path.
pub fn display_name(path: &Path) -> String {
    PathBuf::from(path).display().to_string()
}

#[cfg(test)]
mod reference;

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Table, TableError> {
        Table::read(text.as_bytes(), "test.csv", &TableOptions::default())
    }

    #[test]
    fn reads_header_metadata_and_rows() {
        let t = read("Fs,100\nsensor,mpu\nt,ax,ay\n0,1,2\n0.01,1.5,2.5\n").unwrap();
        assert_eq!(t.header, ["t", "ax", "ay"]);
        assert_eq!(
            t.metadata,
            [(1, "Fs,100".to_string()), (2, "sensor,mpu".to_string())]
        );
        assert_eq!(t.columns[1], [1.0, 1.5]);
        assert_eq!(t.lines, [4, 5]);
        assert_eq!(t.delimiter, Delimiter::Comma);
    }

    #[test]
    fn detects_every_separator() {
        for (text, d) in [
            ("1;2;3\n", Delimiter::Semicolon),
            ("1\t2\t3\n", Delimiter::Tab),
            ("1  2 3\n", Delimiter::Whitespace),
            ("1,2,3,\n", Delimiter::Comma),
        ] {
            let t = read(text).unwrap();
            assert_eq!(t.delimiter, d, "{text:?}");
            assert_eq!(t.n_columns(), 3, "{text:?}");
        }
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = read("t,ax\n0,1\n0.01,abc\n").unwrap_err();
        assert_eq!(e.to_string(), "test.csv:3, column 2 (ax): 'abc' is not a number");
        let e = read("t,ax\n0,1\n0.01,NaN\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.csv:3, column 2 (ax): the value is NaN; spincal needs finite numbers"
        );
        let e = read("t,ax\n0,1\n0.01,\n0.02,1\n").unwrap_err();
        assert_eq!(e.to_string(), "test.csv:3, column 2 (ax): the cell is empty");
        let e = read("t,ax\n0,1\n0.01,1,3\n").unwrap_err();
        assert_eq!(e.to_string(), "test.csv:3: expected 2 fields, found 3");
        let e = read("t,ax,ay\n0,1,2\n0.01,1").unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.csv: the last line (3) has no line ending and only 2 of 3 fields: the file looks truncated"
        );
        assert_eq!(read("").unwrap_err().to_string(), "test.csv: the file is empty");
        assert_eq!(
            read("t,ax\n").unwrap_err().to_string(),
            "test.csv: no numeric data rows found (1 lines read, none was all numbers)"
        );
    }

    #[test]
    fn reads_a_text_label_column() {
        let t = read_labelled(
            "# note\npart,n,ax\nx_p,0,1.5\nx_a,1,-2\n".as_bytes(),
            "l.csv",
            &TableOptions::default(),
            "PART",
        )
        .unwrap();
        assert_eq!(t.labels, ["x_p", "x_a"]);
        assert_eq!(t.table.header, ["n", "ax"]);
        assert_eq!(t.table.columns[1], [1.5, -2.0]);
        let e = read_labelled(
            "part,n,ax\nx,0,q\n".as_bytes(),
            "l.csv",
            &TableOptions::default(),
            "part",
        )
        .unwrap_err();
        assert_eq!(e.to_string(), "l.csv:2, column 3 (ax): 'q' is not a number");
        let e = read_labelled(
            "n,ax\n0,1\n".as_bytes(),
            "l.csv",
            &TableOptions::default(),
            "part",
        )
        .unwrap_err();
        assert!(e.to_string().contains("label column 'part'"), "{e}");
    }

    #[test]
    fn columns_by_name_or_one_based_index() {
        let t = read("time,AX\n0,1\n").unwrap();
        assert_eq!(t.column_index("ax"), Some(1));
        assert_eq!(t.column_index("1"), Some(0));
        assert_eq!(t.column_index("3"), None);
    }

    /// What a reader made of some input, comparable across readers: the table's every bit, or the
    /// error's text.
    fn outcome(result: Result<Table, TableError>) -> Result<String, String> {
        result
            .map(|t| {
                let bits: Vec<Vec<u64>> = t
                    .columns
                    .iter()
                    .map(|c| c.iter().map(|v| v.to_bits()).collect())
                    .collect();
                format!(
                    "{} {:?} {:?} {:?} {:?} {:?}",
                    t.file, t.delimiter, t.header, t.metadata, bits, t.lines
                )
            })
            .map_err(|e| e.to_string())
    }

    /// Every row the streaming reader gives (`next_record`), as text.
    fn streamed(bytes: &[u8], options: &TableOptions) -> Result<Vec<String>, String> {
        let mut rows = RowReader::new(bytes, "test.csv", options).map_err(|e| e.to_string())?;
        let mut values = Vec::new();
        let mut out = Vec::new();
        while let Some(record) = rows.next_record(&mut values).map_err(|e| e.to_string())? {
            out.push(match record {
                Record::Parsed { line } => {
                    format!(
                        "{line} {:?}",
                        values.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                    )
                }
                Record::Refused { line, text, error } => format!("{line} refused {text:?}: {error}"),
                Record::Incomplete { line, column, .. } => format!("{line} incomplete at column {column}"),
            });
        }
        Ok(out)
    }

    fn old_streamed(bytes: &[u8], options: &TableOptions) -> Result<Vec<String>, String> {
        let mut rows = reference::OldRowReader::new(bytes, "test.csv", options).map_err(|e| e.to_string())?;
        let mut values = Vec::new();
        let mut out = Vec::new();
        while let Some(record) = rows.next_record(&mut values).map_err(|e| e.to_string())? {
            out.push(match record {
                Record::Parsed { line } => {
                    format!(
                        "{line} {:?}",
                        values.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                    )
                }
                Record::Refused { line, text, error } => format!("{line} refused {text:?}: {error}"),
                Record::Incomplete { line, column, .. } => format!("{line} incomplete at column {column}"),
            });
        }
        Ok(out)
    }

    /// The byte-level reader, in any number of chunks, and the streaming reader agree with the
    /// line-at-a-time reader they replace: same bits, same lines, same errors.
    fn agree_with(bytes: &[u8], options: &TableOptions) {
        let old = outcome(reference::read(bytes, "test.csv", options));
        assert_eq!(
            outcome(Table::parse(bytes, "test.csv", options)),
            old,
            "{:?}",
            String::from_utf8_lossy(bytes)
        );
        let windows = [
            (2, WINDOW_BYTES),
            (3, WINDOW_BYTES),
            (7, WINDOW_BYTES),
            (64, WINDOW_BYTES),
            (1, 1),
            (1, 9),
            (3, 1),
            (5, 40),
        ];
        for (chunks, window) in windows {
            let chunked = TableHead::new(bytes, "test.csv", options).and_then(|head| {
                let every: Vec<(usize, f64)> = (0..head.width()).map(|c| (c, 1.0)).collect();
                let rows = head.rows_in_windows(&every, |_| chunks, window)?;
                Ok(Table {
                    file: "test.csv".into(),
                    delimiter: head.delimiter,
                    header: head.header,
                    metadata: head.metadata,
                    columns: rows.columns,
                    lines: rows.lines,
                })
            });
            assert_eq!(
                outcome(chunked),
                old,
                "{chunks} chunks, windows of {window} bytes: {:?}",
                String::from_utf8_lossy(bytes)
            );
        }
        // The streaming reader stops at the first error with `next_row` …
        let mut next_row = RowReader::new(bytes, "test.csv", options).and_then(|mut rows| {
            let mut columns = vec![Vec::new(); rows.width()];
            let mut lines = Vec::new();
            let mut values = Vec::new();
            while let Some(line) = rows.next_row(&mut values)? {
                columns.iter_mut().zip(&values).for_each(|(c, v)| c.push(*v));
                lines.push(line);
            }
            Ok(Table {
                file: "test.csv".into(),
                delimiter: rows.delimiter,
                header: rows.header.clone(),
                metadata: rows.metadata.clone(),
                columns,
                lines,
            })
        });
        if let Ok(t) = &mut next_row {
            t.file = "test.csv".into();
        }
        assert_eq!(
            outcome(next_row),
            old,
            "next_row: {:?}",
            String::from_utf8_lossy(bytes)
        );
        // … and goes on past it with `next_record`. The old reader refused a bad first data row
        // while looking for the header; the new one reads ahead as text and refuses that row
        // like any other, with the same message.
        let new = streamed(bytes, options);
        match (&new, old_streamed(bytes, options)) {
            (Ok(rows), Err(old)) if rows.first().is_some_and(|r| r.ends_with(&format!(": {old}"))) => {}
            (new, old) => assert_eq!(new, &old, "{:?}", String::from_utf8_lossy(bytes)),
        }
    }

    fn agree(bytes: &[u8]) {
        agree_with(bytes, &TableOptions::default());
    }

    #[test]
    fn fast_reader_agrees_on_awkward_files() {
        for text in [
            // line endings, BOM, blank and comment lines, an empty last line
            &b"t,ax\r\n0,1\r\n0.01,2\r\n"[..],
            b"\xef\xbb\xbft,ax\n0,1\n0.01,2\n",
            b"\xef\xbb\xbf0,1\n0.01,2",
            b"t,ax\n\n0,1\n   \n# note\n  % note\n0.01,2\n\n",
            b"t,ax\n0,1\n0.01,2\n\n\n",
            b"t,ax\n0,1\n0.01,2\n   ",
            b"t,ax\n0,1\n0.01,2\r\r\n",
            b"t,ax\n0,1\n0.01,2\r",
            // quoted header names, trailing separators, padding
            b"\"t\",\"ax\"\n0,1\n0.01,2\n",
            b"t,ax,\n0,1,\n0.01 , 2 ,\t\n",
            b"t,ax\n0,1\n0.01,2,,\n",
            b"t,ax\n 0 ,\t1\x0b\n0.01,\x0c2\n",
            // every separator
            b"t;ax;ay\n0;1;2\n1;2;3;\n",
            b"t\tax\tay\n0\t1\t2\n1\t\t3\n",
            b"t\tax\n0\t1\n\t1\t2\n",
            b"t\tax\n0\t1\n1 \t 2\t\n",
            b"t ax ay\n0 1 2\n  1\t2   3  \n",
            b"0 1 2\n1 2\n",
            b"0 1 2\n1 2 3 4\n",
            b"0 1 2\n1,2 3 4\n",
            // number syntax
            b"t,ax\n0,+1\n1,-.5\n2,5.\n3,1e5\n4,1E-5\n5,-0\n6,00012\n7,1e+300\n",
            b"t,ax\n0,1\n1,1e\n",
            b"t,ax\n0,1\n1,.\n",
            b"t,ax\n0,1\n1,1.2.3\n",
            b"t,ax\n0,1\n1,0x10\n",
            b"t,ax\n0,1\n1,1_0\n",
            b"t,ax\n0,1\n1,1e400\n",
            b"t,ax\n0,1\n1,1e-400\n",
            b"t,ax\n0,1\n1,-inf\n",
            b"t,ax\n0,1\n1,infinity\n",
            b"t,ax\n0,1\n1,nan\n",
            b"t,ax\n0,NaN\n",
            b"t,ax\n0,1\n1,123456789012345678901234567890.123456789e-10\n",
            b"t,ax\n0,1\n1,0.30000000000000004441\n2,2.2250738585072011e-308\n3,1.7976931348623157e308\n",
            b"t,ax\n0,1\n1,9007199254740993\n2,0.1000000000000000055511151231257827\n",
            // errors
            b"t,ax\n0,1\n1,\"2\"\n",
            b"t,ax\n0,1\n1,2 3\n",
            b"t,ax\n0,1\n1\n",
            b"t,ax,ay\n0,1,2\n1,2",
            b"t,ax,ay\n0,1,2\n1,2,",
            b"t,ax\n0,1\n1,abc\n2,3",
            // Unicode spacing and text
            "t,ax\n0,1\n1,\u{a0}2\n".as_bytes(),
            "t,ax\n0,1\n\u{3000}# note\n1,2\n".as_bytes(),
            "t ax\n0 1\n1\u{2003}2\n".as_bytes(),
            "t,ax\n0,1\n1,2µ\n".as_bytes(),
            "t,ax\n0,1\n# µ\n1,2\n".as_bytes(),
            // not UTF-8: in a row, in a comment, after an earlier error, at the very start
            b"t,ax\n0,1\n1,2\n2,\xff\n3,4\n",
            b"t,ax\n0,1\n# \xff\n3,4\n",
            b"t,ax\n0,1\n1,x\n2,\xff\n",
            b"t,ax\n0,1\n1,2\n2,3\xff",
            b"\xff\n0,1\n",
            b"t,ax\n\xff\n0,1\n",
            // no data
            b"",
            b"\n\n",
            b"t,ax\n",
            b"t,ax\n# only\n",
        ] {
            agree(text);
        }
        for delimiter in [
            Delimiter::Comma,
            Delimiter::Semicolon,
            Delimiter::Tab,
            Delimiter::Whitespace,
        ] {
            let options = TableOptions {
                delimiter: Some(delimiter),
            };
            for text in [
                &b"t,ax\n0,1\n1,2\n"[..],
                b"t;ax\n0;1\n1;2;\n",
                b"t\tax\n0\t1\n1\t2\n",
                b"t ax\n0 1\n1  2\n",
                b"0,1 2\n1,2 3\n",
            ] {
                agree_with(text, &options);
            }
        }
    }

    #[test]
    fn fast_reader_agrees_on_random_text() {
        use proptest::prelude::*;
        let token = prop_oneof![
            (-1e6f64..1e6).prop_map(|v| format!("{v}")),
            (-1e6f64..1e6).prop_map(|v| format!("{v:e}")),
            any::<f64>().prop_map(|v| format!("{v}")),
            any::<u64>().prop_map(|v| format!("{v}.{}", v % 1000)),
            Just("NaN".to_string()),
            Just("inf".to_string()),
            Just("".to_string()),
            Just("x".to_string()),
            Just("1e".to_string()),
            Just("\"t\"".to_string()),
            Just("\u{a0}".to_string()),
            Just("é".to_string()),
        ];
        let sep = prop_oneof![
            4 => Just(","),
            1 => Just(";"),
            1 => Just("\t"),
            1 => Just(" "),
            1 => Just("  "),
            3 => Just("\n"),
            1 => Just("\r\n"),
            1 => Just("\n# c\n"),
            1 => Just("\n\n"),
        ];
        let text = proptest::collection::vec((token, sep), 0..80).prop_map(|v| {
            let body: String = v.into_iter().map(|(t, s)| t + s).collect();
            format!("t,ax,ay\n0,1,2\n{body}")
        });
        let mut runner = proptest::test_runner::TestRunner::new(proptest::test_runner::Config {
            cases: 2000,
            ..Default::default()
        });
        runner
            .run(&text, |text| {
                agree(text.as_bytes());
                Ok(())
            })
            .unwrap();
    }

    /// A file of `rows` rows of full-precision numbers, as spincal writes them.
    fn long_file(rows: usize) -> String {
        let mut text = String::from("t,ax,ay\n");
        for i in 0..rows {
            let x = (i as f64 * 0.7).sin() * 9.81;
            text.push_str(&format!("{},{},{}\n", i as f64 * 0.01, x, x / 3.0));
        }
        text
    }

    #[test]
    fn bad_number_in_a_later_chunk_names_its_line() {
        let mut lines: Vec<String> = long_file(20_000).lines().map(String::from).collect();
        lines[15_000 - 1] = "150,1,x".into();
        let text = lines.join("\n") + "\n";
        let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
        for chunks in [1, 2, 8, 100] {
            let e = head.rows_in_chunks(&[(0, 1.0), (2, 1.0)], chunks).unwrap_err();
            assert_eq!(
                e.to_string(),
                "test.csv:15000, column 3 (ay): 'x' is not a number"
            );
            // Text in a column not chosen is no error.
            assert_eq!(
                head.rows_in_chunks(&[(0, 1.0)], chunks).unwrap().lines.len(),
                20_000
            );
        }
        // The first fault in the file wins, even when a later chunk has one too.
        lines[3_000 - 1] = "30,,1".into();
        let text = lines.join("\n") + "\n";
        let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
        for chunks in [1, 2, 8, 100] {
            let e = head.rows_in_chunks(&[(1, 1.0)], chunks).unwrap_err();
            assert_eq!(e.to_string(), "test.csv:3000, column 2 (ax): the cell is empty");
        }
        agree(text.as_bytes());
    }

    /// An empty cell is an error only in a chosen column, in any chunk; elsewhere the row is kept.
    #[test]
    fn empty_cells_in_columns_not_chosen_are_allowed() {
        let mut lines: Vec<String> = long_file(20_000).lines().map(String::from).collect();
        lines[3_000 - 1] = "30,,1".into();
        lines[17_000 - 1] = "170,2,".into();
        let text = lines.join("\n") + "\n";
        let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
        for chunks in [1, 2, 8, 100] {
            let rows = head.rows_in_chunks(&[(0, 1.0)], chunks).unwrap();
            assert_eq!(rows.lines.len(), 20_000);
            assert_eq!(rows.columns[0][3_000 - 2], 30.0);
            let e = head.rows_in_chunks(&[(0, 1.0), (2, 1.0)], chunks).unwrap_err();
            assert_eq!(e.to_string(), "test.csv:17000, column 3 (ay): the cell is empty");
        }
        let t = Table::parse_columns(text.as_bytes(), "test.csv", &TableOptions::default(), &["t"]).unwrap();
        assert_eq!(
            (t.header.as_slice(), t.n_rows()),
            (&["t".to_string()][..], 20_000)
        );
        let e = Table::parse(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap_err();
        assert_eq!(e.to_string(), "test.csv:3000, column 2 (ax): the cell is empty");
        let e =
            Table::parse_columns(text.as_bytes(), "test.csv", &TableOptions::default(), &["q"]).unwrap_err();
        assert_eq!(e.to_string(), "test.csv: no column 'q' (columns: t, ax, ay)");
    }

    #[test]
    fn chunks_and_threads_do_not_change_a_bit() {
        let text = long_file(150_000) + "# end\n\n";
        let head = TableHead::new(text.as_bytes(), "test.csv", &TableOptions::default()).unwrap();
        let targets = [(2, 1.0), (0, 1e-3), (1, std::f64::consts::PI / 180.0), (1, 1.0)];
        let one = head.rows_in_chunks(&targets, 1).unwrap();
        assert_eq!(one.lines.len(), 150_000);
        assert_eq!(one.lines[149_999], 150_001);
        for chunks in [2, 5, 16] {
            assert_eq!(head.rows_in_chunks(&targets, chunks).unwrap(), one);
            for window in [1 << 12, 100_001] {
                assert_eq!(head.rows_in_windows(&targets, |_| chunks, window).unwrap(), one);
            }
        }
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            assert_eq!(pool.install(|| head.rows(&targets)).unwrap(), one);
        }
        agree(text.as_bytes());
    }

    /// A mapped file read in small windows gives back each window's pages as it goes: the rows are
    /// those of the same bytes in a `Vec`, and the map still reads as the file afterwards.
    #[test]
    fn a_mapped_file_read_in_windows_is_read_whole_and_left_intact() {
        let text = long_file(40_000) + "# end\n";
        assert!(
            text.len() as u64 >= MAP_BYTES,
            "{} bytes are too few to be mapped",
            text.len()
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("long.csv");
        std::fs::write(&path, &text).unwrap();
        let bytes = read_file(&path).unwrap();
        assert!(matches!(bytes, FileBytes::Mapped(_)));
        let targets = [(0, 1.0), (2, 2.0)];
        let mapped = TableHead::new(&bytes, "long.csv", &TableOptions::default()).unwrap();
        let copied = TableHead::new(text.as_bytes(), "long.csv", &TableOptions::default()).unwrap();
        let expected = copied.rows(&targets).unwrap();
        for chunks in [1, 3] {
            assert_eq!(
                mapped.rows_in_windows(&targets, |_| chunks, 5000).unwrap(),
                expected
            );
        }
        assert!(*bytes == *text.as_bytes());
    }
}
