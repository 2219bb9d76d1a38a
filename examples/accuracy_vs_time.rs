//! What accuracy costs in time (issue 6, item 1).
//!
//! XPBD's accuracy is the number of Gauss–Seidel iterations per step (`n_iter`). For `u_obstacle`
//! (at its scene's δ) and `swing`, at the scene's initial guess, this sweeps `n_iter` and reports: the
//! stretch residual (max |C| and RMS of `|x_i − x_j| − l⁰` over every stretch edge at the end of
//! every step), E, L, the relative error of ∇L against a converged reference (5,000 iterations), the
//! median time of one forward and one forward+∇L pass (and of `evaluate(.., true)`, which also
//! pulls back dC/dU), and the consequence for planning: the plan optimized at `n_iter`, re-simulated
//! at the reference accuracy (true G, true min SDF: does it stay safe?). Then forward+∇L time and
//! peak memory against mesh size, 1 vs 2 threads, each measured in a fresh child process (this
//! example re-run with a hidden subcommand). With `--jax PYTHON`, the JAX reference beside it.
//!
//! `cargo run --release --example accuracy_vs_time [-- --out FILE --png-dir DIR --quick --jax PYTHON]`

mod support;

use anyhow::{anyhow, ensure, Context, Result};
use autodiff::Tensor;
use clap::{Parser, Subcommand};
use cloth::{Controls, Model, Scene};
use clothopt::plan::{self, PlanOptions};
use clothopt::plot::{draw_xy, RefLine, Series, XyFigure};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[derive(Parser)]
#[command(
    about = "Accuracy against time: Gauss–Seidel iterations, gradient error, planning safety, mesh size",
    args_conflicts_with_subcommands = true
)]
struct Args {
    /// Internal: one measurement in a fresh process (used for peak memory).
    #[command(subcommand)]
    child: Option<Child>,
    /// Write `{"rows": [...]}` here (atomically).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Draw the PNG plots into this directory (created if missing).
    #[arg(long)]
    png_dir: Option<PathBuf>,
    /// Reduced sweep (n_iter ∈ {5, 20, 100}, reference 1,000 iterations, 3 timing runs,
    /// 30 optimizer iterations, meshes 10 and 20) for a quick look.
    #[arg(long)]
    quick: bool,
    /// Optimizer iteration limit per plan [default: 150; 30 with --quick].
    #[arg(long)]
    plan_iterations: Option<usize>,
    /// Plan only for n_iter up to this (a plan costs about n_iter/100 × the 100-iteration plan).
    #[arg(long, default_value_t = 1000)]
    plan_max_n_iter: usize,
    /// Solver sweeps per step of the converged reference [default: 5000; 1000 with --quick]
    /// (also accepted as `--reference-iterations`).
    #[arg(long = "reference-sweeps", alias = "reference-iterations")]
    reference_iterations: Option<usize>,
    /// Timing runs per median [default: 5; 3 with --quick].
    #[arg(long)]
    reps: Option<usize>,
    /// Also time the JAX reference with this Python (e.g. /tmp/jaxenv/bin/python).
    #[arg(long)]
    jax: Option<PathBuf>,
    /// The JAX benchmark script run by --jax.
    #[arg(long, default_value = "/work/shared/anchors/jax_ref/bench_jax.py")]
    jax_script: PathBuf,
}

#[derive(Subcommand)]
enum Child {
    /// Times forward and forward+∇L of `u_obstacle` at `n × n` and prints one JSON line with the
    /// process's peak RSS (VmHWM) before and after.
    #[command(hide = true)]
    MeasureMesh {
        #[arg(long)]
        n: usize,
        #[arg(long)]
        threads: usize,
        #[arg(long)]
        iterations: usize,
        #[arg(long)]
        reps: usize,
        /// Stop timing after this many seconds (at least one run).
        #[arg(long)]
        budget_s: f64,
    },
}

/// Gauss–Seidel iterations per step of the mesh-size rows and the JAX comparison.
const MESH_N_ITER: usize = 100;

/// Seconds a mesh-size child spends timing before it stops (after at least one run).
const MESH_BUDGET_S: f64 = 5.0;

/// The sweep's settings after `--quick` and the overrides.
struct Config {
    n_iters: Vec<usize>,
    reference_iterations: usize,
    reps: usize,
    plan_iterations: usize,
    plan_max_n_iter: usize,
    mesh_sizes: Vec<usize>,
    /// `u_obstacle`'s safety margin δ, the threshold its plans are judged against.
    delta: f64,
}

/// One output row; `kind` tells which.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum Row<'a> {
    Accuracy(&'a AccuracyRow),
    Mesh(&'a MeshRow),
    Jax(&'a JaxRow),
}

/// One `(scene, n_iter)` setting at the scene's initial guess.
#[derive(Serialize)]
struct AccuracyRow {
    scene: String,
    n_iter: usize,
    /// The controls the row is evaluated at (see [`evaluation_point`]); plans start from the
    /// scene's initial guess.
    point: String,
    /// This is the converged reference itself (its gradient error is 0 by definition).
    reference: bool,
    /// Largest `| |x_i − x_j| − l⁰ |` over stretch edges and steps 1..T (length units).
    max_abs_c: f64,
    /// RMS of the same over every edge and step.
    rms_c: f64,
    /// Largest |C| at the end of each step 1..T.
    max_abs_c_per_step: Vec<f64>,
    e: f64,
    l: f64,
    g: f64,
    /// `‖∇L − ∇L_ref‖₂ / ‖∇L_ref‖₂`.
    grad_rel_err: f64,
    /// `evaluate(.., false)`: the rollout and its metrics.
    forward: Timing,
    /// The rollout, its metrics and ∇L ([`forward_grad_l`]; what JAX's benchmark times).
    forward_grad_l: Timing,
    /// `evaluate(.., true)`: also dC/dU, a second backward pass (scenes with safety obstacles).
    evaluate_gradients: Option<Timing>,
    threads: usize,
    plan: Option<PlanRow>,
    /// Why there is no plan.
    plan_skipped: Option<String>,
}

/// A plan optimized at `n_iter`, and the same controls re-simulated at the reference accuracy.
#[derive(Serialize)]
struct PlanRow {
    status: String,
    iterations: usize,
    simulations: usize,
    wall_s: f64,
    /// What the planner saw (simulated at `n_iter`).
    planned_g: f64,
    planned_l: f64,
    planned_min_sdf: Option<f64>,
    planned_max_abs_c: f64,
    /// The truth (re-simulated at the reference iterations).
    true_g: f64,
    true_l: f64,
    true_min_sdf: Option<f64>,
    true_min_sdf_swept: Option<f64>,
    true_max_abs_c: f64,
    /// The re-simulated rollout passes [`plan::is_safe`] (None without safety obstacles).
    safe: Option<bool>,
}

/// Forward+∇L at one mesh size and thread count, measured in a fresh process.
#[derive(Serialize, Deserialize)]
struct MeshRow {
    scene: String,
    n: usize,
    particles: usize,
    n_iter: usize,
    threads: usize,
    forward: Timing,
    /// The rollout, its metrics and ∇L ([`forward_grad_l`]).
    forward_grad_l: Timing,
    l: f64,
    /// Process peak RSS (VmHWM) after the forward+∇L runs, MB.
    peak_rss_mb: Option<f64>,
    /// VmHWM growth over the forward+∇L runs (model already built), MB.
    rss_growth_mb: Option<f64>,
}

/// The JAX reference at one setting, beside ours.
#[derive(Serialize)]
struct JaxRow {
    scene: String,
    n: usize,
    n_iter: usize,
    forward_s: f64,
    /// The benchmark's value-and-gradient of L.
    forward_grad_l_s: f64,
    l: f64,
    /// Our medians at the same setting (n = 10 from the sweep, else the 2-thread mesh rows).
    ours_forward_s: Option<f64>,
    ours_forward_grad_l_s: Option<f64>,
    /// `|L_jax − L_ours| / |L_ours|` and the same for ∇L (n = 10 only: at other sizes JAX targets
    /// the whole bottom row, `Scene::refined` the 10 original material points).
    l_rel_diff: Option<f64>,
    grad_rel_diff: Option<f64>,
}

/// Everything written to `--out`.
#[derive(Serialize)]
struct Output<'a> {
    rows: &'a [Row<'a>],
    reference_iterations: usize,
    plan_iterations: usize,
    memory_method: &'static str,
    total_wall_s: f64,
}

/// The x axis of the G plots, with the key to the point labels.
fn plan_x_label(plans: &[(usize, &PlanRow)]) -> String {
    if plans.iter().any(|(_, p)| p.status == "iteration_limit") {
        "optimization wall time [s]  (labels: n_iter; \"(limit)\": stopped at the iteration limit)"
            .into()
    } else {
        "optimization wall time [s]  (labels: n_iter)".into()
    }
}

const MEMORY_METHOD: &str =
    "VmHWM from /proc/self/status in a fresh child process per (n, threads): \
     peak_rss_mb is the process peak after the forward+∇L runs, rss_growth_mb its growth over them";

/// The scene's stretch edges and rest lengths, for the constraint residual.
struct Stretch {
    edges: Vec<[usize; 2]>,
    rest: Vec<f64>,
}

impl Stretch {
    fn of(scene: &Scene) -> Stretch {
        let x = scene.rest_positions();
        let edges = scene.mesh().stretch_edges();
        let rest = edges.iter().map(|&[i, j]| dist(&x[i], &x[j])).collect();
        Stretch { edges, rest }
    }

    /// (max |C|, RMS C, max |C| per step) over steps 1..T of `states` (`N × 3` each).
    fn residual(&self, states: &[Tensor]) -> (f64, f64, Vec<f64>) {
        let (mut sq, mut count, mut per_step) = (0.0, 0usize, Vec::new());
        for x in states.iter().skip(1) {
            let p = |i: usize| {
                let r = x.row(i);
                [r[0], r[1], r[2]]
            };
            let mut m: f64 = 0.0;
            for (&[i, j], &l0) in self.edges.iter().zip(&self.rest) {
                let c = dist(&p(i), &p(j)) - l0;
                m = m.max(c.abs());
                sq += c * c;
                count += 1;
            }
            per_step.push(m);
        }
        let max = per_step.iter().copied().fold(0.0, f64::max);
        (max, (sq / count.max(1) as f64).sqrt(), per_step)
    }
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Wall-clock seconds of repeated runs (`std::time::Instant`).
#[derive(Serialize, Deserialize, Clone, Copy)]
struct Timing {
    median_s: f64,
    /// The fastest run: the least disturbed by other processes on a shared machine.
    min_s: f64,
    runs: usize,
}

impl Timing {
    fn once(s: f64) -> Timing {
        Timing {
            median_s: s,
            min_s: s,
            runs: 1,
        }
    }
}

/// Times `f` over `reps` runs, stopping early once `budget_s` is spent (always at least one run).
fn time_runs<T>(reps: usize, budget_s: f64, mut f: impl FnMut() -> Result<T>) -> Result<Timing> {
    let clock = Instant::now();
    let mut times = Vec::with_capacity(reps);
    while times.len() < reps.max(1) {
        let t = Instant::now();
        std::hint::black_box(f()?);
        times.push(t.elapsed().as_secs_f64());
        if clock.elapsed().as_secs_f64() > budget_s {
            break;
        }
    }
    let min_s = times.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(Timing {
        median_s: median(&mut times),
        min_s,
        runs: times.len(),
    })
}

fn rel_err(a: &Tensor, b: &Tensor) -> f64 {
    let diff: f64 = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).powi(2))
        .sum();
    let norm: f64 = b.data().iter().map(|y| y * y).sum();
    (diff / norm).sqrt()
}

/// Where the accuracy and timing rows are evaluated, and how to describe it.
///
/// `u_obstacle`: the scene's initial guess (constant `(0, 0.3, 0)` per step). `swing`: its guess is
/// all zeros, where the flat hanging sheet is a symmetric, unstable (buckling) equilibrium — L jumps
/// by ~2e−4 under a 1e−7 perturbation and the "gradient" there grows with n_iter (‖∇L‖ ≈ 0.7 at 5,
/// 2e3 at 100, 1e10 at ≥ 1000 iterations), so no gradient error can be measured there. Instead a
/// smooth point: the corners move by `(0, 0.25, 0.05)·(0.6 + 0.08 t)` at step `t` (no zero control
/// differences, so no kink of T either; ∇L agrees with central differences to 1e−8 there).
fn evaluation_point(scene: &Scene, model: &Model) -> Result<(Controls, String)> {
    if scene.name != "swing" {
        return Ok((
            plan::initial_controls(scene, model)?,
            "initial guess".into(),
        ));
    }
    let t_max = model.task.horizon;
    let k = model.n_controls();
    let data = (0..t_max)
        .flat_map(|t| {
            let s = 0.6 + 0.08 * t as f64;
            (0..k).flat_map(move |_| [0.0, 0.25 * s, 0.05 * s])
        })
        .collect();
    let u = Tensor::new(t_max, 3 * k, data);
    model.check_controls(&u)?;
    Ok((u, "ramp (0, 0.25, 0.05)·(0.6 + 0.08 t)".into()))
}

/// `scene` with `n` solver iterations per step.
fn with_iterations(scene: &Scene, n: usize) -> Scene {
    let mut s = scene.clone();
    s.physics.iterations = n;
    s
}

/// `Some(v)` for a finite value (min SDF is ∞ without safety obstacles).
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The hidden child: one mesh-size measurement, printed as one JSON line.
fn measure_mesh(
    n: usize,
    threads: usize,
    iterations: usize,
    reps: usize,
    budget_s: f64,
) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let scene = with_iterations(&Scene::builtin("u_obstacle")?.refined(n, n)?, iterations);
    let model = Model::from_scene(&scene)?;
    let start = plan::initial_controls(&scene, &model)?;
    let delta = scene.task.delta;
    let row = pool.install(|| -> Result<MeshRow> {
        let hwm0 = support::proc_status_kb("VmHWM");
        let mut l = f64::NAN;
        let fg = time_runs(reps, budget_s, || {
            let ev = model.evaluate_loss_gradient(&start, delta)?;
            l = ev.metrics.l;
            Ok(ev)
        })?;
        let hwm1 = support::proc_status_kb("VmHWM");
        let fwd = time_runs(reps, budget_s, || Ok(model.evaluate(&start, delta, false)?))?;
        Ok(MeshRow {
            scene: "u_obstacle".into(),
            n,
            particles: model.n_particles(),
            n_iter: iterations,
            threads,
            forward: fwd,
            forward_grad_l: fg,
            l,
            peak_rss_mb: hwm1.map(|k| k / 1024.0),
            rss_growth_mb: hwm0.zip(hwm1).map(|(a, b)| (b - a) / 1024.0),
        })
    })?;
    println!("{}", serde_json::to_string(&row)?);
    Ok(())
}

/// Runs the mesh measurement in a fresh copy of this program.
fn spawn_mesh(n: usize, threads: usize, reps: usize) -> Result<MeshRow> {
    let exe = std::env::current_exe().context("cannot locate this example's executable")?;
    let out = Command::new(exe)
        .args([
            "measure-mesh",
            "--n",
            &n.to_string(),
            "--threads",
            &threads.to_string(),
        ])
        .args(["--iterations", &MESH_N_ITER.to_string()])
        .args(["--reps", &reps.to_string()])
        .args(["--budget-s", &MESH_BUDGET_S.to_string()])
        .output()
        .context("cannot start the measurement child")?;
    ensure!(
        out.status.success(),
        "mesh measurement n = {n}, {threads} thread(s) failed: {}",
        String::from_utf8_lossy(&out.stderr).trim()
    );
    serde_json::from_slice(&out.stdout).context("unreadable output of the measurement child")
}

/// The sweep over `n_iter` for one scene: accuracy, cost, and the consequence for planning.
/// Also returns ∇L at [`MESH_N_ITER`] (if swept), for the JAX comparison.
fn sweep_scene(name: &str, cfg: &Config) -> Result<(Vec<AccuracyRow>, Option<Tensor>)> {
    let base = Scene::builtin(name)?;
    let delta = base.task.delta;
    let stretch = Stretch::of(&base);
    let threads = rayon::current_num_threads();
    let mut jax_grad = None;

    let ref_model = Model::from_scene(&with_iterations(&base, cfg.reference_iterations))?;
    let start = plan::initial_controls(&base, &ref_model)?;
    let (point, point_name) = evaluation_point(&base, &ref_model)?;
    eprintln!(
        "{name}: reference, {} iterations …",
        cfg.reference_iterations
    );
    let clock = Instant::now();
    let reference = ref_model.evaluate_loss_gradient(&point, delta)?;
    let ref_fg = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    ref_model.evaluate(&point, delta, false)?;
    let ref_fwd = clock.elapsed().as_secs_f64();
    let has_safety = ref_model.safety.is_some();
    let g_ref = reference
        .grad_l
        .as_ref()
        .ok_or_else(|| anyhow!("the reference evaluation returned no gradient"))?;
    let (max_c, rms_c, per_step) = stretch.residual(&reference.states);
    let mut rows = vec![AccuracyRow {
        scene: name.into(),
        n_iter: cfg.reference_iterations,
        point: point_name.clone(),
        reference: true,
        max_abs_c: max_c,
        rms_c,
        max_abs_c_per_step: per_step,
        e: reference.metrics.e,
        l: reference.metrics.l,
        g: reference.metrics.g,
        grad_rel_err: 0.0,
        forward: Timing::once(ref_fwd),
        forward_grad_l: Timing::once(ref_fg),
        evaluate_gradients: None,
        threads,
        plan: None,
        plan_skipped: Some("the reference".into()),
    }];

    for &n_iter in &cfg.n_iters {
        let scene = with_iterations(&base, n_iter);
        let model = Model::from_scene(&scene)?;
        eprintln!("{name}: n_iter = {n_iter}: timing …");
        // The first evaluation is also the warm-up of the timings.
        let ev = model.evaluate(&point, delta, true)?;
        let grad = ev
            .grad_l
            .ok_or_else(|| anyhow!("evaluate returned no gradient"))?;
        let (max_c, rms_c, per_step) = stretch.residual(&ev.states);
        let inf = f64::INFINITY;
        let fwd = time_runs(cfg.reps, inf, || Ok(model.evaluate(&point, delta, false)?))?;
        let fg = time_runs(cfg.reps, inf, || {
            Ok(model.evaluate_loss_gradient(&point, delta)?)
        })?;
        let eval_g = if has_safety {
            Some(time_runs(cfg.reps, inf, || {
                Ok(model.evaluate(&point, delta, true)?)
            })?)
        } else {
            None
        };
        let mut row = AccuracyRow {
            scene: name.into(),
            n_iter,
            point: point_name.clone(),
            reference: false,
            max_abs_c: max_c,
            rms_c,
            max_abs_c_per_step: per_step,
            e: ev.metrics.e,
            l: ev.metrics.l,
            g: ev.metrics.g,
            grad_rel_err: rel_err(&grad, g_ref),
            forward: fwd,
            forward_grad_l: fg,
            evaluate_gradients: eval_g,
            threads,
            plan: None,
            plan_skipped: None,
        };
        if n_iter == MESH_N_ITER {
            jax_grad = Some(grad);
        }
        if n_iter > cfg.plan_max_n_iter {
            row.plan_skipped = Some(format!(
                "n_iter > {} (a plan costs ~n_iter/100 × the 100-iteration plan; raise --plan-max-n-iter)",
                cfg.plan_max_n_iter
            ));
        } else {
            eprintln!("{name}: n_iter = {n_iter}: planning …");
            match plan_at(&model, &scene, &ref_model, &start, &stretch, cfg) {
                Ok(p) => row.plan = Some(p),
                Err(e) => row.plan_skipped = Some(format!("planning failed: {e:#}")),
            }
        }
        rows.push(row);
    }
    Ok((rows, jax_grad))
}

/// Optimizes at `model`'s accuracy, then re-simulates the plan with `ref_model`.
fn plan_at(
    model: &Model,
    scene: &Scene,
    ref_model: &Model,
    start: &Controls,
    stretch: &Stretch,
    cfg: &Config,
) -> Result<PlanRow> {
    let mut options = PlanOptions::for_model(model);
    options.iterations = cfg.plan_iterations;
    let delta = options.task.delta;
    let result = plan::plan(model, scene, start, &options, |_| {})?;
    let planned_states = plan::states_of(&result)?;
    let controls = plan::controls_from_nested(ref_model, &result.controls)?;
    let truth = ref_model.evaluate(&controls, delta, false)?;
    let true_min_sdf = finite(truth.metrics.min_sdf);
    Ok(PlanRow {
        status: result.status.clone(),
        iterations: result.iterations,
        simulations: result.evaluations,
        wall_s: result.wall_s,
        planned_g: result.metrics.g,
        planned_l: result.metrics.l,
        planned_min_sdf: finite(result.metrics.min_sdf),
        planned_max_abs_c: stretch.residual(&planned_states).0,
        true_g: truth.metrics.g,
        true_l: truth.metrics.l,
        true_min_sdf,
        true_min_sdf_swept: finite(truth.metrics.min_sdf_swept),
        true_max_abs_c: stretch.residual(&truth.states).0,
        safe: true_min_sdf.map(|_| plan::is_safe(&truth.metrics)),
    })
}

/// The JAX benchmark's output line.
#[derive(Deserialize)]
struct JaxOut {
    forward_s: f64,
    forward_gradient_s: f64,
    #[serde(rename = "L")]
    l: f64,
    #[serde(rename = "grad_L")]
    grad_l: Vec<Vec<[f64; 3]>>,
}

/// Runs the JAX reference for `scene` at mesh size `n`.
fn run_jax(python: &Path, script: &Path, scene: &str, n: usize, n_iter: usize) -> Result<JaxOut> {
    let code = if scene == "u_obstacle" { "U" } else { scene };
    support::run_jax(python, script, code, n, n_iter)
}

fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("—".into(), |v| format!("{v:.prec$}"))
}

fn print_tables(acc: &[AccuracyRow], mesh: &[MeshRow], jax: &[JaxRow], cfg: &Config) {
    println!(
        "\nAccuracy and cost (reference: {} iterations; times: medians of {} runs, {} threads)",
        cfg.reference_iterations,
        cfg.reps,
        rayon::current_num_threads()
    );
    println!(
        "{:<11}{:>7}{:>10}{:>10}{:>10}{:>9}{:>10}{:>11}{:>12}{:>12}",
        "scene",
        "n_iter",
        "max|C|",
        "RMS C",
        "E",
        "L",
        "∇L err",
        "fwd [ms]",
        "fwd+∇L [ms]",
        "+∇C [ms]"
    );
    for r in acc {
        println!(
            "{:<11}{:>7}{:>10.2e}{:>10.2e}{:>10.1}{:>9.4}{:>10}{:>11.2}{:>12.2}{:>12}",
            r.scene,
            r.n_iter,
            r.max_abs_c,
            r.rms_c,
            r.e,
            r.l,
            if r.reference {
                "ref".into()
            } else {
                format!("{:.2e}", r.grad_rel_err)
            },
            1e3 * r.forward.median_s,
            1e3 * r.forward_grad_l.median_s,
            fmt_opt(r.evaluate_gradients.map(|t| 1e3 * t.median_s), 2),
        );
    }
    println!("(max|C|, RMS C: stretch residual |x_i − x_j| − l⁰ over all edges and all steps' ends (rest lengths");
    println!(" 0.111 and 0.157). ∇L err: ‖∇L − ∇L_ref‖/‖∇L_ref‖. fwd: rollout + metrics; fwd+∇L: also ∇L (as JAX's");
    println!(
        " benchmark); +∇C: evaluate(.., true), which also pulls back dC/dU. Reference rows: 1 run."
    );
    println!(" Points: u_obstacle's initial guess; swing at a smooth ramp u_t = (0, 0.25, 0.05)·(0.6 + 0.08t), because");
    println!(" its all-zero guess is a flat, unstable equilibrium where ∇L is meaningless (‖∇L‖ ≈ 0.7 at 5, 2e3 at");
    println!(" 100, 1e10 at ≥ 1000 iterations). u_obstacle's constant guess puts T = Σ‖u_t − u_t−1‖ at its kink, whose");
    println!(" sub-gradient is 0 in every run.)");

    println!(
        "\nConsequence for planning: SQP (≤ {} iterations per κ stage) from the scene's initial guess at n_iter, re-simulated at {} iterations (\"true\")",
        cfg.plan_iterations, cfg.reference_iterations
    );
    println!(
        "{:<11}{:>7}{:>17}{:>6}{:>6}{:>9}{:>9}{:>9}{:>10}{:>10}{:>10}{:>7}",
        "scene",
        "n_iter",
        "status",
        "iter",
        "sims",
        "opt [s]",
        "G plan",
        "G true",
        "SDF plan",
        "SDF true",
        "max|C|",
        "safe"
    );
    for r in acc.iter().filter(|r| !r.reference) {
        match (&r.plan, &r.plan_skipped) {
            (Some(p), _) => println!(
                "{:<11}{:>7}{:>17}{:>6}{:>6}{:>9.1}{:>9.4}{:>9.4}{:>10}{:>10}{:>10.2e}{:>7}",
                r.scene,
                r.n_iter,
                p.status,
                p.iterations,
                p.simulations,
                p.wall_s,
                p.planned_g,
                p.true_g,
                fmt_opt(p.planned_min_sdf, 4),
                fmt_opt(p.true_min_sdf, 4),
                p.planned_max_abs_c,
                p.safe.map_or("—", |s| if s { "yes" } else { "NO" }),
            ),
            (None, reason) => println!(
                "{:<11}{:>7}  skipped: {}",
                r.scene,
                r.n_iter,
                reason.as_deref().unwrap_or("")
            ),
        }
    }
    println!("(G plan / SDF plan: as the planner saw them at n_iter; max|C|: the plan's stretch residual at n_iter;");
    println!(
        " safe: re-simulated, C ≥ −1e−6 with δ = {} (plan::is_safe: no particle more than 1e−6 inside δ); swing has no obstacle.)",
        cfg.delta
    );

    if !mesh.is_empty() {
        println!(
            "\nMesh size: u_obstacle at its initial guess, {MESH_N_ITER} iterations (fresh process per row)"
        );
        println!(
            "{:>4}{:>10}{:>9}{:>11}{:>14}{:>6}{:>15}{:>13}",
            "n",
            "particles",
            "threads",
            "fwd [ms]",
            "fwd+∇L [ms]",
            "runs",
            "peak RSS [MB]",
            "growth [MB]"
        );
        for r in mesh {
            println!(
                "{:>4}{:>10}{:>9}{:>11.1}{:>14.1}{:>6}{:>15}{:>13}",
                r.n,
                r.particles,
                r.threads,
                1e3 * r.forward.median_s,
                1e3 * r.forward_grad_l.median_s,
                r.forward_grad_l.runs,
                fmt_opt(r.peak_rss_mb, 1),
                fmt_opt(r.rss_growth_mb, 1),
            );
        }
        println!("(runs: up to {} or until {MESH_BUDGET_S} s are spent; peak RSS: the child's VmHWM after the fwd+∇L runs,", cfg.reps);
        println!(" growth: its increase over them, the model already built)");
    }

    if !jax.is_empty() {
        println!("\nJAX-jit reference (same spec, float64, CPU, jit compile excluded) beside ours, u_obstacle, {MESH_N_ITER} iterations");
        println!(
            "{:>4}{:>14}{:>16}{:>14}{:>16}{:>10}{:>10}",
            "n", "JAX fwd [ms]", "JAX fwd+∇L [ms]", "ours fwd", "ours fwd+∇L", "L diff", "∇L diff"
        );
        for r in jax {
            println!(
                "{:>4}{:>14.2}{:>16.2}{:>14}{:>16}{:>10}{:>10}",
                r.n,
                1e3 * r.forward_s,
                1e3 * r.forward_grad_l_s,
                fmt_opt(r.ours_forward_s.map(|s| 1e3 * s), 2),
                fmt_opt(r.ours_forward_grad_l_s.map(|s| 1e3 * s), 2),
                r.l_rel_diff.map_or("—".into(), |v| format!("{v:.1e}")),
                r.grad_rel_diff.map_or("—".into(), |v| format!("{v:.1e}")),
            );
        }
        println!("(L, ∇L diff: relative, n = 10 only; at larger n JAX targets the whole bottom row while");
        println!(" Scene::refined keeps the 10 original material points, so L differs by design, not the work)");
    }
}

/// A series of labelled points `(x, y, label)`.
fn labelled(points: Vec<(f64, f64, String)>, name: String) -> Series {
    let (points, labels) = points.into_iter().map(|(x, y, l)| ((x, y), l)).unzip();
    Series {
        name,
        points,
        labels,
    }
}

/// `n_iter`, and the plan's status when it did not converge (e.g. `"20 (limit)"`).
fn plan_label(n_iter: usize, p: &PlanRow) -> String {
    match p.status.as_str() {
        "converged" => n_iter.to_string(),
        "iteration_limit" => format!("{n_iter} (limit)"),
        other => format!("{n_iter} ({other})"),
    }
}

/// Draws the PNGs into the existing directory `dir`; returns their paths.
fn draw_plots(
    dir: &Path,
    acc: &[AccuracyRow],
    mesh: &[MeshRow],
    jax: &[JaxRow],
    cfg: &Config,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let mut draw = |fig: &XyFigure, file: &str| -> Result<()> {
        let path = dir.join(file);
        draw_xy(fig, &path)?;
        written.push(path);
        Ok(())
    };
    let swept = |scene: &'static str| acc.iter().filter(move |r| r.scene == scene && !r.reference);
    let ref_it = cfg.reference_iterations;

    // 1. Gradient error against forward+∇L time.
    let mut series: Vec<Series> = ["u_obstacle", "swing"]
        .into_iter()
        .map(|s| {
            let pts = swept(s)
                .filter(|r| r.grad_rel_err > 0.0)
                .map(|r| {
                    let t = 1e3 * r.forward_grad_l.median_s;
                    (t, r.grad_rel_err, r.n_iter.to_string())
                })
                .collect();
            labelled(pts, format!("{s} (this library)"))
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    let jax_pts: Vec<_> = jax
        .iter()
        .filter(|j| j.n == 10)
        .filter_map(|j| {
            let r = swept("u_obstacle").find(|r| r.n_iter == j.n_iter && r.grad_rel_err > 0.0)?;
            Some((
                1e3 * j.forward_grad_l_s,
                r.grad_rel_err,
                j.n_iter.to_string(),
            ))
        })
        .collect();
    if !jax_pts.is_empty() {
        series.push(labelled(jax_pts, "u_obstacle, JAX-jit (same ∇L)".into()));
    }
    if !series.is_empty() {
        draw(
            &XyFigure {
                title: "Gradient accuracy vs cost (labels: Gauss–Seidel iterations per step)"
                    .into(),
                x_label: "time of one forward + ∇L pass [ms] (median)".into(),
                y_label: format!("relative error of ∇L vs {ref_it} iterations"),
                series,
                log_x: true,
                log_y: true,
                ref_lines: vec![],
            },
            "accuracy_grad_error_vs_time.png",
        )?;
    }

    let planned = |scene: &'static str| {
        swept(scene)
            .filter_map(|r| r.plan.as_ref().map(|p| (r.n_iter, p)))
            .collect::<Vec<_>>()
    };

    // 2. True min SDF of the plans against optimization time (u_obstacle). Plans that never came
    //    near the obstacle are left off, so that the axis resolves the distances around δ.
    let delta = cfg.delta;
    let u = planned("u_obstacle");
    let (near, far): (Vec<_>, Vec<_>) = u
        .iter()
        .filter(|(_, p)| p.true_min_sdf.is_some())
        .partition(|(_, p)| p.true_min_sdf.is_some_and(|m| m <= 3.0 * delta));
    if !near.is_empty() {
        let pts = |f: &dyn Fn(&PlanRow) -> Option<f64>, status: bool| {
            near.iter()
                .filter_map(|(n, p)| {
                    let label = if status {
                        plan_label(*n, p)
                    } else {
                        n.to_string()
                    };
                    f(p).map(|v| (p.wall_s, v, label))
                })
                .collect::<Vec<_>>()
        };
        let mut x_label = "optimization wall time [s] (labels: n_iter".to_string();
        if !far.is_empty() {
            let list: Vec<String> = far.iter().map(|(n, _)| n.to_string()).collect();
            x_label += &format!(
                "; not shown: {}, min SDF > {:.1}, never reached the obstacle",
                list.join(", "),
                3.0 * delta
            );
        }
        x_label += ")";
        draw(
            &XyFigure {
                title: "u_obstacle: does a plan optimized at n_iter iterations stay safe?".into(),
                x_label,
                y_label: "min SDF over the trajectory".into(),
                series: vec![
                    labelled(
                        pts(&|p| p.true_min_sdf, true),
                        format!("true: re-simulated at {ref_it} iterations"),
                    ),
                    labelled(
                        pts(&|p| p.planned_min_sdf, false),
                        "as the planner saw it (n_iter)".into(),
                    ),
                ],
                log_x: true,
                log_y: false,
                ref_lines: vec![RefLine {
                    y: delta,
                    label: format!("δ = {delta}: safe above"),
                }],
            },
            "accuracy_plan_min_sdf.png",
        )?;
    }

    // 3. True G of the plans against optimization time, one figure per scene.
    for s in ["u_obstacle", "swing"] {
        let p = planned(s);
        if p.is_empty() {
            continue;
        }
        let series = vec![
            labelled(
                p.iter()
                    .map(|(n, p)| (p.wall_s, p.true_g, plan_label(*n, p)))
                    .collect(),
                format!("true G: re-simulated at {ref_it} iterations"),
            ),
            labelled(
                p.iter()
                    .map(|(n, p)| (p.wall_s, p.planned_g, n.to_string()))
                    .collect(),
                "G as the planner saw it (n_iter)".into(),
            ),
        ];
        let log_y = series.iter().all(|s| s.points.iter().all(|p| p.1 > 0.0));
        draw(
            &XyFigure {
                title: format!("{s}: target error of plans optimized at n_iter iterations"),
                x_label: plan_x_label(&p),
                y_label: "target error G (lower is better)".into(),
                series,
                log_x: true,
                log_y,
                ref_lines: vec![],
            },
            &format!("accuracy_plan_g_{s}.png"),
        )?;
    }

    // 4. Mesh size.
    if !mesh.is_empty() {
        let mut threads: Vec<usize> = mesh.iter().map(|r| r.threads).collect();
        threads.sort_unstable();
        threads.dedup();
        let series = threads
            .iter()
            .map(|&k| {
                let pts = mesh
                    .iter()
                    .filter(|r| r.threads == k)
                    .map(|r| {
                        let label = match r.peak_rss_mb {
                            Some(m) => format!("{0}×{0}, {m:.0} MB", r.n),
                            None => format!("{0}×{0}", r.n),
                        };
                        (r.particles as f64, r.forward_grad_l.median_s, label)
                    })
                    .collect();
                labelled(pts, format!("{k} thread{}", if k == 1 { "" } else { "s" }))
            })
            .collect();
        draw(
            &XyFigure {
                title: format!(
                    "u_obstacle forward + ∇L, {MESH_N_ITER} iterations (labels: mesh, peak RSS)"
                ),
                x_label: "particles".into(),
                y_label: "time [s] (median)".into(),
                series,
                log_x: true,
                log_y: true,
                ref_lines: vec![],
            },
            "accuracy_mesh_scaling.png",
        )?;
    }
    Ok(written)
}

/// Writes `{"rows": [...]}` to `path` (if any): the accuracy rows, then the mesh and JAX rows.
fn write_output(
    path: Option<&Path>,
    acc: &[AccuracyRow],
    mesh: &[MeshRow],
    jax: &[JaxRow],
    cfg: &Config,
    total: f64,
) -> Result<()> {
    if let Some(path) = path {
        let rows: Vec<Row> = acc
            .iter()
            .map(Row::Accuracy)
            .chain(mesh.iter().map(Row::Mesh))
            .chain(jax.iter().map(Row::Jax))
            .collect();
        plan::write_json_atomic(
            path,
            &Output {
                rows: &rows,
                reference_iterations: cfg.reference_iterations,
                plan_iterations: cfg.plan_iterations,
                memory_method: MEMORY_METHOD,
                total_wall_s: total,
            },
        )?;
    }
    Ok(())
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(Child::MeasureMesh {
        n,
        threads,
        iterations,
        reps,
        budget_s,
    }) = args.child
    {
        return measure_mesh(n, threads, iterations, reps, budget_s);
    }
    let clock = Instant::now();
    let q = args.quick;
    let cfg = Config {
        n_iters: if q {
            vec![5, 20, 100]
        } else {
            vec![5, 10, 20, 50, 100, 200, 400, 1000]
        },
        reference_iterations: args
            .reference_iterations
            .unwrap_or(if q { 1000 } else { 5000 }),
        reps: args.reps.unwrap_or(if q { 3 } else { 5 }),
        plan_iterations: args.plan_iterations.unwrap_or(if q { 30 } else { 150 }),
        plan_max_n_iter: args.plan_max_n_iter,
        mesh_sizes: if q {
            vec![10, 20]
        } else {
            vec![10, 20, 40, 80]
        },
        delta: Scene::builtin("u_obstacle")?.task.delta,
    };
    plan::ensure_iterations("--reps", cfg.reps)?;
    plan::ensure_iterations("--plan-iterations", cfg.plan_iterations)?;
    plan::ensure_iterations("--reference-iterations", cfg.reference_iterations)?;
    if let Some(dir) = &args.png_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    // Fail now rather than after minutes of measuring.
    if let Some(dir) = args
        .out
        .as_deref()
        .and_then(Path::parent)
        .filter(|d| !d.as_os_str().is_empty())
    {
        ensure!(
            dir.is_dir(),
            "--out: the directory {} does not exist",
            dir.display()
        );
    }

    let mut acc = Vec::new();
    let mut grads = HashMap::new();
    for name in ["u_obstacle", "swing"] {
        let (rows, g) = sweep_scene(name, &cfg)?;
        acc.extend(rows);
        if let Some(g) = g {
            grads.insert(name, g);
        }
        write_output(
            args.out.as_deref(),
            &acc,
            &[],
            &[],
            &cfg,
            clock.elapsed().as_secs_f64(),
        )?;
    }

    let mut mesh = Vec::new();
    for &n in &cfg.mesh_sizes {
        for threads in [1, 2] {
            eprintln!("mesh {n}×{n}, {threads} thread(s) …");
            mesh.push(spawn_mesh(n, threads, cfg.reps)?);
        }
    }

    let mut jax = Vec::new();
    let jax_clock = Instant::now();
    if let Some(python) = &args.jax {
        // u_obstacle only: the benchmark evaluates at the scene's initial guess, which for swing
        // is the degenerate all-zero point (see `evaluation_point`).
        let mut settings = vec![("u_obstacle", 10)];
        settings.extend(
            cfg.mesh_sizes
                .iter()
                .filter(|&&n| n > 10 && n <= 40)
                .map(|&n| ("u_obstacle", n)),
        );
        for (scene, n) in settings {
            eprintln!("JAX: {scene}, n = {n}, {MESH_N_ITER} iterations …");
            let j = match run_jax(python, &args.jax_script, scene, n, MESH_N_ITER) {
                Ok(j) => j,
                Err(e) => {
                    eprintln!("JAX skipped: {e:#}");
                    break;
                }
            };
            let ours = acc
                .iter()
                .find(|r| r.scene == scene && r.n_iter == MESH_N_ITER && n == 10);
            let ours_mesh = mesh
                .iter()
                .find(|r| r.n == n && r.threads == 2 && scene == "u_obstacle");
            // L is comparable at n = 10 only (see `JaxRow::l_rel_diff`).
            let ours_l = ours.map(|r| r.l);
            let grad_rel_diff = grads.get(scene).filter(|_| n == 10).map(|g| {
                let flat: Vec<f64> = j.grad_l.iter().flatten().flatten().copied().collect();
                rel_err(&Tensor::new(g.rows(), g.cols(), flat), g)
            });
            jax.push(JaxRow {
                scene: scene.into(),
                n,
                n_iter: MESH_N_ITER,
                forward_s: j.forward_s,
                forward_grad_l_s: j.forward_gradient_s,
                l: j.l,
                ours_forward_s: ours
                    .map(|r| r.forward.median_s)
                    .or(ours_mesh.map(|r| r.forward.median_s)),
                ours_forward_grad_l_s: ours
                    .map(|r| r.forward_grad_l.median_s)
                    .or(ours_mesh.map(|r| r.forward_grad_l.median_s)),
                l_rel_diff: ours_l.map(|l| (j.l - l).abs() / l.abs()),
                grad_rel_diff,
            });
        }
    }

    let jax_time = jax_clock.elapsed().as_secs_f64();
    print_tables(&acc, &mesh, &jax, &cfg);
    let total = clock.elapsed().as_secs_f64();
    write_output(args.out.as_deref(), &acc, &mesh, &jax, &cfg, total)?;
    if let Some(dir) = &args.png_dir {
        for p in draw_plots(dir, &acc, &mesh, &jax, &cfg)? {
            println!("wrote {}", p.display());
        }
    }
    if let Some(out) = &args.out {
        println!("wrote {}", out.display());
    }
    if args.jax.is_some() {
        println!(
            "total wall time {:.1} s (of which the JAX runs {:.1} s)",
            clock.elapsed().as_secs_f64(),
            jax_time
        );
    } else {
        println!("total wall time {:.1} s", clock.elapsed().as_secs_f64());
    }
    Ok(())
}
