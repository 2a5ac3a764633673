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

use std::io::Read;

use crate::input::table::{Delimiter, Table};

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

/// Where the reader is: in the file itself or inside a decompressed element.
#[derive(Clone, Copy)]
struct Place {
    /// File offset of the enclosing `miCOMPRESSED` element, if any.
    compressed_at: Option<usize>,
}

struct Reader<'a> {
    file: &'a str,
    big_endian: bool,
    /// [`MAX_INFLATED_BYTES`] or the limit given to [`parse_limited`].
    limit: u64,
    /// Bytes inflated so far, over every compressed element.
    inflated: std::cell::Cell<u64>,
    /// Bytes of f64 values read from compressed elements so far.
    values: std::cell::Cell<u64>,
    /// The run of empty matrix elements that ends the skipped list: how many, the first's offset.
    empty_run: std::cell::Cell<(usize, usize)>,
}

/// A data element's type and payload, with the payload's offset.
struct Element<'b> {
    kind: u32,
    data: &'b [u8],
    /// Offset of the element's tag.
    at: usize,
    /// Offset just past the element (padding included).
    next: usize,
}

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;

fn class_name(class: u8) -> &'static str {
    match class {
        1 => "cell",
        2 => "struct",
        3 => "object",
        4 => "char",
        5 => "sparse",
        6 => "double",
        7 => "single",
        8 => "int8",
        9 => "uint8",
        10 => "int16",
        11 => "uint16",
        12 => "int32",
        13 => "uint32",
        14 => "int64",
        15 => "uint64",
        16 => "function handle",
        17 => "opaque",
        _ => "unknown class",
    }
}

impl<'a> Reader<'a> {
    fn u32(&self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.big_endian {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }

    fn corrupt(&self, place: Place, at: usize, variable: Option<&str>, why: impl Into<String>) -> MatError {
        let at = match place.compressed_at {
            Some(outer) => format!("byte {at} of the element decompressed from byte {outer}"),
            None => format!("byte {at}"),
        };
        MatError::Corrupt {
            file: self.file.to_string(),
            at,
            variable: variable.map(|v| format!(", variable '{v}'")).unwrap_or_default(),
            why: why.into(),
        }
    }

    /// Reads the data element whose tag starts at `at` in `bytes`.
    /// `base` is the offset of `bytes` in the file (or decompressed element), for errors.
    fn element<'b>(
        &self,
        bytes: &'b [u8],
        at: usize,
        base: usize,
        place: Place,
        variable: Option<&str>,
    ) -> Result<Element<'b>, MatError> {
        let rest = bytes.len() - at.min(bytes.len());
        if rest < 8 {
            return Err(self.corrupt(
                place,
                base + at,
                variable,
                format!("a data element needs an 8-byte tag, {rest} bytes are left"),
            ));
        }
        let first = self.u32(&bytes[at..]);
        let small = first >> 16;
        if small != 0 {
            // Small data element: type and size in one word, up to 4 bytes of data in the next.
            let n = small as usize;
            if n > 4 {
                return Err(self.corrupt(
                    place,
                    base + at,
                    variable,
                    format!("a small data element holds at most 4 bytes, its tag says {n}"),
                ));
            }
            return Ok(Element {
                kind: first & 0xffff,
                data: &bytes[at + 4..at + 4 + n],
                at,
                next: at + 8,
            });
        }
        let n = self.u32(&bytes[at + 4..]) as usize;
        if n > rest - 8 {
            return Err(self.corrupt(
                place,
                base + at,
                variable,
                format!(
                    "the element (type {first}) says {n} bytes follow, only {} are left",
                    rest - 8
                ),
            ));
        }
        let end = at + 8 + n;
        // Elements are padded to 8 bytes, except compressed ones (and a file may end unpadded).
        let next = if first == MI_COMPRESSED {
            end
        } else {
            end.div_ceil(8).saturating_mul(8).min(bytes.len())
        };
        Ok(Element {
            kind: first,
            data: &bytes[at + 8..end],
            at,
            next,
        })
    }

    /// The byte size of one value of a numeric data element, checked against the element's length.
    fn value_size(&self, e: &Element, base: usize, place: Place, variable: &str) -> Result<usize, MatError> {
        let size = match e.kind {
            MI_INT8 | MI_UINT8 => 1,
            MI_INT16 | MI_UINT16 => 2,
            MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
            MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
            k => {
                return Err(self.corrupt(
                    place,
                    base + e.at,
                    Some(variable),
                    format!("data type {k} is not a numeric type"),
                ))
            }
        };
        if !e.data.len().is_multiple_of(size) {
            return Err(self.corrupt(
                place,
                base + e.at,
                Some(variable),
                format!(
                    "{} bytes are not a whole number of {size}-byte values",
                    e.data.len()
                ),
            ));
        }
        Ok(size)
    }

    /// Numbers of a numeric data element of `size`-byte values (see [`Reader::value_size`]),
    /// widened to f64.
    fn numbers(&self, e: &Element, size: usize) -> Vec<f64> {
        let be = self.big_endian;
        let values = e.data.chunks_exact(size).map(|c| {
            macro_rules! get {
                ($t:ty, $n:literal) => {{
                    let mut a = [0u8; $n];
                    a.copy_from_slice(c);
                    if be {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    }
                }};
            }
            match e.kind {
                MI_INT8 => c[0] as i8 as f64,
                MI_UINT8 => c[0] as f64,
                MI_INT16 => get!(i16, 2) as f64,
                MI_UINT16 => get!(u16, 2) as f64,
                MI_INT32 => get!(i32, 4) as f64,
                MI_UINT32 => get!(u32, 4) as f64,
                MI_SINGLE => get!(f32, 4) as f64,
                MI_DOUBLE => get!(f64, 8),
                MI_INT64 => get!(i64, 8) as f64,
                _ => get!(u64, 8) as f64,
            }
        });
        values.collect()
    }

    /// Reads the top-level elements of `bytes` (the file after its header, or a decompressed
    /// element) into `out`.
    fn top_level(&self, bytes: &[u8], start: usize, place: Place, out: &mut MatFile) -> Result<(), MatError> {
        let mut at = start;
        while at < bytes.len() {
            let e = self.element(bytes, at, 0, place, None)?;
            match e.kind {
                MI_MATRIX => self.matrix(&e, place, out)?,
                MI_COMPRESSED => {
                    if place.compressed_at.is_some() {
                        return Err(self.corrupt(
                            place,
                            e.at,
                            None,
                            "a compressed element inside a compressed element",
                        ));
                    }
                    let inflated = self.inflate(&e, place)?;
                    self.top_level(
                        &inflated,
                        0,
                        Place {
                            compressed_at: Some(e.at),
                        },
                        out,
                    )?;
                }
                k => {
                    return Err(self.corrupt(
                        place,
                        e.at,
                        None,
                        format!(
                        "type {k} at the top level; a MAT-file holds matrix (14) or compressed (15) elements"
                    ),
                    ))
                }
            }
            at = e.next;
        }
        Ok(())
    }

    /// Inflates the compressed element `e` within what is left of the limit: the first element
    /// tag inside says how many bytes follow, and is checked before anything is allocated; then
    /// inflating stops one byte past what is left, so a stream longer than its tag said is
    /// refused too.
    fn inflate(&self, e: &Element, place: Place) -> Result<Vec<u8>, MatError> {
        let left = self.limit.saturating_sub(self.inflated.get());
        let over = |what: &str, needed: u64| MatError::OverLimit {
            file: self.file.to_string(),
            at: e.at,
            what: what.to_string(),
            needed,
            limit: self.limit,
            left,
        };
        let fails = |error: std::io::Error| {
            self.corrupt(
                place,
                e.at,
                None,
                format!("the compressed element does not inflate: {error}"),
            )
        };
        let mut decoder = flate2::read::ZlibDecoder::new(e.data).take(left.saturating_add(1));
        // The first tag: a small element is 8 bytes in all, else 8 + the size it states.
        let mut tag = Vec::with_capacity(8);
        (&mut decoder).take(8).read_to_end(&mut tag).map_err(fails)?;
        let stated = if tag.len() < 8 {
            tag.len() as u64
        } else if self.u32(&tag) >> 16 != 0 {
            8
        } else {
            8 + u64::from(self.u32(&tag[4..]))
        };
        if stated > left {
            return Err(over("the compressed element's first tag states", stated));
        }
        let mut inflated = tag;
        inflated.reserve_exact(stated as usize - inflated.len());
        decoder.read_to_end(&mut inflated).map_err(fails)?;
        let got = inflated.len() as u64;
        if got > left {
            return Err(over("the compressed element inflates to at least", got));
        }
        self.inflated.set(self.inflated.get() + got);
        Ok(inflated)
    }

    /// Reads one `miMATRIX` element: flags, dimensions, name, then the real (and imaginary) part.
    fn matrix(&self, e: &Element, place: Place, out: &mut MatFile) -> Result<(), MatError> {
        let data = e.data;
        if data.is_empty() {
            // An empty matrix element (MATLAB writes them for empty cells and fields). A run of
            // them is one entry, so the list stays small next to the file.
            match out.skipped.last_mut() {
                Some(last) if last.name.is_empty() && self.empty_run.get().0 > 0 => {
                    let (n, first) = self.empty_run.get();
                    self.empty_run.set((n + 1, first));
                    last.why = format!("{} empty matrix elements, the first at byte {first}", n + 1);
                }
                _ => {
                    self.empty_run.set((1, e.at));
                    out.skipped.push(Skipped {
                        name: String::new(),
                        why: format!("empty matrix element at byte {}", e.at),
                    });
                }
            }
            return Ok(());
        }
        // Offsets inside `data` are reported relative to the bytes `e` came from.
        let base = e.at + 8;
        let sub = |at: usize, variable: Option<&str>| self.element(data, at, base, place, variable);
        let flags = sub(0, None)?;
        if flags.kind != MI_UINT32 || flags.data.len() != 8 {
            return Err(self.corrupt(
                place,
                base,
                None,
                "a matrix must start with its 8-byte array flags (uint32)",
            ));
        }
        let word = self.u32(flags.data);
        let class = (word & 0xff) as u8;
        let complex = word & 0x0800 != 0;
        let logical = word & 0x0200 != 0;
        let dims = sub(flags.next, None)?;
        if dims.kind != MI_INT32 || dims.data.is_empty() || !dims.data.len().is_multiple_of(4) {
            return Err(self.corrupt(
                place,
                base + dims.at,
                None,
                "the dimensions must be a non-empty int32 array",
            ));
        }
        let dims_values: Vec<i64> = dims
            .data
            .chunks_exact(4)
            .map(|c| self.u32(c) as i32 as i64)
            .collect();
        if dims_values.iter().any(|&d| d < 0) {
            return Err(self.corrupt(
                place,
                base + dims.at,
                None,
                format!("negative dimension in {dims_values:?}"),
            ));
        }
        let name_el = sub(dims.next, None)?;
        if name_el.kind != MI_INT8 && name_el.kind != MI_UINT8 && name_el.kind != MI_UTF8 {
            return Err(self.corrupt(
                place,
                base + name_el.at,
                None,
                format!("the array name must be text (int8), found type {}", name_el.kind),
            ));
        }
        let name = String::from_utf8_lossy(name_el.data)
            .trim_end_matches('\0')
            .to_string();
        let shape = dims_values
            .iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join("×");
        let skip = |out: &mut MatFile, why: String| {
            self.empty_run.set((0, 0));
            out.skipped.push(Skipped {
                name: name.clone(),
                why,
            });
            Ok(())
        };
        let class_text = if logical { "logical" } else { class_name(class) };
        if !(6..=15).contains(&class) {
            return skip(out, format!("{shape} {class_text}: not a numeric array"));
        }
        if complex {
            return skip(
                out,
                format!("{shape} complex {class_text}: complex values are not read"),
            );
        }
        if dims_values.len() != 2 {
            return skip(out, format!("{shape} {class_text}: only 2-D arrays are read"));
        }
        let (rows, cols) = (dims_values[0] as usize, dims_values[1] as usize);
        let Some(count) = rows.checked_mul(cols) else {
            return Err(self.corrupt(
                place,
                base + dims.at,
                Some(&name),
                format!("dimensions {shape} overflow"),
            ));
        };
        let real = sub(name_el.next, Some(&name))?;
        // The dimensions are checked against the data before the values are allocated.
        let size = self.value_size(&real, base, place, &name)?;
        let held = real.data.len() / size;
        if held != count {
            return Err(self.corrupt(
                place,
                base + real.at,
                Some(&name),
                format!("a {shape} array needs {count} values, the real part holds {held}"),
            ));
        }
        if let Some(outer) = place.compressed_at {
            let needed = count as u64 * 8;
            let left = self.limit.saturating_sub(self.values.get());
            if needed > left {
                return Err(MatError::OverLimit {
                    file: self.file.to_string(),
                    at: outer,
                    what: format!("the values of variable '{name}' ({shape}) as f64 take"),
                    needed,
                    limit: self.limit,
                    left,
                });
            }
            self.values.set(self.values.get() + needed);
        }
        let values = self.numbers(&real, size);
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return skip(
                out,
                format!(
                    "{shape} {class_text}: element {} (row {}, column {}) is {}; spincal needs finite numbers",
                    i + 1,
                    i % rows.max(1) + 1,
                    i / rows.max(1) + 1,
                    values[i]
                ),
            );
        }
        out.variables.push(MatVariable {
            name,
            rows,
            cols,
            class: class_text,
            values,
        });
        Ok(())
    }
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
mod tests {
    use super::*;

    /// A little-endian v5 file from (name, class, rows, cols, data type, payload) entries.
    /// (name, class, rows, cols, data type, payload).
    type Var<'a> = (&'a str, u8, i32, i32, u32, Vec<u8>);

    pub(crate) fn write(vars: &[Var], compress: bool) -> Vec<u8> {
        let mut out = Vec::new();
        let mut text = b"MATLAB 5.0 MAT-file, Platform: test, Created on: never".to_vec();
        text.resize(116, b' ');
        out.extend(text);
        out.extend([0u8; 8]);
        out.extend(0x0100u16.to_le_bytes());
        out.extend(b"IM");
        let element = |kind: u32, data: &[u8]| {
            let mut e = Vec::new();
            e.extend(kind.to_le_bytes());
            e.extend((data.len() as u32).to_le_bytes());
            e.extend(data);
            while e.len() % 8 != 0 {
                e.push(0);
            }
            e
        };
        for (name, class, rows, cols, kind, payload) in vars {
            let mut m = Vec::new();
            let mut flags = (*class as u32).to_le_bytes().to_vec();
            flags.extend([0u8; 4]);
            m.extend(element(MI_UINT32, &flags));
            let mut dims = rows.to_le_bytes().to_vec();
            dims.extend(cols.to_le_bytes());
            m.extend(element(MI_INT32, &dims));
            m.extend(element(MI_INT8, name.as_bytes()));
            m.extend(element(*kind, payload));
            let matrix = element(MI_MATRIX, &m);
            if compress {
                use std::io::Write;
                let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                z.write_all(&matrix).unwrap();
                let z = z.finish().unwrap();
                out.extend(MI_COMPRESSED.to_le_bytes());
                out.extend((z.len() as u32).to_le_bytes());
                out.extend(z);
            } else {
                out.extend(matrix);
            }
        }
        out
    }

    fn doubles(v: &[f64]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn reads_vectors_matrices_scalars_in_both_storages() {
        for compress in [false, true] {
            let bytes = write(
                &[
                    ("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5])),
                    ("m", 6, 3, 2, MI_DOUBLE, doubles(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])),
                    (
                        "k",
                        10,
                        3,
                        1,
                        MI_INT16,
                        [-1i16, 2, 300].iter().flat_map(|x| x.to_le_bytes()).collect(),
                    ),
                    ("Ts", 6, 1, 1, MI_UINT8, vec![4]),
                    ("s", 4, 1, 2, MI_UINT16, vec![104, 0, 105, 0]),
                ],
                compress,
            );
            let mat = parse(&bytes, "f.mat").unwrap();
            let t = table(&mat, "f.mat").unwrap();
            assert_eq!(t.header, ["u", "m_1", "m_2", "k"]);
            assert_eq!(t.columns[0], [1.0, 2.0, 3.5]);
            assert_eq!(t.columns[2], [4.0, 5.0, 6.0]);
            assert_eq!(t.columns[3], [-1.0, 2.0, 300.0]);
            assert_eq!(t.lines, [1, 2, 3]);
            assert!(t.metadata.iter().any(|(_, s)| s == "Ts = 4"), "{:?}", t.metadata);
            assert!(
                t.metadata.iter().any(|(_, s)| s.starts_with("s: 1×2 char")),
                "{:?}",
                t.metadata
            );
        }
    }

    #[test]
    fn every_truncation_is_an_error_or_a_shorter_file_never_a_panic() {
        for compress in [false, true] {
            let bytes = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5]))], compress);
            for cut in 0..bytes.len() {
                if let Err(e) = parse(&bytes[..cut], "f.mat") {
                    assert!(e.to_string().starts_with("f.mat: "), "{e}");
                }
            }
        }
    }

    #[test]
    fn errors_name_the_byte_and_the_variable() {
        let mut bytes = write(&[("volts", 6, 2, 3, MI_DOUBLE, doubles(&[1.0; 5]))], false);
        let e = parse(&bytes, "f.mat").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.mat: byte 184, variable 'volts': a 2×3 array needs 6 values, the real part holds 5"
        );
        // The element's size claims more than the file holds.
        bytes[132] = 0xff;
        let e = parse(&bytes, "f.mat").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("f.mat: byte 128: the element (type 14) says"),
            "{e}"
        );
        let e = parse(b"MATLAB 5.0 MAT-file", "f.mat").unwrap_err();
        assert!(e.to_string().contains("the header needs 128 bytes"), "{e}");
        let e = parse(b"hello", "f.mat").unwrap_err();
        assert!(matches!(e, MatError::NotMat { .. }));
        // A compressed element that is not zlib.
        let mut z = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.5]))], true);
        z[136] ^= 0xff;
        let e = parse(&z, "f.mat").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("f.mat: byte 128: the compressed element does not inflate"),
            "{e}"
        );
    }

    fn over(e: MatError) -> (usize, String, u64, u64, u64) {
        match e {
            MatError::OverLimit {
                at,
                what,
                needed,
                limit,
                left,
                ..
            } => (at, what, needed, limit, left),
            other => panic!("expected OverLimit, got {other}"),
        }
    }

    #[test]
    fn a_compressed_element_over_the_limit_is_refused_by_its_tag() {
        let bytes = write(&[("u", 6, 1, 200, MI_DOUBLE, doubles(&[0.0; 200]))], true);
        let e = parse_limited(&bytes, "f.mat", 1000).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("f.mat: byte 128: the compressed element's first tag states 1664 bytes, over the limit of 1000 bytes"),
            "{text}"
        );
        assert!(text.contains("save -v6"), "{text}");
        assert_eq!(over(e).4, 1000);
        // Within a larger limit it is read.
        assert_eq!(parse_limited(&bytes, "f.mat", 1664).unwrap().variables.len(), 1);
    }

    #[test]
    fn the_limit_holds_for_all_compressed_elements_together() {
        let var = |name| (name, 6u8, 1, 50, MI_DOUBLE, doubles(&[1.0; 50]));
        let bytes = write(&[var("a"), var("b")], true);
        // Each inflates to 464 bytes: the second finds 544 − 464 = 80 left.
        let (at, what, needed, limit, left) = over(parse_limited(&bytes, "f.mat", 544).unwrap_err());
        assert!(at > 128, "{at}");
        assert_eq!((needed, limit, left), (464, 544, 80), "{what}");
        assert_eq!(parse_limited(&bytes, "f.mat", 928).unwrap().variables.len(), 2);
    }

    #[test]
    fn a_stream_longer_than_its_tag_is_refused_while_inflating() {
        use std::io::Write;
        // A tag stating 48 bytes, then 100 000 zeros: the reader stops one byte past the limit.
        let mut inner = Vec::new();
        inner.extend(MI_MATRIX.to_le_bytes());
        inner.extend(48u32.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&inner).unwrap();
        z.write_all(&vec![0u8; 100_000]).unwrap();
        let z = z.finish().unwrap();
        let mut bytes = write(&[], false);
        bytes.extend(MI_COMPRESSED.to_le_bytes());
        bytes.extend((z.len() as u32).to_le_bytes());
        bytes.extend(z);
        let (at, what, needed, limit, _) = over(parse_limited(&bytes, "f.mat", 4096).unwrap_err());
        assert_eq!((at, needed, limit), (128, 4097, 4096), "{what}");
    }

    #[test]
    fn values_from_compressed_elements_are_counted_before_they_are_allocated() {
        // 2 000 uint8 values inflate to about 2 kB but take 16 kB as f64.
        let bytes = write(&[("u", 9, 1, 2000, MI_UINT8, vec![7u8; 2000])], true);
        let (at, what, needed, _, left) = over(parse_limited(&bytes, "f.mat", 10_000).unwrap_err());
        assert_eq!((at, needed, left), (128, 16_000, 10_000));
        assert_eq!(what, "the values of variable 'u' (1×2000) as f64 take");
        // Uncompressed, the file holds them: no limit.
        let plain = write(&[("u", 9, 1, 2000, MI_UINT8, vec![7u8; 2000])], false);
        assert_eq!(
            parse_limited(&plain, "f.mat", 10).unwrap().variables[0]
                .values
                .len(),
            2000
        );
    }

    #[test]
    fn a_run_of_empty_matrix_elements_is_one_entry() {
        let mut bytes = write(&[("u", 6, 1, 3, MI_DOUBLE, doubles(&[1.0, 2.0, 3.0]))], false);
        for _ in 0..1000 {
            bytes.extend(MI_MATRIX.to_le_bytes());
            bytes.extend(0u32.to_le_bytes());
        }
        let mat = parse(&bytes, "f.mat").unwrap();
        assert_eq!(mat.skipped.len(), 1);
        assert_eq!(
            mat.skipped[0].why,
            format!(
                "1000 empty matrix elements, the first at byte {}",
                bytes.len() - 8000
            )
        );
    }
}
