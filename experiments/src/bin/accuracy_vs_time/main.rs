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
//! experiment re-run with a hidden subcommand). With `--jax PYTHON`, the JAX reference beside it.
//!
//! `cargo run --release -p experiments --bin accuracy_vs_time [-- --out FILE --png-dir DIR --quick --jax PYTHON]`

mod growth;
mod jax;
mod newton;
mod plots;
mod rows;
mod sweep;
mod tables;

use anyhow::{ensure, Context, Result};
use clap::{Parser, Subcommand};
use cloth::Scene;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
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
    /// Only the Newton rows: Newton's tolerance sweep beside XPBD iteration counts at these
    /// mesh sizes (e.g. `10,20,40`), against the converged Newton gradient; no other rows.
    #[arg(long, value_delimiter = ',')]
    newton_sizes: Vec<usize>,
    /// Mesh sizes of the Newton rows at which each setting also plans `u_obstacle` and the plan
    /// is re-simulated with converged physics (Newton at the reference tolerance) and with XPBD
    /// at 3000 iterations.
    #[arg(long, value_delimiter = ',', default_value = "10")]
    newton_plan_sizes: Vec<usize>,
    /// XPBD iteration counts of the Newton rows.
    #[arg(long, value_delimiter = ',', default_value = "100,1000")]
    newton_xpbd_iterations: Vec<usize>,
    /// Only the cost-growth rows: forward + ∇L of Newton (default tolerance) and XPBD
    /// (100 sweeps) at these mesh sizes (e.g. `10,20,40,60,80,100`), each in a fresh process,
    /// plotted against the particle count (`accuracy_cost_growth.png`); no other rows.
    #[arg(long, value_delimiter = ',')]
    growth_sizes: Vec<usize>,
    /// Thread counts of the cost-growth rows.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    growth_threads: Vec<usize>,
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
        /// Newton's method to this tolerance instead of XPBD.
        #[arg(long)]
        tolerance: Option<f64>,
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

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(Child::MeasureMesh {
        n,
        threads,
        iterations,
        tolerance,
        reps,
        budget_s,
    }) = args.child
    {
        return sweep::measure_mesh(n, threads, iterations, tolerance, reps, budget_s);
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
    use clothopt::validate::ensure_iterations;
    ensure_iterations("--reps", cfg.reps)?;
    ensure_iterations("--plan-iterations", cfg.plan_iterations)?;
    ensure_iterations("--reference-iterations", cfg.reference_iterations)?;
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

    if !args.growth_sizes.is_empty() {
        for &t in &args.growth_threads {
            ensure_iterations("--growth-threads", t)?;
        }
        let rows = growth::sweep(&args.growth_sizes, &args.growth_threads, &cfg)?;
        growth::print_table(&rows);
        if let Some(out) = &args.out {
            growth::write(out, &rows)?;
            println!("wrote {}", out.display());
        }
        if let Some(dir) = &args.png_dir {
            println!("wrote {}", growth::draw(dir, &rows)?.display());
        }
        return Ok(());
    }
    if !args.newton_sizes.is_empty() {
        let rows = newton::sweep(
            &args.newton_sizes,
            &args.newton_xpbd_iterations,
            &args.newton_plan_sizes,
            &cfg,
        )?;
        newton::print_table(&rows);
        newton::print_plans(&rows);
        if let Some(out) = &args.out {
            newton::write(out, &rows)?;
            println!("wrote {}", out.display());
        }
        if let Some(dir) = &args.png_dir {
            println!("wrote {}", newton::draw(dir, &rows)?.display());
        }
        return Ok(());
    }

    let mut acc = Vec::new();
    let mut grads = HashMap::new();
    for name in ["u_obstacle", "swing"] {
        let (rows, g) = sweep::sweep_scene(name, &cfg)?;
        acc.extend(rows);
        if let Some(g) = g {
            grads.insert(name, g);
        }
        rows::write_output(
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
            mesh.push(sweep::spawn_mesh(n, threads, cfg.reps)?);
        }
    }

    let jax_clock = Instant::now();
    let jax = match &args.jax {
        Some(python) => jax::compare(
            python,
            &args.jax_script,
            &cfg.mesh_sizes,
            &acc,
            &mesh,
            &grads,
        ),
        None => Vec::new(),
    };
    let jax_time = jax_clock.elapsed().as_secs_f64();
    tables::print_tables(&acc, &mesh, &jax, &cfg);
    let total = clock.elapsed().as_secs_f64();
    rows::write_output(args.out.as_deref(), &acc, &mesh, &jax, &cfg, total)?;
    if let Some(dir) = &args.png_dir {
        for p in plots::draw_plots(dir, &acc, &mesh, &jax, &cfg)? {
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
