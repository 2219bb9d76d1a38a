//! Forward-mode dual numbers with a fixed-size tangent, generic over their base scalar so they nest.

use crate::real::Real;
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// `re + Σ eps[k]·εₖ` with `εₖ εₗ = 0`: a value and its derivatives along `N` directions.
///
/// `R` is itself a [`Real`], so `Dual<Dual<f64, 1>, N>` carries second derivatives
/// (a Hessian–vector product along the inner direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<R, const N: usize> {
    /// The primal part.
    pub re: R,
    /// The tangent part: one derivative per direction.
    pub eps: [R; N],
}

impl<R: Real, const N: usize> Dual<R, N> {
    /// A constant: zero tangent.
    #[inline(always)]
    pub fn constant(re: R) -> Self {
        Dual {
            re,
            eps: [R::zero(); N],
        }
    }

    /// The `k`-th seed variable: value `re`, tangent the `k`-th unit vector.
    #[inline(always)]
    pub fn variable(re: R, k: usize) -> Self {
        let mut eps = [R::zero(); N];
        eps[k] = R::one();
        Dual { re, eps }
    }

    /// Applies the chain rule for a unary function with value `f` and derivative `df` at `re`.
    #[inline(always)]
    fn chain(self, f: R, df: R) -> Self {
        let mut eps = self.eps;
        for e in eps.iter_mut() {
            *e *= df;
        }
        Dual { re: f, eps }
    }
}

impl<R: Real, const N: usize> num_traits::Zero for Dual<R, N> {
    fn zero() -> Self {
        Self::constant(R::zero())
    }
    fn is_zero(&self) -> bool {
        self.re.is_zero() && self.eps.iter().all(|e| e.is_zero())
    }
}

impl<R: Real, const N: usize> num_traits::One for Dual<R, N> {
    fn one() -> Self {
        Self::constant(R::one())
    }
}

impl<R: Real, const N: usize> Add for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}

impl<R: Real, const N: usize> AddAssign for Dual<R, N> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        self.re += o.re;
        for k in 0..N {
            self.eps[k] += o.eps[k];
        }
    }
}

impl<R: Real, const N: usize> Sub for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, o: Self) -> Self {
        self -= o;
        self
    }
}

impl<R: Real, const N: usize> SubAssign for Dual<R, N> {
    #[inline(always)]
    fn sub_assign(&mut self, o: Self) {
        self.re -= o.re;
        for k in 0..N {
            self.eps[k] -= o.eps[k];
        }
    }
}

impl<R: Real, const N: usize> Mul for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut eps = [R::zero(); N];
        for k in 0..N {
            eps[k] = self.eps[k] * o.re + self.re * o.eps[k];
        }
        Dual {
            re: self.re * o.re,
            eps,
        }
    }
}

impl<R: Real, const N: usize> MulAssign for Dual<R, N> {
    #[inline(always)]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}

impl<R: Real, const N: usize> Div for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let inv = R::one() / o.re;
        // The primal is a true quotient (not `self.re * inv`), so it is bitwise the plain
        // evaluation's.
        let q = self.re / o.re;
        let mut eps = [R::zero(); N];
        for k in 0..N {
            eps[k] = (self.eps[k] - q * o.eps[k]) * inv;
        }
        Dual { re: q, eps }
    }
}

impl<R: Real, const N: usize> DivAssign for Dual<R, N> {
    #[inline(always)]
    fn div_assign(&mut self, o: Self) {
        *self = *self / o;
    }
}

impl<R: Real, const N: usize> Neg for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut eps = self.eps;
        for e in eps.iter_mut() {
            *e = -*e;
        }
        Dual { re: -self.re, eps }
    }
}

impl<R: Real, const N: usize> Add<f64> for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, c: f64) -> Self {
        self.re = self.re + c;
        self
    }
}

impl<R: Real, const N: usize> Sub<f64> for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, c: f64) -> Self {
        self.re = self.re - c;
        self
    }
}

impl<R: Real, const N: usize> Mul<f64> for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn mul(mut self, c: f64) -> Self {
        self.re = self.re * c;
        for e in self.eps.iter_mut() {
            *e = *e * c;
        }
        self
    }
}

impl<R: Real, const N: usize> Div<f64> for Dual<R, N> {
    type Output = Self;
    #[inline(always)]
    fn div(mut self, c: f64) -> Self {
        // Divide (not multiply by `1 / c`), so the primal is bitwise the plain evaluation's.
        self.re = self.re / c;
        for e in self.eps.iter_mut() {
            *e = *e / c;
        }
        self
    }
}

impl<R: Real, const N: usize> Real for Dual<R, N> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Self::constant(R::cst(v))
    }
    #[inline(always)]
    fn value(&self) -> f64 {
        self.re.value()
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        let ds = if self.re.value() == 0.0 {
            R::zero()
        } else {
            (s * 2.0).recip()
        };
        self.chain(s, ds)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        let v = self.re.value();
        let sign = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        self.chain(self.re.abs(), R::cst(sign))
    }
    #[inline(always)]
    fn exp(self) -> Self {
        let e = self.re.exp();
        self.chain(e, e)
    }
    #[inline(always)]
    fn ln(self) -> Self {
        self.chain(self.re.ln(), R::one() / self.re)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        self.chain(self.re.sin(), self.re.cos())
    }
    #[inline(always)]
    fn cos(self) -> Self {
        self.chain(self.re.cos(), -self.re.sin())
    }
    #[inline(always)]
    fn powi(self, n: i32) -> Self {
        let d = if n == 0 {
            R::zero()
        } else {
            self.re.powi(n - 1) * (n as f64)
        };
        self.chain(self.re.powi(n), d)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        let r = self.re.recip();
        let mut eps = self.eps;
        for e in eps.iter_mut() {
            *e = -(*e * r) * r;
        }
        Dual { re: r, eps }
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        let y = self;
        let r2 = y.re * y.re + x.re * x.re;
        let re = y.re.atan2(x.re);
        if r2.value() == 0.0 {
            return Self::constant(re);
        }
        let inv = R::one() / r2;
        let mut eps = [R::zero(); N];
        for k in 0..N {
            eps[k] = (x.re * y.eps[k] - y.re * x.eps[k]) * inv;
        }
        Dual { re, eps }
    }
}
