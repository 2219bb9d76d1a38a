//! Recording during the first forward (`Model::simulate_recording`, what `Model::evaluate` runs):
//! when the whole rollout's recording fits `Model::checkpoint_budget`, every step is recorded on
//! the way and the backward pass pulls back through those recordings (no re-recording).
//!
//! - The results are bitwise those of the plain path (`Model::simulate`, then `Model::gradients`
//!   re-recording each whole step): states, metrics, `dL/dU` and `dC/dU`, for `u_obstacle` (stretch,
//!   distance bending, safety spheres) and `drop` (a ground collider that switches on) at 6×6,
//!   T = 4, 20 iterations.
//! - Memory stays within the budget: the recordings' bytes (`Tape::memory_bytes`) are at most the
//!   budget for every budget from 0.9× to 1.1× what they take; one byte below, nothing is kept
//!   (the plain path runs).

use autodiff::{Tape, Tensor, Var};
use cloth::StepCost;
use cloth::{Model, Scene};

fn model(name: &str) -> (Model, Tensor) {
    let mut scene = Scene::builtin(name).unwrap().refined(6, 6).unwrap();
    scene.task.horizon = 4;
    scene.physics.iterations = 20;
    scene.validate().unwrap();
    let model = Model::from_scene(&scene).unwrap();
    (model, scene.initial_controls())
}

/// The bytes the whole rollout's recordings take with the loss and safety costs (`None`: not
/// recorded).
fn recorded_bytes(m: &Model, u: &Tensor) -> Option<usize> {
    let (beta, delta) = (m.task.beta, m.task.delta);
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| m.record_loss(tape, t, x, beta);
    let safety = |tape: &mut Tape, _: usize, _: Var, x: Var| m.record_safety(tape, x, delta);
    let costs: [StepCost<'_>; 2] = [&loss, &safety];
    m.simulate_recording(u, &costs).unwrap().recorded_bytes()
}

fn bits(t: &Tensor) -> Vec<u64> {
    t.data().iter().map(|v| v.to_bits()).collect()
}

fn check(name: &str) {
    let (recorded, u) = model(name);
    let bytes = recorded_bytes(&recorded, &u).expect("the default budget fits T = 4 at 6×6");
    assert!(bytes <= recorded.checkpoint_budget);
    // A budget that fits two whole steps (so the plain path records whole steps, no blocks) but
    // not the rollout.
    let mut plain = recorded.clone();
    plain.checkpoint_budget = 2 * plain.iterations * plain.recorded_bytes_per_iteration() + 1024;
    assert_eq!(plain.iterations_per_block(), plain.iterations);
    assert_eq!(recorded_bytes(&plain, &u), None);
    let delta = recorded.task.delta;
    let a = recorded.evaluate(&u, delta, true).unwrap();
    let b = plain.evaluate(&u, delta, true).unwrap();
    assert_eq!(a.metrics, b.metrics, "{name}: metrics");
    for (x, y) in a.states.iter().zip(&b.states) {
        assert_eq!(bits(x), bits(y), "{name}: states");
    }
    let (gl, gc) = (a.grad_l.unwrap(), a.grad_c.unwrap());
    assert!(
        gl.data().iter().any(|v| v.abs() > 1e-6),
        "{name}: dL/dU ~ 0"
    );
    assert_eq!(bits(&gl), bits(&b.grad_l.unwrap()), "{name}: dL/dU");
    assert_eq!(bits(&gc), bits(&b.grad_c.unwrap()), "{name}: dC/dU");
    // The loss gradient alone, too.
    let a = recorded.evaluate_loss_gradient(&u, delta).unwrap();
    let b = plain.evaluate_loss_gradient(&u, delta).unwrap();
    assert_eq!(bits(&a.grad_l.unwrap()), bits(&b.grad_l.unwrap()));
}

#[test]
fn first_forward_recording_is_bitwise_the_plain_path_on_u_obstacle() {
    check("u_obstacle");
}

#[test]
fn first_forward_recording_is_bitwise_the_plain_path_with_a_collider() {
    check("drop");
}

#[test]
fn recordings_stay_within_the_budget() {
    let (mut m, u) = model("u_obstacle");
    let bytes = recorded_bytes(&m, &u).unwrap();
    // The lower bound the check starts from is below the actual bytes.
    let lower = m.task.horizon * m.iterations * m.recorded_bytes_per_iteration();
    assert!(lower <= bytes && bytes < 2 * lower, "{lower} vs {bytes}");
    // Around what the recordings take, they are either kept within the budget or all dropped.
    let mut kept = 0;
    for k in 0..=40 {
        m.checkpoint_budget = bytes - bytes / 10 + k * bytes / 200;
        match recorded_bytes(&m, &u) {
            Some(b) => {
                assert_eq!(b, bytes);
                assert!(b <= m.checkpoint_budget, "{b} > {}", m.checkpoint_budget);
                kept += 1;
            }
            None => assert!(m.checkpoint_budget < 2 * bytes),
        }
    }
    assert!(kept > 0, "never kept up to 1.1× their bytes");
    m.checkpoint_budget = bytes - 1;
    assert_eq!(recorded_bytes(&m, &u), None);
    m.checkpoint_budget = lower - 1;
    assert_eq!(recorded_bytes(&m, &u), None);
}
