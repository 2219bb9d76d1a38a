//! The JAX reference beside ours (`--jax PYTHON`).

use anyhow::Result;
use autodiff::Tensor;
use experiments::child;
use serde::Deserialize;
use std::collections::HashMap;
use std::path::Path;

use crate::rows::{AccuracyRow, JaxRow, MeshRow};
use crate::sweep::rel_err;
use crate::MESH_N_ITER;

/// The JAX benchmark's output line.
#[derive(Deserialize)]
pub struct JaxOut {
    pub forward_s: f64,
    pub forward_gradient_s: f64,
    #[serde(rename = "L")]
    pub l: f64,
    #[serde(rename = "grad_L")]
    pub grad_l: Vec<Vec<[f64; 3]>>,
}

/// Times the JAX reference with `python` running `script` on `u_obstacle` at n = 10 and the mesh
/// sizes up to 40, and sets our measurements beside it (`grads`: our ∇L at [`MESH_N_ITER`] per
/// scene). Stops at the first failing run, saying why on stderr.
pub fn compare(
    python: &Path,
    script: &Path,
    mesh_sizes: &[usize],
    acc: &[AccuracyRow],
    mesh: &[MeshRow],
    grads: &HashMap<&str, Tensor>,
) -> Vec<JaxRow> {
    let mut jax = Vec::new();
    // u_obstacle only: the benchmark evaluates at the scene's initial guess, which for swing
    // is the degenerate all-zero point (see `evaluation_point`).
    let mut settings = vec![("u_obstacle", 10)];
    settings.extend(
        mesh_sizes
            .iter()
            .filter(|&&n| n > 10 && n <= 40)
            .map(|&n| ("u_obstacle", n)),
    );
    for (scene, n) in settings {
        eprintln!("JAX: {scene}, n = {n}, {MESH_N_ITER} iterations …");
        let j = match run_jax(python, script, scene, n, MESH_N_ITER) {
            Ok(j) => j,
            Err(e) => {
                eprintln!("JAX skipped: {e:#}");
                break;
            }
        };
        let ours = acc
            .iter()
            .find(|r| r.scene == scene && r.n_iter == MESH_N_ITER && n == 10);
        let ours_mesh = mesh
            .iter()
            .find(|r| r.n == n && r.threads == 2 && scene == "u_obstacle");
        // L is comparable at n = 10 only (see `JaxRow::l_rel_diff`).
        let ours_l = ours.map(|r| r.l);
        let grad_rel_diff = grads.get(scene).filter(|_| n == 10).map(|g| {
            let flat: Vec<f64> = j.grad_l.iter().flatten().flatten().copied().collect();
            rel_err(&Tensor::new(g.rows(), g.cols(), flat), g)
        });
        jax.push(JaxRow {
            scene: scene.into(),
            n,
            n_iter: MESH_N_ITER,
            forward_s: j.forward_s,
            forward_grad_l_s: j.forward_gradient_s,
            l: j.l,
            ours_forward_s: ours
                .map(|r| r.forward.median_s)
                .or(ours_mesh.map(|r| r.forward.median_s)),
            ours_forward_grad_l_s: ours
                .map(|r| r.forward_grad_l.median_s)
                .or(ours_mesh.map(|r| r.forward_grad_l.median_s)),
            l_rel_diff: ours_l.map(|l| (j.l - l).abs() / l.abs()),
            grad_rel_diff,
        });
    }
    jax
}

/// Runs the JAX reference for `scene` at mesh size `n`.
pub fn run_jax(
    python: &Path,
    script: &Path,
    scene: &str,
    n: usize,
    n_iter: usize,
) -> Result<JaxOut> {
    let code = if scene == "u_obstacle" { "U" } else { scene };
    child::run_jax(python, script, code, n, n_iter)
}
