//! How rough a scene's objective is in the controls: `f = G + βE` (the smooth part the SQP
//! models; `αT` is exact in its cones) along the steepest-descent direction `d = −∇f/‖∇f‖` from
//! the scene's initial guess, sampled at `s = k·h` for `k = −K…K` and several step sizes `h`.
//!
//! Per `h` it prints the gradient's slope `∇f·d` and the finite-difference slopes
//! `(f(s + h) − f(s))/h` of the samples: their largest deviation from the gradient's slope, how
//! many of them descend, and the largest distance of `f` from its tangent line over `[−Kh, Kh]`.
//! A smooth objective gives deviations that shrink with `h`; a rough one (a rollout whose contact
//! set, stick/slip state or buckling changes between nearby controls) does not. With
//! `--sensitivity`, also the rollout's per-step sensitivity `max |x_t(s + h) − x_t(s)| / h` across
//! the sample interval `[s, s + h]` whose slope deviates most (where a jump is, the first step
//! whose state jumps is the one that switched: a contact, a stick/slip state or an equilibrium).
//! With `--controls FILE` (a controls file or a result, e.g. a stalled plan) it measures there
//! instead of at the initial guess.
//!
//! ```sh
//! cargo run --release -p experiments --bin roughness -- fold
//! cargo run --release -p experiments --bin roughness -- fold --no-self-collision --friction 0
//! cargo run --release -p experiments --bin roughness -- fold --sweeps 2000 --sensitivity
//! cargo run --release -p experiments --bin roughness -- fold --controls plan.json
//! ```
//!
//! A measurement, not a test: it changes nothing and writes nothing but its table (and `--out`).

use anyhow::{Context, Result};
use clap::Parser;
use cloth::scene::Obstacle;
use cloth::Model;
use clothopt::plan::initial_controls;
use clothopt::problem::{TaskOptions, TrajectoryProblem};
use clothopt::request::load_scene;
use clothopt::result::controls_from_nested;
use experiments::report::write_json;
use optim::Problem;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    about = "Roughness of a scene's objective along −∇f from its initial guess or given controls"
)]
struct Args {
    /// A built-in scene name or a scene JSON file.
    scene: String,
    /// Step sizes `h` (control units).
    #[arg(long, value_delimiter = ',', default_values_t = [1e-10, 1e-8, 1e-6])]
    steps: Vec<f64>,
    /// Samples on each side of the guess (`K`).
    #[arg(long, default_value_t = 10)]
    samples: usize,
    /// Gauss–Seidel sweeps per step instead of the scene's.
    #[arg(long)]
    sweeps: Option<usize>,
    /// Turn the scene's self-collision off.
    #[arg(long)]
    no_self_collision: bool,
    /// Set every collider's friction coefficient to this value (0: frictionless).
    #[arg(long)]
    friction: Option<f64>,
    /// Measure at these controls instead of the scene's initial guess: a controls file
    /// `{"controls": [[[x, y, z], …], …]}` or any result file (such as a plan's end).
    #[arg(long)]
    controls: Option<PathBuf>,
    /// Also print the rollout's per-step sensitivity across each size's roughest interval.
    #[arg(long)]
    sensitivity: bool,
    /// Write the rows as JSON here.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// One step size's measurement.
#[derive(serde::Serialize)]
struct Row {
    h: f64,
    /// `∇f·d` at the guess.
    gradient_slope: f64,
    /// Largest `|(f(s + h) − f(s))/h − ∇f·d|` over the samples.
    max_slope_deviation: f64,
    /// Finite-difference slopes that descend, of all.
    descending: usize,
    intervals: usize,
    /// Largest `|f(s) − f(0) − s ∇f·d|` over `[−Kh, Kh]`.
    max_from_tangent: f64,
    /// Start `s` of the interval `[s, s + h]` whose slope deviates most.
    roughest_at: f64,
    /// Per step `t = 0…T`: `max_i |x_t(s + h) − x_t(s)| / h` across that interval (with
    /// `--sensitivity`).
    sensitivity: Vec<f64>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut scene = load_scene(&args.scene)?;
    if let Some(sweeps) = args.sweeps {
        scene.physics.iterations = sweeps;
    }
    if args.no_self_collision {
        scene.physics.self_collision = None;
    }
    if let Some(mu) = args.friction {
        for obstacle in &mut scene.obstacles {
            if !obstacle.role().is_collider() {
                continue;
            }
            let friction = match obstacle {
                Obstacle::Spheres(o) => &mut o.friction,
                Obstacle::Plane(o) => &mut o.friction,
                Obstacle::Capsule(o) => &mut o.friction,
                Obstacle::Box(o) => &mut o.friction,
                Obstacle::Mesh(o) => &mut o.friction,
            };
            *friction = Some(mu);
        }
    }
    let model = Model::from_scene(&scene).context("building the model")?;
    let x0 = match &args.controls {
        None => initial_controls(&scene, &model)?,
        Some(path) => read_controls(path, &model)?,
    };
    let x0 = x0.data().to_vec();
    let mut problem = TrajectoryProblem::new(&model, TaskOptions::for_model(&model));
    let f0 = problem.objective(&x0)?;
    let mut g = vec![0.0; x0.len()];
    problem.gradient(&x0, &mut g)?;
    let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    anyhow::ensure!(norm > 0.0, "the gradient is zero at the guess");
    let d: Vec<f64> = g.iter().map(|v| -v / norm).collect();
    let along = |s: f64| -> Vec<f64> { x0.iter().zip(&d).map(|(x, di)| x + s * di).collect() };
    let at = args
        .controls
        .as_ref()
        .map_or("the guess".to_string(), |p| p.display().to_string());
    println!(
        "{}: sweeps {}, self-collision {}, f = G + βE = {f0:.10} at {at}, ‖∇f‖ = {norm:.4e}",
        scene.name,
        scene.physics.iterations,
        if scene.physics.self_collision.is_some() {
            "on"
        } else {
            "off"
        },
    );
    println!(
        "{:>8} {:>12} {:>16} {:>11} {:>16}",
        "h", "∇f·d", "max |FD − ∇f·d|", "descending", "max |f − tangent|"
    );
    let k = args.samples as i64;
    let mut rows = Vec::new();
    for &h in &args.steps {
        let values = (-k..=k)
            .map(|i| problem.objective(&along(i as f64 * h)))
            .collect::<Result<Vec<f64>, _>>()?;
        let slopes: Vec<f64> = values.windows(2).map(|w| (w[1] - w[0]) / h).collect();
        let deviations = slopes.iter().map(|s| (s + norm).abs());
        let (roughest, max_slope_deviation) = deviations.enumerate().fold(
            (0, 0.0),
            |best, (i, v)| if v > best.1 { (i, v) } else { best },
        );
        let roughest_at = (roughest as i64 - k) as f64 * h;
        let max_from_tangent = values
            .iter()
            .zip(-k..=k)
            .map(|(f, i)| (f - f0 + norm * i as f64 * h).abs())
            .fold(0.0, f64::max);
        let sensitivity = if args.sensitivity {
            let base = model.simulate(&problem.controls(&along(roughest_at)))?;
            let moved = model.simulate(&problem.controls(&along(roughest_at + h)))?;
            base.iter()
                .zip(&moved)
                .map(|(a, b)| {
                    let gap = a.data().iter().zip(b.data()).map(|(u, v)| (u - v).abs());
                    gap.fold(0.0, f64::max) / h
                })
                .collect()
        } else {
            Vec::new()
        };
        let row = Row {
            h,
            gradient_slope: -norm,
            max_slope_deviation,
            descending: slopes.iter().filter(|&&s| s < 0.0).count(),
            intervals: slopes.len(),
            max_from_tangent,
            roughest_at,
            sensitivity,
        };
        println!(
            "{:>8.0e} {:>12.4e} {:>16.3e} {:>6} of {:<2} {:>16.3e}",
            row.h,
            row.gradient_slope,
            row.max_slope_deviation,
            row.descending,
            row.intervals,
            row.max_from_tangent
        );
        if args.sensitivity {
            let per_step: Vec<String> =
                row.sensitivity.iter().map(|v| format!("{v:.0e}")).collect();
            println!(
                "         sensitivity per step on [{:.0e}, {:.0e}]: {}",
                row.roughest_at,
                row.roughest_at + h,
                per_step.join(" ")
            );
        }
        rows.push(row);
    }
    if let Some(path) = &args.out {
        write_json(
            path,
            &serde_json::json!({
                "scene": scene.name,
                "controls": args.controls,
                "f": f0,
                "rows": rows
            }),
        )?;
    }
    Ok(())
}

/// The controls of `path`: the `controls` of a controls file or a result, checked against the
/// model's horizon and control points. Errors name `--controls` and the file.
fn read_controls(path: &std::path::Path, model: &Model) -> Result<cloth::Controls> {
    let name = || format!("--controls {}", path.display());
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", name()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", name()))?;
    let nested: Vec<Vec<[f64; 3]>> = value
        .get("controls")
        .cloned()
        .map(serde_json::from_value)
        .transpose()
        .with_context(|| format!("{}: `controls` is not a T × K × 3 array", name()))?
        .with_context(|| format!("{}: no `controls`", name()))?;
    controls_from_nested(model, &nested).with_context(name)
}
