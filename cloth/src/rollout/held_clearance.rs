//! The held particles' clearance from the rest of the cloth under smooth self-contact: the gap
//! `d − h` between each control particle and every triangle not incident to it, recorded on a
//! tape, and its smooth minimum.
//!
//! A held particle moves where the gripper puts it. Pressed onto cloth that cannot give way (a
//! layer lying on a table), the self-contact barrier stops the move and the rollout fails
//! ([`crate::ClothError::SelfContactPenetration`]); a planner row on this gap lets the optimizer
//! see that wall while the rollouts still succeed, as the gripper rows let it see the colliders.

use crate::contact::distance::PointTriangle;
use crate::contact::self_barrier::SelfBarrier;
use crate::model::Model;
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tape, Var};
use nalgebra::Vector3;
use std::sync::Arc;

/// Gap of a vertex and a triangle (`12 → 1`: the vertex, then the triangle's corners in;
/// `d − h` out). Which features are nearest is classified at the values (`f64`), and that
/// pair's distance is differentiated: the distance is C¹ across the regions' boundaries.
pub(crate) struct VertexTriangleGap {
    /// The thickness `h`.
    pub thickness: f64,
}

impl RowFn for VertexTriangleGap {
    fn n_in(&self) -> usize {
        12
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        let point = |i: usize| Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        let [p, a, b, c] = [point(0), point(1), point(2), point(3)];
        let value = |v: &Vector3<R>| Vector3::new(v.x.value(), v.y.value(), v.z.value());
        let kind = PointTriangle::classify(&value(&p), [&value(&a), &value(&b), &value(&c)]);
        out[0] = kind.squared(&p, [&a, &b, &c]).sqrt() - R::cst(self.thickness);
    }
}

/// The held pairs of `barrier`'s cloth with grippers at `held` ([`Model::held`]): every pair
/// of a held particle and a triangle not incident to it (`4` particles a row: the held one, then
/// the triangle's corners), with their gap function; `None` with no such pair.
pub(crate) fn held_pairs(
    barrier: &SelfBarrier,
    held: &[usize],
) -> Option<(Arc<dyn DynRowFn>, Arc<RowIndex>)> {
    let mut idx = Vec::new();
    for &p in held {
        for t in barrier.triangles.iter().filter(|t| !t.contains(&p)) {
            idx.extend([p, t[0], t[1], t[2]]);
        }
    }
    let gap: Arc<dyn DynRowFn> = Arc::new(VertexTriangleGap {
        thickness: barrier.thickness,
    });
    (!idx.is_empty()).then(|| (gap, Arc::new(RowIndex::new(4, idx))))
}

impl Model {
    /// Records the gap `d − h` of every held pair ([`Model::held`]) at `x` (`pairs × 1`); `None`
    /// where there is none.
    pub fn record_held_gaps(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let (f, pairs) = self.held.as_ref()?;
        let rows = tape.gather(x, pairs);
        Some(tape.map_rows(f, rows))
    }

    /// Records the smooth minimum of the held pairs' gaps, `−(1/κ) log Σ exp(−κ gᵢ)` (`1 × 1`):
    /// never above the smallest gap and at most `ln(pairs)/κ` below it, so a lower bound on it is
    /// conservative. `None` where there is no held pair.
    pub fn record_soft_min_held_gap(&self, tape: &mut Tape, x: Var, kappa: f64) -> Option<Var> {
        let gaps = self.record_held_gaps(tape, x)?;
        Some(tape.soft_min(gaps, kappa))
    }

    /// The smallest gap of a held pair at `x` (`N × 3` data); `None` where there is none.
    pub fn min_held_gap(&self, x: &autodiff::Tensor) -> Option<f64> {
        let mut tape = Tape::new();
        let xv = tape.leaf(x.clone());
        let gaps = self.record_held_gaps(&mut tape, xv)?;
        Some(
            tape.value(gaps)
                .data()
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The gap's gradient (the row function's vector–Jacobian product, as the tape's
        /// backward pass takes it) equals central differences of its value, in every region of
        /// the triangle a vertex can face.
        #[test]
        fn gap_gradient_matches_central_differences(
            x in prop::array::uniform12(-1.0..1.0f64),
        ) {
            let at = |i: usize| Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
            let (p, a, b, c) = (at(0), at(1), at(2), at(3));
            // A triangle of some area, the vertex some way off it.
            prop_assume!((b - a).cross(&(c - a)).norm() > 0.05);
            prop_assume!(PointTriangle::distance(&p, [&a, &b, &c]) > 0.05);
            let f = VertexTriangleGap { thickness: 0.01 };
            let mut grad = [0.0; 12];
            f.vjp(0, &x, &[1.0], &mut grad);
            let eps = 1e-6;
            for i in 0..12 {
                let (mut hi, mut lo) = (x, x);
                hi[i] += eps;
                lo[i] -= eps;
                let (mut vh, mut vl) = ([0.0], [0.0]);
                f.eval(0, &hi, &mut vh);
                f.eval(0, &lo, &mut vl);
                let fd = (vh[0] - vl[0]) / (2.0 * eps);
                prop_assert!((grad[i] - fd).abs() <= 1e-6, "∂/∂x[{}]: {} vs {}", i, grad[i], fd);
            }
        }
    }

    /// On a flat 5 × 5 cloth with self-collision, each held corner's pairs leave out the
    /// triangles it is a corner of, and its smallest gap is the distance to the nearest other
    /// triangle less the thickness: between the rest edge times sin 45° (a diagonal across from
    /// it) and the rest edge.
    #[test]
    fn each_held_corner_is_paired_with_the_triangles_it_is_not_a_corner_of() {
        let mut scene = crate::Scene::builtin("u_obstacle")
            .unwrap()
            .refined(5, 5)
            .unwrap();
        scene.physics.solver = Some(crate::scene::SolverKind::Newton);
        scene.physics.self_collision = Some(crate::scene::SelfCollisionSpec {
            thickness: 0.005,
            edge_edge: false,
            friction: None,
        });
        let model = Model::from_scene(&scene).unwrap();
        let rest_edge = (0..3)
            .map(|k| model.start.data()[k] - model.start.data()[3 + k])
            .map(|d| d * d)
            .sum::<f64>()
            .sqrt();
        let barrier = model.self_barrier.as_ref().unwrap();
        let pairs = &model.held.as_ref().unwrap().1;
        let held = model.controls.as_slice();
        let incident = |p: usize| barrier.triangles.iter().filter(|t| t.contains(&p)).count();
        let expected: usize = held
            .iter()
            .map(|&p| barrier.triangles.len() - incident(p))
            .sum();
        assert_eq!(pairs.rows(), expected);
        assert!((0..pairs.rows()).all(|r| !pairs.row(r)[1..].contains(&pairs.row(r)[0])));
        let gap = model.min_held_gap(&model.start).unwrap();
        let (h, edge) = (0.005, rest_edge);
        let low = edge * std::f64::consts::FRAC_1_SQRT_2 - h;
        assert!(
            gap <= edge - h + 1e-12 && gap >= low - 1e-12,
            "gap {gap}, edge {edge}"
        );
    }
}
