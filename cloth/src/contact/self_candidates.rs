//! A Verlet list for self-contact's pair searches under Newton ([`super::self_barrier`]): the
//! candidate pairs of a reference set of particle boxes, searched once with a wider margin and
//! then filtered, instead of searched anew, for every later set of boxes each within its
//! reference box grown by a slack. A Newton solve asks for the pairs of many nearby states (the
//! iterates, the line search's trials, the step filter's sweeps), so the grids are built far
//! less often.
//!
//! The answers are those of [`SelfBarrier::for_candidates`] bit for bit: the list holds, in that
//! search's order, every pair whose boxes could meet within the margin while each box is in its
//! grown reference box, and the filter applies the search's own box test with the same
//! arithmetic (the static tests, shared particles and movability, were applied when it was
//! built).

use super::grid::Aabb;
use super::self_barrier::{PairKind, SelfBarrier, SelfPair};
use nalgebra::Vector3;

/// The slack of a list: how far, relative to the search's margin (the barrier's reach), each
/// box may leave its reference box before the list is searched again. Measured on the fold
/// under Newton from the plain guess (16 steps, 4026 pair queries and sweeps): slack 1, 705
/// searches of 65k candidates on average; 0.25, 903 of 17k; 0.1, 1211 of 9.1k; 0.05, 1485 of
/// 7.8k and the least time (a sweep's boxes are long, so the list is never small).
const SLACK: f64 = 0.05;

/// Extra margin of a list's search (relative to its margin) over `margin + 2 slack`, far above
/// the round-off of the box arithmetic.
const ROUNDING: f64 = 1e-6;

/// The candidate pairs of reference boxes within a margin, with the slack they allow
/// ([`SelfBarrier::for_candidates_in`]); empty (holding nothing) by default.
#[derive(Clone, Debug, Default)]
pub struct Candidates {
    reference: Vec<Aabb>,
    margin: f64,
    slack: f64,
    /// Each pair with its query and item ([`SelfBarrier::for_candidates`]).
    pairs: Vec<(SelfPair, [u32; 2])>,
    /// Searches over the whole cloth made so far (lists built).
    pub searches: usize,
}

impl Candidates {
    /// The list answers for `points` with `margin`: the same margin, and every box within its
    /// reference box grown by the slack.
    fn holds(&self, points: &[Aabb], margin: f64) -> bool {
        margin == self.margin
            && points.len() == self.reference.len()
            && points
                .iter()
                .zip(&self.reference)
                .all(|((lo, hi), (rlo, rhi))| {
                    (0..3).all(|k| lo[k] >= rlo[k] - self.slack && hi[k] <= rhi[k] + self.slack)
                })
    }
}

impl SelfBarrier {
    /// [`SelfBarrier::for_candidates`] through the list `list`: filtered from it when it holds
    /// `points` within its slack, else after searching it anew around `points`. The same pairs
    /// in the same order.
    pub(super) fn for_candidates_in(
        &self,
        points: &[Aabb],
        margin: f64,
        list: &mut Candidates,
        mut f: impl FnMut(SelfPair),
    ) {
        if !list.holds(points, margin) {
            let slack = SLACK * margin;
            let wide = margin + 2.0 * slack + ROUNDING * margin;
            let mut pairs = Vec::with_capacity(list.pairs.len());
            self.for_candidates(points, wide, |pair, [a, b]| {
                pairs.push((pair, [a as u32, b as u32]));
            });
            *list = Candidates {
                reference: points.to_vec(),
                margin,
                slack,
                pairs,
                searches: list.searches + 1,
            };
        }
        // The search's box tests with its arithmetic: the query's box (the triangle's, or the
        // first edge's) grown by the margin against the item's.
        let m = Vector3::repeat(margin);
        let union = |ps: &[usize]| -> Aabb {
            ps.iter().map(|&p| points[p]).fold(
                (
                    Vector3::repeat(f64::INFINITY),
                    Vector3::repeat(f64::NEG_INFINITY),
                ),
                |(lo, hi), (a, b)| (lo.inf(&a), hi.sup(&b)),
            )
        };
        let triangles: Vec<Aabb> = self
            .triangles
            .iter()
            .map(|t| union(t))
            .map(|(lo, hi)| (lo - m, hi + m))
            .collect();
        let edges: Vec<Aabb> = self.edges.iter().map(|(e, _)| union(e)).collect();
        let meet = |(lo, hi): &Aabb, (a, b): &Aabb| (0..3).all(|k| a[k] <= hi[k] && b[k] >= lo[k]);
        for &(pair, [q, i]) in &list.pairs {
            let (q, i) = (q as usize, i as usize);
            let near = match pair.kind {
                PairKind::PointTriangle => meet(&triangles[q], &points[i]),
                PairKind::EdgeEdge(_) => {
                    let (lo, hi) = edges[q];
                    meet(&(lo - m, hi + m), &edges[i])
                }
            };
            if near {
                f(pair);
            }
        }
    }

    /// [`SelfBarrier::for_candidates`], through `list` when there is one.
    pub(super) fn candidates_with(
        &self,
        points: &[Aabb],
        margin: f64,
        list: Option<&mut Candidates>,
        mut f: impl FnMut(SelfPair),
    ) {
        match list {
            Some(list) => self.for_candidates_in(points, margin, list, f),
            None => self.for_candidates(points, margin, |pair, _| f(pair)),
        }
    }

    /// [`SelfBarrier::pairs`] through the candidate list `list` (the same pairs in the same
    /// order).
    pub fn pairs_listed(&self, x: &[f64], list: &mut Candidates) -> Vec<SelfPair> {
        self.pairs_with(x, Some(list))
    }
}

#[cfg(test)]
mod tests {
    use super::Candidates;
    use crate::contact::barrier::Barrier;
    use crate::contact::self_barrier::tests::folded;
    use crate::contact::self_barrier::SelfBarrier;
    use std::sync::Arc;

    /// Along a motion that closes the fold and shears its top layer, by small moves (answered
    /// from the list) and jumps (searched again), the pairs of each state and each step
    /// filter through one list are those of a fresh search, in order.
    #[test]
    fn a_listed_search_answers_as_a_fresh_one() {
        let (tris, x) = folded(9, 0.2);
        let b = SelfBarrier::new(
            0.05,
            Barrier {
                d_hat: 0.2,
                kappa: 1.0,
            },
            1.0,
            Arc::from(tris),
            &x,
            &vec![1.0; x.len() / 3],
        );
        let delta: Vec<f64> = (0..x.len())
            .map(|i| match i % 3 {
                2 if x[i] > 0.1 => -0.14,
                0 => 0.05 * x[i + 1].sin(),
                _ => 0.0,
            })
            .collect();
        let at = |t: f64| -> Vec<f64> { x.iter().zip(&delta).map(|(a, d)| a + t * d).collect() };
        let mut list = Candidates::default();
        let (mut queries, mut pairs_seen) = (0, 0);
        for t in [
            0.0, 0.001, 0.002, 0.004, 0.3, 0.3005, 0.301, 0.6, 0.6002, 0.9, 0.9001,
        ] {
            let xt = at(t);
            let fresh = b.pairs(&xt);
            pairs_seen += fresh.len();
            assert_eq!(b.pairs_listed(&xt, &mut list), fresh, "pairs at t = {t}");
            for s in [0.0005, 0.002, 0.1] {
                let step: Vec<f64> = delta.iter().map(|d| s * d).collect();
                let (alpha, sweep) = b.max_step(&xt, &step, 1.0);
                let (listed, listed_sweep) = b.max_step_listed(&xt, &step, 1.0, &mut list);
                assert_eq!(alpha.to_bits(), listed.to_bits(), "t = {t}, step {s}");
                let end: Vec<f64> = xt.iter().zip(&step).map(|(a, d)| a + alpha * d).collect();
                assert_eq!(b.pairs_in(&end, &sweep), b.pairs_in(&end, &listed_sweep));
                assert_eq!(b.pairs_in(&end, &listed_sweep), Some(b.pairs(&end)));
            }
            queries += 4;
        }
        assert!(pairs_seen > 500, "{pairs_seen} pairs over the motion");
        // Small moves are answered from the list: fewer searches than queries.
        assert!(
            list.searches < queries * 3 / 4,
            "{} searches for {queries} queries",
            list.searches
        );
    }
}
