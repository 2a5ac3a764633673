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
