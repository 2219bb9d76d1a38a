//! Unit tests of the scene format and its validation; the built-ins in `builtins.rs`.

use super::*;
use serde_json::{json, Value};

mod builtins;

fn base_value() -> Value {
    serde_json::from_str(BUILTIN_SOURCES[0]).expect("u_obstacle parses")
}

/// Applies `edit` to the u_obstacle JSON, parses it and returns the validation error.
fn invalid_after(edit: impl FnOnce(&mut Value)) -> (String, String) {
    let mut v = base_value();
    edit(&mut v);
    match Scene::from_json_str(&v.to_string()) {
        Err(e @ SceneError::Invalid { .. }) => {
            let display = e.to_string();
            let SceneError::Invalid { field, .. } = e else {
                unreachable!()
            };
            (field, display)
        }
        other => panic!("expected SceneError::Invalid, got {other:?}"),
    }
}

/// Applies `edit` to the built-in u_obstacle scene struct and returns the validation error.
fn invalid_struct(edit: impl FnOnce(&mut Scene)) -> (String, String) {
    let mut s = Scene::builtin("u_obstacle").expect("builtin");
    edit(&mut s);
    match s.validate() {
        Err(e @ SceneError::Invalid { .. }) => {
            let display = e.to_string();
            let SceneError::Invalid { field, .. } = e else {
                unreachable!()
            };
            (field, display)
        }
        other => panic!("expected SceneError::Invalid, got {other:?}"),
    }
}

fn parse_error_after(edit: impl FnOnce(&mut Value)) -> String {
    let mut v = base_value();
    edit(&mut v);
    let text = serde_json::to_string_pretty(&v).expect("to json");
    match Scene::from_json_str(&text) {
        Err(e @ SceneError::Parse { .. }) => e.to_string(),
        other => panic!("expected SceneError::Parse, got {other:?}"),
    }
}

fn set(v: &mut Value, pointer: &str, x: Value) {
    *v.pointer_mut(pointer)
        .unwrap_or_else(|| panic!("{pointer}")) = x;
}

/// A rejection names `expected` as its field, its message starts with that path and gives `reason`.
fn assert_names_field(field: &str, msg: &str, expected: &str, reason: &str) {
    assert_eq!(field, expected, "message: {msg}");
    assert!(msg.starts_with(&format!("{expected}: ")), "{msg}");
    assert!(msg.contains(reason), "{msg}");
}

/// One test per rejection case (JSON edit): asserts the exact field path and that the one-line
/// message starts with it.
macro_rules! rejects {
    ($name:ident, $field:expr, $reason:expr, |$v:ident| $edit:expr) => {
        #[test]
        fn $name() {
            let (field, msg) = invalid_after(|$v: &mut Value| {
                $edit;
            });
            assert_names_field(&field, &msg, $field, $reason);
            assert!(!msg.contains('\n'), "{msg}");
        }
    };
}

/// One test per rejection case that JSON cannot express (non-finite numbers): edits the struct.
macro_rules! rejects_struct {
    ($name:ident, $field:expr, $reason:expr, |$s:ident| $edit:expr) => {
        #[test]
        fn $name() {
            let (field, msg) = invalid_struct(|$s: &mut Scene| {
                $edit;
            });
            assert_names_field(&field, &msg, $field, $reason);
        }
    };
}

// --- cloth ---
rejects!(rows_zero, "cloth.rows", "at least 1", |v| set(
    v,
    "/cloth/rows",
    json!(0)
));
rejects!(cols_zero, "cloth.cols", "at least 1", |v| set(
    v,
    "/cloth/cols",
    json!(0)
));
rejects!(too_many_particles, "cloth", "exceed the limit", |v| {
    set(v, "/cloth/rows", json!(100_000));
    set(v, "/cloth/cols", json!(100_000));
});
rejects!(rows_times_cols_overflow, "cloth", "exceed the limit", |v| {
    set(v, "/cloth/rows", json!(u64::MAX));
    set(v, "/cloth/cols", json!(3));
});
rejects!(right_zero, "cloth.right", "zero-length", |v| set(
    v,
    "/cloth/right",
    json!([0.0, 0.0, 0.0])
));
rejects!(down_zero, "cloth.down", "zero-length", |v| set(
    v,
    "/cloth/down",
    json!([0.0, 0.0, 0.0])
));
rejects!(right_down_parallel, "cloth.down", "parallel", |v| set(
    v,
    "/cloth/down",
    json!([-2.0, 0.0, 0.0])
));
rejects!(mass_zero, "cloth.particle_mass", "positive", |v| set(
    v,
    "/cloth/particle_mass",
    json!(0.0)
));
rejects!(mass_negative, "cloth.particle_mass", "-1", |v| set(
    v,
    "/cloth/particle_mass",
    json!(-1.0)
));
rejects_struct!(top_left_nan, "cloth.top_left[1]", "finite", |s| s
    .cloth
    .top_left[1] =
    f64::NAN);
rejects_struct!(right_inf, "cloth.right[0]", "finite", |s| s.cloth.right
    [0] =
    f64::INFINITY);
rejects_struct!(down_nan, "cloth.down[2]", "finite", |s| s.cloth.down[2] =
    f64::NAN);
rejects_struct!(mass_nan, "cloth.particle_mass", "finite", |s| s
    .cloth
    .particle_mass =
    f64::NAN);

// --- material ---
rejects!(stretch_negative, "material.stretch", "positive", |v| set(
    v,
    "/material/stretch",
    json!(-5.0)
));
rejects!(stretch_zero, "material.stretch", "positive", |v| set(
    v,
    "/material/stretch",
    json!(0)
));
rejects!(
    bending_stiffness_zero,
    "material.bending.stiffness",
    "positive",
    |v| set(v, "/material/bending/stiffness", json!(0.0))
);
rejects_struct!(stretch_nan, "material.stretch", "finite", |s| s
    .material
    .stretch =
    Stiffness::Finite(f64::NAN));
rejects_struct!(stretch_finite_inf, "material.stretch", "finite", |s| s
    .material
    .stretch =
    Stiffness::Finite(f64::INFINITY));

// --- physics ---
rejects!(dt_zero, "physics.dt", "positive", |v| set(
    v,
    "/physics/dt",
    json!(0.0)
));
rejects!(dt_negative, "physics.dt", "positive", |v| set(
    v,
    "/physics/dt",
    json!(-0.1)
));
rejects!(
    iterations_zero,
    "physics.iterations",
    "at least 1",
    |v| set(v, "/physics/iterations", json!(0))
);
rejects_struct!(gravity_nan, "physics.gravity[2]", "finite", |s| s
    .physics
    .gravity[2] =
    f64::NAN);
rejects_struct!(dt_nan, "physics.dt", "finite", |s| s.physics.dt = f64::NAN);

// --- controls ---
rejects!(
    control_row_out_of_range,
    "controls[1]",
    "row 10 out of range (cloth.rows = 10)",
    |v| set(v, "/controls/1", json!([10, 0]))
);
rejects!(
    control_col_out_of_range,
    "controls[0]",
    "col 11 out of range (cloth.cols = 10)",
    |v| set(v, "/controls/0", json!([0, 11]))
);
rejects!(
    control_duplicated,
    "controls[2]",
    "particle (0, 9) duplicates controls[1]",
    |v| {
        set(v, "/controls", json!([[0, 0], [0, 9], [0, 9]]));
        set(v, "/task/initial_controls", json!("zeros"));
    }
);

// --- obstacles ---
rejects!(
    spheres_length_mismatch,
    "obstacles[0].radii",
    "17 radii for 18 centers",
    |v| {
        let radii = v
            .pointer_mut("/obstacles/0/radii")
            .and_then(Value::as_array_mut)
            .expect("radii");
        radii.pop();
    }
);
rejects!(
    spheres_empty,
    "obstacles[0].centers",
    "at least one sphere",
    |v| {
        set(v, "/obstacles/0/centers", json!([]));
        set(v, "/obstacles/0/radii", json!([]));
    }
);
rejects!(
    sphere_radius_zero,
    "obstacles[0].radii[3]",
    "positive",
    |v| { set(v, "/obstacles/0/radii/3", json!(0.0)) }
);
rejects!(
    sphere_radius_negative,
    "obstacles[0].radii[17]",
    "-0.25",
    |v| set(v, "/obstacles/0/radii/17", json!(-0.25))
);
rejects_struct!(
    sphere_center_nan,
    "obstacles[0].centers[2][0]",
    "finite",
    |s| {
        if let Obstacle::Spheres(sp) = &mut s.obstacles[0] {
            sp.centers[2][0] = f64::NAN;
        }
    }
);
rejects!(
    plane_normal_zero,
    "obstacles[1].normal",
    "nonzero normal",
    |v| {
        let obs = v
            .pointer_mut("/obstacles")
            .and_then(Value::as_array_mut)
            .expect("obstacles");
        obs.push(
            json!({"type": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 0.0],
                        "role": "collider"}),
        );
    }
);
rejects_struct!(plane_point_nan, "obstacles[1].point[2]", "finite", |s| {
    s.obstacles.push(Obstacle::Plane(PlaneSpec {
        point: [0.0, 0.0, f64::NAN],
        normal: [0.0, 0.0, 1.0],
        role: ObstacleRole::Both,
        friction: None,
    }))
});

// --- task ---
rejects!(horizon_zero, "task.horizon", "at least 1", |v| set(
    v,
    "/task/horizon",
    json!(0)
));
rejects!(horizon_huge, "task.horizon", "limit", |v| set(
    v,
    "/task/horizon",
    json!(u64::MAX)
));
rejects!(targets_empty, "task.targets", "at least one target", |v| {
    set(v, "/task/targets", json!([]))
});
rejects!(
    target_row_out_of_range,
    "task.targets[3].particle",
    "task.targets[3].particle: row 12 out of range (cloth.rows = 10)",
    |v| set(v, "/task/targets/3/particle", json!([12, 3]))
);
rejects!(
    target_col_out_of_range,
    "task.targets[9].particle",
    "col 10 out of range (cloth.cols = 10)",
    |v| set(v, "/task/targets/9/particle", json!([9, 10]))
);
rejects!(
    target_duplicated,
    "task.targets[4].particle",
    "particle (9, 0) duplicates task.targets[0]",
    |v| set(v, "/task/targets/4/particle", json!([9, 0]))
);
rejects_struct!(
    target_position_nan,
    "task.targets[0].position[1]",
    "finite",
    |s| s.task.targets[0].position[1] = f64::NAN
);
rejects!(alpha_negative, "task.alpha", "non-negative", |v| set(
    v,
    "/task/alpha",
    json!(-1.0)
));
rejects!(beta_negative, "task.beta", "non-negative", |v| set(
    v,
    "/task/beta",
    json!(-1e-4)
));
rejects!(delta_negative, "task.delta", "non-negative", |v| set(
    v,
    "/task/delta",
    json!(-0.2)
));
rejects_struct!(alpha_inf, "task.alpha", "finite", |s| s.task.alpha =
    f64::INFINITY);
rejects!(
    constant_controls_wrong_count,
    "task.initial_controls.constant",
    "1 vector given, need one per control particle (2)",
    |v| set(
        v,
        "/task/initial_controls",
        json!({"constant": [[0.0, 0.3, 0.0]]})
    )
);
rejects_struct!(
    constant_controls_nan,
    "task.initial_controls.constant[1][2]",
    "finite",
    |s| s.task.initial_controls = InitialControls::Constant(vec![[0.0; 3], [0.0, 0.0, f64::NAN]])
);
rejects!(
    explicit_controls_wrong_horizon,
    "task.initial_controls.explicit",
    "3 steps given, need task.horizon = 10",
    |v| set(
        v,
        "/task/initial_controls",
        json!({"explicit": vec![vec![[0.0, 0.0, 0.0]; 2]; 3]})
    )
);
rejects!(
    explicit_controls_wrong_count,
    "task.initial_controls.explicit[4]",
    "1 vector given, need one per control particle (2)",
    |v| {
        let mut steps = vec![vec![[0.0, 0.0, 0.0]; 2]; 10];
        steps[4].pop();
        set(v, "/task/initial_controls", json!({ "explicit": steps }));
    }
);
rejects_struct!(
    explicit_controls_nan,
    "task.initial_controls.explicit[9][0][0]",
    "finite",
    |s| {
        let mut steps = vec![vec![[0.0; 3]; 2]; 10];
        steps[9][0][0] = f64::NEG_INFINITY;
        s.task.initial_controls = InitialControls::Explicit(steps);
    }
);

// --- parse errors (serde names the field) ---
// --- task.limits ---
rejects!(
    max_step_zero,
    "task.limits.max_step",
    "must be positive",
    |v| v["task"]["limits"] = json!({"max_step": 0.0})
);
rejects!(
    max_strain_negative,
    "task.limits.max_strain",
    "must be positive",
    |v| v["task"]["limits"] = json!({"max_strain": -0.1})
);
rejects!(
    workspace_inverted,
    "task.limits.workspace.min[2]",
    "exceeds max[2]",
    |v| v["task"]["limits"] = json!({"workspace": {"min": [-5, -5, 3], "max": [5, 5, 1]}})
);
rejects!(
    workspace_excludes_start,
    "task.limits.workspace",
    "control point (0, 0) starts outside it",
    |v| v["task"]["limits"] = json!({"workspace": {"min": [-5, -5, 2.5], "max": [5, 5, 5]}})
);
rejects!(
    separation_inverted,
    "task.limits.gripper_separation",
    "min 2 exceeds max 1",
    |v| v["task"]["limits"] = json!({"gripper_separation": [2.0, 1.0]})
);
rejects!(
    separation_max_zero,
    "task.limits.gripper_separation[1]",
    "must be positive",
    |v| v["task"]["limits"] = json!({"gripper_separation": [0.0, 0.0]})
);
rejects!(
    separation_excludes_start,
    "task.limits.gripper_separation",
    "start 1 apart",
    |v| v["task"]["limits"] = json!({"gripper_separation": [0.2, 0.5]})
);
rejects_struct!(max_step_nan, "task.limits.max_step", "finite", |s| s
    .task
    .limits
    .max_step =
    Some(f64::NAN));

#[test]
fn limits_round_trip_and_reject_unknown_fields() {
    let mut v = base_value();
    v["task"]["limits"] = json!({"max_step": 0.5, "max_strain": 0.5});
    let scene = Scene::from_json_str(&v.to_string()).expect("valid");
    assert_eq!(scene.task.limits.max_step, Some(0.5));
    assert_eq!(scene.task.limits.workspace, None);
    let back = Scene::from_json_str(&scene.to_json_pretty()).expect("round trip");
    assert_eq!(back, scene);
    // No limits: the field is left out, so limit-free scenes print as before.
    let plain = Scene::builtin("u_obstacle").expect("builtin");
    assert!(!plain.to_json_pretty().contains("limits"));
    let msg = parse_error_after(|v| v["task"]["limits"] = json!({"max_speed": 1.0}));
    assert!(msg.contains("max_speed"), "{msg}");
}

#[test]
fn unknown_top_level_field() {
    let msg = parse_error_after(|v| {
        v["colour"] = json!("red");
    });
    assert!(msg.contains("unknown field `colour`"), "{msg}");
    assert!(msg.contains("line"), "{msg}");
}

#[test]
fn unknown_nested_fields() {
    let msg = parse_error_after(|v| v["cloth"]["side"] = json!(1.0));
    assert!(msg.contains("unknown field `side`"), "{msg}");
    let msg = parse_error_after(|v| v["material"]["bending"]["kind"] = json!(1.0));
    assert!(msg.contains("unknown field `kind`"), "{msg}");
    let msg = parse_error_after(|v| v["physics"]["substeps"] = json!(2));
    assert!(msg.contains("unknown field `substeps`"), "{msg}");
    let msg = parse_error_after(|v| v["task"]["targets"][0]["weight"] = json!(2));
    assert!(msg.contains("unknown field `weight`"), "{msg}");
    let msg = parse_error_after(|v| v["task"]["gamma"] = json!(2));
    assert!(msg.contains("unknown field `gamma`"), "{msg}");
}

#[test]
fn unknown_obstacle_field_and_type() {
    let msg = parse_error_after(|v| v["obstacles"][0]["color"] = json!("red"));
    assert!(msg.contains("unknown field `color`"), "{msg}");
    let msg = parse_error_after(|v| v["obstacles"][0]["type"] = json!("cube"));
    assert!(msg.contains("unknown variant `cube`"), "{msg}");
    let msg = parse_error_after(|v| {
        v["obstacles"] = json!([{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                                 "role": "collider", "radii": [1.0]}]);
    });
    assert!(msg.contains("unknown field `radii`"), "{msg}");
}

#[test]
fn missing_fields() {
    let msg = parse_error_after(|v| {
        v.as_object_mut().expect("object").remove("task");
    });
    assert!(msg.contains("missing field `task`"), "{msg}");
    let msg = parse_error_after(|v| {
        v["physics"].as_object_mut().expect("object").remove("dt");
    });
    assert!(msg.contains("missing field `dt`"), "{msg}");
    let msg = parse_error_after(|v| {
        v["obstacles"][0]
            .as_object_mut()
            .expect("object")
            .remove("role");
    });
    assert!(msg.contains("missing field `role`"), "{msg}");
}

#[test]
fn wrong_types_show_the_line() {
    let msg = parse_error_after(|v| v["physics"]["dt"] = json!("fast"));
    assert!(msg.contains("invalid type: string \"fast\""), "{msg}");
    assert!(msg.contains("\"dt\": \"fast\""), "source line shown: {msg}");
    let msg = parse_error_after(|v| v["cloth"]["rows"] = json!(-3));
    assert!(msg.contains("\"rows\": -3"), "{msg}");
    let msg = parse_error_after(|v| v["cloth"]["top_left"] = json!([0.0, 1.0]));
    assert!(msg.contains("expected an array of length 3"), "{msg}");
    let msg = parse_error_after(|v| v["material"]["stretch"] = json!("infinite"));
    assert!(msg.contains("\"inf\""), "{msg}");
    let msg = parse_error_after(|v| v["material"]["bending"]["model"] = json!("cubic"));
    assert!(msg.contains("unknown variant `cubic`"), "{msg}");
    let msg = parse_error_after(|v| v["obstacles"][0]["role"] = json!("wall"));
    assert!(msg.contains("unknown variant `wall`"), "{msg}");
    let msg = parse_error_after(|v| v["task"]["initial_controls"] = json!("ones"));
    assert!(msg.contains("unknown variant `ones`"), "{msg}");
}

#[test]
fn malformed_json() {
    let err = Scene::from_json_str("{ \"name\": \"x\", ").expect_err("malformed");
    assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
    assert!(err.to_string().contains("line 1"), "{err}");
    let err = Scene::from_json_str("").expect_err("empty");
    assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
    // numbers too large for f64 are refused by the parser, never turned into infinity
    let text = BUILTIN_SOURCES[0].replace("\"dt\": 0.1", "\"dt\": 1e400");
    let err = Scene::from_json_str(&text).expect_err("overflow");
    assert!(err.to_string().contains("out of range"), "{err}");
}

#[test]
fn io_error_and_unknown_builtin() {
    let err = Scene::load("/nonexistent/dir/scene.json").expect_err("missing file");
    assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
    assert!(
        err.to_string().contains("/nonexistent/dir/scene.json"),
        "{err}"
    );
    let err = Scene::builtin("U").expect_err("unknown");
    assert!(matches!(err, SceneError::UnknownBuiltin { ref name } if name == "U"));
    assert!(err.to_string().contains("u_obstacle, swing, drop"), "{err}");
}

// --- accepted edge cases and defaults ---
#[test]
fn minimal_scene_gets_defaults() {
    let text = r#"{
        "name": "rope",
        "cloth": {"rows": 1, "cols": 4, "top_left": [0, 0, 1], "right": [3, 0, 0], "down": [0, 0, 0]},
        "material": {"stretch": "inf"},
        "physics": {"dt": 0.05, "gravity": [0, 0, 0], "iterations": 5},
        "controls": [],
        "task": {"horizon": 2, "targets": [{"particle": [0, 3], "position": [1, 1, 1]}],
                 "alpha": 0, "beta": 0, "initial_controls": "zeros"}
    }"#;
    let s = Scene::from_json_str(text).expect("valid");
    assert_eq!(s.description, "");
    assert_eq!(s.cloth.particle_mass, 1.0);
    assert_eq!(s.material.bending, None);
    assert!(s.obstacles.is_empty());
    assert_eq!(s.task.delta, 0.0);
    assert_eq!(s.material.stretch, Stiffness::Infinite);
    assert_eq!(s.material.stretch.compliance(0.05), 0.0);
    assert_eq!(s.material.stretch.value(), f64::INFINITY);
    assert!(s.control_indices().is_empty());
    assert_eq!(s.initial_controls_array(), vec![Vec::<[f64; 3]>::new(); 2]);
    assert_eq!(
        s.rest_positions(),
        vec![
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [2.0, 0.0, 1.0],
            [3.0, 0.0, 1.0]
        ]
    );
    assert_eq!(s.target_indices(), vec![3]);
    // round trip (bending absent, stiffness "inf")
    let back = Scene::from_json_str(&s.to_json_pretty()).expect("round trip");
    assert_eq!(back, s);
    assert!(s.to_json_pretty().contains("\"stretch\": \"inf\""));
    assert!(!s.to_json_pretty().contains("bending"));
}

#[test]
fn single_particle_and_default_bending_model() {
    let text = r#"{
        "name": "dot",
        "cloth": {"rows": 1, "cols": 1, "top_left": [0, 0, 0], "right": [0, 0, 0], "down": [0, 0, 0],
                  "particle_mass": 0.5},
        "material": {"stretch": 10, "bending": {"stiffness": 2}},
        "physics": {"dt": 1, "gravity": [0, 0, -1], "iterations": 1},
        "controls": [[0, 0]],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 3, 4], "role": "both"}],
        "task": {"horizon": 1, "targets": [{"particle": [0, 0], "position": [0, 0, 0]}],
                 "alpha": 1, "beta": 1, "delta": 0.1, "initial_controls": {"explicit": [[[1, 2, 3]]]}}
    }"#;
    let s = Scene::from_json_str(text).expect("valid");
    let b = s.material.bending.as_ref().expect("bending");
    assert_eq!(b.model, BendingModel::Distance);
    assert_eq!(b.stiffness, Stiffness::Finite(2.0));
    assert_eq!(s.rest_positions(), vec![[0.0, 0.0, 0.0]]);
    assert_eq!(s.initial_controls_array(), vec![vec![[1.0, 2.0, 3.0]]]);
    let Obstacle::Plane(p) = &s.obstacles[0] else {
        panic!("plane expected")
    };
    assert_eq!(p.normal, [0.0, 3.0, 4.0], "stored as written");
    assert_eq!(p.normalized(), [0.0, 0.6, 0.8]);
    assert!(p.role.is_safety() && p.role.is_collider());
    assert_eq!(Scene::from_json_str(&s.to_json_pretty()).expect("rt"), s);
}

#[test]
fn zero_right_allowed_for_single_column() {
    let mut v = base_value();
    set(&mut v, "/cloth/cols", json!(1));
    set(&mut v, "/cloth/right", json!([0.0, 0.0, 0.0]));
    set(&mut v, "/controls", json!([[0, 0]]));
    set(
        &mut v,
        "/task/targets",
        json!([{"particle": [9, 0], "position": [0, 0, 0]}]),
    );
    set(&mut v, "/task/initial_controls", json!("zeros"));
    let s = Scene::from_json_str(&v.to_string()).expect("valid");
    let x = s.rest_positions();
    assert_eq!(x.len(), 10);
    assert_eq!(x[9], [-0.5, -1.5, 1.0]);
    assert_eq!(s.mesh().stretch_edges().len(), 9);
}

#[test]
fn no_controls_is_allowed() {
    let mut v = base_value();
    set(&mut v, "/controls", json!([]));
    set(&mut v, "/task/initial_controls", json!({"constant": []}));
    let s = Scene::from_json_str(&v.to_string()).expect("valid");
    assert_eq!(s.initial_controls_array().len(), 10);
    assert!(s.initial_controls_array().iter().all(Vec::is_empty));
}

#[test]
fn stiffness_compliance_and_value() {
    let k = Stiffness::Finite(1e4);
    assert_eq!(k.value(), 1e4);
    assert_eq!(k.compliance(0.1), (1.0 / 1e4) / (0.1 * 0.1));
    assert!((k.compliance(0.1) - 0.01).abs() < 1e-17);
    assert_eq!(Stiffness::Finite(1e2).compliance(0.1), 0.9999999999999998);
    assert!(!k.is_infinite() && Stiffness::Infinite.is_infinite());
    assert_eq!(Stiffness::Infinite.compliance(0.1), 0.0);
    assert_eq!(Stiffness::Infinite.value(), f64::INFINITY);
    let parsed: Stiffness = serde_json::from_str("25").expect("int");
    assert_eq!(parsed, Stiffness::Finite(25.0));
    let parsed: Stiffness = serde_json::from_str("\"inf\"").expect("inf");
    assert_eq!(parsed, Stiffness::Infinite);
    assert!(serde_json::from_str::<Stiffness>("\"Infinity\"").is_err());
    assert!(serde_json::from_str::<Stiffness>("null").is_err());
}

#[test]
fn json_floats_read_back_bit_identically() {
    // Values serde_json misreads by one ulp without `float_roundtrip`.
    let xs: [f64; 5] = [
        1.0833333333333335,
        0.6666666666666667,
        0.1 + 0.2,
        1e-300,
        -2.5e17,
    ];
    let text = to_json_pretty_compact(&xs.to_vec()).unwrap();
    let back: Vec<f64> = serde_json::from_str(&text).unwrap();
    for (x, y) in xs.iter().zip(&back) {
        assert_eq!(x.to_bits(), y.to_bits(), "{x} read back as {y}");
    }
}

#[test]
fn inline_arrays_only_when_scalar() {
    let text = to_json_pretty_compact(
        &json!({"a": [1.5, 2, 3], "b": [[1, 2], [3, 4]], "c": ["x", "[y]"],
                                            "d": []}),
    )
    .expect("json");
    assert!(text.contains("\"a\": [1.5, 2, 3]"), "{text}");
    assert!(text.contains("[1, 2]") && text.contains("[3, 4]"), "{text}");
    assert!(text.contains("\"[y]\""), "{text}");
    let back: Value = serde_json::from_str(&text).expect("valid");
    assert_eq!(back["c"][1], "[y]");
    assert_eq!(back["d"], json!([]));
}

#[test]
fn roles() {
    assert!(ObstacleRole::Safety.is_safety() && !ObstacleRole::Safety.is_collider());
    assert!(!ObstacleRole::Collider.is_safety() && ObstacleRole::Collider.is_collider());
    assert!(ObstacleRole::Both.is_safety() && ObstacleRole::Both.is_collider());
}

// --- built-in scenes ---

#[test]
fn solver_kind_names_round_trip_through_json_and_from_str() {
    for kind in SolverKind::ALL {
        let json = serde_json::to_string(&kind).expect("serializes");
        assert_eq!(json, format!("\"{}\"", kind.name()));
        assert_eq!(kind.name().parse::<SolverKind>(), Ok(kind));
        assert_eq!(kind.to_string(), kind.name());
    }
    let err = "jacobi".parse::<SolverKind>().unwrap_err();
    assert!(
        err.contains("\"jacobi\"") && err.contains("newton"),
        "{err}"
    );
}

/// `physics.contact`: each bad setting names its field.
#[test]
fn contact_settings_out_of_range_name_their_field() {
    fn with_contact(solver: &'static str, contact: Value) -> impl FnOnce(&mut Value) {
        move |v: &mut Value| {
            v["physics"]["solver"] = json!(solver);
            v["physics"]["contact"] = contact;
        }
    }
    let cases = [
        (
            with_contact("xpbd", json!({"model": "smooth"})),
            "physics.contact.model",
            "needs physics.solver \"newton\"",
        ),
        (
            with_contact("newton", json!({"model": "smooth", "d_hat": -0.01})),
            "physics.contact.d_hat",
            "must be positive",
        ),
        (
            with_contact("newton", json!({"model": "smooth", "d_hat": 1e12})),
            "physics.contact.d_hat",
            "exceeds the limit",
        ),
        (
            with_contact("newton", json!({"model": "smooth", "stiffness": 0.0})),
            "physics.contact.stiffness",
            "must be positive",
        ),
        (
            with_contact("newton", json!({"model": "rigid", "d_hat": 0.01})),
            "physics.contact.d_hat",
            "only the smooth contact model",
        ),
        (
            with_contact("xpbd", json!({"model": "rigid", "stiffness": 10.0})),
            "physics.contact.stiffness",
            "only the smooth contact model",
        ),
    ];
    for (edit, expected, reason) in cases {
        let (field, msg) = invalid_after(edit);
        assert_names_field(&field, &msg, expected, reason);
    }
    // A valid smooth setting passes validation.
    let mut v = base_value();
    with_contact(
        "newton",
        json!({"model": "smooth", "d_hat": 0.02, "stiffness": 50.0}),
    )(&mut v);
    Scene::from_json_str(&v.to_string()).expect("valid smooth contact");
}

/// Friction under Newton needs the smooth contact model; its smoothing displacement is checked.
#[test]
fn newton_friction_needs_the_smooth_model() {
    let frictional_floor = |v: &mut Value| {
        v["physics"]["solver"] = json!("newton");
        v["obstacles"] = json!([{"type": "plane", "point": [0, 0, -5], "normal": [0, 0, 1],
                                 "role": "collider", "friction": 0.4}]);
    };
    let (field, msg) = invalid_after(|v| {
        frictional_floor(v);
        v["physics"]["contact"] = json!({"model": "rigid"});
    });
    assert_names_field(
        &field,
        &msg,
        "obstacles[0].friction",
        "needs the smooth contact model",
    );
    // Naming no model is the smooth one under Newton with colliders.
    let mut v = base_value();
    frictional_floor(&mut v);
    let s: Scene = serde_json::from_value(v).unwrap();
    s.validate().unwrap();
    let (field, msg) = invalid_after(|v| {
        frictional_floor(v);
        v["physics"]["contact"] = json!({"model": "smooth", "friction_epsilon": -1.0});
    });
    assert_names_field(
        &field,
        &msg,
        "physics.contact.friction_epsilon",
        "must be positive",
    );
    let mut v = base_value();
    frictional_floor(&mut v);
    v["physics"]["contact"] = json!({"model": "smooth"});
    Scene::from_json_str(&v.to_string()).expect("friction under the smooth model");
}
