//! The `fold` built-in through the planner: one SQP iteration from the scene's initial guess
//! (self-collision and friction on) returns a plan whose verdict is achieved and safe, and whose
//! rollout, simulated again, gives the same errors. (The full `optimize fold` run and its
//! numbers are in the README; this is the cheap check that the planner keeps the fold.)

use cloth::{Model, Scene};
use clothopt::outcome::target_errors;
use clothopt::plan::{controls_from_nested, initial_controls, plan, PlanOptions};

#[test]
fn one_iteration_from_the_fold_scenes_guess_keeps_the_fold_achieved_and_safe() {
    let scene = Scene::builtin("fold").unwrap();
    assert!(scene.physics.self_collision.is_some());
    let model = Model::from_scene(&scene).unwrap();
    let start = initial_controls(&scene, &model).unwrap();
    let mut options = PlanOptions::for_model(&model);
    options.iterations = 1;
    options.kappa_warmup = None;
    let result = plan(&model, &scene, &start, &options, |_| {}).unwrap();
    assert!(result.task.achieved, "{}", result.task.explanation);
    assert!(
        result.task.max_target_error <= model.task.tolerance,
        "{}",
        result.task.max_target_error
    );
    assert!(
        result.metrics.min_sdf >= scene.task.delta,
        "min SDF {} below δ {}",
        result.metrics.min_sdf,
        scene.task.delta
    );
    let controls = controls_from_nested(&model, &result.controls).unwrap();
    let states = model.simulate(&controls).unwrap();
    let again = target_errors(&model, states.last().unwrap());
    assert_eq!(again, result.task.target_errors);
}
