//! How the cost of one forward + ∇L pass grows with the mesh (issue 34): Newton at its default
//! tolerance beside XPBD at [`MESH_N_ITER`] sweeps, on `u_obstacle` refined to `n × n`, each row
//! measured in a fresh child process ([`spawn_mesh_with`]: medians, peak RSS) at each thread
//! count, with the work of Newton's forward pass (iterations, factorizations) beside its walls.

use anyhow::Result;
use clothopt::plot::Series;
use serde::Serialize;
use std::path::{Path, PathBuf};

use crate::plots::draw_log_log;
use crate::rows::MeshRow;
use crate::sweep::spawn_mesh_with;
use crate::{Config, MESH_N_ITER};

/// One solver at one mesh size and thread count.
#[derive(Serialize)]
pub struct GrowthRow {
    /// `"newton"` or `"xpbd"`.
    pub solver: &'static str,
    /// The measurement (timings, peak RSS, Newton's counts).
    #[serde(flatten)]
    pub measured: MeshRow,
}

/// Measures XPBD, then Newton, at every size of `sizes` and thread count of `threads`.
pub fn sweep(sizes: &[usize], threads: &[usize], cfg: &Config) -> Result<Vec<GrowthRow>> {
    let mut rows = Vec::new();
    for &n in sizes {
        for &t in threads {
            for (solver, tolerance) in [("xpbd", None), ("newton", Some(cloth::DEFAULT_TOLERANCE))]
            {
                eprintln!("growth: {solver} n = {n}, {t} thread(s) …");
                let measured = spawn_mesh_with(n, t, cfg.reps, MESH_N_ITER, tolerance)?;
                rows.push(GrowthRow { solver, measured });
            }
        }
    }
    Ok(rows)
}

/// Newton's forward + ∇L over XPBD's at the same size and thread count (`None` for an XPBD
/// row).
fn ratio(rows: &[GrowthRow], newton: &GrowthRow) -> Option<f64> {
    let m = &newton.measured;
    if newton.solver != "newton" {
        return None;
    }
    rows.iter()
        .find(|r| r.solver == "xpbd" && r.measured.n == m.n && r.measured.threads == m.threads)
        .map(|x| m.forward_grad_l.median_s / x.measured.forward_grad_l.median_s)
}

/// Prints the rows as a table.
pub fn print_table(rows: &[GrowthRow]) {
    println!(
        "\nu_obstacle, cost against mesh size: Newton (tolerance {:e}) and XPBD ({MESH_N_ITER} sweeps)",
        cloth::DEFAULT_TOLERANCE
    );
    println!(
        "{:>4} {:>9} {:>7} {:>7} {:>11} {:>12} {:>14} {:>8} {:>8} {:>8}",
        "n",
        "particles",
        "threads",
        "solver",
        "forward s",
        "fwd+∇L s",
        "Newton/XPBD",
        "peak MB",
        "Newton it",
        "factor."
    );
    for r in rows {
        let m = &r.measured;
        let counts = m.newton.map_or(("-".into(), "-".into()), |c| {
            (
                c.iterations.to_string(),
                format!("{} ({})", c.factorizations, c.failed_factorizations),
            )
        });
        println!(
            "{:>4} {:>9} {:>7} {:>7} {:>11.3} {:>12.3} {:>14} {:>8} {:>8} {:>8}",
            m.n,
            m.particles,
            m.threads,
            r.solver,
            m.forward.median_s,
            m.forward_grad_l.median_s,
            ratio(rows, r).map_or("-".into(), |x| format!("{x:.2}×")),
            m.peak_rss_mb.map_or("-".into(), |v| format!("{v:.0}")),
            counts.0,
            counts.1,
        );
    }
}

/// Writes the rows to `path` (atomically).
pub fn write(path: &Path, rows: &[GrowthRow]) -> Result<()> {
    #[derive(Serialize)]
    struct Out<'a> {
        growth_rows: &'a [GrowthRow],
        newton_tolerance: f64,
        xpbd_sweeps: usize,
        memory_method: &'static str,
    }
    clothopt::output::write_json_atomic(
        path,
        &Out {
            growth_rows: rows,
            newton_tolerance: cloth::DEFAULT_TOLERANCE,
            xpbd_sweeps: MESH_N_ITER,
            memory_method: crate::rows::MEMORY_METHOD,
        },
    )?;
    Ok(())
}

/// Draws `accuracy_cost_growth.png` into `dir`: forward + ∇L (and forward) time against the
/// particle count, log–log, one line per solver and thread count, points labelled with `n`.
pub fn draw(dir: &Path, rows: &[GrowthRow]) -> Result<PathBuf> {
    let mut keys: Vec<(&str, usize)> = rows
        .iter()
        .map(|r| (r.solver, r.measured.threads))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let mut series = Vec::new();
    for (solver, threads) in keys {
        let name = match solver {
            "xpbd" => format!("XPBD-{MESH_N_ITER}"),
            _ => "Newton".to_string(),
        };
        let of = |r: &&GrowthRow| r.solver == solver && r.measured.threads == threads;
        for (what, pick) in [
            (
                "forward + ∇L",
                (|m: &MeshRow| m.forward_grad_l.median_s) as fn(&MeshRow) -> f64,
            ),
            ("forward", |m: &MeshRow| m.forward.median_s),
        ] {
            let (points, labels) = rows
                .iter()
                .filter(of)
                .map(|r| {
                    let m = &r.measured;
                    ((m.particles as f64, pick(m)), m.n.to_string())
                })
                .unzip();
            series.push(Series {
                name: format!("{name}, {what}, {threads} thread(s)"),
                points,
                labels,
            });
        }
    }
    let labels = [
        "u_obstacle: cost against mesh size (labels: n for an n × n cloth)".into(),
        "particles".into(),
        "time of one pass [s] (median, fresh process)".into(),
    ];
    draw_log_log(dir, "accuracy_cost_growth.png", labels, series)
}
