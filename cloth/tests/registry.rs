//! Constraint types registered by name and used from scene JSON (`custom_constraints`).

mod common;

use cloth::nalgebra::Vector3;
use cloth::scene::SceneError;
use cloth::{ClothError, ConstraintRegistry, Model, Scene};
use common::TriangleArea;
use serde_json::{json, Value};

/// A registry with `triangle_area`; its rest areas come from the rest positions, scaled by the
/// optional `params.scale`.
fn registry() -> ConstraintRegistry {
    let mut r = ConstraintRegistry::new();
    r.register("triangle_area", |input| {
        let scale = match &input.spec.params {
            Value::Null => 1.0,
            p => p["scale"]
                .as_f64()
                .ok_or("`scale` must be a number".to_string())?,
        };
        let rest = input
            .rest
            .chunks_exact(3)
            .map(|t| {
                scale
                    * TriangleArea::area(
                        &t.iter()
                            .map(|&[x, y, z]| Vector3::new(x, y, z))
                            .collect::<Vec<_>>(),
                    )
            })
            .collect();
        Ok(TriangleArea { rest })
    });
    r
}

/// A 4×4 swing-like scene (T = 3, 20 sweeps) as JSON.
fn small_swing() -> Value {
    let mut s = Scene::builtin("swing").unwrap().refined(4, 4).unwrap();
    s.physics.iterations = 20;
    s.task.horizon = 3;
    s.task.initial_controls = cloth::scene::InitialControls::Constant(vec![[0.0, 0.1, 0.05]; 2]);
    serde_json::from_str(&s.to_json_pretty()).unwrap()
}

/// Every triangle of the 4×4 grid as `[r, c]` triples, flattened.
fn triangles_rc(scene: &Scene) -> Vec<[usize; 2]> {
    let cols = scene.cloth.cols;
    scene
        .mesh()
        .triangles()
        .iter()
        .flatten()
        .map(|&p| [p / cols, p % cols])
        .collect()
}

fn with_custom(custom: Value) -> Value {
    let mut v = small_swing();
    v["custom_constraints"] = custom;
    v
}

fn field_of(err: ClothError) -> String {
    match err {
        ClothError::Scene(SceneError::Invalid { field, .. }) => field,
        other => panic!("expected a scene error naming a field, got {other}"),
    }
}

#[test]
fn a_registered_type_from_json_equals_the_hand_added_constraint() {
    let base = Scene::from_json_str(&small_swing().to_string()).unwrap();
    let particles = triangles_rc(&base);
    let v =
        with_custom(json!([{"type": "triangle_area", "particles": particles, "stiffness": 1e5}]));
    let text = v.to_string();
    let scene = Scene::from_json_str(&text).unwrap();
    // The field survives a round trip through the writer.
    assert_eq!(
        Scene::from_json_str(&scene.to_json_pretty()).unwrap(),
        scene
    );
    let from_json = Model::from_scene_with(&scene, &registry()).unwrap();
    let group = from_json.groups.last().unwrap();
    assert_eq!((group.name.as_str(), group.count), ("triangle_area", 18));

    // The same constraints added by hand to the plain model.
    let mut by_hand = Model::from_scene(&base).unwrap();
    let rest_pos = base.rest_positions();
    let tris = base.mesh().triangles().to_vec();
    let rest = tris
        .iter()
        .map(|t| {
            TriangleArea::area(
                &t.map(|p| Vector3::new(rest_pos[p][0], rest_pos[p][1], rest_pos[p][2])),
            )
        })
        .collect();
    let flat: Vec<usize> = tris.iter().flatten().copied().collect();
    by_hand
        .add_constraints("triangle_area", TriangleArea { rest }, flat, 1e5)
        .unwrap();

    let u = by_hand.zero_controls();
    let u = {
        let mut u = u;
        for (i, x) in u.data_mut().iter_mut().enumerate() {
            *x = 0.03 * ((i % 5) as f64 - 2.0);
        }
        u
    };
    let a = from_json.simulate(&u).unwrap();
    let b = by_hand.simulate(&u).unwrap();
    assert_eq!(a.last().unwrap().data(), b.last().unwrap().data());
    // And the constraint acts: without it the last state differs.
    let plain = Model::from_scene(&base).unwrap().simulate(&u).unwrap();
    assert_ne!(plain.last().unwrap().data(), a.last().unwrap().data());
    // Gradients flow through it: dL/dU exists and differs from the plain model's.
    let ev = from_json.evaluate(&u, 0.0, true).unwrap();
    let ev_plain = Model::from_scene(&base)
        .unwrap()
        .evaluate(&u, 0.0, true)
        .unwrap();
    assert_ne!(ev.grad_l.unwrap().data(), ev_plain.grad_l.unwrap().data());
}

#[test]
fn unknown_types_are_named_errors_listing_the_registered_ones() {
    let v = with_custom(
        json!([{"type": "glue", "particles": [[0, 0], [0, 1], [1, 1]], "stiffness": 1.0}]),
    );
    let scene = Scene::from_json_str(&v.to_string()).unwrap();
    let err = Model::from_scene_with(&scene, &registry())
        .err()
        .unwrap()
        .to_string();
    assert_eq!(
        err,
        "custom_constraints[0].type: unknown constraint type `glue` (registered: triangle_area)"
    );
    let err = Model::from_scene(&scene).err().unwrap().to_string();
    assert!(err.contains("registered: none"), "{err}");
    assert_eq!(registry().names(), vec!["triangle_area"]);
}

#[test]
fn bad_entries_name_their_field() {
    let tri = json!([[0, 0], [0, 1], [1, 1]]);
    // Validation (no registry needed): particles on the grid, a valid stiffness.
    for (custom, field) in [
        (
            json!([{"type": "triangle_area", "particles": [[0, 0], [4, 1], [1, 1]], "stiffness": 1.0}]),
            "custom_constraints[0].particles[1]",
        ),
        (
            json!([{"type": "triangle_area", "particles": tri, "stiffness": -1.0}]),
            "custom_constraints[0].stiffness",
        ),
    ] {
        match Scene::from_json_str(&with_custom(custom).to_string()) {
            Err(SceneError::Invalid { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: expected Invalid, got {other:?}"),
        }
    }
    // Model building: the arity, the builder's parameters, the constraint's own checks.
    for (custom, field) in [
        (
            json!([{"type": "triangle_area", "particles": [[0, 0], [0, 1]], "stiffness": 1.0}]),
            "custom_constraints[0].particles",
        ),
        (
            json!([
                {"type": "triangle_area", "particles": tri, "stiffness": 1.0},
                {"type": "triangle_area", "particles": tri, "stiffness": 1.0, "params": {"scale": "big"}}
            ]),
            "custom_constraints[1].params",
        ),
    ] {
        let scene = Scene::from_json_str(&with_custom(custom).to_string()).unwrap();
        assert_eq!(
            field_of(Model::from_scene_with(&scene, &registry()).err().unwrap()),
            field
        );
    }
    // Unknown keys are rejected like everywhere else in the format.
    let v =
        with_custom(json!([{"type": "triangle_area", "particles": tri, "stiffness": 1.0, "k": 2}]));
    assert!(matches!(
        Scene::from_json_str(&v.to_string()),
        Err(SceneError::Parse { .. })
    ));
    // A scene with custom constraints is not refined to another grid (their particles would not map).
    let scene = Scene::from_json_str(
        &with_custom(json!([{"type": "triangle_area", "particles": tri, "stiffness": 1.0}]))
            .to_string(),
    )
    .unwrap();
    match scene.refined(5, 5) {
        Err(SceneError::Invalid { field, .. }) => assert_eq!(field, "custom_constraints"),
        other => panic!("expected Invalid, got {other:?}"),
    }
}
