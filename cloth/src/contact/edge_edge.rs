//! Edge–edge self-contacts (`physics.self_collision.edge_edge`): where two parts of the cloth
//! cross edge-on, no vertex need come near the other part's triangles, so the vertex–triangle
//! contacts of [`crate::contact::self_collision`] let one edge pass through the other. These
//! rows hold the two edges' lines apart.
//!
//! # The constraint
//! For edges `p₀p₁` and `p₂p₃` with `n̂` the unit normal of `(p₁ − p₀) × (p₃ − p₂)`,
//! [`EdgeEdge`] is `C = s · (p₂ − p₀)·n̂ − h ≥ 0`: the distance between the two lines, on the side
//! `s = ±1` they were on at the step's start (`+1` when they met), at least the thickness `h`.
//! It is written once, generically; a closed-form `∇C` (the same as the vertex–triangle one,
//! [`crate::contact::self_collision::normal_offset`]) overrides the dual one, and
//! `tests/overrides.rs` checks it against the generic path. Parallel edges have no
//! normal: there `C = −h` with gradient 0, which the projection leaves alone.
//!
//! # Which pairs
//! At the start of each step, with the vertex–triangle search's query radius `r`, a pair of edges
//! `e = p₀p₁`, `f = p₂p₃` is listed (once, the edge of lower index first) when
//! - no vertex of `f` is in the 1-ring of a vertex of `e` (as for vertex–triangle pairs: edges
//!   that close along the cloth follow its bending, not its contact);
//! - the edges are not parallel, and the closest points of their lines lie within both segments
//!   (ends included): the analog of a vertex projecting inside a triangle;
//! - the lines are at most `r` apart;
//! - the closest point on one edge's line projects, onto the plane of a (non-degenerate)
//!   triangle of the other edge, inside that triangle (edges included, and within `h` outside an
//!   edge on the cloth's border): the partner passes over the triangles beside the edge, as a
//!   vertex over a triangle;
//! - not every one of the four vertices is already held by a vertex–triangle pair of the step
//!   (two stacked layers, where every vertex faces a triangle of the other, need no edge rows);
//! - at least one of the four particles can move.
//!
//! The broad phase is a uniform grid of the edges' boxes, queried for each triangle with the box
//! of its candidate region (as for vertex–triangle pairs: the triangle, grown by `h` across its
//! border edges, swept `±r` along its normal), which a partner's closest point lies in. Like the vertex–triangle set, the pairs are fixed within a
//! step and a pure function of its starting state and controls; gradients are those of each
//! step's active set.

use crate::constraint::Constraint;
use crate::contact::grid::{Aabb, BoxGrid};
use crate::contact::self_collision::{
    contact_projection_sets, normal_offset, side_offset, ContactPair, SelfCollision,
};
use crate::geometry::{point, write_points};
use crate::xpbd::set::ProjectionSet;
use autodiff::{Real, Tensor};
use nalgebra::Vector3;
use std::sync::Arc;

/// `C = s·(p₂ − p₀)·n̂ − h ≥ 0`, `n̂ = unit((p₁ − p₀) × (p₃ − p₂))`: the lines of edges `p₀p₁`
/// and `p₂p₃` at least `h` apart, on side `s` (see the module docs).
#[derive(Clone, Debug)]
pub struct EdgeEdge {
    /// The side `s = ±1` per instance.
    pub sides: Vec<f64>,
    /// The thickness `h ≥ 0`.
    pub thickness: f64,
}

impl Constraint for EdgeEdge {
    const ARITY: usize = 4;
    const INEQUALITY: bool = true;
    #[inline(always)]
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        let (d, e1, e2) = (p[2] - p[0], p[1] - p[0], p[3] - p[2]);
        side_offset(d, e1, e2, self.sides[instance], self.thickness)
    }

    /// `∇C` in closed form: [`normal_offset`] of `d = p₂ − p₀` along `e₁ × e₂`
    /// (`e₁ = p₁ − p₀`, `e₂ = p₃ − p₂`): `∇₀ = −s(∂q/∂d + ∂q/∂e₁)`, `∇₁ = s ∂q/∂e₁`,
    /// `∇₂ = s(∂q/∂d − ∂q/∂e₂)`, `∇₃ = s ∂q/∂e₂`.
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let (p0, p2) = (point(x, 0), point(x, 2));
        let (e1, e2) = (point(x, 1) - p0, point(x, 3) - p2);
        let Some(off) = normal_offset(p2 - p0, e1, e2) else {
            g[..12].fill(R::zero());
            return R::cst(-self.thickness);
        };
        let s = R::cst(self.sides[instance]);
        let g1 = off.d_e1 * s;
        let g3 = off.d_e2 * s;
        let g2 = off.d_d * s - g3;
        let g0 = -(g1 + g2 + g3);
        write_points(g, [g0, g1, g2, g3]);
        off.q * s - self.thickness
    }
}

/// One edge–edge contact of a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgePair {
    /// The first edge (particle indices), of the lower index in the cloth's edge list.
    pub first: [usize; 2],
    /// The second edge.
    pub second: [usize; 2],
    /// Whether `(p₂ − p₀)·((p₁ − p₀) × (p₃ − p₂)) ≥ 0` at the step's start (the side `s = +1`).
    pub above: bool,
}

/// Where the lines of `ab` and `cd` come closest: `(u, w)` with the closest points
/// `a + u(b − a)` and `c + w(d − c)`, or `None` for parallel (or degenerate) edges.
fn closest_parameters(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
    d: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let (d1, d2, r) = (b - a, d - c, a - c);
    let (aa, bb, ee) = (d1.dot(&d1), d1.dot(&d2), d2.dot(&d2));
    let (cc, ff) = (d1.dot(&r), d2.dot(&r));
    let denom = aa * ee - bb * bb;
    if !(denom > 0.0 && denom.is_finite()) || d1.cross(&d2).norm_squared() == 0.0 {
        return None;
    }
    Some(((bb * ff - cc * ee) / denom, (aa * ff - bb * cc) / denom))
}

impl SelfCollision {
    /// The edge–edge pairs of a step that starts from `x` (`N × 3`), within query radius `radius`,
    /// given the step's vertex–triangle pairs `held` (see the module docs); sorted, each once.
    pub fn find_edge_pairs(
        &self,
        x: &Tensor,
        radius: f64,
        inv_mass: &[f64],
        held: &[ContactPair],
    ) -> Vec<EdgePair> {
        let p = |i: usize| {
            let r = x.row(i);
            Vector3::new(r[0], r[1], r[2])
        };
        let Some((tris, cell)) = self.triangle_normals(x) else {
            return Vec::new();
        };
        if !(radius >= 0.0 && radius.is_finite()) {
            return Vec::new();
        }
        let mut is_held = vec![false; x.rows()];
        for c in held {
            is_held[c.vertex] = true;
        }
        let boxes: Vec<Aabb> = self
            .edges
            .iter()
            .map(|&[a, b]| (p(a).inf(&p(b)), p(a).sup(&p(b))))
            .collect();
        let grid = BoxGrid::new(&boxes, cell);
        let h = self.thickness;
        let mut pairs = Vec::new();
        let mut candidates = Vec::new();
        // The last triangle that listed each edge (an edge spanning several cells is listed once).
        let mut seen = vec![usize::MAX; self.edges.len()];
        for &(k, n) in &tris {
            let corners = self.triangles[k].map(p);
            let (lo, hi) = self.query_box(corners, &n, k, radius);
            let margin = self.border[k].map(|b| if b { h } else { 0.0 });
            candidates.clear();
            grid.candidates(&lo, &hi, &mut candidates);
            // A point's height over the triangle's plane, and how far inside each edge's line its
            // projection lies (negative outside).
            let inward: [Vector3<f64>; 3] =
                std::array::from_fn(|j| n.cross(&(corners[(j + 1) % 3] - corners[j])).normalize());
            let height = |q: &Vector3<f64>| (q - corners[0]).dot(&n);
            let inside = |q: &Vector3<f64>| {
                [
                    (q - corners[0]).dot(&inward[0]),
                    (q - corners[1]).dot(&inward[1]),
                    (q - corners[2]).dot(&inward[2]),
                ]
            };
            for &fi in &candidates {
                if std::mem::replace(&mut seen[fi], k) == k {
                    continue;
                }
                // The partner's closest point lies in the candidate region, so its box meets the
                // region's box, and some point of the segment lies within `radius` of the plane
                // and over the triangle grown by `h` (cheapest tests first).
                let (blo, bhi) = &boxes[fi];
                if (0..3).any(|j| blo[j] > hi[j] || bhi[j] < lo[j]) {
                    continue;
                }
                let f = self.edges[fi];
                let (pc, pd) = (p(f[0]), p(f[1]));
                let (hc, hd) = (height(&pc), height(&pd));
                if hc.min(hd) > radius || hc.max(hd) < -radius {
                    continue;
                }
                let (ic, id) = (inside(&pc), inside(&pd));
                if (0..3).any(|j| ic[j].max(id[j]) < -margin[j]) {
                    continue;
                }
                for &ei in &self.triangle_edges[k] {
                    let e = self.edges[ei];
                    // Edges within one edge of each other along the cloth (the commonest
                    // candidates: the triangle's neighbours) before any geometry.
                    if ei == fi
                        || f.iter()
                            .any(|&v| self.in_ring(e[0], v) || self.in_ring(e[1], v))
                    {
                        continue;
                    }
                    let (a, b, c0, d) = (p(e[0]), p(e[1]), p(f[0]), p(f[1]));
                    let Some((u, w)) = closest_parameters(&a, &b, &c0, &d) else {
                        continue;
                    };
                    if !((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&w)) {
                        continue;
                    }
                    let q = c0 + (d - c0) * w;
                    let n_ef = (b - a).cross(&(d - c0));
                    let iq = inside(&q);
                    if (c0 - a).dot(&n_ef).abs() > radius * n_ef.norm()
                        || (0..3).any(|j| iq[j] < -margin[j])
                    {
                        continue;
                    }
                    let four = [e[0], e[1], f[0], f[1]];
                    if four.iter().all(|&v| is_held[v]) || four.iter().all(|&v| inv_mass[v] == 0.0)
                    {
                        continue;
                    }
                    pairs.push((ei.min(fi), ei.max(fi)));
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        pairs
            .into_iter()
            .map(|(ei, fi)| {
                let (e, f) = (self.edges[ei], self.edges[fi]);
                let (a, c) = (p(e[0]), p(f[0]));
                let side = (c - a).dot(&(p(e[1]) - a).cross(&(p(f[1]) - c)));
                EdgePair {
                    first: e,
                    second: f,
                    above: side >= 0.0,
                }
            })
            .collect()
    }

    /// The colour sets projecting edge–edge `pairs` (greedy in pair order), each row
    /// `[first edge…, second edge…]`.
    pub fn edge_projection_sets(&self, pairs: &[EdgePair], inv_mass: &[f64]) -> Vec<ProjectionSet> {
        if pairs.is_empty() {
            return Vec::new();
        }
        let rows: Vec<[usize; 4]> = pairs
            .iter()
            .map(|c| [c.first[0], c.first[1], c.second[0], c.second[1]])
            .collect();
        let constraint = Arc::new(EdgeEdge {
            sides: pairs
                .iter()
                .map(|c| if c.above { 1.0 } else { -1.0 })
                .collect(),
            thickness: self.thickness,
        });
        contact_projection_sets(constraint, &rows, inv_mass)
    }
}
