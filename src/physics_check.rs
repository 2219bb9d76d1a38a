//! A plan checked under other physics, and the margin that makes it pass.
//!
//! A plan is safe under the physics it was planned with; XPBD at the scene's iterations, XPBD at
//! many more and Newton's minimizer of `Φ` are different models of the same cloth (their states
//! differ by centimetres on a stretched cloth), so a plan whose safety rows are active can sit
//! inside the margin under another one. [`check_plan`] re-simulates a plan's controls with another
//! step solver and measures it at the user's margin `δ`; [`plan_with_check`] re-plans, from the
//! last plan, with the planning margin raised by the shortfall the check measured
//! ([`MARGIN_GROWTH`] times it) until the check passes or the rounds run out.

use crate::result::{controls_from_nested, is_safe, PlanResult};
// The `check` section of a result, from `crate::result`: re-exported for this module's callers.
pub use crate::result::{CheckPhysics, CheckRound, PhysicsCheck};
use crate::{outcome, Error, Result};
use cloth::{Controls, Model, Scene};

/// How much more than the measured shortfall a round adds to the planning margin: the gap
/// between two physics changes with the plan, so adding exactly the shortfall tends to miss by a
/// little again.
pub const MARGIN_GROWTH: f64 = 1.25;

/// `scene` as `physics` models it.
///
/// # Errors
/// The physics cannot model the scene (e.g. friction under Newton).
fn check_model(scene: &Scene, physics: CheckPhysics) -> Result<Model> {
    Model::from_scene(&physics.apply(scene)).map_err(|source| Error::Check {
        physics: physics.to_string(),
        source,
    })
}

/// Re-simulates `controls` with `model` (a scene under `physics`, [`check_model`]) and measures
/// them at margin `delta`.
fn measure(
    model: &Model,
    physics: CheckPhysics,
    controls: &Controls,
    delta: f64,
    planned_delta: f64,
) -> Result<CheckRound> {
    let ev = model
        .evaluate(controls, delta, false)
        .map_err(|source| Error::Check {
            physics: physics.to_string(),
            source,
        })?;
    let last = ev.states.last().expect("a rollout has its rest state");
    let errors = outcome::target_errors(model, last);
    Ok(CheckRound {
        planned_delta,
        min_sdf: ev.metrics.min_sdf,
        c: ev.metrics.c,
        safe: is_safe(&ev.metrics),
        max_target_error: errors.iter().copied().fold(0.0, f64::max),
    })
}

/// Re-simulates `controls` of `scene` under `physics` and measures them at margin `delta`
/// (`planned_delta`: the margin they were planned with, recorded in the round).
///
/// # Errors
/// The checked physics cannot model the scene (e.g. friction under Newton), or its rollout fails.
pub fn check_plan(
    scene: &Scene,
    physics: CheckPhysics,
    controls: &Controls,
    delta: f64,
    planned_delta: f64,
) -> Result<CheckRound> {
    measure(
        &check_model(scene, physics)?,
        physics,
        controls,
        delta,
        planned_delta,
    )
}

/// A check asked of a planning run: the physics, and the most re-plans after a failed check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckRequest {
    /// The physics the plan is checked under.
    pub physics: CheckPhysics,
    /// Most re-plans with a raised margin (0: only report).
    pub rounds: usize,
}

/// Plans with `replan(δ′, start)` at the user's margin `delta` from `start`; without a `check`,
/// that plan is the result. With one, until the plan passes the check at `delta`, at most
/// `1 + rounds` plans: each further one from the previous plan with `δ′` raised by
/// [`MARGIN_GROWTH`] times the shortfall `δ − min SDF` the check measured. Returns the last plan
/// with its [`PhysicsCheck`]; a plan that still fails the check is returned with its verdict
/// turned to "no safe plan", saying so.
///
/// # Errors
/// A plan or a check fails (see [`check_plan`]).
pub fn plan_with_check(
    model: &Model,
    scene: &Scene,
    check: Option<CheckRequest>,
    delta: f64,
    start: &Controls,
    mut replan: impl FnMut(f64, &Controls) -> Result<PlanResult>,
) -> Result<PlanResult> {
    let mut result = replan(delta, start)?;
    let Some(CheckRequest { physics, rounds }) = check else {
        return Ok(result);
    };
    let checker = check_model(scene, physics)?;
    let mut planned_delta = delta;
    let mut checks = Vec::new();
    loop {
        let controls = controls_from_nested(model, &result.controls)?;
        let round = measure(&checker, physics, &controls, delta, planned_delta)?;
        let passed = round.safe;
        // Not safe means `C < 0`: some distance, so the smallest, is below δ.
        let shortfall = delta - round.min_sdf;
        checks.push(round);
        // A plan that is not safe under its own physics is not made safer by a larger margin
        // of the same kind; the planner's verdict already says why.
        if passed || checks.len() > rounds || !result.is_safe() {
            break;
        }
        planned_delta += MARGIN_GROWTH * shortfall;
        result = replan(planned_delta, &controls)?;
    }
    let check = PhysicsCheck {
        physics,
        delta,
        rounds: checks,
    };
    let last = check.last().clone();
    if !last.safe {
        let plans = check.rounds.len();
        let mut why = format!(
            "under {physics} the cloth comes to {:.4} of the safety obstacles, inside δ = {delta} \
             (C = {:.3e}), after {plans} plan{}",
            last.min_sdf,
            last.c,
            if plans == 1 { "" } else { "s" }
        );
        if !result.task.achieved {
            why = format!("{why}; under its own physics: {}", result.task.explanation);
        }
        result.task.achieved = false;
        result.task.reason = outcome::Reason::NoSafePlan;
        result.task.explanation = why;
    }
    result.check = Some(check);
    Ok(result)
}
