//! Self-contact in Newton's system: the barrier between parts of the cloth
//! ([`crate::contact::self_barrier`]) in `Φ`, its gradient, Hessian and step filter.
//!
//! A pair couples particles that no constraint does, so the Hessian's pattern depends on the
//! state: [`NewtonSystem`](super::solve::NewtonSystem) rebuilds it (and the factorization's
//! symbolic analysis) whenever the pairs at the state it assembles need blocks the pattern
//! does not hold ([`Pattern::self_blocks_for`]), or takes back one of the last patterns it left
//! that holds them, with its analysis. A rebuilt pattern also holds the blocks of the pairs a
//! little beyond the barrier's reach ([`PATTERN_REACH`]), so the iterates that follow seldom
//! need another. The pattern thus depends on the solve's path; a rollout keeps each step's
//! ([`super::continuation::NewtonKept`]), so the gradient pass, which assembles at the same
//! converged states, factorizes the same matrices as the forward, bit for bit. The
//! pair searches and step filters go through a Verlet list of candidate pairs
//! ([`crate::contact::self_candidates`]), with the same answers as a search of the whole cloth.

use super::assembly::{HessianKind, Pattern};
use super::factor::Factor;
use super::psd::project_psd;
use super::solve::{NewtonSystem, StepStats};
use super::NewtonSettings;
use crate::contact::self_barrier::SelfPair;
use crate::contact::self_candidates::Candidates;
use crate::contact::self_filter::Sweep;
use crate::contact::self_friction::LaggedPair;
use crate::error::ClothError;
use autodiff::Tensor;
use std::sync::{Arc, Mutex};

/// The self-contact pairs of the last state asked for, with that state, and the sweep of the last
/// step filtered ([`Sweep`]: the pairs of the states a line search tries along that step are
/// filtered from it instead of searched). Shared by a pattern and the patterns rebuilt from it
/// (the pairs depend on the state alone), with the counts of the work done.
#[derive(Default)]
pub(super) struct SelfPairsCache(Mutex<PairsCacheState>);

#[derive(Default)]
struct PairsCacheState {
    last: Option<(Vec<f64>, Arc<Vec<SelfPair>>)>,
    sweep: Sweep,
    /// The candidate pairs of the searches and the sweeps (a Verlet list).
    candidates: Candidates,
    counts: SelfCounts,
}

/// Self-contact's work so far (the [`StepStats`] fields of the same names).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct SelfCounts {
    pub(super) pair_searches: usize,
    pub(super) pair_filters: usize,
    pub(super) step_filters: usize,
    pub(super) pattern_rebuilds: usize,
    pub(super) pattern_reuses: usize,
    pub(super) grid_searches: usize,
}

impl SelfCounts {
    /// Adds the counts since `earlier` (an earlier reading of the same cache) to `stats`.
    pub(super) fn add_since(self, earlier: SelfCounts, stats: &mut StepStats) {
        stats.pair_searches += self.pair_searches - earlier.pair_searches;
        stats.pair_filters += self.pair_filters - earlier.pair_filters;
        stats.step_filters += self.step_filters - earlier.step_filters;
        stats.pattern_rebuilds += self.pattern_rebuilds - earlier.pattern_rebuilds;
        stats.pattern_reuses += self.pattern_reuses - earlier.pattern_reuses;
        stats.grid_searches += self.grid_searches - earlier.grid_searches;
    }
}

/// Cloth–cloth friction's lagged data for one step ([`Pattern::begin_step`]).
pub(super) struct LaggedSelfPairs {
    /// The step's start (full `N × 3` data).
    pub(super) start: Vec<f64>,
    /// Its frictional pairs.
    pub(super) pairs: Vec<LaggedPair>,
    /// The particle blocks they couple (row ≥ column, sorted): every pattern of the step holds
    /// them.
    pub(super) blocks: Vec<(u32, u32)>,
}

/// Self-contact patterns (with their symbolic analyses) a Newton system keeps after leaving
/// them, to go back to without a new analysis: the pairs' blocks often come and go between a
/// few sets as a solve's iterates move.
const RECENT_PATTERNS: usize = 8;

/// A rebuilt pattern holds the blocks of the pairs nearer than the thickness plus this many
/// barrier reaches `d̂`, not only those of the pairs within one: the iterates and steps that
/// follow move the pairs in and out of reach, and a pattern that already holds their blocks
/// (as explicit zeros until then) is kept instead of being rebuilt with a new symbolic
/// analysis.
const PATTERN_REACH: f64 = 1.5;

/// Whether the sorted `pattern` holds every block of the sorted `blocks`.
fn holds(pattern: &[(u32, u32)], blocks: &[(u32, u32)]) -> bool {
    let mut rest = pattern.iter();
    blocks.iter().all(|b| rest.any(|p| p == b))
}

/// Solves one step takes at most while the control particles move to their places.
const MAX_CONTROL_STAGES: usize = 64;

/// Stages in a row, each bringing the control particles less than `1 / MAX_CONTROL_STAGES` of
/// the way that remains, after which a step gives up: at that pace the stages run out before
/// the controls arrive. A gripper pressing cloth onto a collider, or onto cloth that lies on
/// one, cannot push it through: each stage closes part of the squeezed gap, the fractions fall
/// geometrically, and the last stages of the budget take a hundred iterations or more each.
const STALLED_STAGES: usize = 3;

impl NewtonSystem {
    /// Self-contact: changes the pattern (and the factorization's symbolic analysis) when the
    /// pairs at `x` couple particle blocks it does not hold: to the most recent of the last
    /// [`RECENT_PATTERNS`] patterns left that holds them, else to a new one holding the blocks
    /// of the pairs within [`PATTERN_REACH`] (blocks without a pair are explicit zeros).
    pub(super) fn fit_self_contact(&mut self, x: &[f64]) {
        if self.pattern.self_barrier.is_none() {
            return;
        }
        let pairs = self.pattern.self_pairs(x);
        let blocks = self.pattern.self_blocks_for(&pairs);
        // Cloth–cloth friction's pairs, lagged at the step's start, are in every pattern of the
        // step (sorted already: checked apart, merged only for a new pattern).
        let friction = self.pattern.self_friction.clone();
        let lagged: &[(u32, u32)] = friction.as_ref().map_or(&[], |f| &f.blocks);
        let fits = |p: &Pattern| holds(&p.self_blocks, &blocks) && holds(&p.self_blocks, lagged);
        if fits(&self.pattern) {
            return;
        }
        let recent = self.recent.iter().position(|(p, _)| fits(p));
        self.switch_pattern(recent, |p| p.wide_blocks(x, [&blocks[..], lagged].concat()));
    }

    /// Self-contact: makes the pattern the one with exactly the self-contact blocks `blocks`
    /// (a kept step's, [`super::continuation::NewtonKept`]), so that the gradient pass
    /// factorizes the forward's matrices bit for bit.
    pub(super) fn adopt_self_blocks(&mut self, blocks: &[(u32, u32)]) {
        if self.pattern.self_barrier.is_none() || self.pattern.self_blocks == blocks {
            return;
        }
        let recent = self
            .recent
            .iter()
            .position(|(p, _)| p.self_blocks == blocks);
        self.switch_pattern(recent, |_| blocks.to_vec());
    }

    /// Switches to the recent pattern at `recent`, or else to a new one with the self-contact
    /// blocks `build` gives from the current one, keeping the pattern left among the recent ones.
    fn switch_pattern(
        &mut self,
        recent: Option<usize>,
        build: impl FnOnce(&Pattern) -> Vec<(u32, u32)>,
    ) {
        let (mut pattern, mut analysis) = match recent {
            Some(i) => {
                self.pattern.self_counts_mut(|c| c.pattern_reuses += 1);
                let (mut p, f) = self.recent.remove(i);
                // The step's lagged friction (`Pattern::begin_step`), maybe not its.
                p.friction.clone_from(&self.pattern.friction);
                p.self_friction.clone_from(&self.pattern.self_friction);
                (p, f)
            }
            None => {
                self.pattern.self_counts_mut(|c| c.pattern_rebuilds += 1);
                let p = self.pattern.with_self_blocks(build(&self.pattern));
                let f = Factor::new(&p);
                (p, f)
            }
        };
        std::mem::swap(&mut self.pattern, &mut pattern);
        self.factor.swap_analysis(&mut analysis);
        self.recent.insert(0, (pattern, analysis));
        self.recent.truncate(RECENT_PATTERNS);
        self.values.resize(self.pattern.nnz(), 0.0);
    }

    /// One step under self-contact, from the previous state `x_prev` to the minimizer of `Φ` for
    /// the predicted state `xt`. The control particles are not put at their new places at once
    /// (a gripper's move could bring the cloth it holds within the thickness of another part):
    /// they move there in stages, each as far as the step filter allows with the cloth where
    /// the last stage's solve left it (or, with [`NewtonSettings::predictor`], moved with them
    /// by its first-order response, `super::predictor`), and each stage is solved, so that the
    /// cloth makes way. The last stage is the step's `Φ`, solved from there; the statistics sum
    /// the stages ([`StepStats::loads`] counts them).
    ///
    /// # Errors
    /// As [`NewtonSystem::solve_from`]; [`ClothError::SelfContactPenetration`] when the controls
    /// cannot reach their places in [`MAX_CONTROL_STAGES`] stages, or have stalled on the way
    /// ([`STALLED_STAGES`]).
    pub(super) fn solve_moving_controls(
        &mut self,
        x_prev: &Tensor,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<(Tensor, StepStats), ClothError> {
        let mut stats = StepStats::default();
        let mut x = x_prev.clone();
        let mut stalled = 0;
        for _ in 0..MAX_CONTROL_STAGES {
            let delta = self.pattern.control_move(&x, xt);
            let before = self.pattern.self_counts();
            let (alpha, _) = self.pattern.self_filter(x.data(), &delta);
            stats.step_filters += 1;
            (self.pattern.self_counts()).add_since(before, &mut stats);
            let (alpha, xj, sj) = self.solve_stage((&x, xt), (&delta, alpha), step, settings)?;
            stats.add_work(&sj);
            stats.loads += 1;
            stats.residual = sj.residual;
            stats.at_roundoff = sj.at_roundoff;
            x = xj;
            if alpha == 1.0 {
                return Ok((x, stats));
            }
            // Each stage takes `alpha` of the way that remains.
            stalled = if alpha < 1.0 / MAX_CONTROL_STAGES as f64 {
                stalled + 1
            } else {
                0
            };
            if stalled == STALLED_STAGES {
                break;
            }
        }
        let mut at_target = x.clone();
        self.pattern.hold_fixed(xt.data(), at_target.data_mut());
        let (particles, gap) = self
            .pattern
            .self_penetration(at_target.data())
            .unwrap_or(([0; 4], 0.0));
        Err(ClothError::SelfContactPenetration {
            step,
            particles,
            gap,
        })
    }
}

impl Pattern {
    /// Cloth–cloth friction: lags the frictional pairs at the step's start `y` (full `N × 3`
    /// data). Nothing without it.
    pub(super) fn begin_self_friction(&mut self, y: &[f64]) {
        let Some(b) = self.self_barrier.as_ref().filter(|b| b.friction.is_some()) else {
            return;
        };
        let pairs = b.lagged_pairs(y, &self.self_pairs(y));
        let quads: Vec<SelfPair> = pairs.iter().map(|l| l.pair).collect();
        self.self_friction = Some(Arc::new(LaggedSelfPairs {
            start: y.to_vec(),
            blocks: self.self_blocks_for(&quads),
            pairs,
        }));
    }

    /// The self-contact pairs at `x` (`N × 3` data); none without self-contact.
    pub(super) fn self_pairs(&self, x: &[f64]) -> Arc<Vec<SelfPair>> {
        let Some(b) = &self.self_barrier else {
            return Arc::default();
        };
        let mut cache = self.self_pairs_cache.0.lock().expect("an unpoisoned cache");
        if let Some((at, pairs)) = cache.last.as_ref() {
            if at[..] == *x {
                return pairs.clone();
            }
        }
        let pairs = match b.pairs_in(x, &cache.sweep) {
            Some(pairs) => {
                cache.counts.pair_filters += 1;
                pairs
            }
            None => {
                cache.counts.pair_searches += 1;
                b.pairs_listed(x, &mut cache.candidates)
            }
        };
        let pairs = Arc::new(pairs);
        cache.last = Some((x.to_vec(), pairs.clone()));
        pairs
    }

    /// The self-contact step filter along `delta` (`N × 3` data) from `x`
    /// ([`crate::contact::self_barrier::SelfBarrier::max_step`], its candidates through the
    /// cache's list); `(1, empty)` without self-contact.
    fn self_filter(&self, x: &[f64], delta: &[f64]) -> (f64, Sweep) {
        let Some(b) = &self.self_barrier else {
            return (1.0, Sweep::default());
        };
        let mut cache = self.self_pairs_cache.0.lock().expect("an unpoisoned cache");
        b.max_step_listed(x, delta, 1.0, &mut cache.candidates)
    }

    /// The largest step length in `[0, 1]` along the motion `delta` of every particle (`N × 3`
    /// data) from `x` that both barriers allow: self-contact's filter on every particle, the
    /// colliders' on the free ones.
    pub(super) fn max_move(&self, x: &[f64], delta: &[f64]) -> f64 {
        let (alpha, _) = self.self_filter(x, delta);
        self.colliders_allow(x, alpha, |p, _| {
            [delta[3 * p], delta[3 * p + 1], delta[3 * p + 2]]
        })
    }

    /// Self-contact's work so far (zero without self-contact).
    pub(super) fn self_counts(&self) -> SelfCounts {
        let cache = self.self_pairs_cache.0.lock().expect("an unpoisoned cache");
        SelfCounts {
            grid_searches: cache.candidates.searches,
            ..cache.counts
        }
    }

    /// Changes the work counts with `f`.
    fn self_counts_mut(&self, f: impl FnOnce(&mut SelfCounts)) {
        f(&mut self
            .self_pairs_cache
            .0
            .lock()
            .expect("an unpoisoned cache")
            .counts);
    }

    /// `blocks` with those of every pair at `x` nearer than `h + PATTERN_REACH · d̂`
    /// ([`PATTERN_REACH`]): a pattern the iterates after `x` keep within.
    fn wide_blocks(&self, x: &[f64], blocks: Vec<(u32, u32)>) -> Vec<(u32, u32)> {
        let Some(b) = &self.self_barrier else {
            return blocks;
        };
        let reach = b.thickness + PATTERN_REACH * b.barrier.d_hat;
        let mut wide = self.self_blocks_for(&b.pairs_within(x, reach));
        wide.extend(blocks);
        wide.sort_unstable();
        wide.dedup();
        wide
    }

    /// The particle blocks (row ≥ column, sorted, without duplicates) that `pairs` couple.
    pub(super) fn self_blocks_for(&self, pairs: &[SelfPair]) -> Vec<(u32, u32)> {
        let mut blocks = Vec::new();
        for pair in pairs {
            let dofs = pair.particles.map(|p| self.dof(p));
            for a in dofs.iter().flatten() {
                for b in dofs.iter().flatten() {
                    if a > b {
                        blocks.push(((a / 3) as u32, (b / 3) as u32));
                    }
                }
            }
        }
        blocks.sort_unstable();
        blocks.dedup();
        blocks
    }

    /// The self-contact term's gradient into `grad` (degree-of-freedom order) and, with `values`,
    /// its Hessian (each pair's 12 × 12 block projected to semidefinite for
    /// [`HessianKind::Projected`]). The pattern must hold the pairs' blocks at `x`.
    pub(super) fn assemble_self(
        &self,
        x: &[f64],
        grad: &mut [f64],
        mut values: Option<(&mut [f64], HessianKind)>,
    ) {
        let Some(barrier) = &self.self_barrier else {
            return;
        };
        let (mut g, mut h) = ([0.0; 12], [0.0; 144]);
        for pair in self.self_pairs(x).iter() {
            let Some(involved) = barrier.pair_derivatives(x, pair, &mut g, &mut h) else {
                // At or within the thickness: only a predicted state can be there.
                continue;
            };
            if let Some((_, HessianKind::Projected)) = values {
                project_involved(&mut h, involved);
            }
            self.scatter_pair(pair, &g, &h, grad, values.as_mut().map(|(v, _)| &mut **v));
        }
        self.add_self_friction(x, grad, values.map(|(v, _)| v));
    }

    /// Adds a pair's gradient `g` and, with `values`, Hessian `h` (its particles in order) to
    /// the free particles' entries.
    fn scatter_pair(
        &self,
        pair: &SelfPair,
        g: &[f64; 12],
        h: &[f64; 144],
        grad: &mut [f64],
        values: Option<&mut [f64]>,
    ) {
        let dofs = pair.particles.map(|p| self.dof(p));
        for a in 0..12 {
            if let Some(da) = dofs[a / 3] {
                grad[da + a % 3] += g[a];
            }
        }
        let Some(v) = values else {
            return;
        };
        // Block by block: each stored entry takes one value per pair, as entry by entry.
        for (pa, da) in dofs.iter().enumerate() {
            let Some(da) = *da else { continue };
            for (pb, db) in dofs.iter().enumerate() {
                let Some(db) = *db else { continue };
                if da < db {
                    continue;
                }
                let idx = self
                    .block_index(da / 3, db / 3)
                    .expect("the pattern holds the self-contact pairs' blocks");
                for i in 0..3 {
                    // A diagonal block's upper entries are its lower ones'.
                    let columns = if da == db { i + 1 } else { 3 };
                    for j in 0..columns {
                        v[idx[3 * i + j] as usize] += h[12 * (3 * pa + i) + 3 * pb + j];
                    }
                }
            }
        }
    }

    /// Adds cloth–cloth friction's gradient at `x` to `grad` (degree-of-freedom order) and, with
    /// `values`, its Hessian (semidefinite as it is). Its gradient alone is also its
    /// `∂(∇Φ)/∂ log μ`, the potential being linear in `μ`. Nothing without it.
    pub(super) fn add_self_friction(
        &self,
        x: &[f64],
        grad: &mut [f64],
        mut values: Option<&mut [f64]>,
    ) {
        let (Some(b), Some(f)) = (&self.self_barrier, &self.self_friction) else {
            return;
        };
        let (mut g, mut h) = ([0.0; 12], [0.0; 144]);
        for l in &f.pairs {
            b.pair_friction_derivatives(x, &f.start, l, &mut g, &mut h);
            self.scatter_pair(&l.pair, &g, &h, grad, values.as_deref_mut());
        }
    }

    /// Calls `f(start particle, state degree of freedom, block)` for cloth–cloth friction's
    /// coupling of the state at `x` to the step's start, `∂(∇ₓD)/∂y` per pair of a frictional
    /// pair's particles (the state's free).
    pub(super) fn for_each_self_start_coupling(
        &self,
        x: &[f64],
        f: &mut impl FnMut(usize, usize, &[f64; 9]),
    ) {
        let (Some(b), Some(lagged)) = (&self.self_barrier, &self.self_friction) else {
            return;
        };
        for l in &lagged.pairs {
            let cross = b.pair_friction_cross(x, &lagged.start, &l.pair);
            for (i, &pi) in l.pair.particles.iter().enumerate() {
                let Some(d) = self.dof(pi) else { continue };
                for (k, &pk) in l.pair.particles.iter().enumerate() {
                    let block =
                        std::array::from_fn(|e| cross[12 * (3 * i + e / 3) + 3 * k + e % 3]);
                    f(pk, d, &block);
                }
            }
        }
    }

    /// [`Pattern::control_coupling`]'s entries from the self-contact pairs at `x` that hold a
    /// control particle and a free one.
    pub(super) fn self_control_coupling(
        &self,
        x: &[f64],
        visit: &mut impl FnMut(usize, usize, f64),
    ) {
        let Some(barrier) = &self.self_barrier else {
            return;
        };
        let (mut g, mut h) = ([0.0; 12], [0.0; 144]);
        let held = |pair: &SelfPair| pair.particles.iter().any(|&p| self.dof(p).is_none());
        let mut visit_pair = |pair: &SelfPair, h: &[f64; 144]| {
            let dofs = pair.particles.map(|p| self.dof(p));
            for a in (0..12).filter(|a| dofs[a / 3].is_none()) {
                for b in 0..12 {
                    if let Some(db) = dofs[b / 3] {
                        visit(3 * pair.particles[a / 3] + a % 3, db + b % 3, h[12 * a + b]);
                    }
                }
            }
        };
        for pair in self.self_pairs(x).iter().filter(|p| held(p)) {
            if barrier.pair_derivatives(x, pair, &mut g, &mut h).is_some() {
                visit_pair(pair, &h);
            }
        }
        if let Some(f) = &self.self_friction {
            for l in f.pairs.iter().filter(|l| held(&l.pair)) {
                barrier.pair_friction_derivatives(x, &f.start, l, &mut g, &mut h);
                visit_pair(&l.pair, &h);
            }
        }
    }

    /// The largest step length in `[0, 1]` along `dir` (degree-of-freedom order, scaled by
    /// `step`) from `x` that keeps every self-contact pair's gap above the filter's floor
    /// ([`crate::contact::self_barrier::SelfBarrier::max_step`]); 1 without self-contact.
    pub(super) fn self_max_step(&self, x: &[f64], step: f64, dir: &[f64]) -> f64 {
        if self.self_barrier.is_none() {
            return 1.0;
        }
        let mut delta = vec![0.0; x.len()];
        for p in 0..x.len() / 3 {
            if let Some(d) = self.dof(p) {
                for k in 0..3 {
                    delta[3 * p + k] = step * dir[d + k];
                }
            }
        }
        let (alpha, sweep) = self.self_filter(x, &delta);
        let mut cache = self.self_pairs_cache.0.lock().expect("an unpoisoned cache");
        cache.sweep = sweep;
        cache.counts.step_filters += 1;
        alpha
    }

    /// [`crate::contact::self_barrier::SelfBarrier::free_move`] at `x`: a particle move
    /// [`Pattern::self_max_step`] allows whole; ∞ without self-contact.
    pub(super) fn self_free_move(&self, x: &[f64]) -> f64 {
        match &self.self_barrier {
            Some(b) => b.free_move(x, &self.self_pairs(x)),
            None => f64::INFINITY,
        }
    }

    /// Self-contact: the pair of `x` nearest within the thickness, its particles and gap
    /// `d − h ≤ 0`; `None` when every pair is apart (or without self-contact).
    pub fn self_penetration(&self, x: &[f64]) -> Option<([usize; 4], f64)> {
        let barrier = self.self_barrier.as_ref()?;
        let pairs = self.self_pairs(x);
        barrier
            .penetration_among(x, &pairs)
            .map(|(p, gap)| (p.particles, gap))
    }
}

/// Projects the pair Hessian `h` (row-major 12 × 12, zero outside the `involved` particles'
/// rows and columns) onto the semidefinite matrices, on the involved particles' block alone
/// (6, 9 or 12 coordinates).
fn project_involved(h: &mut [f64; 144], involved: [bool; 4]) {
    let mut coords = [0usize; 12];
    let mut d = 0;
    for a in (0..12).filter(|a| involved[a / 3]) {
        coords[d] = a;
        d += 1;
    }
    let coords = &coords[..d];
    if d == 12 {
        return project_psd(h, 12);
    }
    let mut local = [0.0; 144];
    for (i, &a) in coords.iter().enumerate() {
        for (j, &b) in coords.iter().enumerate() {
            local[d * i + j] = h[12 * a + b];
        }
    }
    project_psd(&mut local[..d * d], d);
    for (i, &a) in coords.iter().enumerate() {
        for (j, &b) in coords.iter().enumerate() {
            h[12 * a + b] = local[d * i + j];
        }
    }
}
