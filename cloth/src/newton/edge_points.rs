//! The edge points' barrier ([`crate::contact::edge_points`]) in Newton's system: each point's
//! term `Δt² κ Σⱼ b(dⱼ(x_p))` at `x_p = (1 − t) x_a + t x_b`, its gradient `w ∇` and Hessian
//! `w wᵀ ⊗ ∇²` with `w = (1 − t, t)` (semidefinite wherever the point's `3 × 3` block is: the
//! projected Hessian projects that block), and the step filter on the points' straight moves.

use super::assembly::{HessianKind, Pattern, NONE};
use super::psd::project_psd;
use crate::contact::barrier::APPROACH;
use crate::contact::edge_points::{EdgeBarrier, EdgePoint};
use std::sync::Arc;

/// The edge points of a pattern: the barrier and, per point, the degrees of freedom of its two
/// particles and the value indices of the blocks `(a, a)`, `(b, b)` and `(a, b)` (row-major, the
/// diagonal blocks' upper entries [`NONE`]).
pub(super) struct EdgePointPattern {
    pub(super) edges: Arc<EdgeBarrier>,
    scatter: Vec<([u32; 2], [[u32; 9]; 3])>,
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
        EdgePointPattern { edges, scatter }
    }

    /// The points' terms in `Φ(x)` (those of edges farther than `d̂` are 0).
    pub(super) fn energy(&self, x: &[f64]) -> f64 {
        (self.edges.points_near(x, self.d_hat()))
            .map(|(_, p)| (self.edges.barrier).energy(&p.position(x)))
            .sum()
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
        for (i, p) in self.edges.points_near(x, self.d_hat()) {
            let ([da, db], blocks) = &self.scatter[i];
            let (mut g, mut h) = ([0.0; 3], [0.0; 9]);
            let q = p.position(x);
            // A point inside (only at x̃, which the iterates never are) adds nothing, as a
            // particle does.
            if !self.edges.barrier.derivatives(&q, &mut g, &mut h, |block| {
                if project {
                    project_psd(block, 3);
                }
            }) || (g == [0.0; 3] && h == [0.0; 9])
            {
                continue;
            }
            let w = [1.0 - p.t, p.t];
            for k in 0..3 {
                grad[*da as usize + k] += w[0] * g[k];
                grad[*db as usize + k] += w[1] * g[k];
            }
            let Some((v, _)) = values.as_mut() else {
                continue;
            };
            let scales = [w[0] * w[0], w[1] * w[1], w[0] * w[1]];
            for (idx, s) in blocks.iter().zip(scales) {
                for (&i, &hv) in idx.iter().zip(&h) {
                    if i != NONE {
                        v[i as usize] += s * hv;
                    }
                }
            }
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

    /// The first point of `x` on or inside a narrow collider ([`EdgeBarrier::penetration`]).
    pub(super) fn penetration(&self, x: &[f64]) -> Option<(EdgePoint, f64)> {
        self.edges.penetration(x)
    }
}
