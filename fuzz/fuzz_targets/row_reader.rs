//! The streaming row reader `spincal correct` uses, on any bytes, read to the end: every record
//! is a full row of finite numbers or a refusal whose error names its line; lines increase; it
//! ends within one record per input line; and it agrees with the whole-table reader.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::input::table::{Delimiter, Record, RowReader, Table, TableError, TableOptions};

/// The line an error names, when it names one.
fn error_line(error: &TableError) -> Option<usize> {
    match error {
        TableError::NotANumber { at, .. }
        | TableError::NonFinite { at, .. }
        | TableError::EmptyCell { at }
        | TableError::Ragged { at, .. } => Some(at.line),
        TableError::Truncated { line, .. } | TableError::NotText { line, .. } => Some(*line),
        _ => None,
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the separator option: detected or one of the four.
    let Some((&choice, bytes)) = data.split_first() else {
        return;
    };
    let delimiter = match choice % 5 {
        0 => None,
        1 => Some(Delimiter::Comma),
        2 => Some(Delimiter::Semicolon),
        3 => Some(Delimiter::Tab),
        _ => Some(Delimiter::Whitespace),
    };
    let options = TableOptions { delimiter };
    let Ok(mut rows) = RowReader::new(bytes, "fuzz.csv", &options) else {
        return;
    };
    let width = rows.width();
    assert!(width > 0);
    let n_lines = bytes.split(|&b| b == b'\n').count();
    let mut values = Vec::new();
    let mut parsed: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut refused = 0;
    let mut last_line = 0;
    let mut records = 0;
    while let Some(record) = rows
        .next_record(&mut values)
        .expect("reading from memory cannot fail")
    {
        records += 1;
        assert!(records <= n_lines, "more records than lines");
        let line = match record {
            Record::Parsed { line } => {
                assert_eq!(values.len(), width, "line {line}");
                assert!(values.iter().all(|v| v.is_finite()), "line {line}");
                parsed.push((line, values.clone()));
                line
            }
            Record::Refused { line, error, .. } => {
                assert_eq!(error_line(&error), Some(line), "{error}");
                assert!(error.to_string().contains(&line.to_string()), "{error}");
                refused += 1;
                line
            }
            Record::Incomplete { line, .. } => {
                panic!("line {line} incomplete, though no columns were chosen")
            }
        };
        assert!(
            line > last_line && line <= n_lines,
            "line {line} after {last_line}"
        );
        last_line = line;
    }
    // The end stays the end.
    assert!(rows.next_record(&mut values).unwrap().is_none());

    // The whole-table reader accepts exactly the files with no refused row, and reads the same.
    match Table::read(bytes, "fuzz.csv", &options) {
        Ok(table) => {
            assert_eq!(refused, 0, "Table::read accepted a file with refused rows");
            assert_eq!(table.lines, parsed.iter().map(|(l, _)| *l).collect::<Vec<_>>());
            for (i, (_, row)) in parsed.iter().enumerate() {
                for (c, v) in row.iter().enumerate() {
                    assert_eq!(table.columns[c][i].to_bits(), v.to_bits());
                }
            }
        }
        Err(e) => assert!(refused > 0, "Table::read refused ({e}) what streaming parsed"),
    }
});
