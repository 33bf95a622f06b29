//! The floating-point types every simkit CPU backend is generic over (`f32`, `f64`), and the
//! [`Precision`] a user picks between them.

use std::fmt::{Debug, Display};
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// Which floating-point type a backend computes in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Precision {
    /// Double precision (the CPU default).
    #[default]
    F64,
    /// Single precision (faster; about 1e-7 relative rounding per operation).
    F32,
}

impl Precision {
    /// The WGSL scalar type, `"f64"` or `"f32"`.
    pub fn wgsl(self) -> &'static str {
        match self {
            Precision::F64 => f64::WGSL,
            Precision::F32 => f32::WGSL,
        }
    }
}

/// `max` that propagates NaN: NaN if either argument is NaN. `f64::max` skips NaN, so a fold
/// with it lets a blown-up field pass a check; fold with this one instead.
#[inline]
pub fn max_or_nan(a: f64, b: f64) -> f64 {
    if b > a || b.is_nan() { b } else { a }
}

/// A real scalar type: implemented for `f32` and `f64` only.
///
/// One law written once is a function generic over `T: Real`, called by the f32 and the
/// f64 paths alike.
pub trait Real:
    Copy
    + Debug
    + Display
    + Default
    + PartialOrd
    + Send
    + Sync
    + bytemuck::Pod
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// The matching [`Precision`].
    const PRECISION: Precision;
    /// WGSL name of the type (`"f32"` or `"f64"`).
    const WGSL: &'static str;
    /// Converts from `f64` (rounding to nearest for `f32`).
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64` exactly.
    fn to_f64(self) -> f64;
    /// Square root.
    fn sqrt(self) -> Self;
    /// `e^self`.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// The smaller of two values (the other one when either is NaN).
    fn min(self, other: Self) -> Self;
    /// The larger of two values (the other one when either is NaN).
    fn max(self, other: Self) -> Self;
    /// `self * a + b` with one rounding (an FMA instruction where the target has one).
    fn mul_add(self, a: Self, b: Self) -> Self;
}

macro_rules! impl_real {
    ($t:ident, $precision:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const PRECISION: Precision = Precision::$precision;
            const WGSL: &'static str = stringify!($t);
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self.into()
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                $t::sqrt(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                $t::exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                $t::ln(self)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                $t::min(self, other)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                $t::max(self, other)
            }
            #[inline(always)]
            fn mul_add(self, a: Self, b: Self) -> Self {
                $t::mul_add(self, a, b)
            }
        }
    };
}

impl_real!(f64, F64);
impl_real!(f32, F32);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_types_convert_and_name_themselves() {
        assert_eq!(f32::from_f64(0.1), 0.1f32);
        assert_eq!(f64::from(0.1f32), 0.1f32.to_f64());
        assert_eq!((f32::WGSL, f64::WGSL), ("f32", "f64"));
        assert_eq!(Precision::default(), Precision::F64);
        assert_eq!(Precision::F32.wgsl(), "f32");
        assert_eq!(<f32 as Real>::PRECISION, Precision::F32);
        assert_eq!(Real::mul_add(2.0f64, 3.0, 1.0), 7.0);
    }

    #[test]
    fn max_or_nan_keeps_a_nan() {
        assert!(max_or_nan(f64::NAN, 1.0).is_nan());
        assert!(max_or_nan(1.0, f64::NAN).is_nan());
        assert_eq!((max_or_nan(1.0, 2.0), max_or_nan(2.0, 1.0)), (2.0, 2.0));
        assert!(
            [1.0, f64::NAN, 3.0]
                .into_iter()
                .fold(0.0, max_or_nan)
                .is_nan()
        );
    }
}
