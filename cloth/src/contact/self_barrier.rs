//! Smooth self-contact under Newton's method (`physics.self_collision` with `physics.solver
//! "newton"`): IPC's log barrier on the distance between parts of the cloth, less its thickness.
//!
//! Every vertex–triangle pair and every edge–edge pair that shares no particle, is nearer than
//! `h + d̂` (thickness `h`, the barrier's reach `d̂`, [`super::barrier::Barrier`]) and has a particle
//! that can move carries
//!
//! ```text
//! Δt² κ m(c) b(d − h),   b(s) = −(s − d̂)² ln(s / d̂)  for 0 < s < d̂,
//! ```
//!
//! with `d` the pair's unsigned distance ([`super::distance`]). `m` is 1 for a vertex–triangle
//! pair; for two edges it is IPC's mollifier `m(c) = (2 − c/ε) c/ε` below `ε` (1 above) in
//! `c = |e₁ × e₂|²`, `ε = 10⁻³ |e₁|²|e₂|²` at rest, which fades the pair out as the edges turn
//! parallel (where their distance's curvature is unbounded and the vertex–triangle pairs of
//! their ends hold them instead). The potential is C¹ in the state (the distance's kind changes
//! with a continuous gradient) and smooth within each kind; its gradient and Hessian are closed forms
//! ([`super::feature`]).
//!
//! The pairs are found anew at every state ([`SelfBarrier::pairs`], a uniform grid of the
//! vertices and one of the edges' boxes, or the same pairs filtered from a Verlet list:
//! [`super::self_candidates`]), so the potential is a function of the state alone.
//! Each step of the solver is filtered ([`SelfBarrier::max_step`]) so that no pair comes closer
//! than [`APPROACH`] of its gap `d − h` at the step's start or of `d̂`, whichever is smaller (a
//! pair farther than the barrier's reach may come as near as a pair at the reach): additive
//! continuous collision
//! detection (Li et al. 2021, "Codimensional IPC", §5), which advances each pair by the length
//! its relative motion cannot close, so the states the solver visits are never in contact.

use super::barrier::Barrier;
use super::distance::{EdgeEdge, PointTriangle};
use super::feature::{cross_squared_derivatives, Feature};
use super::grid::{Aabb, BoxGrid};
use super::self_candidates::Candidates;
use super::self_friction::SelfFriction;
use nalgebra::Vector3;
use std::sync::Arc;

/// Relative mollifier threshold `ε / (|e₁|²|e₂|²)` of an edge–edge pair (IPC's 10⁻³).
const MOLLIFIER: f64 = 1e-3;

/// Which kind of pair, with its nearest features at the state it was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairKind {
    /// Particle 0 and the triangle of particles 1, 2, 3.
    PointTriangle,
    /// The edge of particles 0, 1 and the edge of particles 2, 3, with the mollifier's `ε`.
    EdgeEdge(f64),
}

/// One self-contact pair: four particles and their kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfPair {
    /// Vertex then triangle, or first edge then second edge.
    pub particles: [usize; 4],
    /// The kind of pair.
    pub kind: PairKind,
}

/// The smooth self-contact potential of a cloth.
#[derive(Clone, Debug)]
pub struct SelfBarrier {
    /// The thickness `h ≥ 0`: the distance the barrier keeps between parts of the cloth.
    pub thickness: f64,
    /// The barrier's reach and stiffness.
    pub barrier: Barrier,
    /// `Δt²`: the potential's scale in Newton's `Φ`.
    pub dt2: f64,
    pub(crate) triangles: Arc<[[usize; 3]]>,
    /// Every edge of the triangles once, with its squared rest length.
    pub(super) edges: Vec<([usize; 2], f64)>,
    /// Which particles can move (inverse mass > 0).
    movable: Vec<bool>,
    /// The broad phase's cell: the edges' mean rest length.
    cell: f64,
    /// Cloth–cloth friction on the pairs ([`super::self_friction`]); `None`: frictionless.
    pub friction: Option<SelfFriction>,
}

impl SelfBarrier {
    /// The potential of a cloth with `triangles`, rest state `rest` (`N × 3` data) and inverse
    /// masses `inv_mass`.
    pub fn new(
        thickness: f64,
        barrier: Barrier,
        dt2: f64,
        triangles: Arc<[[usize; 3]]>,
        rest: &[f64],
        inv_mass: &[f64],
    ) -> SelfBarrier {
        let mut edges: Vec<[usize; 2]> = triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let edges: Vec<([usize; 2], f64)> = edges
            .into_iter()
            .map(|[a, b]| ([a, b], (at(rest, a) - at(rest, b)).norm_squared()))
            .collect();
        let cell = edges.iter().map(|e| e.1.sqrt()).sum::<f64>() / edges.len().max(1) as f64;
        SelfBarrier {
            thickness,
            barrier,
            dt2,
            triangles,
            edges,
            movable: inv_mass.iter().map(|&w| w > 0.0).collect(),
            cell: if cell > 0.0 { cell } else { 1.0 },
            friction: None,
        }
    }

    /// The pairs of state `x` (`N × 3` data) nearer than `h + d̂`, vertex–triangle pairs first
    /// (by vertex, then triangle), then edge–edge pairs (by first edge, then second).
    pub fn pairs(&self, x: &[f64]) -> Vec<SelfPair> {
        self.pairs_with(x, None)
    }

    /// A particle move the step filter allows whole from `x`, whose pairs (nearer than `h + d̂`)
    /// are `pairs`: when no particle moves farther than this, every pair of the filter's sweep
    /// passes its first test (its relative motion, at most four times the largest move, within
    /// its gap above the floor, at least `(1 − APPROACH) min(gap, d̂)`), so
    /// [`SelfBarrier::max_step`] is 1 and need not be asked. Half of that bound, for round-off;
    /// 0 when a pair is at or within the thickness.
    pub fn free_move(&self, x: &[f64], pairs: &[SelfPair]) -> f64 {
        let d_hat = self.barrier.d_hat;
        let gap = pairs
            .iter()
            .map(|pair| self.distance(x, pair) - self.thickness)
            .fold(d_hat, f64::min);
        0.5 * (1.0 - super::barrier::APPROACH) * gap.max(0.0) / 4.0
    }

    /// The pairs of state `x` nearer than `reach` (at least `h + d̂` for a superset of
    /// [`SelfBarrier::pairs`]), searched over the whole cloth.
    pub fn pairs_within(&self, x: &[f64], reach: f64) -> Vec<SelfPair> {
        self.pairs_nearer(x, reach, None)
    }

    /// [`SelfBarrier::pairs`], through a candidate list when there is one.
    pub(super) fn pairs_with(&self, x: &[f64], list: Option<&mut Candidates>) -> Vec<SelfPair> {
        self.pairs_nearer(x, self.thickness + self.barrier.d_hat, list)
    }

    /// The pairs of `x` nearer than `reach`, through a candidate list when there is one.
    fn pairs_nearer(&self, x: &[f64], reach: f64, list: Option<&mut Candidates>) -> Vec<SelfPair> {
        let mut out = Vec::new();
        self.candidates_with(&swept_boxes(x, None), reach, list, |pair| {
            if self.distance(x, &pair) < reach {
                out.push(pair);
            }
        });
        out
    }

    /// Calls `f` with every pair whose particles' boxes `points` come within `margin` of each
    /// other, in [`SelfBarrier::pairs`]' order, and the pair's query and item (triangle and
    /// vertex, or first and second edge: indices into [`SelfBarrier::triangles`] and `points`,
    /// or twice into [`SelfBarrier::edges`]).
    pub(super) fn for_candidates(
        &self,
        points: &[Aabb],
        margin: f64,
        mut f: impl FnMut(SelfPair, [usize; 2]),
    ) {
        let n = points.len();
        let grow = |(lo, hi): Aabb| -> Aabb {
            let m = Vector3::repeat(margin);
            (lo - m, hi + m)
        };
        let union = |ps: &[usize]| -> Aabb {
            ps.iter().map(|&p| points[p]).fold(
                (
                    Vector3::repeat(f64::INFINITY),
                    Vector3::repeat(f64::NEG_INFINITY),
                ),
                |(lo, hi), (a, b)| (lo.inf(&a), hi.sup(&b)),
            )
        };
        // Vertex–triangle pairs: the vertices' grid, queried with each triangle's box. `seen`
        // stamps the candidates of one query (a vertex appears once per cell of the query).
        let grid = BoxGrid::new(points, self.cell);
        let mut found: Vec<(usize, usize)> = Vec::new();
        let mut cand = Vec::new();
        let mut seen = vec![usize::MAX; n.max(self.edges.len())];
        for (ti, t) in self.triangles.iter().enumerate() {
            let (lo, hi) = grow(union(t));
            cand.clear();
            grid.candidates(&lo, &hi, &mut cand);
            let any_movable = t.iter().any(|&p| self.movable[p]);
            for &v in &cand {
                if std::mem::replace(&mut seen[v], ti) == ti
                    || t.contains(&v)
                    || !(any_movable || self.movable[v])
                {
                    continue;
                }
                let (a, b) = points[v];
                if (0..3).all(|k| a[k] <= hi[k] && b[k] >= lo[k]) {
                    found.push((v, ti));
                }
            }
        }
        found.sort_unstable();
        for (v, ti) in found {
            let t = self.triangles[ti];
            let pair = SelfPair {
                particles: [v, t[0], t[1], t[2]],
                kind: PairKind::PointTriangle,
            };
            f(pair, [ti, v]);
        }
        // Edge–edge pairs: the edges' grid, queried with each edge's box.
        let boxes: Vec<Aabb> = self.edges.iter().map(|(e, _)| union(e)).collect();
        let grid = BoxGrid::new(&boxes, self.cell);
        seen.fill(usize::MAX);
        for (i, (e, l1)) in self.edges.iter().enumerate() {
            let (lo, hi) = grow(boxes[i]);
            cand.clear();
            grid.candidates(&lo, &hi, &mut cand);
            // Each edge after `i` once (stamped), in increasing order.
            cand.retain(|&j| j > i && std::mem::replace(&mut seen[j], i) != i);
            cand.sort_unstable();
            for &j in &cand {
                let (g, l2) = &self.edges[j];
                if e.iter().any(|p| g.contains(p)) || !e.iter().chain(g).any(|&p| self.movable[p]) {
                    continue;
                }
                let (a, b) = boxes[j];
                if (0..3).all(|k| a[k] <= hi[k] && b[k] >= lo[k]) {
                    let pair = SelfPair {
                        particles: [e[0], e[1], g[0], g[1]],
                        kind: PairKind::EdgeEdge(MOLLIFIER * l1 * l2),
                    };
                    f(pair, [i, j]);
                }
            }
        }
    }

    /// The pair's unsigned distance at `x` (`f64`).
    pub fn distance(&self, x: &[f64], pair: &SelfPair) -> f64 {
        let [p, a, b, c] = pair.particles.map(|q| at(x, q));
        match pair.kind {
            PairKind::PointTriangle => PointTriangle::distance(&p, [&a, &b, &c]),
            PairKind::EdgeEdge(_) => EdgeEdge::distance([&p, &a], [&b, &c]),
        }
    }

    /// `Φ`'s self-contact term at `x` over `pairs` (the pairs of `x`, [`SelfBarrier::pairs`]):
    /// `Δt² κ Σ m b(d − h)`, `+∞` when a pair is at or within the thickness.
    pub fn energy(&self, x: &[f64], pairs: &[SelfPair]) -> f64 {
        pairs.iter().map(|pair| self.potential(x, pair)).sum()
    }

    /// The pair's term `Δt² κ m b(d − h)` at `x` (`+∞` at or within the thickness).
    fn potential(&self, x: &[f64], pair: &SelfPair) -> f64 {
        let s = self.distance(x, pair) - self.thickness;
        if s <= 0.0 {
            return f64::INFINITY;
        }
        let m = match pair.kind {
            PairKind::PointTriangle => 1.0,
            PairKind::EdgeEdge(eps) => mollifier(&pair.particles.map(|q| at(x, q)), eps),
        };
        self.dt2 * self.barrier.kappa * m * self.barrier.shape(s).0
    }

    /// The pair's nearest features at `x` as an affine family ([`Feature`]; the pair's points in
    /// order: vertex then triangle, or first edge then second edge).
    pub(super) fn feature(&self, p: &[Vector3<f64>; 4], kind: PairKind) -> Feature {
        match kind {
            PairKind::PointTriangle => {
                match PointTriangle::classify(&p[0], [&p[1], &p[2], &p[3]]) {
                    PointTriangle::Corner(i) => Feature::point_point(0, 1 + i as usize),
                    PointTriangle::Edge(i, j) => {
                        Feature::point_line(0, 1 + i as usize, 1 + j as usize)
                    }
                    PointTriangle::Face => Feature::point_plane(0, 1, 2, 3),
                }
            }
            PairKind::EdgeEdge(_) => match EdgeEdge::classify([&p[0], &p[1]], [&p[2], &p[3]]) {
                EdgeEdge::Lines => Feature::line_line(0, 1, 2, 3),
                EdgeEdge::FirstEnd(i) => Feature::point_line(i as usize, 2, 3),
                EdgeEdge::SecondEnd(j) => Feature::point_line(2 + j as usize, 0, 1),
                EdgeEdge::Ends(i, j) => Feature::point_point(i as usize, 2 + j as usize),
            },
        }
    }

    /// The pair's gradient (12 coordinates: its four particles in order) and Hessian (row-major
    /// 12 × 12) at `x`, and which of its particles they involve; `None` (nothing written) at or
    /// within the thickness. The squared distance's derivatives are closed forms
    /// ([`Feature::squared_derivatives`]), the barrier is applied by the chain rule and the
    /// mollifier (edge pairs within its region) by the product rule.
    pub fn pair_derivatives(
        &self,
        x: &[f64],
        pair: &SelfPair,
        g: &mut [f64; 12],
        h: &mut [f64; 144],
    ) -> Option<[bool; 4]> {
        let p = pair.particles.map(|q| at(x, q));
        let feature = self.feature(&p, pair.kind);
        let (mut gq, mut hq) = ([0.0; 12], [0.0; 144]);
        let q = feature.squared_derivatives(&p, &mut gq, &mut hq);
        let d = q.max(0.0).sqrt();
        let s = d - self.thickness;
        if s <= 0.0 {
            return None;
        }
        // B(q) = b(s(q)), s = √q − h: B′ = b′ s′, B″ = b″ s′² + b′ s″.
        let (b0, b1, b2) = self.barrier.shape(s);
        let (s1, s2) = (0.5 / d, -0.25 / (d * d * d));
        let (db, ddb) = (b1 * s1, b2 * s1 * s1 + b1 * s2);
        let scale = self.dt2 * self.barrier.kappa;
        for a in 0..12 {
            g[a] = scale * db * gq[a];
            for c in 0..12 {
                h[12 * a + c] = scale * (ddb * gq[a] * gq[c] + db * hq[12 * a + c]);
            }
        }
        let PairKind::EdgeEdge(eps) = pair.kind else {
            return Some(feature.involves());
        };
        // IPC's mollifier m = (2 − c/ε) c/ε of c = |e₁ × e₂|² below ε:
        // m′ = 2(1 − c/ε)/ε, m″ = −2/ε²; ∇m = m′∇c, ∇²m = m″∇c∇cᵀ + m′∇²c.
        let (mut gc, mut hc) = ([0.0; 12], [0.0; 144]);
        let c = cross_squared_derivatives(&p, &mut gc, &mut hc);
        if c >= eps {
            return Some(feature.involves());
        }
        let m = (2.0 - c / eps) * c / eps;
        let (m1, m2) = (2.0 * (1.0 - c / eps) / eps, -2.0 / (eps * eps));
        // P = m B: ∇P = m∇B + B∇m, ∇²P = m∇²B + ∇m∇Bᵀ + ∇B∇mᵀ + B∇²m.
        let bv = scale * b0;
        for a in 0..12 {
            for k in 0..12 {
                let (gma, gmk) = (m1 * gc[a], m1 * gc[k]);
                let hm = m2 * gc[a] * gc[k] + m1 * hc[12 * a + k];
                let i = 12 * a + k;
                h[i] = m * h[i] + gma * g[k] + g[a] * gmk + bv * hm;
            }
        }
        for a in 0..12 {
            g[a] = m * g[a] + bv * m1 * gc[a];
        }
        Some([true; 4])
    }

    /// The pair of `x` with the smallest gap `d − h` when some gap is at most 0 (a part of the
    /// cloth at or within the thickness of another), with that gap; else `None`.
    pub fn penetration(&self, x: &[f64]) -> Option<(SelfPair, f64)> {
        self.penetration_among(x, &self.pairs(x))
    }

    /// [`SelfBarrier::penetration`] with the pairs of `x` already found
    /// ([`SelfBarrier::pairs`]).
    pub fn penetration_among(&self, x: &[f64], pairs: &[SelfPair]) -> Option<(SelfPair, f64)> {
        pairs
            .iter()
            .map(|&p| (p, self.distance(x, &p) - self.thickness))
            .filter(|&(_, s)| s <= 0.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

/// Each particle's box: the point of `x`, or its straight motion to `x + δ`.
pub(super) fn swept_boxes(x: &[f64], delta: Option<&[f64]>) -> Vec<Aabb> {
    (0..x.len() / 3)
        .map(|p| {
            let a = at(x, p);
            let b = delta.map_or(a, |d| a + at(d, p));
            (a.inf(&b), a.sup(&b))
        })
        .collect()
}

/// IPC's mollifier of the edges `p₀p₁`, `p₂p₃`: `(2 − c/ε) c/ε` in `c = |e₁ × e₂|²` below `ε`,
/// else 1.
fn mollifier(p: &[Vector3<f64>; 4], eps: f64) -> f64 {
    let r = (p[1] - p[0]).cross(&(p[3] - p[2])).norm_squared() / eps;
    if r < 1.0 {
        (2.0 - r) * r
    } else {
        1.0
    }
}

/// Particle `p` of `N × 3` data.
#[inline]
pub(super) fn at(x: &[f64], p: usize) -> Vector3<f64> {
    Vector3::new(x[3 * p], x[3 * p + 1], x[3 * p + 2])
}

#[cfg(test)]
pub(super) mod tests {
    use super::{PairKind, SelfBarrier, SelfPair};
    use crate::contact::barrier::Barrier;
    use std::sync::Arc;

    /// A `k × k` grid cloth of spacing 1 folded over itself along the middle column, with a
    /// little noise: layers about `gap` apart.
    pub(in crate::contact) fn folded(k: usize, gap: f64) -> (Vec<[usize; 3]>, Vec<f64>) {
        let mut x = Vec::new();
        let half = (k - 1) as f64 / 2.0;
        for r in 0..k {
            for c in 0..k {
                let u = c as f64;
                let (px, pz) = if u <= half {
                    (u, 0.0)
                } else {
                    (2.0 * half - u, gap)
                };
                let noise = ((r * 31 + c * 17) % 7) as f64 * 1e-3;
                x.extend([px + noise, r as f64, pz + noise]);
            }
        }
        let mut tris = Vec::new();
        for r in 0..k - 1 {
            for c in 0..k - 1 {
                let p = r * k + c;
                tris.push([p, p + 1, p + k]);
                tris.push([p + 1, p + k + 1, p + k]);
            }
        }
        (tris, x)
    }

    fn barrier(tris: Vec<[usize; 3]>, x: &[f64], h: f64) -> SelfBarrier {
        SelfBarrier::new(
            h,
            Barrier {
                d_hat: 0.2,
                kappa: 1.0,
            },
            1.0,
            Arc::from(tris),
            x,
            &vec![1.0; x.len() / 3],
        )
    }

    #[test]
    fn the_pairs_are_those_of_a_brute_force_search() {
        let (tris, x) = folded(9, 0.2);
        let b = barrier(tris.clone(), &x, 0.05);
        let reach = 0.25;
        let pairs = b.pairs(&x);
        let mut brute = Vec::new();
        for v in 0..x.len() / 3 {
            for t in &tris {
                let pair = SelfPair {
                    particles: [v, t[0], t[1], t[2]],
                    kind: PairKind::PointTriangle,
                };
                if !t.contains(&v) && b.distance(&x, &pair) < reach {
                    brute.push(pair);
                }
            }
        }
        for (i, (e, l1)) in b.edges.iter().enumerate() {
            for (g, l2) in &b.edges[i + 1..] {
                let pair = SelfPair {
                    particles: [e[0], e[1], g[0], g[1]],
                    kind: PairKind::EdgeEdge(super::MOLLIFIER * l1 * l2),
                };
                if !e.iter().any(|p| g.contains(p)) && b.distance(&x, &pair) < reach {
                    brute.push(pair);
                }
            }
        }
        assert!(pairs.len() > 50, "{} pairs", pairs.len());
        let missing: Vec<_> = brute.iter().filter(|p| !pairs.contains(p)).collect();
        let extra: Vec<_> = pairs.iter().filter(|p| !brute.contains(p)).collect();
        assert!(
            missing.is_empty() && extra.is_empty(),
            "{} vs {}; missing {:?}, extra {:?}",
            pairs.len(),
            brute.len(),
            &missing[..missing.len().min(4)],
            &extra[..extra.len().min(4)]
        );
        assert_eq!(pairs, brute);
    }

    /// The pairs of states along a swept motion, filtered from the sweep, are exactly those of a
    /// fresh search, in order; a state off the motion's boxes is not answered from it.
    #[test]
    fn pairs_filtered_from_a_sweep_are_those_of_a_search() {
        let (tris, x) = folded(9, 0.2);
        let b = barrier(tris, &x, 0.05);
        // Close the fold and shear its top layer.
        let delta: Vec<f64> = (0..x.len())
            .map(|i| match i % 3 {
                2 if x[i] > 0.1 => -0.15,
                0 => 0.05 * x[i + 1].sin(),
                _ => 0.0,
            })
            .collect();
        let sweep = b.sweep(&x, &delta);
        let mut seen = 0;
        for t in [0.0, 0.3, 0.55, 0.8, 1.0] {
            let xt: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + t * d).collect();
            let fresh = b.pairs(&xt);
            seen += fresh.len();
            assert_eq!(b.pairs_in(&xt, &sweep), Some(fresh), "t = {t}");
        }
        assert!(seen > 100, "{seen} pairs over the motion");
        let beyond: Vec<f64> = x.iter().zip(&delta).map(|(a, d)| a + 1.5 * d).collect();
        assert_eq!(b.pairs_in(&beyond, &sweep), None);
    }

    /// A pair of four points with the given kind in a 4-particle state.
    fn lone(kind: PairKind) -> SelfPair {
        SelfPair {
            particles: [0, 1, 2, 3],
            kind,
        }
    }

    /// Four free particles whose only triangle is particles 1, 2, 3, thickness `h`.
    pub(in crate::contact) fn four_points(h: f64) -> SelfBarrier {
        SelfBarrier::new(
            h,
            Barrier {
                d_hat: 0.1,
                kappa: 3.0,
            },
            0.5,
            Arc::from(vec![[1, 2, 3]]),
            &[0.0; 12],
            &[1.0; 4],
        )
    }

    /// The pair's potential at `x`.
    fn potential_at(b: &SelfBarrier, pair: &SelfPair, x: &[f64]) -> f64 {
        b.potential(x, pair)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 64, .. Default::default() })]

        /// The gradient and Hessian of a vertex–triangle or edge–edge pair (every kind of
        /// nearest features, the mollifier's region included) against central differences of
        /// the potential and of the gradient.
        #[test]
        fn pair_derivatives_match_central_differences(
            coords in proptest::collection::vec(-0.5f64..0.5, 12),
            edge in proptest::bool::ANY,
            lift in 0.05f64..0.12,
        ) {
            let h = 0.02;
            let b = four_points(h);
            // Particle 0 (and 1 for edges) lifted above the others so that the pair is apart.
            let mut x = coords.clone();
            for v in x.iter_mut().skip(2).step_by(3) {
                *v *= 0.02;
            }
            // ε = 1 puts every edge pair in the mollifier's region (|e₁ × e₂|² < 1 here).
            let eps = if lift > 0.085 { 1.0 } else { 1e-3 * 0.25 * 0.25 };
            let kind = if edge { PairKind::EdgeEdge(eps) } else { PairKind::PointTriangle };
            let lifted = if edge { 2 } else { 1 };
            for q in 0..lifted {
                x[3 * q + 2] += lift;
            }
            let pair = lone(kind);
            let gap = b.distance(&x, &pair) - h;
            proptest::prop_assume!(gap > 0.01 && gap < 0.09);
            let (mut g, mut hess) = ([0.0; 12], [0.0; 144]);
            proptest::prop_assert!(b.pair_derivatives(&x, &pair, &mut g, &mut hess).is_some());
            let step = 1e-6;
            let scale = g.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            let hscale = hess.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for a in 0..12 {
                let (mut up, mut down) = (x.clone(), x.clone());
                up[a] += step;
                down[a] -= step;
                let fd = (potential_at(&b, &pair, &up) - potential_at(&b, &pair, &down)) / (2.0 * step);
                proptest::prop_assert!((fd - g[a]).abs() <= 1e-5 * scale, "∂{a}: {fd} vs {}", g[a]);
                let (mut gu, mut gd) = ([0.0; 12], [0.0; 12]);
                b.pair_derivatives(&up, &pair, &mut gu, &mut [0.0; 144]);
                b.pair_derivatives(&down, &pair, &mut gd, &mut [0.0; 144]);
                for c in 0..12 {
                    let fd2 = (gu[c] - gd[c]) / (2.0 * step);
                    proptest::prop_assert!(
                        (fd2 - hess[12 * a + c]).abs() <= 1e-4 * hscale,
                        "∂²{a},{c}: {fd2} vs {}", hess[12 * a + c]
                    );
                }
            }
        }
    }

    /// Random moves no longer than the free move pass the filter whole; bringing the layers
    /// together does not.
    #[test]
    fn moves_within_the_free_move_pass_the_filter_whole() {
        let (tris, x) = folded(7, 0.3);
        let b = barrier(tris, &x, 0.05);
        let free = b.free_move(&x, &b.pairs(&x));
        assert!(free > 0.0 && free < 0.2, "{free}");
        let mut rng = 12345u64;
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % 2001) as f64 / 1000.0 - 1.0
        };
        for _ in 0..20 {
            let mut delta: Vec<f64> = (0..x.len()).map(|_| uniform()).collect();
            let largest = delta
                .chunks_exact(3)
                .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                .fold(0.0, f64::max);
            delta.iter_mut().for_each(|d| *d *= free / largest);
            assert_eq!(b.max_step(&x, &delta, 1.0).0, 1.0);
        }
        // The two layers (0.3 apart, 0.25 above the thickness) brought together: stopped.
        let mut close = vec![0.0; x.len()];
        for (p, v) in x.chunks_exact(3).enumerate() {
            close[3 * p + 2] = if v[2] > 0.1 { -0.3 } else { 0.0 };
        }
        assert!(b.max_step(&x, &close, 1.0).0 < 1.0);
    }

    /// A vertex driven straight through a triangle stops before it: the filter keeps a tenth of
    /// its gap; a move along the triangle's plane is not shortened.
    #[test]
    fn the_filter_stops_a_vertex_before_a_triangle() {
        let h = 0.02;
        let b = four_points(h);
        let x = [
            0.2, 0.2, 0.1, // the vertex, 0.1 above
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ];
        let mut down = [0.0; 12];
        down[2] = -0.5;
        let alpha = b.max_step(&x, &down, 1.0).0;
        let gap0 = 0.1 - h;
        let end = 0.1 - 0.5 * alpha - h;
        assert!(
            end >= crate::contact::barrier::APPROACH * gap0 - 1e-12,
            "gap at the end {end}"
        );
        assert!(end <= 0.2 * gap0, "stopped early: gap {end} of {gap0}");
        let mut along = [0.0; 12];
        along[0] = 0.3;
        assert_eq!(b.max_step(&x, &along, 1.0).0, 1.0);
        // Moving the triangle up onto the vertex is stopped the same way.
        let mut up = [0.0; 12];
        for k in [5, 8, 11] {
            up[k] = 0.5;
        }
        let beta = b.max_step(&x, &up, 1.0).0;
        assert!((beta - alpha).abs() < 1e-9, "{beta} vs {alpha}");
    }
}
