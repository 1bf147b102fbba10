//! The number types the kernels are generic over: `f32` and the Q16.16 fixed-point [`Q16`].
//!
//! The trait is sealed: the kernels rely on the documented rounding and saturation
//! behaviour below, which an outside implementation could not promise.
//!
//! # Q16.16 semantics
//! A [`Q16`] holds `raw / 65536` in an `i32`: range `[-32768, 32768 - 2^-16]`,
//! resolution `2^-16 ≈ 1.53e-5`.
//! - **Saturation**: every arithmetic operation saturates at [`Q16::MIN`] / [`Q16::MAX`]
//!   instead of wrapping or panicking (`-Q16::MIN` is `Q16::MAX`).
//! - **Rounding**: multiplication, division, square root and conversion from `f32`
//!   round to the nearest representable value, ties away from zero, so that
//!   `(-a) * b == -(a * b)` exactly.
//! - **Division by zero** gives `MAX` for a positive numerator, `MIN` for a negative
//!   one and zero for `0 / 0`: a kernel dividing by a vanishing trace sees a large,
//!   finite number rather than a trap.
//! - **Square root** of a negative number is zero.
//! - **From `f32`**: NaN becomes zero, ±∞ and out-of-range values saturate.

use core::fmt;
use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for super::Q16 {}
}

/// Arithmetic the EPI and TV kernels need, implemented for `f32` and [`Q16`].
pub trait Scalar:
    sealed::Sealed
    + Copy
    + Default
    + PartialEq
    + PartialOrd
    + fmt::Debug
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// Additive identity.
    const ZERO: Self;
    /// Multiplicative identity.
    const ONE: Self;
    /// Largest finite value.
    const MAX: Self;
    /// Smallest (most negative) finite value.
    const MIN: Self;
    /// Smallest positive step that is meaningful for this type (`f32::EPSILON`, or one LSB).
    const EPSILON: Self;
    /// Short name for reports (`"f32"`, `"q16.16"`).
    const NAME: &'static str;
    /// Whether `Self` is `f32` (its conversions are the identity): a kernel's
    /// branch-free `f32` path over whole slices, chosen at compile time.
    const IS_F32: bool;

    /// Converts from `f32` (fixed point: round to nearest, saturate, NaN → 0).
    fn from_f32(v: f32) -> Self;
    /// Converts to `f32` (exact for `Q16` values whose raw magnitude is below 2^24).
    fn to_f32(self) -> f32;
    /// Converts an integer (fixed point: saturating).
    fn from_i32(v: i32) -> Self;
    /// Square root; zero for negative inputs.
    fn sqrt(self) -> Self;
    /// Absolute value (fixed point: `abs(MIN) == MAX`).
    fn abs(self) -> Self;
    /// Whether the value is finite (always true for fixed point).
    fn is_finite(self) -> bool;
    /// `(⌊self⌋, self − ⌊self⌋)`: the integer part rounded down (saturating to the `i32`
    /// range) and the fraction in `[0, 1)`. Fixed point splits the raw bits, exactly;
    /// kernels that index pixels at sub-pixel positions use it instead of leaving `Self`.
    fn floor_fract(self) -> (i32, Self);

    /// The value itself when `Self` is `f32`, `None` in fixed point: a kernel's
    /// `f32`-only path, chosen at compile time.
    fn as_f32(self) -> Option<f32>;
    /// [`Self::as_f32`] of a place to write.
    fn as_f32_mut(&mut self) -> Option<&mut f32>;
    /// [`Self::as_f32`] of `N` lanes at once.
    fn as_f32_lanes<const N: usize>(lanes: &[Self; N]) -> Option<&[f32; N]>;
    /// [`Self::as_f32_lanes`] of lanes to write.
    fn as_f32_lanes_mut<const N: usize>(lanes: &mut [Self; N]) -> Option<&mut [f32; N]>;

    /// The smaller of two values (`f32`: a NaN operand yields the other one).
    #[inline]
    #[allow(clippy::eq_op)] // `self != self` is the NaN test
    fn min(self, other: Self) -> Self {
        if self != self || other < self {
            other
        } else {
            self
        }
    }
    /// The larger of two values (`f32`: a NaN operand yields the other one).
    #[inline]
    #[allow(clippy::eq_op)] // `self != self` is the NaN test
    fn max(self, other: Self) -> Self {
        if self != self || other > self {
            other
        } else {
            self
        }
    }
    /// Clamps into `[lo, hi]` (expects `lo <= hi`).
    #[inline]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
}

impl Scalar for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const MAX: Self = f32::MAX;
    const MIN: Self = f32::MIN;
    const EPSILON: Self = f32::EPSILON;
    const NAME: &'static str = "f32";
    const IS_F32: bool = true;

    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn from_i32(v: i32) -> Self {
        v as f32
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        if self > 0.0 {
            crate::float::sqrtf(self)
        } else {
            0.0
        }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn floor_fract(self) -> (i32, Self) {
        let floor = libm::floorf(self);
        // `as` saturates (and maps NaN to 0).
        (floor as i32, self - floor)
    }
    #[inline(always)]
    fn as_f32(self) -> Option<f32> {
        Some(self)
    }
    #[inline(always)]
    fn as_f32_mut(&mut self) -> Option<&mut f32> {
        Some(self)
    }
    #[inline(always)]
    fn as_f32_lanes<const N: usize>(lanes: &[Self; N]) -> Option<&[f32; N]> {
        Some(lanes)
    }
    #[inline(always)]
    fn as_f32_lanes_mut<const N: usize>(lanes: &mut [Self; N]) -> Option<&mut [f32; N]> {
        Some(lanes)
    }
}

/// Q16.16 signed fixed-point number; see the [module documentation](self) for its rules.
#[derive(Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(transparent)]
pub struct Q16(i32);

const FRAC_BITS: u32 = 16;
const ONE_RAW: i64 = 1 << FRAC_BITS;

/// Saturates an `i64` into the `i32` range.
#[inline(always)]
fn saturate(v: i64) -> i32 {
    v.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

/// `num / den` rounded to nearest, ties away from zero (`den > 0`).
#[inline(always)]
fn div_round(num: i64, den: i64) -> i64 {
    let half = den / 2;
    if num >= 0 {
        (num + half) / den
    } else {
        -((-num + half) / den)
    }
}

impl Q16 {
    /// Largest value, `32768 - 2^-16`.
    pub const MAX: Q16 = Q16(i32::MAX);
    /// Smallest value, `-32768`.
    pub const MIN: Q16 = Q16(i32::MIN);
    /// One least-significant bit, `2^-16`.
    pub const LSB: Q16 = Q16(1);

    /// Wraps a raw Q16.16 bit pattern.
    #[inline(always)]
    pub const fn from_raw(raw: i32) -> Self {
        Q16(raw)
    }
    /// The raw Q16.16 bit pattern.
    #[inline(always)]
    pub const fn raw(self) -> i32 {
        self.0
    }
}

impl fmt::Debug for Q16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Q16({})", self.to_f32())
    }
}

impl fmt::Display for Q16 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.to_f32(), f)
    }
}

impl Add for Q16 {
    type Output = Q16;
    #[inline(always)]
    fn add(self, rhs: Q16) -> Q16 {
        Q16(self.0.saturating_add(rhs.0))
    }
}

impl Sub for Q16 {
    type Output = Q16;
    #[inline(always)]
    fn sub(self, rhs: Q16) -> Q16 {
        Q16(self.0.saturating_sub(rhs.0))
    }
}

impl Neg for Q16 {
    type Output = Q16;
    #[inline(always)]
    fn neg(self) -> Q16 {
        Q16(self.0.saturating_neg())
    }
}

impl Mul for Q16 {
    type Output = Q16;
    #[inline(always)]
    fn mul(self, rhs: Q16) -> Q16 {
        let p = self.0 as i64 * rhs.0 as i64;
        Q16(saturate(div_round(p, ONE_RAW)))
    }
}

impl Div for Q16 {
    type Output = Q16;
    #[inline]
    fn div(self, rhs: Q16) -> Q16 {
        if rhs.0 == 0 {
            return match self.0.signum() {
                1 => Q16::MAX,
                -1 => Q16::MIN,
                _ => Q16(0),
            };
        }
        let num = (self.0 as i64) << FRAC_BITS;
        let (num, den) = if rhs.0 < 0 {
            (-num, -(rhs.0 as i64))
        } else {
            (num, rhs.0 as i64)
        };
        Q16(saturate(div_round(num, den)))
    }
}

impl AddAssign for Q16 {
    #[inline(always)]
    fn add_assign(&mut self, rhs: Q16) {
        *self = *self + rhs;
    }
}

impl SubAssign for Q16 {
    #[inline(always)]
    fn sub_assign(&mut self, rhs: Q16) {
        *self = *self - rhs;
    }
}

impl MulAssign for Q16 {
    #[inline(always)]
    fn mul_assign(&mut self, rhs: Q16) {
        *self = *self * rhs;
    }
}

/// Integer square root of a `u64`, rounded to nearest.
fn isqrt_round(v: u64) -> u64 {
    if v == 0 {
        return 0;
    }
    // Newton's method from an over-estimate converges monotonically to floor(sqrt(v)).
    let mut x = 1u64 << (64 - v.leading_zeros()).div_ceil(2);
    loop {
        // x ≥ floor(sqrt(v)) ≥ 1: the checked division never misses (it keeps the
        // division-by-zero panic out of the firmware image).
        let y = (x + v.checked_div(x).unwrap_or(v)) / 2;
        if y >= x {
            break;
        }
        x = y;
    }
    // Round: compare v with (x + 1/2)^2 = x^2 + x + 1/4, i.e. v > x^2 + x.
    if v > x * x + x {
        x + 1
    } else {
        x
    }
}

impl Scalar for Q16 {
    const ZERO: Self = Q16(0);
    const ONE: Self = Q16(1 << FRAC_BITS);
    const MAX: Self = Q16(i32::MAX);
    const MIN: Self = Q16(i32::MIN);
    const EPSILON: Self = Q16(1);
    const NAME: &'static str = "q16.16";
    const IS_F32: bool = false;

    #[inline]
    fn from_f32(v: f32) -> Self {
        if v.is_nan() {
            return Q16(0);
        }
        let scaled = v as f64 * ONE_RAW as f64;
        let rounded = if scaled >= 0.0 {
            libm::floor(scaled + 0.5)
        } else {
            -libm::floor(-scaled + 0.5)
        };
        // `as` from f64 to i64 saturates (and ±∞ saturate too).
        Q16(saturate(rounded as i64))
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self.0 as f32 / ONE_RAW as f32
    }
    #[inline(always)]
    fn from_i32(v: i32) -> Self {
        Q16(saturate((v as i64) << FRAC_BITS))
    }
    #[inline]
    fn sqrt(self) -> Self {
        if self.0 <= 0 {
            return Q16(0);
        }
        // sqrt(raw / 2^16) * 2^16 = sqrt(raw * 2^16); the result always fits (< 2^24).
        Q16(isqrt_round((self.0 as u64) << FRAC_BITS) as i32)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Q16(self.0.saturating_abs())
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        true
    }
    #[inline(always)]
    fn floor_fract(self) -> (i32, Self) {
        // Arithmetic shift rounds towards −∞; the low bits are the fraction.
        (self.0 >> FRAC_BITS, Q16(self.0 & (ONE_RAW as i32 - 1)))
    }
    #[inline(always)]
    fn as_f32(self) -> Option<f32> {
        None
    }
    #[inline(always)]
    fn as_f32_mut(&mut self) -> Option<&mut f32> {
        None
    }
    #[inline(always)]
    fn as_f32_lanes<const N: usize>(_: &[Self; N]) -> Option<&[f32; N]> {
        None
    }
    #[inline(always)]
    fn as_f32_lanes_mut<const N: usize>(_: &mut [Self; N]) -> Option<&mut [f32; N]> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn q(v: f32) -> Q16 {
        Q16::from_f32(v)
    }

    #[test]
    fn q16_round_trips_exactly_representable_values() {
        for v in [
            0.0f32,
            1.0,
            -1.0,
            0.5,
            -0.25,
            1234.5,
            -32768.0,
            1.0 / 65536.0,
        ] {
            assert_eq!(q(v).to_f32(), v, "{v}");
        }
    }

    #[test]
    fn q16_from_f32_rounds_to_nearest_ties_away_from_zero() {
        let lsb = 1.0f32 / 65536.0;
        assert_eq!(q(0.5 * lsb).raw(), 1);
        assert_eq!(q(-0.5 * lsb).raw(), -1);
        assert_eq!(q(0.49 * lsb).raw(), 0);
        assert_eq!(q(1.51 * lsb).raw(), 2);
    }

    #[test]
    fn q16_from_f32_saturates_and_maps_nan_to_zero() {
        assert_eq!(q(1e9), Q16::MAX);
        assert_eq!(q(-1e9), Q16::MIN);
        assert_eq!(q(f32::INFINITY), Q16::MAX);
        assert_eq!(q(f32::NEG_INFINITY), Q16::MIN);
        assert_eq!(q(f32::NAN), Q16::ZERO);
        assert_eq!(Q16::from_i32(40000), Q16::MAX);
        assert_eq!(Q16::from_i32(-40000), Q16::MIN);
        assert_eq!(Q16::from_i32(-3).to_f32(), -3.0);
    }

    #[test]
    fn q16_add_sub_neg_saturate() {
        assert_eq!(Q16::MAX + Q16::ONE, Q16::MAX);
        assert_eq!(Q16::MIN - Q16::ONE, Q16::MIN);
        assert_eq!(-Q16::MIN, Q16::MAX);
        assert_eq!(Q16::MIN.abs(), Q16::MAX);
        assert_eq!((q(1.5) - q(2.25)).to_f32(), -0.75);
    }

    #[test]
    fn q16_mul_rounds_and_saturates() {
        assert_eq!((q(1.5) * q(-2.0)).to_f32(), -3.0);
        // 1 LSB * 0.5 = half an LSB: ties away from zero, symmetric in sign.
        assert_eq!((Q16::LSB * q(0.5)).raw(), 1);
        assert_eq!((-Q16::LSB * q(0.5)).raw(), -1);
        assert_eq!((Q16::LSB * q(0.25)).raw(), 0);
        assert_eq!(q(300.0) * q(300.0), Q16::MAX);
        assert_eq!(q(-300.0) * q(300.0), Q16::MIN);
    }

    #[test]
    fn q16_div_rounds_and_handles_zero() {
        assert_eq!((q(1.0) / q(4.0)).to_f32(), 0.25);
        assert_eq!((q(-3.0) / q(2.0)).to_f32(), -1.5);
        assert_eq!((q(3.0) / q(-2.0)).to_f32(), -1.5);
        // 1/3 rounded to nearest LSB.
        assert_eq!((q(1.0) / q(3.0)).raw(), 21845);
        assert_eq!((q(2.0) / q(3.0)).raw(), 43691);
        assert_eq!(q(1.0) / Q16::ZERO, Q16::MAX);
        assert_eq!(q(-1.0) / Q16::ZERO, Q16::MIN);
        assert_eq!(Q16::ZERO / Q16::ZERO, Q16::ZERO);
        assert_eq!(q(30000.0) / q(0.01), Q16::MAX);
        assert_eq!(Q16::MIN / q(-1.0), Q16::MAX);
    }

    #[test]
    fn q16_sqrt_rounds_and_clamps_negative() {
        assert_eq!(q(4.0).sqrt().to_f32(), 2.0);
        assert_eq!(q(2.0).sqrt().raw(), 92682); // sqrt(2) * 65536 = 92681.9
        assert_eq!(q(-4.0).sqrt(), Q16::ZERO);
        assert_eq!(Q16::MAX.sqrt().raw(), 11863283); // sqrt(32768) * 65536 = 11863283.2
        assert_eq!(Q16::LSB.sqrt().raw(), 256);
    }

    #[test]
    fn floor_fract_splits_at_the_floor() {
        for (v, i, f) in [
            (2.75f32, 2, 0.75f32),
            (-2.25, -3, 0.75),
            (3.0, 3, 0.0),
            (-0.5, -1, 0.5),
        ] {
            assert_eq!(Scalar::floor_fract(v), (i, f), "{v}");
            assert_eq!(q(v).floor_fract(), (i, q(f)), "{v}");
        }
        assert_eq!(Q16::MIN.floor_fract(), (-32768, Q16::ZERO));
        assert_eq!(Q16::MAX.floor_fract(), (32767, q(1.0) - Q16::LSB));
    }

    #[test]
    fn only_f32_takes_the_f32_paths() {
        let mut x = 1.5f32;
        assert_eq!(x.as_f32(), Some(1.5));
        if let Some(v) = x.as_f32_mut() {
            *v = 2.5;
        }
        assert_eq!(x, 2.5);
        let mut lanes = [1.0f32, -2.0];
        assert_eq!(f32::as_f32_lanes(&lanes), Some(&[1.0, -2.0]));
        if let Some(l) = f32::as_f32_lanes_mut(&mut lanes) {
            l[1] = 3.0;
        }
        assert_eq!(lanes, [1.0, 3.0]);
        let mut q = q(1.5);
        assert_eq!(q.as_f32(), None);
        assert!(q.as_f32_mut().is_none());
        assert!(Q16::as_f32_lanes(&[q; 2]).is_none());
        assert!(Q16::as_f32_lanes_mut(&mut [q; 2]).is_none());
    }

    #[test]
    fn f32_scalar_helpers() {
        assert_eq!(Scalar::sqrt(-1.0f32), 0.0);
        assert_eq!(Scalar::sqrt(9.0f32), 3.0);
        assert_eq!(Scalar::clamp(5.0f32, -1.0, 1.0), 1.0);
        assert_eq!(Scalar::min(f32::NAN, 1.0), 1.0);
        assert!(!Scalar::is_finite(f32::NAN));
    }

    proptest! {
        #[test]
        fn q16_ops_track_f64_within_half_lsb(a in -180.0f64..180.0, b in -180.0f64..180.0) {
            let (qa, qb) = (q(a as f32), q(b as f32));
            // Compare through the raw value: `to_f32` itself rounds above 2^24 LSBs.
            let exact = |v: Q16| v.raw() as f64 / 65536.0;
            let (fa, fb) = (exact(qa), exact(qb));
            let lsb = 1.0 / 65536.0;
            prop_assert!((exact(qa + qb) - (fa + fb)).abs() <= 0.5 * lsb);
            let p = fa * fb;
            if p.abs() < 32767.0 {
                prop_assert!((exact(qa * qb) - p).abs() <= 0.5 * lsb);
            } else {
                let saturated = if p > 0.0 { Q16::MAX } else { Q16::MIN };
                prop_assert_eq!(qa * qb, saturated);
            }
            if fb.abs() > 0.01 {
                let quotient = fa / fb;
                if quotient.abs() < 32000.0 {
                    prop_assert!((exact(qa / qb) - quotient).abs() <= 0.5 * lsb + 1e-12);
                }
            }
            let r = exact(qa.abs().sqrt());
            prop_assert!((r - fa.abs().sqrt()).abs() <= 0.5 * lsb + 1e-9);
        }

        #[test]
        fn q16_never_panics(a: i32, b: i32) {
            let (qa, qb) = (Q16::from_raw(a), Q16::from_raw(b));
            let _ = (qa + qb, qa - qb, qa * qb, qa / qb, -qa, qa.abs(), qa.sqrt());
        }
    }
}
