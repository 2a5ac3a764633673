//! The table reader as it was before the byte-level parser (one `String` per line, `str` splitting,
//! `str::parse`), kept for tests only: the fast reader must agree with it on values and on every
//! error.

use std::io::BufRead;

use super::{Delimiter, Location, Record, Table, TableError, TableOptions};

/// The old `Table::read`.
pub(super) fn read<R: BufRead>(reader: R, file: &str, options: &TableOptions) -> Result<Table, TableError> {
    let mut rows = OldRowReader::new(reader, file, options)?;
    let width = rows.width();
    let mut columns = vec![Vec::new(); width];
    let mut lines = Vec::new();
    let mut values = Vec::with_capacity(width);
    while let Some(line) = rows.next_row(&mut values)? {
        for (column, v) in columns.iter_mut().zip(&values) {
            column.push(*v);
        }
        lines.push(line);
    }
    Ok(Table {
        file: file.to_string(),
        delimiter: rows.delimiter,
        header: rows.header.clone(),
        metadata: rows.metadata.clone(),
        columns,
        lines,
    })
}

/// The line-at-a-time reader as it was before the byte-level parser.
pub(super) struct OldRowReader<R: BufRead> {
    reader: R,
    file: String,
    pub delimiter: Delimiter,
    pub header: Vec<String>,
    pub metadata: Vec<(usize, String)>,
    width: usize,
    line_no: usize,
    buffer: String,
    /// The first data line, parsed during construction and handed out by the first `next_row`.
    pending: Option<(usize, Vec<f64>)>,
}

impl<R: BufRead> OldRowReader<R> {
    pub(super) fn new(mut reader: R, file: &str, options: &TableOptions) -> Result<Self, TableError> {
        let mut line_no = 0;
        let mut buffer = String::new();
        let mut preamble: Vec<(usize, String)> = Vec::new();
        loop {
            let mut fields = Vec::new();
            let ended = read_line(&mut reader, &mut buffer, file, line_no + 1)?;
            if ended.is_none() {
                if line_no == 0 {
                    return Err(TableError::Empty {
                        file: file.to_string(),
                    });
                }
                return Err(TableError::NoData {
                    file: file.to_string(),
                    lines: line_no,
                });
            }
            line_no += 1;
            let text = buffer.trim_end_matches(['\n', '\r']);
            if is_skippable(text) {
                continue;
            }
            let delimiter = options.delimiter.unwrap_or_else(|| Delimiter::detect(text));
            delimiter.split_row(text, None, &mut fields);
            let numbers: Option<Vec<f64>> = fields.iter().map(|f| parse_number(f)).collect();
            let Some(values) = numbers else {
                preamble.push((line_no, text.to_string()));
                continue;
            };
            // The first all-numeric line fixes separator and width; the line before it is the
            // header when it splits into the same number of fields.
            let width = values.len();
            let mut header = Vec::new();
            if let Some((_, last)) = preamble.last() {
                let mut names = Vec::new();
                delimiter.split_row(last, Some(width), &mut names);
                if names.len() == width {
                    header = names.iter().map(|s| s.trim_matches('"').to_string()).collect();
                    preamble.pop();
                }
            }
            let mut rows = OldRowReader {
                reader,
                file: file.to_string(),
                delimiter,
                header,
                metadata: preamble,
                width,
                line_no,
                buffer: String::new(),
                pending: None,
            };
            let mut checked = Vec::with_capacity(width);
            rows.parse_fields(text, line_no, &mut checked, ended == Some(true))?;
            rows.pending = Some((line_no, checked));
            return Ok(rows);
        }
    }

    /// Number of fields per row.
    pub(super) fn width(&self) -> usize {
        self.width
    }

    /// Reads the next data row into `values`; returns its 1-based line, or `None` at the end.
    pub(super) fn next_row(&mut self, values: &mut Vec<f64>) -> Result<Option<usize>, TableError> {
        if let Some((line, first)) = self.pending.take() {
            values.clear();
            values.extend_from_slice(&first);
            return Ok(Some(line));
        }
        loop {
            let mut buffer = std::mem::take(&mut self.buffer);
            let ended = read_line(&mut self.reader, &mut buffer, &self.file, self.line_no + 1)?;
            let Some(has_newline) = ended else {
                self.buffer = buffer;
                return Ok(None);
            };
            self.line_no += 1;
            let text = buffer.trim_end_matches(['\n', '\r']);
            if is_skippable(text) {
                self.buffer = buffer;
                continue;
            }
            let line = self.line_no;
            let result = self.parse_fields(text, line, values, has_newline);
            self.buffer = buffer;
            result?;
            return Ok(Some(line));
        }
    }

    /// Reads the next data line, whether or not it parses: a line that cannot be read comes back
    /// as [`Record::Refused`] with its text and the reason, and reading goes on. Only a failure
    /// of the underlying reader is an error.
    pub(super) fn next_record(&mut self, values: &mut Vec<f64>) -> Result<Option<Record>, TableError> {
        if let Some((line, first)) = self.pending.take() {
            values.clear();
            values.extend_from_slice(&first);
            return Ok(Some(Record::Parsed { line }));
        }
        let mut bytes = Vec::new();
        loop {
            bytes.clear();
            let read = self
                .reader
                .read_until(b'\n', &mut bytes)
                .map_err(|source| TableError::Io {
                    file: self.file.clone(),
                    source,
                })?;
            if read == 0 {
                return Ok(None);
            }
            self.line_no += 1;
            let line = self.line_no;
            let has_newline = bytes.ends_with(b"\n");
            while matches!(bytes.last(), Some(b'\n' | b'\r')) {
                bytes.pop();
            }
            let text = match std::str::from_utf8(&bytes) {
                Ok(text) => text,
                Err(_) => {
                    return Ok(Some(Record::Refused {
                        line,
                        text: String::from_utf8_lossy(&bytes).into_owned(),
                        error: TableError::NotText {
                            file: self.file.clone(),
                            line,
                        },
                    }))
                }
            };
            if is_skippable(text) {
                continue;
            }
            return Ok(Some(match self.parse_fields(text, line, values, has_newline) {
                Ok(()) => Record::Parsed { line },
                Err(error) => Record::Refused {
                    line,
                    text: text.to_string(),
                    error,
                },
            }));
        }
    }

    /// Parses the fields of one data line with full error locations.
    fn parse_fields(
        &self,
        text: &str,
        line: usize,
        values: &mut Vec<f64>,
        has_newline: bool,
    ) -> Result<(), TableError> {
        let mut fields = Vec::with_capacity(self.width);
        self.delimiter.split_row(text, Some(self.width), &mut fields);
        if fields.len() != self.width {
            if !has_newline && fields.len() < self.width {
                return Err(TableError::Truncated {
                    file: self.file.clone(),
                    line,
                    expected: self.width,
                    found: fields.len(),
                });
            }
            return Err(TableError::Ragged {
                at: self.location(line, None),
                expected: self.width,
                found: fields.len(),
            });
        }
        values.clear();
        for (c, field) in fields.iter().enumerate() {
            if field.is_empty() {
                return Err(TableError::EmptyCell {
                    at: self.location(line, Some(c)),
                });
            }
            match field.parse::<f64>() {
                Ok(v) if v.is_finite() => values.push(v),
                Ok(_) => {
                    return Err(TableError::NonFinite {
                        at: self.location(line, Some(c)),
                        text: field.to_string(),
                    });
                }
                Err(_) => {
                    return Err(TableError::NotANumber {
                        at: self.location(line, Some(c)),
                        text: field.to_string(),
                    });
                }
            }
        }
        Ok(())
    }

    fn location(&self, line: usize, column: Option<usize>) -> Location {
        Location {
            file: self.file.clone(),
            line,
            column: column.map(|c| c + 1),
            column_name: column.and_then(|c| self.header.get(c).cloned()),
        }
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

fn is_skippable(text: &str) -> bool {
    let t = text.trim_start();
    t.is_empty() || t.starts_with('#') || t.starts_with('%')
}

/// A header-detection parse: a field counts as numeric only when it is a finite or non-finite
/// float literal (so a row of NaNs is still a data row and gets a located error later).
fn parse_number(field: &str) -> Option<f64> {
    field.parse::<f64>().ok()
}
