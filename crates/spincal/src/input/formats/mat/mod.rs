//! MATLAB v5 MAT-files (`save -v5`, `-v6`, `-v7`): the numeric subset, read as table columns.
//!
//! What is read: the 128-byte header (either byte order), top-level `miMATRIX` elements, plain or
//! inside `miCOMPRESSED` (zlib) elements, of the numeric classes (double, single, int8…uint64,
//! logical), real and two-dimensional, their values stored in any numeric data type (MATLAB stores
//! a double array of small integers as `miUINT8`, for instance), small data elements included.
//! Everything else (char, cell, struct, sparse, complex, N-d arrays, function handles, v7.3 HDF5
//! files) is listed as skipped with the reason, never guessed.
//!
//! Every length is checked against the bytes that hold it; an error names the file, the byte offset
//! (inside a compressed element: the offset in the decompressed bytes and the element's own offset
//! in the file) and the variable being read.
//!
//! [`table`] turns the variables into [`Table`] columns: a vector (1×n or n×1) is one column named
//! after the variable; an m×k matrix is k columns `name_1` … `name_k` of m rows. The table's length
//! is the longest such column; scalars (e.g. `Ts = 4`) and variables of another length go to the
//! table's metadata with their value or why they were skipped. The table's `lines` are row numbers
//! (1-based): a MAT-file has no lines.

use crate::input::table::{Delimiter, Table};

mod matrix;
mod reader;

use reader::{Place, Reader};

/// The text every v5 MAT-file starts with.
pub(crate) const MAGIC: &[u8] = b"MATLAB 5.0 MAT-file";

/// Size of the v5 header.
const HEADER_BYTES: usize = 128;

/// The most a MAT-file's `miCOMPRESSED` (zlib) elements may inflate to, all together, and the most
/// the values read from them may take as f64 (8 bytes each): 64 MiB (8 Mi doubles, e.g. 2 M
/// samples of 4 signals). A compressed element is refused before anything is allocated when its
/// inflated tag states more than is left, and while inflating when it yields more than its tag
/// said; an array's dimensions are checked against what is left before its values are allocated.
/// So a zlib bomb (a 0.93 MB file of 30 M × 4 zeros inflates to 960 MB) is refused in constant
/// memory. Uncompressed elements have no such limit: their values are bounded by the file's own
/// size (at most 8 bytes of f64 per byte of data). `parse_limited` takes another limit.
pub const MAX_INFLATED_BYTES: u64 = 64 << 20;

/// What is wrong with a MAT-file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MatError {
    #[error("{file}: not a MATLAB v5 MAT-file: {why}")]
    NotMat { file: String, why: String },
    #[error("{file}: {at}{variable}: {why}")]
    Corrupt {
        file: String,
        /// Where: `byte N`, or `byte N of the element decompressed from byte M`.
        at: String,
        /// `, variable 'x'` when one was being read.
        variable: String,
        why: String,
    },
    #[error("{file}: byte {at}: {what} {needed} bytes, over the limit of {limit} bytes that spincal inflates from one MAT-file's compressed elements ({left} left); save the variables uncompressed (MATLAB: save -v6), which is read without this limit")]
    OverLimit {
        file: String,
        /// File offset of the compressed element.
        at: usize,
        /// What would pass the limit (the element's inflated size, an array's values).
        what: String,
        needed: u64,
        limit: u64,
        left: u64,
    },
    #[error("{file}: no numeric 2-D real variable of more than one value to read as columns{skipped}")]
    NoNumeric { file: String, skipped: String },
}

/// One numeric variable, column-major.
#[derive(Debug, Clone, PartialEq)]
pub struct MatVariable {
    pub name: String,
    pub rows: usize,
    pub cols: usize,
    /// MATLAB class name (`double`, `single`, `int16`, `logical`, …).
    pub class: &'static str,
    /// `rows × cols` values, column-major (column `j` is `values[j*rows .. (j+1)*rows]`).
    pub values: Vec<f64>,
}

/// A variable that is not read, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Skipped {
    pub name: String,
    pub why: String,
}

/// Everything read from a MAT-file.
#[derive(Debug, Clone, PartialEq)]
pub struct MatFile {
    /// The header's descriptive text (platform, date), trimmed.
    pub description: String,
    pub variables: Vec<MatVariable>,
    pub skipped: Vec<Skipped>,
}

/// True when the bytes start like a v5 MAT-file (the v7.3 HDF5 kind too: it has the same text).
pub(crate) fn is_mat(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// Parses a MAT-file held in memory; `file` names it in errors. Compressed elements are read
/// within [`MAX_INFLATED_BYTES`].
pub fn parse(bytes: &[u8], file: &str) -> Result<MatFile, MatError> {
    parse_limited(bytes, file, MAX_INFLATED_BYTES)
}

/// [`parse`], with `limit` bytes for all the compressed elements' inflated bytes (and as much
/// again for the f64 values read from them) instead of [`MAX_INFLATED_BYTES`].
pub(crate) fn parse_limited(bytes: &[u8], file: &str, limit: u64) -> Result<MatFile, MatError> {
    let not = |why: String| MatError::NotMat {
        file: file.to_string(),
        why,
    };
    if !is_mat(bytes) {
        return Err(not("it does not start with 'MATLAB 5.0 MAT-file'".into()));
    }
    if bytes.len() < HEADER_BYTES {
        return Err(not(format!(
            "the header needs {HEADER_BYTES} bytes, the file has {}",
            bytes.len()
        )));
    }
    let big_endian = match &bytes[126..128] {
        b"IM" => false,
        b"MI" => true,
        other => {
            return Err(not(format!(
                "bytes 126–127 should be the byte-order mark 'IM' or 'MI', found {other:?}"
            )))
        }
    };
    let description = String::from_utf8_lossy(&bytes[..116])
        .trim_end_matches(['\0', ' '])
        .to_string();
    if description.contains("MAT-file, Platform") && description.contains("7.3") {
        return Err(not("a v7.3 (HDF5) MAT-file; save it with -v7 or -v6".into()));
    }
    let version = if big_endian {
        u16::from_be_bytes([bytes[124], bytes[125]])
    } else {
        u16::from_le_bytes([bytes[124], bytes[125]])
    };
    if version != 0x0100 {
        return Err(not(format!(
            "version 0x{version:04x} at byte 124 (v5 files say 0x0100; v7.3 files are HDF5)"
        )));
    }
    let reader = Reader {
        file,
        big_endian,
        limit,
        inflated: std::cell::Cell::new(0),
        values: std::cell::Cell::new(0),
        empty_run: std::cell::Cell::new((0, 0)),
    };
    let mut out = MatFile {
        description,
        variables: Vec::new(),
        skipped: Vec::new(),
    };
    reader.top_level(bytes, HEADER_BYTES, Place { compressed_at: None }, &mut out)?;
    Ok(out)
}

/// The variables as table columns (see the module documentation); an error when none is numeric.
pub fn table(mat: &MatFile, file: &str) -> Result<Table, MatError> {
    // A vector is one column of numel values; a matrix is `cols` columns of `rows` values.
    let length = |v: &MatVariable| {
        if v.rows == 1 || v.cols == 1 {
            v.rows * v.cols
        } else {
            v.rows
        }
    };
    let n = mat.variables.iter().map(length).filter(|&l| l > 1).max();
    let mut metadata: Vec<(usize, String)> = Vec::new();
    let mut header = Vec::new();
    let mut columns = Vec::new();
    for (k, v) in mat.variables.iter().enumerate() {
        let shape = format!("{}×{} {}", v.rows, v.cols, v.class);
        if v.values.len() == 1 {
            metadata.push((k + 1, format!("{} = {}", v.name, v.values[0])));
        } else if Some(length(v)) != n || v.values.is_empty() {
            metadata.push((
                k + 1,
                format!(
                    "{}: {shape} skipped (the columns have {} rows)",
                    v.name,
                    n.unwrap_or(0)
                ),
            ));
        } else if v.rows == 1 || v.cols == 1 {
            header.push(v.name.clone());
            columns.push(v.values.clone());
        } else {
            for (j, column) in v.values.chunks_exact(v.rows).enumerate() {
                header.push(format!("{}_{}", v.name, j + 1));
                columns.push(column.to_vec());
            }
        }
    }
    for s in &mat.skipped {
        metadata.push((0, format!("{}: {}", s.name, s.why)));
    }
    let Some(n) = n.filter(|_| !columns.is_empty()) else {
        let listed: Vec<String> = metadata.iter().map(|(_, s)| s.clone()).collect();
        return Err(MatError::NoNumeric {
            file: file.to_string(),
            skipped: if listed.is_empty() {
                String::new()
            } else {
                format!(" ({})", listed.join("; "))
            },
        });
    };
    Ok(Table {
        file: file.to_string(),
        delimiter: Delimiter::Comma,
        header,
        metadata,
        columns,
        lines: (1..=n).collect(),
    })
}
#[cfg(test)]
mod tests;
