//! The rows the sweep measures and the file it writes.

use anyhow::Result;
use experiments::measure::Timing;
use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::Config;

/// One output row; `kind` tells which.
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Row<'a> {
    Accuracy(&'a AccuracyRow),
    Mesh(&'a MeshRow),
    Jax(&'a JaxRow),
}

/// One `(scene, n_iter)` setting at the scene's initial guess.
#[derive(Serialize)]
pub struct AccuracyRow {
    pub scene: String,
    pub n_iter: usize,
    /// The controls the row is evaluated at (see [`crate::sweep::evaluation_point`]); plans start from the
    /// scene's initial guess.
    pub point: String,
    /// This is the converged reference itself (its gradient error is 0 by definition).
    pub reference: bool,
    /// Largest `| |x_i − x_j| − l⁰ |` over stretch edges and steps 1..T (length units).
    pub max_abs_c: f64,
    /// RMS of the same over every edge and step.
    pub rms_c: f64,
    /// Largest |C| at the end of each step 1..T.
    pub max_abs_c_per_step: Vec<f64>,
    pub e: f64,
    pub l: f64,
    pub g: f64,
    /// `‖∇L − ∇L_ref‖₂ / ‖∇L_ref‖₂`.
    pub grad_rel_err: f64,
    /// `evaluate(.., false)`: the rollout and its metrics.
    pub forward: Timing,
    /// The rollout, its metrics and ∇L ([`cloth::Model::evaluate_loss_gradient`]; what JAX's
    /// benchmark times).
    pub forward_grad_l: Timing,
    /// `evaluate(.., true)`: also dC/dU, a second backward pass (scenes with safety obstacles).
    pub evaluate_gradients: Option<Timing>,
    pub threads: usize,
    pub plan: Option<PlanRow>,
    /// Why there is no plan.
    pub plan_skipped: Option<String>,
}

/// A plan optimized at `n_iter`, and the same controls re-simulated at the reference accuracy.
#[derive(Serialize)]
pub struct PlanRow {
    pub status: String,
    pub iterations: usize,
    pub simulations: usize,
    pub wall_s: f64,
    /// What the planner saw (simulated at `n_iter`).
    pub planned_g: f64,
    pub planned_l: f64,
    pub planned_min_sdf: Option<f64>,
    pub planned_max_abs_c: f64,
    /// The truth (re-simulated at the reference iterations).
    pub true_g: f64,
    pub true_l: f64,
    pub true_min_sdf: Option<f64>,
    pub true_min_sdf_swept: Option<f64>,
    pub true_max_abs_c: f64,
    /// The re-simulated rollout passes [`clothopt::result::is_safe`] (None without safety
    /// obstacles).
    pub safe: Option<bool>,
}

/// Forward+∇L at one mesh size and thread count, measured in a fresh process.
#[derive(Serialize, Deserialize)]
pub struct MeshRow {
    pub scene: String,
    pub n: usize,
    pub particles: usize,
    pub n_iter: usize,
    pub threads: usize,
    pub forward: Timing,
    /// The rollout, its metrics and ∇L ([`cloth::Model::evaluate_loss_gradient`]).
    pub forward_grad_l: Timing,
    pub l: f64,
    /// Process peak RSS (VmHWM) after the forward+∇L runs, MB.
    pub peak_rss_mb: Option<f64>,
    /// VmHWM growth over the forward+∇L runs (model already built), MB.
    pub rss_growth_mb: Option<f64>,
    /// Newton's tolerance when the row is Newton's (`n_iter` then unused).
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Newton's work in one forward pass (Newton rows; the forward is then timed through
    /// [`cloth::Model::simulate_newton`]).
    #[serde(default)]
    pub newton: Option<NewtonCounts>,
}

/// What one Newton forward pass did, summed over its steps.
#[derive(Serialize, Deserialize, Clone, Copy)]
pub struct NewtonCounts {
    /// Newton iterations (chord steps included).
    pub iterations: usize,
    /// Successful sparse Cholesky factorizations.
    pub factorizations: usize,
    /// Factorizations that found the matrix not positive definite.
    pub failed_factorizations: usize,
    /// Load increments rejected by the branch following.
    pub rejected_loads: usize,
}

impl NewtonCounts {
    /// The sums over `steps`.
    pub fn of(steps: &[cloth::StepStats]) -> NewtonCounts {
        let sum = |f: fn(&cloth::StepStats) -> usize| steps.iter().map(f).sum();
        NewtonCounts {
            iterations: sum(|s| s.iterations),
            factorizations: sum(|s| s.factorizations),
            failed_factorizations: sum(|s| s.failed_factorizations),
            rejected_loads: sum(|s| s.rejected_loads),
        }
    }
}

/// The JAX reference at one setting, beside ours.
#[derive(Serialize)]
pub struct JaxRow {
    pub scene: String,
    pub n: usize,
    pub n_iter: usize,
    pub forward_s: f64,
    /// The benchmark's value-and-gradient of L.
    pub forward_grad_l_s: f64,
    pub l: f64,
    /// Our medians at the same setting (n = 10 from the sweep, else the 2-thread mesh rows).
    pub ours_forward_s: Option<f64>,
    pub ours_forward_grad_l_s: Option<f64>,
    /// `|L_jax − L_ours| / |L_ours|` and the same for ∇L (n = 10 only: at other sizes JAX targets
    /// the whole bottom row, `Scene::refined` the 10 original material points).
    pub l_rel_diff: Option<f64>,
    pub grad_rel_diff: Option<f64>,
}

/// Everything written to `--out`.
#[derive(Serialize)]
pub struct Output<'a> {
    pub rows: &'a [Row<'a>],
    pub reference_iterations: usize,
    pub plan_iterations: usize,
    pub memory_method: &'static str,
    pub total_wall_s: f64,
}

pub const MEMORY_METHOD: &str =
    "VmHWM from /proc/self/status in a fresh child process per (n, threads): \
     peak_rss_mb is the process peak after the forward+∇L runs, rss_growth_mb its growth over them";

/// `n_iter`, and the plan's status when it did not converge (e.g. `"20 (limit)"`).
pub fn plan_label(n_iter: usize, p: &PlanRow) -> String {
    match p.status.as_str() {
        "converged" => n_iter.to_string(),
        "iteration_limit" => format!("{n_iter} (limit)"),
        other => format!("{n_iter} ({other})"),
    }
}

/// Writes `{"rows": [...]}` to `path` (if any): the accuracy rows, then the mesh and JAX rows.
pub fn write_output(
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
        clothopt::output::write_json_atomic(
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
