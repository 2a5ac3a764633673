//! The streaming row reader: metadata, header, separator and width from the first lines, then
//! one row at a time.

use std::io::BufRead;

use super::fast::{fast_row, Fast};
use super::head::{check_row, Checked, Fault, Incomplete, Need};
use super::{Delimiter, TableError, TableOptions};

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
/// are parsed from one reused byte buffer by the same byte-level parser as `TableHead::rows`.
pub struct RowReader<R: BufRead> {
    pub(super) reader: R,
    pub(super) file: String,
    pub delimiter: Delimiter,
    pub header: Vec<String>,
    pub metadata: Vec<(usize, String)>,
    pub(super) width: usize,
    line_no: usize,
    /// The current line's bytes, reused from line to line.
    bytes: Vec<u8>,
    /// The line in `bytes`.
    current_line: usize,
    /// Data lines read ahead during construction, handed out first.
    pub(super) pending: std::collections::VecDeque<PendingLine>,
    /// The columns that must hold numbers (every one when empty); see [`RowReader::choose_columns`].
    used: Vec<bool>,
    skip_incomplete: bool,
    /// Incomplete rows skipped by [`RowReader::next_row`].
    pub incomplete: Incomplete,
}

/// A line read ahead of the data, kept as text until the columns that matter are known.
#[derive(Debug, Clone)]
pub(super) struct PendingLine {
    pub(super) line: usize,
    pub(super) text: String,
    /// Whether a newline ended it (a last line without one may be truncated).
    pub(super) ended: bool,
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
pub(super) fn read_line<R: BufRead>(
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
pub(super) fn is_skippable(text: &str) -> bool {
    let t = text.trim_start();
    t.is_empty() || t.starts_with('#') || (t.starts_with('%') && !t.starts_with("%time"))
}

/// A header-detection parse: a field counts as numeric only when it is a finite or non-finite
/// float literal (so a row of NaNs is still a data row and gets a located error later).
fn parse_number(field: &str) -> Option<f64> {
    field.parse::<f64>().ok()
}
