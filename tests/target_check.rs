//! Targets the cloth cannot reach (`clothopt::target_check`): a target inside a collider is a
//! warning at load naming the target and the obstacle, and a plan that misses it says so; targets
//! the cloth, put there with its grippers held, does not rest in are the verdict of a plan that
//! misses them.

mod common;

use cloth::{Model, Scene};
use clothopt::plan::{initial_controls, plan, PlanOptions};
use clothopt::result::Reason;
use clothopt::target_check::{
    buried_target_warnings, buried_targets, targets_rest, unreachable_targets, REST_STEPS,
};
use common::{bin, run, stderr};

/// A 0.3 m, 4 × 4 cloth hanging 0.2 m above a box table (top at z = 0.75), held by its top
/// corners; its bottom corners' targets on the table top at `depth` below the surface.
fn scene(depth: f64) -> String {
    let z = 0.75 - depth;
    format!(
        r#"{{"name": "buried", "cloth": {{"rows": 4, "cols": 4, "top_left": [-0.15, 0, 1.25],
            "right": [0.3, 0, 0], "down": [0, 0, -0.3], "particle_mass": 0.001}},
          "material": {{"stretch": 1000}}, "physics": {{"dt": 0.1, "gravity": [0, 0, -9.8]}},
          "controls": [[0, 0], [0, 3]],
          "obstacles": [{{"type": "box", "center": [0, 0, 0.375], "half_extents": [0.5, 0.5, 0.375],
                          "role": "collider"}}],
          "task": {{"horizon": 4, "tolerance": 0.03,
            "targets": [{{"particle": [3, 0], "position": [-0.15, 0.1, {z}]}},
                        {{"particle": [3, 3], "position": [0.15, 0.1, {z}]}}],
            "alpha": 0.1, "beta": 0, "initial_controls": "zeros"}}}}"#
    )
}

/// The plan of `scene` from its guess with at most `iterations` SQP iterations, no search.
fn planned(scene: &Scene, iterations: usize) -> clothopt::result::PlanResult {
    let model = Model::from_scene(scene).unwrap();
    let start = initial_controls(scene, &model).unwrap();
    let mut options = PlanOptions::for_model(&model);
    options.iterations = iterations;
    plan(&model, scene, &start, &options, |_| {}).unwrap()
}

#[test]
fn a_target_inside_the_table_is_named_at_load() {
    let deep = Scene::from_json_str(&scene(0.05)).unwrap();
    let buried = buried_targets(&deep);
    assert_eq!(buried.len(), 2);
    assert!((buried[0].depth - 0.05).abs() < 1e-12 && buried[0].obstacle == 0);
    let warnings = buried_target_warnings(&deep);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let w = &warnings[0];
    assert!(
        w.starts_with("2 targets lie up to 0.0500 (the deepest task.targets[0] (particle (3, 0)))")
            && w.contains("inside obstacles[0] (box), a collider")
            && w.contains("cannot be achieved"),
        "{w}"
    );
    let unreachable = unreachable_targets(&Model::from_scene(&deep).unwrap());
    assert_eq!(unreachable.iter().map(|u| u.0).collect::<Vec<_>>(), [0, 1]);
    assert!(unreachable.iter().all(|u| (u.1 - 0.05).abs() < 1e-12));
    // 1 cm in, within the tolerance 0.03: a particle on the surface meets it.
    let shallow = Scene::from_json_str(&scene(0.01)).unwrap();
    let w = buried_target_warnings(&shallow);
    assert!(w[0].contains("within the tolerance"), "{w:?}");
    assert!(unreachable_targets(&Model::from_scene(&shallow).unwrap()).is_empty());
    // On the surface or above: nothing to say.
    assert!(buried_target_warnings(&Scene::from_json_str(&scene(0.0)).unwrap()).is_empty());
    // The command line says it when it loads the scene.
    let dir = std::env::temp_dir().join(format!("clothopt-buried-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("buried.json");
    std::fs::write(&file, scene(0.05)).unwrap();
    let o = run(bin().arg("simulate").arg(&file));
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("warning: 2 targets lie up to 0.0500"),
        "{}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_plan_that_misses_a_buried_target_says_so() {
    let result = planned(&Scene::from_json_str(&scene(0.05)).unwrap(), 30);
    assert!(!result.task.achieved);
    assert_eq!(result.task.reason, Reason::UnreachableTarget);
    assert!(
        result
            .task
            .explanation
            .starts_with("2 missed targets lie inside the colliders deeper than the tolerance"),
        "{}",
        result.task.explanation
    );
    assert!(result
        .warnings
        .iter()
        .any(|w| w.contains("obstacles[0] (box)")));
}

/// A 5 × 5, 0.3 m towel on a table (a box, top at z = 0.75) under Newton with smooth contact,
/// held at `grippers`, a target for every particle at `target(r, c, rest)` (`rest`: its place
/// lying flat), self-collision 5 mm thick when `fold`.
fn towel(grippers: &str, target: impl Fn(usize, usize, [f64; 3]) -> [f64; 3], fold: bool) -> Scene {
    let mut targets = Vec::new();
    for r in 0..5 {
        for c in 0..5 {
            let rest = [-0.15 + 0.075 * c as f64, -0.15 + 0.075 * r as f64, 0.75];
            let [x, y, z] = target(r, c, rest);
            targets.push(format!(
                r#"{{"particle": [{r}, {c}], "position": [{x}, {y}, {z}]}}"#
            ));
        }
    }
    let self_collision = if fold {
        r#", "self_collision": {"thickness": 0.005}"#
    } else {
        ""
    };
    Scene::from_json_str(&format!(
        r#"{{"name": "towel", "cloth": {{"rows": 5, "cols": 5, "top_left": [-0.15, -0.15, 0.75],
            "right": [0.3, 0, 0], "down": [0, 0.3, 0], "particle_mass": 0.002}},
          "material": {{"stretch": 1000, "bending": {{"model": "isometric", "stiffness": 1e-4}}}},
          "physics": {{"dt": 0.1, "gravity": [0, 0, -9.81]{self_collision}}},
          "controls": {grippers},
          "obstacles": [{{"type": "box", "center": [0, 0, 0.375], "half_extents": [0.5, 0.5, 0.375],
                          "role": "collider"}}],
          "task": {{"horizon": 4, "tolerance": 0.02, "targets": [{}],
            "alpha": 0.1, "beta": 0, "initial_controls": "zeros"}}}}"#,
        targets.join(", ")
    ))
    .unwrap()
}

#[test]
fn targets_lying_on_the_table_rest_and_targets_in_the_air_do_not() {
    let flat = towel("[[0, 0], [0, 4]]", |_, _, rest| rest, false);
    let model = Model::from_scene(&flat).unwrap();
    let d_hat = model.contact_barrier.as_ref().unwrap().barrier.d_hat;
    let rest = targets_rest(&model).expect("simulated");
    // On the table they move by about the barrier's resting height (under d̂) and sag a little.
    assert!(rest.largest_error < d_hat, "{rest:?}, d̂ {d_hat}");
    assert_eq!((rest.reached, rest.targets, rest.spread), (25, 25, 1.0));
    // The same towel flat 0.2 m above the table, held at one corner, swings down.
    let air = towel("[[0, 0]]", |_, _, [x, y, z]| [x, y, z + 0.2], false);
    let rest = targets_rest(&Model::from_scene(&air).unwrap()).expect("simulated");
    assert!(rest.largest_error > 0.1, "{rest:?}");
    assert!(rest.reached < 25, "{rest:?}");
    // Not every particle with a target: nothing to say.
    let mut partial = flat.clone();
    partial.task.targets.truncate(24);
    assert_eq!(targets_rest(&Model::from_scene(&partial).unwrap()), None);
}

#[test]
fn layers_at_the_thickness_start_spread_apart() {
    // Folded in half along row 2: rows 3 and 4 onto rows 1 and 0, 5 mm up (the thickness).
    let folded = towel(
        "[[4, 0], [4, 4]]",
        |r, _, [x, y, z]| match r {
            0..=2 => [x, y, z],
            _ => [x, y - 0.075 * 2.0 * (r as f64 - 2.0), z + 0.005],
        },
        true,
    );
    let rest = targets_rest(&Model::from_scene(&folded).unwrap()).expect("simulated");
    assert!(
        rest.spread > 1.0,
        "layers at the thickness cannot start as given: {rest:?}"
    );
    assert_eq!(rest.targets, 25);
}

#[test]
fn a_plan_for_targets_that_cannot_rest_says_so() {
    let air = towel("[[0, 0]]", |_, _, [x, y, z]| [x, y, z + 0.2], false);
    let result = planned(&air, 5);
    assert!(!result.task.achieved);
    assert_eq!(
        result.task.reason,
        Reason::TargetsCannotRest,
        "{}",
        result.task.explanation
    );
    let e = &result.task.explanation;
    assert!(
        e.starts_with("the targets are no state the cloth rests in with its grippers held there")
            && e.contains(&format!("in {REST_STEPS} steps"))
            && !e.contains("rise"),
        "the towel sinks, it does not rise: {e}"
    );
}

/// The suite's diagonal fold: its crease's bending lifts the folded half off the lower one, by
/// nearly all of the settled error (a lift, not a slide; docs/experiments.md, "Whether a task's
/// targets can rest").
#[test]
fn the_diagonal_folds_targets_lift_as_they_settle() {
    let scene = Scene::load("examples/scenes/tasks/fold_diagonal.json").unwrap();
    let rest = targets_rest(&Model::from_scene(&scene).unwrap()).expect("simulated");
    assert!(rest.largest_error > 0.05, "{rest:?}");
    assert!(rest.largest_rise > 0.8 * rest.largest_error, "{rest:?}");
}
