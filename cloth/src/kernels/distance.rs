//! The forward XPBD projection of [`Distance`] rows, four rows per AVX register.
//!
//! Per row, with `d = p₀ − p₁`: `n = |d|`, `g = d/n` (0 when `d = 0`), `C = n − d⁰`,
//! `D = (|g|²w₀ + |g|²w₁) + α̃`, `Δλ = (−C − λα̃)/D`, `p₀ += g w₀ Δλ`, `p₁ −= g w₁ Δλ`, `λ += Δλ`;
//! a row with `D = 0` does not move. The operations and their order are those of the generic
//! per-row kernel ([`crate::projection::Projection`] on [`Distance::gradient`]), and [`Lanes`]
//! rounds every lane as scalar code does, so the result is the same bit for bit
//! (`cloth/tests/kernels.rs`).

use super::lanes::{has_avx, Lanes};
use super::ProjectionBlock;
use crate::constraint::Distance;

/// Values per row: two points and the multiplier.
const WIDTH: usize = 7;

/// Projects every row of `block` (rows of [`WIDTH`] values).
#[inline(always)]
pub(crate) fn project(constraint: &Distance, block: &mut ProjectionBlock<'_>) {
    let rows = block.inputs.len() / WIDTH;
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if rows >= 4 && has_avx() {
        // SAFETY: the CPU has AVX (just checked).
        done = unsafe { project_avx(constraint, block, rows) };
    }
    for row in done..rows {
        project_lanes::<f64>(constraint, block, row);
    }
}

/// The rows of `block` in groups of sixteen (four AVX registers, whose dependency chains
/// overlap), then of four; returns how many rows it projected.
///
/// # Safety
/// The CPU must have AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn project_avx(
    constraint: &Distance,
    block: &mut ProjectionBlock<'_>,
    rows: usize,
) -> usize {
    use super::lanes::{Avx4, Wide};
    let mut first = 0;
    while rows - first >= Wide::<Avx4, 4>::N {
        project_lanes::<Wide<Avx4, 4>>(constraint, block, first);
        first += Wide::<Avx4, 4>::N;
    }
    while rows - first >= Avx4::N {
        project_lanes::<Avx4>(constraint, block, first);
        first += Avx4::N;
    }
    first
}

/// Projects rows `first .. first + L::N` of `block`, one per lane.
#[inline(always)]
fn project_lanes<L: Lanes>(constraint: &Distance, block: &mut ProjectionBlock<'_>, first: usize) {
    let x = block.inputs;
    // A macro, not a closure (see `g` below).
    macro_rules! at {
        ($j:expr) => {
            L::from_fn(|l| x[WIDTH * (first + l) + $j])
        };
    }
    let (w0, w1) = (
        L::from_fn(|l| block.inv_mass[2 * (first + l)]),
        L::from_fn(|l| block.inv_mass[2 * (first + l) + 1]),
    );
    let rest = L::from_fn(|l| constraint.rest[block.instances[first + l]]);
    let alpha = L::splat(block.compliance);
    let p0 = [at!(0), at!(1), at!(2)];
    let p1 = [at!(3), at!(4), at!(5)];
    let lambda = at!(6);
    let d = [p0[0].sub(p1[0]), p0[1].sub(p1[1]), p0[2].sub(p1[2])];
    let s = d[0].mul(d[0]).add(d[1].mul(d[1])).add(d[2].mul(d[2]));
    let n = s.sqrt();
    let inv = L::splat(1.0).div(n);
    let coincident = s.is_zero();
    let zero = L::splat(0.0);
    // Loops, not closures, wherever lanes are computed: a closure would not be compiled with
    // AVX enabled, so the intrinsics would not inline into it.
    let mut g = d;
    for k in 0..3 {
        g[k] = L::select(coincident, zero, d[k].mul(inv));
    }
    let c = n.sub(rest);
    let q = g[0].mul(g[0]).add(g[1].mul(g[1])).add(g[2].mul(g[2]));
    let denom = q.mul(w0).add(q.mul(w1)).add(alpha);
    let still = denom.is_zero();
    let dlambda = c.neg().sub(lambda.mul(alpha)).div(denom);
    let moved = [
        p0[0].add(g[0].mul(w0).mul(dlambda)),
        p0[1].add(g[1].mul(w0).mul(dlambda)),
        p0[2].add(g[2].mul(w0).mul(dlambda)),
        p1[0].add(g[0].neg().mul(w1).mul(dlambda)),
        p1[1].add(g[1].neg().mul(w1).mul(dlambda)),
        p1[2].add(g[2].neg().mul(w1).mul(dlambda)),
        lambda.add(dlambda),
    ];
    let y = &mut *block.outputs;
    for (j, m) in moved.into_iter().enumerate() {
        L::select(still, at!(j), m).for_each(|l, v| y[WIDTH * (first + l) + j] = v);
    }
}
