//! Tables with one text column of labels (e.g. imucal's `part`).

use std::io::BufRead;

use super::reader::{is_skippable, read_line};
use super::{Delimiter, Location, Table, TableError, TableOptions};

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
    let head = read_header(&mut reader, &mut buffer, &mut line_no, file, options, label)?;
    let width = head.names.len();
    let mut rows = Rows {
        columns: vec![Vec::new(); width - 1],
        lines: Vec::new(),
        labels: Vec::new(),
    };
    while let Some(has_newline) = read_line(&mut reader, &mut buffer, file, line_no + 1)? {
        line_no += 1;
        let text = buffer.trim_end_matches(['\n', '\r']);
        if is_skippable(text) {
            continue;
        }
        let mut fields = Vec::with_capacity(width);
        head.delimiter.split_row(text, Some(width), &mut fields);
        check_width(fields.len(), width, has_newline, file, line_no)?;
        rows.push(&fields, &head, file, line_no)?;
    }
    if rows.lines.is_empty() {
        return Err(TableError::NoData {
            file: file.into(),
            lines: line_no,
        });
    }
    let header: Vec<String> = head
        .names
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != head.label_index)
        .map(|(_, n)| n.clone())
        .collect();
    Ok(LabelledTable {
        table: Table {
            file: file.into(),
            delimiter: head.delimiter,
            header,
            metadata: head.metadata,
            columns: rows.columns,
            lines: rows.lines,
        },
        labels: rows.labels,
        label_name: head.names[head.label_index].clone(),
    })
}

/// The header line and what came before it.
struct Header {
    delimiter: Delimiter,
    /// Every column's name as written, label column included.
    names: Vec<String>,
    label_index: usize,
    /// The lines before the header, with their numbers.
    metadata: Vec<(usize, String)>,
}

/// Reads up to the header: the first non-skippable line that contains the label name as a field.
fn read_header<R: BufRead>(
    reader: &mut R,
    buffer: &mut String,
    line_no: &mut usize,
    file: &str,
    options: &TableOptions,
    label: &str,
) -> Result<Header, TableError> {
    let mut metadata = Vec::new();
    loop {
        let Some(_) = read_line(reader, buffer, file, *line_no + 1)? else {
            if *line_no == 0 {
                return Err(TableError::Empty { file: file.into() });
            }
            return Err(TableError::NoLabelColumn {
                file: file.into(),
                name: label.into(),
            });
        };
        *line_no += 1;
        let text = buffer.trim_end_matches(['\n', '\r']);
        if is_skippable(text) {
            continue;
        }
        let delimiter = options.delimiter.unwrap_or_else(|| Delimiter::detect(text));
        let mut fields = Vec::new();
        delimiter.split_row(text, None, &mut fields);
        let names: Vec<String> = fields.iter().map(|s| s.trim_matches('"').to_string()).collect();
        if let Some(label_index) = names.iter().position(|n| n.eq_ignore_ascii_case(label)) {
            return Ok(Header {
                delimiter,
                names,
                label_index,
                metadata,
            });
        }
        metadata.push((*line_no, text.to_string()));
    }
}

/// A row of `found` fields where `width` are expected: cut short at the end of the file, or ragged.
fn check_width(
    found: usize,
    width: usize,
    has_newline: bool,
    file: &str,
    line: usize,
) -> Result<(), TableError> {
    if found == width {
        return Ok(());
    }
    if !has_newline && found < width {
        return Err(TableError::Truncated {
            file: file.into(),
            line,
            expected: width,
            found,
        });
    }
    Err(TableError::Ragged {
        at: Location {
            file: file.into(),
            line,
            column: None,
            column_name: None,
        },
        expected: width,
        found,
    })
}

/// The rows read so far: numeric columns, labels and line numbers.
struct Rows {
    columns: Vec<Vec<f64>>,
    lines: Vec<usize>,
    labels: Vec<String>,
}

impl Rows {
    /// Adds one row of `head.names.len()` fields: its label and its numbers.
    fn push(&mut self, fields: &[&str], head: &Header, file: &str, line_no: usize) -> Result<(), TableError> {
        let location = |line: usize, c: usize| Location {
            file: file.to_string(),
            line,
            column: Some(c + 1),
            column_name: head.names.get(c).cloned(),
        };
        let mut k = 0;
        for (c, field) in fields.iter().enumerate() {
            if c == head.label_index {
                self.labels.push(field.trim_matches('"').to_string());
                continue;
            }
            if field.is_empty() {
                return Err(TableError::EmptyCell {
                    at: location(line_no, c),
                });
            }
            match field.parse::<f64>() {
                Ok(v) if v.is_finite() => self.columns[k].push(v),
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
        self.lines.push(line_no);
        Ok(())
    }
}
