//! Our forward and forward + ∇L against the JAX reference, in one run on one machine.
//!
//! For `u_obstacle` (T = 10, 100 Gauss–Seidel iterations) at n = 10, 20, 40: the median
//! wall time of our `Model::evaluate(.., false)` (forward and metrics) and
//! `Model::evaluate_loss_gradient` (forward + ∇L) on one thread, then the JAX reference
//! (`bench_jax.py`: jit, float64, CPU) run as a subprocess at the same setting, and the ratios
//! JAX ÷ ours (above 1: we are faster). Shared machines are noisy, so compare only within a run.
//!
//! `cargo run --release -p experiments --bin speed_vs_jax [-- --python /tmp/jaxenv/bin/python --reps 7]`
//!
//! JAX is not a dependency of this workspace: without a Python that can `import jax`, the example
//! prints our times, says so, and exits with success.

use anyhow::Result;
use clap::Parser;
use cloth::{Model, Scene};
use experiments::child::{jax_available, run_jax};
use experiments::measure::time_runs;
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Parser)]
struct Args {
    /// A Python that can `import jax` (e.g. from `pip install "jax[cpu]"`).
    #[arg(long, default_value = "python3")]
    python: PathBuf,
    /// The JAX benchmark script.
    #[arg(long, default_value = "/work/shared/anchors/jax_ref/bench_jax.py")]
    jax_script: PathBuf,
    /// Timed runs per measurement of ours (the median is reported).
    #[arg(long, default_value_t = 7)]
    reps: usize,
    /// Mesh sizes.
    #[arg(long, value_delimiter = ',', default_value = "10,20,40")]
    sizes: Vec<usize>,
}

/// Gauss–Seidel iterations per step, as in the JAX benchmark's default.
const ITERATIONS: usize = 100;

/// The JAX benchmark's JSON line (the fields used here).
#[derive(Deserialize)]
struct JaxOut {
    forward_s: f64,
    forward_gradient_s: f64,
}

/// Median seconds of `reps` runs of `f`, after one warm-up run.
fn median_s<T>(reps: usize, mut f: impl FnMut() -> Result<T>) -> Result<f64> {
    f()?;
    Ok(time_runs(reps, f64::INFINITY, f)?.median_s)
}

/// Our (forward, forward + ∇L) medians at mesh size `n`.
fn ours(n: usize, reps: usize) -> Result<(f64, f64)> {
    let mut scene = Scene::builtin("u_obstacle")?.refined(n, n)?;
    scene.physics.iterations = ITERATIONS;
    let model = Model::from_scene(&scene)?;
    let (u, delta) = (scene.initial_controls(), scene.task.delta);
    let fwd = median_s(reps, || Ok(model.evaluate(&u, delta, false)?))?;
    let grad = median_s(reps, || Ok(model.evaluate_loss_gradient(&u, delta)?))?;
    Ok((fwd, grad))
}

/// Runs the JAX benchmark at mesh size `n` and parses its JSON line.
fn jax(python: &Path, script: &Path, n: usize) -> Result<JaxOut> {
    run_jax(python, script, "U", n, ITERATIONS)
}

fn main() -> Result<()> {
    let args = Args::parse();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let have_jax = jax_available(&args.python) && args.jax_script.exists();
    println!(
        "u_obstacle, T = 10, {ITERATIONS} iterations; ours on 1 thread, medians of {} runs",
        args.reps
    );
    println!(
        "{:>4} {:>12} {:>12} {:>12} {:>12} {:>9} {:>9}",
        "n", "fwd ours", "fwd JAX", "fwd+∇L ours", "fwd+∇L JAX", "fwd ×", "fwd+∇L ×"
    );
    for &n in &args.sizes {
        let (fwd, grad) = pool.install(|| ours(n, args.reps))?;
        let ms = |s: f64| format!("{:.1} ms", 1e3 * s);
        match have_jax {
            true => {
                let j = jax(&args.python, &args.jax_script, n)?;
                println!(
                    "{n:>4} {:>12} {:>12} {:>12} {:>12} {:>8.2}× {:>8.2}×",
                    ms(fwd),
                    ms(j.forward_s),
                    ms(grad),
                    ms(j.forward_gradient_s),
                    j.forward_s / fwd,
                    j.forward_gradient_s / grad
                );
            }
            false => println!(
                "{n:>4} {:>12} {:>12} {:>12} {:>12} {:>9} {:>9}",
                ms(fwd),
                "—",
                ms(grad),
                "—",
                "—",
                "—"
            ),
        }
    }
    if !have_jax {
        println!(
            "\nJAX reference skipped: `{}` cannot `import jax` or {} is missing. Install it \
             (python3 -m venv /tmp/jaxenv && /tmp/jaxenv/bin/pip install \"jax[cpu]\" numpy) \
             and pass --python /tmp/jaxenv/bin/python.",
            args.python.display(),
            args.jax_script.display()
        );
    }
    Ok(())
}
