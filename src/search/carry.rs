//! Carry routes: the grippers lifted off what the cloth rests on.
//!
//! Where the cloth lies on a collider, a path that slides the grippers along it drags the cloth
//! across the surface (against friction, and across the cloth itself when folding), and the
//! gradient of a smooth contact model says so only locally: the planner stalls where the held
//! cloth presses on the rest. A *carry route* moves each gripper from its base path's start to
//! its end along a half circle in the vertical plane of its travel, lifted against gravity by half
//! its horizontal travel at mid-course: pick up, carry, put down. For a fold this turns the held
//! edge about the fold line, the way a hand folds a towel.
//!
//! The half circle is `p(θ) = s + (e − s)(1 − cos θ)/2 + up · r sin θ`, `θ = π t / T`,
//! `r = |horizontal part of e − s| / 2`: each step's angle is the same, so grippers with
//! different travels stay in phase.

use nalgebra::Vector3;

/// Gripper positions of a route: `paths[t][k]`, steps `0..=T`.
type Paths = Vec<Vec<[f64; 3]>>;

/// The carry route of `base` (see the module docs): every gripper from `base[0]` to `base[T]` on
/// a half circle lifted along the unit vector `up`. `None` when no gripper travels at least
/// `2 · min_radius` across `up` (a lift would change nothing worth a plan) or when the base has
/// no step.
pub fn carry_paths(base: &[Vec<[f64; 3]>], up: [f64; 3], min_radius: f64) -> Option<Paths> {
    let horizon = base.len().checked_sub(1).filter(|&t| t > 0)?;
    let up = Vector3::from(up);
    let ends: Vec<(Vector3<f64>, Vector3<f64>, f64)> = base[0]
        .iter()
        .zip(&base[horizon])
        .map(|(&s, &e)| {
            let (s, e) = (Vector3::from(s), Vector3::from(e));
            let travel = e - s;
            let across = travel - up * travel.dot(&up);
            (s, travel, 0.5 * across.norm())
        })
        .collect();
    if ends.iter().all(|&(_, _, r)| r < min_radius) {
        return None;
    }
    let paths = (0..=horizon)
        .map(|t| {
            let theta = std::f64::consts::PI * t as f64 / horizon as f64;
            // The last point is exactly the base's end (cos π ≠ −1 in floating point only by
            // rounding, but the route must end where the base does).
            ends.iter()
                .enumerate()
                .map(|(k, &(s, travel, r))| {
                    if t == horizon {
                        return base[horizon][k];
                    }
                    let p = s + travel * (0.5 * (1.0 - theta.cos())) + up * (r * theta.sin());
                    [p.x, p.y, p.z]
                })
                .collect()
        })
        .collect();
    Some(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(from: [f64; 3], to: [f64; 3], horizon: usize) -> Paths {
        (0..=horizon)
            .map(|t| {
                let f = t as f64 / horizon as f64;
                vec![std::array::from_fn(|j| from[j] + f * (to[j] - from[j]))]
            })
            .collect()
    }

    #[test]
    fn a_carry_is_a_half_circle_over_the_travel() {
        let base = straight([0.0, 0.0, 1.0], [0.0, -0.4, 1.0], 8);
        let route = carry_paths(&base, [0.0, 0.0, 1.0], 1e-3).unwrap();
        assert_eq!(route.len(), 9);
        assert_eq!(route[0][0], base[0][0]);
        assert_eq!(route[8][0], base[8][0]);
        // Mid-course: above the middle of the travel by half of it.
        let mid = route[4][0];
        assert!(
            (mid[1] + 0.2).abs() < 1e-15 && (mid[2] - 1.2).abs() < 1e-15,
            "{mid:?}"
        );
        // Every point lies on the circle of radius 0.2 about the middle, never below the ends.
        for p in &route {
            let (y, z) = (p[0][1] + 0.2, p[0][2] - 1.0);
            assert!(((y * y + z * z).sqrt() - 0.2).abs() < 1e-12);
            assert!(z >= -1e-15 && p[0][0] == 0.0);
        }
    }

    #[test]
    fn grippers_stay_in_phase_and_vertical_travel_is_kept() {
        let mut base = straight([0.0, 0.0, 0.0], [1.0, 0.0, 0.5], 4);
        for (t, row) in base.iter_mut().enumerate() {
            row.push([0.0, 1.0, t as f64 * 0.1]);
        }
        let route = carry_paths(&base, [0.0, 0.0, 1.0], 1e-3).unwrap();
        // Gripper 0 travels 1 across and 0.5 up: the lift rides on the straight rise.
        assert!((route[2][0][0] - 0.5).abs() < 1e-15);
        assert!((route[2][0][2] - (0.25 + 0.5)).abs() < 1e-15);
        // Gripper 1 only rises: no lift, its points on the straight line at the same phase.
        assert!((route[2][1][2] - 0.2).abs() < 1e-15 && route[2][1][0] == 0.0);
        assert_eq!(route[4], base[4]);
    }

    #[test]
    fn no_carry_without_travel_across_up() {
        let base = straight([0.0, 0.0, 0.0], [0.0, 0.0, -0.3], 5);
        assert!(carry_paths(&base, [0.0, 0.0, 1.0], 1e-3).is_none());
        assert!(carry_paths(&base[..1], [0.0, 0.0, 1.0], 1e-3).is_none());
    }
}
