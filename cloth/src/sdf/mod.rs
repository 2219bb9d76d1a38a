//! Signed distance fields of obstacles: sphere sets, planes, capsules, boxes and closed triangle
//! meshes (positive outside).
//!
//! Written generically over [`Real`], so the same code serves the simulator's colliders, the
//! safety constraint and their derivatives. Conventions: at a sphere's centre the distance is
//! `−r` with gradient 0 (the norm's convention); on a tie between spheres, the first sphere wins.

pub(crate) mod batch;
pub(crate) mod bvh;
mod mesh;
pub(crate) mod rows;
mod segment;
mod shapes;
pub mod surface;

pub use mesh::MeshSdf;
pub use segment::{lipschitz_segment_min, SegmentMin, SEGMENT_TOLERANCE};
pub(crate) use shapes::closest_between_segments_within;
pub use shapes::{sphere_surface, Capsule, Cuboid, Surface};

use crate::geometry::norm;
use autodiff::{Dual, Real};
use nalgebra::Vector3;

/// A signed distance field, generic over the scalar type.
///
/// A signed distance is 1-Lipschitz (`|d(p) − d(q)| ≤ |p − q|`); the bounded segment query's
/// default relies on it.
pub trait SignedDistance: Send + Sync + 'static {
    /// Signed distance of `p` (negative inside).
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R;

    /// The signed distance of `p` and its gradient. The default takes the gradient from forward
    /// duals on [`SignedDistance::distance`]; a closed form must agree with it (conventions in
    /// the module docs).
    #[inline(always)]
    fn distance_gradient<R: Real>(&self, p: &Vector3<R>) -> (R, Vector3<R>)
    where
        Self: Sized,
    {
        let q = Vector3::from_fn(|k, _| Dual::<R, 3>::variable(p[k], k));
        let d = self.distance(&q);
        (d.re, Vector3::new(d.eps[0], d.eps[1], d.eps[2]))
    }

    /// A bounded query: [`SignedDistance::distance`] (bitwise) wherever that is at most `bound`;
    /// elsewhere a value `v` with `bound < v ≤ distance(p)` (a lower bound, to rounding),
    /// possibly a constant (derivative 0). What a caller needs that only cares whether a point
    /// is beyond `bound` (an inactive contact row, a safety margin). Meshes stop their search at
    /// the bound; the other primitives answer exactly (the default).
    #[inline(always)]
    fn distance_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> R {
        let _ = bound;
        self.distance(p)
    }

    /// [`SignedDistance::distance_gradient`] (bitwise) wherever the distance is at most `bound`;
    /// elsewhere [`SignedDistance::distance_within`]'s value with its derivative.
    #[inline(always)]
    fn distance_gradient_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> (R, Vector3<R>)
    where
        Self: Sized,
    {
        let _ = bound;
        self.distance_gradient(p)
    }

    /// The smallest signed distance along the straight segment `a → b` and where it is
    /// attained (`f64` only): exact (to rounding) for sphere sets, planes, capsules and boxes.
    ///
    /// The default is [`lipschitz_segment_min`]: a branch and bound on the 1-Lipschitz
    /// distance whose `value` is a lower bound of the minimum, never above it and within
    /// [`SEGMENT_TOLERANCE`] of it (what meshes answer).
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        lipschitz_segment_min(|p| self.distance(p), a, b, SEGMENT_TOLERANCE)
    }

    /// The smallest signed distance along the straight segment `a → b` (`f64` only):
    /// [`SignedDistance::segment_min`]'s value, a lower bound that is exact for every
    /// primitive but meshes.
    fn min_along_segment(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        self.segment_min(a, b).value
    }

    /// [`SignedDistance::min_along_segment`] (bitwise) wherever that is at most `bound`;
    /// elsewhere a value above `bound` and at most it (a lower bound, to rounding).
    ///
    /// The default first bounds the whole segment from its midpoint `m` (half-length `h`):
    /// `min ≥ d(m) − h` (1-Lipschitz), less a rounding slack of `1e-12·(1 + |d(m)| + h)`; when
    /// that exceeds `bound`, it is the answer. Otherwise it is
    /// [`SignedDistance::min_along_segment`].
    fn min_along_segment_within(&self, a: &Vector3<f64>, b: &Vector3<f64>, bound: f64) -> f64 {
        match midpoint_lower_bound(self, a, b, bound) {
            Some(lower) if lower > bound => lower,
            _ => self.min_along_segment(a, b),
        }
    }
}

/// A cheap lower bound of `field`'s smallest value along `a → b` from its midpoint `m`
/// (half-length `h`): `d(m) − h` (1-Lipschitz), less a rounding slack of
/// `1e-12·(1 + |d(m)| + h)`, with `d(m)` queried within `bound + h`. `None` for an unbounded
/// query (`bound = ∞`), which wants the exact minimum anyway.
pub(crate) fn midpoint_lower_bound<S: SignedDistance + ?Sized>(
    field: &S,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    bound: f64,
) -> Option<f64> {
    if bound == f64::INFINITY {
        return None;
    }
    let half = 0.5 * (b - a).norm();
    let centre = field.distance_within(&(a + (b - a) * 0.5), bound + half);
    Some(centre - half - 1e-12 * (1.0 + centre.abs() + half))
}

/// `|p − c| − r`: one sphere of a [`Union`]'s, as its components are computed.
fn sphere_distance<R: Real>(c: &[f64; 3], r: f64, p: &Vector3<R>) -> R {
    norm(&(p - Vector3::new(R::cst(c[0]), R::cst(c[1]), R::cst(c[2])))) - r
}

/// A union of spheres: `min_s (|p − c_s| − r_s)`.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereSet {
    /// Centres.
    pub centers: Vec<[f64; 3]>,
    /// Radii, one per centre.
    pub radii: Vec<f64>,
}

impl SignedDistance for SphereSet {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let mut best: Option<R> = None;
        for (c, &r) in self.centers.iter().zip(&self.radii) {
            let d = p - Vector3::new(R::cst(c[0]), R::cst(c[1]), R::cst(c[2]));
            let s = norm(&d) - r;
            best = Some(match best {
                Some(b) => b.min(s),
                None => s,
            });
        }
        best.unwrap_or_else(|| R::cst(f64::INFINITY))
    }

    /// The nearest sphere's `|p − c| − r` and `(p − c)/|p − c|` (0 at the centre).
    #[inline(always)]
    fn distance_gradient<R: Real>(&self, p: &Vector3<R>) -> (R, Vector3<R>) {
        let mut best = (R::cst(f64::INFINITY), Vector3::zeros());
        for (k, (c, &r)) in self.centers.iter().zip(&self.radii).enumerate() {
            let d = p - Vector3::new(R::cst(c[0]), R::cst(c[1]), R::cst(c[2]));
            let sq = d.dot(&d);
            let n = sq.sqrt();
            let s = n - r;
            // Strictly nearer replaces, so a tie keeps the first sphere (as `Real::min`).
            if k == 0 || s.value() < best.0.value() {
                let grad = if sq.value() == 0.0 {
                    Vector3::zeros()
                } else {
                    d * n.recip()
                };
                best = (s, grad);
            }
        }
        best
    }

    fn min_along_segment(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        let ab = b - a;
        let len2 = ab.norm_squared();
        self.centers
            .iter()
            .zip(&self.radii)
            .map(|(c, &r)| {
                let c = Vector3::new(c[0], c[1], c[2]);
                (a + ab * sphere_segment_param(a, &ab, len2, &c) - c).norm() - r
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Exact: [`SignedDistance::min_along_segment`].
    fn min_along_segment_within(&self, a: &Vector3<f64>, b: &Vector3<f64>, _: f64) -> f64 {
        self.min_along_segment(a, b)
    }

    /// Exact: the nearest sphere's `sphere_segment_param` (the first sphere on a tie).
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        let ab = b - a;
        let len2 = ab.norm_squared();
        let mut best = SegmentMin::exact(f64::INFINITY, 0.0);
        for (c, &r) in self.centers.iter().zip(&self.radii) {
            let c = Vector3::new(c[0], c[1], c[2]);
            let s = sphere_segment_param(a, &ab, len2, &c);
            let d = (a + ab * s - c).norm() - r;
            if d < best.value {
                best = SegmentMin::exact(d, s);
            }
        }
        best
    }
}

/// The parameter `s ∈ [0, 1]` of the point of the segment `a → a + ab` nearest to the centre `c`
/// (`len2 = |ab|²`; 0 for a segment of zero length): where the distance to a sphere around `c`
/// is smallest along the segment.
pub(crate) fn sphere_segment_param(
    a: &Vector3<f64>,
    ab: &Vector3<f64>,
    len2: f64,
    c: &Vector3<f64>,
) -> f64 {
    if len2 > 0.0 {
        ((c - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// A half-space boundary `n·(p − q) = 0` with unit normal `n` pointing to the free side.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: [f64; 3],
    /// Unit normal (towards the outside).
    pub normal: [f64; 3],
}

impl SignedDistance for Plane {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let n = self.normal;
        (p[0] - self.point[0]) * n[0]
            + (p[1] - self.point[1]) * n[1]
            + (p[2] - self.point[2]) * n[2]
    }

    /// The distance and the constant normal.
    #[inline(always)]
    fn distance_gradient<R: Real>(&self, p: &Vector3<R>) -> (R, Vector3<R>) {
        let n = self.normal;
        (
            self.distance(p),
            Vector3::new(R::cst(n[0]), R::cst(n[1]), R::cst(n[2])),
        )
    }

    fn min_along_segment(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        self.distance(a).min(self.distance(b))
    }

    /// Exact: [`SignedDistance::min_along_segment`].
    fn min_along_segment_within(&self, a: &Vector3<f64>, b: &Vector3<f64>, _: f64) -> f64 {
        self.min_along_segment(a, b)
    }

    /// Exact: the distance is linear along the segment, so its minimum is at an end (`a` on a
    /// tie).
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        let (da, db) = (self.distance(a), self.distance(b));
        if db < da {
            SegmentMin::exact(db, 1.0)
        } else {
            SegmentMin::exact(da, 0.0)
        }
    }
}

/// The union of several obstacles: the minimum of their signed distances (first wins a tie).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Union {
    /// Sphere sets.
    pub spheres: Vec<SphereSet>,
    /// Planes.
    pub planes: Vec<Plane>,
    /// Capsules.
    pub capsules: Vec<Capsule>,
    /// Boxes.
    pub boxes: Vec<Cuboid>,
    /// Closed triangle meshes.
    pub meshes: Vec<MeshSdf>,
}

impl Union {
    /// True when the union holds no obstacle.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
            && self.planes.is_empty()
            && self.capsules.is_empty()
            && self.boxes.is_empty()
            && self.meshes.is_empty()
    }

    /// Appends `other`'s obstacles to this union's.
    pub fn extend(&mut self, other: Union) {
        self.spheres.extend(other.spheres);
        self.planes.extend(other.planes);
        self.capsules.extend(other.capsules);
        self.boxes.extend(other.boxes);
        self.meshes.extend(other.meshes);
    }

    /// The primitives narrower than `width` across (spheres and capsules by their diameter,
    /// boxes by their smallest side; planes are unbounded, meshes are not measured), with the
    /// index of each of their components among this union's ([`Union::components`]).
    pub fn narrower_than(&self, width: f64) -> (Union, Vec<usize>) {
        let (mut narrow, mut index) = (Union::default(), Vec::new());
        let mut k = 0;
        for set in &self.spheres {
            let mut kept = SphereSet {
                centers: Vec::new(),
                radii: Vec::new(),
            };
            for (c, &r) in set.centers.iter().zip(&set.radii) {
                if 2.0 * r < width {
                    kept.centers.push(*c);
                    kept.radii.push(r);
                    index.push(k);
                }
                k += 1;
            }
            if !kept.radii.is_empty() {
                narrow.spheres.push(kept);
            }
        }
        k += self.planes.len();
        for c in &self.capsules {
            if c.width() < width {
                narrow.capsules.push(c.clone());
                index.push(k);
            }
            k += 1;
        }
        for b in &self.boxes {
            if b.width() < width {
                narrow.boxes.push(b.clone());
                index.push(k);
            }
            k += 1;
        }
        (narrow, index)
    }

    /// The smallest width across of the spheres, capsules and boxes ([`Union::narrower_than`]);
    /// `∞` without any.
    pub fn narrowest(&self) -> f64 {
        let spheres = (self.spheres.iter()).flat_map(|s| s.radii.iter().map(|r| 2.0 * r));
        let capsules = self.capsules.iter().map(Capsule::width);
        let boxes = self.boxes.iter().map(Cuboid::width);
        (spheres.chain(capsules).chain(boxes)).fold(f64::INFINITY, f64::min)
    }

    /// An axis-aligned box `(lo, hi)` holding every sphere, capsule and box; `None` with a plane
    /// or a mesh (unbounded, or not measured) or without any primitive.
    pub fn bounds(&self) -> Option<([f64; 3], [f64; 3])> {
        if !(self.planes.is_empty() && self.meshes.is_empty()) || self.is_empty() {
            return None;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let mut grow = |c: [f64; 3], half: [f64; 3]| {
            for k in 0..3 {
                lo[k] = lo[k].min(c[k] - half[k]);
                hi[k] = hi[k].max(c[k] + half[k]);
            }
        };
        for set in &self.spheres {
            for (c, &r) in set.centers.iter().zip(&set.radii) {
                grow(*c, [r; 3]);
            }
        }
        for c in &self.capsules {
            grow(c.a, [c.radius; 3]);
            grow(c.b, [c.radius; 3]);
        }
        for b in &self.boxes {
            // Body axes are the rotation's columns: world extent `Σⱼ |R_kj| hⱼ` along axis k.
            let half = std::array::from_fn(|k| {
                (0..3)
                    .map(|j| b.rotation[k][j].abs() * b.half_extents[j])
                    .sum()
            });
            grow(b.center, half);
        }
        Some((lo, hi))
    }

    /// Number of primitives (spheres, planes, capsules, boxes, meshes).
    pub fn component_count(&self) -> usize {
        self.spheres.iter().map(|s| s.radii.len()).sum::<usize>()
            + self.planes.len()
            + self.capsules.len()
            + self.boxes.len()
            + self.meshes.len()
    }

    /// The signed distance of `p` to each primitive (spheres, planes, capsules, boxes, meshes); their minimum is
    /// [`SignedDistance::distance`].
    pub fn components<R: Real>(&self, p: &Vector3<R>, out: &mut [R]) {
        self.components_within(p, f64::INFINITY, out);
    }

    /// [`Union::components`], each primitive queried with `bound`
    /// ([`SignedDistance::distance_within`]): exact wherever it is at most `bound`, a lower bound
    /// above it elsewhere (only meshes answer inexactly).
    pub fn components_within<R: Real>(&self, p: &Vector3<R>, bound: f64, out: &mut [R]) {
        let mut k = 0;
        for set in &self.spheres {
            for (c, &r) in set.centers.iter().zip(&set.radii) {
                out[k] = sphere_distance(c, r, p);
                k += 1;
            }
        }
        for plane in &self.planes {
            out[k] = plane.distance(p);
            k += 1;
        }
        for d in self.others(p, bound) {
            out[k] = d;
            k += 1;
        }
    }

    /// The `k`-th of [`Union::components_within`]'s distances alone, by the same arithmetic
    /// (what a caller that needs a few primitives' derivatives evaluates).
    pub fn component_within<R: Real>(&self, mut k: usize, p: &Vector3<R>, bound: f64) -> R {
        for set in &self.spheres {
            if k < set.radii.len() {
                return sphere_distance(&set.centers[k], set.radii[k], p);
            }
            k -= set.radii.len();
        }
        if k < self.planes.len() {
            return self.planes[k].distance(p);
        }
        k -= self.planes.len();
        if k < self.capsules.len() {
            return self.capsules[k].distance(p);
        }
        k -= self.capsules.len();
        if k < self.boxes.len() {
            return self.boxes[k].distance(p);
        }
        self.meshes[k - self.boxes.len()].distance_within(p, bound)
    }

    /// The distances to the capsules, boxes and meshes, in that order, each bounded by `bound`
    /// ([`SignedDistance::distance_within`]).
    fn others<'a, R: Real>(
        &'a self,
        p: &'a Vector3<R>,
        bound: f64,
    ) -> impl Iterator<Item = R> + 'a {
        let capsules = self.capsules.iter().map(move |c| c.distance(p));
        let boxes = self.boxes.iter().map(move |b| b.distance(p));
        let meshes = self.meshes.iter().map(move |m| m.distance_within(p, bound));
        capsules.chain(boxes).chain(meshes)
    }
}

impl SignedDistance for Union {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        self.distance_within(p, f64::INFINITY)
    }

    /// The minimum of the primitives' bounded distances: where the union's distance is at most
    /// `bound`, the primitive attaining it answers exactly and every other one either exactly
    /// or above `bound`, so the minimum (and which primitive wins a tie) is the exact one's.
    fn distance_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> R {
        let mut best: Option<R> = None;
        let mut take = |s: R| {
            best = Some(match best {
                Some(b) => b.min(s),
                None => s,
            })
        };
        for s in &self.spheres {
            take(s.distance(p));
        }
        for pl in &self.planes {
            take(pl.distance(p));
        }
        for d in self.others(p, bound) {
            take(d);
        }
        best.unwrap_or_else(|| R::cst(f64::INFINITY))
    }

    /// The nearest obstacle's distance and gradient (the first one on a tie, as `Real::min`).
    #[inline(always)]
    fn distance_gradient<R: Real>(&self, p: &Vector3<R>) -> (R, Vector3<R>) {
        self.distance_gradient_within(p, f64::INFINITY)
    }

    /// The nearest obstacle's bounded distance and gradient (as
    /// [`Union::distance_within`]'s minimum).
    #[inline(always)]
    fn distance_gradient_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> (R, Vector3<R>) {
        let mut best: Option<(R, Vector3<R>)> = None;
        let mut take = |c: (R, Vector3<R>)| {
            if best.as_ref().is_none_or(|b| c.0.value() < b.0.value()) {
                best = Some(c);
            }
        };
        for s in &self.spheres {
            take(s.distance_gradient(p));
        }
        for pl in &self.planes {
            take(pl.distance_gradient(p));
        }
        for c in &self.capsules {
            take(c.distance_gradient(p));
        }
        for b in &self.boxes {
            take(b.distance_gradient(p));
        }
        for m in &self.meshes {
            take(m.distance_gradient_within(p, bound));
        }
        best.unwrap_or_else(|| (R::cst(f64::INFINITY), Vector3::zeros()))
    }

    fn min_along_segment(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        self.min_along_segment_within(a, b, f64::INFINITY)
    }

    /// Each primitive's bounded segment minimum, the bound lowered to the smallest one so far.
    fn min_along_segment_within(&self, a: &Vector3<f64>, b: &Vector3<f64>, bound: f64) -> f64 {
        let mut best = f64::INFINITY;
        for s in &self.spheres {
            best = best.min(s.min_along_segment(a, b));
        }
        for p in &self.planes {
            best = best.min(p.min_along_segment(a, b));
        }
        for c in &self.capsules {
            best = best.min(c.min_along_segment_within(a, b, bound.min(best)));
        }
        for c in &self.boxes {
            best = best.min(c.min_along_segment_within(a, b, bound.min(best)));
        }
        for m in &self.meshes {
            best = best.min(m.min_along_segment_within(a, b, bound.min(best)));
        }
        best
    }
}
