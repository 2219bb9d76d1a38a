//! The Newton rows (issue 17): a tolerance sweep of the Newton solver beside XPBD iteration counts
//! on `u_obstacle` at each mesh size, against one converged reference per size.
//!
//! Reference: ∇L of the Newton minimizer at [`REFERENCE_TOLERANCE`] (relative `‖∇Φ‖`; round-off
//! stops the solve where `f64` can do no better). XPBD rows are measured against the same
//! reference, so their error includes the distance between XPBD's fixed point and Newton's
//! minimizer (they differ: docs/physics.md, "The two solvers"), which no iteration count
//! removes.
//! Timing and peak memory come from a fresh child process per row (the mesh measurement).
//! At the `--newton-plan-sizes`, each setting also plans `u_obstacle` with its own physics, and
//! the plan is re-simulated with converged physics (Newton at the reference tolerance) and with
//! XPBD at [`XPBD_CHECK_ITERATIONS`] (the check; XPBD's limit is another fixed point).

use anyhow::Result;
use cloth::scene::SolverKind;
use cloth::{Model, Scene};
use clothopt::plan;
use clothopt::plot::Series;
use clothopt::result::is_safe;
use serde::Serialize;

use crate::rows::{MeshRow, PlanRow};
use crate::sweep::{finite, plan_at, rel_err, spawn_mesh_with, with_iterations, Stretch};
use crate::Config;

/// Newton tolerances swept (relative `‖∇Φ‖`).
pub const TOLERANCES: [f64; 4] = [1e-4, 1e-6, 1e-8, 1e-10];
/// The reference's tolerance.
pub const REFERENCE_TOLERANCE: f64 = 1e-12;
/// XPBD iterations of the second re-simulation of each plan.
pub const XPBD_CHECK_ITERATIONS: usize = 3000;

/// A plan made with one row's physics, re-simulated.
#[derive(Serialize)]
pub struct NewtonPlan {
    /// The plan, and its re-simulation with Newton at [`REFERENCE_TOLERANCE`] (`true_*`, `safe`).
    #[serde(flatten)]
    pub plan: PlanRow,
    /// Smallest obstacle distance of the plan re-simulated with XPBD at
    /// [`XPBD_CHECK_ITERATIONS`].
    pub xpbd_check_min_sdf: Option<f64>,
    /// That re-simulation passes [`is_safe`].
    pub xpbd_check_safe: Option<bool>,
}

/// One solver setting at one mesh size.
#[derive(Serialize)]
pub struct SolverRow {
    /// `"newton"` or `"xpbd"`.
    pub solver: &'static str,
    /// Mesh `n × n`.
    pub n: usize,
    /// Newton's tolerance (Newton rows).
    pub tolerance: Option<f64>,
    /// XPBD's iterations per step (XPBD rows).
    pub n_iter: Option<usize>,
    /// Relative distance of ∇L from the Newton reference.
    pub grad_rel_err: f64,
    /// L at the scene's initial guess.
    pub l: f64,
    /// Forward and forward+∇L timing and peak RSS (one thread, fresh process).
    pub measured: MeshRow,
    /// The plan made with this physics (at the `--newton-plan-sizes`).
    pub plan: Option<NewtonPlan>,
    /// Why there is no plan.
    pub plan_skipped: Option<String>,
}

/// `scene` solved by Newton to `tolerance`.
fn with_newton(scene: &Scene, tolerance: f64) -> Scene {
    let mut s = scene.clone();
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.tolerance = Some(tolerance);
    s
}

/// ∇L and L of `scene` at its initial guess.
fn grad_l(scene: &Scene) -> Result<(autodiff::Tensor, f64)> {
    let model = Model::from_scene(scene)?;
    let u = plan::initial_controls(scene, &model)?;
    let ev = model.evaluate_loss_gradient(&u, scene.task.delta)?;
    Ok((ev.grad_l.expect("requested"), ev.metrics.l))
}

/// The rows at each size of `sizes`: Newton at [`TOLERANCES`], XPBD at `xpbd_iters`; at the
/// sizes in `plan_sizes`, each with its plan ([`plan_with`]).
pub fn sweep(
    sizes: &[usize],
    xpbd_iters: &[usize],
    plan_sizes: &[usize],
    cfg: &Config,
) -> Result<Vec<SolverRow>> {
    let mut rows = Vec::new();
    for &n in sizes {
        let scene = Scene::builtin("u_obstacle")?.refined(n, n)?;
        let reference_scene = with_newton(&scene, REFERENCE_TOLERANCE);
        let (reference, _) = grad_l(&reference_scene)?;
        let checks = plan_sizes
            .contains(&n)
            .then(|| -> Result<_> {
                let truth = Model::from_scene(&reference_scene)?;
                let xpbd = Model::from_scene(&with_iterations(&scene, XPBD_CHECK_ITERATIONS))?;
                Ok((truth, xpbd))
            })
            .transpose()?;
        let settings = TOLERANCES
            .iter()
            .map(|&tol| (with_newton(&scene, tol), Some(tol), None))
            .chain(
                xpbd_iters
                    .iter()
                    .map(|&it| (with_iterations(&scene, it), None, Some(it))),
            );
        for (s, tolerance, n_iter) in settings {
            let what = match (tolerance, n_iter) {
                (Some(tol), _) => format!("newton n = {n}, tolerance {tol:e}"),
                (_, it) => format!("xpbd n = {n}, {} iterations", it.unwrap_or(0)),
            };
            eprintln!("{what} …");
            let (g, l) = grad_l(&s)?;
            let (plan, plan_skipped) = match &checks {
                None => (None, Some(format!("n = {n} is not in --newton-plan-sizes"))),
                Some((truth, xpbd)) => {
                    eprintln!("{what}: planning …");
                    match plan_with(&s, truth, xpbd, cfg) {
                        Ok(p) => (Some(p), None),
                        Err(e) => (None, Some(format!("planning failed: {e:#}"))),
                    }
                }
            };
            rows.push(SolverRow {
                solver: if tolerance.is_some() {
                    "newton"
                } else {
                    "xpbd"
                },
                n,
                tolerance,
                n_iter,
                grad_rel_err: rel_err(&g, &reference),
                l,
                measured: spawn_mesh_with(n, 1, cfg.reps, n_iter.unwrap_or(0), tolerance)?,
                plan,
                plan_skipped,
            });
        }
    }
    Ok(rows)
}

/// Plans `scene`'s task with its own physics from its initial guess, then re-simulates the plan
/// with `truth` (converged Newton) and `xpbd` (XPBD at [`XPBD_CHECK_ITERATIONS`]).
fn plan_with(scene: &Scene, truth: &Model, xpbd: &Model, cfg: &Config) -> Result<NewtonPlan> {
    let model = Model::from_scene(scene)?;
    let start = plan::initial_controls(scene, &model)?;
    let stretch = Stretch::of(scene);
    let (plan, controls) = plan_at(&model, scene, truth, &start, &stretch, cfg)?;
    let check = xpbd.evaluate(&controls, scene.task.delta, false)?;
    let min_sdf = finite(check.metrics.min_sdf);
    Ok(NewtonPlan {
        plan,
        xpbd_check_min_sdf: min_sdf,
        xpbd_check_safe: min_sdf.map(|_| is_safe(&check.metrics)),
    })
}

/// Prints the rows as a table.
pub fn print_table(rows: &[SolverRow]) {
    println!(
        "\nu_obstacle, Newton vs XPBD (∇L error against Newton at tolerance {REFERENCE_TOLERANCE:e}; 1 thread)"
    );
    println!(
        "{:>4} {:>7} {:>10} {:>12} {:>10} {:>12} {:>14} {:>9}",
        "n", "solver", "setting", "∇L rel err", "L", "forward ms", "fwd+∇L ms", "peak MB"
    );
    for r in rows {
        let setting = setting(r);
        let m = &r.measured;
        println!(
            "{:>4} {:>7} {:>10} {:>12.3e} {:>10.4} {:>12.1} {:>14.1} {:>9}",
            r.n,
            r.solver,
            setting,
            r.grad_rel_err,
            r.l,
            1e3 * m.forward.median_s,
            1e3 * m.forward_grad_l.median_s,
            m.peak_rss_mb.map_or("-".into(), |v| format!("{v:.0}")),
        );
    }
}

/// Prints the plans of the rows that have one: what the planner saw with that physics, and the
/// plan re-simulated with converged Newton and with XPBD at [`XPBD_CHECK_ITERATIONS`].
pub fn print_plans(rows: &[SolverRow]) {
    let planned: Vec<_> = rows
        .iter()
        .filter_map(|r| r.plan.as_ref().map(|p| (r, p)))
        .collect();
    if planned.is_empty() {
        return;
    }
    println!(
        "\nu_obstacle plans made with each physics (min SDF ≥ δ is safe), re-simulated with Newton at tolerance {REFERENCE_TOLERANCE:e} and with XPBD at {XPBD_CHECK_ITERATIONS} iterations"
    );
    println!(
        "{:>4} {:>7} {:>10} {:>16} {:>6} {:>6} {:>9} {:>9} {:>10} {:>6} {:>11} {:>6}",
        "n",
        "solver",
        "setting",
        "status",
        "iters",
        "sims",
        "L",
        "min SDF",
        "Newton SDF",
        "safe",
        "XPBD SDF",
        "safe"
    );
    let opt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.4}"));
    let yes = |v: Option<bool>| v.map_or("-", |b| if b { "yes" } else { "NO" });
    for (r, p) in planned {
        let q = &p.plan;
        println!(
            "{:>4} {:>7} {:>10} {:>16} {:>6} {:>6} {:>9.4} {:>9} {:>10} {:>6} {:>11} {:>6}",
            r.n,
            r.solver,
            setting(r),
            q.status,
            q.iterations,
            q.simulations,
            q.planned_l,
            opt(q.planned_min_sdf),
            opt(q.true_min_sdf),
            yes(q.safe),
            opt(p.xpbd_check_min_sdf),
            yes(p.xpbd_check_safe),
        );
    }
}

/// A row's setting as a label: Newton's tolerance or XPBD's iterations.
fn setting(r: &SolverRow) -> String {
    match (r.tolerance, r.n_iter) {
        (Some(t), _) => format!("tol {t:.0e}"),
        (_, Some(i)) => format!("{i} it"),
        _ => String::new(),
    }
}

/// Writes `{"newton_rows": [...], "reference_tolerance": …}` to `path` (atomically).
pub fn write(path: &std::path::Path, rows: &[SolverRow]) -> Result<()> {
    #[derive(Serialize)]
    struct Out<'a> {
        newton_rows: &'a [SolverRow],
        reference_tolerance: f64,
        memory_method: &'static str,
    }
    clothopt::output::write_json_atomic(
        path,
        &Out {
            newton_rows: rows,
            reference_tolerance: REFERENCE_TOLERANCE,
            memory_method: crate::rows::MEMORY_METHOD,
        },
    )?;
    Ok(())
}

/// Draws gradient error against forward+∇L time, one curve per solver and size, into
/// `dir/accuracy_newton_vs_xpbd.png`; returns its path.
pub fn draw(dir: &std::path::Path, rows: &[SolverRow]) -> Result<std::path::PathBuf> {
    let mut keys: Vec<(&str, usize)> = rows.iter().map(|r| (r.solver, r.n)).collect();
    keys.dedup();
    let series = keys
        .into_iter()
        .map(|(solver, n)| {
            let (points, labels) = rows
                .iter()
                .filter(|r| r.solver == solver && r.n == n)
                .map(|r| {
                    let label = match (r.tolerance, r.n_iter) {
                        (Some(t), _) => format!("{t:.0e}"),
                        (_, Some(i)) => i.to_string(),
                        _ => String::new(),
                    };
                    // A zero error (at the reference's own accuracy) cannot sit on a log axis.
                    let err = r.grad_rel_err.max(1e-16);
                    ((1e3 * r.measured.forward_grad_l.median_s, err), label)
                })
                .unzip();
            Series {
                name: format!("{solver}, {n}×{n}"),
                points,
                labels,
            }
        })
        .collect();
    let labels = [
        "u_obstacle: ∇L error vs cost (labels: Newton tolerance, XPBD iterations)".into(),
        "time of one forward + ∇L pass [ms] (median, 1 thread)".into(),
        format!("relative error of ∇L vs Newton at tolerance {REFERENCE_TOLERANCE:e}"),
    ];
    crate::plots::draw_log_log(dir, "accuracy_newton_vs_xpbd.png", labels, series)
}
