//! The sweep's PNG plots.

use anyhow::Result;
use clothopt::plot::{draw_xy, RefLine, Series, XyFigure};
use std::path::{Path, PathBuf};

use crate::rows::{plan_label, AccuracyRow, JaxRow, MeshRow, PlanRow};
use crate::{Config, MESH_N_ITER};

/// The x axis of the G plots, with the key to the point labels.
fn plan_x_label(plans: &[(usize, &PlanRow)]) -> String {
    if plans.iter().any(|(_, p)| p.status == "iteration_limit") {
        "optimization wall time [s]  (labels: n_iter; \"(limit)\": stopped at the iteration limit)"
            .into()
    } else {
        "optimization wall time [s]  (labels: n_iter)".into()
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

/// Draws `series` on log–log axes into `dir/file` with the figure's `[title, x label, y label]`;
/// returns the file's path.
pub fn draw_log_log(
    dir: &Path,
    file: &str,
    [title, x_label, y_label]: [String; 3],
    series: Vec<Series>,
) -> Result<PathBuf> {
    let path = dir.join(file);
    let figure = XyFigure {
        title,
        x_label,
        y_label,
        series,
        log_x: true,
        log_y: true,
        ref_lines: vec![],
    };
    draw_xy(&figure, &path)?;
    Ok(path)
}

/// Draws the PNGs into the existing directory `dir`; returns their paths.
pub fn draw_plots(
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
