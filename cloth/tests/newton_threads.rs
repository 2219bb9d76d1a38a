//! Newton results do not depend on the rayon thread count: `evaluate` (metrics, states, `dL/dU`
//! and `dC/dU` by implicit differentiation) is bitwise identical in a 1-thread and a 2-thread
//! pool, on a refined `u_obstacle` and on `drop` with the cloth pressed onto its ground collider
//! (active contact rows), and with Newton's systems solved by preconditioned conjugate gradients.

mod common;

use autodiff::Tensor;
use cloth::scene::{LinearSolverKind, SolverKind};
use cloth::Evaluation;
use cloth::{Model, Scene};
use common::{bitwise_eq, XorShift};

/// `u` + uniform noise in `[-a, a]`.
fn jittered(u: &Tensor, a: f64, seed: u64) -> Tensor {
    let mut rng = XorShift::new(seed);
    let mut v = u.clone();
    for x in v.data_mut() {
        *x += rng.uniform(-a, a);
    }
    v
}

/// `evaluate(u, delta, true)` of `model` in a pool of `threads` threads.
fn evaluate_in_pool(model: &Model, u: &Tensor, delta: f64, threads: usize) -> Evaluation {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| model.evaluate(u, delta, true).unwrap())
}

/// Asserts two evaluations agree bit for bit and that the gradients are not vacuous.
fn assert_identical(a: &Evaluation, b: &Evaluation) {
    let bits = |e: &Evaluation| {
        let m = e.metrics;
        [m.g, m.t, m.e, m.alpha_t, m.beta_e, m.c, m.min_sdf, m.l].map(f64::to_bits)
    };
    assert_eq!(bits(a), bits(b), "{:?} vs {:?}", a.metrics, b.metrics);
    assert_eq!(a.states.len(), b.states.len());
    for (t, (x, y)) in a.states.iter().zip(&b.states).enumerate() {
        assert!(bitwise_eq(x, y), "state {t} differs");
    }
    for (name, ga, gb) in [
        ("dL/dU", &a.grad_l, &b.grad_l),
        ("dC/dU", &a.grad_c, &b.grad_c),
    ] {
        let (ga, gb) = (ga.as_ref().unwrap(), gb.as_ref().unwrap());
        assert!(bitwise_eq(ga, gb), "{name} differs");
        assert!(ga.is_finite(), "{name} not finite");
    }
    assert!(a.grad_l.as_ref().unwrap().norm() > 0.0);
}

/// With Newton's systems solved directly and by conjugate gradients (`physics.linear_solver`
/// `"pcg"`, `cloth/src/newton/pcg.rs`).
#[test]
fn newton_evaluate_is_bitwise_identical_with_one_and_two_threads_on_u_obstacle() {
    for linear in [LinearSolverKind::Direct, LinearSolverKind::Pcg] {
        let mut scene = Scene::builtin("u_obstacle")
            .unwrap()
            .refined(20, 20)
            .unwrap();
        scene.physics.solver = Some(SolverKind::Newton);
        scene.physics.linear_solver = linear;
        scene.task.horizon = 3;
        scene.validate().unwrap();
        let model = Model::from_scene(&scene).unwrap();
        let u = jittered(&scene.initial_controls(), 0.02, 5);
        // δ above the closest distance, so dC/dU is non-zero and flows through the implicit
        // solves.
        let delta = model.evaluate(&u, 0.0, false).unwrap().metrics.min_sdf + 0.3;
        let one = evaluate_in_pool(&model, &u, delta, 1);
        let two = evaluate_in_pool(&model, &u, delta, 2);
        assert_identical(&one, &two);
        assert!(
            one.grad_c.as_ref().unwrap().norm() > 0.0,
            "C = {}",
            one.metrics.c
        );
    }
}

#[test]
fn newton_evaluate_is_bitwise_identical_with_one_and_two_threads_with_contacts() {
    let mut scene = Scene::builtin("drop").unwrap();
    scene.physics.solver = Some(SolverKind::Newton);
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    // With noise: the cloth lands on the collider, so contact rows are active.
    let u = jittered(&common::lowered_and_dragged(&model), 0.005, 6);
    let delta = scene.task.delta;
    let one = evaluate_in_pool(&model, &u, delta, 1);
    let two = evaluate_in_pool(&model, &u, delta, 2);
    assert_identical(&one, &two);
    let last = one.states.last().unwrap();
    let on_ground = (0..last.rows()).filter(|&p| last.get(p, 2) < 1e-9).count();
    assert!(on_ground >= 10, "{on_ground} particles on the ground");
}
