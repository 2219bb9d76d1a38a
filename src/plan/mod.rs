//! Running a cloth task through an optimizer: [`PlanOptions`], and [`plan`] as a list of named
//! stages (step 0, the smooth κ stage, the sharp stage, re-scoring, the active groups, the verdict);
//! [`snapshot`] scores a run still under way. The result it returns is [`crate::result`]'s
//! [`PlanResult`], re-exported here with its converters for callers of [`plan`].

use crate::anytime::{StopReason, Watch};
use crate::error::{Error, Result};
use crate::outcome::{row_facts, task_outcome, PlanFacts, RowFacts, TaskOutcome};
use crate::problem::TrajectoryProblem;
// The result of a run and its converters, from `crate::result`: re-exported for this module's callers.
pub use crate::result::{
    controls_from_nested, controls_to_nested, gripper_positions, is_safe, mesh_triangles,
    state_points, states_of, PlanResult, Stage, FEASIBILITY_TOLERANCE, SAFETY_TOLERANCE,
};
use crate::result::{Measures, PhysicsReport, SafetyReport};
use crate::safety_check::{check_safety, physics_hint};
use crate::start_check::{judge_start, start_warning};
use crate::target_check::buried_target_warnings;
use crate::thin_colliders::thin_collider_warning;
// The rollout's strain and its warning, from `crate::strain`: re-exported for this module's callers.
pub use crate::strain::{strain_report, strain_warning, StrainReport, STRAIN_WARNING_THRESHOLD};
use autodiff::Tensor;
use cloth::Evaluation;
use cloth::{Controls, Metrics, Model, Scene};
use optim::{
    DenseMatrix, IterationInfo, LbfgsSettings, LbfgsSolver, Problem, SqpSettings, SqpSolver, Status,
};
use std::cell::RefCell;
use std::ops::ControlFlow;
use std::time::Instant;

mod options;
pub use options::{Optimizer, PlanOptions, PLAN_TOL_PROGRESS};

/// The scene's initial guess as a controls tensor.
pub fn initial_controls(scene: &Scene, model: &Model) -> Result<Controls, cloth::ClothError> {
    let c = scene.initial_controls();
    model.check_controls(&c)?;
    Ok(c)
}

/// Optimizes `model`'s task from `start`, calling `progress` after every iteration. The run is a
/// list of stages, each a function of this module:
///
/// 1. `check_start`: the options, the start, and step 0 (the rest state against the obstacles);
/// 2. `smooth_stage`: the κ warm-up, a smooth and conservative soft minimum (when it applies);
/// 3. `sharp_stage`: the task's κ from the warm-up's plan and Hessian, unless the warm-up left it
///    nothing to do ([`sharp_stage_needed`]) or the run was stopped;
/// 4. `stopped_run`: a run stopped by its deadline or interrupt returns its best feasible iterate;
/// 5. `rescore`: the returned controls' rollout with the run's weights and margin, and its
///    safety report ([`check_safety`]: the motion between the steps, the grippers, the colliders);
/// 6. [`row_facts`]: the constraint groups active at the plan, and the most violated row;
/// 7. `plan_warnings` and `verdict`: what the user should know, and whether the task is achieved;
/// 8. `rollout_result`: the result, completed with the solver's counts.
pub fn plan(
    model: &Model,
    scene: &Scene,
    start: &Controls,
    options: &PlanOptions,
    mut progress: impl FnMut(&IterationInfo),
) -> Result<PlanResult> {
    let mut warnings = check_start(model, scene, start, options)?;
    let clock = Instant::now();
    let watch = RefCell::new(Watch::new(
        options.deadline,
        options.stop.clone(),
        options.tol_feasibility,
    ));
    let mut callback = |info: &IterationInfo| {
        progress(info);
        watch.borrow_mut().observe(info)
    };
    let warm = smooth_stage(model, start, options, &mut callback)?;
    let mut problem = TrajectoryProblem::new(model, options.task.clone())
        .with_initial_hessian(warm.hessian)
        .with_stop(options.deadline, options.stop.clone());
    // A stage a line-search trial stopped (at the deadline) did not call back after it.
    watch.borrow_mut().notice();
    let stopped_early = watch.borrow().stopped.is_some();
    let sharp_skipped = warm.settled.is_some() && !stopped_early;
    let mut solution = sharp_stage(
        &mut problem,
        options,
        &warm.x,
        warm.settled,
        stopped_early,
        &mut callback,
    )?;
    watch.borrow_mut().notice();
    let wall_s = clock.elapsed().as_secs_f64();
    let mut stages: Vec<Stage> = warm.stage.into_iter().collect();
    if !sharp_skipped {
        let kappa = options
            .task
            .has_soft_min_rows(model)
            .then_some(options.task.kappa);
        stages.push(stage(kappa, &solution));
    }
    let status = stopped_run(
        &mut problem,
        &mut solution,
        watch.into_inner(),
        warm.iterations,
    )?;
    // The optimizer calls every stop by the watch "interrupted"; a stage the deadline stopped
    // says so.
    for s in stages.iter_mut().filter(|s| s.status == "interrupted") {
        s.status.clone_from(&status);
    }
    let controls = problem.controls(&solution.x);
    let evaluation = rescore(model, &controls, options)?;
    let safety = safety_report(model, options, &evaluation);
    let tol = options.tol_feasibility;
    warnings.extend(physics_hint(model, &safety, &evaluation.metrics, tol));
    let rows = row_facts(&mut problem, &solution)?;
    // A goal stage's plan is judged on the task's rows: one that ends short of its goal row is a
    // plan that misses its targets, safe or not by the rows the task has.
    if let (Some(shortfall), Some(radius)) = (rows.goal_shortfall, options.task.goal_radius) {
        solution.constraint_violation = rows.task_violation;
        if shortfall > tol {
            warnings.push(format!(
                "the goal row (every target within {radius:.4} at the last step) is missed by \
                 {shortfall:.3e}; the plan is judged on the task's other rows"
            ));
        }
    }
    warnings.extend(plan_warnings(
        model,
        options,
        &evaluation.metrics,
        &solution,
        &rows,
    ));
    let task = verdict(
        model,
        options,
        &solution,
        &status,
        &evaluation,
        &safety,
        rows,
    )?;
    Ok(PlanResult {
        status,
        message: solution.message.clone(),
        iterations: warm.iterations + solution.iterations,
        evaluations: warm.simulations + problem.simulations,
        gradient_evaluations: warm.gradients + problem.gradient_evaluations,
        wall_s,
        kkt_residual: solution.kkt_residual,
        constraint_violation: solution.constraint_violation,
        stages,
        warnings,
        solver_status: Some(solution.status),
        hessian: solution.hessian.take(),
        ..rollout_result(model, scene, options, &controls, evaluation, (task, safety))
    })
}

/// Step 0 of a run: the options valid, something to optimize, `start` fitting the model, and the
/// rest state judged against the obstacles ([`judge_start`]). A cloth starting inside an obstacle
/// is an error ([`Error::UnsafeStart`]), or with [`PlanOptions::allow_unsafe_start`] the first
/// warning; the warnings of a start inside a margin follow. Returns the warnings.
fn check_start(
    model: &Model,
    scene: &Scene,
    start: &Controls,
    options: &PlanOptions,
) -> Result<Vec<String>> {
    options.validate()?;
    if model.n_controls() == 0 {
        return Err(Error::NothingToOptimize {
            scene: scene.name.clone(),
        });
    }
    model.check_controls(start)?;
    let (start_error, mut warnings) = judge_start(scene, &model.start, options.task.delta);
    warnings.extend(model.start_report.as_ref().and_then(start_warning));
    warnings.extend(thin_collider_warning(scene, model));
    warnings.extend(buried_target_warnings(scene));
    if let Some(e) = start_error {
        if !options.allow_unsafe_start {
            return Err(Error::UnsafeStart(e));
        }
        warnings.insert(0, e);
    }
    Ok(warnings)
}

/// What the smooth κ stage ([`smooth_stage`]) hands the sharp one.
struct WarmUp {
    /// Where the sharp stage starts: the warm-up's plan, or the start when it did not run.
    x: Vec<f64>,
    /// The warm-up's quasi-Newton Hessian, which starts the sharp stage: only the safety rows'
    /// curvature changes with κ, and rebuilding the rest from the identity took about 30 more
    /// iterations.
    hessian: Option<DenseMatrix>,
    /// The warm-up as the result lists it, when it ran.
    stage: Option<Stage>,
    /// Set when the warm-up leaves the sharp stage nothing to do ([`sharp_stage_needed`]): the
    /// plan's message, saying so.
    settled: Option<String>,
    /// The warm-up's iterations, rollouts and gradient evaluations.
    iterations: usize,
    simulations: usize,
    gradients: usize,
}

/// The κ continuation's first stage: with the SQP and soft-min safety rows
/// ([`TaskOptions::has_soft_min_rows`]), solves at [`PlanOptions::kappa_warmup`] when it is below
/// the task's κ — a smooth, conservative soft minimum, at 10× the KKT tolerance — so that the sharp
/// stage starts from its plan. Otherwise (no safety obstacles, L-BFGS, no warm-up) nothing runs
/// and the sharp stage starts at `start`.
fn smooth_stage(
    model: &Model,
    start: &Controls,
    options: &PlanOptions,
    callback: &mut impl FnMut(&IterationInfo) -> ControlFlow<()>,
) -> Result<WarmUp> {
    let soft_safety = options.task.has_soft_min_rows(model);
    let kappa = match (options.solver, options.kappa_warmup, soft_safety) {
        (Optimizer::Sqp, Some(kappa), true) if kappa < options.task.kappa => kappa,
        _ => {
            return Ok(WarmUp {
                x: start.data().to_vec(),
                hessian: options.initial_hessian.clone(),
                stage: None,
                settled: None,
                iterations: 0,
                simulations: 0,
                gradients: 0,
            })
        }
    };
    let mut task = options.task.clone();
    task.kappa = kappa;
    let mut warm = TrajectoryProblem::new(model, task)
        .with_initial_hessian(options.initial_hessian.clone())
        .with_stop(options.deadline, options.stop.clone());
    let mut settings = sqp_settings(options, 10.0 * options.tol_optimality)?;
    // The sharp stage goes on from the warm-up's end and meets the rows itself: a feasibility
    // correction there would only move its start (measured: Table I's δ = 0.4 from the δ = 0.2
    // plan then ends `no_progress` instead of converging).
    settings.restoration_steps = 0;
    let solution =
        SqpSolver::new(settings)?.solve_with_callback(&mut warm, start.data(), callback)?;
    warm.lift_stop();
    let settled = (!sharp_stage_needed(&mut warm, &solution)?).then(|| {
        format!(
            "{}; the κ = {} stage was not run: no safety row is active at this plan, so it would start where the progress test stopped (its rows are looser there)",
            solution.message, options.task.kappa
        )
    });
    Ok(WarmUp {
        stage: Some(stage(Some(kappa), &solution)),
        x: solution.x,
        hessian: solution.hessian,
        settled,
        iterations: solution.iterations,
        simulations: warm.simulations,
        gradients: warm.gradient_evaluations,
    })
}

/// Whether the sharp κ stage has anything to do after the warm-up ended with `warm`. Not after a
/// warm-up the progress test stopped ([`Status::NoProgress`]) with no safety row active: the
/// stages differ only in their safety rows, the sharp soft minimum is never below the smooth one
/// (so those rows stay inactive), and the objective is the same, so the sharp stage would start
/// where the progress test had just found no progress. Any other ending runs it.
pub fn sharp_stage_needed(
    warm: &mut TrajectoryProblem<'_>,
    solution: &optim::Solution,
) -> Result<bool> {
    Ok(solution.status != Status::NoProgress
        || !row_facts(warm, solution)?.active_safety.is_empty())
}

/// The κ continuation's second stage, or the only one: `problem` (the task's κ) solved from `x0`
/// by the chosen [`Optimizer`]. It does not run when the warm-up `settled` the plan (the result
/// is `x0`, status `no_progress`, with that message and its row violation) or the run was
/// `stopped_early` in the warm-up (its first iteration would cost a gradient and a QP past the
/// deadline; [`stopped_run`] then scores the best iterate).
///
/// # Errors
/// L-BFGS on a problem with inequality rows ([`Error::LbfgsWithConstraints`]); a solver error.
fn sharp_stage(
    problem: &mut TrajectoryProblem<'_>,
    options: &PlanOptions,
    x0: &[f64],
    settled: Option<String>,
    stopped_early: bool,
    callback: &mut impl FnMut(&IterationInfo) -> ControlFlow<()>,
) -> Result<optim::Solution> {
    let solution = match (options.solver, settled) {
        _ if stopped_early => not_run(x0, Status::Interrupted, String::new()),
        (_, Some(message)) => {
            let mut solution = not_run(x0, Status::NoProgress, message);
            solution.constraint_violation = max_violation(problem, x0)?;
            solution
        }
        (Optimizer::Sqp, None) => {
            let settings = sqp_settings(options, options.tol_optimality)?;
            SqpSolver::new(settings)?.solve_with_callback(problem, x0, callback)?
        }
        (Optimizer::Lbfgs, None) => {
            if problem.num_inequalities() > 0 {
                return Err(Error::LbfgsWithConstraints {
                    rows: problem.num_inequalities(),
                });
            }
            let settings = LbfgsSettings::builder()
                .max_iterations(options.iterations)
                .build()?;
            LbfgsSolver::new(settings)?.solve_with_callback(problem, x0, callback)?
        }
    };
    problem.lift_stop();
    Ok(solution)
}

/// A stage as the result lists it: its κ (`None` without soft-min rows), iterations and status.
fn stage(kappa: Option<f64>, solution: &optim::Solution) -> Stage {
    Stage {
        kappa,
        iterations: solution.iterations,
        status: solution.status.name().to_string(),
    }
}

/// The status name of the run whose last stage ended with `solution`. A run the `watch` stopped
/// (deadline, interrupt) returns its best feasible iterate (the last one when none was
/// feasible): `solution` takes that point, its row violation, no KKT residual or multipliers,
/// and a message saying so (counting `earlier_iterations` of the warm-up); the status is
/// `time_limit` or `interrupted`. A run that ended unconverged on an infeasible point returns
/// its best feasible iterate too ([`Watch::take_fallback`]), keeping its status.
fn stopped_run(
    problem: &mut TrajectoryProblem<'_>,
    solution: &mut optim::Solution,
    mut watch: Watch,
    earlier_iterations: usize,
) -> Result<String> {
    let Some(reason) = watch.stopped else {
        let (converged, violation) = (
            solution.status.is_converged(),
            solution.constraint_violation,
        );
        if let Some(best) = watch.take_fallback(converged, violation) {
            settle_at(problem, solution, Some(best.x))?;
            solution.message = format!(
                "{}; its last iterate violates the rows by {violation:.2e}, so the best feasible \
                 iterate seen is returned",
                solution.message
            );
        }
        return Ok(solution.status.name().to_string());
    };
    let found = settle_at(problem, solution, watch.best.take().map(|b| b.x))?;
    solution.message = format!(
        "{} after {} iterations; {}",
        match reason {
            StopReason::TimeLimit => "time limit reached",
            StopReason::Interrupted => "interrupted",
        },
        earlier_iterations + solution.iterations,
        if found {
            "returning the best feasible iterate seen"
        } else {
            "no feasible iterate was seen, returning the last one"
        }
    );
    Ok(reason.status().to_string())
}

/// Makes `solution` the run's answer at `x` (its own point when `None`): that point's row
/// violation, and no KKT residual or multipliers (the solver did not end there). Whether `x`
/// was given.
fn settle_at(
    problem: &mut TrajectoryProblem<'_>,
    solution: &mut optim::Solution,
    x: Option<Vec<f64>>,
) -> Result<bool> {
    let given = x.map(|x| solution.x = x).is_some();
    solution.constraint_violation = max_violation(problem, &solution.x)?;
    solution.kkt_residual = f64::NAN;
    solution.multipliers = Default::default();
    Ok(given)
}

/// What the user should know about the returned plan that its status does not say: under the
/// step-only check, the cloth dipping inside `δ` between steps while the steps keep it (the
/// continuous check makes that a failure instead), and the optimizer's rows violated beyond the
/// feasibility tolerance (naming the most violated row of `rows`).
fn plan_warnings(
    model: &Model,
    options: &PlanOptions,
    m: &Metrics,
    solution: &optim::Solution,
    rows: &RowFacts,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let dip = options.task.delta - m.min_sdf_swept;
    if model.safety.is_some()
        && !options.task.swept
        && dip > SAFETY_TOLERANCE
        && m.min_sdf >= options.task.delta - SAFETY_TOLERANCE
    {
        warnings.push(format!(
            "between steps the cloth comes to {:.4} of the safety obstacles, {dip:.4} inside δ = {}: the safety rows hold at the steps, not on the straight motion between them{}",
            m.min_sdf_swept,
            options.task.delta,
            " (the continuous check, the default, constrains it; this plan was made with --step-only)"
        ));
    }
    if solution.constraint_violation > options.tol_feasibility
        && solution.constraint_violation.is_finite()
    {
        let worst = match &rows.worst_violation {
            Some((label, by)) => format!(" (most: {label}, by {by:.3e})"),
            None => String::new(),
        };
        warnings.push(format!(
            "the returned plan violates the optimizer's rows by {:.3e}{worst}, above the feasibility tolerance {:.1e} (--feasibility-tol)",
            solution.constraint_violation, options.tol_feasibility
        ));
    }
    warnings
}

/// The task verdict of the returned plan ([`task_outcome`]): safe when the solver did not declare
/// it infeasible, its rows hold within the feasibility tolerance, its re-scored rollout
/// `evaluation` is [safe](is_safe) and passes the checks of `safety`; with the run's `status`
/// and the active groups of `rows`.
fn verdict(
    model: &Model,
    options: &PlanOptions,
    solution: &optim::Solution,
    status: &str,
    evaluation: &Evaluation,
    safety: &SafetyReport,
    rows: RowFacts,
) -> Result<TaskOutcome> {
    let safe = !matches!(solution.status, Status::Infeasible { .. })
        && solution.constraint_violation <= options.tol_feasibility
        && is_safe(&evaluation.metrics)
        && safety.failures.is_empty();
    let final_state = evaluation.states.last().ok_or(Error::EmptyRollout)?;
    Ok(task_outcome(
        model,
        final_state,
        &PlanFacts {
            safe,
            status,
            active_safety: rows.active_safety,
            active_other: rows.active_other,
            failures: safety.failures.clone(),
        },
    ))
}

/// The safety report ([`check_safety`]) of the re-scored rollout `evaluation` under the run's
/// options.
fn safety_report(model: &Model, options: &PlanOptions, evaluation: &Evaluation) -> SafetyReport {
    check_safety(
        model,
        &evaluation.states,
        &evaluation.metrics,
        &options.task,
        options.tol_feasibility,
    )
}

/// A stage that did not run: `x` with `status`, no iterations, no multipliers.
fn not_run(x: &[f64], status: Status, message: String) -> optim::Solution {
    optim::Solution {
        status,
        message,
        x: x.to_vec(),
        objective: f64::NAN,
        constraint_violation: f64::NAN,
        kkt_residual: f64::NAN,
        iterations: 0,
        function_evaluations: 0,
        gradient_evaluations: 0,
        multipliers: Default::default(),
        solve_time: 0.0,
        hessian: None,
    }
}

/// The largest violation of `problem`'s rows at `x` (0 when they all hold).
fn max_violation(problem: &mut TrajectoryProblem<'_>, x: &[f64]) -> Result<f64> {
    let mut c = vec![0.0; problem.num_inequalities()];
    problem
        .inequalities(x, &mut c)
        .map_err(|source| Error::Evaluation {
            what: "re-evaluating the returned plan",
            source,
        })?;
    Ok(c.iter().fold(0.0, |v: f64, &ci| v.max(-ci)))
}

/// The rollout of `controls` with the run's weights and margin (not the scene's): what a result
/// reports.
fn rescore(model: &Model, controls: &Controls, options: &PlanOptions) -> Result<Evaluation> {
    let mut scored = model.clone();
    scored.task.alpha = options.task.alpha;
    scored.task.beta = options.task.beta;
    Ok(scored.evaluate(controls, options.task.delta, false)?)
}

/// The result of `controls`, whose re-scored rollout is `evaluation`, with the verdict `task` and
/// its safety report: the scene, margin, metrics, strain, arrays and grid. The solver's fields are left as for a run that
/// did nothing (no status, message or stages, counts 0, NaN residual, violation and time) for
/// [`plan`] and [`snapshot`] to fill in.
fn rollout_result(
    model: &Model,
    scene: &Scene,
    options: &PlanOptions,
    controls: &Controls,
    evaluation: Evaluation,
    (task, safety): (TaskOutcome, SafetyReport),
) -> PlanResult {
    PlanResult {
        scene: scene.name.clone(),
        delta: options.task.delta,
        status: String::new(),
        message: String::new(),
        iterations: 0,
        evaluations: 0,
        gradient_evaluations: 0,
        wall_s: f64::NAN,
        kkt_residual: f64::NAN,
        constraint_violation: f64::NAN,
        strain: strain_report(model, &evaluation.states),
        gripper_positions: gripper_positions(model, &evaluation.states),
        states: Some(evaluation.states.iter().map(state_points).collect()),
        physics: Some(PhysicsReport::of(
            scene,
            model,
            &evaluation.states,
            controls,
        )),
        measures: evaluation.states.last().map(|x| Measures::of(model, x)),
        metrics: evaluation.metrics,
        task,
        safety,
        stages: Vec::new(),
        feasibility_tolerance: options.tol_feasibility,
        warnings: Vec::new(),
        search: None,
        check: None,
        grid: [scene.cloth.rows, scene.cloth.cols],
        triangles: mesh_triangles(scene, model),
        control_particles: model.controls.as_slice().to_vec(),
        controls: controls_to_nested(controls),
        solver_status: None,
        hessian: None,
    }
}

/// The result of controls `x` (flattened `T × 3K`) of a run still under way: status `running`,
/// the metrics and task verdict of their rollout, `iterations` so far. The CLI writes it as the
/// best-so-far file; `violation` is the optimizer's row violation at `x`.
pub fn snapshot(
    model: &Model,
    scene: &Scene,
    x: &[f64],
    violation: f64,
    iterations: usize,
    options: &PlanOptions,
) -> Result<PlanResult> {
    let controls = Tensor::new(model.task.horizon, 3 * model.n_controls(), x.to_vec());
    let evaluation = rescore(model, &controls, options)?;
    let safety = safety_report(model, options, &evaluation);
    let safe = violation <= options.tol_feasibility
        && is_safe(&evaluation.metrics)
        && safety.failures.is_empty();
    let final_state = evaluation.states.last().ok_or(Error::EmptyRollout)?;
    let facts = PlanFacts {
        safe,
        status: "running",
        active_safety: Vec::new(),
        active_other: Vec::new(),
        failures: safety.failures.clone(),
    };
    let task = task_outcome(model, final_state, &facts);
    Ok(PlanResult {
        status: "running".into(),
        message: format!("best feasible iterate after {iterations} iterations; the run goes on"),
        iterations,
        constraint_violation: violation,
        ..rollout_result(model, scene, options, &controls, evaluation, (task, safety))
    })
}

/// The SQP settings of a planning run, with KKT tolerance `tol`.
fn sqp_settings(options: &PlanOptions, tol: f64) -> Result<SqpSettings> {
    Ok(SqpSettings::builder()
        .max_iterations(options.iterations)
        .step_bound_scale(options.step_bound)
        .tol_optimality(tol)
        .tol_feasibility(options.tol_feasibility)
        .jacobian_reuse_margin(options.reuse_band.is_finite().then_some(options.reuse_band))
        .progress_window(options.progress_window)
        .tol_progress(options.tol_progress)
        .build()?)
}
