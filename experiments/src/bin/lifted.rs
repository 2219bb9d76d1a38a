//! Whether keeping a plan's trial rollouts on the branch its rollout is on lets a contact task's
//! targets pull further: Levenberg–Marquardt on the target term `½‖x_targets(T) − p‖²` from given
//! controls, its Jacobian `∂x_T/∂U` from the control tangents (`Model::newton_control_tangents`),
//! each trial rolled out with every step's solve started from the states the tangents predict
//! (`Model::simulate_newton_guided`), or from scratch as a plan's rollouts are (`--plain`). Each
//! accepted iterate is also rolled out from scratch, so that the table shows whether the plain
//! rollout — the one a verdict judges — follows the guided one.
//!
//! Only the target term and the gripper limits a step is projected onto (`max_step`, the
//! workspace) are modelled: no gripper rows, strain or safety. A measurement, not a planner: a
//! promising end is a start for `clothopt optimize --start`.
//!
//! ```sh
//! cargo run --release -p experiments --bin lifted -- examples/scenes/tasks/lay_aside.json \
//!     --controls plan.json --iterations 20 [--plain] [--out lifted.json]
//! ```

use anyhow::{bail, Context, Result};
use autodiff::Tensor;
use clap::Parser;
use cloth::{controls_from_file, ControlTangents, Model, Solver};
use clothopt::outcome::target_errors;
use clothopt::problem::target_residual;
use clothopt::request::load_scene;
use experiments::report::write_json;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser)]
#[command(
    about = "Levenberg–Marquardt on a task's targets with trial rollouts kept on their branch"
)]
struct Args {
    /// A scene JSON file or a built-in scene's name (Newton physics).
    scene: String,
    /// Start from these controls (a controls file or a plan's result); default zeros.
    #[arg(long)]
    controls: Option<PathBuf>,
    /// Accepted or rejected iterations to run.
    #[arg(long, default_value_t = 20)]
    iterations: usize,
    /// Roll trials out from scratch instead of from their predicted states.
    #[arg(long)]
    plain: bool,
    /// Write the last accepted controls (`{"controls": …}`) here.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `½‖r‖²` and the largest target distance.
fn score(model: &Model, x: &Tensor) -> (f64, f64) {
    let errors = target_errors(model, x);
    let half = 0.5 * errors.iter().map(|e| e * e).sum::<f64>();
    (half, errors.iter().copied().fold(0.0, f64::max))
}

/// `u` moved onto the gripper limits: each step's displacement shortened to `max_step`, then the
/// position it reaches clamped into the workspace (which only shortens it further).
fn project_limits(model: &Model, u: &mut Tensor) {
    let limits = &model.task.limits;
    let grippers = model.controls.as_slice();
    let mut at: Vec<[f64; 3]> = grippers
        .iter()
        .map(|&p| [0, 1, 2].map(|j| model.start.get(p, j)))
        .collect();
    for t in 0..u.rows() {
        for (k, pos) in at.iter_mut().enumerate() {
            let row = &mut u.row_mut(t)[3 * k..3 * k + 3];
            if let Some(m) = limits.max_step {
                let n = (row[0] * row[0] + row[1] * row[1] + row[2] * row[2]).sqrt();
                if n > m {
                    row.iter_mut().for_each(|v| *v *= m / n);
                }
            }
            for j in 0..3 {
                let mut next = pos[j] + row[j];
                if let Some(w) = &limits.workspace {
                    next = next.clamp(w.min[j], w.max[j]);
                }
                row[j] = next - pos[j];
                pos[j] = next;
            }
        }
    }
}

/// Solves the symmetric positive definite `a x = b` (`n × n`, row-major) by Cholesky.
fn solve_spd(a: &[f64], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let m = cloth::nalgebra::DMatrix::from_row_slice(n, n, a);
    let chol = m.cholesky()?;
    Some(
        chol.solve(&cloth::nalgebra::DVector::from_column_slice(b))
            .as_slice()
            .to_vec(),
    )
}

#[derive(serde::Serialize)]
struct Row {
    iteration: usize,
    mu: f64,
    accepted: bool,
    /// `½‖r‖²` and the largest target distance of the trial's (guided or plain) rollout.
    trial_cost: f64,
    trial_largest: f64,
    /// The same of the accepted iterate rolled out from scratch.
    plain_cost: f64,
    plain_largest: f64,
    /// Steps of the trial solved from their guess.
    guided_steps: usize,
    seconds: f64,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let scene = load_scene(&args.scene)?;
    let model = Model::from_scene(&scene).context("building the model")?;
    let Solver::Newton(settings) = model.solver else {
        bail!(
            "{}: the scene's physics is XPBD; this measures Newton rollouts",
            scene.name
        );
    };
    let mut u = match &args.controls {
        Some(path) => controls_from_file(path).map_err(anyhow::Error::msg)?,
        None => model.zero_controls(),
    };
    model.check_controls(&u)?;
    let clock = Instant::now();
    let (mut states, _) = model.simulate_newton(&u, &settings)?;
    let (mut cost, largest) = score(&model, &states[model.task.horizon]);
    println!(
        "{}: start ½‖r‖² {cost:.6e}, largest target error {largest:.4} (tolerance {})",
        scene.name, model.task.tolerance
    );
    println!(
        "  it        mu  accepted   trial ½‖r‖²  largest   plain ½‖r‖²  largest  guided     s"
    );
    let mut mu = f64::NAN;
    let mut tangents: Option<ControlTangents> = None;
    let mut rows = Vec::new();
    let horizon = model.task.horizon;
    for iteration in 1..=args.iterations {
        let s = match &tangents {
            Some(s) => s,
            None => tangents.insert(model.newton_control_tangents(&states, &u)?),
        };
        let (jac, r) = jacobian(&model, s, &states[horizon]);
        let n = u.data().len();
        let (jtj, jtr) = normal_equations(&jac, &r, n);
        if mu.is_nan() {
            mu = 1e-3 * (0..n).map(|i| jtj[i * n + i]).sum::<f64>() / n as f64;
        }
        let mut a = jtj.clone();
        (0..n).for_each(|i| a[i * n + i] += mu);
        let neg: Vec<f64> = jtr.iter().map(|v| -v).collect();
        let Some(du) = solve_spd(&a, &neg) else {
            bail!("iteration {iteration}: the damped normal equations are not positive definite");
        };
        let mut trial = u.clone();
        trial
            .data_mut()
            .iter_mut()
            .zip(&du)
            .for_each(|(a, d)| *a += d);
        project_limits(&model, &mut trial);
        let step: Vec<f64> = (trial.data().iter().zip(u.data()))
            .map(|(a, b)| a - b)
            .collect();
        let rolled = if args.plain {
            model
                .simulate_newton(&trial, &settings)
                .map(|(x, _)| (x, 0))
        } else {
            let moves = predicted_moves(&model, s, &step);
            model
                .simulate_newton_guided(&trial, &settings, &states, &moves)
                .map(|(r, g)| (r.states, g))
        };
        let (trial_states, guided) = match rolled {
            Ok(r) => r,
            Err(e) => {
                println!("  {iteration:>2}: trial rollout failed ({e}); damping ×4");
                mu *= 4.0;
                continue;
            }
        };
        let (trial_cost, trial_largest) = score(&model, &trial_states[horizon]);
        let accepted = trial_cost < cost;
        if accepted {
            (u, states, cost, mu) = (trial, trial_states, trial_cost, mu / 3.0);
            tangents = None;
        } else {
            mu *= 4.0;
        }
        let (plain_cost, plain_largest) = if args.plain {
            score(&model, &states[horizon])
        } else {
            match model.simulate_newton(&u, &settings) {
                Ok((x, _)) => score(&model, &x[horizon]),
                Err(_) => (f64::NAN, f64::NAN),
            }
        };
        let seconds = clock.elapsed().as_secs_f64();
        println!(
            "  {iteration:>2} {mu:>9.2e}  {accepted:>8}  {trial_cost:>12.5e}  {trial_largest:.4}  \
             {plain_cost:>12.5e}  {plain_largest:.4}  {guided:>6}  {seconds:>5.1}"
        );
        rows.push(Row {
            iteration,
            mu,
            accepted,
            trial_cost,
            trial_largest,
            plain_cost,
            plain_largest,
            guided_steps: guided,
            seconds,
        });
    }
    if let Some(path) = &args.out {
        let controls = cloth::ControlsView::to_nested(&u);
        write_json(
            path,
            &serde_json::json!({ "scene": scene.name, "controls": controls, "rows": rows }),
        )?;
    }
    Ok(())
}

/// `∂r/∂U` (`3·targets × (T·3K)`, row-major) and `r` at the final state `x`.
fn jacobian(model: &Model, s: &ControlTangents, x: &Tensor) -> (Vec<f64>, Vec<f64>) {
    let r = target_residual(model, x);
    let last = &s.steps[model.task.horizon];
    let n = last.rows();
    let task = &model.task;
    let mut jac = vec![0.0; r.len() * n];
    for k in 0..task.targets.rows() {
        let p = task.targets.row(k)[0];
        for d in 0..3 {
            for j in 0..n {
                jac[(3 * k + d) * n + j] = last.row(j)[3 * p + d];
            }
        }
    }
    (jac, r)
}

/// `JᵀJ` and `Jᵀr` for `J` with `n` columns.
fn normal_equations(jac: &[f64], r: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut jtj, mut jtr) = (vec![0.0; n * n], vec![0.0; n]);
    for (row, ri) in jac.chunks_exact(n).zip(r) {
        for i in 0..n {
            jtr[i] += row[i] * ri;
            for j in 0..n {
                jtj[i * n + j] += row[i] * row[j];
            }
        }
    }
    (jtj, jtr)
}

/// The states' moves the tangents predict for the controls' move `du`: `Σ_j du_j ∂x_t/∂U_j`.
fn predicted_moves(model: &Model, s: &ControlTangents, du: &[f64]) -> Vec<Tensor> {
    (0..s.steps.len())
        .map(|t| Tensor::new(model.n_particles(), 3, s.predict(t, du)))
        .collect()
}
