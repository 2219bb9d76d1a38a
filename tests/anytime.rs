//! Runs that respect the user's time: `--time-limit` returns a file with the best plan so far,
//! SIGINT writes it and exits 130, and a long run off a terminal prints progress lines.

mod common;

use cloth::Scene;
use common::{bin, scratch, write_scene};
use serde_json::Value;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// `u_obstacle` at 16 × 16: slow enough per iteration (and far enough from converging at a KKT
/// tolerance of 1e-300) that a run lasts well beyond the few seconds these tests wait.
fn slow_scene() -> Scene {
    Scene::builtin("u_obstacle")
        .unwrap()
        .refined(16, 16)
        .unwrap()
}

/// `optimize` arguments that cannot converge (a KKT tolerance of 1e-300) within a huge iteration
/// limit: only the time limit or an interrupt ends the run.
const ENDLESS: [&str; 6] = [
    "--iterations",
    "1000000",
    "--tol",
    "1e-300",
    "--search",
    "off",
];

#[test]
fn a_time_limit_returns_the_best_plan_so_far_with_its_status() {
    let dir = scratch("anytime", "limit");
    let scene = slow_scene();
    let path = write_scene(&dir, "scene.json", &scene);
    let out = dir.join("r.json");
    let o = bin()
        .arg("optimize")
        .arg(&path)
        .args(ENDLESS)
        .args(["--time-limit", "6", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{err}");
    let v: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(v["status"], "time_limit", "{}", v["message"]);
    assert!(v["message"]
        .as_str()
        .unwrap()
        .contains("time limit reached"));
    assert!(v["iterations"].as_u64().unwrap() < 1_000_000);
    // The stage the deadline stopped says so too.
    let stages = v["stages"].as_array().unwrap();
    assert_eq!(stages.last().unwrap()["status"], "time_limit", "{stages:?}");
    let reason = v["task"]["reason"].as_str().unwrap();
    assert!(
        matches!(reason, "stopped" | "no_safe_plan" | "achieved"),
        "{reason}"
    );
    // A feasible returned plan is the best feasible iterate: no worse than the initial guess.
    if v["constraint_violation"].as_f64().unwrap() <= 1e-8 {
        let model = cloth::Model::from_scene(&scene).unwrap();
        let u0 = clothopt::plan::initial_controls(&scene, &model).unwrap();
        let l0 = model.evaluate(&u0, 0.2, false).unwrap().metrics.l;
        assert!(
            v["metrics"]["L"].as_f64().unwrap() <= l0,
            "{}",
            v["metrics"]
        );
    }
    // Off a terminal, progress lines are printed every few seconds.
    assert!(err.contains("] iteration "), "{err}");
}

#[test]
fn sigint_writes_the_best_plan_so_far_and_exits_130() {
    let dir = scratch("anytime", "sigint");
    let path = write_scene(&dir, "scene.json", &slow_scene());
    let out = dir.join("r.json");
    let child = bin()
        .arg("optimize")
        .arg(&path)
        .args(ENDLESS)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the first best-so-far file (written every 5 s), then interrupt.
    let start = Instant::now();
    while !out.exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(out.exists(), "no best-so-far file after 120 s");
    let running: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(running["status"], "running");
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let v: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(v["status"], "interrupted", "{v}");
    assert!(v["task"]["explanation"]
        .as_str()
        .unwrap()
        .contains("interrupted"));
}
