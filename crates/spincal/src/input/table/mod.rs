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

mod fast;
mod head;
mod labelled;
mod mapped;
mod reader;

pub use head::Incomplete;
pub(crate) use head::TableHead;
pub use labelled::{read_labelled, LabelledTable};
pub use mapped::{read_file, FileBytes, MappedFile};
pub use reader::{Record, RowReader, MIN_NUMBERS_IN_A_ROW};

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

/// Builds a display name for a path.
pub fn display_name(path: &Path) -> String {
    PathBuf::from(path).display().to_string()
}

#[cfg(test)]
mod reference;

#[cfg(test)]
mod tests;
