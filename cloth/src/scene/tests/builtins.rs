//! The built-in scenes: they round-trip, match their specifications, and derive the expected
//! geometry (counts of mesh built-ins, rest positions of a non-square grid).

use super::super::*;

#[test]
fn builtins_round_trip() {
    for &(name, description) in Scene::builtin_names() {
        let s = Scene::builtin(name).expect("builtin valid");
        assert_eq!(s.name, name);
        assert_eq!(s.description, description);
        let text = s.to_json_pretty();
        // A scene that names files (a mesh cloth) reads them from its folder.
        let folder = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../examples/scenes")
            .join(if s.cloth.is_mesh() { name } else { "" });
        let back = Scene::from_json_str_in(&text, &folder).expect("round trip parses");
        assert_eq!(back, s, "{name}");
        assert_eq!(back.to_json_pretty(), text);
    }
    assert_eq!(
        Scene::builtin_names()
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>(),
        ["u_obstacle", "swing", "drop", "fold"]
    );
}

fn check_common(s: &Scene, y0: f64, z_top: f64) {
    assert_eq!((s.cloth.rows, s.cloth.cols), (10, 10));
    assert_eq!(s.cloth.particle_mass, 1.0);
    assert_eq!(s.material.stretch, Stiffness::Finite(1e4));
    assert_eq!(
        s.material.bending,
        Some(Bending {
            model: BendingModel::Distance,
            stiffness: Stiffness::Finite(1e2)
        })
    );
    assert_eq!(s.physics.dt, 0.1);
    assert_eq!(s.physics.gravity, [0.0, 0.0, -9.8]);
    assert_eq!(s.physics.iterations, 100);
    assert_eq!(s.task.horizon, 10);
    assert_eq!(s.controls, vec![[0, 0], [0, 9]]);
    assert_eq!(s.control_indices(), vec![0, 9]);
    // rest positions bit-exact against the spec formula
    let x = s.rest_positions();
    assert_eq!(x.len(), 100);
    for r in 0..10 {
        for c in 0..10 {
            let expect = [-0.5 + c as f64 / 9.0, y0, z_top - r as f64 / 9.0];
            assert_eq!(x[r * 10 + c], expect, "particle ({r}, {c})");
        }
    }
}

#[test]
fn builtin_u_obstacle_matches_spec() {
    let s = Scene::builtin("u_obstacle").expect("builtin");
    check_common(&s, -1.5, 2.0);
    assert_eq!(s.obstacles.len(), 1);
    let Obstacle::Spheres(sp) = &s.obstacles[0] else {
        panic!("spheres expected")
    };
    assert_eq!(sp.role, ObstacleRole::Safety);
    // recompute the 18 centres from the formula (exact comparison)
    let mut centers = Vec::new();
    for x in [-0.75, 0.75] {
        for k in 0..7 {
            centers.push([x, 0.0, 0.25 + k as f64 * (2.5 / 6.0)]);
        }
    }
    for x in [-0.45, -0.15, 0.15, 0.45] {
        centers.push([x, 0.0, 0.25]);
    }
    assert_eq!(sp.centers, centers);
    assert_eq!(sp.radii, vec![0.25; 18]);
    // targets: bottom row to (-0.5 + c/9, 1.5, 1.0)
    assert_eq!(s.target_indices(), (90..100).collect::<Vec<_>>());
    let expect: Vec<[f64; 3]> = (0..10).map(|c| [-0.5 + c as f64 / 9.0, 1.5, 1.0]).collect();
    assert_eq!(s.target_positions(), expect);
    assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (1.0, 1e-4, 0.2));
    assert_eq!(
        s.initial_controls_array(),
        vec![vec![[0.0, 0.3, 0.0]; 2]; 10]
    );
}

#[test]
fn builtin_swing_matches_spec() {
    let s = Scene::builtin("swing").expect("builtin");
    check_common(&s, -1.5, 2.0);
    assert!(s.obstacles.is_empty());
    assert_eq!(s.target_indices(), (90..100).collect::<Vec<_>>());
    let expect: Vec<[f64; 3]> = (0..10).map(|c| [-0.5 + c as f64 / 9.0, 1.0, 1.5]).collect();
    assert_eq!(s.target_positions(), expect);
    assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (1.0, 1e-5, 0.0));
    assert_eq!(s.task.initial_controls, InitialControls::Zeros);
    assert_eq!(s.initial_controls_array(), vec![vec![[0.0; 3]; 2]; 10]);
}

#[test]
fn builtin_drop_matches_spec() {
    let s = Scene::builtin("drop").expect("builtin");
    check_common(&s, 0.0, 1.5);
    assert_eq!(
        s.obstacles,
        vec![Obstacle::Plane(PlaneSpec {
            point: [0.0, 0.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            role: ObstacleRole::Collider,
            friction: None,
        })]
    );
    assert_eq!(s.target_indices(), vec![0, 9, 90, 99]);
    assert_eq!(
        s.target_positions(),
        vec![
            [-0.5, 0.5, 0.0],
            [0.5, 0.5, 0.0],
            [-0.5, -0.5, 0.0],
            [0.5, -0.5, 0.0]
        ]
    );
    assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (0.1, 1e-5, 0.0));
    assert_eq!(s.task.initial_controls, InitialControls::Zeros);
}

#[test]
fn builtin_meshes_have_canonical_counts() {
    for &(name, _) in Scene::builtin_names() {
        let scene = Scene::builtin(name).expect("builtin");
        if scene.cloth.is_mesh() {
            continue;
        }
        let m = scene.mesh();
        assert_eq!(m.n_particles(), 100);
        assert_eq!(m.stretch_edges().len(), 261);
        assert_eq!(m.bending_pairs().len(), 225);
    }
}

#[test]
fn non_square_rest_positions() {
    let mut s = Scene::builtin("swing").expect("builtin");
    s.cloth.rows = 3;
    s.cloth.cols = 5;
    s.cloth.top_left = [1.0, 2.0, 3.0];
    s.cloth.right = [4.0, 0.0, 0.0];
    s.cloth.down = [0.0, -2.0, 0.0];
    s.controls = vec![[0, 0].into(), [0, 4].into()];
    s.task.targets = vec![Target {
        particle: [2, 4].into(),
        position: [0.0; 3],
    }];
    s.validate().expect("valid");
    let x = s.rest_positions();
    assert_eq!(x.len(), 15);
    assert_eq!(x[0], [1.0, 2.0, 3.0]);
    assert_eq!(x[4], [5.0, 2.0, 3.0]);
    assert_eq!(x[10], [1.0, 0.0, 3.0]);
    assert_eq!(x[14], [5.0, 0.0, 3.0]);
    assert_eq!(x[7], [3.0, 1.0, 3.0]);
    assert_eq!(s.target_indices(), vec![14]);
}
