//! phyphox's Excel export through `calamine` (the `phone` feature): the Android app writes an
//! .xlsx, the iOS app an .xls; one sheet per export set with its header row, then "Metadata
//! Device" and "Metadata Time" (phyphox-android DataExport.java `ExcelFormat`; phyphox-ios
//! ExperimentExport.swift). Each sheet becomes the CSV member the zip export would hold, so
//! the zip's rules read it.

use std::fmt::Write;

use calamine::{open_workbook_auto_from_rs, Data, Reader};

use super::super::{FormatError, Loaded, ReadOptions};
use super::text::Members;
use super::{phyphox, PhoneError};

/// Reads a phyphox workbook held in memory.
pub(crate) fn read(bytes: &[u8], file: &str, options: &ReadOptions) -> Result<Loaded, FormatError> {
    let members = members(bytes, file)?;
    let mut loaded = phyphox::read_members(&members, file, options)?;
    loaded.format = super::super::Format::PhyphoxExcel;
    loaded.recording.source.format = loaded.format.name().into();
    Ok(loaded)
}

/// The sheets as CSV members: "Metadata Time" as `meta/time.csv`, "Metadata Device" as
/// `meta/device.csv`, any other sheet as `<sheet>.csv`. Numbers are written in Rust's shortest
/// round-trip form, so the values are the workbook's to the bit; one sheet row is one line, so a
/// line number in a message is the sheet's row.
fn members(bytes: &[u8], file: &str) -> Result<Members, FormatError> {
    let excel_error = |why: String| PhoneError::Excel {
        file: file.into(),
        why,
    };
    if !bytes.starts_with(super::ZIP_MAGIC) && !bytes.starts_with(super::OLE_MAGIC) {
        return Err(excel_error("neither an .xlsx (zip) nor an .xls (OLE2) workbook".into()).into());
    }
    // calamine's parsers are not this crate's: a panic on a malformed workbook is caught and
    // reported as this file's error rather than ending the program.
    let parsed = std::panic::catch_unwind(|| sheets(bytes));
    let sheets = match parsed {
        Ok(result) => result.map_err(excel_error)?,
        Err(_) => return Err(excel_error("the workbook reader failed on malformed data".into()).into()),
    };
    let mut entries = Vec::new();
    for (sheet, text) in sheets {
        let name = match sheet.as_str() {
            "Metadata Time" => "meta/time.csv".to_string(),
            "Metadata Device" => "meta/device.csv".to_string(),
            s => format!("{s}.csv"),
        };
        entries.push((name, text.into_bytes()));
    }
    Ok(Members {
        source: file.into(),
        entries,
        alone: None,
    })
}

/// Each sheet's name and its rows as CSV text.
fn sheets(bytes: &[u8]) -> Result<Vec<(String, String)>, String> {
    let mut workbook = open_workbook_auto_from_rs(std::io::Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for sheet in workbook.sheet_names() {
        let range = workbook
            .worksheet_range(&sheet)
            .map_err(|e| format!("sheet {sheet}: {e}"))?;
        let mut text = String::new();
        for row in range.rows() {
            for (c, cell) in row.iter().enumerate() {
                if c > 0 {
                    text.push(',');
                }
                let _ = match cell {
                    Data::Float(v) => write!(text, "{v}"),
                    Data::Int(v) => write!(text, "{v}"),
                    Data::String(s) | Data::DateTimeIso(s) | Data::DurationIso(s) => {
                        write!(text, "\"{}\"", s.replace(['"', ','], " "))
                    }
                    Data::Bool(b) => write!(text, "{b}"),
                    Data::DateTime(d) => write!(text, "{}", d.as_f64()),
                    Data::Error(_) | Data::Empty => Ok(()),
                };
            }
            text.push('\n');
        }
        out.push((sheet, text));
    }
    Ok(out)
}
