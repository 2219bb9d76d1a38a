//! Capsule, box and mesh obstacles: their signed distances' gradients (forward duals) against
//! central finite differences inside, outside, near edges and corners; finite values on mesh
//! features; scene loading with `role` `"safety"` and `"collider"`; named errors for bad OBJ files.

use cloth::nalgebra::Vector3;
use cloth::sdf::{Capsule, Cuboid, MeshSdf, SignedDistance};
use cloth::{Model, Scene};
use proptest::prelude::*;

/// Central differences of `f` at `p` with step `h`.
fn fd(f: &impl SignedDistance, p: &Vector3<f64>, h: f64) -> Vector3<f64> {
    Vector3::from_fn(|k, _| {
        let mut a = *p;
        let mut b = *p;
        a[k] += h;
        b[k] -= h;
        (f.distance(&a) - f.distance(&b)) / (2.0 * h)
    })
}

/// Asserts the dual gradient matches finite differences to `1e-6` (absolute; gradients are unit).
fn check(f: &impl SignedDistance, p: &Vector3<f64>) -> Result<(), TestCaseError> {
    let (d, g) = f.distance_gradient(p);
    prop_assert_eq!(d, f.distance(p));
    let n = fd(f, p, 1e-7);
    prop_assert!(
        (g - n).norm() < 1e-6,
        "at {:?}: dual {:?}, fd {:?}",
        p,
        g,
        n
    );
    prop_assert!(
        (g.norm() - 1.0).abs() < 1e-9,
        "|∇d| = {} at {:?}",
        g.norm(),
        p
    );
    Ok(())
}

fn vec3(r: f64) -> impl Strategy<Value = Vector3<f64>> {
    [-r..r, -r..r, -r..r].prop_map(|[x, y, z]| Vector3::new(x, y, z))
}

fn quaternion() -> impl Strategy<Value = [f64; 4]> {
    [0.2..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64]
}

/// The box's body-frame `d = |q| − h`, to stay off its inside kinks.
fn box_d(b: &Cuboid, p: &Vector3<f64>) -> [f64; 3] {
    let rel = p - Vector3::from(b.center);
    std::array::from_fn(|k| {
        let q: f64 = (0..3).map(|i| rel[i] * b.rotation[i][k]).sum();
        q.abs() - b.half_extents[k]
    })
}

/// True when `p` is inside `b` and within `gap` of where two faces are equally near.
fn near_inside_kink(b: &Cuboid, p: &Vector3<f64>, gap: f64) -> bool {
    let mut d = box_d(b, p);
    if d.iter().any(|&x| x > -gap) && d.iter().any(|&x| x > 0.0) {
        return false;
    }
    d.sort_by(f64::total_cmp);
    d.iter().all(|&x| x <= 0.0) && d[2] - d[1] < gap
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn capsule_gradient_matches_fd(a in vec3(1.0), b in vec3(1.0), r in 0.05..0.8f64,
                                   p in vec3(2.0), at_end in 0..3usize, off in vec3(0.9)) {
        let cap = Capsule { a: a.into(), b: b.into(), radius: r };
        // Points around an end cap, or anywhere.
        let p = match at_end { 0 => a + off, 1 => b + off, _ => p };
        // Off the axis (where the distance has no gradient).
        let axis_distance = cap.distance(&p) + r;
        prop_assume!(axis_distance > 1e-3);
        check(&cap, &p)?;
    }

    #[test]
    fn box_gradient_matches_fd(c in vec3(1.0), h in [0.1..1.0f64, 0.1..1.0, 0.1..1.0],
                               q in quaternion(), p in vec3(2.5), corner in 0..9usize,
                               off in vec3(0.3)) {
        let b = Cuboid::new(c.into(), h, Some(q));
        // Near a corner (inside and outside), or anywhere.
        let p = if corner < 8 {
            let s = |bit: usize| if corner >> bit & 1 == 1 { 1.0 } else { -1.0 };
            let local = Vector3::new(s(0) * h[0], s(1) * h[1], s(2) * h[2]);
            let world = Vector3::from_fn(|i, _| c[i] + (0..3).map(|j| b.rotation[i][j] * local[j]).sum::<f64>());
            world + off
        } else {
            p
        };
        prop_assume!(!near_inside_kink(&b, &p, 1e-4));
        prop_assume!(box_d(&b, &p).iter().all(|x| x.abs() > 1e-5) || b.distance(&p) > 0.0);
        check(&b, &p)?;
    }

    #[test]
    fn box_mesh_gradient_matches_fd(c in vec3(1.0), h in [0.1..1.0f64, 0.1..1.0, 0.1..1.0],
                                    q in quaternion(), p in vec3(2.5), corner in 0..9usize,
                                    off in vec3(0.3)) {
        let b = Cuboid::new(c.into(), h, Some(q));
        let (v, t) = b.surface_triangles();
        let mesh = MeshSdf::new(v.clone(), t);
        let p = if corner < 8 { Vector3::from(v[corner]) + off } else { p };
        prop_assume!(!near_inside_kink(&b, &p, 1e-4));
        prop_assume!(b.distance(&p).abs() > 1e-5);
        prop_assert!((mesh.distance(&p) - b.distance(&p)).abs() < 1e-9);
        check(&mesh, &p)?;
    }

    #[test]
    fn capsule_mesh_gradient_matches_fd_outside(p in vec3(2.0), vertex in 0..200usize, off in vec3(0.2)) {
        let cap = Capsule { a: [0.0, 0.0, -0.5], b: [0.2, 0.1, 0.5], radius: 0.4 };
        let (v, t) = cap.surface_triangles();
        let mesh = MeshSdf::new(v.clone(), t);
        let p = if vertex < v.len() { Vector3::from(v[vertex]) + off } else { p };
        // Outside a convex mesh the distance is smooth; and it matches the capsule's to within
        // the tessellation's error.
        let d = mesh.distance(&p);
        prop_assume!(d > 1e-4);
        prop_assert!((d - cap.distance(&p)).abs() < 0.05);
        check(&mesh, &p)?;
    }
}

#[test]
fn mesh_features_are_finite() {
    let b = Cuboid::new([0.0; 3], [0.5, 0.5, 0.5], None);
    let (v, t) = b.surface_triangles();
    let mesh = MeshSdf::new(v.clone(), t.clone());
    let mut points: Vec<Vector3<f64>> = v.iter().map(|&p| Vector3::from(p)).collect();
    for tri in &t {
        for k in 0..3 {
            points.push((Vector3::from(v[tri[k]]) + Vector3::from(v[tri[(k + 1) % 3]])) / 2.0);
        }
    }
    points.push(Vector3::zeros()); // the centre: equidistant from all six faces
    for p in points {
        let (d, g) = mesh.distance_gradient(&p);
        assert!(
            d.is_finite() && g.iter().all(|x| x.is_finite()),
            "{d} {g:?} at {p:?}"
        );
        assert!((d - b.distance(&p)).abs() < 1e-12, "{d} at {p:?}");
    }
}

const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv -0.5 0.5 -0.5\nv 0.5 0.5 -0.5\n\
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv -0.5 0.5 0.5\nv 0.5 0.5 0.5\n\
f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

/// The `drop` scene with `obstacles` replaced, as JSON text.
fn drop_with(obstacles: serde_json::Value) -> String {
    let mut v: serde_json::Value =
        serde_json::from_str(&Scene::builtin("drop").unwrap().to_json_pretty()).unwrap();
    v["obstacles"] = obstacles;
    v.to_string()
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("cloth-obstacles-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn every_primitive_works_as_safety_and_collider() {
    let dir = temp_dir("roles");
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    for role in ["safety", "collider", "both"] {
        let obstacles = serde_json::json!([
            {"type": "capsule", "a": [0.2, 0.2, 0.3], "b": [0.8, 0.8, 0.3], "radius": 0.1, "role": role},
            {"type": "box", "center": [0.5, 0.5, -0.2], "half_extents": [1.0, 1.0, 0.2],
             "rotation": [1.0, 0.0, 0.0, 0.1], "role": role},
            {"type": "mesh", "file": "cube.obj", "role": role}
        ]);
        let text = drop_with(obstacles);
        std::fs::write(dir.join("scene.json"), &text).unwrap();
        let scene = Scene::load(dir.join("scene.json")).unwrap();
        let model = Model::from_scene(&scene).unwrap();
        assert_eq!(
            model.colliders.component_count(),
            if role == "safety" { 0 } else { 3 }
        );
        assert_eq!(
            model.safety_obstacles.component_count(),
            if role == "collider" { 0 } else { 3 }
        );
        let u = scene.initial_controls();
        // `evaluate` fails on any non-finite metric or gradient entry.
        let eval = model.evaluate(&u, 0.01, true).unwrap();
        assert!(eval.grad_l.is_some() && eval.grad_c.is_some());
        if role != "safety" {
            // Colliders push every free particle out of every obstacle.
            let last = eval.states.last().unwrap();
            for p in 0..model.n_particles() {
                let x = last.row(p);
                let d = model.colliders.distance(&Vector3::new(x[0], x[1], x[2]));
                assert!(
                    d > -1e-6 || model.inv_mass[p] == 0.0,
                    "particle {p} at depth {d}"
                );
            }
        }
    }
}

#[test]
fn bad_obj_files_are_named() {
    let dir = temp_dir("bad");
    let cases = [
        ("missing.obj", None, "cannot read"),
        (
            "nan.obj",
            Some("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n"),
            "line 2",
        ),
        (
            "range.obj",
            Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
            "out of range",
        ),
        (
            "open.obj",
            Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            "open mesh",
        ),
        (
            "flat.obj",
            Some("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"),
            "degenerate",
        ),
    ];
    for (file, text, expect) in cases {
        if let Some(text) = text {
            std::fs::write(dir.join(file), text).unwrap();
        }
        let scene =
            drop_with(serde_json::json!([{"type": "mesh", "file": file, "role": "safety"}]));
        std::fs::write(dir.join("scene.json"), &scene).unwrap();
        let err = Scene::load(dir.join("scene.json")).unwrap_err().to_string();
        assert!(err.starts_with("obstacles[0].file: "), "{err}");
        assert!(err.contains(expect) && err.contains(file), "{file}: {err}");
    }
    // A non-manifold edge: three triangles on one edge.
    let text = format!("{CUBE_OBJ}v 0.0 -0.5 1.5\nf 1 2 9\n");
    std::fs::write(dir.join("fin.obj"), text).unwrap();
    let scene =
        drop_with(serde_json::json!([{"type": "mesh", "file": "fin.obj", "role": "safety"}]));
    std::fs::write(dir.join("scene.json"), &scene).unwrap();
    let err = Scene::load(dir.join("scene.json")).unwrap_err().to_string();
    assert!(err.contains("non-manifold"), "{err}");
}

#[test]
fn box_and_capsule_fields_are_validated() {
    let bad = [
        (
            serde_json::json!({"type": "capsule", "a": [0, 0, 0], "b": [1, 0, 0], "radius": 0, "role": "safety"}),
            "obstacles[0].radius",
        ),
        (
            serde_json::json!({"type": "box", "center": [0, 0, 0], "half_extents": [1, -1, 1], "role": "safety"}),
            "obstacles[0].half_extents[1]",
        ),
        (
            serde_json::json!({"type": "box", "center": [0, 0, 0], "half_extents": [1, 1, 1], "rotation": [0, 0, 0, 0], "role": "safety"}),
            "obstacles[0].rotation",
        ),
    ];
    for (obstacle, field) in bad {
        let err = Scene::from_json_str(&drop_with(serde_json::json!([obstacle])))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(&format!("{field}: ")), "{err}");
    }
}
