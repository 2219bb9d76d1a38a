//! Signed distances along straight segments: where along `a → b` a field is smallest.
//!
//! Every primitive but the mesh answers exactly ([`SegmentMin::exact`]): a sphere's nearest point
//! of the segment is a projection, a plane's minimum is at an end, capsules and boxes are solved
//! in closed form (`shapes.rs`). A mesh (and any field without a closed form) is searched by
//! [`lipschitz_segment_min`], a branch and bound whose answer is a lower bound never above the
//! true minimum and within [`SEGMENT_TOLERANCE`] of it.
//!
//! [`Union::segment_components`] evaluates each primitive at its own minimizing point, generic
//! over [`Real`]: the minimizer is found on the values and held fixed, so forward duals give the
//! minimum's exact gradient (at an interior minimizer the distance is stationary along the
//! segment; at an end the minimizer does not move), which is what the planner's continuous
//! safety rows and gripper rows differentiate. A box the segment enters counts minus its
//! crossing depth instead, which keeps a slope where the deepest point's depth is flat.

use super::{midpoint_lower_bound, sphere_segment_param, SignedDistance, Union};
use crate::geometry::norm;
use autodiff::{Dual, Real};
use nalgebra::Vector3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// How far (length units) [`lipschitz_segment_min`]'s lower bound may lie below the true
/// minimum: the search refines until the best point it found is within this of the bound.
pub const SEGMENT_TOLERANCE: f64 = 1e-7;

/// Most distance evaluations of one [`lipschitz_segment_min`]; a search that reaches it returns
/// its (looser, still valid) lower bound.
const MAX_EVALUATIONS: usize = 4096;

/// The smallest signed distance along a segment `a → b`, and where it is attained.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentMin {
    /// A lower bound of the smallest signed distance along the segment: the minimum itself (to
    /// rounding) for an exact answer.
    pub value: f64,
    /// The parameter `s ∈ [0, 1]` of the point `a + s(b − a)` where the minimum is attained (for
    /// a searched answer: the best point found).
    pub at: f64,
    /// The signed distance at that point: `value` for an exact answer, at most
    /// [`SEGMENT_TOLERANCE`] above it for a searched one.
    pub attained: f64,
}

impl SegmentMin {
    /// An exact answer: the minimum `value`, attained at `at`.
    pub fn exact(value: f64, at: f64) -> SegmentMin {
        SegmentMin {
            value,
            at,
            attained: value,
        }
    }

    /// How far the attained distance lies above the lower bound (0 for an exact answer).
    pub fn gap(&self) -> f64 {
        self.attained - self.value
    }
}

/// One interval `[s0, s1]` of a search, with the values at its ends and their lower bound.
#[derive(Clone, Copy, Debug)]
struct Interval {
    lower: f64,
    s0: f64,
    s1: f64,
    f0: f64,
    f1: f64,
}

impl PartialEq for Interval {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Interval {}

impl PartialOrd for Interval {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Interval {
    /// Reversed, so that the [`BinaryHeap`] pops the smallest lower bound first (the leftmost
    /// interval on a tie): the search is deterministic.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .lower
            .total_cmp(&self.lower)
            .then(other.s0.total_cmp(&self.s0))
    }
}

/// The smallest value along `a → b` of a function `f` that is 1-Lipschitz in space (a signed
/// distance), by branch and bound (Piyavskii–Shubert): along the segment `f` is `L`-Lipschitz
/// with `L = |b − a|`, so on an interval of width `w` with end values `f₀`, `f₁` it is at least
/// `(f₀ + f₁ − L·w)/2`. The interval of smallest bound is split at its midpoint until the best
/// value found is within `tol` of the smallest bound (or after 4096 evaluations).
///
/// Returns that smallest bound less a rounding slack of `1e-12·(1 + |f| + L)` (never above the
/// minimum), the best point's parameter and its value. Deterministic: ties go to the leftmost
/// interval.
pub fn lipschitz_segment_min(
    f: impl Fn(&Vector3<f64>) -> f64,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    tol: f64,
) -> SegmentMin {
    let ab = b - a;
    let lipschitz = ab.norm();
    let at = |s: f64| f(&(a + ab * s));
    let (f0, f1) = (at(0.0), at(1.0));
    let mut best = if f1 < f0 { (f1, 1.0) } else { (f0, 0.0) };
    if lipschitz == 0.0 {
        return SegmentMin::exact(best.0, best.1);
    }
    let bound = |s0: f64, s1: f64, f0: f64, f1: f64| Interval {
        lower: 0.5 * (f0 + f1 - lipschitz * (s1 - s0)),
        s0,
        s1,
        f0,
        f1,
    };
    let mut heap = BinaryHeap::new();
    heap.push(bound(0.0, 1.0, f0, f1));
    let mut evaluations = 2;
    let lower = loop {
        let Some(cell) = heap.pop() else {
            break best.0;
        };
        if best.0 - cell.lower <= tol || evaluations >= MAX_EVALUATIONS {
            break cell.lower.min(best.0);
        }
        let mid = 0.5 * (cell.s0 + cell.s1);
        if mid <= cell.s0 || mid >= cell.s1 {
            // The interval cannot be split in `f64`: its ends are all there is.
            continue;
        }
        let fm = at(mid);
        evaluations += 1;
        if fm < best.0 {
            best = (fm, mid);
        }
        heap.push(bound(cell.s0, mid, cell.f0, fm));
        heap.push(bound(mid, cell.s1, fm, cell.f1));
    };
    let slack = 1e-12 * (1.0 + best.0.abs() + lipschitz);
    SegmentMin {
        value: (lower - slack).min(best.0),
        at: best.1,
        attained: best.0,
    }
}

impl Union {
    /// The index range of the planes among [`Union::components`]' primitives (spheres come
    /// first, then planes, capsules, boxes and meshes).
    pub fn plane_components(&self) -> std::ops::Range<usize> {
        let spheres: usize = self.spheres.iter().map(|s| s.radii.len()).sum();
        spheres..spheres + self.planes.len()
    }

    /// Each primitive's signed distance at its own minimizing point of the segment `a → b`, in
    /// [`Union::components`]' order: the minimizer found on the values (exact for spheres,
    /// capsules and boxes; a mesh's best searched point, its value lowered by the search's gap
    /// to its lower bound, so it never exceeds the minimum), then the distance evaluated there
    /// in `R`, so duals give the minimum's gradient (module docs). A plane's is its distance at
    /// `b`: linear along the segment, its minimum is at an end, and the state `a` is held by the
    /// previous step's row. A box the segment enters counts minus its crossing depth
    /// ([`crate::sdf::Cuboid::crossing_depth`], at least its deepest point's depth): it keeps a
    /// slope where the segment crosses a thin box through its middle, where the deepest point's
    /// depth is flat, so a row on it says which way leads out.
    pub fn segment_components<R: Real>(&self, a: &Vector3<R>, b: &Vector3<R>, out: &mut [R]) {
        let mut k = 0;
        self.visit_segment_components(a, b, f64::INFINITY, |v| {
            out[k] = v;
            k += 1;
        });
    }

    /// The smallest of [`Union::segment_components`] (minus its crossing depth for a box the
    /// segment enters) for a bounded query (as [`SignedDistance::min_along_segment_within`]):
    /// exact wherever it is at most `bound`; a mesh whose segment cannot come within `bound`
    /// answers its lower bound above `bound` as a constant (derivative 0). The minimum over
    /// primitives passes the gradient to the first one on a tie.
    pub fn segment_distance_within<R: Real>(
        &self,
        a: &Vector3<R>,
        b: &Vector3<R>,
        bound: f64,
    ) -> R {
        let mut best: Option<R> = None;
        self.visit_segment_components(a, b, bound, |v| {
            best = Some(best.map_or(v, |x| x.min(v)));
        });
        best.unwrap_or_else(|| R::cst(f64::INFINITY))
    }

    /// Calls `put` with each primitive's value of [`Union::segment_components`], in order; a
    /// mesh whose segment's quick lower bound exceeds `mesh_bound` gets that bound as a
    /// constant instead of a search.
    fn visit_segment_components<R: Real>(
        &self,
        a: &Vector3<R>,
        b: &Vector3<R>,
        mesh_bound: f64,
        mut put: impl FnMut(R),
    ) {
        let (av, bv) = (values(a), values(b));
        let abv = bv - av;
        let len2 = abv.norm_squared();
        let point = |s: f64| a + (b - a) * R::cst(s);
        for set in &self.spheres {
            for (c, &r) in set.centers.iter().zip(&set.radii) {
                let cv = Vector3::new(c[0], c[1], c[2]);
                let p = point(sphere_segment_param(&av, &abv, len2, &cv));
                put(norm(&(p - Vector3::new(R::cst(c[0]), R::cst(c[1]), R::cst(c[2])))) - r);
            }
        }
        for plane in &self.planes {
            put(plane.distance(b));
        }
        for capsule in &self.capsules {
            put(capsule.distance(&point(capsule.segment_min(&av, &bv).at)));
        }
        for cuboid in &self.boxes {
            let deepest = cuboid.distance(&(a + (b - a) * cuboid.segment_param(a, b)));
            put(if deepest.value() < 0.0 {
                cuboid.crossing_depth(a, b).map_or(deepest, |d| -d)
            } else {
                deepest
            });
        }
        for mesh in &self.meshes {
            put(match midpoint_lower_bound(mesh, &av, &bv, mesh_bound) {
                Some(lower) if lower > mesh_bound => R::cst(lower),
                _ => {
                    let m = mesh.segment_min(&av, &bv);
                    mesh.distance(&point(m.at)) - m.gap()
                }
            });
        }
    }

    /// [`Union::segment_components`] in `f64` with each one's gradient with respect to `a`
    /// (entries 0–2) and `b` (entries 3–5), by forward duals.
    pub fn segment_components_with_gradients(
        &self,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
    ) -> Vec<(f64, [f64; 6])> {
        let var = |p: &Vector3<f64>, first: usize| {
            Vector3::from_fn(|j, _| Dual::<f64, 6>::variable(p[j], first + j))
        };
        let mut out = vec![Dual::<f64, 6>::cst(0.0); self.component_count()];
        self.segment_components(&var(a, 0), &var(b, 3), &mut out);
        out.iter().map(|d| (d.re, d.eps)).collect()
    }
}

/// The values of a point of any scalar.
fn values<R: Real>(p: &Vector3<R>) -> Vector3<f64> {
    Vector3::new(p[0].value(), p[1].value(), p[2].value())
}
