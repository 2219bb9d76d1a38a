//! `clothopt fit`: material parameters from observed motion.

use super::common::{load_scene, PhysicsArgs};
use anyhow::Result;
use cloth::{ConstraintRegistry, Model, Parameter};
use clothopt::fit::{fit, FitOptions, FitStatus, Observations};
use clothopt::output::{write_atomic, write_json_atomic};
use std::path::PathBuf;

/// Fit material parameters to observed motion.
#[derive(clap::Args)]
pub struct FitArgs {
    /// A built-in scene name or a scene JSON file: the cloth, its start and the starting values.
    scene: String,
    /// Observation file: `{"controls": …, "points": [{"particle": [r, c] or i, "step": t,
    /// "position": [x, y, z]}, …], "noise": σ}` (docs/fitting.md).
    #[arg(long)]
    observed: PathBuf,
    /// Parameters to fit, comma-separated: `stretch`, `bending`, a custom constraint type,
    /// `mass`, `gravity`, `friction`.
    #[arg(long, value_delimiter = ',', required = true)]
    params: Vec<String>,
    /// Write the fit (parameters with standard errors, residual per step) as JSON.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the scene with the fitted values.
    #[arg(long)]
    scene_out: Option<PathBuf>,
    /// Most Levenberg–Marquardt iterations.
    #[arg(long, default_value_t = FitOptions::default().max_iterations)]
    max_iterations: usize,
    /// Each parameter stays within [v/range, v·range] of the scene's value v.
    #[arg(long, default_value_t = FitOptions::default().range)]
    range: f64,
    #[command(flatten)]
    physics: PhysicsArgs,
}

/// Runs `fit`: prints the fitted values and writes the files asked for; exit 0 when the fit
/// converged, 3 when it stopped short (the files are written either way).
pub fn run(args: FitArgs) -> Result<i32> {
    let scene = load_scene(&args.scene, None, &args.physics)?;
    let model = Model::from_scene(&scene)?;
    let observed = Observations::read(&args.observed, &scene, &model)?;
    let params: Vec<Parameter> = args
        .params
        .iter()
        .map(|p| Parameter::parse(p.trim()))
        .collect();
    let options = FitOptions {
        max_iterations: args.max_iterations,
        range: args.range,
        ..FitOptions::default()
    };
    let result = fit(
        &scene,
        &ConstraintRegistry::new(),
        &observed,
        &params,
        &options,
    )?;
    print!("{}", result.summary(true));
    if let Some(out) = &args.out {
        write_json_atomic(out, &result)?;
    }
    if let Some(out) = &args.scene_out {
        let text = cloth::scene::to_json_pretty_compact(&result.fitted_scene)?;
        write_atomic(out, format!("{text}\n").as_bytes())?;
    }
    Ok(if result.status == FitStatus::Converged {
        0
    } else {
        3
    })
}
