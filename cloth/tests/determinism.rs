//! Bitwise determinism: the plain rollout (`Model::simulate`) and the recorded one
//! (`Model::record_step` chained on one `Tape`) give identical states, and `evaluate` (metrics,
//! states, both gradients) is identical in a 1-thread and a 2-thread rayon pool.

mod common;

use autodiff::rowfn::PARALLEL_MIN_ROWS;
use autodiff::{Tape, Tensor};
use cloth::Evaluation;
use cloth::{Model, Scene};
use common::{bitwise_eq, XorShift};

/// Records the whole rollout on one tape (each step chained to the previous step's output) and
/// returns the recorded states, the first the rest state.
fn recorded_rollout(model: &Model, controls: &Tensor) -> (Vec<Tensor>, usize) {
    let mut tape = Tape::new();
    let mut x = tape.leaf(model.start.clone());
    let mut states = vec![tape.value(x).clone()];
    for t in 0..model.task.horizon {
        let u = tape.leaf(model.step_controls(controls, t));
        x = model.record_step(&mut tape, x, u);
        states.push(tape.value(x).clone());
    }
    (states, tape.len())
}

/// Asserts the plain and recorded rollouts agree bit for bit at every step.
fn assert_paths_agree(model: &Model, controls: &Tensor) -> Vec<Tensor> {
    let plain = model.simulate(controls).unwrap();
    let (recorded, nodes) = recorded_rollout(model, controls);
    assert_eq!(plain.len(), model.task.horizon + 1);
    assert_eq!(recorded.len(), plain.len());
    for (t, (a, b)) in plain.iter().zip(&recorded).enumerate() {
        assert!(
            bitwise_eq(a, b),
            "step {t}: plain and recorded states differ"
        );
    }
    // Not vacuous: the rollout moved the cloth, and the tape holds one node per set update.
    assert!(!bitwise_eq(&plain[0], &plain[model.task.horizon]));
    let per_step = 2 * model.iterations * model.sets_per_iteration();
    assert!(nodes > model.task.horizon * per_step, "{nodes} nodes");
    plain
}

/// `u` + uniform noise in `[-a, a]`.
fn jittered(u: &Tensor, a: f64, seed: u64) -> Tensor {
    let mut rng = XorShift::new(seed);
    let mut v = u.clone();
    for x in v.data_mut() {
        *x += rng.uniform(-a, a);
    }
    v
}

#[test]
fn plain_and_recorded_rollouts_are_bitwise_equal_on_u_obstacle() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let u0 = scene.initial_controls();
    assert_paths_agree(&model, &u0);
    assert_paths_agree(&model, &jittered(&u0, 0.05, 1));
}

#[test]
fn plain_and_recorded_rollouts_are_bitwise_equal_on_drop() {
    let scene = Scene::builtin("drop").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    assert!(model.group("collider").is_some());
    assert_paths_agree(&model, &model.zero_controls());
    // Corners lowered 0.145 per step (to z = 0.05) with some noise: the cloth lands on the
    // ground, so the collider projection is active in both paths.
    let mut lower = model.zero_controls();
    for t in 0..model.task.horizon {
        for k in 0..model.n_controls() {
            lower.row_mut(t)[3 * k + 2] = -0.145;
        }
    }
    let states = assert_paths_agree(&model, &jittered(&lower, 0.01, 2));
    let last = states.last().unwrap();
    let on_ground = (0..last.rows()).filter(|&p| last.get(p, 2) < 1e-6).count();
    assert!(on_ground >= 10, "{on_ground} particles on the ground");
}

/// Bitwise comparison of two evaluations: every metric, every state, both gradients.
fn assert_evaluations_identical(a: &Evaluation, b: &Evaluation) {
    let m = |e: &Evaluation| {
        let m = e.metrics;
        [m.g, m.t, m.e, m.alpha_t, m.beta_e, m.c, m.min_sdf, m.l].map(f64::to_bits)
    };
    assert_eq!(
        m(a),
        m(b),
        "metrics differ: {:?} vs {:?}",
        a.metrics,
        b.metrics
    );
    assert_eq!(a.states.len(), b.states.len());
    for (t, (x, y)) in a.states.iter().zip(&b.states).enumerate() {
        assert!(bitwise_eq(x, y), "state {t} differs");
    }
    assert!(bitwise_eq(
        a.grad_l.as_ref().unwrap(),
        b.grad_l.as_ref().unwrap()
    ));
    assert!(bitwise_eq(
        a.grad_c.as_ref().unwrap(),
        b.grad_c.as_ref().unwrap()
    ));
}

#[test]
fn evaluate_is_bitwise_identical_with_one_and_two_threads() {
    let mut scene = Scene::builtin("u_obstacle")
        .unwrap()
        .refined(40, 40)
        .unwrap();
    scene.task.horizon = 2;
    scene.physics.iterations = 10;
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    // The big sets cross the parallel threshold, so the 2-thread pool really splits them.
    let largest = model.sets().map(|s| s.index.rows()).max().unwrap();
    assert!(
        largest >= PARALLEL_MIN_ROWS,
        "largest set has {largest} rows < {PARALLEL_MIN_ROWS}"
    );
    assert!(model.n_particles() >= PARALLEL_MIN_ROWS); // the per-particle SDF map too
    let u = jittered(&scene.initial_controls(), 0.05, 3);
    // After two steps the cloth is still ~0.7 from the obstacle: δ = (closest distance) + 0.3, so
    // many particles (not only the gripped corners) violate it and dC/dU flows through the solver.
    let delta = model.evaluate(&u, 0.0, false).unwrap().metrics.min_sdf + 0.3;
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let ev = model.evaluate(&u, delta, true).unwrap();
                // Plain and recorded paths agree in this pool too.
                let (recorded, _) = recorded_rollout(&model, &u);
                for (a, b) in ev.states.iter().zip(&recorded) {
                    assert!(bitwise_eq(a, b));
                }
                ev
            })
    };
    let one = run(1);
    let two = run(2);
    assert_evaluations_identical(&one, &two);
    // Not vacuous: both gradients are non-zero and finite.
    let (gl, gc) = (one.grad_l.as_ref().unwrap(), one.grad_c.as_ref().unwrap());
    assert!(gl.is_finite() && gl.norm() > 0.0);
    assert!(gc.is_finite() && gc.norm() > 0.0, "C = {}", one.metrics.c);
    println!(
        "40×40: {} sets, largest {largest} rows; L = {}, C = {}, |dL/dU| = {:e}, |dC/dU| = {:e}",
        model.sets_per_iteration(),
        one.metrics.l,
        one.metrics.c,
        gl.norm(),
        gc.norm()
    );
}
