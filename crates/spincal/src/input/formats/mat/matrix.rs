//! One `miMATRIX` element read: its header (flags, dimensions, name), then its real part, or the
//! reason it is skipped.

use super::reader::{class_name, Element, Place, Reader, MI_INT32, MI_INT8, MI_UINT32, MI_UINT8, MI_UTF8};
use super::{MatError, MatFile, MatVariable, Skipped};

/// What a matrix element says about itself before its values.
struct MatrixHead {
    class: u8,
    complex: bool,
    logical: bool,
    /// Offset of the dimensions element inside the matrix's data.
    dims_at: usize,
    dims: Vec<i64>,
    name: String,
    /// Offset of the real part's element inside the matrix's data.
    real_at: usize,
    /// The dimensions as `a×b`.
    shape: String,
}

impl MatrixHead {
    fn class_text(&self) -> &'static str {
        if self.logical {
            "logical"
        } else {
            class_name(self.class)
        }
    }

    /// Why the array is not read (not numeric, complex, not 2-D), if it is not.
    fn unread_reason(&self) -> Option<String> {
        let (shape, class_text) = (&self.shape, self.class_text());
        if !(6..=15).contains(&self.class) {
            return Some(format!("{shape} {class_text}: not a numeric array"));
        }
        if self.complex {
            return Some(format!(
                "{shape} complex {class_text}: complex values are not read"
            ));
        }
        if self.dims.len() != 2 {
            return Some(format!("{shape} {class_text}: only 2-D arrays are read"));
        }
        None
    }
}

impl Reader<'_> {
    /// Reads one `miMATRIX` element: flags, dimensions, name, then the real (and imaginary) part.
    pub(super) fn matrix(&self, e: &Element, place: Place, out: &mut MatFile) -> Result<(), MatError> {
        let data = e.data;
        if data.is_empty() {
            self.empty_matrix(e.at, out);
            return Ok(());
        }
        // Offsets inside `data` are reported relative to the bytes `e` came from.
        let base = e.at + 8;
        let head = self.matrix_head(data, base, place)?;
        if let Some(why) = head.unread_reason() {
            self.skip(out, head.name, why);
            return Ok(());
        }
        let (rows, cols) = (head.dims[0] as usize, head.dims[1] as usize);
        let values = self.real_part(data, base, place, &head, rows, cols)?;
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let why = format!(
                "{} {}: element {} (row {}, column {}) is {}; spincal needs finite numbers",
                head.shape,
                head.class_text(),
                i + 1,
                i % rows.max(1) + 1,
                i / rows.max(1) + 1,
                values[i]
            );
            self.skip(out, head.name, why);
            return Ok(());
        }
        let class = head.class_text();
        out.variables.push(MatVariable {
            name: head.name,
            rows,
            cols,
            class,
            values,
        });
        Ok(())
    }

    /// An empty matrix element (MATLAB writes them for empty cells and fields). A run of them is
    /// one entry, so the list stays small next to the file.
    fn empty_matrix(&self, at: usize, out: &mut MatFile) {
        match out.skipped.last_mut() {
            Some(last) if last.name.is_empty() && self.empty_run.get().0 > 0 => {
                let (n, first) = self.empty_run.get();
                self.empty_run.set((n + 1, first));
                last.why = format!("{} empty matrix elements, the first at byte {first}", n + 1);
            }
            _ => {
                self.empty_run.set((1, at));
                out.skipped.push(Skipped {
                    name: String::new(),
                    why: format!("empty matrix element at byte {at}"),
                });
            }
        }
    }

    /// A named variable listed as skipped; it ends any run of empty matrix elements.
    fn skip(&self, out: &mut MatFile, name: String, why: String) {
        self.empty_run.set((0, 0));
        out.skipped.push(Skipped { name, why });
    }

    /// The array flags, dimensions and name at the start of a matrix's `data`.
    fn matrix_head(&self, data: &[u8], base: usize, place: Place) -> Result<MatrixHead, MatError> {
        let sub = |at: usize| self.element(data, at, base, place, None);
        let flags = sub(0)?;
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
        let dims = sub(flags.next)?;
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
        let name_el = sub(dims.next)?;
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
        Ok(MatrixHead {
            class,
            complex,
            logical,
            dims_at: dims.at,
            dims: dims_values,
            name,
            real_at: name_el.next,
            shape,
        })
    }

    /// The real part of a `rows × cols` array as f64, its size checked against the dimensions
    /// (and, inside a compressed element, against the limit) before the values are allocated.
    fn real_part(
        &self,
        data: &[u8],
        base: usize,
        place: Place,
        head: &MatrixHead,
        rows: usize,
        cols: usize,
    ) -> Result<Vec<f64>, MatError> {
        let (name, shape) = (&head.name, &head.shape);
        let Some(count) = rows.checked_mul(cols) else {
            return Err(self.corrupt(
                place,
                base + head.dims_at,
                Some(name),
                format!("dimensions {shape} overflow"),
            ));
        };
        let real = self.element(data, head.real_at, base, place, Some(name))?;
        // The dimensions are checked against the data before the values are allocated.
        let size = self.value_size(&real, base, place, name)?;
        let held = real.data.len() / size;
        if held != count {
            return Err(self.corrupt(
                place,
                base + real.at,
                Some(name),
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
        Ok(self.numbers(&real, size))
    }
}
