//! [`F64x8`]: eight `f64` lanes, one per batch row, for the lane-wise kernels of
//! [`crate::RowFn::eval_lanes`].
//!
//! Written in plain Rust, lane by lane: the in-place kernels compile the code that uses it inside
//! an AVX2 function (chosen at run time), where each operation becomes two independent 4-wide
//! instructions (two groups of four rows, so their square-root-then-division chains overlap),
//! and every lane's operations are the IEEE operations the row-by-row code performs, in the
//! same order (no fused multiply–add), so the results are bitwise those of the scalar path.
//! Conditions are bit masks and [`F64x8::select`] is bitwise, so no lane is branched on.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Rows a lane-wise kernel processes at once.
pub const LANES: usize = 8;

/// Eight `f64` values, lane `l` belonging to the `l`-th row of a group of [`LANES`] rows.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[repr(C, align(32))]
pub struct F64x8(pub [f64; LANES]);

/// A per-lane condition of [`F64x8`] comparisons, for [`F64x8::select`]: all bits set where it
/// holds, none elsewhere.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mask8(pub [u64; LANES]);

/// The bits of a lane where `b` holds.
#[inline(always)]
fn bits(b: bool) -> u64 {
    (b as u64).wrapping_neg()
}

impl F64x8 {
    /// The same value in every lane.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        F64x8([v; LANES])
    }

    /// `f(lane)` in every lane.
    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        F64x8(std::array::from_fn(f))
    }

    /// `√x` lane by lane (correctly rounded, as `f64::sqrt`).
    #[inline(always)]
    pub fn sqrt(self) -> Self {
        F64x8(self.0.map(f64::sqrt))
    }

    /// Lanes equal to `0.0` (either sign).
    #[inline(always)]
    pub fn eq_zero(self) -> Mask8 {
        Mask8(self.0.map(|v| bits(v == 0.0)))
    }

    /// Lanes `≥ 0.0` (false for NaN).
    #[inline(always)]
    pub fn ge_zero(self) -> Mask8 {
        Mask8(self.0.map(|v| bits(v >= 0.0)))
    }

    /// `if mask { a } else { b }` lane by lane.
    #[inline(always)]
    pub fn select(mask: Mask8, a: Self, b: Self) -> Self {
        F64x8(std::array::from_fn(|l| {
            let m = mask.0[l];
            f64::from_bits((a.0[l].to_bits() & m) | (b.0[l].to_bits() & !m))
        }))
    }
}

/// Copies lane `l` of every vector of `src` into `dst` (one value per vector).
#[inline(always)]
pub fn read_lane(src: &[F64x8], l: usize, dst: &mut [f64]) {
    dst.iter_mut().zip(src).for_each(|(d, s)| *d = s.0[l]);
}

/// Writes `src` (one value per vector) into lane `l` of the vectors of `dst`.
#[inline(always)]
pub fn write_lane(dst: &mut [F64x8], l: usize, src: &[f64]) {
    dst.iter_mut().zip(src).for_each(|(d, s)| d.0[l] = *s);
}

impl Mask8 {
    /// `self || other` lane by lane.
    #[inline(always)]
    pub fn or(self, other: Self) -> Self {
        Mask8(std::array::from_fn(|l| self.0[l] | other.0[l]))
    }
}

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F64x8 {
            type Output = F64x8;
            #[inline(always)]
            fn $method(self, rhs: F64x8) -> F64x8 {
                F64x8(std::array::from_fn(|l| self.0[l] $op rhs.0[l]))
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);
lanewise!(Div, div, /);

impl Neg for F64x8 {
    type Output = F64x8;
    #[inline(always)]
    fn neg(self) -> F64x8 {
        F64x8(self.0.map(|v| -v))
    }
}
