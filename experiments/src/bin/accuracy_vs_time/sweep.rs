//! The measurements: the `n_iter` sweep of one scene (accuracy, cost, planning) and the
//! mesh-size rows, each in a fresh child process.

use anyhow::{anyhow, Result};
use autodiff::Tensor;
use cloth::{Controls, Model, Scene};
use clothopt::plan::{self, PlanOptions};
use clothopt::result::{controls_from_nested, is_safe, states_of};
use experiments::child;
use experiments::measure::{proc_status_kb, time_runs, Timing};
use std::time::Instant;

use crate::rows::{AccuracyRow, MeshRow, NewtonCounts, PlanRow};
use crate::{Config, MESH_BUDGET_S, MESH_N_ITER};

/// The scene's stretch edges and rest lengths, for the constraint residual.
pub struct Stretch {
    pub edges: Vec<[usize; 2]>,
    pub rest: Vec<f64>,
}

impl Stretch {
    pub fn of(scene: &Scene) -> Stretch {
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

pub fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

pub fn rel_err(a: &Tensor, b: &Tensor) -> f64 {
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
pub fn evaluation_point(scene: &Scene, model: &Model) -> Result<(Controls, String)> {
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
pub fn with_iterations(scene: &Scene, n: usize) -> Scene {
    let mut s = scene.clone();
    s.physics.iterations = n;
    s
}

/// `Some(v)` for a finite value (min SDF is ∞ without safety obstacles).
pub fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// The hidden child: one mesh-size measurement, printed as one JSON line.
pub fn measure_mesh(
    n: usize,
    threads: usize,
    iterations: usize,
    tolerance: Option<f64>,
    reps: usize,
    budget_s: f64,
) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let mut scene = with_iterations(&Scene::builtin("u_obstacle")?.refined(n, n)?, iterations);
    if let Some(tol) = tolerance {
        scene.physics.solver = Some(cloth::scene::SolverKind::Newton);
        scene.physics.tolerance = Some(tol);
    }
    let model = Model::from_scene(&scene)?;
    let start = plan::initial_controls(&scene, &model)?;
    let delta = scene.task.delta;
    let row = pool.install(|| -> Result<MeshRow> {
        let hwm0 = proc_status_kb("VmHWM");
        let mut l = f64::NAN;
        let fg = time_runs(reps, budget_s, || {
            let ev = model.evaluate_loss_gradient(&start, delta)?;
            l = ev.metrics.l;
            Ok(ev)
        })?;
        let hwm1 = proc_status_kb("VmHWM");
        // Newton's forward is timed through the rollout that counts its work (the metrics,
        // which `evaluate` adds, cost microseconds beside it).
        let mut counts = None;
        let fwd = match model.solver {
            cloth::Solver::Newton(settings) => time_runs(reps, budget_s, || {
                let (_, stats) = model.simulate_newton(&start, &settings)?;
                counts = Some(NewtonCounts::of(&stats));
                Ok(())
            })?,
            cloth::Solver::Xpbd => {
                time_runs(reps, budget_s, || Ok(model.evaluate(&start, delta, false)?))?
            }
        };
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
            tolerance,
            newton: counts,
        })
    })?;
    println!("{}", serde_json::to_string(&row)?);
    Ok(())
}

/// Runs the mesh measurement ([`MESH_N_ITER`] XPBD iterations) in a fresh copy of this program.
pub fn spawn_mesh(n: usize, threads: usize, reps: usize) -> Result<MeshRow> {
    spawn_mesh_with(n, threads, reps, MESH_N_ITER, None)
}

/// Runs the mesh measurement in a fresh copy of this program: XPBD at `iterations`, or with a
/// `tolerance` Newton to it.
pub fn spawn_mesh_with(
    n: usize,
    threads: usize,
    reps: usize,
    iterations: usize,
    tolerance: Option<f64>,
) -> Result<MeshRow> {
    let what = format!("mesh measurement n = {n}, {threads} thread(s)");
    let mut cmd = child::this_program()?;
    cmd.args(["measure-mesh", "--n", &n.to_string()])
        .args(["--threads", &threads.to_string()])
        .args(["--iterations", &iterations.max(1).to_string()])
        .args(["--reps", &reps.to_string()])
        .args(["--budget-s", &MESH_BUDGET_S.to_string()]);
    if let Some(tol) = tolerance {
        cmd.args(["--tolerance", &tol.to_string()]);
    }
    let stdout = child::run(&mut cmd, &what)?;
    child::last_json_line(&stdout, &what)
}

/// The sweep over `n_iter` for one scene: accuracy, cost, and the consequence for planning.
/// Also returns ∇L at [`MESH_N_ITER`] (if swept), for the JAX comparison.
pub fn sweep_scene(name: &str, cfg: &Config) -> Result<(Vec<AccuracyRow>, Option<Tensor>)> {
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
                Ok((p, _)) => row.plan = Some(p),
                Err(e) => row.plan_skipped = Some(format!("planning failed: {e:#}")),
            }
        }
        rows.push(row);
    }
    Ok((rows, jax_grad))
}

/// Optimizes at `model`'s accuracy (at most `cfg.plan_iterations` per stage), then re-simulates
/// the plan with `ref_model`; also returns the plan's controls (checked against `ref_model`).
pub fn plan_at(
    model: &Model,
    scene: &Scene,
    ref_model: &Model,
    start: &Controls,
    stretch: &Stretch,
    cfg: &Config,
) -> Result<(PlanRow, Controls)> {
    let mut options = PlanOptions::for_model(model);
    options.iterations = cfg.plan_iterations;
    let delta = options.task.delta;
    let result = plan::plan(model, scene, start, &options, |_| {})?;
    let planned_states = states_of(&result)?;
    let controls = controls_from_nested(ref_model, &result.controls)?;
    let truth = ref_model.evaluate(&controls, delta, false)?;
    let true_min_sdf = finite(truth.metrics.min_sdf);
    let row = PlanRow {
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
        safe: true_min_sdf.map(|_| is_safe(&truth.metrics)),
    };
    Ok((row, controls))
}
