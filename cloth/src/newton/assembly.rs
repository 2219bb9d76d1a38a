//! The Newton system of one quasi-static step, assembled into a sparse pattern fixed per model.
//!
//! `Φ(x) = ½ (x − x̃)ᵀ M (x − x̃) + Σⱼ ½ C_j(x)² / α̃_j` over the free particles (inverse mass > 0),
//! the control particles held where [`Model::begin_step`] put them. An inequality constraint
//! contributes only while `C < 0`. The Hessian is stored as its lower triangle in compressed
//! columns, one degree of freedom per free coordinate, numbered in the fill-reducing elimination
//! order of [`super::ordering`].

use super::contact::is_contact;
use super::edge_points::{coupled_blocks, EdgePointPattern};
use super::ordering::elimination_positions;
use super::psd::projected_local_hessian;
use super::self_contact::{LaggedSelfPairs, SelfPairsCache};
use super::terms::{ConstraintTerms, MAX_DOF};
use crate::contact::barrier::ColliderBarrier;
use crate::contact::edge_points::EdgeBarrier;
use crate::contact::self_barrier::SelfBarrier;
use crate::contact::smooth_friction::LaggedContact;
use crate::model::Model;
use std::sync::Arc;

/// Marks a coordinate without a degree of freedom (a control particle's, or an upper-triangle
/// entry of a local Hessian).
pub(super) const NONE: u32 = u32::MAX;

/// One constraint type and where each of its local Hessian entries goes in the sparse values.
struct GroupPattern {
    terms: Arc<dyn ConstraintTerms>,
    /// `1/α̃`.
    stiffness: f64,
    /// Per instance, `d × d` value indices (row-major), [`NONE`] where the entry is not stored.
    scatter: Vec<u32>,
}

/// How the constraint part of the Hessian is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HessianKind {
    /// `Σ (∇C∇Cᵀ + C∇²C)/α̃`: the exact Hessian.
    Exact,
    /// Each constraint's `d × d` block with its negative eigenvalues set to 0: positive definite
    /// (with the mass term) whatever the state.
    Projected,
}

/// The sparse structure of a model's Newton system.
pub struct Pattern {
    /// Degree of freedom of each particle's first coordinate ([`NONE`] for control particles).
    pub(super) dof_of: Vec<u32>,
    /// Mass `1/w` of each particle (0 for control particles).
    mass: Vec<f64>,
    /// Number of degrees of freedom (3 × free particles).
    pub n_dof: usize,
    /// Lower-triangular compressed columns.
    pub col_ptr: Vec<usize>,
    /// Row of each stored entry.
    pub row_idx: Vec<usize>,
    /// Index of each degree of freedom's diagonal entry.
    pub(super) diag: Vec<usize>,
    /// Every stored 3 × 3 particle block: (row block, column block, value index of each entry,
    /// row-major; a diagonal block's upper entries point at their lower mirror).
    blocks: Vec<(u32, u32, [u32; 9])>,
    /// Column block `c`'s blocks are `blocks[block_start[c]..block_start[c + 1]]` (by row).
    block_start: Vec<usize>,
    groups: Vec<GroupPattern>,
    /// The Hessian values of the linear groups' `k∇C∇Cᵀ` ([`ConstraintTerms::linear`]), the
    /// same at every state: every assembly of a Hessian starts from them.
    constant: Vec<f64>,
    /// Smooth contact: the barrier potential of every free particle, and the value indices of
    /// each particle's diagonal block (lower triangle, row-major; [`NONE`] above the diagonal).
    pub(super) barrier: Option<(Arc<ColliderBarrier>, Vec<[u32; 9]>)>,
    /// Smooth contact along the edges, for colliders narrower than them
    /// ([`crate::contact::edge_points`]).
    pub(super) edge_points: Option<EdgePointPattern>,
    /// Smooth contact with friction: the step's start (full `N × 3` data) and each particle's
    /// frictional contacts there ([`Pattern::begin_step`]).
    pub(super) friction: Option<(Vec<f64>, Vec<Vec<LaggedContact>>)>,
    /// Self-contact under Newton ([`super::self_contact`]): the barrier between parts of the
    /// cloth.
    pub(super) self_barrier: Option<Arc<SelfBarrier>>,
    /// Cloth–cloth friction: the step's start and its frictional self-contact pairs there
    /// ([`Pattern::begin_step`]).
    pub(super) self_friction: Option<Arc<LaggedSelfPairs>>,
    /// The particle blocks (row ≥ column) the self-contact pairs of the last
    /// [`Pattern::with_self_blocks`] added to the constraints' (sorted).
    pub(super) self_blocks: Vec<(u32, u32)>,
    /// The self-contact pairs of the last state they were found at (the line search, the
    /// assembly and the pattern's fit ask for the same state's in turn); shared with the
    /// patterns rebuilt from this one.
    pub(super) self_pairs_cache: Arc<SelfPairsCache>,
}

impl Pattern {
    /// The pattern of `model`'s Newton system. Contact rows ([`super::contact::is_contact`]) are
    /// not terms of `Φ` (they act through the active set); other rigid constraints (compliance 0)
    /// have no finite energy: the caller rejects them first ([`super::check_supported`]).
    pub fn new(model: &Model) -> Pattern {
        let groups: Vec<Arc<dyn ConstraintTerms>> = model
            .groups
            .iter()
            .map(|g| g.terms.clone())
            .filter(|t| !is_contact(t.as_ref()))
            .collect();
        // The free particles, numbered in the elimination order of the graph the constraints
        // make of them ([`super::ordering`]): the assembled matrix is already permuted.
        let mut free = vec![NONE; model.n_particles()];
        let mut n_free = 0u32;
        for (p, &w) in model.inv_mass.iter().enumerate() {
            if w > 0.0 {
                free[p] = n_free;
                n_free += 1;
            }
        }
        let mut edges = Vec::new();
        for terms in &groups {
            for k in 0..terms.count() {
                let ps = terms.particles(k);
                for (i, &a) in ps.iter().enumerate() {
                    for &b in &ps[i + 1..] {
                        if free[a] != NONE && free[b] != NONE {
                            edges.push((free[a], free[b]));
                        }
                    }
                }
            }
        }
        let position = elimination_positions(n_free as usize, &edges);
        let dof_of: Vec<u32> = free
            .iter()
            .map(|&f| {
                if f == NONE {
                    NONE
                } else {
                    3 * position[f as usize]
                }
            })
            .collect();
        let mass = model
            .inv_mass
            .iter()
            .map(|&w| if w > 0.0 { 1.0 / w } else { 0.0 })
            .collect();
        Pattern::structured(
            dof_of,
            mass,
            groups,
            (model.contact_barrier.clone(), model.edge_barrier.clone()),
            (model.self_barrier.clone(), Vec::new()),
            None,
        )
    }

    /// This pattern with the particle blocks `self_blocks` (row ≥ column, sorted, without
    /// duplicates) as its self-contact blocks instead of its own: the same degrees of freedom,
    /// energy and lagged friction.
    pub(super) fn with_self_blocks(&self, self_blocks: Vec<(u32, u32)>) -> Pattern {
        let mut pattern = Pattern::structured(
            self.dof_of.clone(),
            self.mass.clone(),
            self.groups.iter().map(|g| g.terms.clone()).collect(),
            (
                self.barrier.as_ref().map(|(b, _)| b.clone()),
                self.edge_points.as_ref().map(|e| e.edges.clone()),
            ),
            (self.self_barrier.clone(), self_blocks),
            self.friction.clone(),
        );
        pattern.self_pairs_cache = self.self_pairs_cache.clone();
        pattern.self_friction.clone_from(&self.self_friction);
        if let (Some(new), Some(old)) = (&mut pattern.edge_points, &self.edge_points) {
            new.friction = old.friction.clone();
        }
        pattern
    }

    /// The pattern over the degrees of freedom `dof_of` of the constraint `groups` and the
    /// extra particle blocks of self-contact.
    fn structured(
        dof_of: Vec<u32>,
        mass: Vec<f64>,
        groups: Vec<Arc<dyn ConstraintTerms>>,
        (barrier, edges): (Option<Arc<ColliderBarrier>>, Option<Arc<EdgeBarrier>>),
        (self_barrier, self_blocks): (Option<Arc<SelfBarrier>>, Vec<(u32, u32)>),
        friction: Option<(Vec<f64>, Vec<Vec<LaggedContact>>)>,
    ) -> Pattern {
        let n_free = dof_of.iter().filter(|&&d| d != NONE).count() as u32;
        let n_dof = 3 * n_free as usize;
        // Particle blocks (row ≥ column) touched by a mass or a constraint.
        let mut blocks: Vec<Vec<u32>> = vec![Vec::new(); n_free as usize];
        for &d in dof_of.iter().filter(|&&d| d != NONE) {
            blocks[d as usize / 3].push(d / 3);
        }
        for terms in &groups {
            for k in 0..terms.count() {
                let ps = terms.particles(k);
                for &a in ps {
                    for &b in ps {
                        let (da, db) = (dof_of[a], dof_of[b]);
                        if da != NONE && db != NONE && da >= db {
                            blocks[db as usize / 3].push(da / 3);
                        }
                    }
                }
            }
        }
        let edge_blocks = edges.as_ref().map(|e| coupled_blocks(e, &dof_of));
        for &(r, c) in self_blocks.iter().chain(edge_blocks.iter().flatten()) {
            blocks[c as usize].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n_dof + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (bc, rows) in blocks.iter_mut().enumerate() {
            rows.sort_unstable();
            rows.dedup();
            for j in 0..3 {
                for &br in rows.iter() {
                    let first = if br as usize == bc { j } else { 0 };
                    row_idx.extend((first..3).map(|i| 3 * br as usize + i));
                }
                col_ptr.push(row_idx.len());
            }
        }
        let index = |r: usize, c: usize| -> usize {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            col_ptr[c] + rows.binary_search(&r).expect("entry in the pattern")
        };
        let diag = (0..n_dof).map(|d| index(d, d)).collect();
        let mut block_list = Vec::new();
        let mut block_start = Vec::with_capacity(blocks.len() + 1);
        for (bc, rows) in blocks.iter().enumerate() {
            block_start.push(block_list.len());
            for &br in rows {
                let (r0, c0) = (3 * br as usize, 3 * bc);
                let idx = std::array::from_fn(|k| {
                    let (i, j) = (r0 + k / 3, c0 + k % 3);
                    index(i.max(j), i.min(j)) as u32
                });
                block_list.push((br, bc as u32, idx));
            }
        }
        block_start.push(block_list.len());
        let groups: Vec<GroupPattern> = groups
            .into_iter()
            .map(|terms| {
                let d = 3 * terms.arity();
                let mut scatter = vec![NONE; terms.count() * d * d];
                for (k, out) in scatter.chunks_exact_mut(d * d).enumerate() {
                    // Block by block (the entries `index` would find, for less search).
                    let ps = terms.particles(k);
                    for (pa, &a) in ps.iter().enumerate() {
                        for (pb, &b) in ps.iter().enumerate() {
                            let (ra, cb) = (dof_of[a], dof_of[b]);
                            if ra == NONE || cb == NONE || ra < cb {
                                continue;
                            }
                            let (br, bc) = (ra as usize / 3, cb as usize / 3);
                            let column = &block_list[block_start[bc]..block_start[bc + 1]];
                            let at = column.partition_point(|blk| (blk.0 as usize) < br);
                            let idx = &column[at].2;
                            for i in 0..3 {
                                // A diagonal block's upper entries are not stored.
                                for j in 0..if ra == cb { i + 1 } else { 3 } {
                                    out[(3 * pa + i) * d + 3 * pb + j] = idx[3 * i + j];
                                }
                            }
                        }
                    }
                }
                let compliance = terms.compliance();
                GroupPattern {
                    terms,
                    stiffness: 1.0 / compliance,
                    scatter,
                }
            })
            .collect();
        let barrier = barrier.map(|b| {
            let diagonal = (0..n_free as usize)
                .map(|blk| {
                    std::array::from_fn(|k| {
                        let (i, j) = (3 * blk + k / 3, 3 * blk + k % 3);
                        if i < j {
                            NONE
                        } else {
                            index(i, j) as u32
                        }
                    })
                })
                .collect();
            (b, diagonal)
        });
        let constant = Pattern::linear_hessian(&groups, row_idx.len());
        let mut pattern = Pattern {
            dof_of,
            mass,
            n_dof,
            col_ptr,
            row_idx,
            diag,
            blocks: block_list,
            block_start,
            groups,
            constant,
            barrier,
            friction,
            self_barrier,
            self_friction: None,
            self_blocks,
            self_pairs_cache: Arc::default(),
            edge_points: None,
        };
        pattern.edge_points = edges.map(|e| EdgePointPattern::new(e, &pattern));
        pattern
    }

    /// Every stored 3 × 3 particle block as (row block, column block, value indices row-major);
    /// a diagonal block's upper entries point at their lower mirror.
    pub fn blocks(&self) -> impl Iterator<Item = (usize, usize, &[u32; 9])> {
        self.blocks
            .iter()
            .map(|(r, c, idx)| (*r as usize, *c as usize, idx))
    }

    /// The value indices (row-major) of the stored particle block `(r, c)`, `r ≥ c` (particle
    /// blocks: degrees of freedom over 3); `None` when the pattern does not hold it.
    pub(super) fn block_index(&self, r: usize, c: usize) -> Option<&[u32; 9]> {
        let column = &self.blocks[self.block_start[c]..self.block_start[c + 1]];
        let i = column.binary_search_by_key(&(r as u32), |b| b.0).ok()?;
        Some(&column[i].2)
    }

    /// Number of stored (lower-triangle) entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Degree of freedom of particle `p`'s first coordinate, `None` for a control particle.
    pub fn dof(&self, p: usize) -> Option<usize> {
        let d = self.dof_of[p];
        (d != NONE).then_some(d as usize)
    }

    /// The free coordinates of a full `N × 3` state, in degree-of-freedom order.
    pub fn gather(&self, x: &[f64], out: &mut [f64]) {
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d != NONE {
                out[d as usize..d as usize + 3].copy_from_slice(&x[3 * p..3 * p + 3]);
            }
        }
    }

    /// Writes `z` (degree-of-freedom order) into the free coordinates of a full `N × 3` state
    /// `out`, the inverse of [`Pattern::gather`]; the control particles' rows are left as they are.
    pub fn scatter(&self, z: &[f64], out: &mut [f64]) {
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d != NONE {
                out[3 * p..3 * p + 3].copy_from_slice(&z[d as usize..d as usize + 3]);
            }
        }
    }

    /// Copies the coordinates without a degree of freedom (the held control particles) of the
    /// full state `from` into `to`.
    pub fn hold_fixed(&self, from: &[f64], to: &mut [f64]) {
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d == NONE {
                to[3 * p..3 * p + 3].copy_from_slice(&from[3 * p..3 * p + 3]);
            }
        }
    }

    /// Adds `step · v` (degree-of-freedom order) to the free coordinates of a full state.
    pub fn add_scaled(&self, x: &mut [f64], step: f64, v: &[f64]) {
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d != NONE {
                for k in 0..3 {
                    x[3 * p + k] += step * v[d as usize + k];
                }
            }
        }
    }

    /// `Φ(x)` for the predicted state `xt` (both full `N × 3` data).
    pub fn energy(&self, x: &[f64], xt: &[f64]) -> f64 {
        let mut phi = 0.0;
        for (p, &m) in self.mass.iter().enumerate() {
            if m > 0.0 {
                let d2: f64 = (0..3).map(|k| (x[3 * p + k] - xt[3 * p + k]).powi(2)).sum();
                phi += 0.5 * m * d2;
            }
        }
        let mut local = [0.0; MAX_DOF];
        for g in &self.groups {
            let terms = g.terms.as_ref();
            for k in 0..terms.count() {
                let d = gather_local(terms.particles(k), x, &mut local);
                let c = terms.value(k, &local[..d]);
                if !terms.inequality() || c < 0.0 {
                    phi += 0.5 * g.stiffness * c * c;
                }
            }
        }
        phi += self.collider_energy(x);
        if let Some(b) = &self.self_barrier {
            phi += b.energy(x, &self.self_pairs(x));
            if let Some(f) = &self.self_friction {
                phi += b.friction_energy(x, &f.start, &f.pairs);
            }
        }
        phi
    }

    /// `∇Φ(x)` into `grad` (degree-of-freedom order) and, with `values`, the Hessian of `kind`
    /// into the pattern's values.
    pub fn assemble(
        &self,
        x: &[f64],
        xt: &[f64],
        grad: &mut [f64],
        mut values: Option<(&mut [f64], HessianKind)>,
    ) {
        grad.fill(0.0);
        if let Some((v, _)) = values.as_mut() {
            v.copy_from_slice(&self.constant);
        }
        for (p, &m) in self.mass.iter().enumerate() {
            let d = self.dof_of[p];
            if d == NONE {
                continue;
            }
            for k in 0..3 {
                let i = d as usize + k;
                grad[i] += m * (x[3 * p + k] - xt[3 * p + k]);
                if let Some((v, _)) = values.as_mut() {
                    v[self.diag[i]] += m;
                }
            }
        }
        let (mut local, mut g, mut h) = ([0.0; MAX_DOF], [0.0; MAX_DOF], [0.0; MAX_DOF * MAX_DOF]);
        for gp in &self.groups {
            let terms = gp.terms.as_ref();
            let linear = terms.linear();
            for k in 0..terms.count() {
                let ps = terms.particles(k);
                let d = gather_local(ps, x, &mut local);
                let (g, h) = (&mut g[..d], &mut h[..d * d]);
                // `∇²C` only where a Hessian is assembled (`∇C` is the same bits either way); a
                // linear group's Hessian is in `constant` already.
                let c = if values.is_some() && !linear {
                    terms.second_order(k, &local[..d], g, h)
                } else {
                    terms.first_order(k, &local[..d], g)
                };
                if terms.inequality() && c >= 0.0 {
                    continue;
                }
                let s = gp.stiffness;
                for a in 0..d {
                    if let Some(da) = self.dof(ps[a / 3]) {
                        grad[da + a % 3] += s * c * g[a];
                    }
                }
                let Some((v, kind)) = values.as_mut().filter(|_| !linear) else {
                    continue;
                };
                match kind {
                    HessianKind::Exact => local_hessian(s, c, g, h),
                    HessianKind::Projected => projected_local_hessian(s, c, g, h),
                }
                let scatter = &gp.scatter[k * d * d..(k + 1) * d * d];
                for (&i, &hv) in scatter.iter().zip(h.iter()) {
                    if i != NONE {
                        v[i as usize] += hv;
                    }
                }
            }
        }
        self.assemble_colliders(x, grad, values.as_mut().map(|(v, k)| (&mut **v, *k)));
        self.assemble_self(x, grad, values);
    }

    /// The Hessian values (`nnz` of them) of the linear groups: `k∇C∇Cᵀ` per instance,
    /// scattered as [`Pattern::assemble`] would at any state (`∇C` of an affine `C` is the same
    /// everywhere; it is taken at the origin). Exact and projected alike: the block is
    /// semidefinite.
    fn linear_hessian(groups: &[GroupPattern], nnz: usize) -> Vec<f64> {
        let mut values = vec![0.0; nnz];
        let (zero, mut g, mut h) = ([0.0; MAX_DOF], [0.0; MAX_DOF], [0.0; MAX_DOF * MAX_DOF]);
        for gp in groups.iter().filter(|gp| gp.terms.linear()) {
            let d = 3 * gp.terms.arity();
            for k in 0..gp.terms.count() {
                let (g, h) = (&mut g[..d], &mut h[..d * d]);
                gp.terms.first_order(k, &zero[..d], g);
                h.fill(0.0);
                local_hessian(gp.stiffness, 0.0, g, h);
                let scatter = &gp.scatter[k * d * d..(k + 1) * d * d];
                for (&i, &hv) in scatter.iter().zip(h.iter()) {
                    if i != NONE {
                        values[i as usize] += hv;
                    }
                }
            }
        }
        values
    }

    /// `y −= H_cf z`: the exact Hessian's coupling of control-particle coordinates (rows of `y`,
    /// `N × 3` data) to the free ones (`z`, degree-of-freedom order), at state `x`.
    pub fn sub_control_coupling(&self, x: &[f64], z: &[f64], y: &mut [f64]) {
        self.control_coupling(x, |c, f, h| y[c] -= h * z[f]);
    }

    /// Visits the exact Hessian's coupling of the control particles to the free ones at state
    /// `x`: `visit(c, f, h)` for an entry `h` in control coordinate `c` (an index into `N × 3`
    /// data) and degree of freedom `f`; an entry may come in several parts, to be summed.
    pub(super) fn control_coupling(&self, x: &[f64], mut visit: impl FnMut(usize, usize, f64)) {
        let (mut local, mut g, mut h) = ([0.0; MAX_DOF], [0.0; MAX_DOF], [0.0; MAX_DOF * MAX_DOF]);
        for gp in &self.groups {
            let terms = gp.terms.as_ref();
            for k in 0..terms.count() {
                let ps = terms.particles(k);
                if ps.iter().all(|&p| self.dof_of[p] != NONE) {
                    continue;
                }
                let d = gather_local(ps, x, &mut local);
                let (g, h) = (&mut g[..d], &mut h[..d * d]);
                let c = terms.second_order(k, &local[..d], g, h);
                if terms.inequality() && c >= 0.0 {
                    continue;
                }
                local_hessian(gp.stiffness, c, g, h);
                for a in 0..d {
                    if self.dof_of[ps[a / 3]] != NONE {
                        continue;
                    }
                    for b in 0..d {
                        if let Some(db) = self.dof(ps[b / 3]) {
                            visit(3 * ps[a / 3] + a % 3, db + b % 3, h[a * d + b]);
                        }
                    }
                }
            }
        }
        self.self_control_coupling(x, &mut visit);
    }

    /// The largest step length in `[0, 1]` along `dir` (degree-of-freedom order) from `x` that
    /// the smooth contact potential allows ([`ColliderBarrier::max_step`]); 1 without it.
    pub fn max_step(&self, x: &[f64], step: f64, dir: &[f64]) -> f64 {
        self.max_step_free(x, step, dir, 0.0)
    }

    /// [`Pattern::max_step`], where no particle moving at most `free` can be stopped by
    /// self-contact ([`Pattern::self_free_move`] at `x`, or 0): such moves skip its sweep.
    pub(super) fn max_step_free(&self, x: &[f64], step: f64, dir: &[f64], free: f64) -> f64 {
        let largest = || {
            (dir.chunks_exact(3))
                .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                .fold(0.0, f64::max)
        };
        let alpha = if free > 0.0 && step.abs() * largest() <= free {
            1.0
        } else {
            self.self_max_step(x, step, dir)
        };
        self.colliders_allow(x, alpha, |_, d| {
            [step * dir[d], step * dir[d + 1], step * dir[d + 2]]
        })
    }

    /// Whether the model has a barrier potential, of the colliders or of self-contact (its
    /// states must stay outside the colliders and apart by the thickness).
    pub fn has_barrier(&self) -> bool {
        self.barrier.is_some() || self.self_barrier.is_some()
    }

    /// `M z` for the free particles, scattered into full `N × 3` data `y` (added).
    pub fn add_mass_times(&self, z: &[f64], y: &mut [f64]) {
        for (p, &d) in self.dof_of.iter().enumerate() {
            if d != NONE {
                for k in 0..3 {
                    y[3 * p + k] += self.mass[p] * z[d as usize + k];
                }
            }
        }
    }
}

/// Copies the coordinates of `particles` from full data `x` into `local`; returns their count.
/// Copies the coordinates of `particles` in `x` (full data) into `local`; their count.
pub(super) fn gather_local(particles: &[usize], x: &[f64], local: &mut [f64; MAX_DOF]) -> usize {
    for (i, &p) in particles.iter().enumerate() {
        local[3 * i..3 * i + 3].copy_from_slice(&x[3 * p..3 * p + 3]);
    }
    3 * particles.len()
}

/// Overwrites `h` (holding `∇²C`) with `s (∇C∇Cᵀ + C∇²C)`.
pub(super) fn local_hessian(s: f64, c: f64, g: &[f64], h: &mut [f64]) {
    let d = g.len();
    for a in 0..d {
        for b in 0..d {
            h[a * d + b] = s * (g[a] * g[b] + c * h[a * d + b]);
        }
    }
}
