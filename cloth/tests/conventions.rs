//! The documented sub-gradients where the paper's formulas are not differentiable, each checked
//! with exact numbers, plus finiteness at degenerate constraints:
//!
//! - `‖·‖` at 0 (every norm of `T`, and `G`): gradient 0;
//! - the SDF at a sphere's centre: value `−r`, gradient 0;
//! - the relu kink (a particle exactly at `δ`): counts as safe, no contribution to `dC` — the
//!   derivative from the safe side;
//! - the min over spheres on a tie: the first sphere (and spheres before planes in a union);
//! - a distance constraint with rest length 0 or coincident particles: finite projection, finite
//!   VJP (equal to the engine's generic one), finite rollout gradients.

mod common;

use autodiff::{vjp_by_duals, RowFn, Tensor};
use cloth::constraint::{value_and_gradient, Collision, Distance};
use cloth::internals::trajectory_irregularity;
use cloth::internals::Projection;
use cloth::scene::ObstacleRole;
use cloth::sdf::{Plane, SphereSet, Union};
use cloth::{Model, Scene};
use common::*;
use std::sync::Arc;

/// The small test cloth: 4×4, `T = 3`, 20 iterations, stretch 1e4, distance bending 1e2.
fn small() -> Scene {
    small_scene(4, 4, 3, 20, 1e4, BendKind::Distance(1e2))
}

/// `(value, gradient)` of a signed distance at `p`, through the collider constraint (duals).
fn sdf_and_gradient<S: cloth::sdf::SignedDistance>(sdf: S, p: [f64; 3]) -> (f64, [f64; 3]) {
    let mut g = [0.0; 3];
    let v = value_and_gradient(&Collision { sdf }, 0, &p, &mut g);
    (v, g)
}

#[test]
fn all_zero_controls_give_zero_irregularity_gradient_and_a_finite_l_gradient() {
    let (t, grad) = trajectory_irregularity(&Tensor::zeros(10, 6));
    assert_eq!(t, 0.0);
    assert!(grad.data().iter().all(|&v| v == 0.0));
    // Constant (the u_obstacle initial guess): every difference is exactly zero too.
    let scene = Scene::builtin("u_obstacle").unwrap();
    let (t, grad) = trajectory_irregularity(&scene.initial_controls());
    assert_eq!(t, 0.0);
    assert!(grad.data().iter().all(|&v| v == 0.0));
    // One zero difference among non-zero ones contributes nothing; the others are unit vectors.
    let u = Tensor::new(3, 3, vec![1.0, 2.0, 3.0, 1.0, 2.0, 3.0, 4.0, 6.0, 3.0]);
    let (t, grad) = trajectory_irregularity(&u);
    assert_eq!(t, 5.0);
    assert_eq!(
        grad.data(),
        &[0.0, 0.0, 0.0, -0.6, -0.8, 0.0, 0.6, 0.8, 0.0]
    );
    // Through evaluate: at zero controls the L gradient is finite, and α has no effect on it.
    let mut scene = small();
    let model = Model::from_scene(&scene).unwrap();
    let u = model.zero_controls();
    let ev = model.evaluate(&u, 0.0, true).unwrap();
    assert_eq!(ev.metrics.t, 0.0);
    let gl = ev.grad_l.unwrap();
    assert!(gl.is_finite() && gl.norm() > 0.1, "|dL/dU| = {}", gl.norm());
    scene.task.alpha = 0.0;
    let no_t = Model::from_scene(&scene).unwrap();
    let gl0 = no_t.evaluate(&u, 0.0, true).unwrap().grad_l.unwrap();
    assert!(bitwise_eq(&gl, &gl0));
}

#[test]
fn target_error_at_zero_has_gradient_zero() {
    // Put the targets exactly where the rollout takes them: G = 0, and G adds nothing to dL/dU,
    // which is then exactly β·dE/dU + α·dT/dU.
    let mut scene = small();
    let model = Model::from_scene(&scene).unwrap();
    let mut rng = XorShift::new(5);
    let u = controls_from(
        &model,
        &rng.direction(18)
            .iter()
            .map(|v| 0.1 * v)
            .collect::<Vec<_>>(),
    );
    let states = model.simulate(&u).unwrap();
    let last = states.last().unwrap();
    for (t, &p) in scene
        .task
        .targets
        .iter_mut()
        .zip(model.task.targets.as_slice())
    {
        t.position = [last.get(p, 0), last.get(p, 1), last.get(p, 2)];
    }
    let model = Model::from_scene(&scene).unwrap();
    let ev = model.evaluate(&u, 0.0, true).unwrap();
    assert_eq!(ev.metrics.g, 0.0);
    let beta = model.task.beta;
    let energy = |tape: &mut autodiff::Tape, _t: usize, _prev: autodiff::Var, x: autodiff::Var| {
        model.record_energy(tape, x).map(|e| tape.scale(e, beta))
    };
    let mut expected = model.gradients(&ev.states, &u, &[&energy]).remove(0);
    let (_, t_grad) = trajectory_irregularity(&u);
    for (a, b) in expected.data_mut().iter_mut().zip(t_grad.data()) {
        *a += model.task.alpha * b;
    }
    let gl = ev.grad_l.unwrap();
    for (a, b) in gl.data().iter().zip(expected.data()) {
        assert!((a - b).abs() <= 1e-15 * b.abs().max(1e-300), "{a} vs {b}");
    }
}

#[test]
fn sdf_at_a_sphere_centre_is_minus_r_with_zero_gradient() {
    let sphere = SphereSet {
        centers: vec![[0.3, -0.2, 1.1]],
        radii: vec![0.25],
    };
    let (v, g) = sdf_and_gradient(sphere.clone(), [0.3, -0.2, 1.1]);
    assert_eq!(v, -0.25);
    assert_eq!(g, [0.0; 3]);
    // Just off the centre the gradient is the unit radial vector.
    let (_, g) = sdf_and_gradient(sphere.clone(), [0.3, -0.2, 1.1 + 1e-9]);
    assert!((g[2] - 1.0).abs() < 1e-12 && g[0] == 0.0 && g[1] == 0.0);
    // A rigid collider projection of a particle at the centre: no direction to push, so the row
    // is left as it is, and its VJP is finite (the identity).
    let p = Projection::new(Arc::new(Collision { sdf: sphere }), vec![0], vec![1.0], 0.0);
    let x = [0.3, -0.2, 1.1, 0.7];
    let mut out = [0.0; 4];
    p.eval(0, &x, &mut out);
    assert_eq!(out, x);
    let adj = [1.0, 2.0, 3.0, 4.0];
    let mut a = [0.0; 4];
    RowFn::vjp(&p, 0, &x, &adj, &mut a);
    assert_eq!(a, adj);
}

/// The small cloth with one safety sphere set; particle 0 (a gripped corner, which stays exactly
/// at its rest position `(−0.5, −1.5, 2.0)` under zero controls) is the one near the spheres.
fn with_spheres(centers: Vec<[f64; 3]>, radii: Vec<f64>) -> Model {
    let mut scene = small();
    scene
        .obstacles
        .push(spheres(centers, radii, ObstacleRole::Safety));
    let model = Model::from_scene(&scene).unwrap();
    assert_eq!(model.start.row(0), &[-0.5, -1.5, 2.0]);
    model
}

#[test]
fn particle_at_a_sphere_centre_contributes_no_safety_gradient() {
    // A small sphere centred exactly on the gripped corner: it violates any δ ≥ 0 at every step,
    // with SDF = −r and, by the convention, no gradient; the other particles are ≥ 1/3 − 0.05 away.
    let model = with_spheres(vec![[-0.5, -1.5, 2.0]], vec![0.05]);
    let delta = 0.01;
    let ev = model.evaluate(&model.zero_controls(), delta, true).unwrap();
    assert_eq!(ev.metrics.min_sdf, -0.05);
    assert!(
        (ev.metrics.c - (-3.0 * (delta + 0.05))).abs() < 1e-15,
        "C = {}",
        ev.metrics.c
    );
    let gc = ev.grad_c.unwrap();
    assert!(gc.data().iter().all(|&v| v == 0.0), "{gc:?}");
}

#[test]
fn particle_exactly_at_delta_counts_as_safe_and_pulls_nothing() {
    // Sphere of radius 0.25 at distance 0.5 from the gripped corner: SDF = 0.25 = δ exactly.
    let model = with_spheres(vec![[-0.5, -1.0, 2.0]], vec![0.25]);
    let delta = 0.25;
    let u = model.zero_controls();
    let ev = model.evaluate(&u, delta, true).unwrap();
    assert_eq!(ev.metrics.min_sdf, 0.25);
    assert_eq!(ev.metrics.c, 0.0);
    let gc = ev.grad_c.unwrap();
    assert!(gc.data().iter().all(|&v| v == 0.0), "{gc:?}");
    // It is a real kink: the derivative along +y of the corner's first control is 0 from the safe
    // side (the convention) and −T = −3 from the violating side (the corner then violates δ at
    // all three steps).
    let mut d = vec![0.0; 18];
    d[1] = 1.0;
    let c = |s: f64| {
        model
            .evaluate(&shifted(&u, &d, s), delta, false)
            .unwrap()
            .metrics
            .c
    };
    let h = 1e-7;
    assert_eq!(c(-h), 0.0);
    let from_violating_side = c(h) / h;
    assert!(
        (from_violating_side + 3.0).abs() < 1e-6,
        "{from_violating_side}"
    );
    assert_eq!(dot(gc.data(), &d), 0.0);
}

#[test]
fn tie_between_spheres_takes_the_first_sphere() {
    // Directly: the origin is 0.5 from both spheres.
    let a = [1.0, 0.0, 0.0];
    let b = [0.0, 1.0, 0.0];
    let set = |c: Vec<[f64; 3]>| SphereSet {
        centers: c,
        radii: vec![0.5, 0.5],
    };
    assert_eq!(
        sdf_and_gradient(set(vec![a, b]), [0.0; 3]),
        (0.5, [-1.0, 0.0, 0.0])
    );
    assert_eq!(
        sdf_and_gradient(set(vec![b, a]), [0.0; 3]),
        (0.5, [0.0, -1.0, 0.0])
    );
    // In a union, on a tie, sphere sets come before planes.
    let ground = Plane {
        point: [0.0, 0.0, -0.5],
        normal: [0.0, 0.0, 1.0],
    };
    let union = Union {
        spheres: vec![set(vec![a, b])],
        planes: vec![ground.clone()],
        ..Default::default()
    };
    assert_eq!(sdf_and_gradient(union, [0.0; 3]), (0.5, [-1.0, 0.0, 0.0]));
    assert_eq!(sdf_and_gradient(ground, [0.0; 3]), (0.5, [0.0, 0.0, 1.0]));

    // Through the rollout: the gripped corner is 0.25 from two spheres (one in front, one above)
    // at every step; δ = 0.3, so dC/du_t = (T − t)·∇SDF of the corner, with ∇SDF the unit vector
    // from the *first* sphere.
    let front = [-0.5, -1.0, 2.0];
    let above = [-0.5, -1.5, 2.5];
    for (centers, grad) in [
        (vec![front, above], [0.0, -1.0, 0.0]),
        (vec![above, front], [0.0, 0.0, -1.0]),
    ] {
        let model = with_spheres(centers, vec![0.25, 0.25]);
        let ev = model.evaluate(&model.zero_controls(), 0.3, true).unwrap();
        assert_eq!(ev.metrics.min_sdf, 0.25);
        assert!(
            (ev.metrics.c - (-3.0 * 0.05)).abs() < 1e-15,
            "C = {}",
            ev.metrics.c
        );
        let gc = ev.grad_c.unwrap();
        for t in 0..3 {
            let expected: Vec<f64> = grad
                .iter()
                .map(|g| g * (3 - t) as f64)
                .chain([0.0; 3])
                .collect();
            for (a, b) in gc.row(t).iter().zip(&expected) {
                assert!(
                    (a - b).abs() < 1e-12,
                    "step {t}: {:?} vs {expected:?}",
                    gc.row(t)
                );
            }
        }
    }
}

#[test]
fn distance_with_rest_length_zero_or_coincident_particles_stays_finite() {
    // Rows: coincident with rest 0 (C = 0, ∇C = 0), coincident with rest 0.3 (C = −0.3, ∇C = 0),
    // apart with rest 0.
    let c = Arc::new(Distance {
        rest: vec![0.0, 0.3, 0.0],
    });
    let rows: [[f64; 7]; 3] = [
        [0.1, 0.2, 0.3, 0.1, 0.2, 0.3, 0.5],
        [0.1, 0.2, 0.3, 0.1, 0.2, 0.3, -0.5],
        [0.1, 0.2, 0.3, 0.4, 0.6, 0.3, 0.5],
    ];
    for alpha in [0.0, 1e-2] {
        let p = Projection::new(c.clone(), vec![0, 1, 2], vec![1.0; 6], alpha);
        for (row, x) in rows.iter().enumerate() {
            let mut out = [0.0; 7];
            p.eval(row, x, &mut out);
            assert!(out.iter().all(|v| v.is_finite()), "row {row}: {out:?}");
            if row < 2 {
                // No direction to move along: the particles stay; λ only changes when α̃ > 0.
                assert_eq!(out[..6], x[..6]);
                let dl = if alpha == 0.0 {
                    0.0
                } else {
                    (c.rest[row] - alpha * x[6]) / alpha
                };
                assert_eq!(out[6], x[6] + dl, "row {row}, α̃ = {alpha}");
            } else if alpha == 0.0 {
                // A rigid zero-length constraint pulls both particles to their midpoint.
                assert!((out[0] - 0.25).abs() < 1e-15 && (out[3] - 0.25).abs() < 1e-15);
                assert!((out[1] - 0.4).abs() < 1e-15 && (out[4] - 0.4).abs() < 1e-15);
            }
            let adj = [1.0, -2.0, 0.5, 0.25, 3.0, -1.0, 2.0];
            let (mut a, mut b) = ([0.0; 7], [0.0; 7]);
            RowFn::vjp(&p, row, x, &adj, &mut a);
            vjp_by_duals(&p, row, x, &adj, &mut b);
            assert!(a.iter().all(|v| v.is_finite()), "row {row}: {a:?}");
            for (ai, bi) in a.iter().zip(&b) {
                assert!(
                    (ai - bi).abs() <= 1e-12 * ai.abs().max(1.0),
                    "{a:?} vs {b:?}"
                );
            }
        }
    }
}

#[test]
fn zero_rest_length_tether_in_a_rollout_has_finite_gradients() {
    // A user constraint tying the two bottom corners together (rest length 0).
    let scene = small();
    let (a, b) = (12, 15);
    let mut rng = XorShift::new(11);
    let values: Vec<f64> = rng.direction(18).iter().map(|v| 0.1 * v).collect();
    for stiffness in [f64::INFINITY, 1e3] {
        let mut model = Model::from_scene(&scene).unwrap();
        model
            .add_constraints(
                "tether",
                Distance { rest: vec![0.0] },
                vec![a, b],
                stiffness,
            )
            .unwrap();
        let u = controls_from(&model, &values);
        let ev = model.evaluate(&u, 0.0, true).unwrap();
        let gap = |x: &Tensor| {
            (0..3)
                .map(|k| (x.get(a, k) - x.get(b, k)).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let last = ev.states.last().unwrap();
        let gl = ev.grad_l.unwrap();
        assert!(gl.is_finite() && ev.grad_c.unwrap().is_finite());
        assert!(ev.metrics.l.is_finite());
        if stiffness.is_infinite() {
            // The rigid tether is projected last: the corners end each step together.
            assert!(gap(last) < 1e-12, "gap {:e}", gap(last));
        } else {
            // A compliant tether pulls them together without making them coincide, and the
            // rollout is smooth: the gradient matches a central difference.
            assert!(gap(last) > 1e-3 && gap(last) < 0.5, "gap {}", gap(last));
            let d = rng.direction(18);
            let f = |s: f64| {
                model
                    .evaluate(&shifted(&u, &d, s), 0.0, false)
                    .unwrap()
                    .metrics
                    .l
            };
            let h = 1e-6;
            let fd = (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h);
            let an = dot(gl.data(), &d);
            assert!(within(an, fd, 1e-6, 1e-8), "{an} vs {fd}");
        }
    }
}

/// A user's constraint with a positive stiffness so small that its compliance `1/(k·dt²)` is not
/// finite is rejected with an error naming it, not a panic (and bad stiffness in general).
#[test]
fn add_constraints_rejects_stiffness_whose_compliance_is_not_finite() {
    let scene = Scene::builtin("swing").unwrap();
    for k in [1e-320, 0.0, -1.0, f64::NAN] {
        let mut model = Model::from_scene(&scene).unwrap();
        let err = model
            .add_constraints("tether", Distance { rest: vec![0.5] }, vec![0, 1], k)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("tether") && err.contains("stiffness"),
            "{k}: {err}"
        );
    }
}

/// A non-finite control is reported with the same coordinates as a non-finite gradient entry:
/// steps counted from 1 (row `t − 1` acts during step `t`).
#[test]
fn a_non_finite_control_names_its_step_control_and_component() {
    let scene = Scene::builtin("swing").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let mut u = scene.initial_controls();
    let width = u.cols();
    u.data_mut()[2 * width + 3 + 1] = f64::NAN;
    let err = model.simulate(&u).unwrap_err().to_string();
    assert!(
        err.contains("step 3, control 1, component 1 is not finite"),
        "{err}"
    );
}
