//! End-to-end tests of the `clothopt` binary on small scenes.

mod common;

use cloth::Scene;
use common::{bin, run, stderr, stdout};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> common::Scratch {
    common::scratch("cli", name)
}

/// `u_obstacle` at 5×5 with 20 solver iterations per step: the safety task, small enough for tests.
fn small_obstacle_scene(dir: &Path) -> PathBuf {
    let mut scene = Scene::builtin("u_obstacle").unwrap().refined(5, 5).unwrap();
    scene.physics.iterations = 20;
    scene.task.delta = 0.1;
    let path = dir.join("small.json");
    std::fs::write(&path, scene.to_json_pretty()).unwrap();
    path
}

#[test]
fn scenes_lists_the_built_ins() {
    let o = run(bin().arg("scenes"));
    assert!(o.status.success());
    let text = stdout(&o);
    for name in ["u_obstacle", "swing", "drop", "fold"] {
        assert!(text.contains(name), "{name} missing from:\n{text}");
    }
    assert_eq!(text.lines().count(), 4);
}

#[test]
fn simulate_writes_a_result_with_t_plus_one_states() {
    let dir = scratch("simulate");
    let scene = small_obstacle_scene(&dir);
    let out = dir.join("sim.json");
    let o = run(bin().arg("simulate").arg(&scene).arg("--out").arg(&out));
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["states"].as_array().unwrap().len(), 11);
    assert_eq!(v["states"][0].as_array().unwrap().len(), 25);
    assert_eq!(v["controls"].as_array().unwrap().len(), 10);
    assert!(v["metrics"]["G"].as_f64().unwrap() > 0.0);
}

/// `--physics-linear-solver pcg` reaches the direct solver's states: the same metrics within
/// Newton's tolerance, by another path (other bits).
#[test]
fn simulate_under_newton_with_either_linear_solver_gives_the_same_rollout() {
    let dir = scratch("linear_solver");
    let scene = small_obstacle_scene(&dir);
    let metrics = |solver: &str| -> Value {
        let out = dir.join(format!("{solver}.json"));
        let o = run(bin()
            .arg("simulate")
            .arg(&scene)
            .args(["--physics", "newton", "--physics-linear-solver", solver])
            .arg("--out")
            .arg(&out));
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap()
    };
    let (direct, pcg) = (metrics("direct"), metrics("pcg"));
    for key in ["G", "E", "L"] {
        let (a, b) = (
            direct["metrics"][key].as_f64().unwrap(),
            pcg["metrics"][key].as_f64().unwrap(),
        );
        assert!(
            (a - b).abs() <= 1e-6 * a.abs().max(1e-3),
            "{key}: {a} vs {b}"
        );
    }
    // The flag took effect: conjugate gradients round differently from the factorization.
    assert_ne!(
        direct["states"], pcg["states"],
        "the same bits: was pcg used?"
    );
}

#[test]
fn a_bad_scene_is_rejected_in_one_line_naming_the_field_and_writes_nothing() {
    let dir = scratch("bad");
    let mut scene: Value =
        serde_json::from_str(&Scene::builtin("swing").unwrap().to_json_pretty()).unwrap();
    scene["physics"]["dt"] = Value::from(-0.1);
    let path = dir.join("bad.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let out = dir.join("never.json");
    let o = run(bin().arg("simulate").arg(&path).arg("--out").arg(&out));
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("physics.dt"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out.exists());

    let mut unknown: Value =
        serde_json::from_str(&Scene::builtin("swing").unwrap().to_json_pretty()).unwrap();
    unknown["physics"]["gravityy"] = Value::from(1.0);
    std::fs::write(&path, unknown.to_string()).unwrap();
    let o = run(bin().arg("simulate").arg(&path));
    assert!(!o.status.success());
    assert!(stderr(&o).contains("gravityy"), "{}", stderr(&o));
}

#[test]
fn a_controls_file_of_the_wrong_shape_is_rejected() {
    let dir = scratch("controls");
    let path = dir.join("u.json");
    std::fs::write(&path, r#"{"controls": [[[0, 0, 0]]]}"#).unwrap();
    let o = run(bin().args(["simulate", "swing", "--controls"]).arg(&path));
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("expected 10 steps × 2 control points"),
        "{}",
        stderr(&o)
    );
}

fn grad_json(scene: &Path, controls: &Path) -> Value {
    let o = run(bin().arg("grad").arg(scene).arg("--controls").arg(controls));
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

#[test]
fn grad_agrees_with_central_differences_through_the_cli() {
    let dir = scratch("grad");
    let scene = small_obstacle_scene(&dir);
    // Distinct consecutive controls, away from the T kinks.
    let base: Vec<Vec<[f64; 3]>> = (0..10)
        .map(|t| {
            vec![
                [0.01 * t as f64, 0.3, 0.02],
                [-0.01, 0.3 - 0.01 * t as f64, 0.0],
            ]
        })
        .collect();
    let dirn: Vec<Vec<[f64; 3]>> = (0..10)
        .map(|t| vec![[0.3, -0.2, 0.1 * (t % 3) as f64], [0.1, 0.25, -0.15]])
        .collect();
    let write = |name: &str, s: f64| {
        let u: Vec<Vec<[f64; 3]>> = base
            .iter()
            .zip(&dirn)
            .map(|(b, d)| {
                b.iter()
                    .zip(d)
                    .map(|(p, q)| [p[0] + s * q[0], p[1] + s * q[1], p[2] + s * q[2]])
                    .collect()
            })
            .collect();
        let path = dir.join(name);
        std::fs::write(&path, serde_json::json!({ "controls": u }).to_string()).unwrap();
        path
    };
    let h = 1e-6;
    let at = grad_json(&scene, &write("u0.json", 0.0));
    let plus = grad_json(&scene, &write("up.json", h));
    let minus = grad_json(&scene, &write("um.json", -h));
    let grad = &at["grad_L"];
    assert_eq!(grad.as_array().unwrap().len(), 10);
    assert_eq!(grad[0].as_array().unwrap().len(), 2);
    let mut directional = 0.0;
    for (t, d) in dirn.iter().enumerate() {
        for (k, q) in d.iter().enumerate() {
            for j in 0..3 {
                directional += grad[t][k][j].as_f64().unwrap() * q[j];
            }
        }
    }
    let fd = (plus["L"].as_f64().unwrap() - minus["L"].as_f64().unwrap()) / (2.0 * h);
    assert!(
        (directional - fd).abs() <= 1e-6 * fd.abs().max(1.0),
        "grad·d = {directional}, FD = {fd}"
    );
    for key in ["L", "G", "T", "E", "C", "min_sdf", "grad_C"] {
        assert!(!at[key].is_null(), "{key} missing");
    }
}

#[test]
fn optimize_reaches_a_feasible_converged_plan_on_a_small_obstacle_scene() {
    let dir = scratch("optimize");
    let scene = small_obstacle_scene(&dir);
    let out = dir.join("result.json");
    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--iterations", "150", "--out"])
        .arg(&out));
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let m = &v["metrics"];
    assert_eq!(v["status"], "converged", "{}", stdout(&o));
    assert!(m["C"].as_f64().unwrap() >= -1e-6);
    assert!(m["min_sdf"].as_f64().unwrap() >= 0.1 - 1e-3);
    let start_l = 4.0;
    assert!(m["L"].as_f64().unwrap() < start_l, "L = {}", m["L"]);
    for key in [
        "scene",
        "delta",
        "iterations",
        "evaluations",
        "wall_s",
        "controls",
        "states",
    ] {
        assert!(!v[key].is_null(), "{key} missing");
    }

    // The result exports to way-points and meshes.
    let csv = dir.join("wp.csv");
    let objs = dir.join("objs");
    let o = run(bin()
        .arg("export")
        .arg(&out)
        .arg("--waypoints")
        .arg(&csv)
        .arg("--obj")
        .arg(&objs)
        .args(["--per-step", "5"]));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap().lines().count(),
        1 + 10 * 5 + 1
    );
    assert_eq!(std::fs::read_dir(&objs).unwrap().count(), 11);
}

/// Runs `clothopt ARGS` and parses its stdout as JSON.
fn json_of(args: &[&str], scene: &Path) -> Value {
    let o = run(bin().arg(args[0]).arg(scene).args(&args[1..]));
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

/// `--sweeps` sets the solver sweeps per step (`physics.iterations`) for every subcommand; grad's
/// old `--iterations` still means the same; optimize's `--iterations` is the optimizer's.
#[test]
fn sweeps_set_the_solver_sweeps_under_every_spelling() {
    let dir = scratch("sweeps");
    let scene = small_obstacle_scene(&dir);
    let default = json_of(&["grad"], &scene);
    let sweeps = json_of(&["grad", "--sweeps", "3"], &scene);
    let old = json_of(&["grad", "--iterations", "3"], &scene);
    assert_eq!(sweeps, old);
    assert_ne!(sweeps["L"], default["L"]);
    // The same scene with physics.iterations = 3 gives the same numbers.
    let mut three: Scene = Scene::load(&scene).unwrap();
    three.physics.iterations = 3;
    let three_path = dir.join("three.json");
    std::fs::write(&three_path, three.to_json_pretty()).unwrap();
    assert_eq!(json_of(&["grad"], &three_path), sweeps);
    // simulate --sweeps agrees with grad --sweeps.
    let out = dir.join("sim.json");
    let o = run(bin()
        .arg("simulate")
        .arg(&scene)
        .args(["--sweeps", "3", "--out"])
        .arg(&out));
    assert!(o.status.success(), "{}", stderr(&o));
    let sim: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(sim["metrics"]["L"], sweeps["L"]);
    // `--help` names both meanings.
    let help = stdout(&run(bin().args(["optimize", "--help"])));
    assert!(
        help.contains("--sweeps") && help.contains("--iterations"),
        "{help}"
    );
    let help = stdout(&run(bin().args(["grad", "--help"])));
    assert!(
        help.contains("--sweeps <") && !help.contains("--iterations <"),
        "{help}"
    );
}

#[test]
fn optimize_check_reports_the_plan_under_other_physics_and_rejects_bad_values() {
    let dir = scratch("check");
    let scene = small_obstacle_scene(&dir);
    let out = dir.join("checked.json");
    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--search", "off", "--check", "xpbd:200", "--out"])
        .arg(&out));
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let check = &v["check"];
    assert_eq!(check["physics"]["solver"], "xpbd", "{}", stdout(&o));
    assert_eq!(check["physics"]["iterations"], 200);
    assert_eq!(check["delta"], 0.1);
    // Measured: the plan at δ = 0.1 (20 iterations per step) comes to 0.02 under XPBD-200; the
    // re-plan at the raised margin passes.
    let rounds = check["rounds"].as_array().unwrap();
    assert!(rounds.len() >= 2, "{rounds:?}");
    assert_eq!(rounds[0]["safe"], false, "{rounds:?}");
    assert_eq!(rounds.last().unwrap()["safe"], true, "{rounds:?}");
    assert!(stdout(&o).contains("checked under XPBD at 200 iterations"));
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Without re-plans the failing check is the verdict: no safe plan (4), naming the physics.
    let o = run(bin().arg("optimize").arg(&scene).args([
        "--search",
        "off",
        "--check",
        "xpbd:200",
        "--check-rounds",
        "0",
    ]));
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no safe plan: under XPBD at 200 iterations"),
        "{}",
        stderr(&o)
    );
    for bad in ["xpbd", "xpbd:0", "newton:1.5", "jax"] {
        let o = run(bin().arg("optimize").arg(&scene).args(["--check", bad]));
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(stderr(&o).contains("--check"), "{}", stderr(&o));
    }
}

/// The continuous check is the default and `--step-only` turns it off: the first line says so and
/// the result records which check judged it; `--swept` (the default) beside `--step-only` is
/// rejected naming both. With a route search the counts line is the whole run's.
#[test]
fn step_only_is_named_on_the_first_line_and_the_counts_are_the_whole_runs() {
    let dir = scratch("step-only");
    let scene = small_obstacle_scene(&dir);
    let out = dir.join("r.json");
    let quick = ["--iterations", "3", "--no-timing", "--out"];
    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--step-only", "--search", "off"])
        .args(quick)
        .arg(&out));
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{}", stderr(&o));
    let first = stdout(&o).lines().next().unwrap().to_string();
    assert!(
        first.contains(
            "(step-only check: safety judged at the steps, not on the motion between them)"
        ),
        "{first}"
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["safety"]["check"], "step_only");
    assert!(v["safety"]["between_steps"].is_null());

    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--search", "always", "--starts", "2"])
        .args(quick)
        .arg(&out));
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        !text.lines().next().unwrap().contains("step-only"),
        "{text}"
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["safety"]["check"], "continuous");
    assert!(v["safety"]["between_steps"]["distance"].is_f64());
    let search = &v["search"];
    let sum = |key: &str| -> u64 {
        search["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c[key].as_u64().unwrap())
            .sum()
    };
    assert!(search["candidates"].as_array().unwrap().len() > 1);
    assert_eq!(search["iterations"].as_u64().unwrap(), sum("iterations"));
    assert_eq!(search["simulations"].as_u64().unwrap(), sum("simulations"));
    let counts = format!(
        "iterations {} in all, the kept plan's {} (",
        search["iterations"], v["iterations"]
    );
    assert!(text.contains(&counts), "{counts} in\n{text}");
    assert!(
        text.contains(&format!(
            "simulations {}  gradients {}",
            search["simulations"], search["gradient_evaluations"]
        )),
        "{text}"
    );

    let o = run(bin()
        .arg("optimize")
        .arg(&scene)
        .args(["--step-only", "--swept"]));
    assert_eq!(o.status.code(), Some(2), "clap's usage error");
    let err = stderr(&o);
    assert!(
        err.contains("--step-only") && err.contains("--swept"),
        "{err}"
    );
}

/// A `--controls` file may hold the bare nested array the scene format describes; a file that is
/// neither that nor an object with a `controls` key says what is expected.
#[test]
fn a_bare_nested_controls_array_is_accepted() {
    let dir = scratch("bare-controls");
    let scene = small_obstacle_scene(&dir);
    let step = "[[0.0, 0.1, 0.0], [0.0, 0.1, 0.0]]";
    let bare = dir.join("bare.json");
    std::fs::write(&bare, format!("[{}]", [step; 10].join(", "))).unwrap();
    let wrapped = dir.join("wrapped.json");
    std::fs::write(
        &wrapped,
        format!("{{\"controls\": [{}]}}", [step; 10].join(", ")),
    )
    .unwrap();
    let sim = |controls: &Path| {
        let o = run(bin()
            .arg("simulate")
            .arg(&scene)
            .arg("--controls")
            .arg(controls));
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    assert_eq!(sim(&bare), sim(&wrapped));
    let neither = dir.join("neither.json");
    std::fs::write(&neither, r#"{"u": []}"#).unwrap();
    let o = run(bin()
        .arg("simulate")
        .arg(&scene)
        .arg("--controls")
        .arg(&neither));
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("an object with a `controls` key") && err.contains("[[[dx, dy, dz], …], …]"),
        "{err}"
    );
}
