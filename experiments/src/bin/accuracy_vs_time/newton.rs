//! The Newton rows (issue 17): a tolerance sweep of the Newton solver beside XPBD iteration counts
//! on `u_obstacle` at each mesh size, against one converged reference per size.
//!
//! Reference: ∇L of the Newton minimizer at [`REFERENCE_TOLERANCE`] (relative `‖∇Φ‖`; round-off
//! stops the solve where `f64` can do no better). XPBD rows are measured against the same
//! reference, so their error includes the distance between XPBD's fixed point and Newton's
//! minimizer (they differ: README "Which physics solver"), which no iteration count removes.
//! Timing and peak memory come from a fresh child process per row (the mesh measurement).
//! Planning with each physics is not part of these rows.

use anyhow::Result;
use cloth::scene::SolverKind;
use cloth::{Model, Scene};
use clothopt::plan;
use clothopt::plot::{draw_xy, Series, XyFigure};
use serde::Serialize;

use crate::rows::MeshRow;
use crate::sweep::{rel_err, spawn_mesh_with};

/// Newton tolerances swept (relative `‖∇Φ‖`).
pub const TOLERANCES: [f64; 4] = [1e-4, 1e-6, 1e-8, 1e-10];
/// The reference's tolerance.
pub const REFERENCE_TOLERANCE: f64 = 1e-12;

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
}

/// `scene` solved by Newton to `tolerance`.
fn with_newton(scene: &Scene, tolerance: f64) -> Scene {
    let mut s = scene.clone();
    s.physics.solver = SolverKind::Newton;
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

/// The rows at each size of `sizes`: Newton at [`TOLERANCES`], XPBD at `xpbd_iters`.
pub fn sweep(sizes: &[usize], xpbd_iters: &[usize], reps: usize) -> Result<Vec<SolverRow>> {
    let mut rows = Vec::new();
    for &n in sizes {
        let scene = Scene::builtin("u_obstacle")?.refined(n, n)?;
        let (reference, _) = grad_l(&with_newton(&scene, REFERENCE_TOLERANCE))?;
        for tol in TOLERANCES {
            eprintln!("newton n = {n}, tolerance {tol:e} …");
            let (g, l) = grad_l(&with_newton(&scene, tol))?;
            rows.push(SolverRow {
                solver: "newton",
                n,
                tolerance: Some(tol),
                n_iter: None,
                grad_rel_err: rel_err(&g, &reference),
                l,
                measured: spawn_mesh_with(n, 1, reps, 0, Some(tol))?,
            });
        }
        for &it in xpbd_iters {
            eprintln!("xpbd n = {n}, {it} iterations …");
            let mut s = scene.clone();
            s.physics.iterations = it;
            let (g, l) = grad_l(&s)?;
            rows.push(SolverRow {
                solver: "xpbd",
                n,
                tolerance: None,
                n_iter: Some(it),
                grad_rel_err: rel_err(&g, &reference),
                l,
                measured: spawn_mesh_with(n, 1, reps, it, None)?,
            });
        }
    }
    Ok(rows)
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
        let setting = match (r.tolerance, r.n_iter) {
            (Some(t), _) => format!("tol {t:.0e}"),
            (_, Some(i)) => format!("{i} it"),
            _ => String::new(),
        };
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
    let path = dir.join("accuracy_newton_vs_xpbd.png");
    draw_xy(
        &XyFigure {
            title: "u_obstacle: ∇L error vs cost (labels: Newton tolerance, XPBD iterations)"
                .into(),
            x_label: "time of one forward + ∇L pass [ms] (median, 1 thread)".into(),
            y_label: format!("relative error of ∇L vs Newton at tolerance {REFERENCE_TOLERANCE:e}"),
            series,
            log_x: true,
            log_y: true,
            ref_lines: vec![],
        },
        &path,
    )?;
    Ok(path)
}
