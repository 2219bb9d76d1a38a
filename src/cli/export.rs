//! `clothopt export`: a result's control-point way-points (CSV) and one OBJ mesh per step.

use anyhow::{bail, Context, Result};
use clothopt::export::{obj_mesh, obj_triangles, waypoints_csv};
use clothopt::output::write_atomic;
use std::path::PathBuf;

/// Export a result: dense way-points of the control points (CSV) and/or one OBJ mesh per step.
#[derive(clap::Args)]
pub struct ExportArgs {
    /// A result JSON written by `optimize --out` (or `simulate --out`).
    result: PathBuf,
    /// Write the control points' way-points here (CSV).
    #[arg(long)]
    waypoints: Option<PathBuf>,
    /// Way-points per step (linear interpolation between steps).
    #[arg(long, default_value_t = 10)]
    per_step: usize,
    /// Write one OBJ mesh per step into this directory.
    #[arg(long)]
    obj: Option<PathBuf>,
}

/// What `export` needs from a result file.
#[derive(serde::Deserialize)]
struct ExportInput {
    grid: [usize; 2],
    #[serde(default)]
    triangles: Option<Vec<[usize; 3]>>,
    control_particles: Vec<usize>,
    states: Vec<Vec<[f64; 3]>>,
}

/// Runs `export`: checks the result file, then writes the way-points and/or the meshes.
pub fn run(args: ExportArgs) -> Result<i32> {
    let result = &args.result;
    let text = std::fs::read_to_string(result)
        .with_context(|| format!("cannot read {}", result.display()))?;
    let parsed: ExportInput = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a clothopt result", result.display()))?;
    let [rows, cols] = parsed.grid;
    if parsed.states.is_empty() {
        bail!("{}: the result has no states to export", result.display());
    }
    // A mesh cloth's particle count is its states' (every triangle index must be below it).
    let n = match &parsed.triangles {
        Some(_) => parsed.states[0].len(),
        None => rows * cols,
    };
    if let Some(bad) = parsed.states.iter().position(|s| s.len() != n) {
        bail!(
            "{}: states[{bad}] has {} points for a {rows} × {cols} grid",
            result.display(),
            parsed.states[bad].len()
        );
    }
    if let Some(t) = parsed
        .triangles
        .iter()
        .flatten()
        .flatten()
        .find(|&&p| p >= n)
    {
        bail!("{}: triangle particle {t} out of range", result.display());
    }
    if let Some(&p) = parsed.control_particles.iter().find(|&&p| p >= n) {
        bail!("{}: control particle {p} out of range", result.display());
    }
    if args.waypoints.is_none() && args.obj.is_none() {
        bail!("nothing to export: give --waypoints FILE and/or --obj DIR");
    }
    if let Some(path) = args.waypoints {
        let paths: Vec<Vec<[f64; 3]>> = parsed
            .control_particles
            .iter()
            .map(|&p| parsed.states.iter().map(|s| s[p]).collect())
            .collect();
        write_atomic(&path, waypoints_csv(&paths, args.per_step).as_bytes())?;
        println!(
            "wrote {} ({} way-points per step)",
            path.display(),
            args.per_step.max(1)
        );
    }
    if let Some(dir) = args.obj {
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        for (t, state) in parsed.states.iter().enumerate() {
            let path = dir.join(format!("step_{t:03}.obj"));
            let text = match &parsed.triangles {
                Some(t) => obj_triangles(state, t),
                None => obj_mesh(state, rows, cols),
            };
            write_atomic(&path, text.as_bytes())?;
        }
        println!(
            "wrote {} OBJ meshes to {}",
            parsed.states.len(),
            dir.display()
        );
    }
    Ok(0)
}
