//! The continuous check's rows against central differences (proptests over random points):
//! the per-step and scalar safety rows over the straight motion between steps (paths that dip
//! between the steps, so the path minima carry the rows), and the gripper rows against every
//! collider kind but planes (paths through and past a sphere, a capsule and a box, and past a
//! mesh: a path into a mesh is a violated row whose minimum sits on a crease of the mesh's
//! field, differentiated at the deepest point its search found, so it is left out).
//! Also: a feasible continuous row is truly feasible (its value is never above the exact
//! smallest path distance less δ).

mod common;
use cloth::nalgebra::Vector3;
use cloth::scene::{MeshSpec, Obstacle};
use cloth::sdf::{Cuboid, MeshSdf, SignedDistance};
use cloth::{Model, Scene};
use clothopt::plan::initial_controls;
use clothopt::problem::{RowLabel, SafetyForm, TaskOptions, TrajectoryProblem};
use common::{noise, row_derivatives};
use optim::Problem;
use proptest::prelude::*;

/// `u_obstacle` with its steps doubled in length and halved in number (T = 5): the straight
/// motion between the steps sweeps past the U's spheres where the steps do not.
fn long_steps() -> Scene {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    scene.task.horizon = 5;
    if let cloth::scene::InitialControls::Constant(c) = &mut scene.task.initial_controls {
        for v in c.iter_mut() {
            for x in v.iter_mut() {
                *x *= 2.0;
            }
        }
    }
    scene.validate().unwrap();
    scene
}

/// A cloth whose two grippers move 1.2 m along +y at z = 0.5 through four colliders: a sphere, a
/// capsule, a box and a box-shaped mesh across their straight path.
fn gripper_scene() -> Scene {
    let text = r#"{
      "name": "grippers",
      "cloth": {"rows": 3, "cols": 3, "top_left": [-0.3, -0.6, 0.5], "right": [0.6, 0, 0],
                "down": [0, 0, -0.2]},
      "material": {"stretch": 1e3},
      "physics": {"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 10, "solver": "xpbd"},
      "controls": [[0, 0], [0, 2]],
      "obstacles": [
        {"type": "spheres", "centers": [[-0.3, -0.2, 0.45]], "radii": [0.1], "role": "collider"},
        {"type": "capsule", "a": [0.3, 0.0, 0.3], "b": [0.3, 0.0, 0.7], "radius": 0.05,
         "role": "both"},
        {"type": "box", "center": [-0.3, 0.25, 0.5], "half_extents": [0.1, 0.05, 0.1],
         "rotation": [0.95, 0.1, 0.2, 0.2], "role": "collider"}
      ],
      "task": {"horizon": 4, "targets": [{"particle": [2, 1], "position": [0.0, 0.6, 0.3]}],
               "alpha": 1.0, "beta": 0.0, "delta": 0.02,
               "initial_controls": {"constant": [[0.0, 0.3, 0.0], [0.0, 0.3, 0.0]]}}
    }"#;
    let mut scene = Scene::from_json_str(text).unwrap();
    let (v, t) = Cuboid::new(
        [0.3, 0.4, 0.5],
        [0.06, 0.04, 0.08],
        Some([0.9, -0.2, 0.1, 0.3]),
    )
    .surface_triangles();
    scene.obstacles.push(Obstacle::Mesh(MeshSpec {
        file: "cube.obj".into(),
        role: cloth::scene::ObstacleRole::Collider,
        friction: None,
        surface: Some(MeshSdf::new(v, t)),
    }));
    scene.validate().unwrap();
    scene
}

/// Every row's analytic directional derivative against central differences (relative 1e-6)
/// at `x` along `d`, for the rows `which` selects (by index and label).
fn check_rows(
    problem: &mut TrajectoryProblem<'_>,
    x: &[f64],
    d: &[f64],
    which: impl Fn(usize, &RowLabel) -> bool,
) -> Result<usize, TestCaseError> {
    let labels = problem.row_labels();
    let mut checked = 0;
    for (r, (an, fd)) in row_derivatives(problem, x, d, 1e-6).into_iter().enumerate() {
        if !which(r, &labels[r]) {
            continue;
        }
        prop_assert!(
            (an - fd).abs() <= 1e-6 * an.abs().max(1.0),
            "row {} ({}): analytic {} vs central difference {}",
            r,
            labels[r],
            an,
            fd
        );
        checked += 1;
    }
    Ok(checked)
}

/// Gripper `k`'s position at step `t` under the flat controls `x`: its rest position plus the
/// displacements of the steps before.
fn gripper_at(model: &Model, x: &[f64], t: usize, k: usize) -> Vector3<f64> {
    let p = model.controls.as_slice()[k];
    let w = 3 * model.n_controls();
    Vector3::from_fn(|j, _| {
        model.start.get(p, j) + (0..t).map(|s| x[s * w + 3 * k + j]).sum::<f64>()
    })
}

/// The smallest distance to the safety obstacles along any particle's straight path of step
/// `t`, from the states alone (every particle, every sphere, exact).
fn exact_path_minimum(model: &Model, a: &autodiff::Tensor, b: &autodiff::Tensor) -> f64 {
    (0..a.rows())
        .map(|p| {
            let (pa, pb) = (
                Vector3::from_fn(|j, _| a.get(p, j)),
                Vector3::from_fn(|j, _| b.get(p, j)),
            );
            model.safety_obstacles.min_along_segment(&pa, &pb)
        })
        .fold(f64::INFINITY, f64::min)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// The continuous per-step rows: exact derivatives, and conservative (never above the
    /// exact smallest path distance less δ). κ = 200 and 3000: the band of paths that enter
    /// the rows is wide, then narrow.
    #[test]
    fn continuous_per_step_rows_match_central_differences(seed in 0u64..1000, sharp in any::<bool>()) {
        let scene = long_steps();
        let model = Model::from_scene(&scene).unwrap();
        let mut options = TaskOptions::for_model(&model);
        options.kappa = if sharp { 3000.0 } else { 200.0 };
        prop_assert!(options.swept, "continuous is the default");
        let mut p = TrajectoryProblem::new(&model, options.clone());
        let mut x = initial_controls(&scene, &model).unwrap().into_data();
        let shake = noise(seed, x.len());
        for (v, e) in x.iter_mut().zip(shake) {
            *v += 0.05 * e;
        }
        let states = p.states(&x).unwrap();
        let mut c = vec![0.0; p.num_inequalities()];
        p.inequalities(&x, &mut c).unwrap();
        let mut dips = 0;
        for t in 1..states.len() {
            let path = exact_path_minimum(&model, &states[t - 1], &states[t]);
            let step = exact_path_minimum(&model, &states[t], &states[t]);
            dips += usize::from(path < step - 1e-3);
            prop_assert!(c[t - 1] <= path - options.delta + 1e-12, "row {} = {} above {}", t, c[t - 1], path - options.delta);
        }
        prop_assert!(dips > 0, "some path dips between the steps");
        let d = noise(seed + 7, x.len());
        let n = check_rows(&mut p, &x, &d, |_, l| matches!(l, RowLabel::Safety { .. }))?;
        prop_assert_eq!(n, model.task.horizon);
    }

    /// The paper's scalar term over the paths, with δ large enough that many paths are inside.
    #[test]
    fn continuous_scalar_row_matches_central_differences(seed in 0u64..1000) {
        let scene = long_steps();
        let model = Model::from_scene(&scene).unwrap();
        let mut options = TaskOptions::for_model(&model);
        options.safety = Some(SafetyForm::Scalar);
        options.delta = 0.4;
        let mut p = TrajectoryProblem::new(&model, options);
        let mut x = initial_controls(&scene, &model).unwrap().into_data();
        let shake = noise(seed, x.len());
        for (v, e) in x.iter_mut().zip(shake) {
            *v += 0.05 * e;
        }
        let mut c = vec![0.0; p.num_inequalities()];
        p.inequalities(&x, &mut c).unwrap();
        prop_assert!(c[0] < 0.0, "paths inside δ: {}", c[0]);
        let d = noise(seed + 7, x.len());
        let n = check_rows(&mut p, &x, &d, |_, l| matches!(l, RowLabel::Safety { .. }))?;
        prop_assert_eq!(n, 1);
    }

    /// The gripper rows against a sphere, a capsule, a box and a mesh, on the motion between the
    /// steps and (step-only) at the steps; and every gripper row is at most the exact smallest
    /// distance along its motion.
    #[test]
    fn gripper_rows_match_central_differences(seed in 0u64..1000, swept in any::<bool>(),
                                              sharp in any::<bool>()) {
        let scene = gripper_scene();
        let model = Model::from_scene(&scene).unwrap();
        let mut options = TaskOptions::for_model(&model);
        options.swept = swept;
        options.kappa = if sharp { 3000.0 } else { 200.0 };
        let mut p = TrajectoryProblem::new(&model, options);
        let mut x = initial_controls(&scene, &model).unwrap().into_data();
        let shake = noise(seed, x.len());
        for (v, e) in x.iter_mut().zip(shake) {
            *v += 0.03 * e;
        }
        let labels = p.row_labels();
        let mut c = vec![0.0; p.num_inequalities()];
        p.inequalities(&x, &mut c).unwrap();
        let colliders = model.colliders_without_planes();
        let mut inside = 0;
        // Rows whose motion enters the mesh: there the minimum sits on a crease of the mesh's
        // field, and the row's derivative is that at the deepest point its search found.
        let mut into_mesh = vec![false; labels.len()];
        for (r, label) in labels.iter().enumerate() {
            if let RowLabel::Collider { control, step } = *label {
                let at = |t: usize| gripper_at(&model, &x, t, control);
                let (a, b) = if swept { (at(step - 1), at(step)) } else { (at(step), at(step)) };
                let exact = colliders.min_along_segment(&a, &b);
                prop_assert!(c[r] <= exact + 1e-12, "{}: row {} above {}", label, c[r], exact);
                inside += usize::from(exact < 0.0);
                into_mesh[r] = colliders.meshes[0].min_along_segment(&a, &b) < 1e-3;
            }
        }
        // The motion runs through every collider; the steps, shaken, need not.
        prop_assert!(inside > 0 || !swept, "some gripper goes into a collider");
        let d = noise(seed + 7, x.len());
        let n = check_rows(&mut p, &x, &d, |r, l| matches!(l, RowLabel::Collider { .. }) && !into_mesh[r])?;
        prop_assert!(n + into_mesh.iter().filter(|&&m| m).count() == 2 * model.task.horizon);
    }
}

/// [`gripper_scene`]'s grippers carried 0.4 m along +y at z = 0.5 in one step through a wall
/// 1 cm thick whose top is at z = 0.6: their motion crosses it through its middle.
fn wall_scene() -> Scene {
    let mut scene = gripper_scene();
    scene.obstacles = vec![Obstacle::Box(cloth::scene::BoxSpec {
        center: [0.0, -0.3, 0.3],
        half_extents: [1.0, 0.005, 0.3],
        rotation: None,
        role: cloth::scene::ObstacleRole::Collider,
        friction: None,
    })];
    scene.task.horizon = 1;
    scene.task.initial_controls =
        cloth::scene::InitialControls::Constant(vec![[0.0, 0.4, 0.0], [0.0, 0.4, 0.0]]);
    scene.validate().unwrap();
    scene
}

/// A gripper row whose motion crosses a thin wall through its middle counts the way out over the
/// wall's top (0.1 m), not the deepest point's depth (its half thickness, 5 mm, the same wherever
/// the motion crosses): lifting the gripper's end raises the row (by three quarters of the lift:
/// the motion crosses the wall three quarters of the way along), so the planner can pull it back
/// over the wall; the rows match central differences there.
#[test]
fn a_gripper_crossing_a_thin_wall_has_a_row_with_a_slope() {
    let scene = wall_scene();
    let model = Model::from_scene(&scene).unwrap();
    let mut options = TaskOptions::for_model(&model);
    options.kappa = 3000.0;
    let mut p = TrajectoryProblem::new(&model, options);
    let x = initial_controls(&scene, &model).unwrap().into_data();
    let labels = p.row_labels();
    let rows: Vec<usize> = (0..labels.len())
        .filter(|&r| matches!(labels[r], RowLabel::Collider { .. }))
        .collect();
    assert_eq!(rows.len(), 2, "a row per gripper");
    let values = |x: &[f64], p: &mut TrajectoryProblem<'_>| {
        let mut c = vec![0.0; p.num_inequalities()];
        p.inequalities(x, &mut c).unwrap();
        rows.iter().map(|&r| c[r]).collect::<Vec<f64>>()
    };
    let at = values(&x, &mut p);
    let mut lifted = x.clone();
    lifted[2] += 0.01;
    let up = values(&lifted, &mut p);
    eprintln!("rows {at:?}, gripper 0 lifted 1 cm: {up:?}");
    assert!(
        (at[0] + 0.1).abs() < 2e-3,
        "the way over the top: {}",
        at[0]
    );
    assert!(up[0] - at[0] > 0.005, "it rises: {} → {}", at[0], up[0]);
    let d = noise(3, x.len());
    let n = check_rows(&mut p, &x, &d, |_, l| {
        matches!(l, RowLabel::Collider { .. })
    })
    .unwrap();
    assert_eq!(n, 2);
}
