//! The fast row path: a line of plain numbers parsed byte by byte, without allocating.

use super::Delimiter;

/// What [`fast_row`] made of the start of its input (byte counts include the newline).
pub(super) enum Fast {
    Row(usize),
    Skip(usize),
    Slow,
}

/// ASCII bytes that `str::trim` and `split_whitespace` remove; other spacing takes the careful path.
#[inline(always)]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Spacing around a field that is not itself the separator `SEP` (0 for runs of spaces).
#[inline(always)]
fn is_padding<const SEP: u8>(b: u8) -> bool {
    is_space(b) && b != SEP
}

/// Reads one line of plain ASCII numbers straight from bytes into `row` (`row.len()` fields), or
/// recognises a blank or comment line (a comment must be UTF-8). Anything else (non-ASCII, a bad
/// or non-finite number, a wrong field count) is `Slow`, for [`check_row`] to decide. fast-float2
/// reads the same decimal syntax as `str::parse` and rounds correctly too, so the values are the
/// same bits.
#[inline]
pub(super) fn fast_row(input: &[u8], delimiter: Delimiter, row: &mut [f64]) -> Fast {
    let mut p = 0;
    while p < input.len() && is_space(input[p]) {
        p += 1;
    }
    match input.get(p) {
        None => return Fast::Skip(input.len()),
        Some(b'\n') => return Fast::Skip(p + 1),
        Some(b'#' | b'%') => {
            let end = memchr::memchr(b'\n', &input[p..]).map_or(input.len(), |e| p + e + 1);
            // A comment that is not text is the careful path's error.
            return match std::str::from_utf8(&input[p..end]) {
                Ok(_) => Fast::Skip(end),
                Err(_) => Fast::Slow,
            };
        }
        _ => {}
    }
    match delimiter {
        Delimiter::Comma => fast_fields::<b','>(input, p, row),
        Delimiter::Semicolon => fast_fields::<b';'>(input, p, row),
        // Leading tabs are empty fields, not padding.
        Delimiter::Tab => fast_fields::<b'\t'>(input, 0, row),
        Delimiter::Whitespace => fast_fields::<0>(input, p, row),
    }
}

/// The fields of [`fast_row`]; `SEP` is the separator byte, 0 for runs of spaces.
#[inline(always)]
fn fast_fields<const SEP: u8>(input: &[u8], mut p: usize, row: &mut [f64]) -> Fast {
    let pad = is_padding::<SEP>;
    let len = input.len();
    let last = row.len() - 1;
    for (c, slot) in row.iter_mut().enumerate() {
        // Plain decimals by our own reader (its values are finite, and it takes no padding); then
        // padding, and numbers of other forms by fast-float2. Both round correctly.
        let (value, end) = match crate::input::decimal::parse_decimal(&input[p..]) {
            Some((value, used)) => (value, p + used),
            None => match padded_number::<SEP>(input, p) {
                Some(parsed) => parsed,
                None => return Fast::Slow,
            },
        };
        *slot = value;
        p = end;
        if c < last {
            if SEP == 0 {
                // The spaces after it are the next field's padding.
                if p >= len || !is_space(input[p]) {
                    return Fast::Slow;
                }
            } else if p < len && input[p] == SEP {
                p += 1;
            } else {
                while p < len && pad(input[p]) {
                    p += 1;
                }
                if p >= len || input[p] != SEP {
                    return Fast::Slow;
                }
                p += 1;
            }
        }
    }
    while p < len && pad(input[p]) {
        p += 1;
    }
    if SEP != 0 && p < len && input[p] == SEP {
        // One trailing separator (`1,2,`) is tolerated, as by `Delimiter::split_row`.
        p += 1;
        while p < len && pad(input[p]) {
            p += 1;
        }
    }
    match input.get(p) {
        None => Fast::Row(len),
        Some(b'\n') => Fast::Row(p + 1),
        _ => Fast::Slow,
    }
}

/// The finite number at `p` after any padding, read by our reader or by fast-float2, and where it
/// ends; `None` when there is none. Off the common path, so kept out of [`fast_fields`]'s loop.
#[cold]
#[inline(never)]
fn padded_number<const SEP: u8>(input: &[u8], mut p: usize) -> Option<(f64, usize)> {
    let start = p;
    while p < input.len() && is_padding::<SEP>(input[p]) {
        p += 1;
    }
    // Our reader again only if there was padding to skip.
    let (value, used) = (p > start)
        .then(|| crate::input::decimal::parse_decimal(&input[p..]))
        .flatten()
        .or_else(|| fast_float2::parse_partial::<f64, _>(&input[p..]).ok())?;
    value.is_finite().then_some((value, p + used))
}
