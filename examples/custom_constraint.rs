//! A constraint the library does not ship, end to end, without a hand-derived gradient.
//!
//! `cargo run --release --example custom_constraint`
//!
//! 1. defines triangle-area preservation `C = ½|(p₁ − p₀) × (p₂ − p₀)| − A⁰` by writing only `C`;
//! 2. adds it to the built-in `swing` scene's model and shows that it acts (area error with and
//!    without it);
//! 3. checks the library-derived `dL/dU` against central finite differences (exits non-zero when
//!    a relative error exceeds 1e-6);
//! 4. registers it by name, so that a scene file can use it (`custom_constraints`), loads the
//!    scene from JSON with the registry and checks that the model equals the hand-built one (bitwise
//!    rollout);
//! 5. plans the swing task with the model from JSON (SQP).
//!
//! The scene runs 50 Gauss–Seidel iterations per step instead of its 100, to keep the run short.

use anyhow::{bail, Context, Result};
use autodiff::{Real, Tensor};
use cloth::constraint::{norm, Constraint};
use cloth::nalgebra::Vector3;
use cloth::{ConstraintRegistry, Controls, ControlsView, Model, Scene};
use clothopt::plan::{plan, PlanOptions};
use clothopt::result::controls_from_nested;
use std::time::Instant;

// ---- the user's constraint: this is all a new constraint type needs ------------------------

/// Triangle-area preservation: `C = ½|(p₁ − p₀) × (p₂ − p₀)| − A⁰`, one instance per triangle.
struct TriangleArea {
    /// Rest area `A⁰` per triangle.
    rest: Vec<f64>,
}

impl TriangleArea {
    /// The area of the triangle `p₀p₁p₂`, for any scalar (plain, dual, nested dual).
    fn area<R: Real>(p: &[Vector3<R>]) -> R {
        norm(&(p[1] - p[0]).cross(&(p[2] - p[0]))) * 0.5
    }
}

impl Constraint for TriangleArea {
    const ARITY: usize = 3;
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        Self::area(p) - self.rest[instance]
    }
}

/// A registry that knows `triangle_area`: rest areas from the rest positions of each entry's
/// particles, three per triangle, so a scene file needs only the particles and a stiffness.
fn registry() -> ConstraintRegistry {
    let mut registry = ConstraintRegistry::new();
    registry.register("triangle_area", |input| {
        let rest = input
            .rest
            .chunks_exact(3)
            .map(|t| {
                TriangleArea::area(
                    &t.iter()
                        .map(|&[x, y, z]| Vector3::new(x, y, z))
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        Ok(TriangleArea { rest })
    });
    registry
}

/// The scene's JSON with one `custom_constraints` entry: `triangle_area` on every mesh triangle.
fn scene_json_with_area(scene: &Scene, stiffness: f64) -> Result<String> {
    let mut json: serde_json::Value = serde_json::from_str(&scene.to_json_pretty())?;
    let cols = scene.cloth.cols;
    let particles: Vec<[usize; 2]> = scene
        .mesh()
        .triangles()
        .iter()
        .flatten()
        .map(|&p| [p / cols, p % cols])
        .collect();
    json["custom_constraints"] = serde_json::json!([
        {"type": "triangle_area", "particles": particles, "stiffness": stiffness}
    ]);
    Ok(cloth::scene::to_json_pretty_compact(&json)?)
}

// ---- using it ------------------------------------------------------------------------------

/// Gauss–Seidel iterations per step (fewer than the scene's 100, to keep the run short).
const ITERATIONS: usize = 50;
/// Stiffness `k` of the area constraints (energy per area²): the restoring force at 1% area error,
/// `k·|∇C|·A⁰/100`, is of the order of a particle's weight, as for the scene's stretch stiffness
/// 1e4 at 1% strain.
const AREA_STIFFNESS: f64 = 1e6;
/// Step of the fourth-order central difference.
const FD_STEP: f64 = 1e-4;
/// Largest accepted error between `dL/dU·d` and finite differences, relative to the larger of
/// the two, floored at `1e-3·|dL/dU|` (a direction nearly orthogonal to the gradient is judged
/// by its absolute error).
const FD_TOLERANCE: f64 = 1e-6;
/// SQP iteration limit of the planning run.
const PLAN_ITERATIONS: usize = 150;

/// Particle `p` of an `N × 3` state.
fn point(x: &Tensor, p: usize) -> Vector3<f64> {
    Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2))
}

/// Mean and max relative area error `|A − A⁰| / A⁰` over the triangles, in state `x`.
fn area_error(area: &TriangleArea, triangles: &[[usize; 3]], x: &Tensor) -> (f64, f64) {
    let errors: Vec<f64> = triangles
        .iter()
        .enumerate()
        .map(|(k, tri)| area.c(k, &tri.map(|p| point(x, p))).abs() / area.rest[k])
        .collect();
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    (mean, errors.iter().copied().fold(0.0, f64::max))
}

/// A small deterministic generator (xorshift64*) for reproducible "random" numbers in `[−1, 1)`.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        2.0 * (bits as f64 / (1u64 << 53) as f64) - 1.0
    }
}

/// `L` of `model` at `controls` (forward only).
fn loss(model: &Model, controls: &Controls, delta: f64) -> Result<f64> {
    Ok(model.evaluate(controls, delta, false)?.metrics.l)
}

/// `dL/dU·d` by the fourth-order central difference
/// `[8(L(U + hd) − L(U − hd)) − (L(U + 2hd) − L(U − 2hd))] / 12h`.
fn directional_fd(model: &Model, controls: &Controls, d: &[f64], delta: f64) -> Result<f64> {
    let l = |s: f64| loss(model, &shifted(controls, d, s * FD_STEP), delta);
    Ok((8.0 * (l(1.0)? - l(-1.0)?) - (l(2.0)? - l(-2.0)?)) / (12.0 * FD_STEP))
}

/// `controls + s·d`.
fn shifted(controls: &Controls, d: &[f64], s: f64) -> Controls {
    let mut c = controls.clone();
    for (a, b) in c.data_mut().iter_mut().zip(d) {
        *a += s * b;
    }
    c
}

fn main() -> Result<()> {
    let clock = Instant::now();
    let mut scene = Scene::builtin("swing")?;
    scene.physics.iterations = ITERATIONS;
    let delta = scene.task.delta;

    // 1–2. Rest areas from the rest positions, one constraint per mesh triangle.
    let mesh = scene.mesh();
    let triangles = mesh.triangles().to_vec();
    let rest_pos: Vec<Vector3<f64>> = scene
        .rest_positions()
        .iter()
        .map(|&[x, y, z]| Vector3::new(x, y, z))
        .collect();
    let rest = triangles
        .iter()
        .map(|tri| TriangleArea::area(&tri.map(|p| rest_pos[p])))
        .collect();
    let area = TriangleArea { rest };
    let particles: Vec<usize> = triangles.iter().flatten().copied().collect();

    let plain = Model::from_scene(&scene)?;
    let mut model = plain.clone();
    model.add_constraints(
        "area",
        TriangleArea {
            rest: area.rest.clone(),
        },
        particles,
        AREA_STIFFNESS,
    )?;
    println!(
        "scene swing, {} Gauss–Seidel iterations per step",
        model.iterations
    );
    println!("  without: {}", plain.effects());
    println!("  with:    {}", model.effects());

    // A non-trivial control sequence: lift and swing, plus a little noise on every coordinate.
    let mut rng = Rng(0x5eed_c0de_1234_5678);
    let (horizon, k) = (model.task.horizon, model.n_controls());
    let mut controls = model.zero_controls();
    for t in 0..horizon {
        for c in 0..k {
            let displacement = [0.0, 0.15, 0.08].map(|base| base + 0.02 * rng.next());
            controls.set_at(t, c, displacement);
        }
    }

    println!("\nrelative triangle-area error |A − A⁰|/A⁰ at the last step (mean / max):");
    let mut evals = Vec::new();
    for (name, m) in [("without area", &plain), ("with area", &model)] {
        let ev = m.evaluate(&controls, delta, true)?;
        let last = ev.states.last().context("a rollout has states")?;
        let (mean, max) = area_error(&area, &triangles, last);
        println!("  {name:<13} mean {mean:.3e}  max {max:.3e}");
        evals.push(ev);
    }

    // 3. dL/dU from the library next to central finite differences.
    let grad_plain = evals[0].grad_l.clone().context("gradient requested")?;
    let grad = evals[1].grad_l.clone().context("gradient requested")?;
    let diff: f64 = grad
        .data()
        .iter()
        .zip(grad_plain.data())
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let gnorm = grad.data().iter().map(|a| a * a).sum::<f64>().sqrt();
    println!(
        "\ndL/dU with the area constraint: |dL/dU| = {gnorm:.4}; it differs from the model without \
         it by {:.1}%",
        100.0 * diff / gnorm
    );
    println!("fourth-order central differences, step {FD_STEP:e}:");
    println!(
        "  {:<28} {:>15} {:>15} {:>10}",
        "direction", "dL/dU·d", "finite diff.", "rel. err."
    );
    let n = grad.data().len();
    let mut directions: Vec<(String, Vec<f64>)> = (0..3)
        .map(|i| {
            let d: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            (
                format!("random #{}", i + 1),
                d.iter().map(|v| v / len).collect(),
            )
        })
        .collect();
    for (t, c, j) in [(0, 0, 1), (4, 1, 2), (9, 0, 0)] {
        let mut d = vec![0.0; n];
        d[controls.flat_index(t, c, j)] = 1.0;
        let axis = ["x", "y", "z"][j];
        directions.push((format!("step {t}, control {c}, {axis}"), d));
    }
    let mut worst: f64 = 0.0;
    for (name, d) in &directions {
        let analytic: f64 = grad.data().iter().zip(d).map(|(g, v)| g * v).sum();
        let fd = directional_fd(&model, &controls, d, delta)?;
        let rel = (analytic - fd).abs() / analytic.abs().max(fd.abs()).max(1e-3 * gnorm);
        worst = worst.max(rel);
        println!("  {name:<28} {analytic:>15.9} {fd:>15.9} {rel:>10.2e}");
    }
    if worst > FD_TOLERANCE {
        bail!("gradient check failed: worst relative error {worst:.2e} > {FD_TOLERANCE:e}");
    }
    println!("  worst relative error {worst:.2e} ≤ {FD_TOLERANCE:e}: OK");

    // 4. The same constraint from a scene file: register the type, name it in the JSON.
    let text = scene_json_with_area(&scene, AREA_STIFFNESS)?;
    let from_file = Scene::from_json_str(&text)?;
    let registry = registry();
    let model_from_file = Model::from_scene_with(&from_file, &registry)?;
    println!(
        "\nfrom JSON (`\"custom_constraints\": [{{\"type\": \"triangle_area\", \"particles\": [[0, 0], [0, 1], [1, 1], …], \"stiffness\": {AREA_STIFFNESS:e}}}]`), registered types {:?}:",
        registry.names()
    );
    println!("  {}", model_from_file.effects());
    let same = model_from_file
        .simulate(&controls)?
        .last()
        .map(|x| x.data().to_vec())
        == model.simulate(&controls)?.last().map(|x| x.data().to_vec());
    if !same {
        bail!("the model from JSON does not roll out as the hand-built one");
    }
    println!("  rollout bitwise equal to the hand-built model's: OK");
    let model = model_from_file;

    // 5. Plan the swing task with the area constraint in the model (from JSON).
    let mut options = PlanOptions::for_model(&model);
    options.iterations = PLAN_ITERATIONS;
    let start = model.zero_controls();
    let before = model.evaluate(&start, delta, false)?.metrics;
    println!(
        "\nplanning swing with the area constraint (SQP, ≤ {} iterations):",
        options.iterations
    );
    let result = plan(&model, &from_file, &start, &options, |info| {
        if info.iteration % 10 == 0 {
            println!(
                "  it {:>3}  L {:>10.6}  kkt {:>8.1e}",
                info.iteration, info.objective, info.kkt_residual
            );
        }
    })?;
    let m = &result.metrics;
    println!(
        "  status {} ({}), {} iterations, {} simulations, {:.1} s",
        result.status, result.message, result.iterations, result.evaluations, result.wall_s
    );
    println!(
        "  G {:.4} → {:.4}   (L {:.4} → {:.4})",
        before.g, m.g, before.l, m.l
    );
    let planned = controls_from_nested(&model, &result.controls)?;
    println!("  area error of the planned motion at the last step (mean / max):");
    for (name, m) in [("without area", &plain), ("with area", &model)] {
        let states = m.simulate(&planned)?;
        let last = states.last().context("a rollout has states")?;
        let (mean, max) = area_error(&area, &triangles, last);
        println!("    {name:<13} mean {mean:.3e}  max {max:.3e}");
    }
    println!("\ntotal wall time {:.1} s", clock.elapsed().as_secs_f64());
    Ok(())
}
