//! Smooth contact along the cloth's edges, for colliders narrower than them.
//!
//! The collider barrier ([`super::barrier`]) keeps every particle outside the colliders, not the
//! edges between them: a rail or a thin wall narrower than an edge fits between two neighbouring
//! particles, and the cloth passes through it. Here every edge between two free particles that is
//! longer than half the narrowest such collider's width carries barrier points at fixed fractions
//! `t` along it, `x = (1 − t) x_a + t x_b`, at most half that width apart in the rest shape. The
//! points see only the narrow colliders (spheres, capsules and boxes narrower than the longest
//! edge, [`crate::sdf::Union::narrower_than`]), with the particles' barrier and friction: on a
//! narrow collider's face the points carry part of the load, and rub as the particles do.
//!
//! Why half the width: a segment through a capsule's axis, a sphere's centre or a slab's
//! mid-plane has a chord at least the width inside it, which would hold a point; the points stay
//! outside, so the edge cannot cross. Between two outside points `s` apart, the edge reaches at
//! most `r (1 − √(1 − (s/2r)²))` into a capsule of radius `r`: `0.13 r` at `s = r`.
//!
//! A point is linear in its particles, so their straight moves move it straight: the colliders'
//! conservative step filter ([`ColliderBarrier::max_step`]) applies to it unchanged, and its
//! barrier's derivatives are the particles' with weights `(1 − t, t)`. Edges with a held end are
//! left out (their points would couple the controls into the barrier); the grippers are kept off
//! the colliders by the planner's own rows.

use super::barrier::ColliderBarrier;
use super::smooth_friction::FrictionParams;

use std::ops::Range;
use std::sync::Arc;

/// A barrier point on an edge: `(1 − t) x_a + t x_b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgePoint {
    /// The edge's first particle.
    pub a: usize,
    /// The edge's second particle.
    pub b: usize,
    /// The fraction along `a → b`, in `(0, 1)`.
    pub t: f64,
}

impl EdgePoint {
    /// Its position in the full `N × 3` state `x`.
    pub fn position(&self, x: &[f64]) -> [f64; 3] {
        let (a, b) = (3 * self.a, 3 * self.b);
        std::array::from_fn(|k| (1.0 - self.t) * x[a + k] + self.t * x[b + k])
    }
}

/// The barrier points of a cloth's edges against its narrow colliders.
#[derive(Clone, Debug)]
pub struct EdgeBarrier {
    /// The narrow colliders' barrier, frictionless, at each point.
    pub barrier: ColliderBarrier,
    /// The points, edge by edge.
    pub points: Vec<EdgePoint>,
    /// The points' largest spacing in the rest shape.
    pub spacing: f64,
    /// Each edge with points: its particles and the range of its points in `points`.
    pub edges: Vec<([usize; 2], Range<usize>)>,
    /// A box holding every narrow collider: an edge whose box keeps away from it keeps its
    /// points away, so most edges are passed over without a distance query.
    pub bounds: ([f64; 3], [f64; 3]),
}

impl EdgeBarrier {
    /// The points of `edges` (with their `rest` lengths) whose ends are both `free`, against the
    /// colliders of `particles` (the particles' barrier) narrower than the longest edge, with
    /// the same barrier and friction; `None` when no collider is that narrow or no edge needs a
    /// point.
    pub fn new(
        particles: &ColliderBarrier,
        edges: &[[usize; 2]],
        rest: &[f64],
        free: impl Fn(usize) -> bool,
    ) -> Option<EdgeBarrier> {
        let longest = rest.iter().copied().fold(0.0, f64::max);
        let (narrow, index) = particles.field.narrower_than(longest);
        let bounds = narrow.bounds()?;
        let spacing = 0.5 * narrow.narrowest();
        let (mut points, mut runs) = (Vec::new(), Vec::new());
        for (&[a, b], &length) in edges.iter().zip(rest) {
            let pieces = (length / spacing).ceil() as usize;
            if !(free(a) && free(b)) || pieces < 2 {
                continue;
            }
            let first = points.len();
            points.extend((1..pieces).map(|k| EdgePoint {
                a,
                b,
                t: k as f64 / pieces as f64,
            }));
            runs.push(([a, b], first..points.len()));
        }
        (!points.is_empty()).then(|| EdgeBarrier {
            barrier: ColliderBarrier {
                field: Arc::new(narrow),
                barrier: particles.barrier,
                dt2: particles.dt2,
                friction: (particles.friction.as_ref())
                    .map(|f| FrictionParams {
                        mu: index.iter().map(|&k| f.mu[k]).collect(),
                        epsilon: f.epsilon,
                    })
                    .filter(|f| f.mu.iter().any(|&m| m > 0.0)),
            },
            points,
            spacing,
            edges: runs,
            bounds,
        })
    }

    /// A lower bound of the distance from the edge `[a, b]` of the full `N × 3` state `x` to
    /// the narrow colliders: the gap between its box and [`EdgeBarrier::bounds`] (0 where they
    /// meet).
    pub fn edge_gap(&self, [a, b]: [usize; 2], x: &[f64]) -> f64 {
        let (lo, hi) = &self.bounds;
        let mut gap2 = 0.0;
        for k in 0..3 {
            let (u, v) = (x[3 * a + k], x[3 * b + k]);
            let g = (lo[k] - u.max(v)).max(u.min(v) - hi[k]).max(0.0);
            gap2 += g * g;
        }
        gap2.sqrt()
    }

    /// The points (with their indices) of the edges of `x` that may come nearer than `reach`
    /// to the narrow colliders ([`EdgeBarrier::edge_gap`] below it); the others are farther.
    pub fn points_near<'a>(
        &'a self,
        x: &'a [f64],
        reach: f64,
    ) -> impl Iterator<Item = (usize, &'a EdgePoint)> + 'a {
        (self.edges.iter())
            .filter(move |(edge, _)| self.edge_gap(*edge, x) < reach)
            .flat_map(move |(_, range)| range.clone().map(move |i| (i, &self.points[i])))
    }

    /// The first point of `x` on or inside a narrow collider, with its signed distance; `None`
    /// when all are outside.
    pub fn penetration(&self, x: &[f64]) -> Option<(EdgePoint, f64)> {
        (self.points_near(x, f64::MIN_POSITIVE))
            .map(|(_, p)| (*p, self.barrier.distance(&p.position(x))))
            .find(|&(_, d)| d <= 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::barrier::Barrier;
    use crate::sdf::{Capsule, Cuboid, Plane, Union};

    fn colliders() -> Union {
        Union {
            capsules: vec![Capsule {
                a: [-1.0, 0.0, 1.0],
                b: [1.0, 0.0, 1.0],
                radius: 0.015,
            }],
            boxes: vec![Cuboid::new([0.0, 0.0, 0.3], [0.6, 0.4, 0.3], None)],
            planes: vec![Plane {
                point: [0.0; 3],
                normal: [0.0, 0.0, 1.0],
            }],
            ..Union::default()
        }
    }

    /// The particles' barrier on [`colliders`], friction 0.3 on the rail alone.
    fn particles() -> ColliderBarrier {
        ColliderBarrier {
            field: Arc::new(colliders()),
            barrier: Barrier {
                d_hat: 0.005,
                kappa: 1.0,
            },
            dt2: 1.0,
            friction: Some(FrictionParams {
                mu: vec![0.0, 0.3, 0.0],
                epsilon: 1e-4,
            }),
        }
    }

    /// Only the rail is narrow; an edge of 0.05 gets points at most 0.015 apart (4 pieces), one
    /// of 0.01 none, and an edge with a held end none.
    #[test]
    fn points_are_spaced_by_half_the_narrowest_width_on_free_edges() {
        let edges = [[0, 1], [1, 2], [2, 3]];
        let rest = [0.05, 0.01, 0.05];
        let e = EdgeBarrier::new(&particles(), &edges, &rest, |p| p != 3).unwrap();
        assert_eq!(e.barrier.field.component_count(), 1, "the rail alone");
        assert_eq!(
            e.barrier.friction.as_ref().unwrap().mu,
            [0.3],
            "the rail's friction"
        );
        assert_eq!(e.spacing, 0.015);
        let ts: Vec<f64> = e.points.iter().map(|p| p.t).collect();
        assert_eq!(ts, [0.25, 0.5, 0.75]);
        assert!(e.points.iter().all(|p| (p.a, p.b) == (0, 1)));
        assert_eq!(e.edges, [([0, 1], 0..3)]);
        assert_eq!(e.bounds, ([-1.015, -0.015, 0.985], [1.015, 0.015, 1.015]));
    }

    /// An edge's box gap bounds its points' distances (where outside) from below, and is 0
    /// where the boxes meet.
    #[test]
    fn the_edge_gap_is_a_lower_bound_of_its_points_distances() {
        let e = EdgeBarrier::new(&particles(), &[[0, 1]], &[0.05], |_| true).unwrap();
        for x in [
            [0.3, 0.2, 1.4, 0.35, 0.1, 1.2],
            [2.0, 0.0, 1.0, 2.0, 0.0, 1.05],
            [0.0, -0.1, 0.9, 0.0, 0.1, 1.1],
        ] {
            let gap = e.edge_gap([0, 1], &x);
            for p in &e.points {
                let d = e.barrier.distance(&p.position(&x));
                assert!(gap <= d.max(0.0), "{gap} > {d}");
            }
        }
        assert_eq!(e.edge_gap([0, 1], &[0.0, -0.1, 0.9, 0.0, 0.1, 1.1]), 0.0);
        assert_eq!(
            e.points_near(&[2.0, 0.0, 1.0, 2.0, 0.0, 1.05], 0.5).count(),
            0
        );
        assert_eq!(
            e.points_near(&[2.0, 0.0, 1.0, 2.0, 0.0, 1.05], 1.0).count(),
            3
        );
    }

    /// Edges shorter than every collider is wide need no points.
    #[test]
    fn no_points_without_a_collider_narrower_than_the_longest_edge() {
        let e = EdgeBarrier::new(&particles(), &[[0, 1]], &[0.02], |_| true);
        assert!(e.is_none());
    }

    /// A point is the edge's interpolant, and one inside the rail is found.
    #[test]
    fn a_point_inside_the_rail_is_found() {
        let e = EdgeBarrier::new(&particles(), &[[0, 1]], &[0.05], |_| true).unwrap();
        // The edge straddles the rail: its ends are outside, its middle inside.
        let x = [0.0, -0.04, 1.0, 0.0, 0.04, 1.0];
        assert_eq!(e.points[1].position(&x), [0.0, 0.0, 1.0]);
        let (p, d) = e.penetration(&x).unwrap();
        assert_eq!(p.t, 0.5);
        assert!((d + 0.015).abs() < 1e-15, "{d}");
        let apart = [0.0, -0.04, 1.1, 0.0, 0.04, 1.1];
        assert!(e.penetration(&apart).is_none());
    }
}
