//! The two precisions a corrector runs in, and the few functions it needs beyond arithmetic.
//!
//! `f64` does the library's operations in the library's order, so a correction equals
//! `spincal correct`'s to the last bit or nearly (the tests allow 1e-9 relative). `f32` does the
//! same operations rounded to single precision; its tanh is stated below.

use core::ops::{Add, Div, Mul, Neg, Sub};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// `f32` or `f64`.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + sealed::Sealed
{
    const ZERO: Self;
    const ONE: Self;
    const TWO: Self;
    const FOUR: Self;
    /// The machine epsilon (`f32::EPSILON`, `f64::EPSILON`).
    const EPSILON: Self;
    /// Correctly rounded square root (`libm`, as IEEE 754 and C's `sqrt`/`sqrtf` give it).
    fn sqrt(self) -> Self;
    /// Hyperbolic tangent, see [`tanh_f64`] and [`tanh_f32`].
    fn tanh(self) -> Self;
    fn abs(self) -> Self;
    fn is_finite(self) -> bool;
    /// A small count (a cell count) as this type; exact.
    fn from_count(n: usize) -> Self;
    /// Truncation toward zero of a value in [0, cells] (a cell index).
    fn to_index(self) -> usize;
}

impl Real for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    const TWO: f64 = 2.0;
    const FOUR: f64 = 4.0;
    const EPSILON: f64 = f64::EPSILON;
    #[inline]
    fn sqrt(self) -> f64 {
        libm::sqrt(self)
    }
    #[inline]
    fn tanh(self) -> f64 {
        tanh_f64(self)
    }
    #[inline]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline]
    fn from_count(n: usize) -> f64 {
        n as f64
    }
    #[inline]
    fn to_index(self) -> usize {
        self as usize
    }
}

impl Real for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    const TWO: f32 = 2.0;
    const FOUR: f32 = 4.0;
    const EPSILON: f32 = f32::EPSILON;
    #[inline]
    fn sqrt(self) -> f32 {
        libm::sqrtf(self)
    }
    #[inline]
    fn tanh(self) -> f32 {
        tanh_f32(self)
    }
    #[inline]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline]
    fn from_count(n: usize) -> f32 {
        n as f32
    }
    #[inline]
    fn to_index(self) -> usize {
        self as usize
    }
}

// ln 2 split so that k·LN2_HI is exact for the k that occur (|k| ≤ 58).
pub const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
pub const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
// 1.5·2^52: adding it rounds to an integer, which then sits in the low mantissa bits.
pub const ROUNDER: f64 = 6_755_399_441_055_744.0;
/// 1/2! … 1/13!: (expm1(r) − r)/r² by Taylor's series.
pub const TANH_C: [f64; 12] = [
    0.5,
    1.666_666_666_666_666_6e-1,
    4.166_666_666_666_666_4e-2,
    8.333_333_333_333_333e-3,
    1.388_888_888_888_889e-3,
    1.984_126_984_126_984e-4,
    2.480_158_730_158_73e-5,
    2.755_731_922_398_589_3e-6,
    2.755_731_922_398_589e-7,
    2.505_210_838_544_172e-8,
    2.087_675_698_786_81e-9,
    1.605_904_383_682_161_3e-10,
];

/// tanh in double precision: the operations of spincal's network (tanh(|x|) = −u/(2 + u) with
/// u = expm1(−2|x|), expm1 by reduction to |r| ≤ ln2/2 and a degree-13 Taylor polynomial in
/// Estrin's order, no fused multiply-adds), so the same bits as the library's; within 4 ulps of
/// the correctly rounded tanh. ±1 for |x| ≥ 20, NaN for NaN.
#[inline]
pub fn tanh_f64(x: f64) -> f64 {
    let magnitude = x.abs();
    let y = -2.0 * if magnitude > 20.0 { 20.0 } else { magnitude };
    let shifted = y * core::f64::consts::LOG2_E + ROUNDER;
    let k = shifted - ROUNDER;
    let r = (y - k * LN2_HI) - k * LN2_LO;
    let r2 = r * r;
    let r4 = r2 * r2;
    let pair = |j: usize| TANH_C[j] + TANH_C[j + 1] * r;
    let (p0, p2, p4, p6, p8, p10) = (pair(0), pair(2), pair(4), pair(6), pair(8), pair(10));
    let low = (p0 + p2 * r2) + (p4 + p6 * r2) * r4;
    let high = p8 + p10 * r2;
    let p = low + high * (r4 * r4);
    let expm1_r = r + r2 * p;
    let k_int = (shifted.to_bits() as i64).wrapping_sub(ROUNDER.to_bits() as i64);
    let scale = f64::from_bits((k_int.wrapping_add(1023) as u64) << 52);
    let u = scale * expm1_r + (scale - 1.0);
    (-u / (2.0 + u)).copysign(x)
}

pub const LN2_HI_F: f32 = f32::from_bits(0x3f31_7200);
pub const LN2_LO_F: f32 = f32::from_bits(0x35bf_be8e);
// 1.5·2^23.
pub const ROUNDER_F: f32 = 12_582_912.0;
/// 1/2! … 1/8!.
pub const TANH_C_F: [f32; 7] = [
    0.5,
    1.666_666_7e-1,
    4.166_666_8e-2,
    8.333_334e-3,
    1.388_888_9e-3,
    1.984_127e-4,
    2.480_158_7e-5,
];

/// tanh in single precision: the double version's method with a degree-8 Taylor polynomial in
/// Horner's order (its truncation error at |r| = ln2/2 is below 2⁻²⁶ relative). Within 2 ulps of
/// the correctly rounded tanh over [−20, 20] (measured every 1/4096 by the unit test, which
/// fails above 3); ±1 for |x| ≥ 20, NaN for NaN. The C export's `float` tanh does the same
/// operations.
#[inline]
pub fn tanh_f32(x: f32) -> f32 {
    let magnitude = x.abs();
    let y = -2.0 * if magnitude > 20.0 { 20.0 } else { magnitude };
    let shifted = y * core::f32::consts::LOG2_E + ROUNDER_F;
    let k = shifted - ROUNDER_F;
    let r = (y - k * LN2_HI_F) - k * LN2_LO_F;
    let c = &TANH_C_F;
    let p = c[0] + r * (c[1] + r * (c[2] + r * (c[3] + r * (c[4] + r * (c[5] + r * c[6])))));
    let expm1_r = r + (r * r) * p;
    let k_int = (shifted.to_bits() as i32).wrapping_sub(ROUNDER_F.to_bits() as i32);
    let scale = f32::from_bits((k_int.wrapping_add(127) as u32) << 23);
    let u = scale * expm1_r + (scale - 1.0);
    (-u / (2.0 + u)).copysign(x)
}
