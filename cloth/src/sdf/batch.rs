//! Queries over every particle of a state that need an exact value only where it matters: the
//! safety term needs each distance exactly only below the margin `δ`, and the metrics need the
//! smallest one exactly. Branch and bound over the particles with the bounded queries
//! ([`SignedDistance::distance_within`], [`SignedDistance::min_along_segment_within`]): a cheap
//! lower bound for every particle first, then exact values in increasing order of the bounds
//! until no bound can beat the smallest value found.

use super::{SignedDistance, Union};
use autodiff::Tensor;
use nalgebra::Vector3;

/// Particle `p` of a state (`N × 3`).
fn point(x: &Tensor, p: usize) -> Vector3<f64> {
    Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2))
}

/// Each particle's signed distance to `field`, exact (bitwise [`SignedDistance::distance`])
/// wherever it is at most `delta` and at the smallest one; elsewhere a lower bound above
/// `delta`. So `relu(δ − d)` of every particle and the minimum are exact.
pub fn distances_within(field: &Union, x: &Tensor, delta: f64) -> Vec<f64> {
    refined(x.rows(), delta, |p, bound| {
        field.distance_within(&point(x, p), bound)
    })
}

/// The smallest signed distance to `field` along every particle's straight path from `a` to
/// `b`: bitwise the minimum of [`SignedDistance::min_along_segment`] over the particles.
pub fn min_along_segments(field: &Union, a: &Tensor, b: &Tensor) -> f64 {
    smallest(a.rows(), |p, bound| {
        field.min_along_segment_within(&point(a, p), &point(b, p), bound)
    })
}

/// [`min_along_segments`] and the particle whose path attains it (the first on a tie); `None`
/// for a state without particles.
pub fn deepest_along_segments(field: &Union, a: &Tensor, b: &Tensor) -> Option<(f64, usize)> {
    deepest(a.rows(), |p, bound| {
        field.min_along_segment_within(&point(a, p), &point(b, p), bound)
    })
}

/// Every particle's smallest signed distance to `field` along its straight path from `a` to `b`,
/// exact (bitwise [`SignedDistance::min_along_segment`]) wherever it is within `band` of the
/// smallest one (which is exact) or below 0 (a path into the field); elsewhere a lower bound
/// above both.
pub fn segment_distances_near_min(field: &Union, a: &Tensor, b: &Tensor, band: f64) -> Vec<f64> {
    let query =
        |p: usize, bound: f64| field.min_along_segment_within(&point(a, p), &point(b, p), bound);
    let mut values = refined(a.rows(), f64::NEG_INFINITY, query);
    let near = (values.iter().copied().fold(f64::INFINITY, f64::min) + band).max(0.0);
    for (p, v) in values.iter_mut().enumerate() {
        if *v <= near {
            *v = query(p, near);
        }
    }
    values
}

/// The smallest signed distance of any particle of `x` to `field`: bitwise the minimum of
/// [`SignedDistance::distance`] over the particles.
pub fn min_distance(field: &Union, x: &Tensor) -> f64 {
    smallest(x.rows(), |p, bound| {
        field.distance_within(&point(x, p), bound)
    })
}

/// [`min_distance`] and the particle attaining it (the first on a tie); `None` for a state
/// without particles.
pub fn deepest_particle(field: &Union, x: &Tensor) -> Option<(f64, usize)> {
    deepest(x.rows(), |p, bound| {
        field.distance_within(&point(x, p), bound)
    })
}

/// The smallest of `n` values, exactly, from a bounded query (`query(p, bound)`: value `p`
/// exactly wherever it is at most `bound`, a lower bound above it elsewhere): every value's
/// cheapest lower bound first (bound −∞), then [`refine_smallest`].
fn smallest(n: usize, query: impl Fn(usize, f64) -> f64) -> f64 {
    let values = refined(n, f64::NEG_INFINITY, query);
    values.iter().copied().fold(f64::INFINITY, f64::min)
}

/// [`smallest`] and the first index attaining it; `None` when `n = 0`.
fn deepest(n: usize, query: impl Fn(usize, f64) -> f64) -> Option<(f64, usize)> {
    let values = refined(n, f64::NEG_INFINITY, query);
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    values.iter().position(|&v| v == min).map(|p| (min, p))
}

/// `n` values from a bounded query at `bound` (exact where at most `bound`), the smallest then
/// made exact ([`refine_smallest`]).
fn refined(n: usize, bound: f64, query: impl Fn(usize, f64) -> f64) -> Vec<f64> {
    let mut values: Vec<f64> = (0..n).map(|p| query(p, bound)).collect();
    refine_smallest(&mut values, bound, query);
    values
}

/// Makes the smallest of `values` exact, given that each is exact where at most `exact_up_to`
/// and a lower bound elsewhere, and that `query(p, bound)` returns particle `p`'s value exactly
/// where it is at most `bound` (a lower bound above `bound` elsewhere). Particles are refined in
/// increasing order of their bounds (index order on a tie) until a bound reaches the smallest
/// value so far: no later particle can be smaller.
fn refine_smallest(values: &mut [f64], exact_up_to: f64, query: impl Fn(usize, f64) -> f64) {
    let mut best = values
        .iter()
        .copied()
        .filter(|&v| v <= exact_up_to)
        .fold(f64::INFINITY, f64::min);
    let mut order: Vec<usize> = (0..values.len())
        .filter(|&p| values[p] > exact_up_to || values[p].is_nan())
        .collect();
    order.sort_by(|&p, &q| values[p].total_cmp(&values[q]).then(p.cmp(&q)));
    for p in order {
        if values[p] >= best {
            break;
        }
        values[p] = query(p, best);
        best = best.min(values[p]);
    }
}
