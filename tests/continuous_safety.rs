//! A plan called safe never collides, checked independently of the planner's rows: from the
//! returned states alone, 32 samples per step of every particle's straight motion keep `δ − 1e−6`
//! from the safety obstacles, and no particle at a step nor gripper along its motion is inside a
//! collider. Every example and route scene and `u_obstacle` exits 0 only when this holds, and
//! otherwise says "no safe plan" and why. A thin pole that a step-only plan tunnels through is
//! passed around by the default plan; grippers go over a box table across their straight path.
//!
//! CI plans `u_obstacle`, `swing`, `towel` and `routes/target_inside` (the cheap ones); the other
//! example and route scenes take minutes each on a 2-core host, so their tests are ignored and the
//! whole sweep runs with `cargo test --release -p clothopt --test continuous_safety --
//! --include-ignored` (about 18 min on the 2-core host under load; results in
//! docs/performance.md#continuous-safety).

mod common;
use autodiff::Tensor;
use cloth::nalgebra::Vector3;
use cloth::sdf::SignedDistance;
use cloth::{Model, Scene};
use clothopt::plan::{initial_controls, plan, PlanOptions};
use clothopt::request::load_scene;
use clothopt::result::{states_of, MotionCheck, PlanResult, Reason};
use common::{bin, run, scratch, stderr};

/// Samples per step of the straight motion between two states.
const SAMPLES: usize = 32;

/// Particle `p` of state `x`.
fn at(x: &Tensor, p: usize) -> Vector3<f64> {
    Vector3::from_fn(|j, _| x.get(p, j))
}

/// What the independent check finds wrong with a plan's returned states, one sentence each:
/// a sample of a particle's motion within `δ − 1e−6` of the safety obstacles (a particle whose
/// rest state is already within `δ` counted from its step-1 state, as documented), a particle
/// inside a collider at a step, or a sample of a gripper's motion inside one (beyond the result's
/// feasibility tolerance). Also returns the smallest safety sample.
fn independent_check(model: &Model, result: &PlanResult) -> (Vec<String>, f64) {
    let states = states_of(result).unwrap();
    let delta = result.delta;
    let tol = result.feasibility_tolerance;
    let safety = &model.safety_obstacles;
    let colliders = &model.colliders;
    let mut found = Vec::new();
    let mut smallest = f64::INFINITY;
    let starts_inside: Vec<bool> = (0..model.n_particles())
        .map(|p| !safety.is_empty() && safety.distance(&at(&states[0], p)) < delta)
        .collect();
    for t in 1..states.len() {
        for (p, &inside) in starts_inside.iter().enumerate() {
            let b = at(&states[t], p);
            let a = if t == 1 && inside {
                b
            } else {
                at(&states[t - 1], p)
            };
            if !safety.is_empty() {
                let worst = (0..=SAMPLES)
                    .map(|k| safety.distance(&(a + (b - a) * (k as f64 / SAMPLES as f64))))
                    .fold(f64::INFINITY, f64::min);
                smallest = smallest.min(worst);
                if worst < delta - 1e-6 {
                    found.push(format!(
                        "particle {p} comes to {worst:.6} between steps {} and {t}",
                        t - 1
                    ));
                }
            }
            if !colliders.is_empty() {
                let d = colliders.distance(&b);
                if d < -tol {
                    found.push(format!(
                        "particle {p} is {:.6} inside a collider at step {t}",
                        -d
                    ));
                }
            }
        }
        if !colliders.is_empty() {
            for (k, &p) in model.controls.as_slice().iter().enumerate() {
                let (a, b) = (at(&states[t - 1], p), at(&states[t], p));
                let worst = (0..=SAMPLES)
                    .map(|s| colliders.distance(&(a + (b - a) * (s as f64 / SAMPLES as f64))))
                    .fold(f64::INFINITY, f64::min);
                if worst < -tol {
                    found.push(format!(
                        "gripper {k} goes {:.6} inside a collider between steps {} and {t}",
                        -worst,
                        t - 1
                    ));
                }
            }
        }
    }
    (found, smallest)
}

/// Plans `scene` (a path under the repository, or a built-in name) with `clothopt optimize`'s
/// defaults and checks the verdict against [`independent_check`]: exit 0 only when the check
/// passes; a plan it finds unsafe ends "no safe plan" (exit 4), naming why.
fn exit_zero_means_safe(scene: &str) {
    let dir = scratch("continuous", &scene.replace('/', "_"));
    let out = dir.join("result.json");
    let o = run(bin()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["optimize", scene, "--no-timing", "--out"])
        .arg(&out));
    let code = o.status.code().unwrap();
    assert!(
        matches!(code, 0 | 3 | 4),
        "{scene}: exit {code}: {}",
        stderr(&o)
    );
    let result: PlanResult = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(result.safety.check, MotionCheck::Continuous, "the default");
    let model = Model::from_scene(&load_scene_at(scene)).unwrap();
    let (found, smallest) = independent_check(&model, &result);
    println!(
        "{scene}: exit {code}, {}; smallest safety sample {smallest:.6}; {} found, the first {:?}; \
         verdict {}",
        result.task.reason.name(),
        found.len(),
        found.iter().take(3).collect::<Vec<_>>(),
        result.task.explanation
    );
    if !found.is_empty() {
        assert_eq!(code, 4, "{scene}: {found:?}, yet exit {code}");
        assert_eq!(result.task.reason, Reason::NoSafePlan);
        assert!(
            !result.safety.failures.is_empty()
                && result.task.explanation.contains(&result.safety.failures[0]),
            "{scene}: the verdict says why: {}",
            result.task.explanation
        );
    }
    if code == 0 {
        assert!(found.is_empty() && result.task.achieved);
    }
}

/// A scene by built-in name or by a path relative to the repository.
fn load_scene_at(scene: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(scene);
    if path.exists() {
        Scene::load(&path).unwrap()
    } else {
        load_scene(scene).unwrap()
    }
}

#[test]
fn u_obstacle_exits_zero_only_when_safe() {
    exit_zero_means_safe("u_obstacle");
}

#[test]
fn swing_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/swing.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn drop_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/drop.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn fold_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/fold/fold.json");
}

#[test]
fn towel_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/towel/towel.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn limits_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/limits/u_obstacle_limits.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn route_ball_25_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/ball_25.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn route_long_soft_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/long_soft.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn route_overhead_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/overhead.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn route_slalom_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/slalom.json");
}

#[test]
fn route_target_inside_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/target_inside.json");
}

#[test]
#[ignore = "slow: the all-scenes sweep, run with --include-ignored"]
fn route_wall_opening_exits_zero_only_when_safe() {
    exit_zero_means_safe("examples/scenes/routes/wall_opening.json");
}

/// A 5 × 5 cloth (0.3 m square, hanging from its top corners) carried 1.2 m along +y in 3 steps
/// of 0.4 m, past a pole of radius 0.04 standing 0.02 m beyond its right edge (δ = 0.03). The
/// steps end at y = −0.2 and 0.2, 0.16 from the pole's surface, but the edge column's straight
/// motion between them passes 0.02 from the pole's axis: inside the pole itself. Passing beside it
/// takes a shift of the cloth by at least 0.02 + 0.04 + 0.03 = 0.09 during that step.
fn pole_scene() -> Scene {
    Scene::from_json_str(
        r#"{
      "name": "pole",
      "cloth": {"rows": 5, "cols": 5, "top_left": [-0.15, -0.6, 1.0], "right": [0.3, 0, 0],
                "down": [0, 0, -0.3]},
      "material": {"stretch": 1e4, "bending": {"model": "distance", "stiffness": 100}},
      "physics": {"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 50, "solver": "xpbd"},
      "controls": [[0, 0], [0, 4]],
      "obstacles": [{"type": "capsule", "a": [0.17, 0.0, 0.0], "b": [0.17, 0.0, 2.0],
                     "radius": 0.04, "role": "safety"}],
      "task": {"horizon": 3,
        "targets": [{"particle": [4, 0], "position": [-0.15, 0.6, 0.7]},
                    {"particle": [4, 4], "position": [0.15, 0.6, 0.7]}],
        "alpha": 1.0, "beta": 1e-4, "delta": 0.03,
        "initial_controls": {"constant": [[0, 0.4, 0], [0, 0.4, 0]]}}
    }"#,
    )
    .unwrap()
}

#[test]
fn a_thin_pole_a_step_only_plan_tunnels_through_is_passed_around() {
    let scene = pole_scene();
    let model = Model::from_scene(&scene).unwrap();
    let start = initial_controls(&scene, &model).unwrap();
    let mut step_only = PlanOptions::for_model(&model);
    step_only.task.swept = false;
    let tunnels = plan(&model, &scene, &start, &step_only, |_| {}).unwrap();
    let (found, smallest) = independent_check(&model, &tunnels);
    // Safe at the steps, "achieved" by the step-only check, through the pole between them.
    assert!(tunnels.task.achieved, "{}", tunnels.task.explanation);
    assert!(tunnels.metrics.min_sdf >= 0.03 - 1e-6);
    assert!(
        smallest < 0.0,
        "the motion passes inside the pole: {smallest}"
    );
    assert!(!found.is_empty());

    let options = PlanOptions::for_model(&model);
    let search = clothopt::search::SearchOptions::default();
    let around =
        clothopt::search::plan_with_search(&model, &scene, &start, &options, &search, |_| {})
            .unwrap();
    let (found, smallest) = independent_check(&model, &around);
    assert!(around.task.achieved, "{}", around.task.explanation);
    assert!(found.is_empty(), "{found:?}");
    assert!(smallest >= 0.03 - 1e-6, "{smallest}");
    // Beside the pole, not over it: every particle crosses the pole's plane y = 0 left of
    // x = 0.17 − 0.04 − 0.03 = 0.10 (the step-only plan's edge column crosses within the pole's
    // radius of its axis), below the pole's top (z = 2).
    let crossings = |r: &PlanResult| -> Vec<[f64; 2]> {
        let states = states_of(r).unwrap();
        let mut out = Vec::new();
        for t in 1..states.len() {
            for p in 0..model.n_particles() {
                let (a, b) = (at(&states[t - 1], p), at(&states[t], p));
                if a.y < 0.0 && b.y >= 0.0 {
                    let q = a + (b - a) * (-a.y / (b.y - a.y));
                    out.push([q.x, q.z]);
                }
            }
        }
        out
    };
    let through = crossings(&tunnels);
    assert!(
        through.iter().any(|c| (c[0] - 0.17).abs() < 0.04),
        "{through:?}"
    );
    let beside = crossings(&around);
    assert_eq!(
        beside.len(),
        model.n_particles(),
        "every particle crosses once"
    );
    assert!(
        beside.iter().all(|c| c[0] <= 0.10 + 1e-6 && c[1] < 2.0),
        "{beside:?}"
    );
}

/// A 4 × 4 cloth (0.3 m) hanging from grippers at z = 0.5, carried 1.4 m along +y in 6 steps across
/// a box table (collider) 1.2 × 0.5 m whose top is at z = 0.6: the grippers' straight path runs
/// through the table, 0.1 below its top.
fn table_scene() -> Scene {
    Scene::from_json_str(
        r#"{
      "name": "table",
      "cloth": {"rows": 4, "cols": 4, "top_left": [-0.15, -0.7, 0.5], "right": [0.3, 0, 0],
                "down": [0, 0, -0.3]},
      "material": {"stretch": 1e4, "bending": {"model": "distance", "stiffness": 100}},
      "physics": {"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 50, "solver": "xpbd"},
      "controls": [[0, 0], [0, 3]],
      "obstacles": [{"type": "box", "center": [0.0, 0.0, 0.2], "half_extents": [0.6, 0.25, 0.4],
                     "role": "collider"}],
      "task": {"horizon": 6,
        "targets": [{"particle": [3, 0], "position": [-0.15, 0.7, 0.2]},
                    {"particle": [3, 3], "position": [0.15, 0.7, 0.2]}],
        "alpha": 1.0, "beta": 1e-4,
        "initial_controls": {"constant": [[0, 0.23333333333333334, 0], [0, 0.23333333333333334, 0]]}}
    }"#,
    )
    .unwrap()
}

#[test]
fn grippers_go_over_a_box_table_across_their_straight_path() {
    let scene = table_scene();
    let model = Model::from_scene(&scene).unwrap();
    let start = initial_controls(&scene, &model).unwrap();
    // The straight path: both grippers 0.1 inside the table at step 3 (y = 0).
    let table = &model.colliders;
    let straight = model.simulate(&start).unwrap();
    let p = model.controls.as_slice()[0];
    assert!(table.distance(&at(&straight[3], p)) < -0.09);

    let result = plan(
        &model,
        &scene,
        &start,
        &PlanOptions::for_model(&model),
        |_| {},
    )
    .unwrap();
    let (found, _) = independent_check(&model, &result);
    assert!(found.is_empty(), "{found:?}");
    assert!(result.task.achieved, "{}", result.task.explanation);
    assert!(result.safety.failures.is_empty());
    // Over it: every gripper rises above the table's top (z = 0.6) while it crosses the table's
    // extent in y, and never enters it (32 samples per step).
    let states = states_of(&result).unwrap();
    for &p in model.controls.as_slice() {
        for t in 1..states.len() {
            let (a, b) = (at(&states[t - 1], p), at(&states[t], p));
            for k in 0..=SAMPLES {
                let q = a + (b - a) * (k as f64 / SAMPLES as f64);
                assert!(table.distance(&q) >= -result.feasibility_tolerance, "{q:?}");
                if q.y.abs() <= 0.25 && q.x.abs() <= 0.6 {
                    assert!(q.z >= 0.6 - result.feasibility_tolerance, "{q:?}");
                }
            }
        }
    }
}
