//! `Model::gradients` recorded in blocks of iterations from checkpoints (when a step's recording
//! exceeds `Model::checkpoint_budget`) gives the gradients of the whole-step recording.
//!
//! Scenes: `u_obstacle` at 6×6 (stretch, distance bending, safety spheres) and `drop` at 6×6 (a
//! ground collider, an inequality constraint that switches on), T = 3, 20 iterations. Costs: the
//! loss, the safety function, and a cost reading the state before the step (`Σ|x − x_prev|²`),
//! whose `x_prev` adjoint reaches the step's first block from its last one. Blocks of 1, 7
//! (uneven: 7 + 7 + 6) and 20 iterations (one block) must agree to 1e-12 relative.

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
    let mut m = model.clone();
    m.checkpoint_budget = 2 * block * m.recorded_bytes_per_iteration();
    assert_eq!(m.iterations_per_block(), block.min(m.iterations));
    let states = m.simulate(u).unwrap();
    let beta = m.task.beta;
    let delta = m.task.delta;
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| m.record_loss(tape, t, x, beta);
    let safety = |tape: &mut Tape, _: usize, _: Var, x: Var| m.record_safety(tape, x, delta);
    let motion = |tape: &mut Tape, _: usize, x_prev: Var, x: Var| {
        let d = tape.sub(x, x_prev);
        let d2 = tape.square(d);
        Some(tape.sum(d2))
    };
    m.gradients(&states, u, &[&loss, &safety, &motion])
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
