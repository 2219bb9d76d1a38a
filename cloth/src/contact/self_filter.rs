//! The step filter of self-contact under Newton ([`super::self_barrier`]): the pairs a straight
//! motion of the particles can bring within the barrier's reach (a [`Sweep`]), and the longest
//! step along it that keeps every pair's gap above its floor, by additive continuous collision
//! detection (Li et al. 2021, "Codimensional IPC", §5).

use super::barrier::APPROACH;
use super::grid::Aabb;
use super::self_barrier::{at, swept_boxes, PairKind, SelfBarrier, SelfPair};
use super::self_candidates::Candidates;

/// Advances one pair's time-of-impact search makes at most before it stops where it is.
const MAX_ADVANCES: usize = 200;

impl SelfBarrier {
    /// The pairs that can come nearer than `h + d̂` anywhere in the particles' boxes swept from
    /// `x` to `x + δ` (both `N × 3` data), hence anywhere on that straight motion: those whose
    /// swept boxes come that near and whose distance at `x`, less the largest move of a particle
    /// of each of their features, is below it; in [`SelfBarrier::pairs`]' order, with their gaps
    /// `d − h` at `x`.
    pub fn sweep(&self, x: &[f64], delta: &[f64]) -> Sweep {
        self.sweep_with(x, delta, None)
    }

    /// [`SelfBarrier::sweep`], through a candidate list when there is one.
    fn sweep_with(&self, x: &[f64], delta: &[f64], list: Option<&mut Candidates>) -> Sweep {
        let boxes = swept_boxes(x, Some(delta));
        let moved: Vec<f64> = (0..boxes.len()).map(|p| at(delta, p).norm()).collect();
        let (mut pairs, mut gaps) = (Vec::new(), Vec::new());
        let reach = self.thickness + self.barrier.d_hat;
        self.candidates_with(&boxes, reach, list, |pair| {
            let m = pair.particles.map(|q| moved[q]);
            let farthest = match pair.kind {
                PairKind::PointTriangle => m[0] + m[1].max(m[2]).max(m[3]),
                PairKind::EdgeEdge(_) => m[0].max(m[1]) + m[2].max(m[3]),
            };
            let d = self.distance(x, &pair);
            if d - farthest < reach {
                pairs.push(pair);
                gaps.push(d - self.thickness);
            }
        });
        Sweep { boxes, pairs, gaps }
    }

    /// [`SelfBarrier::pairs`] of `x` when every particle of `x` is within its box of `sweep`
    /// (any state on the swept motion is): the same pairs in the same order, filtered from the
    /// sweep's instead of searched; `None` otherwise.
    pub fn pairs_in(&self, x: &[f64], sweep: &Sweep) -> Option<Vec<SelfPair>> {
        let inside = sweep.boxes.len() * 3 == x.len()
            && sweep.boxes.iter().enumerate().all(|(p, (lo, hi))| {
                (0..3).all(|k| lo[k] <= x[3 * p + k] && x[3 * p + k] <= hi[k])
            });
        let reach = self.thickness + self.barrier.d_hat;
        inside.then(|| {
            sweep
                .pairs
                .iter()
                .filter(|pair| self.distance(x, pair) < reach)
                .copied()
                .collect()
        })
    }

    /// The largest step length `α ≤ alpha` such that moving every particle in a straight line
    /// from `x` to `x + α δ` (both `N × 3` data) keeps every pair's gap `d − h` at least
    /// [`APPROACH`] times the smaller of its gap at `x` and `d̂`: additive continuous collision
    /// detection per pair of the motion's [`SelfBarrier::sweep`] (which holds every pair that can
    /// come that near), each advancing by the length its relative motion cannot close. 0 when a
    /// pair is already at or within the thickness. The sweep is returned for the states the
    /// line search then tries on the motion ([`SelfBarrier::pairs_in`]).
    pub fn max_step(&self, x: &[f64], delta: &[f64], alpha: f64) -> (f64, Sweep) {
        self.max_step_with(x, delta, alpha, None)
    }

    /// [`SelfBarrier::max_step`] with its sweep's candidates through the list `list` (the same
    /// answer).
    pub fn max_step_listed(
        &self,
        x: &[f64],
        delta: &[f64],
        alpha: f64,
        list: &mut Candidates,
    ) -> (f64, Sweep) {
        self.max_step_with(x, delta, alpha, Some(list))
    }

    fn max_step_with(
        &self,
        x: &[f64],
        delta: &[f64],
        alpha: f64,
        list: Option<&mut Candidates>,
    ) -> (f64, Sweep) {
        let scaled: Vec<f64> = delta.iter().map(|v| v * alpha).collect();
        let sweep = self.sweep_with(x, &scaled, list);
        let mut limit = alpha;
        for (pair, &gap) in sweep.pairs.iter().zip(&sweep.gaps) {
            if limit == 0.0 {
                break;
            }
            limit = self.time_of_approach(x, delta, (alpha, limit), pair, gap);
        }
        (limit, sweep)
    }

    /// The step length `t` at which the pair's gap along `x + t δ`, `gap0` at `x`, would first fall below
    /// floor `APPROACH · min(gap at x, d̂)` (conservative advancement: each advance is the gap
    /// above the floor over the bound of the pair's relative motion, and an advance shorter than
    /// `10⁻⁹ alpha` stops it), or `cutoff ≤ alpha` if that is smaller; 0 when the pair is at or
    /// within the thickness at `x`. The advances do not depend on `cutoff`, so the smallest
    /// result over pairs does not depend on their order.
    fn time_of_approach(
        &self,
        x: &[f64],
        delta: &[f64],
        (alpha, cutoff): (f64, f64),
        pair: &SelfPair,
        gap0: f64,
    ) -> f64 {
        let ps = pair.particles;
        // The relative motion's bound: each particle's move less the pair's mean move.
        let moves = ps.map(|q| at(delta, q));
        let mean = (moves[0] + moves[1] + moves[2] + moves[3]) / 4.0;
        let len = moves.map(|m| (m - mean).norm());
        let bound = match pair.kind {
            PairKind::PointTriangle => len[0] + len[1].max(len[2]).max(len[3]),
            PairKind::EdgeEdge(_) => len[0].max(len[1]) + len[2].max(len[3]),
        };
        if gap0 <= 0.0 {
            return 0.0;
        }
        let floor = APPROACH * gap0.min(self.barrier.d_hat);
        if bound * cutoff <= gap0 - floor {
            return cutoff;
        }
        let local = SelfPair {
            particles: [0, 1, 2, 3],
            kind: pair.kind,
        };
        let mut trial = [0.0; 12];
        let (mut t, mut gap) = (0.0, gap0);
        for _ in 0..MAX_ADVANCES {
            let dt = (gap - floor) / bound;
            if t + dt >= cutoff {
                return cutoff;
            }
            if dt <= 1e-9 * alpha {
                break;
            }
            t += dt;
            for (i, &q) in ps.iter().enumerate() {
                for k in 0..3 {
                    trial[3 * i + k] = x[3 * q + k] + t * delta[3 * q + k];
                }
            }
            gap = self.distance(&trial, &local) - self.thickness;
        }
        t
    }
}

/// The pairs that can come within the barrier's reach on one straight motion of the particles,
/// with the particles' swept boxes ([`SelfBarrier::sweep`]).
#[derive(Clone, Debug, Default)]
pub struct Sweep {
    boxes: Vec<Aabb>,
    pairs: Vec<SelfPair>,
    /// Each pair's gap `d − h` at the motion's start.
    gaps: Vec<f64>,
}
