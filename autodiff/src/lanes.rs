//! The lane-wise in-place kernel for rows of points: [`LANES`] rows of a colour set at once,
//! each point gathered straight from the state into lanes (one masked load per point and 4 × 4
//! register transposes, no staging of the rows), evaluated by [`RowFn::eval_lanes`] and
//! transposed back into the state.
//!
//! It runs where the CPU has AVX2 (detected at run time) for row functions with
//! [`RowFn::HAS_LANES`]; elsewhere the row-by-row kernels of [`crate::update`] run. A range's
//! last group of fewer than eight rows repeats its last row in the spare lanes: they load that
//! row's values, so they compute its results and store them once more. Both paths give the same
//! values bit for bit (no fused multiply–add on either, each lane's operations in the row's
//! order), so results do not depend on the CPU's features, the thread count or where a group of
//! rows starts.

use crate::rowfn::RowFn;
#[cfg(target_arch = "x86_64")]
use crate::rowfn::SEED_CHUNK;
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
        return range.end;
    }
    let _ = (f, idx, buf);
    range.start
}

/// [`vjp_groups_seeds`] on the rows of `range` where the target has it; returns the first row
/// left to the row-by-row kernel.
///
/// # Safety
/// As [`vjp_groups_seeds`].
#[inline(always)]
pub(crate) unsafe fn lane_groups_vjp_seeds<F: RowFn, const A: usize>(
    f: &F,
    idx: &[usize],
    range: std::ops::Range<usize>,
    inputs: &[f64],
    states: &[SharedRows],
    carries: &[SharedRows],
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if F::HAS_LANES {
        let fresh = || Box::new([[F64x8::default(); 13 * SEED_CHUNK]; 2]);
        crate::rowfn::with_scratch(&SEED_LANES, fresh, |scratch| {
            vjp_groups_seeds::<F, A>(f, idx, range.clone(), inputs, states, carries, scratch)
        });
        return range.end;
    }
    let _ = (f, idx, inputs, states, carries);
    range.start
}

/// The rows of the group from row `k` of a range ending at `end`: `k + l` in lane `l`, the
/// range's last row in the lanes past it.
#[inline(always)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
fn group_rows(k: usize, end: usize) -> [usize; LANES] {
    std::array::from_fn(|l| (k + l).min(end - 1))
}

/// The lanes of `v` whose rows are whole, at `ptr` (`ptr` holding a value per row from row `k`).
///
/// # Safety
/// `ptr` is writable for `min(LANES, end − k)` values, touched by no other task.
#[inline(always)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
unsafe fn store_rows(ptr: *mut f64, k: usize, end: usize, v: [f64; LANES]) {
    if k + LANES <= end {
        std::ptr::write_unaligned(ptr.add(k).cast(), v);
    } else {
        for (l, &value) in v.iter().enumerate().take(end - k) {
            *ptr.add(k + l) = value;
        }
    }
}

/// One value per row of `rows` from `ptr` (a value per row).
///
/// # Safety
/// `ptr` is readable at each of `rows`.
#[inline(always)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
unsafe fn load_rows(ptr: *const f64, rows: [usize; LANES]) -> [f64; LANES] {
    if rows[LANES - 1] == rows[0] + LANES - 1 {
        std::ptr::read_unaligned(ptr.add(rows[0]).cast())
    } else {
        std::array::from_fn(|l| *ptr.add(rows[l]))
    }
}

/// Updates the rows `range` of an in-place update of `A` points and
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
    let width = 3 * A + 1;
    debug_assert!(idx.len() >= A * range.end);
    let (state, carry, saved) = (buf.state.ptr, buf.carry.ptr, buf.saved.ptr);
    let (mut x, mut y) = ([F64x8::default(); 13], [F64x8::default(); 13]);
    let mut k = range.start;
    while k < range.end {
        let (rows, whole) = (group_rows(k, range.end), LANES.min(range.end - k));
        let points = |j: usize| point_offsets::<A>(idx, rows, j);
        for j in 0..A {
            let loaded = load_points(state, points(j), &mut x[3 * j..3 * j + 3]);
            if !saved.is_null() {
                // Four values at the point's place in the row: the fourth is overwritten by
                // the next point or the carried value, written after it.
                for (l, &row) in loaded.iter().enumerate().take(whole) {
                    let at = saved.add(width * (k + l) + 3 * j);
                    std::arch::x86_64::_mm256_storeu_pd(at, row);
                }
            }
        }
        x[3 * A] = F64x8(load_rows(carry, rows));
        if !saved.is_null() {
            for l in 0..whole {
                *saved.add(width * (k + l) + 3 * A) = x[3 * A].0[l];
            }
        }
        f.eval_lanes(rows, &x[..width], &mut y[..width]);
        for j in 0..A {
            store_points(state, points(j), &y[3 * j..3 * j + 3]);
        }
        store_rows(carry, k, range.end, y[3 * A].0);
        k += LANES;
    }
}

/// The adjoint of [`update_groups`] in place for up to [`SEED_CHUNK`] seeds at once, through
/// [`RowFn::vjp_lanes_seeds`]: on the rows `range`, seed `s`'s adjoints `states[s]` and
/// `carries[s]` of the updated rows become those of the rows before the update; `inputs` are the
/// saved inputs (row layout), each group's loaded once for all the seeds. `scratch` holds the
/// seeds' output and input adjoints of a group (every value written before it is read).
///
/// # Safety
/// As [`update_groups`], with every seed's buffers for the state and carry, and `inputs` holding
/// `3A + 1` values per row up to `range.end`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn vjp_groups_seeds<F: RowFn, const A: usize>(
    f: &F,
    idx: &[usize],
    range: std::ops::Range<usize>,
    inputs: &[f64],
    states: &[SharedRows],
    carries: &[SharedRows],
    scratch: &mut [[F64x8; 13 * SEED_CHUNK]; 2],
) {
    let [oa, ia] = scratch;
    let width = 3 * A + 1;
    let seeds = states.len();
    debug_assert!(seeds <= SEED_CHUNK && carries.len() == seeds);
    debug_assert!(idx.len() >= A * range.end && inputs.len() >= width * range.end);
    let saved = inputs.as_ptr();
    let mut x = [F64x8::default(); 13];
    let mut k = range.start;
    while k < range.end {
        let rows = group_rows(k, range.end);
        let points = |j: usize| point_offsets::<A>(idx, rows, j);
        for j in 0..A {
            load_points(
                saved,
                std::array::from_fn(|l| width * rows[l] + 3 * j),
                &mut x[3 * j..3 * j + 3],
            );
        }
        x[3 * A] = F64x8::from_fn(|l| *saved.add(width * rows[l] + 3 * A));
        for (s, (state, carry)) in states.iter().zip(carries).enumerate() {
            let oa = &mut oa[width * s..width * s + width];
            for j in 0..A {
                load_points(state.ptr, points(j), &mut oa[3 * j..3 * j + 3]);
            }
            oa[3 * A] = F64x8(load_rows(carry.ptr, rows));
        }
        let n = width * seeds;
        f.vjp_lanes_seeds(rows, &x[..width], &oa[..n], &mut ia[..n]);
        for (s, (state, carry)) in states.iter().zip(carries).enumerate() {
            let ia = &ia[width * s..width * s + width];
            for j in 0..A {
                store_points(state.ptr, points(j), &ia[3 * j..3 * j + 3]);
            }
            store_rows(carry.ptr, k, range.end, ia[3 * A].0);
        }
        k += LANES;
    }
}

#[cfg(target_arch = "x86_64")]
thread_local! {
    /// Each thread's scratch for [`vjp_groups_seeds`] (13 kB, on the heap), kept so that a
    /// colour set's call does not zero it first: that `memset` was 8% of planning u_obstacle.
    static SEED_LANES: std::cell::RefCell<Box<[[F64x8; 13 * SEED_CHUNK]; 2]>> =
        std::cell::RefCell::new(Box::new([[F64x8::default(); 13 * SEED_CHUNK]; 2]));
}

/// Where point `j` of each of the rows `rows` starts in the state.
///
/// # Safety
/// `idx` holds `A` points for each of these rows.
#[inline(always)]
unsafe fn point_offsets<const A: usize>(
    idx: &[usize],
    rows: [usize; LANES],
    j: usize,
) -> [usize; LANES] {
    // `from_fn`, not `map`: `map` was not inlined here (a call per group, without AVX2).
    std::array::from_fn(|l| 3 * *idx.get_unchecked(A * rows[l] + j))
}

/// Loads the three values at `base + off[l]` of every lane `l` into `dst` (x, y and z lanes),
/// by two 4 × 4 transposes; returns the loaded registers (each `[x y z 0]`).
///
/// # Safety
/// Three values readable at each offset; AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load_points(
    base: *const f64,
    off: [usize; LANES],
    dst: &mut [F64x8],
) -> [std::arch::x86_64::__m256d; LANES] {
    use std::arch::x86_64::*;
    // Lanes 0–2 of a point: its coordinates (the fourth value is another point's or past the end).
    let xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
    let r = off.map(|o| _mm256_maskload_pd(base.add(o), xyz));
    for h in 0..2 {
        let r = &r[4 * h..4 * h + 4];
        // [x0 x1 z0 z1], [y0 y1 · ·], [x2 x3 z2 z3], [y2 y3 · ·].
        let (a, b) = (
            _mm256_unpacklo_pd(r[0], r[1]),
            _mm256_unpackhi_pd(r[0], r[1]),
        );
        let (c, d) = (
            _mm256_unpacklo_pd(r[2], r[3]),
            _mm256_unpackhi_pd(r[2], r[3]),
        );
        set_half(&mut dst[0], h, _mm256_permute2f128_pd::<0x20>(a, c));
        set_half(&mut dst[1], h, _mm256_permute2f128_pd::<0x20>(b, d));
        set_half(&mut dst[2], h, _mm256_permute2f128_pd::<0x31>(a, c));
    }
    r
}

/// Stores `src`'s x, y and z lanes as three values at `base + off[l]` for every lane `l`.
///
/// # Safety
/// Three values writable at each offset, touched by no other task; AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_points(base: *mut f64, off: [usize; LANES], src: &[F64x8]) {
    use std::arch::x86_64::*;
    for h in 0..2 {
        let [px, py, pz] = [0, 1, 2].map(|c| half(&src[c], h));
        // [x0 y0 x2 y2], [x1 y1 x3 y3], [z0 z0 z2 z2], [z1 z1 z3 z3].
        let (a, b) = (_mm256_unpacklo_pd(px, py), _mm256_unpackhi_pd(px, py));
        let (c, d) = (_mm256_unpacklo_pd(pz, pz), _mm256_unpackhi_pd(pz, pz));
        for (l, (xy, zz)) in [(a, c), (b, d)].into_iter().enumerate() {
            let (lo, hi) = (base.add(off[4 * h + l]), base.add(off[4 * h + l + 2]));
            _mm_storeu_pd(lo, _mm256_castpd256_pd128(xy));
            _mm_store_sd(lo.add(2), _mm256_castpd256_pd128(zz));
            _mm_storeu_pd(hi, _mm256_extractf128_pd::<1>(xy));
            _mm_store_sd(hi.add(2), _mm256_extractf128_pd::<1>(zz));
        }
    }
}

/// Lanes `4h .. 4h + 4` of `v` as a register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn half(v: &F64x8, h: usize) -> std::arch::x86_64::__m256d {
    // SAFETY: four values of the eight, unaligned load.
    unsafe { std::arch::x86_64::_mm256_loadu_pd(v.0[4 * h..4 * h + 4].as_ptr()) }
}

/// Sets lanes `4h .. 4h + 4` of `v` to a register's values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
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
