//! The verdict checks step 0 and says what it measured: a start inside an obstacle is an error
//! naming the obstacle and the depth (a warning with `--allow-unsafe-start`), the iteration count
//! is given per stage, and the feasibility tolerance is a documented, validated option. It judges
//! the cloth, not only its particles: a thin obstacle through a triangle, and (with
//! self-collision) layers pressed within half the thickness or passing through each other, make a
//! plan not safe.

mod common;

use cloth::scene::{Obstacle, ObstacleRole, SphereSetSpec};
use cloth::{Model, Scene};
use clothopt::start_check::{judge_start, start_intrusions};
use common::{bin, files_in, run, scratch, stderr, stdout, write_scene};

/// A 4 × 4 cloth (side 1, top at z = 2, plane y = −1.5) whose particle [3, 0] (at
/// (−0.5, −1.5, 1.0)) lies 0.05 inside a safety sphere of radius 0.2.
fn start_inside() -> Scene {
    let mut s = common::small(4, 4, 3, 10);
    s.obstacles = vec![Obstacle::Spheres(SphereSetSpec {
        centers: vec![[5.0, 5.0, 5.0], [-0.5, -1.5, 0.85]],
        radii: vec![0.1, 0.2],
        role: ObstacleRole::Safety,
        friction: None,
    })];
    s.task.delta = 0.1;
    s.validate().unwrap();
    s
}

#[test]
fn the_deepest_start_intrusion_is_found_per_obstacle() {
    let scene = start_inside();
    let start = Model::from_scene(&scene).unwrap().start;
    let found = start_intrusions(&scene, &start, 0.1);
    assert_eq!(found.len(), 1, "{found:?}");
    let i = &found[0];
    assert_eq!(
        (i.obstacle, i.sphere, i.particle),
        (0, Some(1), [3, 0].into())
    );
    assert!((i.distance - (0.15 - 0.2)).abs() < 1e-12, "{}", i.distance);
    let (error, _) = judge_start(&scene, &start, 0.1);
    let e = error.unwrap();
    assert!(
        e.contains("obstacles[0] (spheres), sphere 1") && e.contains("0.0500"),
        "{e}"
    );
    // Moved 0.1 down, the sphere is 0.05 outside the particle: inside δ = 0.1, a warning naming
    // the distance, not an error; with δ = 0.01 nothing at all.
    let mut outside = scene.clone();
    if let Obstacle::Spheres(set) = &mut outside.obstacles[0] {
        set.centers[1][2] = 0.75;
    }
    let (error, warnings) = judge_start(&outside, &start, 0.1);
    assert!(error.is_none(), "{error:?}");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("starts 0.0500 from obstacles[0] (spheres), sphere 1"),
        "{}",
        warnings[0]
    );
    assert_eq!(judge_start(&outside, &start, 0.01), (None, Vec::new()));
}

#[test]
fn the_cli_refuses_a_start_inside_an_obstacle_unless_allowed() {
    let dir = scratch("verdict", "start");
    let path = write_scene(&dir, "scene.json", &start_inside());
    let out = dir.join("r.json");
    let o = run(bin()
        .arg("optimize")
        .arg(&path)
        .args(["--iterations", "5", "--search", "off", "--out"])
        .arg(&out));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("starts inside obstacles[0] (spheres), sphere 1 at depth 0.0500"),
        "{err}"
    );
    assert_eq!(files_in(&dir), vec!["scene.json"], "nothing written");

    let o = run(bin()
        .arg("optimize")
        .arg(&path)
        .args([
            "--iterations",
            "5",
            "--search",
            "off",
            "--allow-unsafe-start",
            "--out",
        ])
        .arg(&out));
    let (so, se) = (stdout(&o), stderr(&o));
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{so}{se}");
    assert!(se.contains("warning: the cloth starts inside"), "{se}");
    assert!(out.exists());
    // Iterations per stage: a κ warm-up, then the sharp stage.
    assert!(so.contains("(κ = 200: "), "{so}");
    assert!(so.contains(", κ = 3000: "), "{so}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let stages = v["stages"].as_array().unwrap();
    assert_eq!(stages.len(), 2);
    let total: u64 = stages
        .iter()
        .map(|s| s["iterations"].as_u64().unwrap())
        .sum();
    assert_eq!(total, v["iterations"].as_u64().unwrap());
    assert_eq!(v["feasibility_tolerance"], 1e-8);
}

#[test]
fn a_bad_feasibility_tolerance_is_rejected_naming_the_flag() {
    for bad in ["0", "nan", "-1e-3"] {
        let flag = format!("--feasibility-tol={bad}");
        let o = run(bin().args(["optimize", "u_obstacle", &flag]));
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{bad}: {err}");
        assert!(err.contains("--feasibility-tol"), "{err}");
    }
}

/// A 5 × 5 cloth in three made-up states: at rest, then with its corner vertex 0 moved 0.05 in
/// front of the far corner's last triangle, then 0.05 behind it.
fn through_itself(scene: &Scene) -> (cloth::Model, Vec<autodiff::Tensor>) {
    let model = cloth::Model::from_scene(scene).unwrap();
    let rest = model.start.clone();
    let p = |x: &autodiff::Tensor, i: usize| {
        cloth::nalgebra::Vector3::new(x.get(i, 0), x.get(i, 1), x.get(i, 2))
    };
    let far = *model.triangles.last().unwrap();
    let [a, b, c] = far.map(|i| p(&rest, i));
    let normal = (b - a).cross(&(c - a)).normalize();
    let centre = (a + b + c) / 3.0;
    let moved = |offset: f64| {
        let mut x = rest.clone();
        let q = centre + normal * offset;
        x.row_mut(0).copy_from_slice(&[q.x, q.y, q.z]);
        x
    };
    let states = vec![rest.clone(), moved(0.05), moved(-0.05)];
    (model, states)
}

#[test]
fn a_cloth_through_itself_or_its_layers_pressed_together_is_not_safe() {
    let mut scene = common::small(5, 5, 2, 10);
    scene.physics.self_collision = Some(cloth::scene::SelfCollisionSpec {
        thickness: 0.2,
        edge_edge: false,
        friction: None,
    });
    scene.validate().unwrap();
    let (model, states) = through_itself(&scene);
    let mut task = clothopt::problem::TaskOptions::for_model(&model);
    task.swept = true;
    let metrics = cloth::Metrics::default();
    let report = clothopt::safety_check::check_safety(&model, &states, &metrics, &task, 1e-6);
    let layers = report.layers.expect("a layer report under self-collision");
    let nearest = layers
        .nearest
        .expect("the moved vertex within the thickness");
    // Vertex 0 is 0.05 from the far triangle (the triangles it drags along may come nearer
    // to other vertices).
    assert!(nearest.distance <= 0.05 + 1e-9, "{nearest:?}");
    assert_eq!(layers.first_crossing_step, Some(2), "{layers:?}");
    assert!(layers.crossings >= 1);
    let text = report.failures.join("\n");
    assert!(text.contains("less than half the thickness 0.2"), "{text}");
    assert!(
        text.contains("passes through itself between steps 1 and 2"),
        "{text}"
    );

    // Without self-collision the scene does not simulate it, and the verdict does not judge it.
    scene.physics.self_collision = None;
    let (model, states) = through_itself(&scene);
    let report = clothopt::safety_check::check_safety(&model, &states, &metrics, &task, 1e-6);
    assert!(
        report.layers.is_none() && report.failures.is_empty(),
        "{report:?}"
    );
}

/// A thin safety pole through a triangle's middle, every particle more than `δ` from it: the
/// particles' check passes, the surface's does not.
#[test]
fn a_thin_obstacle_through_the_cloth_between_its_particles_is_not_safe() {
    let mut scene = common::small(5, 5, 1, 10);
    let model = cloth::Model::from_scene(&scene).unwrap();
    let p = |i: usize| {
        cloth::nalgebra::Vector3::new(
            model.start.get(i, 0),
            model.start.get(i, 1),
            model.start.get(i, 2),
        )
    };
    let [a, b, c] = model.triangles[5].map(p);
    let normal = (b - a).cross(&(c - a)).normalize();
    let centre = (a + b + c) / 3.0;
    let nearest = (0..model.n_particles())
        .map(|i| (p(i) - centre).norm())
        .fold(f64::INFINITY, f64::min);
    let radius = 0.005;
    let (from, to) = (centre - normal, centre + normal);
    scene.obstacles = vec![Obstacle::Capsule(cloth::scene::CapsuleSpec {
        a: [from.x, from.y, from.z],
        b: [to.x, to.y, to.z],
        radius,
        role: ObstacleRole::Safety,
        friction: None,
    })];
    scene.task.delta = 0.5 * (nearest - radius);
    scene.validate().unwrap();
    let model = cloth::Model::from_scene(&scene).unwrap();
    let states = vec![model.start.clone(), model.start.clone()];
    let mut task = clothopt::problem::TaskOptions::for_model(&model);
    task.swept = false;
    let metrics = cloth::Metrics::default();
    let report = clothopt::safety_check::check_safety(&model, &states, &metrics, &task, 1e-6);
    let surface = report
        .surface
        .expect("a surface report with safety obstacles");
    assert!((surface.distance + radius).abs() <= 1e-3, "{surface:?}");
    let text = report.failures.join("\n");
    assert!(
        text.contains("passes through the cloth at step 1"),
        "{text}"
    );
    assert_eq!(report.failures.len(), 1, "the particles keep δ: {text}");
}
