//! The element reader: where it is (file or inflated element), data element tags, numeric
//! payloads, top-level elements and their zlib inflation within the limit.

use std::io::Read;

use super::{MatError, MatFile};

/// Where the reader is: in the file itself or inside a decompressed element.
#[derive(Clone, Copy)]
pub(super) struct Place {
    /// File offset of the enclosing `miCOMPRESSED` element, if any.
    pub(super) compressed_at: Option<usize>,
}

pub(super) struct Reader<'a> {
    pub(super) file: &'a str,
    pub(super) big_endian: bool,
    /// [`MAX_INFLATED_BYTES`] or the limit given to [`parse_limited`].
    pub(super) limit: u64,
    /// Bytes inflated so far, over every compressed element.
    pub(super) inflated: std::cell::Cell<u64>,
    /// Bytes of f64 values read from compressed elements so far.
    pub(super) values: std::cell::Cell<u64>,
    /// The run of empty matrix elements that ends the skipped list: how many, the first's offset.
    pub(super) empty_run: std::cell::Cell<(usize, usize)>,
}

/// A data element's type and payload, with the payload's offset.
pub(super) struct Element<'b> {
    pub(super) kind: u32,
    pub(super) data: &'b [u8],
    /// Offset of the element's tag.
    pub(super) at: usize,
    /// Offset just past the element (padding included).
    pub(super) next: usize,
}

pub(super) const MI_INT8: u32 = 1;
pub(super) const MI_UINT8: u32 = 2;
pub(super) const MI_INT16: u32 = 3;
pub(super) const MI_UINT16: u32 = 4;
pub(super) const MI_INT32: u32 = 5;
pub(super) const MI_UINT32: u32 = 6;
pub(super) const MI_SINGLE: u32 = 7;
pub(super) const MI_DOUBLE: u32 = 9;
pub(super) const MI_INT64: u32 = 12;
pub(super) const MI_UINT64: u32 = 13;
pub(super) const MI_MATRIX: u32 = 14;
pub(super) const MI_COMPRESSED: u32 = 15;
pub(super) const MI_UTF8: u32 = 16;

pub(super) fn class_name(class: u8) -> &'static str {
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
    pub(super) fn u32(&self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.big_endian {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }

    pub(super) fn corrupt(
        &self,
        place: Place,
        at: usize,
        variable: Option<&str>,
        why: impl Into<String>,
    ) -> MatError {
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
    pub(super) fn element<'b>(
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
    pub(super) fn value_size(
        &self,
        e: &Element,
        base: usize,
        place: Place,
        variable: &str,
    ) -> Result<usize, MatError> {
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
    pub(super) fn numbers(&self, e: &Element, size: usize) -> Vec<f64> {
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
    pub(super) fn top_level(
        &self,
        bytes: &[u8],
        start: usize,
        place: Place,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
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
    pub(super) fn inflate(&self, e: &Element, place: Place) -> Result<Vec<u8>, MatError> {
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
}
