//! Self-collision of the cloth (`physics.self_collision`): vertex–triangle contacts found at the
//! start of every step and projected as rigid inequality constraints during its sweeps.
//!
//! # The constraint
//! For a vertex `p₀` and a triangle `(p₁, p₂, p₃)`, with `n̂` the unit normal of the triangle
//! (`(p₂ − p₁) × (p₃ − p₁)` normalised), [`VertexTriangle`] is
//! `C = s · (p₀ − p₁)·n̂ − h ≥ 0`, where `h` is the thickness and `s = ±1` the side of the
//! triangle's plane the vertex was on at the step's start (`+1` when it lay exactly on the plane).
//! It is written once, generically (its derivatives could all come from forward duals, like a
//! user constraint's); a closed-form `∇C` overrides the dual one for speed, and `∇²C·v` is the
//! forward-dual derivative of that closed form (`tests/self_collision.rs` checks both against the
//! generic path). A triangle that has collapsed to zero area has no normal: there `C = −h` with
//! gradient 0, which the projection leaves alone.
//!
//! # Which pairs
//! At the start of each step (from the state `x_prev` before gravity and the controls act),
//! [`SelfCollision::find_pairs`] lists every vertex–triangle pair such that
//! - the triangle has none of the vertex's *1-ring* (the vertex itself and every vertex that
//!   shares a triangle edge with it): triangles that close to the vertex along the cloth follow
//!   its bending, not its contact, and on a curved cloth they lie within `h` of it;
//! - the triangle is not degenerate (its normal is defined);
//! - the vertex's distance to the triangle's plane is at most the query radius
//!   `r = h + 2δ`, with `δ = max_k |u_k| + |½gΔt²|` the step's largest control displacement plus
//!   the gravity step (the assumption: no particle moves farther in one step than the fastest
//!   gripper plus one free-fall step, so vertex and triangle approach each other by at most `2δ`);
//! - the vertex's projection onto the plane falls inside the triangle, edges included, and
//!   within `h` outside an edge on the cloth's border (so a vertex at the border of one layer
//!   cannot slip off the border of the other, where no neighbouring triangle takes over);
//! - at least one of the four particles can move (not all are controls).
//!
//! The search is a uniform grid of the vertices (cells of the mean triangle extent, fewer when
//! that would make more than eight cells per vertex) queried with the bounding box of each
//! triangle's candidate region: the triangle, grown by `h` across its border edges, swept `±r`
//! along its normal. Pairs are listed by vertex, then triangle.
//!
//! # Within a step
//! The contact set is fixed within a step: the pairs are coloured greedily in pair order into
//! independent sets ([`crate::coloring`]), projected after the model's own colour sets in every
//! iteration, with `λ` reset each step. The search is a pure function of the step's starting state
//! and controls, so the recorded (gradient) path rebuilds exactly the forward's set for a step, and
//! results are bitwise identical for any thread count. **Gradients are those of each step's active
//! set**: the pair search itself is not differentiated (a pair that appears or disappears between
//! two control choices is a discontinuity the gradient does not see). A vertex that slides past a
//! triangle's edge within a step is still held off the triangle's (extended) plane until the step
//! ends. Choose `h` below the cloth's edge length.

use crate::constraint::Constraint;
use crate::contact::grid::BoxGrid;
use crate::geometry::{norm, point, write_points};
use crate::mesh::ClothMesh;
use crate::xpbd::coloring::{greedy_coloring, independent_sets};
use crate::xpbd::projection::Projection;
use crate::xpbd::set::{Carry, ProjectionSet};
use autodiff::{Real, RowIndex, Tensor};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::sync::Arc;

/// `C = s·(p₀ − p₁)·n̂ − h ≥ 0`: vertex `p₀` at least `h` from the plane of triangle
/// `(p₁, p₂, p₃)`, on side `s` (see the module docs).
#[derive(Clone, Debug)]
pub struct VertexTriangle {
    /// The side `s = ±1` per instance.
    pub sides: Vec<f64>,
    /// The thickness `h ≥ 0`.
    pub thickness: f64,
}

impl Constraint for VertexTriangle {
    const ARITY: usize = 4;
    const INEQUALITY: bool = true;
    #[inline(always)]
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        let (d, e1, e2) = (p[0] - p[1], p[2] - p[1], p[3] - p[1]);
        side_offset(d, e1, e2, self.sides[instance], self.thickness)
    }

    /// `∇C` in closed form ([`normal_offset`] of `d = p₀ − p₁` along `e₁ × e₂`, `e₁ = p₂ − p₁`,
    /// `e₂ = p₃ − p₁`): `∇₀ = s ∂q/∂d`, `∇₂ = s ∂q/∂e₁`, `∇₃ = s ∂q/∂e₂`,
    /// `∇₁ = −(∇₀ + ∇₂ + ∇₃)`.
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let p1 = point(x, 1);
        let (e1, e2) = (point(x, 2) - p1, point(x, 3) - p1);
        let Some(off) = normal_offset(point(x, 0) - p1, e1, e2) else {
            g[..12].fill(R::zero());
            return R::cst(-self.thickness);
        };
        let s = R::cst(self.sides[instance]);
        let g0 = off.d_d * s;
        let g2 = off.d_e1 * s;
        let g3 = off.d_e2 * s;
        let g1 = -(g0 + g2 + g3);
        write_points(g, [g0, g1, g2, g3]);
        off.q * s - self.thickness
    }
}

/// `s·(d·n̂) − h` with `n̂` the unit normal of `e₁ × e₂`, or `−h` where `e₁ × e₂ = 0` (no
/// normal): the generic `C` of both self-contact constraints ([`VertexTriangle`] and
/// [`crate::contact::edge_edge::EdgeEdge`]).
#[inline(always)]
pub(crate) fn side_offset<R: Real>(
    d: Vector3<R>,
    e1: Vector3<R>,
    e2: Vector3<R>,
    side: f64,
    h: f64,
) -> R {
    let n = e1.cross(&e2);
    let len = norm(&n);
    if len.value() == 0.0 {
        return R::cst(-h);
    }
    d.dot(&(n * len.recip())) * side - h
}

/// The offset `q = d·n̂` of a vector `d` along the unit normal `n̂ = n/|n|` of `n = e₁ × e₂`, with
/// its gradients ([`normal_offset`]).
pub(crate) struct NormalOffset<R> {
    /// `q`.
    pub(crate) q: R,
    /// `∂q/∂d = n̂`.
    pub(crate) d_d: Vector3<R>,
    /// `∂q/∂e₁ = e₂ × m`, with `m = (d − q n̂)/|n|` the gradient of `q` in `n`.
    pub(crate) d_e1: Vector3<R>,
    /// `∂q/∂e₂ = m × e₁`.
    pub(crate) d_e2: Vector3<R>,
}

/// [`NormalOffset`] of `d` along `e₁ × e₂`, or `None` when `e₁ × e₂ = 0` (no normal). The
/// closed form of both self-contact constraints: a vertex's height over a triangle's plane
/// ([`VertexTriangle`]) and the distance between two edges' lines
/// ([`crate::contact::edge_edge::EdgeEdge`]).
#[inline(always)]
pub(crate) fn normal_offset<R: Real>(
    d: Vector3<R>,
    e1: Vector3<R>,
    e2: Vector3<R>,
) -> Option<NormalOffset<R>> {
    let n = e1.cross(&e2);
    let len = norm(&n);
    if len.value() == 0.0 {
        return None;
    }
    let inv = len.recip();
    let unit = n * inv;
    let q = d.dot(&unit);
    let m = (d - unit * q) * inv;
    Some(NormalOffset {
        q,
        d_d: unit,
        d_e1: e2.cross(&m),
        d_e2: m.cross(&e1),
    })
}

/// A non-degenerate triangle of a state (its index) with its unit normal.
pub(crate) type TriangleNormal = (usize, Vector3<f64>);

/// One vertex–triangle contact of a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContactPair {
    /// The vertex (particle index).
    pub vertex: usize,
    /// The triangle (index into the cloth's triangles).
    pub triangle: usize,
    /// Whether the vertex was on the side the triangle's normal points to (or on the plane).
    pub above: bool,
}

/// A model's self-collision: the thickness and the cloth's topology the pair searches need.
#[derive(Clone, Debug)]
pub struct SelfCollision {
    /// The thickness `h ≥ 0`.
    pub thickness: f64,
    /// Whether edge–edge contacts are added to the vertex–triangle ones
    /// ([`crate::contact::edge_edge`]).
    pub edge_edge: bool,
    pub(crate) triangles: Arc<[[usize; 3]]>,
    /// The cloth's edges ([`ClothMesh::stretch_edges`]), and each triangle's three (indices).
    pub(crate) edges: Vec<[usize; 2]>,
    pub(crate) triangle_edges: Vec<[usize; 3]>,
    /// Per triangle, whether each edge (`ab`, `bc`, `ca`) lies on the cloth's border (one
    /// triangle uses it).
    pub(crate) border: Vec<[bool; 3]>,
    /// Each vertex's 1-ring (itself and its edge neighbours), sorted: `ring[ring_start[v]..ring_start[v + 1]]`.
    ring_start: Vec<usize>,
    ring: Vec<usize>,
}

impl SelfCollision {
    /// Self-collision of thickness `h` on a cloth of `n_particles` with these triangles
    /// (vertex–triangle contacts; [`SelfCollision::with_edge_edge`] adds edge–edge ones).
    pub fn new(thickness: f64, triangles: Arc<[[usize; 3]]>, n_particles: usize) -> Self {
        let mut rings: Vec<Vec<usize>> = (0..n_particles).map(|v| vec![v]).collect();
        for t in triangles.iter() {
            for &a in t {
                rings[a].extend(t.iter().copied().filter(|&b| b != a));
            }
        }
        let mut ring_start = Vec::with_capacity(n_particles + 1);
        let mut ring = Vec::new();
        for mut r in rings {
            r.sort_unstable();
            r.dedup();
            ring_start.push(ring.len());
            ring.extend(r);
        }
        ring_start.push(ring.len());
        let edge = |a: usize, b: usize| (a.min(b), a.max(b));
        let mut uses: HashMap<(usize, usize), usize> = HashMap::new();
        for &[a, b, c] in triangles.iter() {
            for e in [edge(a, b), edge(b, c), edge(c, a)] {
                *uses.entry(e).or_default() += 1;
            }
        }
        let border = triangles
            .iter()
            .map(|&[a, b, c]| [edge(a, b), edge(b, c), edge(c, a)].map(|e| uses[&e] == 1))
            .collect();
        let edges = ClothMesh::from_triangles(n_particles, triangles.to_vec()).stretch_edges();
        let index: HashMap<(usize, usize), usize> = edges
            .iter()
            .enumerate()
            .map(|(i, &[a, b])| ((a, b), i))
            .collect();
        let triangle_edges = triangles
            .iter()
            .map(|&[a, b, c]| [edge(a, b), edge(b, c), edge(c, a)].map(|e| index[&e]))
            .collect();
        SelfCollision {
            thickness,
            edge_edge: false,
            triangles,
            edges,
            triangle_edges,
            border,
            ring_start,
            ring,
        }
    }

    /// The same with edge–edge contacts when `on` ([`crate::contact::edge_edge`]).
    pub fn with_edge_edge(mut self, on: bool) -> Self {
        self.edge_edge = on;
        self
    }

    /// Whether `q` is in `v`'s 1-ring (`v` itself or an edge neighbour).
    pub(crate) fn in_ring(&self, v: usize, q: usize) -> bool {
        self.ring[self.ring_start[v]..self.ring_start[v + 1]]
            .binary_search(&q)
            .is_ok()
    }

    /// The non-degenerate triangles of state `x` with their unit normals, and their mean extent
    /// (the grid's cell); `None` when there is none.
    pub(crate) fn triangle_normals(&self, x: &Tensor) -> Option<(Vec<TriangleNormal>, f64)> {
        let point = |p: usize| {
            let r = x.row(p);
            Vector3::new(r[0], r[1], r[2])
        };
        let mut tris = Vec::with_capacity(self.triangles.len());
        let mut extent_sum = 0.0;
        for (k, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = t.map(point);
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            extent_sum += (a.sup(&b).sup(&c) - a.inf(&b).inf(&c)).max();
            tris.push((k, n / len));
        }
        let cell = extent_sum / tris.len().max(1) as f64;
        (!tris.is_empty()).then_some((tris, cell))
    }

    /// Whether the pair search skips triangle `triangle` for `vertex`: the triangle has a vertex
    /// of `vertex`'s 1-ring.
    pub fn excludes(&self, vertex: usize, triangle: usize) -> bool {
        self.triangles[triangle]
            .iter()
            .any(|&q| self.in_ring(vertex, q))
    }

    /// The contact pairs of a step that starts from `x` (`N × 3`), within query radius `radius`
    /// (see the module docs), by vertex then triangle. `inv_mass` skips pairs that cannot move.
    pub fn find_pairs(&self, x: &Tensor, radius: f64, inv_mass: &[f64]) -> Vec<ContactPair> {
        let point = |p: usize| {
            let r = x.row(p);
            Vector3::new(r[0], r[1], r[2])
        };
        // Non-degenerate triangles with their unit normals.
        let Some((tris, cell)) = self.triangle_normals(x) else {
            return Vec::new();
        };
        if !(radius >= 0.0 && radius.is_finite()) {
            return Vec::new();
        }
        let grid = BoxGrid::of_points(x, cell);
        let mut pairs = Vec::new();
        let mut candidates = Vec::new();
        for &(k, n) in &tris {
            let tri = self.triangles[k];
            let (lo, hi) = self.query_box(tri.map(point), &n, k, radius);
            candidates.clear();
            grid.candidates(&lo, &hi, &mut candidates);
            let [a, b, c] = tri.map(point);
            let movable = tri.iter().any(|&q| inv_mass[q] > 0.0);
            for &p in &candidates {
                let q = point(p);
                let d = (q - a).dot(&n);
                // The in-plane distance of the projection inside each edge's line (negative
                // outside): at least 0, or −h across the cloth's border.
                let inside = |e0: &Vector3<f64>, e1: &Vector3<f64>, border: bool| {
                    let e = e1 - e0;
                    let margin = if border {
                        self.thickness * e.norm()
                    } else {
                        0.0
                    };
                    e.cross(&(q - e0)).dot(&n) >= -margin
                };
                let [ab, bc, ca] = self.border[k];
                // The geometric tests first: they reject most candidates, and cost less than
                // the 1-ring's search.
                if d.abs() <= radius
                    && inside(&a, &b, ab)
                    && inside(&b, &c, bc)
                    && inside(&c, &a, ca)
                    && (movable || inv_mass[p] > 0.0)
                    && !self.excludes(p, k)
                {
                    pairs.push(ContactPair {
                        vertex: p,
                        triangle: k,
                        above: d >= 0.0,
                    });
                }
            }
        }
        pairs.sort_unstable_by_key(|c| (c.vertex, c.triangle));
        pairs
    }

    /// The bounding box of the points the rules above can pair with triangle `k` (corners
    /// `corners`, unit normal `n`): the triangle with each border edge moved out by `h` in its
    /// plane, swept `±radius` along `n`; grown by a rounding slack.
    pub(crate) fn query_box(
        &self,
        corners: [Vector3<f64>; 3],
        n: &Vector3<f64>,
        k: usize,
        radius: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let margin = self.border[k].map(|b| if b { self.thickness } else { 0.0 });
        // Inward in-plane unit normals of the edges ab, bc, ca.
        let inward: [Vector3<f64>; 3] = std::array::from_fn(|e| {
            let d = corners[(e + 1) % 3] - corners[e];
            n.cross(&d).normalize()
        });
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for (v, at) in corners.iter().enumerate() {
            // Corner v lies on edges v (v → v+1) and v+2 (v+2 → v): move it to where both lines,
            // shifted outwards by their margins, meet.
            let (e, f) = (v, (v + 2) % 3);
            let c = inward[e].dot(&inward[f]);
            let det = 1.0 - c * c;
            let (x, y) = if margin[e] == 0.0 && margin[f] == 0.0 {
                (0.0, 0.0)
            } else {
                (
                    (-margin[e] + margin[f] * c) / det,
                    (-margin[f] + margin[e] * c) / det,
                )
            };
            let corner = at + inward[e] * x + inward[f] * y;
            for s in [-radius, radius] {
                let q = corner + n * s;
                lo = lo.inf(&q);
                hi = hi.sup(&q);
            }
        }
        let slack = 1e-9 * (1.0 + radius + lo.abs().max().max(hi.abs().max()));
        (lo.add_scalar(-slack), hi.add_scalar(slack))
    }

    /// The colour sets projecting `pairs` (greedy in pair order), each row `[vertex, triangle…]`.
    pub fn projection_sets(&self, pairs: &[ContactPair], inv_mass: &[f64]) -> Vec<ProjectionSet> {
        if pairs.is_empty() {
            return Vec::new();
        }
        let rows: Vec<[usize; 4]> = pairs
            .iter()
            .map(|c| {
                let [a, b, d] = self.triangles[c.triangle];
                [c.vertex, a, b, d]
            })
            .collect();
        let constraint = Arc::new(VertexTriangle {
            sides: pairs
                .iter()
                .map(|c| if c.above { 1.0 } else { -1.0 })
                .collect(),
            thickness: self.thickness,
        });
        contact_projection_sets(constraint, &rows, inv_mass)
    }
}

/// The colour sets projecting the rows `rows` (four particles each) of a contact constraint
/// (instance `k` = row `k`), greedily coloured in row order; rigid (compliance 0).
pub(crate) fn contact_projection_sets<C: Constraint>(
    constraint: Arc<C>,
    rows: &[[usize; 4]],
    inv_mass: &[f64],
) -> Vec<ProjectionSet> {
    let colors = greedy_coloring(rows, inv_mass.len());
    independent_sets(&colors)
        .into_iter()
        .map(|members| {
            let idx: Vec<usize> = members.iter().flat_map(|&k| rows[k]).collect();
            let w = idx.iter().map(|&p| inv_mass[p]).collect();
            let projection = Projection::new(constraint.clone(), members, w, 0.0);
            ProjectionSet {
                projection: Arc::new(projection),
                index: Arc::new(RowIndex::new(4, idx)),
                carry: Carry::Multiplier,
            }
        })
        .collect()
}
