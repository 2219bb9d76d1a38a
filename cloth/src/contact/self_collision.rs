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
//! The search is a spatial hash of the vertices (cells of edge `max(r, mean triangle extent)`)
//! queried with each triangle's box grown by `r`. Pairs are listed by vertex, then triangle.
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

use crate::coloring::{greedy_coloring, independent_sets};
use crate::constraint::Constraint;
use crate::geometry::norm;
use crate::model::{Carry, Model, ProjectionSet};
use crate::projection::Projection;
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
        let n = (p[2] - p[1]).cross(&(p[3] - p[1]));
        let len = norm(&n);
        if len.value() == 0.0 {
            return R::cst(-self.thickness);
        }
        (p[0] - p[1]).dot(&(n * len.recip())) * self.sides[instance] - self.thickness
    }

    /// `∇C` in closed form: with `e₁ = p₂ − p₁`, `e₂ = p₃ − p₁`, `n = e₁ × e₂`, `d = p₀ − p₁`,
    /// `q = d·n̂` and `m = (d − q n̂)/|n|` (the gradient of `q` in `n`):
    /// `∇₀ = s n̂`, `∇₂ = s e₂ × m`, `∇₃ = s m × e₁`, `∇₁ = −(∇₀ + ∇₂ + ∇₃)`.
    #[inline(always)]
    fn gradient<R: Real>(&self, instance: usize, x: &[R], g: &mut [R]) -> R {
        let p1 = point(x, 1);
        let (e1, e2) = (point(x, 2) - p1, point(x, 3) - p1);
        let n = e1.cross(&e2);
        let len = norm(&n);
        if len.value() == 0.0 {
            g[..12].fill(R::zero());
            return R::cst(-self.thickness);
        }
        let s = R::cst(self.sides[instance]);
        let inv = len.recip();
        let unit = n * inv;
        let d = point(x, 0) - p1;
        let q = d.dot(&unit);
        let m = (d - unit * q) * inv;
        let g0 = unit * s;
        let g2 = e2.cross(&m) * s;
        let g3 = m.cross(&e1) * s;
        let g1 = -(g0 + g2 + g3);
        for k in 0..3 {
            g[k] = g0[k];
            g[3 + k] = g1[k];
            g[6 + k] = g2[k];
            g[9 + k] = g3[k];
        }
        q * s - self.thickness
    }
}

/// Particle `i`'s position in a row of coordinates.
#[inline(always)]
fn point<R: Real>(x: &[R], i: usize) -> Vector3<R> {
    Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2])
}

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

/// A model's self-collision: the thickness and the cloth's topology the pair search needs.
#[derive(Clone, Debug)]
pub struct SelfCollision {
    /// The thickness `h ≥ 0`.
    pub thickness: f64,
    triangles: Arc<[[usize; 3]]>,
    /// Per triangle, whether each edge (`ab`, `bc`, `ca`) lies on the cloth's border (one
    /// triangle uses it).
    border: Vec<[bool; 3]>,
    /// Each vertex's 1-ring (itself and its edge neighbours), sorted: `ring[ring_start[v]..ring_start[v + 1]]`.
    ring_start: Vec<usize>,
    ring: Vec<usize>,
}

impl SelfCollision {
    /// Self-collision of thickness `h` on a cloth of `n_particles` with these triangles.
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
        SelfCollision {
            thickness,
            triangles,
            border,
            ring_start,
            ring,
        }
    }

    /// Whether the pair search skips triangle `triangle` for `vertex`: the triangle has a vertex
    /// of `vertex`'s 1-ring.
    pub fn excludes(&self, vertex: usize, triangle: usize) -> bool {
        let ring = &self.ring[self.ring_start[vertex]..self.ring_start[vertex + 1]];
        self.triangles[triangle]
            .iter()
            .any(|q| ring.binary_search(q).is_ok())
    }

    /// The contact pairs of a step that starts from `x` (`N × 3`), within query radius `radius`
    /// (see the module docs), by vertex then triangle. `inv_mass` skips pairs that cannot move.
    pub fn find_pairs(&self, x: &Tensor, radius: f64, inv_mass: &[f64]) -> Vec<ContactPair> {
        let point = |p: usize| {
            let r = x.row(p);
            Vector3::new(r[0], r[1], r[2])
        };
        // Non-degenerate triangles with their unit normals and bounding boxes.
        let mut tris = Vec::with_capacity(self.triangles.len());
        let mut extent_sum = 0.0;
        for (k, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = t.map(point);
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let lo = a.inf(&b).inf(&c);
            let hi = a.sup(&b).sup(&c);
            extent_sum += (hi - lo).max();
            tris.push((k, n / len, lo, hi));
        }
        if tris.is_empty() {
            return Vec::new();
        }
        let cell = radius.max(extent_sum / tris.len() as f64);
        if !(cell > 0.0 && cell.is_finite()) {
            return Vec::new();
        }
        let key = |v: &Vector3<f64>| v.map(|c| (c / cell).floor() as i64);
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for p in 0..x.rows() {
            let k = key(&point(p));
            grid.entry([k.x, k.y, k.z]).or_default().push(p);
        }
        let grow = Vector3::repeat(radius);
        let mut pairs = Vec::new();
        let mut candidates = Vec::new();
        for &(k, n, lo, hi) in &tris {
            let tri = self.triangles[k];
            let (klo, khi) = (key(&(lo - grow)), key(&(hi + grow)));
            let span = khi.zip_map(&klo, |h, l| {
                h.saturating_sub(l).saturating_add(1).max(0) as u128
            });
            candidates.clear();
            if span.x * span.y * span.z > x.rows() as u128 {
                candidates.extend(0..x.rows());
            } else {
                for i in klo.x..=khi.x {
                    for j in klo.y..=khi.y {
                        for l in klo.z..=khi.z {
                            if let Some(ps) = grid.get(&[i, j, l]) {
                                candidates.extend_from_slice(ps);
                            }
                        }
                    }
                }
            }
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
        let colors = greedy_coloring(&rows, inv_mass.len());
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
}

impl Model {
    /// The query radius of a step with controls `u` (`n_controls × 3`): `h + 2δ`, `δ` the largest
    /// control displacement plus the gravity step (see [`crate::contact::self_collision`]).
    pub fn contact_radius(&self, thickness: f64, u: &Tensor) -> f64 {
        let fastest = (0..u.rows())
            .map(|k| norm(&Vector3::new(u.get(k, 0), u.get(k, 1), u.get(k, 2))))
            .fold(0.0, f64::max);
        let fall = self
            .gravity_step
            .map_or(0.0, |g| norm(&Vector3::new(g[0], g[1], g[2])));
        thickness + 2.0 * (fastest + fall)
    }

    /// The self-contact pairs of a step from `x_prev` with controls `u` (empty without
    /// `physics.self_collision`).
    pub fn contact_pairs(&self, x_prev: &Tensor, u: &Tensor) -> Vec<ContactPair> {
        match &self.self_collision {
            None => Vec::new(),
            Some(sc) => sc.find_pairs(x_prev, self.contact_radius(sc.thickness, u), &self.inv_mass),
        }
    }

    /// The colour sets of a step's self-contacts, projected after the model's own sets (none
    /// without `physics.self_collision`).
    pub fn contact_sets(&self, x_prev: &Tensor, u: &Tensor) -> Vec<ProjectionSet> {
        match &self.self_collision {
            None => Vec::new(),
            Some(sc) => sc.projection_sets(&self.contact_pairs(x_prev, u), &self.inv_mass),
        }
    }
}
