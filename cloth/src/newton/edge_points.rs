//! The edge points' barrier ([`crate::contact::edge_points`]) in Newton's system: each point's
//! term `Δt² κ Σⱼ b(dⱼ(x_p))` at `x_p = (1 − t) x_a + t x_b`, its gradient `w ∇` and Hessian
//! `w wᵀ ⊗ ∇²` with `w = (1 − t, t)` (semidefinite wherever the point's `3 × 3` block is: the
//! projected Hessian projects that block), and the step filter on the points' straight moves.
//! With friction on a narrow collider, each point has the particles' lagged, smoothed Coulomb
//! potential at its own displacement since the step's start ([`crate::contact::smooth_friction`]),
//! so the load the points carry rubs as the particles' does; its coupling to the start enters the
//! implicit gradient with the same weights on both sides.

use super::assembly::{HessianKind, Pattern, NONE};
use super::psd::project_psd;
use crate::contact::barrier::APPROACH;
use crate::contact::edge_points::{EdgeBarrier, EdgePoint};
use crate::contact::smooth_friction::LaggedContact;
use std::sync::Arc;

/// The step's start (full `N × 3` data) and each point with frictional contacts there: its index
/// and its contacts.
type LaggedPoints = (Vec<f64>, Vec<(usize, Vec<LaggedContact>)>);

/// The edge points of a pattern: the barrier and, per point, the degrees of freedom of its two
/// particles and the value indices of the blocks `(a, a)`, `(b, b)` and `(a, b)` (row-major, the
/// diagonal blocks' upper entries [`NONE`]).
pub(super) struct EdgePointPattern {
    pub(super) edges: Arc<EdgeBarrier>,
    scatter: Vec<([u32; 2], [[u32; 9]; 3])>,
    /// With friction: the step's start (full `N × 3` data) and the frictional contacts of each
    /// point with any there ([`EdgePointPattern::begin_step`]).
    pub(super) friction: Option<LaggedPoints>,
}

/// The particle blocks (row ≥ column, in particle blocks) the points of `edges` couple, under
/// the degrees of freedom `dof_of`.
pub(super) fn coupled_blocks(edges: &EdgeBarrier, dof_of: &[u32]) -> Vec<(u32, u32)> {
    (edges.points.iter())
        .map(|p| {
            let (da, db) = (dof_of[p.a] / 3, dof_of[p.b] / 3);
            (da.max(db), da.min(db))
        })
        .collect()
}

impl EdgePointPattern {
    /// Indexes `edges`' points into `pattern`, which holds their blocks
    /// ([`coupled_blocks`]).
    pub(super) fn new(edges: Arc<EdgeBarrier>, pattern: &Pattern) -> EdgePointPattern {
        let block = |r: usize, c: usize| -> [u32; 9] {
            let mut idx = *pattern
                .block_index(r.max(c), r.min(c))
                .expect("the edge's block is in the pattern");
            if r == c {
                for i in 0..3 {
                    for j in i + 1..3 {
                        idx[3 * i + j] = NONE;
                    }
                }
            }
            idx
        };
        let scatter = (edges.points.iter())
            .map(|p| {
                let da = pattern.dof(p.a).expect("a free particle") as u32;
                let db = pattern.dof(p.b).expect("a free particle") as u32;
                let (ba, bb) = (da as usize / 3, db as usize / 3);
                ([da, db], [block(ba, ba), block(bb, bb), block(ba, bb)])
            })
            .collect();
        EdgePointPattern {
            edges,
            scatter,
            friction: None,
        }
    }

    /// With friction: lags the points' frictional contacts at the step's start `y` (full
    /// `N × 3` data). Nothing without friction.
    pub(super) fn begin_step(&mut self, y: &[f64]) {
        let barrier = &self.edges.barrier;
        if barrier.friction.is_none() {
            return;
        }
        let lagged = (self.edges.points_near(y, barrier.barrier.d_hat))
            .map(|(i, p)| (i, barrier.lagged(&p.position(y))))
            .filter(|(_, contacts)| !contacts.is_empty())
            .collect();
        self.friction = Some((y.to_vec(), lagged));
    }

    /// Each point with frictional contacts: its index, the point, its position at the step's
    /// start and its contacts.
    fn frictional(&self) -> impl Iterator<Item = (usize, &EdgePoint, [f64; 3], &[LaggedContact])> {
        (self.friction.iter()).flat_map(move |(start, lagged)| {
            lagged.iter().map(move |(i, contacts)| {
                let p = &self.edges.points[*i];
                (*i, p, p.position(start), &contacts[..])
            })
        })
    }

    /// The points' terms in `Φ(x)` (those of edges farther than `d̂` are 0).
    pub(super) fn energy(&self, x: &[f64]) -> f64 {
        let barrier = &self.edges.barrier;
        let contact: f64 = (self.edges.points_near(x, self.d_hat()))
            .map(|(_, p)| barrier.energy(&p.position(x)))
            .sum();
        let friction: f64 = (self.frictional())
            .map(|(_, p, y, contacts)| barrier.friction_energy(&p.position(x), &y, contacts))
            .sum();
        contact + friction
    }

    fn d_hat(&self) -> f64 {
        self.edges.barrier.barrier.d_hat
    }

    /// Adds the points' gradient to `grad` (degree-of-freedom order) and, with `values`, their
    /// Hessian of `kind`.
    pub(super) fn assemble(
        &self,
        x: &[f64],
        grad: &mut [f64],
        mut values: Option<(&mut [f64], HessianKind)>,
    ) {
        let project = matches!(values, Some((_, HessianKind::Projected)));
        let barrier = &self.edges.barrier;
        for (i, p) in self.edges.points_near(x, self.d_hat()) {
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            // A point inside (only at x̃, which the iterates never are) adds nothing, as a
            // particle does.
            let inside = !barrier.derivatives(&p.position(x), &mut g, &mut h, |block| {
                if project {
                    project_psd(block, 3);
                }
            });
            if !inside && (g != [0.0; 3] || h != [0.0; 9]) {
                self.scatter(i, p, &g, &h, grad, values.as_mut().map(|(v, _)| &mut **v));
            }
        }
        // The friction potential's Hessian is semidefinite already.
        for (i, p, y, contacts) in self.frictional() {
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            barrier.friction_derivatives(&p.position(x), &y, contacts, &mut g, &mut h);
            self.scatter(i, p, &g, &h, grad, values.as_mut().map(|(v, _)| &mut **v));
        }
    }

    /// Adds point `i`'s gradient `g` and Hessian `h` (in its position) to its particles'.
    fn scatter(
        &self,
        i: usize,
        p: &EdgePoint,
        g: &[f64; 3],
        h: &[f64; 9],
        grad: &mut [f64],
        values: Option<&mut [f64]>,
    ) {
        let ([da, db], blocks) = &self.scatter[i];
        let w = [1.0 - p.t, p.t];
        for k in 0..3 {
            grad[*da as usize + k] += w[0] * g[k];
            grad[*db as usize + k] += w[1] * g[k];
        }
        let Some(v) = values else {
            return;
        };
        let scales = [w[0] * w[0], w[1] * w[1], w[0] * w[1]];
        for (idx, s) in blocks.iter().zip(scales) {
            for (&j, &hv) in idx.iter().zip(h) {
                if j != NONE {
                    v[j as usize] += s * hv;
                }
            }
        }
    }

    /// Calls `f(start particle, state degree of freedom, block)` for the points' friction
    /// coupling of the state to the step's start, `∂(∇ₓD)/∂y` per pair of their particles (the
    /// point's block weighted by both particles' fractions), at `x`.
    pub(super) fn for_each_start_coupling(
        &self,
        x: &[f64],
        mut f: impl FnMut(usize, usize, &[f64; 9]),
    ) {
        for (i, p, y, _) in self.frictional() {
            let cross = self.edges.barrier.friction_cross(&p.position(x), &y);
            let ([da, db], _) = &self.scatter[i];
            let (w, dofs, particles) = ([1.0 - p.t, p.t], [*da, *db], [p.a, p.b]);
            for (wi, d) in w.iter().zip(dofs) {
                for (wj, q) in w.iter().zip(particles) {
                    f(q, d as usize, &cross.map(|c| wi * wj * c));
                }
            }
        }
    }

    /// Adds `∂(∇Φ)/∂ log μ` of the points' friction (its gradient: the potential is linear in
    /// `μ`) into `out` (degree-of-freedom order), at `x`.
    pub(super) fn add_friction_gradient(&self, x: &[f64], out: &mut [f64]) {
        for (i, p, y, contacts) in self.frictional() {
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            (self.edges.barrier).friction_derivatives(&p.position(x), &y, contacts, &mut g, &mut h);
            self.scatter(i, p, &g, &h, out, None);
        }
    }

    /// The largest step length in `[0, 1]` (1 or a power of one half) such that every point,
    /// moved straight by its particles' moves `moved(particle, dof)`, keeps the colliders'
    /// [`crate::contact::barrier::APPROACH`] fraction of its distance.
    ///
    /// An edge whose particles move less than `(1 − APPROACH)` times its box gap
    /// ([`EdgeBarrier::edge_gap`]) is passed over: each of its points moves no farther than its
    /// farther particle and starts at least that gap away, so the filter would pass it too.
    pub(super) fn max_step(&self, x: &[f64], moved: impl Fn(usize, usize) -> [f64; 3]) -> f64 {
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let mut moves: Vec<([f64; 3], [f64; 3])> = Vec::new();
        for ([a, b], range) in &self.edges.edges {
            let [da, db] = self.scatter[range.start].0;
            let (ma, mb) = (moved(*a, da as usize), moved(*b, db as usize));
            let gap = self.edges.edge_gap([*a, *b], x);
            if norm(ma).max(norm(mb)) <= (1.0 - APPROACH) * gap {
                continue;
            }
            moves.extend(self.edges.points[range.clone()].iter().map(|p| {
                let w = [1.0 - p.t, p.t];
                let delta = std::array::from_fn(|k| w[0] * ma[k] + w[1] * mb[k]);
                (p.position(x), delta)
            }));
        }
        (self.edges.barrier).max_step(moves.iter().map(|(q, d)| (&q[..], *d)))
    }
}
