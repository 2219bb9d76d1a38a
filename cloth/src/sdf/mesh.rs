//! The signed distance to a closed triangle mesh.
//!
//! The nearest triangle comes from a [`Bvh`] query on the point's value, and the nearest feature
//! of that triangle (its face, one of its edges or vertices) from the Voronoi regions of the
//! triangle (Ericson, *Real-Time Collision Detection*, 5.1.5). The distance to that feature is then
//! written generically over [`Real`], so gradients come from the dual machinery; the feature is
//! fixed per evaluation. The sign is the face plane's inside the face, and otherwise that of the
//! feature's angle-weighted pseudo-normal (Bærentzen and Aanæs, 2005), which is exact for a closed,
//! consistently oriented mesh.

use super::bvh::Bvh;
use super::shapes::{closest_between_segments, Surface};
use super::{lipschitz_segment_min, SegmentMin, SignedDistance, SEGMENT_TOLERANCE};
use crate::geometry::{constant, norm};
use autodiff::Real;
use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The nearest feature of a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Feature {
    /// The interior of the face.
    Face,
    /// Edge from corner `k` to corner `(k + 1) % 3`.
    Edge(usize),
    /// Corner `k`.
    Vertex(usize),
}

/// A closed, outward-oriented triangle mesh as a signed distance field.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshSdf {
    inner: Arc<MeshData>,
}

#[derive(Debug, PartialEq)]
struct MeshData {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[usize; 3]>,
    face_normals: Vec<Vector3<f64>>,
    /// Pseudo-normal of each triangle's edge `k` (corner `k` to `k + 1`).
    edge_normals: Vec<[Vector3<f64>; 3]>,
    vertex_normals: Vec<Vector3<f64>>,
    bvh: Bvh,
}

impl MeshSdf {
    /// The field of a closed, consistently oriented mesh (checked by the caller, see
    /// [`crate::ObjMesh::check_closed`]) of non-degenerate triangles. Triangles wound
    /// inwards (negative enclosed volume) are reversed.
    pub fn new(vertices: Vec<[f64; 3]>, mut triangles: Vec<[usize; 3]>) -> MeshSdf {
        let v = |i: usize| Vector3::from(vertices[i]);
        let volume: f64 = triangles
            .iter()
            .map(|&[a, b, c]| v(a).dot(&v(b).cross(&v(c))))
            .sum();
        if volume < 0.0 {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        let face_normals: Vec<Vector3<f64>> = triangles
            .iter()
            .map(|&[a, b, c]| (v(b) - v(a)).cross(&(v(c) - v(a))).normalize())
            .collect();
        let mut edge_sum: BTreeMap<[usize; 2], Vector3<f64>> = BTreeMap::new();
        let mut vertex_normals = vec![Vector3::zeros(); vertices.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *edge_sum
                    .entry([a.min(b), a.max(b)])
                    .or_insert_with(Vector3::zeros) += face_normals[t];
                let prev = tri[(k + 2) % 3];
                let (e1, e2) = ((v(b) - v(a)).normalize(), (v(prev) - v(a)).normalize());
                let angle = e1.dot(&e2).clamp(-1.0, 1.0).acos();
                vertex_normals[a] += face_normals[t] * angle;
            }
        }
        let edge_normals = triangles
            .iter()
            .map(|tri| {
                std::array::from_fn(|k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    edge_sum[&[a.min(b), a.max(b)]]
                })
            })
            .collect();
        let bvh = Bvh::new(&vertices, &triangles);
        MeshSdf {
            inner: Arc::new(MeshData {
                vertices,
                triangles,
                face_normals,
                edge_normals,
                vertex_normals,
                bvh,
            }),
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.inner.triangles.len()
    }

    /// The mesh itself (outward wound).
    pub fn surface_triangles(&self) -> Surface {
        (self.inner.vertices.clone(), self.inner.triangles.clone())
    }

    fn corner(&self, t: usize, k: usize) -> Vector3<f64> {
        Vector3::from(self.inner.vertices[self.inner.triangles[t][k]])
    }

    /// The nearest point of triangle `t` to `p` and its feature (Ericson 5.1.5).
    fn closest(&self, t: usize, p: &Vector3<f64>) -> (Vector3<f64>, Feature) {
        let (a, b, c) = (self.corner(t, 0), self.corner(t, 1), self.corner(t, 2));
        let (ab, ac, ap) = (b - a, c - a, p - a);
        let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return (a, Feature::Vertex(0));
        }
        let bp = p - b;
        let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
        if d3 >= 0.0 && d4 <= d3 {
            return (b, Feature::Vertex(1));
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return (a + ab * (d1 / (d1 - d3)), Feature::Edge(0));
        }
        let cp = p - c;
        let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
        if d6 >= 0.0 && d5 <= d6 {
            return (c, Feature::Vertex(2));
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return (a + ac * (d2 / (d2 - d6)), Feature::Edge(2));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            return (
                b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))),
                Feature::Edge(1),
            );
        }
        let denom = 1.0 / (va + vb + vc);
        (a + ab * (vb * denom) + ac * (vc * denom), Feature::Face)
    }

    /// The nearest triangle to `p` and its nearest feature, when that triangle is within
    /// `radius`; otherwise a lower bound (above `radius²`) of the squared distance.
    fn nearest_feature_within(
        &self,
        p: &Vector3<f64>,
        radius: f64,
    ) -> Result<(usize, Feature), f64> {
        let (t, _) = self.inner.bvh.nearest_within(p, radius * radius, |t| {
            (self.closest(t, p).0 - p).norm_squared()
        })?;
        Ok((t, self.closest(t, p).1))
    }

    /// The smallest distance (unsigned) between the segment `a → b` and triangle `t`, and the
    /// segment's parameter where it is attained: 0 where the segment crosses the triangle;
    /// otherwise the smallest of an end against the triangle and the segment against an edge.
    fn segment_triangle(&self, t: usize, a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, f64) {
        let corners = [self.corner(t, 0), self.corner(t, 1), self.corner(t, 2)];
        let d = b - a;
        let n = (corners[1] - corners[0]).cross(&(corners[2] - corners[0]));
        let across = d.dot(&n);
        if across != 0.0 {
            let s = (corners[0] - a).dot(&n) / across;
            if (0.0..=1.0).contains(&s) {
                let x = a + d * s;
                if (self.closest(t, &x).0 - x).norm() <= 1e-12 * (1.0 + x.norm()) {
                    return (0.0, s);
                }
            }
        }
        let mut best = ((self.closest(t, a).0 - a).norm(), 0.0);
        let end = (self.closest(t, b).0 - b).norm();
        if end < best.0 {
            best = (end, 1.0);
        }
        for k in 0..3 {
            let (p, q) = (corners[k], corners[(k + 1) % 3]);
            let (s, u) = closest_between_segments(a, b, &p, &q);
            let dist = (a + d * s - (p + (q - p) * u)).norm();
            if dist < best.0 {
                best = (dist, s);
            }
        }
        best
    }

    /// The smallest distance (unsigned) between the segment `a → b` and the mesh's surface, and
    /// the segment's parameter where it is attained: a BVH search whose boxes are bounded below
    /// by the distance between the box and the segment's bounding box, and by the midpoint's
    /// box distance less half the segment's length.
    fn segment_surface_distance(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> (f64, f64) {
        let (mid, half) = ((a + b) * 0.5, 0.5 * (b - a).norm());
        let box_lower = |min: &[f64; 3], max: &[f64; 3]| {
            let gap = |k: usize| {
                let (lo, hi) = (a[k].min(b[k]), a[k].max(b[k]));
                (min[k] - hi).max(lo - max[k]).max(0.0)
            };
            let boxes = (0..3).map(|k| gap(k).powi(2)).sum::<f64>().sqrt();
            let centre = (0..3)
                .map(|k| (min[k] - mid[k]).max(mid[k] - max[k]).max(0.0).powi(2))
                .sum::<f64>()
                .sqrt();
            boxes.max(centre - half)
        };
        match self.inner.bvh.nearest_by(f64::INFINITY, box_lower, |t| {
            self.segment_triangle(t, a, b).0
        }) {
            Ok((t, _)) => self.segment_triangle(t, a, b),
            Err(_) => (f64::INFINITY, 0.0),
        }
    }

    /// The signed distance of `p` to `feature` of triangle `t` (module docs).
    fn signed_distance_to<R: Real>(&self, p: &Vector3<R>, t: usize, feature: Feature) -> R {
        let m = &*self.inner;
        let at = |k: usize| constant::<R>(&m.vertices[m.triangles[t][k]]);
        let signed = |closest: Vector3<R>, pseudo: &Vector3<f64>| {
            let d = p - closest;
            let side = d[0].value() * pseudo.x + d[1].value() * pseudo.y + d[2].value() * pseudo.z;
            let n = norm(&d);
            if side < 0.0 {
                -n
            } else {
                n
            }
        };
        match feature {
            Feature::Face => {
                let n = m.face_normals[t];
                let d = p - at(0);
                d[0] * n.x + d[1] * n.y + d[2] * n.z
            }
            Feature::Edge(k) => {
                let (a, b) = (at(k), at((k + 1) % 3));
                let ab = b - a;
                let s = (p - a).dot(&ab) / ab.dot(&ab);
                signed(a + ab * s, &m.edge_normals[t][k])
            }
            Feature::Vertex(k) => signed(at(k), &m.vertex_normals[m.triangles[t][k]]),
        }
    }
}

impl SignedDistance for MeshSdf {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        self.distance_within(p, f64::INFINITY)
    }

    /// The search stops at `max(bound, 0)`: a point with no triangle that near and outside the
    /// mesh's bounding box is outside, and gets the search's lower bound of its distance (a
    /// constant, less `10⁻¹²` relative for rounding); inside the box, where such a point may be deep inside the mesh, the search
    /// runs again unbounded (the exact value).
    fn distance_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> R {
        let pv = Vector3::new(p[0].value(), p[1].value(), p[2].value());
        match self.nearest_feature_within(&pv, bound.max(0.0)) {
            Ok((t, feature)) => self.signed_distance_to(p, t, feature),
            Err(beyond) if !self.inner.bvh.contains(&pv) => {
                // Less a relative slack far above rounding, so it stays below the exact value.
                let lower = beyond.sqrt();
                R::cst((lower - 1e-12 * lower).max(next_above(bound)))
            }
            Err(_) => self.distance(p),
        }
    }

    /// A path that stays outside the mesh (by more than rounding) is answered exactly: its
    /// smallest distance to the surface, from a BVH search over the triangles
    /// (`segment_surface_distance`). A path that starts inside or touches the surface is
    /// searched by [`lipschitz_segment_min`]: a lower bound within [`SEGMENT_TOLERANCE`], or
    /// after its 4096 evaluations (a path running parallel to a face inside) a looser one, its
    /// `gap` saying by how much at most.
    fn segment_min(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> SegmentMin {
        let (surface, s) = self.segment_surface_distance(a, b);
        // A path that only rounding keeps off the surface (one starting on it, say) may go
        // inside: that is the Lipschitz search's case.
        let rounding = 1e-10 * (1.0 + a.norm().max(b.norm()));
        if surface > rounding && self.distance(a) > 0.0 {
            let attained = self.distance(&(a + (b - a) * s));
            return SegmentMin {
                value: surface.min(attained),
                at: s,
                attained,
            };
        }
        lipschitz_segment_min(|p| self.distance(p), a, b, SEGMENT_TOLERANCE)
    }

    /// Forward duals on [`MeshSdf::distance_within`] (as the default
    /// [`SignedDistance::distance_gradient`]).
    #[inline(always)]
    fn distance_gradient_within<R: Real>(&self, p: &Vector3<R>, bound: f64) -> (R, Vector3<R>) {
        let q = Vector3::from_fn(|k, _| autodiff::Dual::<R, 3>::variable(p[k], k));
        let d = self.distance_within(&q, bound);
        (d.re, Vector3::new(d.eps[0], d.eps[1], d.eps[2]))
    }
}

/// The smallest `f64` above `x` (`x` itself for NaN and +∞; `f64::next_up` needs Rust 1.86).
fn next_above(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        x
    } else if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sdf::shapes::Cuboid;

    #[test]
    fn a_box_mesh_matches_the_box_field() {
        let cube = Cuboid::new(
            [0.1, 0.2, 0.3],
            [0.5, 1.0, 1.5],
            Some([0.9, 0.1, 0.3, -0.2]),
        );
        let (v, t) = cube.surface_triangles();
        let mesh = MeshSdf::new(v.clone(), t.clone());
        // Inward winding is reversed.
        let flipped = MeshSdf::new(v, t.iter().map(|&[a, b, c]| [a, c, b]).collect());
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
        };
        for _ in 0..500 {
            let p = Vector3::new(next(), next(), next());
            let exact = cube.distance(&p);
            let d = mesh.distance(&p);
            // Inside, the mesh gives the distance to the nearest face: the box's field.
            assert!((d - exact).abs() < 1e-9, "at {p:?}: mesh {d}, box {exact}");
            assert_eq!(flipped.distance(&p), d);
        }
    }
}
