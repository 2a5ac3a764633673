//! What the phone apps' CSVs share: the separator and decimal mark of the export's locale, the
//! U+2212 minus sign, quoted header names; one sensor's stream (time and three axes) picked by
//! column name; and the files of an export (zip members or a folder's files) by name.

use std::borrow::Cow;
use std::path::Path;

use super::super::FormatError;
use crate::input::table::{Delimiter, Table, TableOptions};

/// One sensor's samples as its app wrote them: time in seconds on the export's own clock, three
/// axes in SI units (m/s² or rad/s) in the app's sign convention turned into spincal's.
#[derive(Debug, Clone)]
pub(crate) struct Stream {
    /// `export/member` (or the file) the samples came from.
    pub(crate) file: String,
    pub(crate) time_s: Vec<f64>,
    pub(crate) xyz: [Vec<f64>; 3],
    /// 1-based line of each sample in `file`.
    pub(crate) lines: Vec<usize>,
    /// The time, x, y, z columns' names in the file.
    pub(crate) columns: Vec<String>,
}

impl Stream {
    pub(crate) fn len(&self) -> usize {
        self.time_s.len()
    }

    /// `first … last s` for messages.
    pub(crate) fn span(&self) -> String {
        match (self.time_s.first(), self.time_s.last()) {
            (Some(a), Some(b)) => format!("{a:.3} … {b:.3} s"),
            _ => "no samples".into(),
        }
    }
}

/// A CSV of a phone export ready for the table parser: its separator, whether a decimal comma
/// was turned into a point, its header names (quotes removed) and the normalised text.
pub(crate) struct PhoneCsv<'a> {
    pub(crate) file: String,
    pub(crate) delimiter: Delimiter,
    pub(crate) decimal_comma: bool,
    pub(crate) header: Vec<String>,
    pub(crate) text: Cow<'a, [u8]>,
}

impl<'a> PhoneCsv<'a> {
    /// Reads the header and normalises the text. The separator comes from the header line: tab,
    /// else semicolon, else comma (phyphox's five CSV variants and Physics Toolbox's locales use
    /// no other). With a tab or semicolon separator a comma can only be a decimal mark, so every
    /// comma becomes a point; U+2212 (the minus some locales print) becomes `-`.
    pub(crate) fn new(bytes: &'a [u8], file: &str) -> PhoneCsv<'a> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        let text = String::from_utf8_lossy(bytes);
        let header_line = text.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or("");
        let delimiter = if header_line.contains('\t') {
            Delimiter::Tab
        } else if header_line.contains(';') {
            Delimiter::Semicolon
        } else {
            Delimiter::Comma
        };
        let header = header_line
            .split(delimiter.as_char())
            .map(|f| f.trim().trim_matches('"').trim().to_string())
            .collect();
        let body_has_comma = text
            .lines()
            .skip_while(|l| l.trim().is_empty())
            .skip(1)
            .any(|l| l.contains(','));
        let decimal_comma = delimiter != Delimiter::Comma && body_has_comma;
        let minus = text.contains('\u{2212}');
        let text: Cow<'a, [u8]> = if decimal_comma || minus {
            let mut t = text.replace('\u{2212}', "-");
            if decimal_comma {
                t = t.replace(',', ".");
            }
            Cow::Owned(t.into_bytes())
        } else {
            Cow::Borrowed(bytes)
        };
        PhoneCsv {
            file: file.into(),
            delimiter,
            decimal_comma,
            header,
            text,
        }
    }

    /// The first column whose name (case-insensitive) is one of `names`.
    pub(crate) fn column(&self, names: &[&str]) -> Option<usize> {
        self.header
            .iter()
            .position(|h| names.iter().any(|n| h.eq_ignore_ascii_case(n)))
    }

    /// The header as one string for messages.
    pub(crate) fn columns_text(&self) -> String {
        self.header.join(", ")
    }

    /// Reads columns `t, x, y, z` (0-based) as a stream; `time_to_s` and `to_si` convert the
    /// file's units. Only these columns are read, so another column's empty cell is no error.
    pub(crate) fn stream(
        &self,
        columns: [usize; 4],
        time_to_s: f64,
        to_si: f64,
    ) -> Result<Stream, FormatError> {
        let keys: Vec<String> = columns.iter().map(|&c| (c + 1).to_string()).collect();
        let keys: Vec<&str> = keys.iter().map(String::as_str).collect();
        let options = TableOptions {
            delimiter: Some(self.delimiter),
        };
        let table = Table::parse_columns(&self.text, &self.file, &options, &keys)?;
        let mut columns_iter = table.columns.into_iter();
        let time_s: Vec<f64> = columns_iter
            .next()
            .unwrap_or_default()
            .into_iter()
            .map(|t| t * time_to_s)
            .collect();
        let mut axis = || -> Vec<f64> {
            columns_iter
                .next()
                .unwrap_or_default()
                .into_iter()
                .map(|v| v * to_si)
                .collect()
        };
        let xyz = [axis(), axis(), axis()];
        Ok(Stream {
            file: self.file.clone(),
            time_s,
            xyz,
            lines: table.lines,
            columns: columns.iter().map(|&c| self.header[c].clone()).collect(),
        })
    }
}

/// The files of one export: a zip's members or a folder's files, by name.
#[derive(Debug, Default)]
pub(crate) struct Members {
    /// The zip or folder, as named in messages.
    pub(crate) source: String,
    /// (name inside the export, contents).
    pub(crate) entries: Vec<(String, Vec<u8>)>,
    /// How to name the one entry of a file read on its own (its own path, not `source/name`).
    pub(crate) alone: Option<String>,
}

impl Members {
    /// The CSV files of a folder and of its `meta/` folder (what an unzipped export holds).
    pub(crate) fn from_dir(path: &Path) -> Result<Members, FormatError> {
        let source = path.display().to_string();
        let io = |source_err: std::io::Error, at: &Path| FormatError::Io {
            file: at.display().to_string(),
            source: source_err,
        };
        let mut entries = Vec::new();
        for (dir, prefix) in [(path.to_path_buf(), ""), (path.join("meta"), "meta/")] {
            if !dir.is_dir() {
                continue;
            }
            let mut names: Vec<_> = std::fs::read_dir(&dir)
                .map_err(|e| io(e, &dir))?
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("csv")))
                .collect();
            names.sort();
            for p in names {
                let bytes = crate::input::limits::check_regular(
                    &p,
                    crate::input::limits::LARGEST_RECORDING_BYTES,
                    "a recording's limit",
                )
                .and_then(|()| std::fs::read(&p))
                .map_err(|e| io(e, &p))?;
                let name = p
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                entries.push((format!("{prefix}{name}"), bytes));
            }
        }
        Ok(Members {
            source,
            entries,
            alone: None,
        })
    }

    /// The entry named `name` (exactly, or case-insensitively when no exact match exists).
    pub(crate) fn get(&self, name: &str) -> Option<&[u8]> {
        self.entries
            .iter()
            .find(|(n, _)| n == name)
            .or_else(|| self.entries.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)))
            .map(|(_, b)| b.as_slice())
    }

    pub(crate) fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|(n, _)| n.as_str())
    }

    /// `source/name`, how a member is named in messages and errors.
    pub(crate) fn display(&self, name: &str) -> String {
        match &self.alone {
            Some(file) => file.clone(),
            None => format!("{}/{name}", self.source),
        }
    }

    /// The names, for messages.
    pub(crate) fn listing(&self) -> String {
        let names: Vec<&str> = self.names().collect();
        if names.is_empty() {
            "no files".into()
        } else {
            names.join(", ")
        }
    }
}
