//! `clothopt optimize`: plan a scene's task, write the result and the figures, and turn the
//! verdict into the exit code.

use super::common::{draw, load_controls, load_scene, PhysicsArgs, WatchArgs};
use super::progress::Reporter;
use super::summary;
use anyhow::{Context, Result};
use cloth::{Model, Scene};
use clothopt::output::write_json_atomic;
use clothopt::physics_check::{plan_with_check, CheckPhysics, CheckRequest};
use clothopt::plan::{self, Optimizer};
use clothopt::problem::{SafetyForm, TargetModel};
use clothopt::request::OptimizeRequest;
use clothopt::result::{states_of, PlanResult, FEASIBILITY_TOLERANCE};
use clothopt::search::{plan_with_search, Progress, SearchMode};
use clothopt::validate::ensure_iterations;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Optimize the control sequence of a scene's task.
#[derive(clap::Args)]
pub struct OptimizeArgs {
    /// A built-in scene name or a scene JSON file.
    scene: String,
    /// Safety margin δ (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    delta: Option<f64>,
    /// Weight α of the trajectory irregularity (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    alpha: Option<f64>,
    /// Weight β of the elastic energy (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    beta: Option<f64>,
    /// Optimizer iteration limit, per κ stage (the soft safety forms first solve at κ = 200)
    #[arg(long, default_value_t = 200)]
    iterations: usize,
    /// Solver sweeps per time step of the simulation (default: the scene's
    /// `physics.iterations`).
    #[arg(long)]
    sweeps: Option<usize>,
    /// Form of the safety constraint.
    #[arg(long, value_enum, default_value_t = SafetyForm::PerStep)]
    safety: SafetyForm,
    /// How the SQP models the target term G: `bfgs` leaves G in the smooth objective, its
    /// curvature learnt by BFGS (the paper's formulation); `gauss-newton` linearizes the target
    /// residual in each QP's second-order cone (slower on the scenes measured).
    #[arg(long, value_enum, default_value_t = TargetModel::Bfgs)]
    target_model: TargetModel,
    /// Judge safety at the steps only: the rows and the verdict leave the straight motion
    /// between the steps (and the grippers' motion between them) unchecked. By default the
    /// motion between the steps keeps δ from the safety obstacles and the grippers out of the
    /// colliders too.
    #[arg(long, conflicts_with = "swept")]
    step_only: bool,
    /// The default (kept for scripts that ask for it): the motion between the steps is checked.
    #[arg(long)]
    swept: bool,
    /// Sharpness κ (1/length) of the soft minimum in the per-step and aggregate forms (default
    /// 3000); above 200 the planner first solves at κ = 200 and refines from that plan.
    #[arg(long, allow_negative_numbers = true)]
    kappa: Option<f64>,
    /// Safety rows farther than this above their margin keep their last gradient instead of
    /// a backward pass per iterate while it predicts their change (length units; default off).
    #[arg(long, allow_negative_numbers = true)]
    reuse_band: Option<f64>,
    /// Newton physics: a line-search trial whose rollout would take more than this many times
    /// the Newton iterations of its iterate's rollout (step by step) is stopped and counts as a
    /// step too long (default `inf`: never; 2–4 pays where contact makes trials costly).
    #[arg(long, allow_negative_numbers = true)]
    trial_work_factor: Option<f64>,
    /// The solver.
    #[arg(long, value_enum, default_value_t = Optimizer::Sqp)]
    solver: Optimizer,
    /// Route search: `auto` plans other routes (detours over, beside or under the obstacles
    /// the first plan runs into, the grippers lifted where the cloth rests on a collider, and
    /// seeded perturbations) only when the plan from the start does not achieve the task;
    /// `always` also when it does; `off` never.
    #[arg(long, value_enum, default_value_t = SearchMode::Auto)]
    search: SearchMode,
    /// Most candidate routes the search plans (from 4 on, 2 of them seeded random
    /// perturbations).
    #[arg(long, default_value_t = 6)]
    starts: usize,
    /// Write the result JSON here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Start from these controls: a controls file or a previous result (default: the scene's
    /// initial guess).
    #[arg(long)]
    start: Option<PathBuf>,
    /// Scaled KKT tolerance for `converged`.
    #[arg(long, default_value_t = 1e-4, allow_negative_numbers = true)]
    tol: f64,
    /// Largest violation (length units) of the optimizer's rows (safety rows, collider rows)
    /// at which a plan still counts as feasible; a plan violating them by more ends `no safe
    /// plan` (exit 4) and says by how much.
    #[arg(long, default_value_t = FEASIBILITY_TOLERANCE, allow_negative_numbers = true)]
    feasibility_tol: f64,
    /// Plan even when the cloth starts inside an obstacle (an error otherwise): step 0 is
    /// fixed by the scene, so no plan can make it safe.
    #[arg(long)]
    allow_unsafe_start: bool,
    /// Draw the result: a 3-D view here and a top view beside it (`*_top.png`).
    #[arg(long)]
    png: Option<PathBuf>,
    #[command(flatten)]
    watch: WatchArgs,
    /// Print one line per optimizer iteration to stderr.
    #[arg(long)]
    verbose: bool,
    /// Stop after this many seconds and return the best safe plan found so far (status
    /// `time_limit`); the route search stops too. With the search on, the plan from the initial
    /// guess gets half of the time and the other routes the rest.
    #[arg(long, allow_negative_numbers = true)]
    time_limit: Option<f64>,
    /// Leave the wall-clock time out of the result JSON and the summary, so that the same
    /// command writes byte-identical results (any thread count).
    #[arg(long)]
    no_timing: bool,
    #[command(flatten)]
    physics: PhysicsArgs,
    /// Check the plan under other physics: `xpbd:N` (XPBD at N iterations per step), `newton`,
    /// `newton:TOL`, or `newton-branch[:H]` (Newton with branch following, at most H load
    /// halvings, default 10: whether the plan's end depends on which of a step's equilibria the
    /// solver lands in). The plan must also be safe at δ there; where it is not, it is re-planned
    /// from itself with the margin raised by 1.25× the shortfall, up to `--check-rounds` times.
    #[arg(long)]
    check: Option<CheckPhysics>,
    /// Most re-plans with a raised margin after a failed `--check` (0: only report).
    #[arg(long, default_value_t = 3)]
    check_rounds: usize,
}

/// The command-line spelling of a setting: `reuse_band` → `--reuse-band`.
fn flag_name(field: &str) -> String {
    format!("--{}", field.replace('_', "-"))
}

/// The planning settings of the flags, as the CLI and Python share them.
fn request(args: &OptimizeArgs) -> OptimizeRequest {
    OptimizeRequest {
        delta: args.delta,
        alpha: args.alpha,
        beta: args.beta,
        iterations: args.iterations,
        safety: args.safety,
        target_model: args.target_model,
        // `--swept` asks for the default; clap rejects it beside `--step-only`.
        step_only: args.step_only && !args.swept,
        kappa: args.kappa,
        reuse_band: args.reuse_band,
        trial_work_factor: args.trial_work_factor,
        solver: args.solver,
        search: args.search,
        starts: args.starts,
        tol: args.tol,
        feasibility_tol: args.feasibility_tol,
        allow_unsafe_start: args.allow_unsafe_start,
        time_limit: args.time_limit,
    }
}

/// Runs `optimize`: plans (with the route search), prints the summary, writes the result and
/// figures; the exit code is the verdict's ([`summary::report_verdict`]).
pub fn run(args: OptimizeArgs) -> Result<i32> {
    let request = request(&args);
    request.check(&flag_name)?;
    if let Some(n) = args.sweeps {
        ensure_iterations("--sweeps", n)?;
    }
    let scene = load_scene(&args.scene, args.sweeps, &args.physics)?;
    let model = Model::from_scene(&scene)?;
    let start = load_controls(&scene, &model, args.start.as_deref())?;
    let (mut options, search) = request.options(&model, &flag_name)?;
    let stop = Arc::new(AtomicBool::new(false));
    options.stop = Some(stop.clone());
    // First Ctrl-C: stop the optimizer and write the best plan so far; a second one quits.
    ctrlc::set_handler(move || {
        if stop.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    })
    .context("cannot install the Ctrl-C handler")?;
    let (out, no_timing) = (args.out, args.no_timing);
    let budget = args.iterations * (1 + usize::from(options.kappa_warmup.is_some()));
    // One plan at margin `delta` from `start`, with its progress and best-so-far file.
    let run_plan = |delta: f64, start: &cloth::Controls| {
        let mut options = options.clone();
        options.task.delta = delta;
        let mut reporter = Reporter::new(budget, args.verbose, options.tol_feasibility);
        let mut save = |x: &[f64], violation: f64, seen: usize| {
            let Some(path) = &out else { return };
            match plan::snapshot(&model, &scene, x, violation, seen, &options) {
                Ok(mut r) => {
                    if no_timing {
                        r.drop_timing();
                    }
                    if let Err(e) = write_json_atomic(path, &r) {
                        eprintln!("warning: best-so-far file: {e:#}");
                    }
                }
                Err(e) => eprintln!("warning: best-so-far file: {e:#}"),
            }
        };
        let result = plan_with_search(
            &model,
            &scene,
            start,
            &options,
            &search,
            |event| match event {
                Progress::Iteration(info) => reporter.iteration(info, &mut save),
                Progress::Stage { stage, route } => reporter.stage(stage, route),
            },
        );
        reporter.finish();
        result
    };
    let check = args.check.map(|physics| CheckRequest {
        physics,
        rounds: args.check_rounds,
    });
    let result = plan_with_check(&model, &scene, check, options.task.delta, &start, run_plan);
    let mut result = result?;
    if no_timing {
        result.drop_timing();
    }
    if let Some(warning) = clothopt::strain::strain_warning(&model, &result) {
        result.warnings.push(warning);
    }
    summary::print_summary(&result, no_timing);
    if let Some(out) = &out {
        write_json_atomic(out, &result)?;
    }
    draw_result(&model, &scene, &result, args.png.as_deref(), &args.watch)?;
    Ok(summary::report_verdict(&result, out.as_deref()))
}

/// The figures of the returned plan's rollout that the flags ask for (`--png`, `--html`, `--gif`).
fn draw_result(
    model: &Model,
    scene: &Scene,
    result: &PlanResult,
    png: Option<&Path>,
    watch: &WatchArgs,
) -> Result<()> {
    if png.is_none() && watch.html.is_none() && watch.gif.is_none() {
        return Ok(());
    }
    let states = states_of(result)?;
    let title = format!(
        "{}  δ = {}  ({})",
        result.scene, result.delta, result.status
    );
    if let Some(png) = png {
        draw(model, scene, &states, &title, result.delta, png)?;
    }
    watch.write(model, scene, &states, &title, result.delta)
}
