//! A cloth read from a triangle mesh (`cloth.mesh`): topology, targets from `task.target_mesh`,
//! agreement with the grid it was cut from, and a named error for every kind of bad input.

use std::path::{Path, PathBuf};

use cloth::internals::GridMesh;
use cloth::scene::{ParticleRef, Scene, SceneError};
use cloth::Model;
use serde_json::{json, Value};

fn towel_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes/towel")
}

/// A fresh folder under the system's temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cloth-mesh-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// OBJ text of the `rows × cols` grid of `swing`'s cloth (same rest positions, same triangles).
fn grid_obj(scene: &Scene) -> String {
    let mut text = String::new();
    for p in scene.rest_positions() {
        text += &format!("v {:?} {:?} {:?}\n", p[0], p[1], p[2]);
    }
    for t in GridMesh::new(scene.cloth.rows, scene.cloth.cols).triangles() {
        text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    text
}

/// `swing` with its cloth replaced by the same grid written as an OBJ file in `dir`.
fn swing_as_mesh(dir: &Path) -> (Scene, Scene) {
    let grid = Scene::builtin("swing").unwrap();
    std::fs::write(dir.join("grid.obj"), grid_obj(&grid)).unwrap();
    let mut v: Value = serde_json::from_str(&grid.to_json_pretty()).unwrap();
    let cols = grid.cloth.cols;
    v["cloth"] = json!({"mesh": "grid.obj", "particle_mass": grid.cloth.particle_mass});
    v["controls"] = json!(grid
        .controls
        .iter()
        .map(|&p| grid.particle_index(p))
        .collect::<Vec<_>>());
    for t in v["task"]["targets"].as_array_mut().unwrap() {
        let [r, c]: [usize; 2] = serde_json::from_value(t["particle"].clone()).unwrap();
        t["particle"] = json!(r * cols + c);
    }
    let mesh = Scene::from_json_str_in(&v.to_string(), dir).unwrap();
    (grid, mesh)
}

fn invalid_field(result: Result<Scene, SceneError>) -> (String, String) {
    match result {
        Err(SceneError::Invalid { field, reason }) => (field, reason),
        Err(other) => panic!("expected a named field, got {other}"),
        Ok(_) => panic!("expected an error"),
    }
}

#[test]
fn the_towel_scene_loads_with_every_vertex_a_target() {
    let scene = Scene::load(towel_dir().join("towel.json")).unwrap();
    assert!(scene.cloth.is_mesh());
    assert_eq!(scene.n_particles(), 64);
    assert_eq!(scene.control_indices(), vec![0, 7]);
    assert_eq!(scene.target_indices(), (0..64).collect::<Vec<_>>());
    // towel_moved.obj: vertex 0 at (−0.5, 0.5 + 0.3, 0).
    assert_eq!(scene.target_positions()[0], [-0.5, 0.8, 0.0]);
    // Default tolerance: 10% of the bounding box's largest extent (1 m).
    assert!((scene.tolerance() - 0.1).abs() < 1e-12);
    let mesh = scene.mesh();
    // 7·7 cells, 2 triangles each; edges 7·8·2 + 49 = 161; interior 161 − 28 = 133.
    assert_eq!(
        (
            mesh.triangles().len(),
            mesh.stretch_edges().len(),
            mesh.bending_pairs().len()
        ),
        (98, 161, 133)
    );
    let model = Model::from_scene(&scene).unwrap();
    assert_eq!(model.triangles.len(), 98);
    assert_eq!(model.task.target_positions.rows(), 64);
    let counts: Vec<(String, usize)> = model
        .groups
        .iter()
        .map(|g| (g.name.clone(), g.count))
        .collect();
    // The scene names no solver and has a collider: Newton with smooth contact (a barrier in
    // its energy, not a collider group).
    assert_eq!(
        counts,
        [("stretch".to_string(), 161), ("bending".to_string(), 133)]
    );
    let barrier = model.contact_barrier.as_ref().expect("smooth contact");
    let d_hat = barrier.barrier.d_hat;
    let states = model.simulate(&scene.initial_controls()).unwrap();
    let last = states.last().unwrap();
    assert!(last.data().iter().all(|x| x.is_finite()));
    // The grippers hold their corners 2 cm up; no vertex reaches the table, and the rows beyond
    // the first two rest on it, within d̂.
    assert_eq!((last.get(0, 2), last.get(7, 2)), (0.02, 0.02));
    for p in 0..64 {
        let z = last.get(p, 2);
        assert!(z > 0.0, "vertex {p} at z = {z}");
        assert!(p < 16 || z < d_hat, "vertex {p} at z = {z} (d̂ {d_hat})");
    }
}

#[test]
fn a_mesh_scene_prints_its_file_and_reads_back_equal() {
    let scene = Scene::load(towel_dir().join("towel.json")).unwrap();
    let text = scene.to_json_pretty();
    assert!(text.contains("\"mesh\": \"towel.obj\"") && !text.contains("\"rows\""));
    assert!(text.contains("\"target_mesh\": \"towel_moved.obj\""));
    assert_eq!(Scene::from_json_str_in(&text, &towel_dir()).unwrap(), scene);
}

#[test]
fn the_grid_as_a_mesh_has_the_grids_constraints_and_nearly_its_rollout() {
    let dir = temp_dir("grid");
    let (grid, mesh) = swing_as_mesh(&dir);
    assert_eq!(mesh.rest_positions(), grid.rest_positions());
    assert_eq!(mesh.control_indices(), grid.control_indices());
    assert_eq!(mesh.target_indices(), grid.target_indices());
    assert_eq!(mesh.tolerance(), grid.tolerance());
    let (mg, mm) = (
        Model::from_scene(&grid).unwrap(),
        Model::from_scene(&mesh).unwrap(),
    );
    let counts = |m: &Model| -> Vec<(String, usize)> {
        m.groups.iter().map(|g| (g.name.clone(), g.count)).collect()
    };
    assert_eq!(counts(&mm), counts(&mg));
    assert_eq!(mm.triangles, mg.triangles);
    // Same constraints, swept in another (first-use) order: the converged states agree closely.
    let u = grid.initial_controls();
    let (sg, sm) = (mg.simulate(&u).unwrap(), mm.simulate(&u).unwrap());
    let diff = sg
        .last()
        .unwrap()
        .data()
        .iter()
        .zip(sm.last().unwrap().data())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff < 1e-2, "largest coordinate difference {diff}");
    let eg = mg.evaluate(&u, grid.task.delta, false).unwrap().metrics;
    let em = mm.evaluate(&u, mesh.task.delta, false).unwrap().metrics;
    assert!((eg.g - em.g).abs() <= 1e-2 * eg.g, "G {} vs {}", eg.g, em.g);
    std::fs::remove_dir_all(dir).ok();
}

/// The towel scene's JSON with `edit` applied, loaded from `dir` (which holds the towel's OBJ
/// files and whatever the test writes there).
fn towel_with(dir: &Path, edit: impl FnOnce(&mut Value)) -> Result<Scene, SceneError> {
    for f in ["towel.obj", "towel_moved.obj"] {
        std::fs::copy(towel_dir().join(f), dir.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(towel_dir().join("towel.json")).unwrap();
    let mut v: Value = serde_json::from_str(&text).unwrap();
    edit(&mut v);
    Scene::from_json_str_in(&v.to_string(), dir)
}

#[test]
fn bad_mesh_cloths_are_rejected_naming_the_field_and_the_line() {
    let dir = temp_dir("bad");
    let square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    let cases: Vec<(&str, String, &str, &str)> = vec![
        ("missing.obj", String::new(), "cloth.mesh", "cannot read"),
        (
            "nan.obj",
            "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n".into(),
            "cloth.mesh",
            "line 2",
        ),
        (
            "range.obj",
            format!("{square}f 1 2 9\n"),
            "cloth.mesh",
            "line 5: vertex index 9 out of range",
        ),
        (
            "flat.obj",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n".into(),
            "cloth.mesh",
            "line 5: triangle 0 is degenerate",
        ),
        (
            "fan.obj",
            format!("{square}v 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n"),
            "cloth.mesh",
            "non-manifold",
        ),
        (
            "flipped.obj",
            format!("{square}f 1 2 3\nf 1 4 3\n"),
            "cloth.mesh",
            "inconsistent orientation",
        ),
    ];
    for (file, text, field, needle) in cases {
        if !text.is_empty() {
            std::fs::write(dir.join(file), text).unwrap();
        }
        let (f, reason) = invalid_field(towel_with(&dir, |v| {
            v["cloth"]["mesh"] = json!(file);
            v["controls"] = json!([0, 1]);
            v["task"]["target_mesh"] = Value::Null;
            v["task"]["targets"] = json!([{"particle": 2, "position": [0, 0, 0]}]);
        }));
        assert_eq!(f, field, "{file}: {reason}");
        assert!(
            reason.contains(needle) && reason.contains(file),
            "{file}: {reason}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

/// A change to a scene's JSON.
type Edit = Box<dyn FnOnce(&mut Value)>;

#[test]
fn particles_targets_and_target_meshes_are_checked_against_the_mesh() {
    let dir = temp_dir("refs");
    let cases: Vec<(&str, Edit, &str, &str)> = vec![
        (
            "vertex out of range",
            Box::new(|v| v["controls"] = json!([0, 64])),
            "controls[1]",
            "vertex 64 out of range (cloth.mesh has 64 vertices",
        ),
        (
            "a grid particle on a mesh",
            Box::new(|v| v["controls"] = json!([[0, 0]])),
            "controls[0]",
            "is a grid particle",
        ),
        (
            "repeated control",
            Box::new(|v| v["controls"] = json!([7, 7])),
            "controls[1]",
            "vertex 7 duplicates controls[0]",
        ),
        (
            "targets beside a target mesh",
            Box::new(|v| v["task"]["targets"] = json!([{"particle": 3, "position": [0, 0, 0]}])),
            "task.targets",
            "not both",
        ),
        (
            "target mesh of another size",
            Box::new(|v| v["task"]["target_mesh"] = json!("small.obj")),
            "task.target_mesh",
            "has 3 vertices, the cloth (cloth.mesh) has 64",
        ),
        (
            "missing target mesh",
            Box::new(|v| v["task"]["target_mesh"] = json!("nowhere.obj")),
            "task.target_mesh",
            "cannot read",
        ),
    ];
    std::fs::write(
        dir.join("small.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    for (what, edit, field, needle) in cases {
        let (f, reason) = invalid_field(towel_with(&dir, edit));
        assert_eq!(f, field, "{what}: {reason}");
        assert!(reason.contains(needle), "{what}: {reason}");
    }
    // On a grid, a vertex index and a target mesh are errors too.
    let grid = Scene::builtin("swing").unwrap();
    let mut v: Value = serde_json::from_str(&grid.to_json_pretty()).unwrap();
    v["controls"] = json!([0, [0, 9]]);
    let (f, reason) = invalid_field(Scene::from_json_str(&v.to_string()));
    assert_eq!(f, "controls[0]");
    assert!(
        reason.contains("is a vertex index, but the cloth is a grid"),
        "{reason}"
    );
    let mut v: Value = serde_json::from_str(&grid.to_json_pretty()).unwrap();
    v["task"]["target_mesh"] = json!("towel_moved.obj");
    v["task"]["targets"] = json!([]);
    let (f, _) = invalid_field(Scene::from_json_str_in(&v.to_string(), &towel_dir()));
    assert_eq!(f, "task.target_mesh");
    // Grid fields beside `mesh` are a parse error naming the field.
    let mut v: Value = serde_json::from_str(&grid.to_json_pretty()).unwrap();
    v["cloth"]["mesh"] = json!("towel.obj");
    let e = Scene::from_json_str_in(&v.to_string(), &towel_dir())
        .unwrap_err()
        .to_string();
    assert!(e.contains("`rows` is a grid field"), "{e}");
    assert_eq!(ParticleRef::from(3).to_string(), "vertex 3");
    std::fs::remove_dir_all(dir).ok();
}
