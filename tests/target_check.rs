//! Targets the cloth cannot reach (`clothopt::target_check`): a target inside a collider is a
//! warning at load naming the target and the obstacle, and a plan that misses it says so.

mod common;

use cloth::{Model, Scene};
use clothopt::plan::{initial_controls, plan, PlanOptions};
use clothopt::result::Reason;
use clothopt::target_check::{buried_target_warnings, buried_targets, unreachable_targets};
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
    let s = Scene::from_json_str(&scene(0.05)).unwrap();
    let model = Model::from_scene(&s).unwrap();
    let start = initial_controls(&s, &model).unwrap();
    let mut options = PlanOptions::for_model(&model);
    options.iterations = 30;
    let result = plan(&model, &s, &start, &options, |_| {}).unwrap();
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
