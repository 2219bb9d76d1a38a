//! Where the cloth passed through itself between two states: continuous collision detection of
//! every vertex–triangle and edge–edge pair (no shared vertex) along the straight motion from one
//! state to the next. A diagnostic for tests and measurements, not part of the simulation.
//!
//! A pair crosses when the four points become coplanar at some `s ∈ [0, 1]` (a root of the
//! cubic `V(s) = (p₁ − p₀) × (p₂ − p₀) · (p₃ − p₀)`) and at that instant the vertex lies in the
//! triangle, or the two edges intersect (closest points within `1e−9` of the pair's size, both
//! interior to their segments). Roots are found on the cubic's monotone pieces by bisection, so
//! a tangency (a double root) is not counted. Pairs are found by their swept bounding boxes in a
//! uniform grid.

use crate::mesh::ClothMesh;
use autodiff::Tensor;
use nalgebra::Vector3;
use std::collections::{BTreeSet, HashMap};

/// The crossings of one motion, as pairs of particle indices.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Crossings {
    /// `(vertex, triangle index)`: a vertex passed through a triangle's interior.
    pub vertex_triangle: Vec<(usize, usize)>,
    /// `((a, b), (c, d))`: edge `ab` passed through edge `cd`.
    pub edge_edge: Vec<([usize; 2], [usize; 2])>,
}

/// The edges of a cloth of `n` particles joined by `triangles`, each once
/// ([`ClothMesh::stretch_edges`]).
fn mesh_edges(n: usize, triangles: &[[usize; 3]]) -> Vec<[usize; 2]> {
    ClothMesh::from_triangles(n, triangles.to_vec()).stretch_edges()
}

/// The crossings of the cloth (`triangles`) moving straight from `x0` to `x1` (`N × 3` each).
pub fn crossings(triangles: &[[usize; 3]], x0: &Tensor, x1: &Tensor) -> Crossings {
    let p = |x: &Tensor, i: usize| Vector3::new(x.get(i, 0), x.get(i, 1), x.get(i, 2));
    let motion = |i: usize| (p(x0, i), p(x1, i));
    let edges = mesh_edges(x0.rows(), triangles);
    let mut out = Crossings::default();
    // Vertex–triangle: every vertex against every triangle whose swept box meets its own.
    let boxes_t: Vec<_> = triangles.iter().map(|t| swept_box(t, &motion)).collect();
    let vertex_boxes: Vec<_> = (0..x0.rows()).map(|v| swept_box(&[v], &motion)).collect();
    for (v, t) in overlapping(&vertex_boxes, &boxes_t) {
        let tri = triangles[t];
        if tri.contains(&v) {
            continue;
        }
        let m = [v, tri[0], tri[1], tri[2]].map(motion);
        if vertex_triangle_crosses(&m) {
            out.vertex_triangle.push((v, t));
        }
    }
    // Edge–edge: pairs without a shared vertex, each once.
    let boxes_e: Vec<_> = edges.iter().map(|e| swept_box(e, &motion)).collect();
    for (i, j) in overlapping(&boxes_e, &boxes_e) {
        let (e, f) = (edges[i], edges[j]);
        if i >= j || e.iter().any(|a| f.contains(a)) {
            continue;
        }
        let m = [e[0], e[1], f[0], f[1]].map(motion);
        if edge_edge_crosses(&m) {
            out.edge_edge.push((e, f));
        }
    }
    out
}

/// The places where the cloth (`triangles`) at state `x` passes through itself: every edge
/// that pierces a triangle it shares no vertex with (the segment meets the triangle's interior),
/// as `(edge, triangle index)`. A path-independent count: a cloth that started without any has
/// since passed through itself, whatever the motion in between.
pub fn intersections(triangles: &[[usize; 3]], x: &Tensor) -> Vec<([usize; 2], usize)> {
    let p = |i: usize| Vector3::new(x.get(i, 0), x.get(i, 1), x.get(i, 2));
    let still = |i: usize| (p(i), p(i));
    let edges = mesh_edges(x.rows(), triangles);
    let boxes_e: Vec<_> = edges.iter().map(|e| swept_box(e, &still)).collect();
    let boxes_t: Vec<_> = triangles.iter().map(|t| swept_box(t, &still)).collect();
    let mut out = Vec::new();
    for (i, t) in overlapping(&boxes_e, &boxes_t) {
        let (e, tri) = (edges[i], triangles[t]);
        if e.iter().any(|a| tri.contains(a)) {
            continue;
        }
        let (a, b) = (p(e[0]), p(e[1]));
        let [q0, q1, q2] = tri.map(p);
        let n = (q1 - q0).cross(&(q2 - q0));
        let (da, db) = ((a - q0).dot(&n), (b - q0).dot(&n));
        // The ends on opposite sides of the plane (false for NaN as well).
        if da * db >= 0.0 || (da * db).is_nan() {
            continue;
        }
        let hit = a + (b - a) * (da / (da - db));
        let side = |u: &Vector3<f64>, v: &Vector3<f64>| (v - u).cross(&(hit - u)).dot(&n);
        if side(&q0, &q1) > 0.0 && side(&q1, &q2) > 0.0 && side(&q2, &q0) > 0.0 {
            out.push((e, t));
        }
    }
    out
}

type Motion = (Vector3<f64>, Vector3<f64>);
type Aabb = (Vector3<f64>, Vector3<f64>);

/// The box around the points' start and end positions.
fn swept_box(points: &[usize], motion: &impl Fn(usize) -> Motion) -> Aabb {
    let mut b = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for &i in points {
        let (a, c) = motion(i);
        b.0 = b.0.inf(&a).inf(&c);
        b.1 = b.1.sup(&a).sup(&c);
    }
    b
}

/// Every `(i, j)` with `a[i]` and `b[j]` overlapping, sorted: `b` bucketed in a uniform grid of
/// the mean box size, each `a` box querying the cells it touches.
fn overlapping(a: &[Aabb], b: &[Aabb]) -> Vec<(usize, usize)> {
    let finite = |x: &Aabb| x.0.iter().chain(x.1.iter()).all(|c| c.is_finite());
    let size = b
        .iter()
        .filter(|x| finite(x))
        .map(|x| (x.1 - x.0).max())
        .sum::<f64>()
        / b.len().max(1) as f64;
    let cell = if size > 0.0 { size } else { 1.0 };
    let key = |v: &Vector3<f64>| v.map(|c| (c / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (j, x) in b.iter().enumerate().filter(|(_, x)| finite(x)) {
        let (lo, hi) = (key(&x.0), key(&x.1));
        for k0 in lo.x..=hi.x {
            for k1 in lo.y..=hi.y {
                for k2 in lo.z..=hi.z {
                    grid.entry([k0, k1, k2]).or_default().push(j);
                }
            }
        }
    }
    let meets = |x: &Aabb, y: &Aabb| (0..3).all(|k| x.0[k] <= y.1[k] && y.0[k] <= x.1[k]);
    let mut pairs = BTreeSet::new();
    for (i, x) in a.iter().enumerate().filter(|(_, x)| finite(x)) {
        let (lo, hi) = (key(&x.0), key(&x.1));
        for k0 in lo.x..=hi.x {
            for k1 in lo.y..=hi.y {
                for k2 in lo.z..=hi.z {
                    for &j in grid.get(&[k0, k1, k2]).into_iter().flatten() {
                        if meets(x, &b[j]) {
                            pairs.insert((i, j));
                        }
                    }
                }
            }
        }
    }
    pairs.into_iter().collect()
}

/// The four points at time `s` of their straight motion.
fn at(m: &[Motion; 4], s: f64) -> [Vector3<f64>; 4] {
    m.map(|(a, b)| a + (b - a) * s)
}

/// The signed volume `(p₁ − p₀) × (p₂ − p₀) · (p₃ − p₀)`.
fn volume(p: &[Vector3<f64>; 4]) -> f64 {
    (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&(p[3] - p[0]))
}

/// The times in `[0, 1]` where the four moving points are coplanar (simple roots of the cubic
/// volume, from its values at `0, ⅓, ⅔, 1`).
fn coplanar_times(m: &[Motion; 4]) -> Vec<f64> {
    let v = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].map(|s| volume(&at(m, s)));
    // Points that stay coplanar (moving within one plane) never pass through each other's
    // plane: no crossing, whatever rounding makes of the volume.
    let scale = m
        .iter()
        .flat_map(|(a, b)| [a - m[0].0, b - m[0].1])
        .map(|d| d.norm())
        .fold(0.0, f64::max);
    if v.iter().all(|x| x.abs() <= 1e-12 * scale.powi(3)) {
        return Vec::new();
    }
    // V(s) = c0 + c1 s + c2 s² + c3 s³ through the four samples (Newton's divided differences).
    let h = 1.0 / 3.0;
    let d1 = [(v[1] - v[0]) / h, (v[2] - v[1]) / h, (v[3] - v[2]) / h];
    let d2 = [(d1[1] - d1[0]) / (2.0 * h), (d1[2] - d1[1]) / (2.0 * h)];
    let d3 = (d2[1] - d2[0]) / (3.0 * h);
    let (x1, x2) = (h, 2.0 * h);
    let c3 = d3;
    let c2 = d2[0] - d3 * (x1 + x2);
    let c1 = d1[0] - d2[0] * x1 + d3 * x1 * x2;
    let c0 = v[0];
    let f = |s: f64| ((c3 * s + c2) * s + c1) * s + c0;
    // Split [0, 1] where V' = c1 + 2 c2 s + 3 c3 s² vanishes: V is monotone on each piece.
    let mut cuts = vec![0.0, 1.0];
    let (a, b, c) = (3.0 * c3, 2.0 * c2, c1);
    if a.abs() > 0.0 {
        let disc = b * b - 4.0 * a * c;
        if disc > 0.0 {
            let r = disc.sqrt();
            cuts.extend([(-b - r) / (2.0 * a), (-b + r) / (2.0 * a)]);
        }
    } else if b.abs() > 0.0 {
        cuts.push(-c / b);
    }
    cuts.retain(|s| (0.0..=1.0).contains(s));
    cuts.sort_by(f64::total_cmp);
    let mut roots = Vec::new();
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (flo, fhi) = (f(lo), f(hi));
        if flo == 0.0 {
            roots.push(lo);
            continue;
        }
        if flo.signum() == fhi.signum() {
            continue;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if f(mid).signum() == flo.signum() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        roots.push(0.5 * (lo + hi));
    }
    if f(1.0) == 0.0 {
        roots.push(1.0);
    }
    roots.dedup();
    roots
}

/// Whether vertex `m[0]` passes through the triangle `m[1..4]`'s interior.
fn vertex_triangle_crosses(m: &[Motion; 4]) -> bool {
    coplanar_times(m).into_iter().any(|s| {
        let p = at(m, s);
        let n = (p[2] - p[1]).cross(&(p[3] - p[1]));
        let side = |a: &Vector3<f64>, b: &Vector3<f64>| (b - a).cross(&(p[0] - a)).dot(&n);
        let inside = [side(&p[1], &p[2]), side(&p[2], &p[3]), side(&p[3], &p[1])];
        n.norm() > 0.0 && inside.iter().all(|&d| d > 0.0)
    })
}

/// Whether edge `m[0]m[1]` passes through edge `m[2]m[3]`.
fn edge_edge_crosses(m: &[Motion; 4]) -> bool {
    coplanar_times(m).into_iter().any(|s| {
        let p = at(m, s);
        let (d1, d2, r) = (p[1] - p[0], p[3] - p[2], p[0] - p[2]);
        let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
        let (b, c) = (d1.dot(&d2), d1.dot(&r));
        let denom = a * e - b * b;
        if !(a > 0.0 && e > 0.0 && denom > 1e-12 * a * e) {
            return false; // degenerate or parallel edges
        }
        let u = (b * f - c * e) / denom;
        let w = (a * f - b * c) / denom;
        let gap = (p[0] + d1 * u - (p[2] + d2 * w)).norm();
        u > 0.0 && u < 1.0 && w > 0.0 && w < 1.0 && gap <= 1e-9 * (a.sqrt() + e.sqrt())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(points: &[[f64; 3]]) -> Tensor {
        Tensor::new(points.len(), 3, points.iter().flatten().copied().collect())
    }

    #[test]
    fn an_edge_moving_through_another_crosses_once() {
        // Edge 0–1 along x at z = 0.1 moving to z = −0.1 through edge 2–3 along y at z = 0.
        let tris = [[0, 1, 4], [2, 3, 5]];
        let before = [
            [-1.0, 0.0, 0.1],
            [1.0, 0.0, 0.1],
            [0.0, -1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 5.0],
            [5.0, 0.0, 0.0],
        ];
        let mut after = before;
        after[0][2] = -0.1;
        after[1][2] = -0.1;
        after[4][2] = 4.8;
        let c = crossings(&tris, &state(&before), &state(&after));
        assert_eq!(c.edge_edge, vec![([0, 1], [2, 3])]);
        // Moved beside the other edge instead (x shifted past its end): none.
        for p in &mut after[..2] {
            p[1] = 2.0;
        }
        let c = crossings(&tris, &state(&before), &state(&after));
        assert!(c.edge_edge.iter().all(|&(e, f)| (e, f) != ([0, 1], [2, 3])));
    }

    #[test]
    fn a_vertex_moving_through_a_triangle_crosses() {
        let tris = [[1, 2, 3], [0, 4, 5]];
        let before = [
            [0.2, 0.2, 0.5],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.3, 0.2, 1.0],
            [0.2, 0.3, 1.0],
        ];
        let mut after = before;
        after[0][2] = -0.5;
        let c = crossings(&tris, &state(&before), &state(&after));
        assert_eq!(c.vertex_triangle, vec![(0, 0)]);
        assert!(crossings(&tris, &state(&before), &state(&before))
            .vertex_triangle
            .is_empty());
    }
}
