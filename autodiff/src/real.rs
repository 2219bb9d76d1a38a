//! The scalar algebra every differentiable function in the workspace is written against.
//!
//! A function written once as `fn f<R: Real>(..)` evaluates plainly with `R = f64`, gives local
//! derivatives with `R = Dual<f64, N>`, and second derivatives with nested duals
//! (`Dual<Dual<f64, 1>, N>`).
//!
//! # Conventions at non-differentiable points
//! Every function returns a finite sub-gradient where the classical derivative does not exist:
//! - `sqrt(0)`: derivative 0 (so `sqrt(v·v)`, the norm of a zero vector, has gradient 0, not NaN);
//! - `abs(0)`: derivative 0;
//! - `relu(0)`: derivative 0 (the function is treated as flat at the kink);
//! - `min(a, b)` / `max(a, b)` on a tie: the derivative of the first argument `a`;
//! - `atan2(0, 0)`: derivative 0.
//!
//! Near-degenerate but non-zero arguments get the classical derivative: the norm
//! `sqrt(v·v)` of a vector of length 1e-12 has exactly the unit-vector gradient `v/|v|` (no
//! regularization, no epsilon). Only when `v·v` itself underflows to 0 (`|v|` below about
//! 1.5e-154) is the vector treated as the zero vector: value 0, gradient 0, never NaN.
//! `tests/degenerate.rs` checks each of these conventions.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real scalar: `f64`, or a forward-mode dual number over another `Real`.
pub trait Real:
    Copy
    + Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + num_traits::Zero
    + num_traits::One
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant (all derivative parts zero).
    fn cst(v: f64) -> Self;
    /// The primal value, with all derivative parts dropped (recursively for nested duals).
    fn value(&self) -> f64;
    /// Square root; derivative 0 at 0 (see the module's conventions).
    fn sqrt(self) -> Self;
    /// Absolute value; derivative 0 at 0.
    fn abs(self) -> Self;
    /// Natural exponential.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Integer power.
    fn powi(self, n: i32) -> Self;
    /// Four-quadrant arctangent of `self / x`; derivative 0 at the origin.
    fn atan2(self, x: Self) -> Self;
    /// `max(self, 0)`; derivative 0 at 0.
    fn relu(self) -> Self {
        if self.value() > 0.0 {
            self
        } else {
            Self::zero()
        }
    }
    /// The smaller of the two; on a tie, `self` (and its derivative).
    fn min(self, other: Self) -> Self {
        if other.value() < self.value() {
            other
        } else {
            self
        }
    }
    /// The larger of the two; on a tie, `self` (and its derivative).
    fn max(self, other: Self) -> Self {
        if other.value() > self.value() {
            other
        } else {
            self
        }
    }
    /// `self * self`.
    fn square(self) -> Self {
        self * self
    }
    /// `1 / self`, with a single division also for duals.
    fn recip(self) -> Self {
        Self::one() / self
    }
}

impl Real for f64 {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn value(&self) -> f64 {
        *self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn exp(self) -> Self {
        f64::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        f64::ln(self)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        f64::powi(self, n)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        1.0 / self
    }
}
