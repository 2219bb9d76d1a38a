//! `Model::gradients` recorded in blocks of iterations from checkpoints (when a step's recording
//! exceeds `Model::checkpoint_budget`) gives the gradients of the whole-step recording.
//!
//! Scenes: `u_obstacle` at 6×6 (stretch, distance bending, safety spheres) and `drop` at 6×6 (a
//! ground collider, an inequality constraint that switches on), T = 3, 20 iterations. Costs: the
//! loss, the safety function, and a cost reading the state before the step (`Σ|x − x_prev|²`),
//! whose `x_prev` adjoint reaches the step's first block from its last one. Blocks of 1, 7
//! (uneven: 7 + 7 + 6) and 20 iterations (one block) must agree to 1e-12 relative. The
//! checkpoints the plain forward keeps (`Model::simulate_recording` over the budget) give the
//! states and gradients of the checkpoints recomputed in the backward pass, bit for bit.

use autodiff::{Tape, Tensor, Var};
use cloth::{Model, Scene};

mod common;

fn model(name: &str) -> (Model, Tensor) {
    let mut scene = Scene::builtin(name).unwrap().refined(6, 6).unwrap();
    scene.task.horizon = 3;
    scene.physics.iterations = 20;
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let u = scene.initial_controls();
    (model, u)
}

/// The three costs' gradients with blocks of `block` iterations.
fn gradients(model: &Model, u: &Tensor, block: usize) -> Vec<Tensor> {
    let m = blocked(model, block);
    let states = m.simulate(u).unwrap();
    with_costs(&m, |costs| m.gradients(&states, u, costs))
}

/// `model` with a budget that records blocks of `block` iterations.
fn blocked(model: &Model, block: usize) -> Model {
    let mut m = model.clone();
    m.checkpoint_budget = 2 * block * m.recorded_bytes_per_iteration();
    assert_eq!(m.iterations_per_block(), block.min(m.iterations));
    m
}

/// `run` on the three costs.
fn with_costs<T>(m: &Model, run: impl FnOnce(&[cloth::StepCost<'_>]) -> T) -> T {
    let beta = m.task.beta;
    let delta = m.task.delta;
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| m.record_loss(tape, t, x, beta);
    let safety = |tape: &mut Tape, _: usize, _: Var, x: Var| m.record_safety(tape, x, delta);
    let motion = |tape: &mut Tape, _: usize, x_prev: Var, x: Var| {
        let d = tape.sub(x, x_prev);
        let d2 = tape.square(d);
        Some(tape.sum(d2))
    };
    run(&[&loss, &safety, &motion])
}

fn check(name: &str) {
    let (model, u) = model(name);
    let whole = gradients(&model, &u, 20);
    let norm = whole
        .iter()
        .flat_map(|g| g.data())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(norm > 1e-3, "{name}: gradients are all ~0 ({norm:e})");
    for block in [1, 7] {
        let blocked = gradients(&model, &u, block);
        for (k, (a, b)) in whole.iter().zip(&blocked).enumerate() {
            for (x, y) in a.data().iter().zip(b.data()) {
                assert!(
                    (x - y).abs() <= 1e-12 * norm,
                    "{name}, cost {k}, blocks of {block}: {x} vs {y}"
                );
            }
        }
    }
}

#[test]
fn blocked_gradients_match_whole_steps_on_u_obstacle() {
    check("u_obstacle");
}

#[test]
fn blocked_gradients_match_whole_steps_with_a_collider() {
    check("drop");
}

#[test]
fn checkpoints_kept_by_the_forward_give_the_same_bits() {
    for name in ["u_obstacle", "drop"] {
        let (model, u) = model(name);
        let m = blocked(&model, 7);
        let recomputed = gradients(&model, &u, 7);
        let states = m.simulate(&u).unwrap();
        let (kept_states, kept) = with_costs(&m, |costs| {
            let rollout = m.simulate_recording(&u, costs).unwrap();
            // Three steps, three blocks each: two checkpoints per step.
            assert_eq!(rollout.kept_checkpoints(), Some(6), "{name}");
            rollout.gradients(&m, &u, costs)
        });
        assert_eq!(states, kept_states, "{name}: states");
        assert_eq!(recomputed, kept, "{name}: gradients");
    }
}
