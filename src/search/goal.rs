//! The goal stage of the route search (module docs of `search`, step 2): a safe plan that misses
//! its targets planned again with them as a constraint, and a result just outside the task's rows
//! planned on without that constraint.

use super::{
    is_safe, out_of_time, plan_on, polish_rank, tally, time_share, Progress, Tally,
    NEAR_SAFE_FRACTION,
};
use crate::plan::{plan, PlanOptions};
use crate::result::controls_from_nested;
use cloth::{Model, Scene};
use std::cmp::Ordering;

/// Radius of the goal stage's goal row, as a fraction of the task tolerance.
const GOAL_FRACTION: f64 = 0.98;

/// The goal stage: when the best plan so far is safe but misses its targets, plan again from it
/// with the targets as a constraint ([`crate::problem::TaskOptions::goal_radius`] at
/// [`GOAL_FRACTION`] of the tolerance) instead of only a cost (from that plan's quasi-Newton
/// Hessian when it misses by at most `warm_within` tolerances,
/// [`goal_hessian`](super::SearchOptions::goal_hessian)), and keep the result if it ranks above.
/// Where the targets cannot be reached safely the stage ends infeasible and is not kept; a
/// result just outside the task's rows that ranks above by promise
/// ([`polish_rank`](super::polish_rank)) is planned on without the goal row (stage `restored`).
/// Under `shared`, each stage takes [`TIME_SHARE`](super::TIME_SHARE) of the time left.
pub(super) fn goal_stage(
    model: &Model,
    scene: &Scene,
    (options, shared, warm_within): (&PlanOptions, bool, Option<f64>),
    route: &str,
    progress: &mut impl FnMut(Progress<'_>),
    (best, best_report, reports): Tally<'_>,
) -> crate::Result<()> {
    if !is_safe(best) || best.task.achieved || model.task.targets.rows() == 0 {
        return Ok(());
    }
    let share = |o: &PlanOptions| if shared { time_share(o) } else { o.clone() };
    let mut goal = share(options);
    goal.task.goal_radius = Some(GOAL_FRACTION * model.task.tolerance);
    goal.kappa_warmup = None;
    // The goal row aside, the problem is the one the best plan solved: the curvature model its
    // last stage converged with carries over, for a local correction, with at most the
    // iterations that plan took (a correction that costs more than the plan is not paying off).
    let full_budget = goal.iterations;
    let converged = best.stages.last().is_some_and(|s| s.status == "converged");
    let narrow =
        warm_within.is_some_and(|k| best.task.max_target_error <= k * model.task.tolerance);
    if let (true, true, Some(b)) = (converged, narrow, &best.hessian) {
        goal.initial_hessian = Some(b.clone());
        goal.iterations = full_budget.min(best.iterations.max(1));
    }
    let start = controls_from_nested(model, &best.controls)?;
    let mut run = |stage: &'static str, goal: &PlanOptions| {
        progress(Progress::Stage { stage, route });
        plan(model, scene, &start, goal, |i| {
            progress(Progress::Iteration(i))
        })
    };
    let mut stage = "goal";
    let mut result = run(stage, &goal)?;
    // A warm start held to a shorter budget that ends short of a safe, achieved plan, or at that
    // budget, is retried from the identity with the full budget. One that had the full budget
    // was the goal stage.
    let retry = goal.initial_hessian.is_some()
        && goal.iterations < full_budget
        && (!(result.task.achieved && is_safe(&result)) || result.status == "iteration_limit")
        && !matches!(result.status.as_str(), "interrupted" | "time_limit");
    if retry {
        tally(route, stage, result, (best, best_report, reports));
        goal.initial_hessian = None;
        goal.iterations = full_budget;
        stage = "goal_identity";
        result = run(stage, &goal)?;
    }
    // A goal stage that ends just outside the task's rows (its own row aside) but closer to the
    // targets than the best plan is planned on without the goal row: the task's rows restored,
    // as a cheap result is polished. (Unsafe, it cannot become the best plan when tallied.)
    let slack = NEAR_SAFE_FRACTION * model.task.tolerance;
    let restore = !is_safe(&result)
        && !out_of_time(options)
        && result.status != "interrupted"
        && polish_rank(&result, best, options.task.delta, slack) == Ordering::Less;
    let from = if restore {
        Some((
            controls_from_nested(model, &result.controls)?,
            result.hessian.take(),
        ))
    } else {
        None
    };
    tally(route, stage, result, (best, best_report, reports));
    if let Some(from) = from {
        plan_on(
            (model, scene, &share(options)),
            from,
            (route, "restored"),
            progress,
            (best, best_report, reports),
        )?;
    }
    Ok(())
}
