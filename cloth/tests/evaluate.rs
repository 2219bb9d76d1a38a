//! `Model::evaluate_loss_gradient` (one backward pass) gives `Model::evaluate`'s metrics and
//! `dL/dU` bit for bit, and no `dC/dU`.

use cloth::{Model, Scene};

mod common;

#[test]
fn loss_gradient_alone_is_evaluates_bit_for_bit() {
    let mut scene = Scene::builtin("u_obstacle").unwrap().refined(5, 5).unwrap();
    scene.task.horizon = 4;
    scene.physics.iterations = 15;
    let model = Model::from_scene(&scene).unwrap();
    let u = scene.initial_controls();
    let both = model.evaluate(&u, 0.2, true).unwrap();
    let alone = model.evaluate_loss_gradient(&u, 0.2).unwrap();
    assert_eq!(both.metrics, alone.metrics);
    assert_eq!(both.grad_l, alone.grad_l);
    assert!(alone.grad_c.is_none());
    let g = alone.grad_l.unwrap();
    assert!(g.data().iter().any(|v| v.abs() > 1e-3), "{:?}", g.data());
}
