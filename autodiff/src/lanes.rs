//! The lane-wise in-place kernel for rows of points: [`LANES`] rows of a colour set at once,
//! each point gathered straight from the state into lanes (one masked load per point and 4 × 4
//! register transposes, no staging of the rows), evaluated by [`RowFn::eval_lanes`] and
//! transposed back into the state.
//!
//! It runs where the CPU has AVX2 (detected at run time) for row functions with
//! [`RowFn::HAS_LANES`]; elsewhere, and for the rows left over after the groups of eight, the
//! row-by-row kernels of [`crate::update`] run. Both give the same values bit for bit (no fused
//! multiply–add on either path, each lane's operations in the row's order), so results do not
//! depend on the CPU's features, the thread count or where a group of rows starts.

use crate::rowfn::RowFn;
#[cfg(target_arch = "x86_64")]
use crate::simd::F64x8;
use crate::simd::LANES;
use std::cell::Cell;

thread_local! {
    /// Set while [`without_lanes`] runs on this thread.
    static OFF: Cell<bool> = const { Cell::new(false) };
}

/// Runs `work` with the lane-wise kernel switched off for the updates this thread starts (their
/// rows then go one by one): how tests compare the two paths.
pub fn without_lanes<T>(work: impl FnOnce() -> T) -> T {
    /// Restores the previous setting, also when `work` panics.
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            OFF.with(|off| off.set(self.0));
        }
    }
    let _restore = Restore(OFF.with(|off| off.replace(true)));
    work()
}

/// Whether an in-place update by `F` takes the lane-wise kernel on this machine and thread.
#[inline(always)]
pub(crate) fn lanes_for<F: RowFn>() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        F::HAS_LANES && std::arch::is_x86_feature_detected!("avx2") && !OFF.with(Cell::get)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// An in-place update's buffers for [`update_groups`]: the state (3 values per point), the
/// carry (one value per row) and, when recording, the saved inputs (`3A + 1` values per row,
/// written, never read; [`SharedRows::EMPTY`] when not recording).
#[derive(Clone, Copy)]
pub(crate) struct PointBuffers {
    /// The state.
    pub state: SharedRows,
    /// The carry.
    pub carry: SharedRows,
    /// The saved inputs, or [`SharedRows::EMPTY`].
    pub saved: SharedRows,
}

/// [`update_groups`] on the rows of `range` where the target has it; returns the first row left
/// to the row-by-row kernel.
///
/// # Safety
/// As [`update_groups`].
#[inline(always)]
pub(crate) unsafe fn lane_groups<F: RowFn, const A: usize>(
    f: &F,
    idx: &[usize],
    range: std::ops::Range<usize>,
    buf: PointBuffers,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if F::HAS_LANES {
        update_groups::<F, A>(f, idx, range.clone(), buf);
        return groups_end(&range);
    }
    let _ = (f, idx, buf);
    range.start
}

/// First row of `range` that [`update_groups`] leaves to the row-by-row kernel.
#[inline(always)]
pub(crate) fn groups_end(range: &std::ops::Range<usize>) -> usize {
    range.end - (range.end - range.start) % LANES
}

/// Updates the rows `range.start .. groups_end(range)` of an in-place update of `A` points and
/// one carried value per row, [`LANES`] rows at a time through [`RowFn::eval_lanes`], and
/// saves each row's inputs in row layout when `buf.saved` is not empty.
///
/// # Safety
/// The CPU has AVX2; `idx` (`A` points per row) is disjoint and in range for the state and
/// covers `range`; the carry has a value for every row of `range`; `buf.saved`, if not empty,
/// has room for `3A + 1` values per row up to `range.end`; no other task touches these rows'
/// values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn update_groups<F: RowFn, const A: usize>(
    f: &F,
    idx: &[usize],
    range: std::ops::Range<usize>,
    buf: PointBuffers,
) {
    use std::arch::x86_64::*;
    let width = 3 * A + 1;
    debug_assert!(idx.len() >= A * range.end);
    // Lanes 0–2 of a point: its coordinates (the fourth value is another point's or past the end).
    let xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
    let (state, carry, saved) = (buf.state.ptr, buf.carry.ptr, buf.saved.ptr);
    let (mut x, mut y) = ([F64x8::default(); 13], [F64x8::default(); 13]);
    let mut k = range.start;
    while k < groups_end(&range) {
        // Two groups of four rows, each gathered by 4 × 4 transposes of its points.
        for (h, k) in [k, k + 4].into_iter().enumerate() {
            for j in 0..A {
                let p = |l: usize| 3 * *idx.get_unchecked(A * (k + l) + j);
                let r = [0, 1, 2, 3].map(|l| _mm256_maskload_pd(state.add(p(l)), xyz));
                if !saved.is_null() {
                    // Four values at the point's place in the row: the fourth is overwritten by
                    // the next point or the carried value, written after it.
                    for (l, &rl) in r.iter().enumerate() {
                        _mm256_storeu_pd(saved.add(width * (k + l) + 3 * j), rl);
                    }
                }
                // [x0 x1 z0 z1], [y0 y1 · ·], [x2 x3 z2 z3], [y2 y3 · ·].
                let (a, b) = (
                    _mm256_unpacklo_pd(r[0], r[1]),
                    _mm256_unpackhi_pd(r[0], r[1]),
                );
                let (c, d) = (
                    _mm256_unpacklo_pd(r[2], r[3]),
                    _mm256_unpackhi_pd(r[2], r[3]),
                );
                set_half(&mut x[3 * j], h, _mm256_permute2f128_pd::<0x20>(a, c));
                set_half(&mut x[3 * j + 1], h, _mm256_permute2f128_pd::<0x20>(b, d));
                set_half(&mut x[3 * j + 2], h, _mm256_permute2f128_pd::<0x31>(a, c));
            }
        }
        x[3 * A] = F64x8(std::ptr::read_unaligned(carry.add(k).cast()));
        if !saved.is_null() {
            for l in 0..LANES {
                *saved.add(width * (k + l) + 3 * A) = x[3 * A].0[l];
            }
        }
        f.eval_lanes(k, &x[..width], &mut y[..width]);
        for (h, k) in [k, k + 4].into_iter().enumerate() {
            for j in 0..A {
                let p = |l: usize| 3 * *idx.get_unchecked(A * (k + l) + j);
                let [px, py, pz] = [0, 1, 2].map(|c| half(&y[3 * j + c], h));
                // [x0 y0 x2 y2], [x1 y1 x3 y3], [z0 z0 z2 z2], [z1 z1 z3 z3].
                let (a, b) = (_mm256_unpacklo_pd(px, py), _mm256_unpackhi_pd(px, py));
                let (c, d) = (_mm256_unpacklo_pd(pz, pz), _mm256_unpackhi_pd(pz, pz));
                for (l, (xy, zz)) in [(a, c), (b, d)].into_iter().enumerate() {
                    let (lo, hi) = (p(l), p(l + 2));
                    _mm_storeu_pd(state.add(lo), _mm256_castpd256_pd128(xy));
                    _mm_store_sd(state.add(lo + 2), _mm256_castpd256_pd128(zz));
                    _mm_storeu_pd(state.add(hi), _mm256_extractf128_pd::<1>(xy));
                    _mm_store_sd(state.add(hi + 2), _mm256_extractf128_pd::<1>(zz));
                }
            }
        }
        std::ptr::write_unaligned(carry.add(k).cast(), y[3 * A].0);
        k += LANES;
    }
}

/// Lanes `4h .. 4h + 4` of `v` as a register.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn half(v: &F64x8, h: usize) -> std::arch::x86_64::__m256d {
    // SAFETY: four values of the eight, unaligned load.
    unsafe { std::arch::x86_64::_mm256_loadu_pd(v.0[4 * h..4 * h + 4].as_ptr()) }
}

/// Sets lanes `4h .. 4h + 4` of `v` to a register's values.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn set_half(v: &mut F64x8, h: usize, r: std::arch::x86_64::__m256d) {
    // SAFETY: four values of the eight, unaligned store.
    unsafe { std::arch::x86_64::_mm256_storeu_pd(v.0[4 * h..4 * h + 4].as_mut_ptr(), r) }
}

/// A buffer that several rayon tasks write at once, each to values no other task touches.
#[derive(Clone, Copy)]
pub(crate) struct SharedRows {
    pub(crate) ptr: *mut f64,
    pub(crate) len: usize,
}

// SAFETY: only used for writes to disjoint ranges (see `update_points`).
unsafe impl Send for SharedRows {}
unsafe impl Sync for SharedRows {}

impl SharedRows {
    /// No buffer (a placeholder in fixed arrays).
    pub(crate) const EMPTY: SharedRows = SharedRows {
        ptr: std::ptr::null_mut(),
        len: 0,
    };

    pub(crate) fn new(data: &mut [f64]) -> Self {
        SharedRows {
            ptr: data.as_mut_ptr(),
            len: data.len(),
        }
    }

    /// Copies `src` to the values from `start`, which may be uninitialized (no reference to them
    /// is made).
    ///
    /// # Safety
    /// As [`SharedRows::slice`].
    #[inline(always)]
    pub(crate) unsafe fn write(self, start: usize, src: &[f64]) {
        debug_assert!(start + src.len() <= self.len);
        std::ptr::copy_nonoverlapping(src.as_ptr(), self.ptr.add(start), src.len());
    }

    /// `n` values from `start`.
    ///
    /// # Safety
    /// They must lie inside the buffer (the kernels check their index's bound up front), and no
    /// other live reference may overlap them.
    #[inline(always)]
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn slice<'a>(self, start: usize, n: usize) -> &'a mut [f64] {
        debug_assert!(
            start + n <= self.len,
            "SharedRows: {start}+{n} > {}",
            self.len
        );
        std::slice::from_raw_parts_mut(self.ptr.add(start), n)
    }
}
