//! Hard cases stay numerically stable (issue 7, item 1).
//!
//! Each case builds a small scene by editing [`Scene`] fields, simulates it, and asserts:
//! - every state, every metric (`L`, `G`, `T`, `E`, `C`) and both gradients `dL/dU`, `dC/dU` are
//!   finite, and so are the objective, gradient, safety rows and Jacobian that the optimizer sees
//!   through [`TrajectoryProblem`];
//! - the gradient agrees with finite differences: central differences (Richardson, `h = 1e-6`)
//!   where the rollout is smooth, and where it is not, the documented sub-gradient convention
//!   (docs/physics.md, "Conventions at non-differentiable points"). At a norm kink (`‖·‖` at 0:
//!   `T` with identical consecutive controls, coincident particles, a particle at a sphere's
//!   centre) the kink is symmetric, so the central difference *is* the convention's value 0 for
//!   that term. At the relu kink and the sphere tie the convention is one side's derivative: it is
//!   compared with the one-sided difference from that side, and the other side is shown to differ
//!   (so the check can fail);
//! - nothing panics.
//!
//! The long-horizon cases print the gradient norm and compare it with a shorter horizon; see
//! [`long_horizon_t100_gradient_grows_like_sqrt_t`] for the measured growth and why it is what the
//! physics explains.

mod common;

use autodiff::Tensor;
use cloth::scene::{
    Bending, BendingModel, Obstacle, ObstacleRole, PlaneSpec, SphereSetSpec, Stiffness, Target,
};
use cloth::{Evaluation, Model};
use clothopt::problem::{SafetyForm, TaskOptions, TrajectoryProblem};
use common::{noise, small};
use optim::{Jacobian, Problem};

// ---------------------------------------------------------------------------------------------
// helpers

fn spheres(centers: Vec<[f64; 3]>, radii: Vec<f64>, role: ObstacleRole) -> Obstacle {
    Obstacle::Spheres(SphereSetSpec {
        centers,
        radii,
        role,
        friction: None,
    })
}

fn controls(model: &Model, values: Vec<f64>) -> Tensor {
    Tensor::new(model.task.horizon, 3 * model.n_controls(), values)
}

/// Random controls `|u| ≤ scale`.
fn random_controls(model: &Model, seed: u64, scale: f64) -> Tensor {
    let n = model.task.horizon * 3 * model.n_controls();
    controls(model, noise(seed, n).iter().map(|v| scale * v).collect())
}

fn shifted(u: &Tensor, d: &[f64], s: f64) -> Tensor {
    let mut v = u.clone();
    for (x, di) in v.data_mut().iter_mut().zip(d) {
        *x += s * di;
    }
    v
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Which scalar of the rollout is differentiated.
#[derive(Clone, Copy, Debug)]
enum Scalar {
    L,
    C,
}

fn value(model: &Model, u: &Tensor, delta: f64, which: Scalar) -> f64 {
    let m = model.evaluate(u, delta, false).unwrap().metrics;
    match which {
        Scalar::L => m.l,
        Scalar::C => m.c,
    }
}

/// Evaluates with gradients and asserts that every state, metric and gradient is finite, and that
/// the optimizer's view of the same point (objective, gradient, safety rows, Jacobian) is too.
fn evaluate_finite(name: &str, model: &Model, u: &Tensor, delta: f64) -> Evaluation {
    let ev = model
        .evaluate(u, delta, true)
        .unwrap_or_else(|e| panic!("{name}: evaluate failed: {e}"));
    assert_eq!(ev.states.len(), model.task.horizon + 1, "{name}");
    for (t, x) in ev.states.iter().enumerate() {
        assert!(x.is_finite(), "{name}: state {t} is not finite");
    }
    let m = ev.metrics;
    for (k, v) in [("L", m.l), ("G", m.g), ("T", m.t), ("E", m.e), ("C", m.c)] {
        assert!(v.is_finite(), "{name}: {k} = {v}");
    }
    assert!(!m.min_sdf.is_nan() && !m.min_sdf_swept.is_nan(), "{name}");
    let gl = ev.grad_l.as_ref().unwrap();
    let gc = ev.grad_c.as_ref().unwrap();
    assert!(gl.is_finite(), "{name}: dL/dU not finite");
    assert!(gc.is_finite(), "{name}: dC/dU not finite");
    assert_eq!(gl.shape(), u.shape(), "{name}");
    problem_finite(name, model, u, delta);
    ev
}

/// The optimizer's view: objective, gradient, inequalities and Jacobian are finite (every safety
/// form when the scene has safety obstacles).
fn problem_finite(name: &str, model: &Model, u: &Tensor, delta: f64) {
    let forms: &[Option<SafetyForm>] = if model.safety.is_some() {
        &[
            Some(SafetyForm::PerStep),
            Some(SafetyForm::Aggregate),
            Some(SafetyForm::Scalar),
        ]
    } else {
        &[None]
    };
    for &form in forms {
        let mut options = TaskOptions::for_model(model);
        options.delta = delta;
        options.safety = form;
        let mut p = TrajectoryProblem::new(model, options);
        let (n, m) = (p.num_variables(), p.num_inequalities());
        let x = u.data();
        let f = p.objective(x).unwrap();
        assert!(f.is_finite(), "{name} {form:?}: objective {f}");
        let mut g = vec![0.0; n];
        p.gradient(x, &mut g).unwrap();
        assert!(g.iter().all(|v| v.is_finite()), "{name} {form:?}: gradient");
        let mut c = vec![0.0; m];
        p.inequalities(x, &mut c).unwrap();
        assert!(
            c.iter().all(|v| v.is_finite()),
            "{name} {form:?}: rows {c:?}"
        );
        let mut jac = Jacobian::dense(m, n);
        p.inequality_jacobian(x, &mut jac).unwrap();
        let Jacobian::Dense(jac) = jac else {
            panic!("dense Jacobian expected")
        };
        for r in 0..m {
            assert!(
                jac.row(r).iter().all(|v| v.is_finite()),
                "{name} {form:?}: Jacobian row {r}"
            );
        }
    }
}

/// Central difference, Richardson-extrapolated over `h` and `2h` (error `O(h⁴)`).
fn central(model: &Model, u: &Tensor, d: &[f64], delta: f64, which: Scalar, h: f64) -> f64 {
    let f = |s: f64| value(model, &shifted(u, d, s), delta, which);
    (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h)
}

/// One-sided difference from the `+d` side, second order: `(−3f(0) + 4f(h) − f(2h)) / 2h`.
fn one_sided(model: &Model, u: &Tensor, d: &[f64], delta: f64, which: Scalar, h: f64) -> f64 {
    let f = |s: f64| value(model, &shifted(u, d, s), delta, which);
    (-3.0 * f(0.0) + 4.0 * f(h) - f(2.0 * h)) / (2.0 * h)
}

/// Relative error with an absolute floor: `|a − b| / (max(|a|, |b|) + floor)`.
fn rel_err(a: f64, b: f64, floor: f64) -> f64 {
    (a - b).abs() / (a.abs().max(b.abs()) + floor)
}

/// `|analytic − central FD|` relative (floor 1e-3·max(1, |f|)) along `dirs` random directions of
/// `dL/dU` (and of `dC/dU` when the scene has safety obstacles); returns the worst error.
fn central_fd_error(name: &str, model: &Model, u: &Tensor, delta: f64, dirs: u64) -> f64 {
    let ev = model.evaluate(u, delta, true).unwrap();
    let n = u.len();
    let mut worst: f64 = 0.0;
    let mut scalars = vec![(Scalar::L, ev.grad_l.unwrap(), ev.metrics.l)];
    if model.safety.is_some() {
        scalars.push((Scalar::C, ev.grad_c.unwrap(), ev.metrics.c));
    }
    for (which, grad, f) in &scalars {
        for seed in 0..dirs {
            let d = noise(1000 + seed, n);
            let an = dot(grad.data(), &d);
            let fd = central(model, u, &d, delta, *which, 1e-6);
            let e = rel_err(an, fd, 1e-3 * f.abs().max(1.0));
            println!("{name}: {which:?} dir {seed}: analytic {an:.12e}  FD {fd:.12e}  rel {e:.2e}");
            worst = worst.max(e);
        }
    }
    worst
}

/// The smooth-case check: finite everywhere and central differences within `tol`.
fn check_smooth(name: &str, model: &Model, u: &Tensor, delta: f64, tol: f64) -> Evaluation {
    let ev = evaluate_finite(name, model, u, delta);
    let worst = central_fd_error(name, model, u, delta, 3);
    assert!(
        worst <= tol,
        "{name}: worst relative FD error {worst:.3e} > {tol:.0e}"
    );
    ev
}

/// Unit direction changing only one control coordinate (`step`, `control`, `axis`).
fn coordinate(model: &Model, step: usize, control: usize, axis: usize) -> Vec<f64> {
    let mut d = vec![0.0; model.task.horizon * 3 * model.n_controls()];
    d[step * 3 * model.n_controls() + 3 * control + axis] = 1.0;
    d
}

// ---------------------------------------------------------------------------------------------
// zero-length edges and coincident particles

#[test]
fn zero_length_edges_of_a_collapsed_cloth() {
    // `right` and `down` of length 1e-300: validation accepts them (nonzero, not parallel), but
    // every rest position rounds to `top_left`, so every edge has rest length 0 and all
    // particles start coincident (‖·‖ at 0 in every constraint).
    let mut scene = small(3, 3, 3, 20);
    scene.cloth.right = [1e-300, 0.0, 0.0];
    scene.cloth.down = [0.0, 0.0, -1e-300];
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let rest = &model.start;
    assert!((1..9).all(|p| rest.row(p) == rest.row(0)), "coincident");
    // At zero controls the free particles start falling from one point: every constraint is
    // first projected with ‖·‖ at 0 (∇C = 0, skipped), then gravity separates them.
    let ev = evaluate_finite(
        "collapsed, zero controls",
        &model,
        &model.zero_controls(),
        0.0,
    );
    assert!(ev.metrics.e > 0.0);
    // Random controls pull the particles apart; the rollout is then smooth in U (the coincident
    // start does not depend on U), so the central difference applies.
    let u = random_controls(&model, 1, 0.1);
    let ev = check_smooth("collapsed, random controls", &model, &u, 0.0, 1e-5);
    assert!(ev.metrics.e > 0.0);
}

#[test]
fn coincident_control_particles() {
    // 2×2: the two gripped corners are joined by a stretch edge. Step 1 moves them onto the same
    // point (x = 0 exactly): that edge's C = −1 and ∇C is the norm at 0. Both particles have
    // inverse mass 0, so the projection leaves them; its energy ½kC² has a symmetric kink there,
    // where the documented gradient (0) equals the central difference.
    for k in [1e4, f64::INFINITY] {
        let mut scene = small(2, 2, 3, 20);
        scene.material.stretch = Stiffness::from_value(k);
        scene.task.beta = 1e-3;
        let model = Model::from_scene(&scene).unwrap();
        let mut u = random_controls(&model, 2, 0.05);
        u.data_mut()[..6].copy_from_slice(&[0.5, 0.0, 0.0, -0.5, 0.0, 0.0]);
        let states = model.simulate(&u).unwrap();
        assert_eq!(states[1].row(0), states[1].row(1), "corners coincide");
        check_smooth(
            &format!("coincident corners, k = {k}"),
            &model,
            &u,
            0.0,
            1e-5,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// SDF kinks: sphere centre, relu at δ, ties between spheres

#[test]
fn particle_exactly_at_a_sphere_centre() {
    // A safety sphere centred where gripped corner 0 is at step 1 (its rest position, u₀ = 0):
    // SDF = −r there with gradient 0 (the norm's convention). The kink is symmetric, so the
    // central difference of C along any direction equals the convention.
    let mut scene = small(4, 4, 3, 20);
    scene.obstacles = vec![spheres(
        vec![[-0.5, -1.5, 2.0]],
        vec![0.25],
        ObstacleRole::Safety,
    )];
    let model = Model::from_scene(&scene).unwrap();
    let mut u = random_controls(&model, 3, 0.05);
    u.data_mut()[..3].fill(0.0);
    let ev = check_smooth("particle at sphere centre", &model, &u, 0.1, 1e-5);
    assert_eq!(ev.metrics.min_sdf, -0.25);
    // Moving the corner off the centre along z: the documented gradient at the centre is 0 in
    // every direction, and the one-sided derivatives are ±1 per unit (the kink is real).
    let d = coordinate(&model, 0, 0, 2);
    let an = dot(ev.grad_c.as_ref().unwrap().data(), &d);
    let step1 = |s: f64| {
        let ev = model.evaluate(&shifted(&u, &d, s), 0.1, false).unwrap();
        ev.metrics.c
    };
    let right = (step1(1e-6) - step1(0.0)) / 1e-6;
    let left = (step1(0.0) - step1(-1e-6)) / 1e-6;
    println!("sphere centre: dC·e_z analytic {an:e}, one-sided right {right:e}, left {left:e}");
    // C gains |s| from the corner (a V-shaped kink of slope ±1): the one-sided derivatives differ
    // by 2, and the convention (0 from the corner) is their midpoint.
    assert!(
        (right - left - 2.0).abs() < 1e-4,
        "right {right}, left {left}"
    );
    assert!((an - 0.5 * (right + left)).abs() < 1e-4, "{an}");
    // The corner's own contribution is zero: the analytic derivative is what the other
    // (smooth) particles give, which the central difference also sees.
    let fd = central(&model, &u, &d, 0.1, Scalar::C, 1e-6);
    assert!(rel_err(an, fd, 1e-3) < 1e-6, "{an} vs {fd}");
}

#[test]
fn a_collider_sphere_centred_on_a_free_particle() {
    // Gravity off, so free particle 5 of the 4×4 cloth is still exactly at the centre of a
    // collider sphere when the first projection sees it: the collider has no direction to push
    // (∇C = 0) and leaves it; nothing becomes NaN. Later the stretch constraints move it off
    // the centre and the collider pushes it out.
    let mut scene = small(4, 4, 3, 20);
    scene.physics.gravity = [0.0; 3];
    let model0 = Model::from_scene(&scene).unwrap();
    let c = model0.start.row(5).to_vec();
    scene.obstacles = vec![spheres(
        vec![[c[0], c[1], c[2]]],
        vec![0.05],
        ObstacleRole::Both,
    )];
    let model = Model::from_scene(&scene).unwrap();
    evaluate_finite(
        "collider centred on particle, zero controls",
        &model,
        &model.zero_controls(),
        0.0,
    );
    let u = random_controls(&model, 4, 0.02);
    evaluate_finite("collider centred on particle", &model, &u, 0.0);
    let worst = central_fd_error("collider centred on particle", &model, &u, 0.0, 3);
    assert!(worst <= 1e-5, "{worst:.3e}");
}

#[test]
fn particle_exactly_at_delta_relu_kink() {
    // A safety sphere above gripped corner 0: at u₀ = 0 its SDF is 0.5 − 0.25 = 0.25 = δ exactly.
    // Convention: relu'(0) = 0 — the corner counts as safe and pulls nothing; that is the
    // derivative from the safe side (moving away), not the central difference.
    let mut scene = small(4, 4, 3, 20);
    scene.obstacles = vec![spheres(
        vec![[-0.5, -1.5, 2.5]],
        vec![0.25],
        ObstacleRole::Safety,
    )];
    let model = Model::from_scene(&scene).unwrap();
    let delta = 0.25;
    // Corner 0 stays put on every step (control 1 moves, so consecutive controls differ).
    let mut u = random_controls(&model, 5, 0.05);
    for t in 0..3 {
        u.row_mut(t)[..3].fill(0.0);
    }
    let ev = evaluate_finite("particle at δ", &model, &u, delta);
    assert_eq!(ev.metrics.min_sdf, delta, "exactly at the kink");
    assert_eq!(ev.metrics.c, 0.0);
    let gc = ev.grad_c.as_ref().unwrap();
    // Toward the sphere (+z) is the unsafe side; away (−z) is the safe side.
    let away: Vec<f64> = coordinate(&model, 0, 0, 2).iter().map(|v| -v).collect();
    let an = dot(gc.data(), &away);
    let safe = one_sided(&model, &u, &away, delta, Scalar::C, 1e-6);
    let toward: Vec<f64> = away.iter().map(|v| -v).collect();
    let unsafe_side = one_sided(&model, &u, &toward, delta, Scalar::C, 1e-6);
    println!("relu kink: analytic {an:e}, safe side {safe:e}, unsafe side {unsafe_side:e}");
    assert_eq!(an, 0.0);
    assert!(safe.abs() < 1e-6, "safe side {safe}");
    // Toward the sphere, the corner's margin is violated on all 3 steps: slope −3.
    assert!(
        (unsafe_side + 3.0).abs() < 1e-4,
        "the kink is real: unsafe side {unsafe_side}"
    );
    // The objective is smooth there (no safety term in L).
    let worst = central_fd_error("particle at δ (L only)", &model, &u, 0.0, 2);
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn two_spheres_equidistant_min_tie() {
    // Two safety spheres at exactly the same distance (√0.3125, centres at x = −0.5 ± 0.25, all
    // binary-exact) from gripped corner 0 at step 1;
    // δ = 0.4 so the corner violates the margin and the tie decides its gradient. Convention: the
    // first sphere. That equals the one-sided derivative from the side where the first sphere is
    // the nearer one, and differs from the other side's.
    let delta = 0.4;
    let build = |centers: Vec<[f64; 3]>| {
        let mut scene = small(4, 4, 3, 20);
        scene.obstacles = vec![spheres(centers, vec![0.25, 0.25], ObstacleRole::Safety)];
        Model::from_scene(&scene).unwrap()
    };
    let first = [-0.75, -1.5, 2.5];
    let second = [-0.25, -1.5, 2.5];
    let model = build(vec![first, second]);
    let mut u = random_controls(&model, 6, 0.05);
    u.data_mut()[..3].fill(0.0);
    let ev = evaluate_finite("sphere tie", &model, &u, delta);
    let mut comps = [0.0; 2];
    model
        .safety_obstacles
        .components(&cloth::nalgebra::Vector3::new(-0.5, -1.5, 2.0), &mut comps);
    assert_eq!(comps[0], comps[1], "an exact tie");
    let gc = ev.grad_c.as_ref().unwrap();
    // −x moves the corner toward the first sphere (it becomes strictly nearer).
    let to_first: Vec<f64> = coordinate(&model, 0, 0, 0).iter().map(|v| -v).collect();
    let to_second: Vec<f64> = to_first.iter().map(|v| -v).collect();
    let an = dot(gc.data(), &to_first);
    let side_first = one_sided(&model, &u, &to_first, delta, Scalar::C, 1e-6);
    let side_second = -one_sided(&model, &u, &to_second, delta, Scalar::C, 1e-6);
    println!("tie: analytic {an:.9e}, first-sphere side {side_first:.9e}, second-sphere side {side_second:.9e}");
    assert!(rel_err(an, side_first, 1e-6) < 1e-6, "{an} vs {side_first}");
    assert!(
        (side_first - side_second).abs() > 0.1,
        "the tie is a real kink: {side_first} vs {side_second}"
    );
    // Swapping the order swaps the convention: now the −x side is the second-listed sphere's.
    let swapped = build(vec![second, first]);
    let ev = evaluate_finite("sphere tie swapped", &swapped, &u, delta);
    let an_swapped = dot(ev.grad_c.as_ref().unwrap().data(), &to_first);
    assert!(
        rel_err(an_swapped, side_second, 1e-6) < 1e-6,
        "{an_swapped} vs {side_second}"
    );
}

// ---------------------------------------------------------------------------------------------
// T's kinks: identical consecutive controls, all-zero controls

#[test]
fn identical_consecutive_and_all_zero_controls() {
    let scene = small(4, 4, 4, 20);
    let model = Model::from_scene(&scene).unwrap();
    // All zero: every ‖u_t − u_{t−1}‖ is at 0. The kinks are symmetric, so the central difference
    // of L equals the convention (T contributes 0).
    check_smooth(
        "all-zero controls",
        &model,
        &model.zero_controls(),
        0.0,
        1e-5,
    );
    // Steps 1 and 2 identical, the others distinct.
    let mut u = random_controls(&model, 7, 0.05);
    let w = 3 * model.n_controls();
    let first: Vec<f64> = u.row(0).to_vec();
    u.row_mut(1).copy_from_slice(&first);
    let ev = check_smooth("identical steps 1 and 2", &model, &u, 0.0, 1e-5);
    // The T part of dL/dU on step 1 comes only from ‖u₂ − u₁‖ (the zero difference adds 0):
    // compare with the model without α.
    let mut no_t = scene.clone();
    no_t.task.alpha = 0.0;
    let g0 = Model::from_scene(&no_t)
        .unwrap()
        .evaluate(&u, 0.0, true)
        .unwrap()
        .grad_l
        .unwrap();
    let gl = ev.grad_l.unwrap();
    let d12: Vec<f64> = (0..w).map(|j| u.get(2, j) - u.get(1, j)).collect();
    let n12 = dot(&d12, &d12).sqrt();
    for (j, d) in d12.iter().enumerate() {
        let expect = g0.get(0, j); // step 0 only has the zero difference to step 1
        assert!((gl.get(0, j) - expect).abs() < 1e-12, "step 0, {j}");
        let expect = g0.get(1, j) - scene.task.alpha * d / n12;
        assert!((gl.get(1, j) - expect).abs() < 1e-12, "step 1, {j}");
    }
}

// ---------------------------------------------------------------------------------------------
// stiffness extremes

#[test]
fn stiffness_extremes() {
    // (stretch, bending): rigid, nearly none, nearly rigid, and stretch/bend ratio 1e10 both ways.
    let cases: [(&str, f64, f64, f64); 6] = [
        ("stretch ∞, bending ∞", f64::INFINITY, f64::INFINITY, 1e-5),
        ("stretch ∞, bending 1e2", f64::INFINITY, 1e2, 1e-5),
        ("stretch 1e-12, bending 1e-12", 1e-12, 1e-12, 1e-5),
        ("stretch 1e12, bending 1e12", 1e12, 1e12, 1e-5),
        ("stretch 1e12, bending 1e2 (ratio 1e10)", 1e12, 1e2, 1e-5),
        ("stretch 1e4, bending 1e-6 (ratio 1e10)", 1e4, 1e-6, 1e-5),
    ];
    for (name, ks, kb, tol) in cases {
        let mut scene = small(4, 4, 3, 20);
        scene.material.stretch = Stiffness::from_value(ks);
        scene.material.bending = Some(Bending {
            model: BendingModel::Distance,
            stiffness: Stiffness::from_value(kb),
        });
        let model = Model::from_scene(&scene).unwrap();
        let u = random_controls(&model, 8, 0.05);
        check_smooth(name, &model, &u, 0.0, tol);
    }
}

// ---------------------------------------------------------------------------------------------
// extreme controls: 10× overstretch, inverted triangles

#[test]
fn ten_cloth_widths_in_one_step() {
    // Corner 0 jumps 10 cloth widths in x in step 1: every edge near it is overstretched ~10×.
    for bending in [
        BendingModel::Distance,
        BendingModel::Dihedral,
        BendingModel::Isometric,
    ] {
        let mut scene = small(4, 4, 3, 20);
        scene.material.bending = Some(Bending {
            model: bending,
            stiffness: Stiffness::Finite(1e2),
        });
        let model = Model::from_scene(&scene).unwrap();
        let mut u = random_controls(&model, 9, 0.05);
        u.data_mut()[0] = -10.0;
        let name = format!("10 widths in one step, {bending:?} bending");
        let ev = check_smooth(&name, &model, &u, 0.0, 1e-5);
        let last = ev.states.last().unwrap();
        let (x0, x3) = (last.get(0, 0), last.get(3, 0));
        assert!(x3 - x0 > 5.0, "the cloth is overstretched: {x0} .. {x3}");
    }
}

#[test]
fn inverted_triangles() {
    // The gripped corners swap sides (x: −0.5 ↔ 0.5) in the first step: the top edge of every
    // triangle is mirrored, so the cloth turns inside out (dihedral bending sees inverted
    // triangles; the distance constraints pass through zero length on the way).
    for bending in [
        BendingModel::Distance,
        BendingModel::Dihedral,
        BendingModel::Isometric,
    ] {
        let mut scene = small(4, 4, 3, 40);
        scene.material.bending = Some(Bending {
            model: bending,
            stiffness: Stiffness::Finite(1e2),
        });
        let model = Model::from_scene(&scene).unwrap();
        let mut u = random_controls(&model, 10, 0.02);
        u.data_mut()[0] = 1.0;
        u.data_mut()[3] = -1.0;
        let name = format!("inverted triangles, {bending:?} bending");
        check_smooth(&name, &model, &u, 0.0, 1e-5);
    }
}

// ---------------------------------------------------------------------------------------------
// long horizons and many iterations

/// `|dL/dU|` and the largest per-step row norm.
fn gradient_norms(model: &Model, u: &Tensor) -> (f64, f64) {
    let ev = evaluate_finite("long horizon", model, u, 0.0);
    let g = ev.grad_l.unwrap();
    let rows = (0..g.rows())
        .map(|t| dot(g.row(t), g.row(t)).sqrt())
        .fold(0.0, f64::max);
    (g.norm(), rows)
}

/// Controls of `horizon` steps that take the grippers along the same path whatever the horizon:
/// a total displacement of (0.3, 0.6, −0.2) per gripper, split evenly with a small deterministic
/// wiggle (so consecutive controls differ).
fn path_controls(model: &Model) -> Tensor {
    let h = model.task.horizon;
    let w = 3 * model.n_controls();
    let total = [0.3, 0.6, -0.2];
    let wiggle = noise(42, h * w);
    let v = (0..h * w)
        .map(|i| total[i % 3] / h as f64 * (1.0 + 0.2 * wiggle[i]))
        .collect();
    controls(model, v)
}

#[test]
fn long_horizon_t100_gradient_grows_like_sqrt_t() {
    // Quasi-static physics: the final state depends on the grippers' final positions
    // (rest + Σ_t u_t), so every step's control moves G alike and |dG/du_t| is the same for all
    // t: |dL/dU| ≈ √T·|dG/dp| — it grows like √T, not exponentially. Measured here on a 4×4 cloth
    // with 100 iterations per step along the same gripper path.
    let mut norms = Vec::new();
    for horizon in [10, 100] {
        let model = Model::from_scene(&small(4, 4, horizon, 100)).unwrap();
        let u = path_controls(&model);
        let (norm, row) = gradient_norms(&model, &u);
        println!(
            "T = {horizon:>3}, 100 iterations: |dL/dU| = {norm:.6e}, largest step row {row:.6e}"
        );
        norms.push((norm, row));
        if horizon == 100 {
            let worst = central_fd_error("T = 100", &model, &u, 0.0, 1);
            assert!(worst < 1e-5, "{worst}");
        }
    }
    let growth = norms[1].0 / norms[0].0;
    let row_growth = norms[1].1 / norms[0].1;
    println!(
        "T 10 → 100: |dL/dU| grows ×{growth:.3} (√10 = {:.3}); largest row ×{row_growth:.3}",
        10f64.sqrt()
    );
    assert!(growth < 2.0 * 10f64.sqrt(), "growth ×{growth}");
    assert!(row_growth < 2.0, "per-step rows grow ×{row_growth}");
}

#[test]
fn many_iterations_t10_2000_gradient_converges() {
    // More Gauss–Seidel iterations bring each step closer to its quasi-static equilibrium; the
    // gradient converges to the equilibrium's instead of growing.
    let mut norms = Vec::new();
    for iterations in [100, 2000] {
        let model = Model::from_scene(&small(4, 4, 10, iterations)).unwrap();
        let u = path_controls(&model);
        let (norm, row) = gradient_norms(&model, &u);
        println!(
            "T = 10, {iterations:>4} iterations: |dL/dU| = {norm:.6e}, largest step row {row:.6e}"
        );
        norms.push(norm);
        if iterations == 2000 {
            let worst = central_fd_error("2000 iterations", &model, &u, 0.0, 1);
            assert!(worst < 1e-5, "{worst}");
        }
    }
    let ratio = norms[1] / norms[0];
    println!("100 → 2000 iterations: |dL/dU| ×{ratio:.4}");
    assert!((0.5..2.0).contains(&ratio), "×{ratio}");
}

// ---------------------------------------------------------------------------------------------
// tiny and odd meshes

#[test]
fn tiny_and_odd_meshes() {
    for (rows, cols) in [(2, 2), (1, 5), (5, 1), (3, 7), (6, 2)] {
        for bending in [
            None,
            Some(BendingModel::Distance),
            Some(BendingModel::Dihedral),
            Some(BendingModel::Isometric),
        ] {
            let mut scene = small(rows, cols, 3, 20);
            scene.material.bending = bending.map(|model| Bending {
                model,
                stiffness: Stiffness::Finite(1e2),
            });
            let model = Model::from_scene(&scene).unwrap();
            let u = random_controls(&model, 11, 0.05);
            let name = format!("{rows}×{cols}, bending {bending:?}");
            check_smooth(&name, &model, &u, 0.0, 1e-5);
        }
    }
}

#[test]
fn a_single_free_particle() {
    // 1×1, no controls: nothing to differentiate (0 variables), but everything stays finite; the
    // particle falls freely (½gΔt² per step).
    let mut scene = small(1, 1, 3, 5);
    scene.controls.clear();
    scene.task.targets = vec![Target {
        particle: [0, 0].into(),
        position: [0.0, 0.0, 0.0],
    }];
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let u = model.zero_controls();
    assert_eq!(u.shape(), (3, 0));
    let ev = evaluate_finite("single free particle", &model, &u, 0.0);
    let z: Vec<f64> = ev.states.iter().map(|x| x.get(0, 2)).collect();
    let g = 0.5 * 9.8 * 0.1 * 0.1;
    for t in 1..z.len() {
        assert!((z[t - 1] - z[t] - g).abs() < 1e-12, "{z:?}");
    }
    // A single gripped particle: the gradient of G is exactly the unit vector toward the target
    // on every step.
    scene.controls = vec![[0, 0].into()];
    let model = Model::from_scene(&scene).unwrap();
    let u = random_controls(&model, 12, 0.05);
    check_smooth("single gripped particle", &model, &u, 0.0, 1e-6);
}

// ---------------------------------------------------------------------------------------------
// contact edge cases

#[test]
fn ground_plane_exactly_at_a_particles_height() {
    // Gravity off; a collider plane through the bottom row's rest height: C = 0 exactly (not
    // projected, the inequality holds). Then with gravity on: the bottom row falls onto it and
    // rests there (C = 0 to the last bit after each projection).
    for gravity in [[0.0, 0.0, 0.0], [0.0, 0.0, -9.8]] {
        let mut scene = small(4, 4, 3, 20);
        scene.physics.gravity = gravity;
        scene.obstacles = vec![Obstacle::Plane(PlaneSpec {
            point: [0.0, 0.0, 1.0],
            normal: [0.0, 0.0, 1.0],
            role: ObstacleRole::Both,
            friction: None,
        })];
        let model = Model::from_scene(&scene).unwrap();
        assert_eq!(model.start.get(12, 2), 1.0, "bottom row at the plane");
        let u = random_controls(&model, 13, 0.02);
        let name = format!("ground at particle height, g = {}", gravity[2]);
        let ev = evaluate_finite(&name, &model, &u, 0.0);
        let lowest = ev
            .states
            .iter()
            .flat_map(|x| (0..16).map(move |p| x.get(p, 2)))
            .fold(f64::INFINITY, f64::min);
        assert!(lowest >= 1.0 - 1e-12, "{name}: lowest z {lowest}");
        let worst = central_fd_error(&name, &model, &u, 0.0, 3);
        assert!(worst <= 1e-5, "{name}: {worst:.3e}");
    }
}

#[test]
fn a_cloth_starting_inside_an_obstacle() {
    // A collider sphere containing the lower half of the cloth at rest: the first projections
    // push those particles out through the surface. And a safety sphere containing the whole
    // cloth: every particle violates the margin (C ≪ 0), gradients stay finite.
    let mut scene = small(4, 4, 3, 30);
    scene.obstacles = vec![spheres(
        vec![[0.0, -1.5, 1.0]],
        vec![0.6],
        ObstacleRole::Collider,
    )];
    let model = Model::from_scene(&scene).unwrap();
    let u = random_controls(&model, 14, 0.02);
    let ev = evaluate_finite("cloth inside a collider", &model, &u, 0.0);
    let last = ev.states.last().unwrap();
    for p in 0..16 {
        if model.inv_mass[p] > 0.0 {
            let r: f64 = [0.0, -1.5, 1.0]
                .iter()
                .enumerate()
                .map(|(k, c)| (last.get(p, k) - c).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(r >= 0.6 - 1e-9, "particle {p} still inside: r = {r}");
        }
    }
    let worst = central_fd_error("cloth inside a collider", &model, &u, 0.0, 3);
    assert!(worst <= 1e-5, "{worst:.3e}");

    let mut scene = small(4, 4, 3, 20);
    scene.obstacles = vec![spheres(
        vec![[0.0, -1.5, 1.5]],
        vec![2.0],
        ObstacleRole::Safety,
    )];
    let model = Model::from_scene(&scene).unwrap();
    let u = random_controls(&model, 15, 0.05);
    let ev = check_smooth("cloth inside a safety sphere", &model, &u, 0.1, 1e-5);
    assert!(
        ev.metrics.c < -10.0 && ev.metrics.min_sdf < -1.0,
        "{:?}",
        ev.metrics
    );
}
