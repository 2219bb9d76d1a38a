//! The same command gives byte-identical result JSON across runs and thread counts (issue 7,
//! item 5).
//!
//! `wall_s` (wall-clock time) differs between any two runs, so `clothopt optimize --no-timing`
//! leaves it out of the result; everything else is compared as whole-file bytes: status,
//! message, iteration and evaluation counts, KKT residual, constraint violation, metrics,
//! controls and every state.
//!
//! The scene is large enough that the parallel paths really run: `u_obstacle` at 34×34 has colour
//! sets of more than [`PARALLEL_MIN_ROWS`] constraints and more than that many particles (the
//! per-particle signed distances), so with `RAYON_NUM_THREADS=2` rows are split across threads
//! (asserted below) — with 1 thread they are not.

mod common;

use autodiff::rowfn::PARALLEL_MIN_ROWS;
use cloth::{Model, Scene};
use common::*;
use serde_json::Value;
use std::path::Path;

/// `u_obstacle` at 34×34, 3 solver iterations per step, T = 3.
fn scene() -> Scene {
    let mut s = Scene::builtin("u_obstacle")
        .unwrap()
        .refined(34, 34)
        .unwrap();
    s.physics.iterations = 3;
    s.task.horizon = 3;
    s.task.initial_controls = cloth::scene::InitialControls::Constant(vec![[0.0, 0.3, 0.0]; 2]);
    s.validate().unwrap();
    s
}

/// `clothopt optimize SCENE --iterations 4 --search always --starts 4 --no-timing --out OUT`
/// with `threads` rayon threads (the route search's candidates run in parallel); returns the
/// result file's bytes.
fn optimize(scene: &Path, out: &Path, threads: usize) -> Vec<u8> {
    let o = run(bin()
        .env("RAYON_NUM_THREADS", threads.to_string())
        .arg("optimize")
        .arg(scene)
        .args(["--iterations", "4", "--search", "always", "--starts", "4"])
        .args(["--no-timing", "--out"])
        .arg(out));
    // 4 iterations do not reach the targets: exit 3 (safe, not achieved) or 4 (no safe plan).
    assert!(
        matches!(o.status.code(), Some(0 | 3 | 4)),
        "{}\n{}",
        stdout(&o),
        stderr(&o)
    );
    let text = String::from_utf8_lossy(&std::fs::read(out).unwrap()).into_owned();
    assert!(text.contains("\"candidates\""), "the search did not run");
    assert!(!stdout(&o).contains("wall"), "{}", stdout(&o));
    std::fs::read(out).unwrap()
}

#[test]
fn optimize_writes_identical_bytes_across_runs_and_thread_counts() {
    let scene = scene();
    let model = Model::from_scene(&scene).unwrap();
    let largest_set = model.sets().map(|s| s.index.rows()).max().unwrap();
    assert!(
        largest_set >= PARALLEL_MIN_ROWS && model.n_particles() >= PARALLEL_MIN_ROWS,
        "largest set {largest_set}, {} particles: the parallel path would not run",
        model.n_particles()
    );

    let dir = scratch("determinism", "optimize");
    let path = write_scene(&dir, "scene.json", &scene);
    let runs = [
        (1, "a1.json"),
        (2, "a2.json"),
        (2, "b2.json"),
        (1, "b1.json"),
    ];
    let bytes: Vec<Vec<u8>> = runs
        .iter()
        .map(|&(threads, name)| optimize(&path, &dir.join(name), threads))
        .collect();
    let v: Value = serde_json::from_slice(&bytes[0]).unwrap();
    assert!(v.get("wall_s").is_none(), "--no-timing keeps wall_s out");
    assert!(
        v["iterations"].as_u64().unwrap() >= 1,
        "the optimizer moved"
    );
    assert_eq!(v["states"].as_array().unwrap().len(), 4);
    println!(
        "status {}, {} iterations, {} simulations, L {}, {} bytes",
        v["status"],
        v["iterations"],
        v["evaluations"],
        v["metrics"]["L"],
        bytes[0].len()
    );
    for (b, (threads, name)) in bytes.iter().zip(runs).skip(1) {
        assert!(
            b == &bytes[0],
            "{name} ({threads} threads) differs from a1.json (1 thread)"
        );
    }
    // Without --no-timing the file differs only by the wall_s fields (the result's and each
    // search candidate's).
    let o = run(bin()
        .arg("optimize")
        .arg(&path)
        .args([
            "--iterations",
            "4",
            "--search",
            "always",
            "--starts",
            "4",
            "--out",
        ])
        .arg(dir.join("timed.json")));
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{}", stderr(&o));
    let mut timed: Value =
        serde_json::from_slice(&std::fs::read(dir.join("timed.json")).unwrap()).unwrap();
    assert!(timed["wall_s"].as_f64().unwrap() > 0.0);
    timed.as_object_mut().unwrap().remove("wall_s");
    for c in timed["search"]["candidates"].as_array_mut().unwrap() {
        assert!(c["wall_s"].as_f64().unwrap() > 0.0);
        c.as_object_mut().unwrap().remove("wall_s");
    }
    assert_eq!(timed, v);
    // A result without wall_s reads back as a PlanResult (timing NaN: not measured).
    let back: clothopt::result::PlanResult = serde_json::from_slice(&bytes[0]).unwrap();
    assert!(back.wall_s.is_nan());
    assert_eq!(serde_json::to_vec_pretty(&back).unwrap(), bytes[0]);
}

#[test]
fn simulate_and_grad_are_identical_across_thread_counts() {
    let dir = scratch("determinism", "simulate");
    let path = write_scene(&dir, "scene.json", &scene());
    let mut sims = Vec::new();
    let mut grads = Vec::new();
    for threads in [1, 2, 1, 2] {
        let out = dir.join(format!("sim{}.json", sims.len()));
        let o = run(bin()
            .env("RAYON_NUM_THREADS", threads.to_string())
            .arg("simulate")
            .arg(&path)
            .arg("--out")
            .arg(&out));
        assert!(o.status.success(), "{}", stderr(&o));
        sims.push(std::fs::read(&out).unwrap());
        let o = run(bin()
            .env("RAYON_NUM_THREADS", threads.to_string())
            .arg("grad")
            .arg(&path));
        assert!(o.status.success(), "{}", stderr(&o));
        grads.push(o.stdout);
    }
    assert!(sims.iter().all(|s| s == &sims[0]));
    assert!(grads.iter().all(|g| g == &grads[0]));
    let g: Value = serde_json::from_slice(&grads[0]).unwrap();
    assert!(g["grad_L"][0][0][0].as_f64().unwrap().abs() > 0.0);
}

/// A result whose metrics hold ∞ (no safety obstacle: min SDF ∞, written as `null`) reads back as a
/// `PlanResult` and writes the same bytes again.
#[test]
fn a_result_without_safety_obstacles_reads_back() {
    let dir = scratch("determinism", "readback");
    let out = dir.join("swing.json");
    let o = run(bin()
        .args([
            "optimize",
            "swing",
            "--iterations",
            "2",
            "--search",
            "always",
            "--starts",
            "2",
            "--no-timing",
            "--out",
        ])
        .arg(&out));
    assert!(matches!(o.status.code(), Some(0 | 3 | 4)), "{}", stderr(&o));
    let bytes = std::fs::read(&out).unwrap();
    let back: clothopt::result::PlanResult = serde_json::from_slice(&bytes).unwrap();
    assert!(back.metrics.min_sdf.is_infinite() && back.metrics.min_sdf_swept.is_infinite());
    assert_eq!(serde_json::to_vec_pretty(&back).unwrap(), bytes);
}
