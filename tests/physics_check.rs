//! Plans checked under other physics (`optimize --check`): the check re-simulates the plan with
//! the other step solver and judges it at the user's margin; a plan that fails is re-planned from
//! itself with the margin raised by 1.25× the measured shortfall.
//!
//! Measured on `u_obstacle` refined to 6 × 6, planned on XPBD-100 (the continuous check, the
//! default) and checked under Newton at 1e-12: the first plan (δ = 0.2) keeps 0.2 under XPBD but
//! comes to 0.1805 under Newton (the two physics' states differ); the re-plan at δ′ = 0.2244 keeps
//! 0.2137 under Newton. (Step-only, before the continuous check: 0.1708, 0.2366 and 0.2190.)

use cloth::scene::{ContactModel, ContactSpec};
use cloth::{Model, Scene};
use clothopt::outcome::exit_code;
use clothopt::physics_check::{check_plan, plan_with_check, CheckRequest, MARGIN_GROWTH};
use clothopt::plan::{self, PlanOptions};
use clothopt::result::{controls_from_nested, CheckPhysics, PlanResult, Reason};
use clothopt::Error;

#[test]
fn check_physics_parses_and_names_the_setting() {
    assert_eq!(
        "xpbd:3000".parse::<CheckPhysics>().unwrap(),
        CheckPhysics::Xpbd { iterations: 3000 }
    );
    assert_eq!(
        "newton".parse::<CheckPhysics>().unwrap(),
        CheckPhysics::Newton { tolerance: 1e-12 }
    );
    assert_eq!(
        "newton:1e-8".parse::<CheckPhysics>().unwrap(),
        CheckPhysics::Newton { tolerance: 1e-8 }
    );
    assert_eq!(
        "newton-branch".parse::<CheckPhysics>().unwrap(),
        CheckPhysics::NewtonBranch { halvings: 10 }
    );
    assert_eq!(
        "newton-branch:4".parse::<CheckPhysics>().unwrap(),
        CheckPhysics::NewtonBranch { halvings: 4 }
    );
    for bad in [
        "xpbd",
        "xpbd:0",
        "xpbd:-3",
        "newton:2",
        "newton:nan",
        "newton-branch:0",
        "newton-branch:21",
        "newton-branch:x",
        "pbd:10",
        "",
    ] {
        let e = bad.parse::<CheckPhysics>().unwrap_err();
        assert!(
            matches!(&e, Error::InvalidSetting { name, .. } if name == "check"),
            "{bad}: {e}"
        );
        assert!(e.to_string().contains(&format!("`{bad}`")), "{e}");
    }
}

/// `u_obstacle` at 6 × 6 on the scene's XPBD physics.
fn small_scene() -> (Scene, Model) {
    let scene = Scene::builtin("u_obstacle").unwrap().refined(6, 6).unwrap();
    let model = Model::from_scene(&scene).unwrap();
    (scene, model)
}

/// Plans `model`'s task at margin `delta` from `start`, without the route search.
fn replan<'a>(
    scene: &'a Scene,
    model: &'a Model,
) -> impl FnMut(f64, &cloth::Controls) -> clothopt::Result<PlanResult> + 'a {
    move |delta, start| {
        let mut options = PlanOptions::for_model(model);
        options.task.delta = delta;
        plan::plan(model, scene, start, &options, |_| {})
    }
}

/// Newton at 1e-12, the check of these tests.
const NEWTON: CheckPhysics = CheckPhysics::Newton { tolerance: 1e-12 };

/// [`small_scene`] planned on XPBD and checked under [`NEWTON`] with up to `rounds` re-plans.
fn checked_under_newton(rounds: usize) -> (Scene, Model, PlanResult) {
    let (scene, model) = small_scene();
    let start = plan::initial_controls(&scene, &model).unwrap();
    let delta = scene.task.delta;
    let check = CheckRequest {
        physics: NEWTON,
        rounds,
    };
    let result = plan_with_check(
        &model,
        &scene,
        Some(check),
        delta,
        &start,
        replan(&scene, &model),
    )
    .unwrap();
    (scene, model, result)
}

#[test]
fn a_plan_failing_its_check_is_replanned_with_a_larger_margin_until_it_passes() {
    let (scene, model, result) = checked_under_newton(3);
    let (delta, newton) = (scene.task.delta, NEWTON);
    let check = result.check.clone().expect("a check");
    let rounds = &check.rounds;
    // The premise: the plan at δ is safe under XPBD but not under Newton.
    assert!(!rounds[0].safe, "{rounds:?}");
    // The measured rounds of the module docs.
    assert_eq!(rounds.len(), 2, "{rounds:?}");
    let near = |a: f64, b: f64| (a - b).abs() < 1e-3;
    assert!(near(rounds[0].min_sdf, 0.1805), "{rounds:?}");
    assert!(near(rounds[1].planned_delta, 0.2244), "{rounds:?}");
    assert!(near(rounds[1].min_sdf, 0.2137), "{rounds:?}");
    assert!(rounds[0].min_sdf < delta - 1e-4, "{rounds:?}");
    assert_eq!(rounds[0].planned_delta, delta);
    for pair in rounds.windows(2) {
        let grown = pair[0].planned_delta + MARGIN_GROWTH * (delta - pair[0].min_sdf);
        assert!((pair[1].planned_delta - grown).abs() < 1e-12, "{rounds:?}");
    }
    let last = check.last();
    assert!(last.safe, "{rounds:?}");
    assert!(last.min_sdf >= delta - 1e-6, "{rounds:?}");
    assert_eq!(result.delta, last.planned_delta);
    assert!(result.is_safe(), "{:?}", result.metrics);
    // The check's numbers are a re-simulation of the returned plan under Newton.
    let controls = controls_from_nested(&model, &result.controls).unwrap();
    let again = check_plan(&scene, newton, &controls, delta, result.delta).unwrap();
    assert_eq!(&again, last);
    let mut newton_scene = scene.clone();
    newton_scene.physics.solver = Some(cloth::scene::SolverKind::Newton);
    newton_scene.physics.tolerance = Some(1e-12);
    let truth = Model::from_scene(&newton_scene)
        .unwrap()
        .evaluate(&controls, delta, false)
        .unwrap();
    assert_eq!(truth.metrics.min_sdf, last.min_sdf);
    // A passed check leaves the planner's verdict alone.
    assert_ne!(result.task.reason, Reason::NoSafePlan, "{:?}", result.task);
}

#[test]
fn a_plan_still_failing_its_check_is_no_safe_plan_and_says_under_which_physics() {
    let (_, _, result) = checked_under_newton(0);
    let check = result.check.as_ref().unwrap();
    assert_eq!(check.rounds.len(), 1);
    assert!(!check.last().safe);
    assert!(result.is_safe(), "safe under its own physics");
    assert!(!result.task.achieved);
    assert_eq!(result.task.reason, Reason::NoSafePlan);
    assert_eq!(exit_code(&result.task), 4);
    assert!(
        result
            .task
            .explanation
            .contains("under Newton at tolerance 1e-12"),
        "{}",
        result.task.explanation
    );
    assert!(result.summary(false).contains("NOT safe"));
    // The check is part of the result file.
    let json = serde_json::to_value(&result).unwrap();
    assert_eq!(json["check"]["physics"]["solver"], "newton");
    assert_eq!(json["check"]["rounds"].as_array().unwrap().len(), 1);
}

/// Branch following on `u_obstacle`'s cloth carried in free space by its initial guess (one
/// equilibrium a step): the same final state as one Newton solve a step, to the solver's
/// tolerance, and the setting named in the summary.
#[test]
fn branch_following_checks_a_plan_on_the_scenes_other_settings() {
    let (scene, model) = small_scene();
    let branch = CheckPhysics::NewtonBranch { halvings: 6 };
    let checked = branch.apply(&scene);
    assert_eq!(checked.physics.load_halvings, Some(6));
    assert_eq!(checked.physics.tolerance, scene.physics.tolerance);
    let controls = plan::initial_controls(&scene, &model).unwrap();
    let mut one_solve = scene.clone();
    one_solve.physics.load_halvings = Some(0);
    let own = check_plan(&one_solve, NEWTON, &controls, 0.0, 0.0).unwrap();
    let round = check_plan(&scene, branch, &controls, 0.0, 0.0).unwrap();
    assert!(own.max_target_error > 0.01, "{own:?}");
    assert!(
        (own.max_target_error - round.max_target_error).abs() < 1e-6,
        "{own:?} against {round:?}"
    );
    assert_eq!(
        branch.to_string(),
        "Newton with branch following (6 load halvings)"
    );
}

#[test]
fn a_physics_that_cannot_model_the_scene_is_a_named_error() {
    // The fold with the rigid contact model named has friction on rigid contact, which Newton
    // does not model (under its default, the smooth model, it does).
    let mut scene = Scene::builtin("fold").unwrap();
    scene.physics.contact = Some(ContactSpec {
        model: ContactModel::Rigid,
        d_hat: None,
        stiffness: None,
        friction_epsilon: None,
    });
    let model = Model::from_scene(&scene).unwrap();
    let controls = plan::initial_controls(&scene, &model).unwrap();
    let newton = CheckPhysics::Newton { tolerance: 1e-10 };
    let e = check_plan(
        &scene,
        newton,
        &controls,
        scene.task.delta,
        scene.task.delta,
    )
    .unwrap_err();
    assert!(matches!(e, Error::Check { .. }), "{e}");
    assert!(
        e.to_string()
            .starts_with("the check under Newton at tolerance 1e-10: "),
        "{e}"
    );
}

#[test]
fn a_check_without_safety_obstacles_reads_back_from_its_json() {
    let scene = Scene::load("examples/scenes/towel/towel.json").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let start = plan::initial_controls(&scene, &model).unwrap();
    let xpbd = CheckPhysics::Xpbd { iterations: 20 };
    let check = Some(CheckRequest {
        physics: xpbd,
        rounds: 1,
    });
    let mut result = plan_with_check(&model, &scene, check, 0.0, &start, |delta, u| {
        let mut options = PlanOptions::for_model(&model);
        options.task.delta = delta;
        options.iterations = 3;
        plan::plan(&model, &scene, u, &options, |_| {})
    })
    .unwrap();
    result.drop_timing();
    let check = result.check.as_ref().unwrap();
    assert_eq!(check.last().min_sdf, f64::INFINITY);
    assert!(check.last().safe);
    assert!(
        check.summary().contains("no safety obstacle"),
        "{}",
        check.summary()
    );
    let json = serde_json::to_string(&result).unwrap();
    let back: PlanResult = serde_json::from_str(&json).unwrap();
    assert_eq!(back.check, result.check);
}
