//! Bad input gets one readable line and loses nothing (issue 7, item 3).
//!
//! Every case runs the `clothopt` binary and asserts: exit code 1 (not a panic's 101), exactly one
//! line on stderr, starting `error: ` and naming the field, flag or position. Cases that would
//! write a result (`--out` into the case's directory) also assert that no output file and no
//! temporary file is left there (results are written through a temporary file and a rename, and
//! only after everything succeeded); the few cases without `--out` (`grad`, unknown scenes) have
//! nothing to leave behind. Scene cases also check the
//! library's error: [`SceneError::Invalid`] with the exact field path, or [`SceneError::Parse`]
//! with the line and column.

mod common;

use cloth::scene::SceneError;
use cloth::Scene;
use common::*;
use serde_json::{json, Value};
use std::path::Path;
use std::process::Output;

/// Asserts the clean failure described in the module docs; `inputs` are the files the test
/// itself wrote into `dir` (everything else there would be left behind by the binary).
fn fails_cleanly(o: &Output, expected: &[&str], dir: &Path, inputs: &[&str]) -> String {
    let err = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "exit status {:?}\nstdout: {}\nstderr: {err}",
        o.status,
        stdout(o)
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line:\n{err}");
    assert!(err.starts_with("error: "), "{err}");
    for e in expected {
        assert!(err.contains(e), "`{e}` missing from: {err}");
    }
    let mut left = files_in(dir);
    left.retain(|f| !inputs.contains(&f.as_str()));
    assert!(left.is_empty(), "left behind: {left:?} ({err})");
    err
}

/// The `swing` scene as a JSON value.
fn swing() -> Value {
    serde_json::from_str(&Scene::builtin("swing").unwrap().to_json_pretty()).unwrap()
}

/// A small `swing` (4×4, T = 3, 10 iterations) as a JSON value, for the optimize cases.
fn small_swing() -> Value {
    let mut s = small(4, 4, 3, 10);
    s.name = "small_swing".into();
    serde_json::from_str(&s.to_json_pretty()).unwrap()
}

/// Runs `clothopt simulate SCENE --out out.json` on `text` in a fresh directory; returns the
/// output and the directory.
fn simulate_text(name: &str, text: &str) -> (Output, common::Scratch) {
    let dir = scratch("bad", name);
    let path = dir.join("scene.json");
    std::fs::write(&path, text).unwrap();
    let o = run(bin()
        .arg("simulate")
        .arg(&path)
        .arg("--out")
        .arg(dir.join("out.json")));
    (o, dir)
}

/// A scene text must fail to load: through the library with `Invalid { field }` (when `field` is
/// given) or a `Parse` error, and through the CLI with one line containing `expected`.
fn rejects_scene(name: &str, text: &str, field: Option<&str>, expected: &[&str]) -> String {
    match (Scene::from_json_str(text), field) {
        (Err(SceneError::Invalid { field: f, .. }), Some(want)) => assert_eq!(f, want, "{name}"),
        (Err(e @ SceneError::Parse { .. }), None) => {
            let msg = e.to_string();
            assert!(msg.contains("line") && msg.contains("column"), "{msg}");
        }
        (other, _) => panic!("{name}: unexpected {other:?}"),
    }
    let (o, dir) = simulate_text(name, text);
    fails_cleanly(&o, expected, &dir, &["scene.json"])
}

/// `swing` with one JSON-pointer edit.
fn edited(pointer: &str, value: Value) -> String {
    let mut v = swing();
    *v.pointer_mut(pointer).unwrap() = value;
    serde_json::to_string_pretty(&v).unwrap()
}

/// `swing`'s pretty JSON with a textual substitution (for what `Value` cannot hold).
fn substituted(from: &str, to: &str) -> String {
    let text = serde_json::to_string_pretty(&swing()).unwrap();
    assert!(text.contains(from), "{from}");
    text.replacen(from, to, 1)
}

#[test]
fn malformed_json() {
    let text = serde_json::to_string_pretty(&swing()).unwrap();
    let truncated = &text[..text.len() / 2];
    let err = rejects_scene(
        "truncated",
        truncated,
        None,
        &["invalid scene JSON", "line"],
    );
    println!("{err}");
    rejects_scene("empty", "", None, &["invalid scene JSON", "EOF"]);
    let trailing = substituted("\"solver\": \"xpbd\"", "\"solver\": \"xpbd\",");
    rejects_scene(
        "trailing comma",
        &trailing,
        None,
        &["trailing comma", "line"],
    );
    rejects_scene(
        "not JSON",
        "cloth: 3",
        None,
        &["invalid scene JSON", "line 1"],
    );
}

#[test]
fn unknown_field() {
    let mut v = swing();
    v["physics"]["gravityy"] = json!(1.0);
    let text = v.to_string();
    rejects_scene(
        "unknown",
        &text,
        None,
        &["unknown field `gravityy`", "gravity"],
    );
    // A field name with a newline in it is quoted escaped: the message stays on one line.
    v["physics"]["grav\nity"] = json!(1.0);
    v["physics"].as_object_mut().unwrap().remove("gravityy");
    rejects_scene("unknown newline", &v.to_string(), None, &["grav\\nity"]);
}

#[test]
fn missing_field() {
    let mut v = swing();
    v["physics"].as_object_mut().unwrap().remove("dt");
    rejects_scene("missing", &v.to_string(), None, &["missing field `dt`"]);
    let mut v = swing();
    v.as_object_mut().unwrap().remove("task");
    rejects_scene(
        "missing task",
        &v.to_string(),
        None,
        &["missing field `task`"],
    );
}

#[test]
fn nan_and_inf() {
    // JSON has no NaN or ∞: a number too large for f64, the bare words and their string forms
    // are all parse errors naming the position.
    let cases = [
        (
            "1e400",
            substituted("\"dt\": 0.1", "\"dt\": 1e400"),
            "number out of range",
        ),
        (
            "-1e400",
            substituted("\"dt\": 0.1", "\"dt\": -1e400"),
            "number out of range",
        ),
        (
            "NaN word",
            substituted("\"dt\": 0.1", "\"dt\": NaN"),
            "expected value",
        ),
        (
            "Infinity word",
            substituted("\"dt\": 0.1", "\"dt\": Infinity"),
            "expected value",
        ),
        (
            "\"NaN\"",
            edited("/physics/dt", json!("NaN")),
            "invalid type: string \"NaN\"",
        ),
        (
            "\"Infinity\"",
            edited("/cloth/top_left/1", json!("Infinity")),
            "string \"Infinity\"",
        ),
        (
            "stiffness \"nan\"",
            edited("/material/stretch", json!("nan")),
            "\"inf\"",
        ),
        (
            "stiffness \"-inf\"",
            edited("/material/stretch", json!("-inf")),
            "\"inf\"",
        ),
    ];
    for (name, text, expected) in &cases {
        let err = rejects_scene(name, text, None, &[expected, "line"]);
        println!("{name}: {err}");
    }
    // Finite but absurd: beyond the range a rollout can represent.
    let err = rejects_scene(
        "1e154",
        &edited("/cloth/top_left/0", json!(1e154)),
        Some("cloth.top_left[0]"),
        &["cloth.top_left[0]", "exceeds the limit"],
    );
    println!("{err}");
    rejects_scene(
        "delta 1e300",
        &edited("/task/delta", json!(1e300)),
        Some("task.delta"),
        &["task.delta"],
    );
}

#[test]
fn negative_or_zero_size() {
    rejects_scene(
        "rows -3",
        &edited("/cloth/rows", json!(-3)),
        None,
        &["expected usize", "\"rows\": -3"],
    );
    rejects_scene(
        "rows 0",
        &edited("/cloth/rows", json!(0)),
        Some("cloth.rows"),
        &["cloth.rows"],
    );
    rejects_scene(
        "cols 0",
        &edited("/cloth/cols", json!(0)),
        Some("cloth.cols"),
        &["cloth.cols"],
    );
    rejects_scene(
        "zero width",
        &edited("/cloth/right", json!([0, 0, 0])),
        Some("cloth.right"),
        &["cloth.right", "zero-length"],
    );
    rejects_scene(
        "mass 0",
        &edited("/cloth/particle_mass", json!(0)),
        Some("cloth.particle_mass"),
        &["cloth.particle_mass"],
    );
    rejects_scene(
        "mass 1e-320",
        &edited("/cloth/particle_mass", json!(1e-320)),
        Some("cloth.particle_mass"),
        &["cloth.particle_mass", "inverse overflows"],
    );
    rejects_scene(
        "dt -0.1",
        &edited("/physics/dt", json!(-0.1)),
        Some("physics.dt"),
        &["physics.dt"],
    );
    rejects_scene(
        "dt 1e-300",
        &edited("/physics/dt", json!(1e-300)),
        Some("physics.dt"),
        &["physics.dt", "dt²"],
    );
    rejects_scene(
        "radius -1",
        &{
            let mut v = swing();
            v["obstacles"] = json!([{"type": "spheres", "centers": [[0, 0, 0]], "radii": [-1],
                                     "role": "safety"}]);
            v.to_string()
        },
        Some("obstacles[0].radii[0]"),
        &["obstacles[0].radii[0]"],
    );
}

#[test]
fn control_index_out_of_range() {
    let err = rejects_scene(
        "control",
        &edited("/controls/1", json!([0, 10])),
        Some("controls[1]"),
        &["controls[1]: col 10 out of range (cloth.cols = 10)"],
    );
    println!("{err}");
    rejects_scene(
        "control duplicate",
        &edited("/controls/1", json!([0, 0])),
        Some("controls[1]"),
        &["controls[1]", "duplicates controls[0]"],
    );
}

#[test]
fn target_out_of_range() {
    let err = rejects_scene(
        "target",
        &edited("/task/targets/3/particle", json!([12, 3])),
        Some("task.targets[3].particle"),
        &["task.targets[3].particle: row 12 out of range (cloth.rows = 10)"],
    );
    println!("{err}");
}

#[test]
fn negative_stiffness() {
    let err = rejects_scene(
        "stretch",
        &edited("/material/stretch", json!(-1e4)),
        Some("material.stretch"),
        &["material.stretch", "-10000"],
    );
    println!("{err}");
    rejects_scene(
        "bending 0",
        &edited("/material/bending/stiffness", json!(0)),
        Some("material.bending.stiffness"),
        &["material.bending.stiffness"],
    );
    // So small that the compliance 1/(k·dt²) overflows (this panicked in the projection).
    let err = rejects_scene(
        "stretch 5e-324",
        &edited("/material/stretch", json!(5e-324)),
        Some("material.stretch"),
        &["material.stretch", "compliance"],
    );
    println!("{err}");
}

#[test]
fn zero_iterations() {
    rejects_scene(
        "physics.iterations 0",
        &edited("/physics/iterations", json!(0)),
        Some("physics.iterations"),
        &["physics.iterations: must be at least 1, got 0"],
    );
    // The flags of grad and optimize name themselves: `--sweeps` (solver sweeps per step, also
    // accepted as grad's old `--iterations`) and `--iterations` (optimizer iterations).
    let dir = scratch("bad", "iterations-flag");
    let out = dir.join("out.json");
    let o = run(bin().args(["grad", "swing", "--sweeps", "0"]));
    fails_cleanly(&o, &["--sweeps must be at least 1"], &dir, &[]);
    let o = run(bin().args(["grad", "swing", "--iterations", "0"]));
    fails_cleanly(&o, &["--sweeps must be at least 1"], &dir, &[]);
    let o = run(bin()
        .args(["optimize", "swing", "--sweeps", "0", "--out"])
        .arg(&out));
    fails_cleanly(&o, &["--sweeps must be at least 1"], &dir, &[]);
    let o = run(bin()
        .args(["optimize", "swing", "--iterations", "0", "--out"])
        .arg(&out));
    fails_cleanly(&o, &["--iterations must be at least 1"], &dir, &[]);
}

#[test]
fn zero_horizon() {
    let err = rejects_scene(
        "T = 0",
        &edited("/task/horizon", json!(0)),
        Some("task.horizon"),
        &["task.horizon: must be at least 1, got 0"],
    );
    println!("{err}");
    // T that disagrees with an explicit initial guess.
    let mut v = swing();
    v["task"]["initial_controls"] = json!({"explicit": [[[0, 0, 0], [0, 0, 0]]]});
    rejects_scene(
        "explicit guess",
        &v.to_string(),
        Some("task.initial_controls.explicit"),
        &["1 step given, need task.horizon = 10"],
    );
}

/// Runs `simulate`, `grad` and `optimize --start` with a controls file holding `controls_json`;
/// each must fail cleanly with `expected`.
fn rejects_controls(name: &str, controls_json: &str, expected: &[&str]) {
    let dir = scratch("bad", &format!("controls-{name}"));
    let scene = write_scene(
        &dir,
        "scene.json",
        &Scene::from_json_str(&small_swing().to_string()).unwrap(),
    );
    let controls = dir.join("u.json");
    std::fs::write(&controls, controls_json).unwrap();
    let out = dir.join("out.json");
    let inputs = ["scene.json", "u.json"];
    let o = run(bin()
        .arg("simulate")
        .arg(&scene)
        .arg("--controls")
        .arg(&controls)
        .arg("--out")
        .arg(&out));
    let err = fails_cleanly(&o, expected, &dir, &inputs);
    println!("{name}: {err}");
    let o = run(bin()
        .arg("grad")
        .arg(&scene)
        .arg("--controls")
        .arg(&controls));
    fails_cleanly(&o, expected, &dir, &inputs);
    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .arg("--start")
        .arg(&controls)
        .arg("--out")
        .arg(&out));
    fails_cleanly(&o, expected, &dir, &inputs);
}

#[test]
fn controls_file_of_the_wrong_shape() {
    // The small swing: T = 3, 2 control points.
    let ok = |v: Value| json!({ "controls": v }).to_string();
    rejects_controls(
        "steps",
        &ok(json!([[[0, 0, 0], [0, 0, 0]]])),
        &[
            "u.json",
            "expected 3 steps × 2 control points, got 1 steps × 2",
        ],
    );
    rejects_controls(
        "points",
        &ok(json!([[[0, 0, 0]], [[0, 0, 0]], [[0, 0, 0]]])),
        &["u.json", "expected 3 steps × 2 control points"],
    );
    rejects_controls(
        "components",
        &ok(json!([
            [[0, 0], [0, 0]],
            [[0, 0], [0, 0]],
            [[0, 0], [0, 0]]
        ])),
        &[
            "u.json",
            "not a controls file",
            "expected an array of length 3",
        ],
    );
    rejects_controls(
        "key",
        r#"{"u": []}"#,
        &["u.json", "missing field `controls`"],
    );
    rejects_controls("malformed", r#"{"controls": [[[0, 0"#, &["u.json", "EOF"]);
    let nan = ok(json!([
        [[0, 0, "NaN"], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]]
    ]));
    rejects_controls("NaN", &nan, &["u.json", "invalid type: string \"NaN\""]);
    let huge = ok(json!([
        [[0, 0, 0], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]]
    ]))
    .replacen("0]", "1e400]", 1);
    rejects_controls("1e400", &huge, &["u.json", "number out of range"]);
    // Finite but so large that the rollout leaves f64: the error names the step and particle.
    let far = ok(json!([
        [[1e300, 0, 0], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]],
        [[0, 0, 0], [0, 0, 0]]
    ]));
    rejects_controls("1e300", &far, &["simulation diverged at step 1: particle"]);
}

#[test]
fn bad_optimize_flags() {
    let dir = scratch("bad", "flags");
    let scene = write_scene(
        &dir,
        "scene.json",
        &Scene::from_json_str(&small_swing().to_string()).unwrap(),
    );
    let out = dir.join("out.json");
    // (`--alpha=-1`: with a space clap reads `-1` as a flag.) `--kappa 0` and `--kappa nan` used
    // to panic in the soft minimum; `--beta nan` was accepted silently.
    let cases: [(&[&str], &str); 15] = [
        (
            &["--delta", "nan"],
            "--delta must be a finite number ≥ 0, got NaN",
        ),
        (&["--delta", "inf"], "--delta"),
        (
            &["--alpha=-1"],
            "--alpha must be a finite number ≥ 0, got -1",
        ),
        (
            &["--beta", "nan"],
            "--beta must be a finite number ≥ 0, got NaN",
        ),
        (
            &["--kappa", "0"],
            "--kappa must be a finite number > 0, got 0",
        ),
        (&["--kappa", "nan"], "--kappa must be"),
        (&["--tol", "0"], "--tol must be a finite number > 0"),
        (
            &["--reuse-band", "nan"],
            "--reuse-band must be a number > 0, got NaN",
        ),
        (
            &["--reuse-band", "0"],
            "--reuse-band must be a number > 0, got 0",
        ),
        (&["--solver", "newton"], "invalid value 'newton'"),
        (
            &["--target-model", "newton"],
            "invalid value 'newton' for '--target-model",
        ),
        (
            &["--physics-tolerance", "1"],
            "--physics-tolerance must be in (0, 1), got 1",
        ),
        (
            &["--physics-tolerance", "nan"],
            "--physics-tolerance must be",
        ),
        (
            &["--physics-load-steps", "0"],
            "--physics-load-steps must be at least 1, got 0",
        ),
        (
            &["--physics-linear-solver", "cg"],
            "invalid value 'cg' for '--physics-linear-solver",
        ),
    ];
    for (args, expected) in cases {
        let o = run(bin()
            .arg("optimize")
            .arg(&scene)
            .args(args)
            .arg("--out")
            .arg(&out));
        if ["--solver", "--target-model", "--physics-linear-solver"].contains(&args[0]) {
            // clap's own usage error: exit 2 and a usage block, still no panic and no file.
            assert_eq!(o.status.code(), Some(2));
            assert!(stderr(&o).contains(expected), "{}", stderr(&o));
            assert!(!out.exists());
            continue;
        }
        let err = fails_cleanly(&o, &[expected], &dir, &["scene.json"]);
        println!("{args:?}: {err}");
    }
    let o = run(bin().args(["grad", "swing", "--delta", "nan"]));
    fails_cleanly(
        &o,
        &["--delta must be a finite number ≥ 0"],
        &dir,
        &["scene.json"],
    );
    // The library rejects the same options instead of panicking.
    let s = Scene::builtin("swing").unwrap();
    let model = cloth::Model::from_scene(&s).unwrap();
    let start = clothopt::plan::initial_controls(&s, &model).unwrap();
    let mut options = clothopt::plan::PlanOptions::for_model(&model);
    options.task.kappa = 0.0;
    let err = clothopt::plan::plan(&model, &s, &start, &options, |_| {})
        .expect_err("kappa 0")
        .to_string();
    assert!(err.contains("kappa"), "{err}");
    let mut options = clothopt::plan::PlanOptions::for_model(&model);
    options.reuse_band = f64::NAN;
    let err = clothopt::plan::plan(&model, &s, &start, &options, |_| {})
        .expect_err("reuse band NaN")
        .to_string();
    assert!(err.contains("reuse_band must be a number > 0"), "{err}");
}

#[test]
fn unwritable_output_leaves_nothing_behind() {
    let dir = scratch("bad", "unwritable");
    let scene = write_scene(
        &dir,
        "scene.json",
        &Scene::from_json_str(&small_swing().to_string()).unwrap(),
    );
    // --out names an existing directory: the temporary file is written, the rename fails, and
    // the temporary file is removed.
    std::fs::create_dir(dir.join("taken")).unwrap();
    let o = run(bin()
        .arg("simulate")
        .arg(&scene)
        .arg("--out")
        .arg(dir.join("taken")));
    let err = fails_cleanly(
        &o,
        &["cannot write", "taken"],
        &dir,
        &["scene.json", "taken"],
    );
    println!("{err}");
    assert!(files_in(&dir.join("taken")).is_empty());
    // --out in a directory that does not exist.
    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--iterations", "2", "--search", "off", "--out"])
        .arg(dir.join("missing").join("r.json")));
    fails_cleanly(
        &o,
        &["cannot write", "r.json"],
        &dir,
        &["scene.json", "taken"],
    );
}

#[test]
fn nothing_to_optimize_and_unknown_scenes() {
    let dir = scratch("bad", "misc");
    // A scene without control particles simulates, but there is nothing to optimize.
    let mut v = small_swing();
    v["controls"] = json!([]);
    let scene = dir.join("scene.json");
    std::fs::write(&scene, v.to_string()).unwrap();
    let out = dir.join("out.json");
    let o = run(bin().arg("optimize").arg(&scene).arg("--out").arg(&out));
    let err = fails_cleanly(
        &o,
        &["has no control particles: there is nothing to optimize"],
        &dir,
        &["scene.json"],
    );
    println!("{err}");
    let o = run(bin().args(["simulate", "swingg"]));
    fails_cleanly(
        &o,
        &["unknown built-in scene `swingg`", "u_obstacle"],
        &dir,
        &["scene.json"],
    );
    let o = run(bin().arg("simulate").arg(dir.join("absent.json")));
    fails_cleanly(
        &o,
        &["cannot read scene file", "absent.json"],
        &dir,
        &["scene.json"],
    );
    let o = run(bin()
        .arg("export")
        .arg(&scene)
        .args(["--waypoints"])
        .arg(&out));
    fails_cleanly(&o, &["not a clothopt result"], &dir, &["scene.json"]);
    // A result without states (hand-edited): an error, not an index panic.
    let result = dir.join("empty.json");
    let empty = r#"{"grid": [2, 2], "control_particles": [0], "states": []}"#;
    std::fs::write(&result, empty).unwrap();
    let o = run(bin()
        .arg("export")
        .arg(&result)
        .args(["--waypoints"])
        .arg(&out));
    fails_cleanly(
        &o,
        &["has no states to export"],
        &dir,
        &["scene.json", "empty.json"],
    );
}

/// Issue 21's papercuts: each message says its thing once, in our words.
#[test]
fn papercuts_say_it_once() {
    let dir = scratch("bad", "papercuts");
    // An unknown scene lists the built-in scenes once.
    let o = run(bin().args(["optimize", "nosuchscene"]));
    let err = fails_cleanly(&o, &["unknown built-in scene `nosuchscene`"], &dir, &[]);
    assert_eq!(err.matches("u_obstacle").count(), 1, "{err}");
    // A missing scene file gives the OS error once.
    let o = run(bin().arg("optimize").arg(dir.join("nosuch.json")));
    let err = fails_cleanly(&o, &["cannot read scene file", "nosuch.json"], &dir, &[]);
    assert_eq!(err.matches("os error").count(), 1, "{err}");
    // A negative number is a value with our range message naming the flag, not clap's `-- -1` tip.
    for (command, flag) in [
        ("optimize", "--delta"),
        ("optimize", "--alpha"),
        ("optimize", "--beta"),
        ("grad", "--delta"),
    ] {
        let o = run(bin().args([command, "swing", flag, "-1"]));
        let err = fails_cleanly(
            &o,
            &[&format!("{flag} must be a finite number ≥ 0, got -1")],
            &dir,
            &[],
        );
        assert!(!err.contains("-- -1"), "{err}");
    }
    for flag in ["--kappa", "--tol", "--feasibility-tol"] {
        let o = run(bin().args(["optimize", "swing", flag, "-2.5"]));
        fails_cleanly(
            &o,
            &[&format!("{flag} must be a finite number > 0, got -2.5")],
            &dir,
            &[],
        );
    }
    let o = run(bin().args(["optimize", "swing", "--reuse-band", "-1"]));
    fails_cleanly(
        &o,
        &["--reuse-band must be a number > 0, got -1"],
        &dir,
        &[],
    );
}

/// "1 vector given", "2 vectors given": counts agree with their nouns.
#[test]
fn counts_in_messages_are_pluralised() {
    let one = edited("/task/initial_controls", json!({"constant": [[0, 0, 0]]}));
    let err = rejects_scene(
        "one constant vector for two controls",
        &one,
        Some("task.initial_controls.constant"),
        &["1 vector given, need one per control particle (2)"],
    );
    assert!(!err.contains("1 vectors"), "{err}");
    let three = edited(
        "/task/initial_controls",
        json!({"constant": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}),
    );
    rejects_scene(
        "three constant vectors for two controls",
        &three,
        Some("task.initial_controls.constant"),
        &["3 vectors given, need one per control particle (2)"],
    );
    let mut v = swing();
    v["task"]["horizon"] = json!(2);
    v["task"]["initial_controls"] = json!({"explicit": [[[0, 0, 0], [0, 0, 0]]]});
    rejects_scene(
        "one explicit step for horizon 2",
        &v.to_string(),
        Some("task.initial_controls.explicit"),
        &["1 step given, need task.horizon = 2"],
    );
}
