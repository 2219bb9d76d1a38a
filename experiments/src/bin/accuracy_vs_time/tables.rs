//! The sweep's tables on stdout.

use experiments::report::fmt_opt;

use crate::rows::{AccuracyRow, JaxRow, MeshRow};
use crate::{Config, MESH_BUDGET_S, MESH_N_ITER};

/// Prints the accuracy, planning, mesh-size and JAX tables (the last two when measured).
pub fn print_tables(acc: &[AccuracyRow], mesh: &[MeshRow], jax: &[JaxRow], cfg: &Config) {
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
