//! The fold under XPBD from its hand-made arc (`examples/scenes/fold/fold_xpbd.json`) through the
//! planner, cheaply: a κ warm-up stopped by the progress test after its first iteration (a window of one iteration, any decrease below 100%) with no safety row
//! active is the plan — the sharp stage is not run — and that plan reaches every target but is not
//! called safe (the cloth sinks 0.3 mm into the table, more than the feasibility tolerance, and its
//! layers pass through each other), and its
//! rollout, simulated again, gives the same errors. (The full `optimize fold` run and its numbers
//! are in docs/performance.md, "The towel and the fold".) Also: when the planner skips the sharp
//! stage, and that the progress options are checked.

use cloth::{Model, Scene};
use clothopt::outcome::target_errors;
use clothopt::plan::{initial_controls, plan, sharp_stage_needed, PlanOptions};
use clothopt::problem::{TaskOptions, TrajectoryProblem};
use clothopt::result::controls_from_nested;
use optim::{Solution, Status};

#[test]
fn a_warm_up_without_progress_and_far_from_the_mug_is_the_fold_plan() {
    let scene = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/fold/fold_xpbd.json"
    ))
    .unwrap();
    assert!(scene.physics.self_collision.is_some());
    let model = Model::from_scene(&scene).unwrap();
    let start = initial_controls(&scene, &model).unwrap();
    let mut options = PlanOptions::for_model(&model);
    options.progress_window = Some(1);
    options.tol_progress = 1.0;
    let result = plan(&model, &scene, &start, &options, |_| {}).unwrap();
    assert_eq!(result.status, "no_progress", "{}", result.message);
    assert!(
        result
            .message
            .starts_with("no progress: the objective fell by")
            && result.message.contains("the κ = 3000 stage was not run"),
        "{}",
        result.message
    );
    assert_eq!(result.iterations, 1);
    assert_eq!(result.stages.len(), 1, "the sharp stage did not run");
    assert_eq!(result.stages[0].kappa, Some(200.0));
    assert_eq!(result.stages[0].status, "no_progress");
    // Every target is reached, but the plan is not called safe: XPBD (150 sweeps) leaves the cloth
    // 0.3 mm inside the table at step 14, beyond the feasibility tolerance (1e-8) that the deepest
    // penetration is held to, and its self-collision lets the folded layers pass through each
    // other (from step 8) and lie 0.1 mm apart (thickness 1 cm): the failures the verdict names.
    assert!(!result.task.achieved);
    assert_eq!(result.task.reason, clothopt::result::Reason::NoSafePlan);
    let deepest = result.metrics.max_penetration.unwrap();
    assert!(
        deepest.depth > options.tol_feasibility && deepest.depth < 1e-3,
        "{deepest:?}"
    );
    assert!(
        !result.safety.failures.is_empty()
            && result
                .safety
                .failures
                .iter()
                .all(|f| f.contains("inside the colliders")
                    || f.contains("passes through itself")
                    || f.contains("half the thickness")),
        "{:?}",
        result.safety.failures
    );
    let layers = result
        .safety
        .layers
        .expect("a layer report under self-collision");
    assert!(layers.crossings > 0, "{layers:?}");
    // Those failures are XPBD's unresolved contacts, which no control fixes: the plan says that
    // Newton physics (which supports this scene) keeps the cloth apart.
    let hints: Vec<&String> = (result.warnings.iter())
        .filter(|w| w.contains("--physics newton"))
        .collect();
    assert_eq!(hints.len(), 1, "{:?}", result.warnings);
    assert!(
        hints[0].contains("the cloth's layers and the colliders"),
        "{}",
        hints[0]
    );
    // The same failures under Newton, or contacts resolved within the tolerances: no hint.
    let hint = |m: &Model, tol: f64, layers| {
        let mut report = result.safety.clone();
        report.layers = layers;
        clothopt::safety_check::physics_hint(m, &report, &result.metrics, tol)
    };
    let mut newton = scene.clone();
    newton.physics.solver = Some(cloth::scene::SolverKind::Newton);
    let newton = Model::from_scene(&newton).unwrap();
    assert!(hint(&newton, options.tol_feasibility, result.safety.layers).is_none());
    assert!(hint(&model, 1.0, None).is_none());
    let colliders_only = hint(&model, options.tol_feasibility, None).unwrap();
    assert!(
        colliders_only.contains("against the colliders;"),
        "{colliders_only}"
    );
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
    assert!(result.constraint_violation <= options.tol_feasibility);
    let controls = controls_from_nested(&model, &result.controls).unwrap();
    let states = model.simulate(&controls).unwrap();
    let again = target_errors(&model, states.last().unwrap());
    assert_eq!(again, result.task.target_errors);
}

/// A solution at `x` that ended with `status` (no multipliers: a row is active when its value is).
fn ended(x: Vec<f64>, status: Status) -> Solution {
    Solution {
        status,
        message: String::new(),
        x,
        objective: f64::NAN,
        constraint_violation: 0.0,
        kkt_residual: f64::NAN,
        iterations: 1,
        function_evaluations: 1,
        gradient_evaluations: 1,
        multipliers: Default::default(),
        solve_time: 0.0,
        hessian: None,
    }
}

#[test]
fn the_sharp_stage_is_skipped_only_after_no_progress_with_every_safety_row_inactive() {
    for (name, rows_active) in [("fold", false), ("u_obstacle", true)] {
        let scene = match name {
            "fold" => Scene::load(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/examples/scenes/fold/fold_xpbd.json"
            ))
            .unwrap(),
            _ => Scene::builtin(name).unwrap(),
        };
        let model = Model::from_scene(&scene).unwrap();
        let x = initial_controls(&scene, &model).unwrap().data().to_vec();
        let mut task = TaskOptions::for_model(&model);
        task.kappa = 200.0;
        let mut warm = TrajectoryProblem::new(&model, task);
        let no_progress = ended(x.clone(), Status::NoProgress);
        assert_eq!(
            sharp_stage_needed(&mut warm, &no_progress).unwrap(),
            rows_active,
            "{name}"
        );
        for other in [Status::Converged, Status::Stalled, Status::IterationLimit] {
            let solution = ended(x.clone(), other);
            assert!(sharp_stage_needed(&mut warm, &solution).unwrap(), "{name}");
        }
    }
}

#[test]
fn bad_progress_options_are_named() {
    let scene = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/fold/fold_xpbd.json"
    ))
    .unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let start = initial_controls(&scene, &model).unwrap();
    let mut cases = Vec::new();
    for (window, tol) in [(Some(0), 1e-6), (Some(10), -1.0), (None, f64::NAN)] {
        let mut options = PlanOptions::for_model(&model);
        options.progress_window = window;
        options.tol_progress = tol;
        cases.push(options);
    }
    let names = ["progress_window", "tol_progress", "tol_progress"];
    for (options, name) in cases.iter().zip(names) {
        let err = plan(&model, &scene, &start, options, |_| {})
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(name), "{err}");
    }
}
