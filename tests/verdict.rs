//! The verdict checks step 0 and says what it measured: a start inside an obstacle is an error
//! naming the obstacle and the depth (a warning with `--allow-unsafe-start`), the iteration count
//! is given per stage, and the feasibility tolerance is a documented, validated option.

mod common;

use cloth::scene::{Obstacle, ObstacleRole, SphereSetSpec};
use cloth::Scene;
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
    let found = start_intrusions(&scene, 0.1);
    assert_eq!(found.len(), 1, "{found:?}");
    let i = &found[0];
    assert_eq!(
        (i.obstacle, i.sphere, i.particle),
        (0, Some(1), [3, 0].into())
    );
    assert!((i.distance - (0.15 - 0.2)).abs() < 1e-12, "{}", i.distance);
    let (error, _) = judge_start(&scene, 0.1);
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
    let (error, warnings) = judge_start(&outside, 0.1);
    assert!(error.is_none(), "{error:?}");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("starts 0.0500 from obstacles[0] (spheres), sphere 1"),
        "{}",
        warnings[0]
    );
    assert_eq!(judge_start(&outside, 0.01), (None, Vec::new()));
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
