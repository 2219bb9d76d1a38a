//! Lanes of `f64`: one value ([`f64`] itself) or four in an AVX register ([`Avx4`]).
//!
//! A batch kernel is written once over [`Lanes`] and instantiated for both. Only IEEE-exact
//! operations are offered (add, subtract, multiply, divide, square root, negation, selection) and
//! no fused multiply–add, so every lane of [`Avx4`] rounds exactly as the scalar code does: the
//! vector and scalar instantiations give the same bits.

/// A SIMD vector of `f64` lanes with IEEE-exact lane-wise arithmetic.
pub trait Lanes: Copy {
    /// Number of lanes.
    const N: usize;
    /// The mask of a lane-wise comparison.
    type Mask: Copy;
    /// Every lane `v`.
    fn splat(v: f64) -> Self;
    /// Lane `l` is `value(l)`.
    fn from_fn(value: impl FnMut(usize) -> f64) -> Self;
    /// Calls `sink(l, lane l)` for every lane.
    fn for_each(self, sink: impl FnMut(usize, f64));
    /// `self + o` lane-wise.
    fn add(self, o: Self) -> Self;
    /// `self − o` lane-wise.
    fn sub(self, o: Self) -> Self;
    /// `self · o` lane-wise.
    fn mul(self, o: Self) -> Self;
    /// `self / o` lane-wise.
    fn div(self, o: Self) -> Self;
    /// `√self` lane-wise.
    fn sqrt(self) -> Self;
    /// `−self` lane-wise (the sign bit flipped).
    fn neg(self) -> Self;
    /// Lanes equal to zero (`±0`).
    fn is_zero(self) -> Self::Mask;
    /// `if mask { a } else { b }` lane-wise.
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self;
}

impl Lanes for f64 {
    const N: usize = 1;
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn from_fn(mut value: impl FnMut(usize) -> f64) -> Self {
        value(0)
    }
    #[inline(always)]
    fn for_each(self, mut sink: impl FnMut(usize, f64)) {
        sink(0, self)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self + o
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self - o
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self * o
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self / o
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn neg(self) -> Self {
        -self
    }
    #[inline(always)]
    fn is_zero(self) -> bool {
        self == 0.0
    }
    #[inline(always)]
    fn select(mask: bool, a: Self, b: Self) -> Self {
        if mask {
            a
        } else {
            b
        }
    }
}

/// `K` registers of lanes `L` side by side: every operation runs on each of them in turn, so
/// `K` independent dependency chains (square root, then divisions) overlap in the pipeline.
#[derive(Clone, Copy)]
pub struct Wide<L, const K: usize>(pub [L; K]);

/// `out[k] = op(a[k], b[k])` for every register, as a plain loop: a closure here would not be
/// compiled with the caller's target features, so the vector intrinsics would not inline into it.
macro_rules! each {
    ($a:expr, $b:expr, $op:ident) => {{
        let (a, b) = ($a, $b);
        let mut out = a;
        for k in 0..K {
            out[k] = L::$op(a[k], b[k]);
        }
        out
    }};
    ($a:expr, $op:ident) => {{
        let mut out = $a;
        for k in 0..K {
            out[k] = L::$op(out[k]);
        }
        out
    }};
}

impl<L: Lanes, const K: usize> Lanes for Wide<L, K> {
    const N: usize = K * L::N;
    type Mask = [L::Mask; K];
    #[inline(always)]
    fn splat(v: f64) -> Self {
        Wide([L::splat(v); K])
    }
    #[inline(always)]
    fn from_fn(mut value: impl FnMut(usize) -> f64) -> Self {
        let mut out = [L::splat(0.0); K];
        for (k, lanes) in out.iter_mut().enumerate() {
            *lanes = L::from_fn(|l| value(k * L::N + l));
        }
        Wide(out)
    }
    #[inline(always)]
    fn for_each(self, mut sink: impl FnMut(usize, f64)) {
        for k in 0..K {
            self.0[k].for_each(|l, v| sink(k * L::N + l, v));
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Wide(each!(self.0, o.0, add))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Wide(each!(self.0, o.0, sub))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Wide(each!(self.0, o.0, mul))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Wide(each!(self.0, o.0, div))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Wide(each!(self.0, sqrt))
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Wide(each!(self.0, neg))
    }
    #[inline(always)]
    fn is_zero(self) -> Self::Mask {
        let zero = L::splat(0.0).is_zero();
        let mut out = [zero; K];
        for k in 0..K {
            out[k] = self.0[k].is_zero();
        }
        out
    }
    #[inline(always)]
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self {
        let mut out = a.0;
        for k in 0..K {
            out[k] = L::select(mask[k], a.0[k], b.0[k]);
        }
        Wide(out)
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::{has_avx, Avx4};

#[cfg(not(target_arch = "x86_64"))]
/// False: no AVX off x86-64 (the kernels take their scalar lanes).
#[inline(always)]
pub fn has_avx() -> bool {
    false
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lanes;
    use std::arch::x86_64::*;

    /// True when the CPU has AVX, so [`Avx4`] may be used (checked at run time, cached).
    #[inline(always)]
    pub fn has_avx() -> bool {
        std::arch::is_x86_feature_detected!("avx")
    }

    /// Four `f64` lanes in an AVX register.
    ///
    /// Its operations are only sound on a CPU with AVX: kernels instantiate it inside a
    /// `#[target_feature(enable = "avx")]` function that is called only after [`has_avx`].
    #[derive(Clone, Copy)]
    pub struct Avx4(__m256d);

    // SAFETY (every `unsafe` block below): the intrinsics need AVX, which the kernels using
    // `Avx4` check with `has_avx` before entering their `target_feature(enable = "avx")` code.
    impl Lanes for Avx4 {
        const N: usize = 4;
        type Mask = __m256d;
        #[inline(always)]
        fn splat(v: f64) -> Self {
            Avx4(unsafe { _mm256_set1_pd(v) })
        }
        #[inline(always)]
        fn from_fn(mut value: impl FnMut(usize) -> f64) -> Self {
            let (a, b, c, d) = (value(0), value(1), value(2), value(3));
            Avx4(unsafe { _mm256_set_pd(d, c, b, a) })
        }
        #[inline(always)]
        fn for_each(self, mut sink: impl FnMut(usize, f64)) {
            let mut out = [0.0; 4];
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) };
            for (l, v) in out.into_iter().enumerate() {
                sink(l, v);
            }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Avx4(unsafe { _mm256_add_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Avx4(unsafe { _mm256_sub_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Avx4(unsafe { _mm256_mul_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Avx4(unsafe { _mm256_div_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Avx4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            Avx4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
        #[inline(always)]
        fn is_zero(self) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, _mm256_setzero_pd()) }
        }
        #[inline(always)]
        fn select(mask: __m256d, a: Self, b: Self) -> Self {
            Avx4(unsafe { _mm256_blendv_pd(b.0, a.0, mask) })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation of [`Avx4`] gives the scalar lanes' bits, on values that include zeros,
    /// signed zeros, infinities, NaN and subnormals.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_lanes_round_as_scalar() {
        if !has_avx() {
            return;
        }
        let vals = [
            0.0,
            -0.0,
            1.0,
            -3.5,
            1e-310,
            7.25e300,
            f64::INFINITY,
            f64::NAN,
            0.1,
            2.0f64.sqrt(),
            -1e-12,
            123.456,
        ];
        for a in vals.chunks_exact(4) {
            for b in vals.chunks_exact(4) {
                let (va, vb) = (Avx4::from_fn(|l| a[l]), Avx4::from_fn(|l| b[l]));
                let check = |v: Avx4, f: &dyn Fn(f64, f64) -> f64| {
                    v.for_each(|l, x| {
                        let want = f(a[l], b[l]);
                        assert!(
                            x.to_bits() == want.to_bits() || (x.is_nan() && want.is_nan()),
                            "lane {l}: {x} vs {want}"
                        );
                    })
                };
                check(va.add(vb), &|x, y| x.add(y));
                check(va.sub(vb), &|x, y| x.sub(y));
                check(va.mul(vb), &|x, y| x.mul(y));
                check(va.div(vb), &|x, y| x.div(y));
                check(va.sqrt(), &|x, _| Lanes::sqrt(x));
                check(va.neg(), &|x, _| x.neg());
                check(Avx4::select(va.is_zero(), va, vb), &|x, y| {
                    f64::select(x.is_zero(), x, y)
                });
            }
        }
    }
}
