//! Capsules and (optionally rotated) boxes, generic over [`Real`], with their exact minima along
//! segments; and the surface tessellations figures draw obstacles with.

use super::{SegmentMin, SignedDistance};
use crate::geometry::{constant, norm};
use autodiff::Real;
use nalgebra::Vector3;

/// A surface as triangles: vertices and counter-clockwise (seen from outside) index triples.
pub type Surface = (Vec<[f64; 3]>, Vec<[usize; 3]>);

/// Segments around a circle in [`Capsule::surface_triangles`] and [`sphere_surface`].
const SEGMENTS: usize = 16;

/// The points within `radius` of the segment `a–b`: `|p − closest(a–b, p)| − radius`.
///
/// The closest point's parameter `t = (p − a)·(b − a)/|b − a|²` is clamped to `[0, 1]` on its
/// value, so at an end cap the distance is the end sphere's; `a = b` is a sphere.
#[derive(Clone, Debug, PartialEq)]
pub struct Capsule {
    /// One end of the axis.
    pub a: [f64; 3],
    /// The other end of the axis.
    pub b: [f64; 3],
    /// Radius (> 0).
    pub radius: f64,
}

impl Capsule {
    /// Its width across: the diameter.
    pub fn width(&self) -> f64 {
        2.0 * self.radius
    }
}

impl SignedDistance for Capsule {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let a = constant::<R>(&self.a);
        let ab: [f64; 3] = std::array::from_fn(|k| self.b[k] - self.a[k]);
        let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        let ap = p - a;
        let t = if len2 > 0.0 {
            (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / len2
        } else {
            R::zero()
        };
        let t = if t.value() <= 0.0 {
            R::zero()
        } else if t.value() >= 1.0 {
            R::one()
        } else {
            t
        };
        let closest = a + constant::<R>(&ab) * t;
        norm(&(p - closest)) - self.radius
    }

    /// Exact: the distance grows with the distance to the axis, so its minimum is at the
    /// segment's point nearest to the axis segment (`closest_between_segments`).
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        let (s, _) = closest_between_segments(a, b, &Vector3::from(self.a), &Vector3::from(self.b));
        SegmentMin::exact(self.distance(&(a + (b - a) * s)), s)
    }
}

/// The parameters `(s, t) ∈ [0, 1]²` of the closest points `p₁ + s(q₁ − p₁)` and
/// `p₂ + t(q₂ − p₂)` of two segments (Ericson, *Real-Time Collision Detection*, 5.1.9); a segment
/// of zero length is a point (parameter 0), parallel segments get one closest pair of many.
pub fn closest_between_segments(
    p1: &Vector3<f64>,
    q1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q2: &Vector3<f64>,
) -> (f64, f64) {
    closest_between_segments_within(p1, q1, p2, q2, 0.0)
}

/// [`closest_between_segments`], treating the segments as parallel (the first's parameter 0)
/// where `sin²` of the angle between them is at most `parallel`.
pub fn closest_between_segments_within(
    p1: &Vector3<f64>,
    q1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q2: &Vector3<f64>,
    parallel: f64,
) -> (f64, f64) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    if a == 0.0 && e == 0.0 {
        return (0.0, 0.0);
    }
    if a == 0.0 {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e == 0.0 {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    let s = if denom > parallel * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = (b * s + f) / e;
    if t < 0.0 {
        ((-c / a).clamp(0.0, 1.0), 0.0)
    } else if t > 1.0 {
        (((b - c) / a).clamp(0.0, 1.0), 1.0)
    } else {
        (s, t)
    }
}

impl Capsule {
    /// A closed tessellation: a cylinder of `SEGMENTS` (`cloth/src/sdf/shapes.rs`) sides capped by
    /// two hemispheres.
    pub fn surface_triangles(&self) -> Surface {
        let a = Vector3::from(self.a);
        let b = Vector3::from(self.b);
        let axis = b - a;
        let w = if axis.norm() > 0.0 {
            axis.normalize()
        } else {
            Vector3::z()
        };
        let (u, v) = orthonormal_pair(&w);
        // Rings from the pole below `a` to the pole above `b`: a hemisphere's latitudes at each end.
        let half = SEGMENTS / 4;
        let mut rings: Vec<(Vector3<f64>, f64, f64)> = Vec::new(); // centre, axial offset, ring radius
        for k in 1..=half {
            let phi = std::f64::consts::FRAC_PI_2 * (1.0 - k as f64 / half as f64);
            rings.push((a, -self.radius * phi.sin(), self.radius * phi.cos()));
        }
        for k in 0..half {
            let phi = std::f64::consts::FRAC_PI_2 * (k as f64 / half as f64);
            rings.push((b, self.radius * phi.sin(), self.radius * phi.cos()));
        }
        let point = |c: &Vector3<f64>, off: f64, r: f64, j: usize| {
            let th = 2.0 * std::f64::consts::PI * j as f64 / SEGMENTS as f64;
            let q = c + w * off + (u * th.cos() + v * th.sin()) * r;
            [q.x, q.y, q.z]
        };
        let mut vertices = vec![[
            a.x - w.x * self.radius,
            a.y - w.y * self.radius,
            a.z - w.z * self.radius,
        ]];
        for (c, off, r) in &rings {
            vertices.extend((0..SEGMENTS).map(|j| point(c, *off, *r, j)));
        }
        vertices.push([
            b.x + w.x * self.radius,
            b.y + w.y * self.radius,
            b.z + w.z * self.radius,
        ]);
        (
            vertices.clone(),
            ring_triangles(rings.len(), vertices.len() - 1),
        )
    }
}

/// Triangles of a closed surface of revolution: pole 0, `n_rings` rings of [`SEGMENTS`] vertices
/// (ring `k` starts at `1 + k·SEGMENTS`, rings run from the bottom pole upwards), and pole `top`.
fn ring_triangles(n_rings: usize, top: usize) -> Vec<[usize; 3]> {
    let at = |k: usize, j: usize| 1 + k * SEGMENTS + j % SEGMENTS;
    let mut tris = Vec::new();
    for j in 0..SEGMENTS {
        tris.push([0, at(0, j + 1), at(0, j)]);
    }
    for k in 0..n_rings - 1 {
        for j in 0..SEGMENTS {
            tris.push([at(k, j), at(k, j + 1), at(k + 1, j + 1)]);
            tris.push([at(k, j), at(k + 1, j + 1), at(k + 1, j)]);
        }
    }
    for j in 0..SEGMENTS {
        tris.push([top, at(n_rings - 1, j), at(n_rings - 1, j + 1)]);
    }
    tris
}

/// Two unit vectors that make a right-handed orthonormal frame `(u, v, w)` with the unit `w`.
fn orthonormal_pair(w: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if w.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = helper.cross(w).normalize();
    (u, w.cross(&u))
}

/// A sphere's closed tessellation (for figures), like a capsule of zero length.
pub fn sphere_surface(center: [f64; 3], radius: f64) -> Surface {
    Capsule {
        a: center,
        b: center,
        radius,
    }
    .surface_triangles()
}

/// A box `|Rᵀ(p − c)|ₖ ≤ hₖ`: centre `c`, half extents `h`, rotation `R` (body to world).
///
/// With `q = Rᵀ(p − c)` and `dₖ = |qₖ| − hₖ`, the distance is `|max(d, 0)|` outside and `max_k dₖ`
/// inside (the exact Euclidean signed distance of a box).
#[derive(Clone, Debug, PartialEq)]
pub struct Cuboid {
    /// Centre.
    pub center: [f64; 3],
    /// Half extents along the body axes (each > 0).
    pub half_extents: [f64; 3],
    /// Rotation matrix, rows of `R` (body axes are its columns).
    pub rotation: [[f64; 3]; 3],
}

impl Cuboid {
    /// Its width across: the smallest side.
    pub fn width(&self) -> f64 {
        2.0 * self
            .half_extents
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    }

    /// A box rotated by the quaternion `[w, x, y, z]` (normalised here; validation rejects zero).
    pub fn new(center: [f64; 3], half_extents: [f64; 3], rotation: Option<[f64; 4]>) -> Cuboid {
        let [w, x, y, z] = rotation.unwrap_or([1.0, 0.0, 0.0, 0.0]);
        let n = (w * w + x * x + y * y + z * z).sqrt();
        let (w, x, y, z) = (w / n, x / n, y / n, z / n);
        let rotation = [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ];
        Cuboid {
            center,
            half_extents,
            rotation,
        }
    }

    /// The body-frame point `q` in world coordinates, `c + R q`.
    fn to_world(&self, q: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| {
            self.center[i] + (0..3).map(|j| self.rotation[i][j] * q[j]).sum::<f64>()
        })
    }

    /// The 8 corners and 12 outward-wound triangles.
    pub fn surface_triangles(&self) -> Surface {
        let h = self.half_extents;
        let vertices = (0..8)
            .map(|k| {
                let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                self.to_world([s(0) * h[0], s(1) * h[1], s(2) * h[2]])
            })
            .collect();
        // Corner k has x = bit 0, y = bit 1, z = bit 2.
        let faces = [
            [0, 2, 3, 1], // z−
            [4, 5, 7, 6], // z+
            [0, 1, 5, 4], // y−
            [2, 6, 7, 3], // y+
            [0, 4, 6, 2], // x−
            [1, 3, 7, 5], // x+
        ];
        let triangles = faces
            .iter()
            .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
            .collect();
        (vertices, triangles)
    }
}

impl SignedDistance for Cuboid {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let q = self.body(p);
        let d: [R; 3] = std::array::from_fn(|k| q[k].abs() - self.half_extents[k]);
        if d.iter().any(|x| x.value() > 0.0) {
            let o = Vector3::new(d[0].relu(), d[1].relu(), d[2].relu());
            norm(&o)
        } else {
            d[0].max(d[1]).max(d[2])
        }
    }

    /// Exact: the distance is convex along the segment and, between the parameters where a
    /// body coordinate crosses `−h`, `0` or `h`, either `√(quadratic)` (outside: the axes
    /// beyond their faces are fixed there) or a maximum of three linear functions (inside).
    /// The minimum is at a piece's end, a quadratic's vertex or two linear functions'
    /// crossing; the distance is evaluated at each candidate and the smallest kept (the
    /// smallest parameter on a tie).
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        let (s, _) = self.segment_minimizer(a, b);
        SegmentMin::exact(self.distance(&(a + (b - a) * s)), s)
    }
}

/// How a box's minimizing parameter along a segment is defined (`Cuboid::segment_param`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum BoxCandidate {
    /// A fixed parameter: an end of the segment, or the vertex of a smooth piece (where the
    /// distance is stationary along the segment, so the parameter's own motion does not count).
    Fixed,
    /// Where body coordinate `axis` reaches `level` (`−h`, `0` or `h`).
    Level { axis: usize, level: f64 },
    /// Where the inside terms `σᵢqᵢ − hᵢ` and `σⱼqⱼ − hⱼ` cross.
    Crossing { i: usize, j: usize, signs: [f64; 3] },
}

impl Cuboid {
    /// The body coordinates `Rᵀ(p − c)` of a point of any scalar.
    fn body<R: Real>(&self, p: &Vector3<R>) -> [R; 3] {
        let rel = p - constant::<R>(&self.center);
        std::array::from_fn(|k| {
            rel[0] * self.rotation[0][k]
                + rel[1] * self.rotation[1][k]
                + rel[2] * self.rotation[2][k]
        })
    }

    /// The parameter in `[0, 1]` where the distance is smallest along `a → b`
    /// ([`SignedDistance::segment_min`]) and how it is defined.
    fn segment_minimizer(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, BoxCandidate) {
        let (qa, qb) = (self.body(a), self.body(b));
        let e: [f64; 3] = std::array::from_fn(|k| qb[k] - qa[k]);
        let h = self.half_extents;
        let mut cuts = vec![(0.0, BoxCandidate::Fixed), (1.0, BoxCandidate::Fixed)];
        for axis in 0..3 {
            if e[axis] != 0.0 {
                for level in [-h[axis], 0.0, h[axis]] {
                    let s = (level - qa[axis]) / e[axis];
                    if s > 0.0 && s < 1.0 {
                        cuts.push((s, BoxCandidate::Level { axis, level }));
                    }
                }
            }
        }
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        cuts.dedup_by(|x, y| x.0 == y.0);
        let mut candidates = cuts.clone();
        for w in cuts.windows(2) {
            candidates.extend(box_piece_candidates(&qa, &e, &h, w[0].0, w[1].0));
        }
        candidates.sort_by(|x, y| x.0.total_cmp(&y.0));
        let value = |s: f64| self.distance(&(a + (b - a) * s));
        let mut best = (f64::INFINITY, (0.0, BoxCandidate::Fixed));
        for c in candidates {
            let v = value(c.0);
            if v < best.0 {
                best = (v, c);
            }
        }
        best.1
    }

    /// How deep the straight segment `a → b` lies in the box: the least distance it must move,
    /// along one of the separating axes of a segment and a box (the box's three axes and their
    /// cross products with the segment), to come clear of it; `None` where it is clear. At least
    /// the depth of its deepest point, and, unlike that depth, not flat where the segment crosses
    /// a thin box through its middle: there it is the way out over the nearer rim.
    pub fn crossing_depth<R: Real>(&self, a: &Vector3<R>, b: &Vector3<R>) -> Option<R> {
        let (qa, qb) = (self.body(a), self.body(b));
        let d: [R; 3] = std::array::from_fn(|k| qb[k] - qa[k]);
        let h = self.half_extents;
        // The cross products first: where one coincides with a box axis (a motion square to a
        // face), the tie goes to it, whose projections of the two ends are equal as functions,
        // so the depth has one derivative there.
        let mut axes: Vec<[R; 3]> = Vec::with_capacity(6);
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().value();
        for k in 0..3 {
            // d × e_k.
            let mut n = [R::cst(0.0); 3];
            n[(k + 1) % 3] = d[(k + 2) % 3];
            n[(k + 2) % 3] = -d[(k + 1) % 3];
            let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if norm.value() > 1e-9 * length.max(f64::MIN_POSITIVE) {
                axes.push(n.map(|v| v / norm));
            }
        }
        axes.extend(
            (0..3).map(|k| std::array::from_fn(|j| R::cst(if j == k { 1.0 } else { 0.0 }))),
        );
        let mut depth: Option<R> = None;
        for n in axes {
            let dot = |q: &[R; 3]| q[0] * n[0] + q[1] * n[1] + q[2] * n[2];
            let r = (0..3).fold(R::cst(0.0), |acc, k| acc + n[k].abs() * h[k]);
            let (sa, sb) = (dot(&qa), dot(&qb));
            let overlap = (sa.max(sb) + r).min(r - sa.min(sb));
            if overlap.value() <= 0.0 {
                return None;
            }
            depth = Some(depth.map_or(overlap, |m| m.min(overlap)));
        }
        depth
    }

    /// The minimizing parameter of [`SignedDistance::segment_min`] as a function of the segment's
    /// ends, for any scalar: found on the values, then recomputed from `a` and `b` by its
    /// definition (where a coordinate reaches a level, where two inside terms cross), so that
    /// where the minimum sits on a crease of the box's field its motion with the ends is
    /// differentiated too; a fixed parameter (an end, a smooth piece's vertex) is a constant.
    /// The distance at `a + s(b − a)` then has the minimum's exact derivative.
    pub fn segment_param<R: Real>(&self, a: &Vector3<R>, b: &Vector3<R>) -> R {
        let value = |p: &Vector3<R>| Vector3::new(p[0].value(), p[1].value(), p[2].value());
        let (s, how) = self.segment_minimizer(&value(a), &value(b));
        let (qa, qb) = (self.body(a), self.body(b));
        let e: [R; 3] = std::array::from_fn(|k| qb[k] - qa[k]);
        match how {
            BoxCandidate::Fixed => R::cst(s),
            BoxCandidate::Level { axis, level } => (R::cst(level) - qa[axis]) / e[axis],
            BoxCandidate::Crossing { i, j, signs } => {
                let h = self.half_extents;
                let alpha = |k: usize| qa[k] * signs[k] - h[k];
                let beta = |k: usize| e[k] * signs[k];
                (alpha(j) - alpha(i)) / (beta(i) - beta(j))
            }
        }
    }
}

/// The candidate minimizers of a box's distance inside the piece `[s0, s1]` of the body-frame
/// segment `q(s) = qa + s·e` (half extents `h`), on which no coordinate crosses `−h`, `0` or `h`:
/// outside, the vertex of `Σ (|q_k| − h_k)²` over the axes beyond their faces, clamped to the
/// piece; inside, the crossings of two of the linear `|q_k| − h_k`.
fn box_piece_candidates(
    qa: &[f64; 3],
    e: &[f64; 3],
    h: &[f64; 3],
    s0: f64,
    s1: f64,
) -> Vec<(f64, BoxCandidate)> {
    let mid = 0.5 * (s0 + s1);
    let signs: [f64; 3] =
        std::array::from_fn(|k| if qa[k] + mid * e[k] < 0.0 { -1.0 } else { 1.0 });
    // On the piece, |q_k| − h_k = α_k + β_k s.
    let line: [(f64, f64); 3] = std::array::from_fn(|k| (signs[k] * qa[k] - h[k], signs[k] * e[k]));
    let outside: Vec<(f64, f64)> = line
        .iter()
        .copied()
        .filter(|(al, be)| al + be * mid > 0.0)
        .collect();
    if !outside.is_empty() {
        let a2: f64 = outside.iter().map(|(_, be)| be * be).sum();
        let b1: f64 = outside.iter().map(|(al, be)| al * be).sum();
        return if a2 > 0.0 {
            vec![((-b1 / a2).clamp(s0, s1), BoxCandidate::Fixed)]
        } else {
            Vec::new()
        };
    }
    let mut out = Vec::new();
    for i in 0..3 {
        for j in i + 1..3 {
            let (ai, bi) = line[i];
            let (aj, bj) = line[j];
            if bi != bj {
                let s = (aj - ai) / (bi - bj);
                if s > s0 && s < s1 {
                    out.push((s, BoxCandidate::Crossing { i, j, signs }));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use autodiff::Dual;

    /// A segment through a 1 cm wall (0.3 high, top at z = 0.3) through its middle: the depth is
    /// the way out over the top, falling as the segment rises (the deepest point's depth stays
    /// at the half thickness, 0.005); a segment clear of the wall has none; a point inside has
    /// its own depth.
    #[test]
    fn a_segment_through_a_thin_wall_is_as_deep_as_the_way_over_it() {
        let wall = Cuboid::new([0.0, 0.0, 0.15], [0.005, 1.0, 0.15], None);
        let depth =
            |a: [f64; 3], b: [f64; 3]| wall.crossing_depth(&Vector3::from(a), &Vector3::from(b));
        let low = depth([-0.1, 0.0, 0.2], [0.1, 0.0, 0.2]).unwrap();
        let high = depth([-0.1, 0.0, 0.28], [0.1, 0.0, 0.28]).unwrap();
        assert!(
            (low - 0.1).abs() < 1e-12 && (high - 0.02).abs() < 1e-12,
            "{low} {high}"
        );
        let deepest = wall.distance(&Vector3::new(0.0, 0.0, 0.2));
        assert!((deepest + 0.005).abs() < 1e-12, "{deepest}");
        assert_eq!(depth([-0.1, 0.0, 0.31], [0.1, 0.0, 0.31]), None);
        let inside = depth([0.002, 0.0, 0.2], [0.002, 0.0, 0.2]).unwrap();
        assert!((inside - 0.003).abs() < 1e-12, "{inside}");
        // Its slope along z is −1 where the deepest point's is 0.
        let lifted = |z: Dual<f64, 1>| {
            let p = |x: f64| Vector3::new(Dual::cst(x), Dual::cst(0.0), z);
            wall.crossing_depth(&p(-0.1), &p(0.1)).unwrap()
        };
        let slope = lifted(Dual::variable(0.2, 0)).eps[0];
        assert!((slope + 1.0).abs() < 1e-12, "{slope}");
    }

    /// Sum over triangles of the signed volume `(a·(b×c))/6`: positive for outward winding.
    fn volume((v, t): &Surface) -> f64 {
        t.iter()
            .map(|&[a, b, c]| {
                let (a, b, c) = (
                    Vector3::from(v[a]),
                    Vector3::from(v[b]),
                    Vector3::from(v[c]),
                );
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn tessellations_are_closed_and_outward() {
        let cube = Cuboid::new(
            [1.0, 2.0, 3.0],
            [0.5, 1.0, 1.5],
            Some([0.9, 0.1, 0.3, -0.2]),
        );
        let s = cube.surface_triangles();
        assert_eq!((s.0.len(), s.1.len()), (8, 12));
        assert!(
            (volume(&s) - 6.0).abs() < 1e-12,
            "box volume {}",
            volume(&s)
        );
        for v in &s.0 {
            assert!(cube.distance(&Vector3::from(*v)).abs() < 1e-12);
        }
        let cap = Capsule {
            a: [0.0, 0.0, 0.0],
            b: [0.0, 0.0, 2.0],
            radius: 0.5,
        };
        let s = cap.surface_triangles();
        let exact = std::f64::consts::PI * 0.25 * 2.0 + 4.0 / 3.0 * std::f64::consts::PI * 0.125;
        let v = volume(&s);
        assert!(
            v > 0.9 * exact && v < exact,
            "capsule volume {v} vs {exact}"
        );
        for p in &s.0 {
            assert!(cap.distance(&Vector3::from(*p)).abs() < 1e-12);
        }
        let sphere = sphere_surface([0.0; 3], 1.0);
        assert!(volume(&sphere) > 0.9 * 4.0 / 3.0 * std::f64::consts::PI);
    }

    #[test]
    fn distances_at_known_points() {
        let cap = Capsule {
            a: [0.0, 0.0, 0.0],
            b: [0.0, 0.0, 2.0],
            radius: 0.5,
        };
        assert_eq!(cap.distance(&Vector3::new(1.0, 0.0, 1.0)), 0.5);
        assert_eq!(cap.distance(&Vector3::new(0.0, 0.0, 3.0)), 0.5);
        assert_eq!(cap.distance(&Vector3::new(0.0, 0.0, 1.0)), -0.5);
        let cube = Cuboid::new([0.0; 3], [1.0, 2.0, 3.0], None);
        assert_eq!(cube.distance(&Vector3::new(0.0, 0.0, 0.0)), -1.0);
        assert_eq!(cube.distance(&Vector3::new(2.0, 0.0, 0.0)), 1.0);
        assert_eq!(cube.distance(&Vector3::new(4.0, 6.0, 3.0)), 5.0);
        // Rotated 90° about z: the body x axis points along world y.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let turned = Cuboid::new([0.0; 3], [1.0, 2.0, 3.0], Some([h, 0.0, 0.0, h]));
        assert!((turned.distance(&Vector3::new(0.0, 2.0, 0.0)) - 1.0).abs() < 1e-12);
        assert!((turned.distance(&Vector3::new(3.0, 0.0, 0.0)) - 1.0).abs() < 1e-12);
    }
}
