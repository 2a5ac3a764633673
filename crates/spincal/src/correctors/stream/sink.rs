//! Where corrected rows go: a [`RowSink`] takes the header and each row as text fields plus the
//! corrected values; [`DelimitedSink`] writes them as delimited text.

use std::io::Write;

/// The writing end of the correction pipeline.
pub trait RowSink {
    /// The header: the input's column names, then the corrected columns, `valid` and `status`.
    fn header(&mut self, names: &[String]) -> std::io::Result<()>;
    /// One row: the input as text (already joined by the sink's separator, fields quoted where
    /// needed), the corrected values (None: empty), whether the row is valid, and its status.
    fn row(
        &mut self,
        input: &str,
        corrected: &[Option<f64>],
        valid: bool,
        status: &str,
    ) -> std::io::Result<()>;
    /// The separator the sink joins fields with.
    fn separator(&self) -> char;
    /// Everything written reaches the writer.
    fn flush(&mut self) -> std::io::Result<()>;
}

/// Delimited text, with the input's separator.
pub struct DelimitedSink<'w> {
    out: &'w mut dyn Write,
    separator: char,
}

impl<'w> DelimitedSink<'w> {
    pub fn new(out: &'w mut dyn Write, separator: char) -> Self {
        DelimitedSink { out, separator }
    }
}

/// A field for delimited output: quoted when it holds the separator or a quote (or a tab where
/// fields are separated by blanks).
pub(super) fn field(text: &str, separator: char) -> String {
    if text.contains(separator) || text.contains('"') || (separator == ' ' && text.contains('\t')) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

impl RowSink for DelimitedSink<'_> {
    fn header(&mut self, names: &[String]) -> std::io::Result<()> {
        let sep = self.separator.to_string();
        let line = names
            .iter()
            .map(|n| field(n, self.separator))
            .collect::<Vec<_>>()
            .join(&sep);
        writeln!(self.out, "{line}")
    }

    fn row(
        &mut self,
        input: &str,
        corrected: &[Option<f64>],
        valid: bool,
        status: &str,
    ) -> std::io::Result<()> {
        let sep = self.separator;
        write!(self.out, "{input}")?;
        for v in corrected {
            match v {
                Some(v) => write!(self.out, "{sep}{v}")?,
                None => write!(self.out, "{sep}")?,
            }
        }
        writeln!(self.out, "{sep}{}{sep}{}", u8::from(valid), field(status, sep))
    }

    fn separator(&self) -> char {
        self.separator
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}
