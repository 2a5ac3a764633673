//! A fast reader for the plain decimals that fill recordings (`-0.3900573453406082`, `1.5e-3`):
//! at most 19 significant digits and a decimal exponent within ±27, correctly rounded to the
//! nearest double (ties to even), as `str::parse` does. Anything else — more digits, a larger
//! exponent, `inf`, a lone `.` — is left to the caller's general parser (`None`).
//!
//! The digits after the point are read eight at a time (SWAR), the last few of them too (padded to
//! eight with leading zeros), so no branch is taken per digit. The conversion is Clinger's exact
//! fast path when the digits fit a double's mantissa and the power of ten is exact, and otherwise
//! the Eisel–Lemire method (D. Lemire, "Number parsing at a gigabyte per second", 2021): one or
//! two 64 × 64-bit products with a 128-bit power of five. Within the exponents taken here that
//! product always decides the rounding, so no slow path is needed.

/// Parses the number at the start of `bytes`: `[-]digits[.digits][(e|E)[+-]digits]`, with digits
/// on both sides of a point. Returns the value (always finite: below 10⁴⁷) and the bytes it used,
/// or `None` when the number is not of that simple kind (the caller's general parser then
/// decides).
#[inline]
pub fn parse_decimal(bytes: &[u8]) -> Option<(f64, usize)> {
    #[cfg(target_arch = "x86_64")]
    if bytes.len() >= PLAIN_BYTES {
        if let Some(parsed) = parse_plain(bytes) {
            return Some(parsed);
        }
    }
    parse_general(bytes)
}

/// Bytes [`parse_plain`] looks at.
#[cfg(target_arch = "x86_64")]
const PLAIN_BYTES: usize = 32;

/// Sixteen bytes of ones then sixteen of zeros: the 16 bytes from `16 − k` select the first `k`.
#[cfg(target_arch = "x86_64")]
static FIRST_BYTES: [u8; 32] = {
    let mut bytes = [0u8; 32];
    let mut k = 0;
    while k < 16 {
        bytes[k] = 0xFF;
        k += 1;
    }
    bytes
};

/// The shape that fills recordings, `[-]d{1,15}.d+` with at most 19 digits in all (a minus sign
/// counts as one) and no exponent, read with SSE2 (every x86-64 has it) and no branch that
/// depends on the digits: a mispredicted branch costs as much as the conversion, and in a
/// recording the sign and the number of digits change at random from field to field.
///
/// The number's end, which the next field waits for, comes straight from one compare of 32 bytes
/// (digits and points, and a sign in the first place). The sign is read as a leading zero digit,
/// so nothing but the result's sign depends on it. The point is squeezed out (the bytes after it
/// moved down one), the first 16 digits are converted together by multiply-adds (pairs, fours,
/// eights), and the value always goes through Eisel–Lemire. `None` for any other shape, for
/// [`parse_general`] to decide; needs [`PLAIN_BYTES`] bytes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn parse_plain(bytes: &[u8]) -> Option<(f64, usize)> {
    use std::arch::x86_64::*;
    let s: &[u8; 32] = bytes[..32].try_into().expect("32 bytes");
    let negative = s[0] == b'-';
    // SAFETY (all loads below): SSE2 is part of every x86-64 target, and each load reads 16 bytes
    // inside `s` or `FIRST_BYTES`.
    let first_bytes = |k: usize| unsafe { _mm_loadu_si128(FIRST_BYTES[16 - k..].as_ptr().cast()) };
    let load = |at: usize| unsafe { _mm_loadu_si128(s[at..].as_ptr().cast()) };
    let (head, tail) = (load(0), load(16));
    // Bit k: byte k is a digit or a point; and is a point.
    let (number, points) = unsafe {
        let masks = |v: __m128i| {
            let above = _mm_cmpgt_epi8(v, _mm_set1_epi8(b'0' as i8 - 1));
            let below = _mm_cmplt_epi8(v, _mm_set1_epi8(b'9' as i8 + 1));
            let point = _mm_cmpeq_epi8(v, _mm_set1_epi8(b'.' as i8));
            let digit_or_point = _mm_or_si128(_mm_and_si128(above, below), point);
            (
                _mm_movemask_epi8(digit_or_point) as u32,
                _mm_movemask_epi8(point) as u32,
            )
        };
        let ((number_head, points_head), (number_tail, points_tail)) = (masks(head), masks(tail));
        (
            number_head | (number_tail << 16),
            points_head | (points_tail << 16),
        )
    };
    let end = (!(number | u32::from(negative))).trailing_zeros() as usize;
    // Digit places before the point, the sign's included.
    let int_places = points.trailing_zeros() as usize;
    let places = end.saturating_sub(1);
    let run = ((1u64 << end) - 1) as u32;
    if int_places <= usize::from(negative)
        || int_places > 15
        || int_places + 1 >= end
        || places > 19
        || points & run != 1 << int_places
        || s[end] | 0x20 == b'e'
    {
        return None;
    }
    // The places without the point, the first 16 of them, with zeros after them (and for a sign).
    let first16 = unsafe {
        let before_point = first_bytes(int_places);
        let joined = _mm_or_si128(
            _mm_and_si128(before_point, head),
            _mm_andnot_si128(before_point, load(1)),
        );
        // Saturating: '-' less '0' is zero.
        let values = _mm_and_si128(
            _mm_subs_epu8(joined, _mm_set1_epi8(b'0' as i8)),
            first_bytes(places.min(16)),
        );
        let zero = _mm_setzero_si128();
        let tens = _mm_setr_epi16(10, 1, 10, 1, 10, 1, 10, 1);
        let pairs = _mm_packs_epi32(
            _mm_madd_epi16(_mm_unpacklo_epi8(values, zero), tens),
            _mm_madd_epi16(_mm_unpackhi_epi8(values, zero), tens),
        );
        let fours = _mm_madd_epi16(pairs, _mm_setr_epi16(100, 1, 100, 1, 100, 1, 100, 1));
        let eights = _mm_madd_epi16(
            _mm_packs_epi32(fours, fours),
            _mm_setr_epi16(10_000, 1, 10_000, 1, 10_000, 1, 10_000, 1),
        );
        let both = _mm_cvtsi128_si64(eights) as u64;
        (both & 0xFFFF_FFFF) * 100_000_000 + (both >> 32)
    };
    // Places 17 to 19 (with the point before them they start at byte 17), zeros where there are
    // none: W is then every digit with zeros after them up to 19 places, below 10^19.
    let extra_places = places.saturating_sub(16);
    let word = u32::from_le_bytes(s[17..21].try_into().expect("four bytes")).wrapping_sub(0x3030_3030);
    let extra = word & ((1 << (8 * extra_places)) - 1);
    let extra = u64::from(extra & 0xff) * 100 + u64::from((extra >> 8) & 0xff) * 10 + u64::from(extra >> 16);
    let w = first16 * 1000 + extra;
    let magnitude = if w == 0 {
        0.0
    } else {
        eisel_lemire(w, int_places as i64 - 19)
    };
    Some((with_sign(magnitude, negative), end))
}

/// The reader for every simple decimal, one branch per stretch of digits.
#[inline]
fn parse_general(bytes: &[u8]) -> Option<(f64, usize)> {
    let len = bytes.len();
    // The sign skipped without a branch (see `with_sign`).
    let negative = bytes.first() == Some(&b'-');
    let mut p = usize::from(negative);
    let mut digits: u64 = 0;
    let int_start = p;
    // Usually one or two digits: a byte at a time.
    p = read_digits_bytewise(bytes, p, &mut digits);
    let int_digits = p - int_start;
    let mut frac_digits = 0;
    if p < len && bytes[p] == b'.' {
        p += 1;
        let frac_start = p;
        p = read_digits(bytes, p, &mut digits);
        frac_digits = p - frac_start;
        if frac_digits == 0 {
            return None;
        }
    }
    if int_digits == 0 {
        return None;
    }
    if int_digits + frac_digits > 19 && significant_digits(&bytes[int_start..p]) > 19 {
        return None;
    }
    let mut exponent: i64 = 0;
    if p < len && bytes[p] | 0x20 == b'e' {
        let mut e = p + 1;
        let exp_negative = match bytes.get(e) {
            Some(b'-') => {
                e += 1;
                true
            }
            Some(b'+') => {
                e += 1;
                false
            }
            _ => false,
        };
        let exp_start = e;
        while e < len && bytes[e].is_ascii_digit() && e - exp_start < 6 {
            exponent = 10 * exponent + i64::from(bytes[e] - b'0');
            e += 1;
        }
        if e == exp_start || (e < len && bytes[e].is_ascii_digit()) {
            return None;
        }
        if exp_negative {
            exponent = -exponent;
        }
        p = e;
    }
    let q = exponent - frac_digits as i64;
    let magnitude = to_double(digits, q)?;
    Some((with_sign(magnitude, negative), p))
}

/// `-magnitude` when `negative`, as a bit rather than a branch: signs in a recording are a coin
/// toss, and a compiled `if negative` was mispredicted on half the fields (14 % of the reading
/// time).
#[inline(always)]
fn with_sign(magnitude: f64, negative: bool) -> f64 {
    f64::from_bits(magnitude.to_bits() | u64::from(negative) << 63)
}

/// Reads the run of digits from `p` into `digits` (wrapping past 19 digits: the caller counts
/// them) and returns where the run ends. Eight bytes at a time where eight are there to load: the
/// digits among them are counted and converted without a branch per digit.
#[inline(always)]
fn read_digits(bytes: &[u8], mut p: usize, digits: &mut u64) -> usize {
    while p + 8 <= bytes.len() {
        let chunk = u64::from_le_bytes(bytes[p..p + 8].try_into().expect("eight bytes"));
        let run = leading_digits(chunk);
        if run == 8 {
            *digits = digits.wrapping_mul(100_000_000).wrapping_add(eight_digits(chunk));
            p += 8;
            continue;
        }
        if run > 0 {
            // The run moved to the last `run` places of eight, with zeros before it.
            let shift = 8 * (8 - run) as u32;
            let padded = (chunk << shift) | (0x3030_3030_3030_3030 & ((1u64 << shift) - 1));
            *digits = digits
                .wrapping_mul(POWERS_OF_TEN_U64[run])
                .wrapping_add(eight_digits(padded));
        }
        return p + run;
    }
    read_digits_bytewise(bytes, p, digits)
}

/// [`read_digits`] one byte at a time.
#[inline(always)]
fn read_digits_bytewise(bytes: &[u8], mut p: usize, digits: &mut u64) -> usize {
    while p < bytes.len() && bytes[p].is_ascii_digit() {
        *digits = digits.wrapping_mul(10).wrapping_add(u64::from(bytes[p] - b'0'));
        p += 1;
    }
    p
}

/// 10^k for k < 9.
const POWERS_OF_TEN_U64: [u64; 9] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
];

/// How many of the eight little-endian bytes of `chunk`, from the first, are ASCII digits. A byte's
/// flag is exact up to the first non-digit (digits neither carry nor borrow); flags after it may
/// be disturbed, and are not looked at.
#[inline(always)]
fn leading_digits(chunk: u64) -> usize {
    let above_nine = chunk.wrapping_add(0x4646_4646_4646_4646);
    let below_zero = chunk.wrapping_sub(0x3030_3030_3030_3030);
    let flags = (above_nine | below_zero) & 0x8080_8080_8080_8080;
    (flags.trailing_zeros() / 8) as usize
}

/// The digits in `number` (digits and at most one point) after its leading zeros.
fn significant_digits(number: &[u8]) -> usize {
    let leading = number
        .iter()
        .take_while(|&&b| b == b'0' || b == b'.')
        .filter(|&&b| b == b'0')
        .count();
    number.iter().filter(|b| b.is_ascii_digit()).count() - leading
}

/// The value of eight ASCII digits read little-endian (the first byte is the most significant
/// digit): pairs, then fours, then the eight, each step one multiply.
#[inline(always)]
fn eight_digits(chunk: u64) -> u64 {
    let v = chunk.wrapping_sub(0x3030_3030_3030_3030);
    let pairs = v.wrapping_mul(10).wrapping_add(v >> 8) & 0x00FF_00FF_00FF_00FF;
    let fours = pairs.wrapping_mul(100).wrapping_add(pairs >> 16) & 0x0000_FFFF_0000_FFFF;
    fours.wrapping_mul(10_000).wrapping_add(fours >> 32) & 0xFFFF_FFFF
}

/// Exact powers of ten as doubles (10²² is the last one).
const EXACT_POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18,
    1e19, 1e20, 1e21, 1e22,
];

/// The exponents of ten this reader converts.
const MIN_Q: i64 = -27;
const MAX_Q: i64 = 27;

/// `w × 10^q` correctly rounded, for `q` in [`MIN_Q`, `MAX_Q`]; `None` outside.
#[inline]
fn to_double(w: u64, q: i64) -> Option<f64> {
    if w == 0 {
        return Some(0.0);
    }
    if !(MIN_Q..=MAX_Q).contains(&q) {
        return None;
    }
    // Clinger: both operands exact, so the one rounding of the product or quotient is correct.
    if w <= 1 << 53 && (-22..=22).contains(&q) {
        let value = w as f64;
        return Some(if q < 0 {
            value / EXACT_POWERS_OF_TEN[(-q) as usize]
        } else {
            value * EXACT_POWERS_OF_TEN[q as usize]
        });
    }
    Some(eisel_lemire(w, q))
}

/// Bits after the 52 explicit ones, the round bit and the bit above them that the product's high
/// word carries: when they are all ones the low half of 5^q may still carry into them.
const PRECISION_MASK: u64 = u64::MAX >> (52 + 3);

/// Eisel–Lemire for a normal result (true for every `w ≥ 1` and `q` within ±27).
#[inline(always)]
fn eisel_lemire(w: u64, q: i64) -> f64 {
    let (high5, low5) = POWERS_OF_FIVE[(q - MIN_Q) as usize];
    let shift = w.leading_zeros();
    let w = w << shift;
    let first = u128::from(w) * u128::from(high5);
    let (mut upper, mut lower) = ((first >> 64) as u64, first as u64);
    if upper & PRECISION_MASK == PRECISION_MASK {
        let second_high = ((u128::from(w) * u128::from(low5)) >> 64) as u64;
        let (sum, carry) = lower.overflowing_add(second_high);
        lower = sum;
        upper += u64::from(carry);
    }
    let upper_bit = upper >> 63;
    let mut mantissa = upper >> (upper_bit + 64 - 52 - 3);
    // ⌊q log₂10⌋ + 63 (217706 / 2¹⁶ is log₂10 to the precision this needs).
    let power_of_two = ((217_706 * q) >> 16) + 63;
    let mut biased = power_of_two + upper_bit as i64 - i64::from(shift) + 1023;
    // A product exactly halfway between two doubles (only possible for small |q|) rounds to even.
    if lower <= 1
        && (-4..=23).contains(&q)
        && mantissa & 3 == 1
        && (mantissa << (upper_bit + 64 - 52 - 3)) == upper
    {
        mantissa &= !1;
    }
    mantissa += mantissa & 1;
    mantissa >>= 1;
    if mantissa >= 2 << 52 {
        mantissa = 1 << 52;
        biased += 1;
    }
    mantissa &= !(1 << 52);
    f64::from_bits(mantissa | ((biased as u64) << 52))
}

/// The 128-bit significands of 5^q for q in [`MIN_Q`, `MAX_Q`], as (high, low) words, normalised
/// so the top bit is set: exact for q ≥ 0; for q < 0, ⌊2^b / 5^−q⌋ + 1 with b chosen to fill 128
/// bits (rounded up, so the product errs on one known side).
const POWERS_OF_FIVE: [(u64, u64); (MAX_Q - MIN_Q + 1) as usize] = powers_of_five();

const fn powers_of_five() -> [(u64, u64); (MAX_Q - MIN_Q + 1) as usize] {
    let mut table = [(0u64, 0u64); (MAX_Q - MIN_Q + 1) as usize];
    let mut q = MIN_Q;
    while q <= MAX_Q {
        let mut power: u64 = 1;
        let mut k = 0;
        while k < q.unsigned_abs() {
            power *= 5;
            k += 1;
        }
        let value: u128 = if q >= 0 {
            (power as u128) << (64 + power.leading_zeros())
        } else {
            // ⌊2^(bits + 127) / 5^−q⌋ + 1, where 5^−q has `bits` bits: long division, one bit at a
            // time (the quotient has exactly 128 bits).
            let bits = 64 - power.leading_zeros();
            let total = bits + 127;
            let mut remainder: u128 = 0;
            let mut quotient: u128 = 0;
            let mut bit = total as i64;
            while bit >= 0 {
                remainder = (remainder << 1) | (bit == total as i64) as u128;
                quotient <<= 1;
                if remainder >= power as u128 {
                    remainder -= power as u128;
                    quotient |= 1;
                }
                bit -= 1;
            }
            quotient + 1
        };
        table[(q - MIN_Q) as usize] = ((value >> 64) as u64, value as u64);
        q += 1;
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// `text` alone, and followed by a field as in a file (long enough for [`parse_plain`]).
    fn check(text: &str) {
        check_in(text, text);
        check_in(text, &format!("{text},1.234567890123456789012345678901234567"));
        check_in(text, &format!("{text}\n"));
    }

    fn check_in(text: &str, line: &str) {
        let expected: f64 = text.parse().unwrap();
        match parse_decimal(line.as_bytes()) {
            Some((value, used)) => {
                assert_eq!(used, text.len(), "{text}");
                assert!(value.is_finite(), "{text}");
                assert_eq!(
                    value.to_bits(),
                    expected.to_bits(),
                    "{text}: {value:e} vs {expected:e}"
                );
            }
            None => {
                // Declined: only for what this reader leaves to the general parser.
                let digits = text.bytes().filter(u8::is_ascii_digit).count();
                assert!(digits > 19 || text.contains(['e', 'E']), "{text} was declined");
            }
        }
    }

    #[test]
    fn the_table_is_five_to_the_q() {
        // 5^0 = 1 and 5^1 = 5 normalised; 5^−1 = 0.8 = 0xCCCC…CCCD rounded up.
        assert_eq!(POWERS_OF_FIVE[(0 - MIN_Q) as usize], (1 << 63, 0));
        assert_eq!(POWERS_OF_FIVE[(1 - MIN_Q) as usize], (0xA000_0000_0000_0000, 0));
        assert_eq!(
            POWERS_OF_FIVE[(-1 - MIN_Q) as usize],
            (0xCCCC_CCCC_CCCC_CCCC, 0xCCCC_CCCC_CCCC_CCCD)
        );
        for (high, _) in POWERS_OF_FIVE {
            assert!(high >> 63 == 1);
        }
    }

    /// Eisel–Lemire alone, also where Clinger's path would do (small mantissas, small exponents),
    /// as [`parse_plain`] uses it for every value.
    #[test]
    fn eisel_lemire_is_exact_for_every_mantissa_size() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..1_000_000 {
            let digits = rng.gen_range(1..=19u32);
            let w: u64 = rng.gen_range(10u64.pow(digits - 1)..10u64.pow(digits - 1).saturating_mul(10));
            let q: i64 = rng.gen_range(MIN_Q..=MAX_Q);
            let expected: f64 = format!("{w}e{q}").parse().unwrap();
            assert_eq!(eisel_lemire(w, q).to_bits(), expected.to_bits(), "{w}e{q}");
        }
        // Exact values, halfway cases and their neighbours at small exponents.
        for w in (1..200_000u64).chain((1u64 << 53) - 100..(1u64 << 53) + 100) {
            for q in -4..=4 {
                let expected: f64 = format!("{w}e{q}").parse().unwrap();
                assert_eq!(eisel_lemire(w, q).to_bits(), expected.to_bits(), "{w}e{q}");
            }
        }
    }

    /// Wherever the SSE2 path takes a number it reads what the general reader reads, to the bit
    /// and the byte: random runs of signs, digits, points, exponents and separators, placed so
    /// numbers end anywhere in the 32 bytes looked at (and past them).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn plain_path_agrees_with_the_general_reader() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut taken = 0;
        for _ in 0..2_000_000 {
            let mut text = Vec::new();
            while text.len() < 40 {
                match rng.gen_range(0..10) {
                    0 => text.push(b'-'),
                    1 => text.push(b'.'),
                    2 => text.push([b'e', b'E', b'+'][rng.gen_range(0..3)]),
                    3 => text.push([b',', b' ', b'\n', b'\r', b'x'][rng.gen_range(0..5)]),
                    _ => {
                        for _ in 0..rng.gen_range(1..=12) {
                            text.push(b'0' + rng.gen_range(0..10u8));
                        }
                    }
                }
            }
            // Most of the time, the shape a recording has.
            if rng.gen_bool(0.5) {
                let (int_width, frac_width) = (rng.gen_range(1..6), rng.gen_range(1..19));
                let number = format!(
                    "{}{}.{:0frac_width$}",
                    if rng.gen_bool(0.5) { "-" } else { "" },
                    rng.gen_range(0..10u64.pow(int_width)),
                    rng.gen_range(0..10u64.pow(frac_width as u32)),
                );
                text.splice(0..0, number.bytes());
            }
            if let Some((value, used)) = parse_plain(&text) {
                taken += 1;
                let general = parse_general(&text);
                assert_eq!(
                    general.map(|(v, u)| (v.to_bits(), u)),
                    Some((value.to_bits(), used)),
                    "{}",
                    String::from_utf8_lossy(&text)
                );
            }
        }
        assert!(taken > 200_000, "the plain path took only {taken}");
    }

    #[test]
    fn agrees_with_str_parse_on_simple_and_awkward_numbers() {
        for text in [
            "0",
            "-0",
            "0.0",
            "1",
            "-1",
            "2.5",
            "0.1",
            "0.5",
            "1.5",
            "3.14159",
            "-0.3900573453406082",
            "10.170538484348688",
            "8.24761456346716",
            "0.000123",
            "1e5",
            "1E-5",
            "2.5e+3",
            "9007199254740993",
            "9007199254740992.5",
            "4503599627370497.5",
            "18446744073709551615",
            "9999999999999999999",
            "0.0000000000000000000000000001",
            "1.7976931348623157e308",
            "00000000000000000000012.5",
            "123456789012345678.9",
            "1.00000000000000011102230246251565404236316680908203125",
        ] {
            check(text);
        }
        // Declined without a digit on both sides of the point, with a plus sign, or an exponent
        // without digits: the general parser decides those.
        for text in [".5", "5.", "-", "+2.5", "e5", "1e", "1e+", "inf", "nan", ""] {
            assert_eq!(parse_decimal(text.as_bytes()), None, "{text}");
        }
        // Stops where the number ends.
        assert_eq!(parse_decimal(b"1.25,3"), Some((1.25, 4)));
        assert_eq!(parse_decimal(b"-7e2 x"), Some((-700.0, 4)));
    }

    /// Random numbers of 1–19 significant digits at every exponent taken, written plainly and in
    /// e-notation, and exact midpoints between doubles (where rounding goes to even): every bit
    /// equals `str::parse`'s.
    #[test]
    fn agrees_with_str_parse_on_millions_of_random_numbers() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..400_000 {
            let digits = rng.gen_range(1..=19);
            let w: u64 =
                rng.gen_range(0..10u64.pow(digits as u32 - 1).max(1) * 9) + 10u64.pow(digits as u32 - 1);
            let q: i64 = rng.gen_range(MIN_Q..=MAX_Q);
            check(&format!("{w}e{q}"));
            let text = w.to_string();
            let point = rng.gen_range(1..=text.len());
            let sign = if rng.gen_bool(0.5) { "-" } else { "" };
            if point < text.len() {
                check(&format!("{sign}{}.{}", &text[..point], &text[point..]));
            } else {
                check(&format!("{sign}{text}.0"));
            }
            // Halfway between consecutive doubles above 2^52 (spacing 1) and above 2^51 (0.5).
            let k: u64 = rng.gen_range(1u64 << 52..1u64 << 53);
            check(&format!("{k}.5"));
            let k: u64 = rng.gen_range(1u64 << 51..1u64 << 52);
            check(&format!("{k}.{}", ["25", "75"][rng.gen_range(0..2)]));
            // Integers above 2^53, odd ones halfway between doubles.
            let n: u64 = rng.gen_range(1u64 << 53..u64::MAX / 2);
            check(&n.to_string());
        }
        // Every double written with the shortest round-trip digits (what spincal writes).
        for _ in 0..400_000 {
            let x = f64::from_bits(rng.gen_range(0x3C00_0000_0000_0000u64..0x4600_0000_0000_0000));
            check(&x.to_string());
            check(&format!("{x:e}"));
        }
    }
}
