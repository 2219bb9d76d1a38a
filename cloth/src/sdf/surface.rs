//! The smallest signed distance over the cloth's surface, not only its particles: what tells a
//! thin obstacle passing *between* the particles (through a triangle, at a step or between two)
//! from one passing beside the cloth.
//!
//! A triangle `(p₀, p₁, p₂)` moving straight from state `a` to state `b` sweeps the patch
//! `x(t, u, w) = (1 − t)·y_a(u, w) + t·y_b(u, w)` with `y(u, w) = p₀ + u(p₁ − p₀) + uw(p₂ − p₁)`
//! over the unit cube (the collapsed square: `u = 0` is the corner `p₀`). It is trilinear, so the
//! image of a box of parameters lies in the convex hull of its eight corners' images, within
//! `r = max |x(corner) − x(centre)|` of the centre's image; a 1-Lipschitz field (a signed
//! distance) is therefore at least `f(x(centre)) − r` on it. Branch and bound over the boxes of
//! every triangle and step, best first by that bound, splitting a box across the parameter whose
//! edges are longest in space, certifies the minimum to a tolerance. A triangle at rest (the
//! step-only check) is the same patch with `t` fixed.

use super::{SignedDistance, Union};
use autodiff::Tensor;
use nalgebra::Vector3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Most boxes evaluated by one [`surface_minimum`]; beyond it the bound returned is the smallest
/// open box's (honest, possibly looser than the tolerance).
pub const MAX_SURFACE_BOXES: usize = 1 << 20;

/// The smallest signed distance over the cloth's surface during a rollout ([`surface_minimum`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMinimum {
    /// A certified lower bound of the minimum (to rounding), at most the cap.
    pub lower: f64,
    /// The smallest distance found at a point of the surface (an upper bound of the minimum;
    /// `+∞` when no point came below the cap).
    pub value: f64,
    /// The step `1..=T` whose state (or motion from the step before) holds that point, or the
    /// lowest bound when none was found.
    pub step: usize,
    /// The triangle (index into the cloth's triangles).
    pub triangle: usize,
}

/// A box of parameters `[t₀, t₁] × [u₀, u₁] × [w₀, w₁]` of one triangle's patch between two
/// steps, with the lower bound of the field on it.
#[derive(Clone, Copy, Debug)]
struct Cell {
    lower: f64,
    step: usize,
    triangle: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    /// The parameter whose edges of the box are longest in space (the first on a tie): where
    /// the box is split.
    axis: usize,
}

impl PartialEq for Cell {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Cell {}
impl PartialOrd for Cell {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Cell {
    /// Reversed, so that the max-heap pops the smallest bound first (earliest step, triangle
    /// and parameters on a tie: deterministic).
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .lower
            .total_cmp(&self.lower)
            .then(other.step.cmp(&self.step))
            .then(other.triangle.cmp(&self.triangle))
            .then(other.lo.partial_cmp(&self.lo).unwrap_or(Ordering::Equal))
    }
}

/// One triangle's corners at the start and end of a motion.
struct Patch {
    a: [Vector3<f64>; 3],
    b: [Vector3<f64>; 3],
}

impl Patch {
    fn at(&self, [t, u, w]: [f64; 3]) -> Vector3<f64> {
        let y = |p: &[Vector3<f64>; 3]| p[0] + (p[1] - p[0]) * u + (p[2] - p[1]) * (u * w);
        y(&self.a) * (1.0 - t) + y(&self.b) * t
    }
}

/// The smallest signed distance to `field` over the surface `triangles` of the rollout `states`
/// (`states[0]` the rest state): for every step `k = 1..=T` the triangles moving straight from
/// state `k − 1` to `k` when `swept`, at state `k` alone otherwise (and from state 1 alone when
/// `rest_alone`, for a rest state the field already cuts). Exact to `tol` wherever the minimum
/// is below `cap`; otherwise `lower ≥ cap − tol`. `None` without triangles, steps or obstacles.
pub fn surface_minimum(
    field: &Union,
    triangles: &[[usize; 3]],
    states: &[Tensor],
    (swept, rest_alone): (bool, bool),
    cap: f64,
    tol: f64,
) -> Option<SurfaceMinimum> {
    if triangles.is_empty() || states.len() < 2 || field.is_empty() {
        return None;
    }
    // The motion of step `k`: from state `k − 1`, or at state `k` alone.
    let patch = |step: usize, triangle: usize| {
        let still = !swept || (step == 1 && rest_alone);
        let start = &states[if still { step } else { step - 1 }];
        let corner = |x: &Tensor, p: usize| Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2));
        let [i, j, k] = triangles[triangle];
        Patch {
            a: [corner(start, i), corner(start, j), corner(start, k)],
            b: [i, j, k].map(|p| corner(&states[step], p)),
        }
    };
    let mut search = Search {
        field,
        cap,
        best: f64::INFINITY,
        best_at: (1, 0),
        evaluations: 0,
        heap: BinaryHeap::new(),
    };
    for step in 1..states.len() {
        for triangle in 0..triangles.len() {
            search.push(
                &patch(step, triangle),
                Cell {
                    lower: f64::NEG_INFINITY,
                    step,
                    triangle,
                    lo: [0.0; 3],
                    hi: [1.0; 3],
                    axis: 0,
                },
            );
        }
    }
    let mut lowest: Option<Cell> = None;
    // The smallest bound of the boxes too small to split in `f64`, which leave the heap.
    let mut unsplit = f64::INFINITY;
    while let Some(cell) = search.heap.pop() {
        if cell.lower >= search.best.min(cap) - tol || search.evaluations >= MAX_SURFACE_BOXES {
            lowest = Some(cell);
            break;
        }
        let axis = cell.axis;
        let mid = 0.5 * (cell.lo[axis] + cell.hi[axis]);
        if mid <= cell.lo[axis] || mid >= cell.hi[axis] {
            unsplit = unsplit.min(cell.lower);
            continue;
        }
        let p = patch(cell.step, cell.triangle);
        let (mut left, mut right) = (cell, cell);
        left.hi[axis] = mid;
        right.lo[axis] = mid;
        search.push(&p, left);
        search.push(&p, right);
    }
    // Every box left open is bounded below by the last one popped; every pruned one by the best
    // value or the cap.
    let lower = lowest
        .map_or(f64::INFINITY, |c| c.lower)
        .min(unsplit)
        .min(search.best)
        .min(cap);
    let (step, triangle) = match lowest {
        Some(c) if search.best == f64::INFINITY => (c.step, c.triangle),
        _ => search.best_at,
    };
    Some(SurfaceMinimum {
        lower,
        value: search.best,
        step,
        triangle,
    })
}

/// The branch and bound's state: the best value found and the open boxes.
struct Search<'f> {
    field: &'f Union,
    cap: f64,
    best: f64,
    best_at: (usize, usize),
    evaluations: usize,
    heap: BinaryHeap<Cell>,
}

impl Search<'_> {
    /// Bounds the field on `cell` of `patch` from its centre and opens it unless the bound
    /// cannot beat the best value (or the cap); its corners' images also give its split axis.
    fn push(&mut self, patch: &Patch, mut cell: Cell) {
        let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (cell.lo[k] + cell.hi[k]));
        let x = patch.at(centre);
        // Corner `c` has parameter `k` at its upper end where bit `k` of `c` is set.
        let corners: [Vector3<f64>; 8] = std::array::from_fn(|c| {
            patch.at(std::array::from_fn(|k| {
                if c >> k & 1 == 0 {
                    cell.lo[k]
                } else {
                    cell.hi[k]
                }
            }))
        });
        let radius = corners.iter().map(|q| (q - x).norm()).fold(0.0, f64::max);
        let edge = |axis: usize| {
            (0..8)
                .filter(|c| c >> axis & 1 == 0)
                .map(|c| (corners[c | 1 << axis] - corners[c]).norm())
                .fold(0.0, f64::max)
        };
        cell.axis = (1..3).fold(0, |widest, axis| {
            if edge(axis) > edge(widest) {
                axis
            } else {
                widest
            }
        });
        let ceiling = self.best.min(self.cap);
        let d = self.field.distance_within(&x, ceiling + radius);
        self.evaluations += 1;
        if d <= ceiling + radius && d < self.best {
            self.best = d;
            self.best_at = (cell.step, cell.triangle);
        }
        // Rounding in the corners' images and the distance.
        let slack = 1e-12 * (1.0 + d.abs() + radius);
        cell.lower = d - radius - slack;
        if cell.lower < self.best.min(self.cap) {
            self.heap.push(cell);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sdf::Capsule;

    fn state(points: &[[f64; 3]]) -> Tensor {
        Tensor::from_rows(points)
    }

    /// A vertical pole of radius 0.01 at the origin; a triangle far larger than it, whose corners
    /// all stay 0.3 away, moves straight across it.
    #[test]
    fn a_pole_between_the_corners_is_found_inside_the_moving_triangle() {
        let field = Union {
            capsules: vec![Capsule {
                a: [0.0, 0.0, -1.0],
                b: [0.0, 0.0, 1.0],
                radius: 0.01,
            }],
            ..Union::default()
        };
        let tri = [[0usize, 1, 2]];
        let before = state(&[[-0.5, -1.0, -0.3], [0.5, -1.0, -0.3], [0.0, -1.0, 0.5]]);
        let after = state(&[[-0.5, 1.0, -0.3], [0.5, 1.0, -0.3], [0.0, 1.0, 0.5]]);
        let states = [before.clone(), after.clone()];
        let swept = surface_minimum(&field, &tri, &states, (true, false), 0.1, 1e-4).unwrap();
        // Halfway, the triangle's plane y = 0 holds a stretch of the pole's axis (every point
        // of it a minimizer): the surface reaches the axis, 0.01 inside.
        assert!(swept.value >= -0.01 - 1e-12, "{swept:?}");
        assert!(swept.lower <= swept.value && swept.value - swept.lower <= 1e-4);
        assert!(swept.value < -0.01 + 1e-4, "{swept:?}");
        // At the steps alone, the triangle is 1 away.
        let still = surface_minimum(&field, &tri, &states, (false, false), 0.1, 1e-6).unwrap();
        assert!(
            still.lower >= 0.1 - 1e-6 && still.value == f64::INFINITY,
            "{still:?}"
        );
    }
}
