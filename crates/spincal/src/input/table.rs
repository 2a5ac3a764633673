//! Delimited numeric text tables: the one parser behind every CSV-like format spincal reads.
//!
//! A table is: optional metadata lines (reported, not parsed), an optional header line, then rows of
//! numbers. Separators are comma, semicolon, tab or runs of whitespace, detected from the first data
//! line unless given. Lines starting with `#` or `%` and blank lines are skipped anywhere. A trailing
//! separator (e.g. `1.0,2.0,`) is tolerated. Every error names the file, the 1-based line and the
//! 1-based column (with its header name when there is one).

use std::fmt;
use std::io::BufRead;
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

    /// The separator written by [`Delimiter::join`]-style writers.
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

    /// Reads a table from a file path.
    pub fn read_path(path: &Path, options: &TableOptions) -> Result<Table, TableError> {
        let file = path.display().to_string();
        let handle = std::fs::File::open(path).map_err(|source| TableError::Io {
            file: file.clone(),
            source,
        })?;
        Table::read(std::io::BufReader::new(handle), &file, options)
    }

    /// Reads a table from any buffered reader; `file` names the source in errors.
    pub fn read<R: BufRead>(reader: R, file: &str, options: &TableOptions) -> Result<Table, TableError> {
        let mut rows = RowReader::new(reader, file, options)?;
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

    /// Finds a column by header name (case-insensitive) or by 1-based index written as a number.
    pub fn column_index(&self, key: &str) -> Option<usize> {
        find_column(&self.header, self.n_columns(), key)
    }
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
    /// The line could not be read as a row; its text and why.
    Refused {
        line: usize,
        text: String,
        error: TableError,
    },
}

/// Streams the rows of a table one at a time, in constant memory.
///
/// Construction reads ahead to the first data row to learn the separator, header and width.
pub struct RowReader<R: BufRead> {
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

impl<R: BufRead> RowReader<R> {
    pub fn new(mut reader: R, file: &str, options: &TableOptions) -> Result<Self, TableError> {
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
            let mut rows = RowReader {
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
    pub fn width(&self) -> usize {
        self.width
    }

    /// The source name used in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// Reads the next data row into `values`; returns its 1-based line, or `None` at the end.
    pub fn next_row(&mut self, values: &mut Vec<f64>) -> Result<Option<usize>, TableError> {
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
    pub fn next_record(&mut self, values: &mut Vec<f64>) -> Result<Option<Record>, TableError> {
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

/// Builds a display name for a path.
pub fn display_name(path: &Path) -> String {
    PathBuf::from(path).display().to_string()
}

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
}
