//! Route search: when the plan from the initial guess does not achieve the task, plan from other
//! routes and keep the best.
//!
//! 1. Plan from the given start ([`crate::plan::plan`]), or from a carry route
//!    ([`routes::carried`]: the grippers lifted on half circles, along the guess or the straight
//!    path, where the start's rollout rests the cloth on a collider; the lay route of a
//!    hanging cloth to be laid flat, `lay/`; and the drape route of a cloth to be hung over a
//!    collider, `drape.rs`) when its rollout is safer or, as safe, has the
//!    lower `L`: a few rollouts decide it (up to eight more to build the lay route), and the
//!    guess becomes a candidate route. With
//!    [`SearchMode::Auto`] an achieved task ends the search here: no extra work. Under a deadline this plan gets half the time,
//!    and the goal stage after it half of the rest, so that a guess the planner stalls on
//!    leaves the other routes time.
//! 2. *Goal stage:* a safe plan that misses its targets is planned again from where it ended with
//!    the targets as a constraint ([`crate::problem::TaskOptions::goal_radius`]) rather than
//!    only a cost: a plan that misses because `αT + βE` outweighs the last centimetres of `G`
//!    reaches them here, on the same route, from that plan's quasi-Newton Hessian
//!    ([`SearchOptions::goal_hessian`]; from the identity again if that falls short). Its plan is
//!    judged on the task's rows, the goal row aside (one that ends short of the goal row misses
//!    its targets). One that ends just outside the task's rows (near safe, as in step 5) and
//!    closer to the targets than the best plan is planned on without the goal row (stage
//!    `restored`), as a cheap result is polished. With `Auto`, success ends the search.
//! 3. Propose candidate routes from the scene's geometry ([`routes::propose`]).
//! 4. *Cheap stage:* optimize every candidate at the warm-up sharpness `κ` (smooth, conservative
//!    safety rows) with a small iteration budget, in parallel (rayon; results in candidate order,
//!    so the outcome is the same for any thread count).
//! 5. *Polish:* the best few cheap results, ranked by promise — (near safe, every target within
//!    tolerance, `L`), where near safe allows a tenth of the tolerance of violation, since a cheap
//!    stage often stops just short of feasibility — are planned in full from where they stopped
//!    (and from their quasi-Newton Hessian: the full plan's first stage goes on with the cheap
//!    stage's problem), each only while its cheap result ranks above the best plan so far by the
//!    same ranking (the first plan included), so a search that finds nothing better costs one
//!    cheap stage.
//!    A polished plan that becomes the best gets its own goal stage.
//!    Under a deadline, where the cheap stage could not finish in the time left (its candidates
//!    at the best plan's wall time per iteration), the best plan, if only its share of the time
//!    stopped it, is planned on from where it stopped instead (stage `continued`): a search that
//!    cannot finish keeps no candidate better than its first few iterations.
//! 6. Keep the best of every stage by the same ranking.
//!
//! The search lives in the root package: `optim` stays problem-agnostic.

mod carry;
mod drape;
mod goal;
mod lay;
mod limits;
mod obstacles;
pub mod routes;

use crate::plan::{plan, PlanOptions};
use crate::result::{controls_from_nested, PlanResult};
use goal::goal_stage;
// The `search` section of a result, from `crate::result`: re-exported for this module's callers.
pub use crate::result::{CandidateReport, SearchMode, SearchReport};
use cloth::{Controls, Model, Scene};
use optim::IterationInfo;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::time::Instant;

/// What [`plan_with_search`] reports while it runs.
#[derive(Clone, Copy, Debug)]
pub enum Progress<'a> {
    /// A stage after the first plan begins.
    Stage {
        /// `"goal"`, `"restored"`, `"cheap"`, `"polished"` or `"continued"`, as in
        /// [`CandidateReport::stage`].
        stage: &'a str,
        /// The route it starts from; for the cheap stage, which runs every candidate in
        /// parallel and reports no iterations, how many candidates.
        route: &'a str,
    },
    /// One iteration of the sequential stage under way.
    Iteration(&'a IterationInfo),
}

/// Settings of the route search.
#[derive(Clone, Debug)]
pub struct SearchOptions {
    /// When to search. Default [`SearchMode::Auto`].
    pub mode: SearchMode,
    /// Seeded random perturbations among the candidates. Default 2.
    pub random_starts: usize,
    /// Most candidates (geometric routes first, then the random ones). Default 6.
    pub max_candidates: usize,
    /// Iteration budget of each candidate's cheap stage. Default 30.
    pub cheap_iterations: usize,
    /// How many of the best cheap results are planned in full. Default 2.
    pub polish: usize,
    /// Seed of the random perturbations. Default 0.
    pub seed: u64,
    /// Start a goal stage from the best plan's quasi-Newton Hessian ([`PlanResult::hessian`])
    /// instead of the identity when that plan's last stage converged and it misses its targets
    /// narrowly (largest error at most [`SearchOptions::near_miss`] tolerances), for at most the
    /// iterations that plan took (a correction should not cost more than the plan it corrects),
    /// and plan the stage again from the identity when that ends short of a safe, achieved plan.
    /// Default true: u_obstacle's goal stage takes 13 iterations instead of 90, to the same plan
    /// (`docs/performance.md`).
    pub goal_hessian: bool,
    /// The largest target error, in tolerances, that counts as a near miss for
    /// [`SearchOptions::goal_hessian`] (> 0; ∞: every miss). Default [`DEFAULT_NEAR_MISS`].
    pub near_miss: f64,
}

/// A goal stage corrects a *near miss* from the plan's quasi-Newton Hessian when the plan's
/// largest target error is at most this many tolerances: its targets then move by about one
/// tolerance, within the region the plan's curvature model was learnt in; farther misses start
/// from the identity. Measured (`docs/performance.md`): u_obstacle's first plan misses by 1.1
/// tolerances and the warm stage takes 13 iterations instead of 90; misses of 3.5 to 26
/// tolerances (five route scenes) cost the warm start 0–120 more iterations than the identity
/// on four of them, and save 100 on one (`long_soft`, 3.8).
pub const DEFAULT_NEAR_MISS: f64 = 2.0;

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            mode: SearchMode::Auto,
            random_starts: 2,
            max_candidates: 6,
            cheap_iterations: 30,
            polish: 2,
            seed: 0,
            goal_hessian: true,
            near_miss: DEFAULT_NEAR_MISS,
        }
    }
}

impl SearchOptions {
    /// Checks the counts and the near-miss bound, naming the first bad one.
    pub fn validate(&self) -> crate::Result<()> {
        crate::validate::ensure_iterations("cheap_iterations", self.cheap_iterations)?;
        crate::validate::ensure_iterations("max_candidates", self.max_candidates)?;
        crate::validate::ensure_iterations("polish", self.polish)?;
        crate::validate::ensure_positive_or_infinite("near_miss", self.near_miss)
    }

    /// The near-miss bound in tolerances when goal stages may start warm, else `None`.
    fn warm_goal_within(&self) -> Option<f64> {
        self.goal_hessian.then_some(self.near_miss)
    }
}

/// The report of a plan `r` of `route` made by `stage`, not (yet) kept.
fn candidate_report(route: &str, stage: &str, r: &PlanResult) -> CandidateReport {
    CandidateReport {
        route: route.to_string(),
        stage: stage.to_string(),
        status: r.status.clone(),
        safe: is_safe(r),
        achieved: r.task.achieved,
        l: r.metrics.l,
        g: r.metrics.g,
        min_sdf: r.metrics.min_sdf,
        simulations: r.evaluations,
        iterations: r.iterations,
        gradient_evaluations: r.gradient_evaluations,
        wall_s: r.wall_s,
        kept: false,
        error: None,
    }
}

/// The report of a candidate of `route` whose `stage` failed with `error` (its start could not
/// be simulated, say): never kept, `L` and `G` infinite.
fn failed_report(route: &str, stage: &str, error: &crate::Error) -> CandidateReport {
    CandidateReport {
        route: route.to_string(),
        stage: stage.to_string(),
        status: "failed".into(),
        safe: false,
        achieved: false,
        l: f64::INFINITY,
        g: f64::INFINITY,
        min_sdf: f64::INFINITY,
        simulations: 0,
        iterations: 0,
        gradient_evaluations: 0,
        wall_s: f64::NAN,
        kept: false,
        error: Some(error.to_string()),
    }
}

/// Safe to execute: feasible for the optimizer's rows, and its rollout safe at its margin.
fn is_safe(r: &PlanResult) -> bool {
    r.is_feasible() && r.is_safe()
}

/// The ranking of plans: safe before unsafe, achieved before not, then lower `L` (NaN last).
pub fn rank(a: &PlanResult, b: &PlanResult) -> Ordering {
    is_safe(b)
        .cmp(&is_safe(a))
        .then(b.task.achieved.cmp(&a.task.achieved))
        .then(a.metrics.l.total_cmp(&b.metrics.l))
}

/// How far from safe (length units, as a fraction of the task tolerance) a cheap result may be and
/// still be worth polishing: the cheap stage stops after a few iterations, often just short of
/// feasibility, and the full plan restores it.
const NEAR_SAFE_FRACTION: f64 = 0.1;

/// Within `slack` of safe: the optimizer's rows violated by at most `slack`, and no particle
/// more than `slack` inside the margin `delta` (NaN is never near safe).
fn near_safe(r: &PlanResult, delta: f64, slack: f64) -> bool {
    r.constraint_violation <= slack && r.metrics.min_sdf >= delta - slack
}

/// The ranking that picks cheap results to polish: near safe before not (`near_safe` in
/// `src/search/mod.rs`), every target within tolerance before not (the verdict's `achieved` also
/// asks for strict safety), then lower `L` (NaN last).
pub fn polish_rank(a: &PlanResult, b: &PlanResult, delta: f64, slack: f64) -> Ordering {
    let reached = |r: &PlanResult| r.task.targets_reached == r.task.target_errors.len();
    near_safe(b, delta, slack)
        .cmp(&near_safe(a, delta, slack))
        .then(reached(b).cmp(&reached(a)))
        .then(a.metrics.l.total_cmp(&b.metrics.l))
}

/// The best plan so far, the index of its report, and every report.
type Tally<'r> = (
    &'r mut PlanResult,
    &'r mut usize,
    &'r mut Vec<CandidateReport>,
);

/// Under a deadline ([`PlanOptions::deadline`]), the share of the time left that the first plan,
/// and then its goal stage, may take when a search may follow: a first plan that stalls on its
/// guess leaves the other routes the rest (a stage stopped by its share is still a candidate,
/// status `time_limit`).
const TIME_SHARE: f64 = 0.5;

/// The first plan's start (its route's name, its controls, and the rollouts simulated to choose
/// it): the initial guess `start`, or a carry route ([`routes::carried`]: the guess's or the
/// straight path's, when the guess's rollout rests the cloth on a collider; the lay route, where
/// the task has one) whose rollout ranks before the guess's by (safe at `δ`, `L`). A guess that
/// drags the cloth across a table or itself is a poor start that the gradient cannot repair;
/// lifting it is one rollout away.
fn first_start(
    model: &Model,
    start: &Controls,
    options: &PlanOptions,
) -> (String, Controls, usize) {
    let guess = || ("initial guess".to_string(), start.clone());
    let delta = options.task.delta;
    let score = |states: &[autodiff::Tensor], u: &Controls| {
        let m = model.metrics(states, u, delta);
        let clear = if options.task.swept {
            m.min_sdf.min(m.min_sdf_swept)
        } else {
            m.min_sdf
        };
        (clear < delta, m.l)
    };
    if model.colliders.is_empty() {
        let (route, u) = guess();
        return (route, u, 0);
    }
    let Ok(states) = model.simulate(start) else {
        let (route, u) = guess();
        return (route, u, 1);
    };
    let (carried, building) = routes::carried(model, start, &states);
    let rollouts = 1 + building + carried.len();
    let mut best = (score(&states, start), None);
    for carry in carried {
        if let Ok(carry_states) = model.simulate(&carry.controls) {
            let (a, b) = (score(&carry_states, &carry.controls), best.0);
            // Safe before unsafe, then the lower L.
            if a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)) == Ordering::Less {
                best = (a, Some(carry));
            }
        }
    }
    match best.1 {
        Some(carry) => (carry.route, carry.controls, rollouts),
        None => {
            let (route, u) = guess();
            (route, u, rollouts)
        }
    }
}

/// `options` with its deadline, if any, moved to [`TIME_SHARE`] of the time left: the deadline
/// of a stage that other stages may follow.
fn time_share(options: &PlanOptions) -> PlanOptions {
    let now = Instant::now();
    PlanOptions {
        deadline: options
            .deadline
            .map(|d| now + d.saturating_duration_since(now).mul_f64(TIME_SHARE)),
        ..options.clone()
    }
}

/// Whether `options`' deadline, if any, has passed.
fn out_of_time(options: &PlanOptions) -> bool {
    options.deadline.is_some_and(|d| Instant::now() >= d)
}

/// Keeps `result` (reported as `route`, `stage`) when it ranks above the best plan so far.
fn tally(route: &str, stage: &str, result: PlanResult, (best, best_report, reports): Tally<'_>) {
    reports.push(candidate_report(route, stage, &result));
    if rank(&result, best) == Ordering::Less {
        *best = result;
        *best_report = reports.len() - 1;
    }
}

/// The cheap stage over every candidate, then the polish of the best few (module docs, steps
/// 3–4). Returns the route of the polished plan that became the best, if one did.
fn route_stages(
    model: &Model,
    scene: &Scene,
    options: &PlanOptions,
    search: &SearchOptions,
    candidates: &[routes::Candidate],
    progress: &mut impl FnMut(Progress<'_>),
    (best, best_report, reports): Tally<'_>,
) -> crate::Result<Option<String>> {
    // Cheap stage: warm-up sharpness only, a small budget, looser tolerance.
    let mut cheap_options = options.clone();
    cheap_options.iterations = search.cheap_iterations;
    if let Some(kappa) = options.kappa_warmup {
        cheap_options.task.kappa = kappa.min(options.task.kappa);
    }
    cheap_options.kappa_warmup = None;
    cheap_options.tol_optimality = 10.0 * options.tol_optimality;
    if !candidates.is_empty() {
        let count = format!("{} candidates", candidates.len());
        progress(Progress::Stage {
            stage: "cheap",
            route: &count,
        });
    }
    // A candidate that cannot be planned (its rollout fails, e.g. a route that folds the cloth
    // through itself under self-contact) is reported and left out; the search goes on.
    let planned: Vec<crate::Result<PlanResult>> = candidates
        .par_iter()
        .map(|c| plan(model, scene, &c.controls, &cheap_options, |_| {}))
        .collect();
    let mut cheap: Vec<(usize, PlanResult)> = Vec::new();
    for (i, (c, r)) in candidates.iter().zip(planned).enumerate() {
        match r {
            Ok(r) => {
                reports.push(candidate_report(&c.route, "cheap", &r));
                cheap.push((i, r));
            }
            Err(e) => reports.push(failed_report(&c.route, "cheap", &e)),
        }
    }
    let (delta, slack) = (
        options.task.delta,
        NEAR_SAFE_FRACTION * model.task.tolerance,
    );
    let by_promise = |a: &PlanResult, b: &PlanResult| polish_rank(a, b, delta, slack);
    cheap.sort_by(|(a, ra), (b, rb)| by_promise(ra, rb).then(a.cmp(b)));
    let mut kept = None;
    for &(i, ref cheap_result) in cheap.iter().take(search.polish) {
        // Only candidates whose cheap result already ranks above the best plan so far (by
        // promise: near safe counts as safe) are worth a full plan (the order is best first, so
        // the rest rank lower too).
        if by_promise(cheap_result, best) != Ordering::Less {
            break;
        }
        // The polish's first stage goes on with the cheap stage's problem (the warm-up κ), so
        // it goes on with its curvature model too.
        let from = (
            controls_from_nested(model, &cheap_result.controls)?,
            cheap_result.hessian.clone(),
        );
        let before = *best_report;
        plan_on(
            (model, scene, options),
            from,
            (&candidates[i].route, "polished"),
            progress,
            (&mut *best, &mut *best_report, &mut *reports),
        )?;
        if *best_report != before {
            kept = Some(candidates[i].route.clone());
        }
    }
    Ok(kept)
}

/// Whether the cheap stage over `candidates` routes would finish before `deadline`, at `best`'s
/// wall time per iteration (its whole wall where it took none): [`cheap_stage_seconds`].
fn cheap_stage_fits(
    best: &PlanResult,
    search: &SearchOptions,
    candidates: usize,
    deadline: Instant,
) -> bool {
    let per_iteration = best.wall_s / best.iterations.max(1) as f64;
    let needed = cheap_stage_seconds(
        per_iteration,
        search.cheap_iterations,
        candidates,
        rayon::current_num_threads(),
    );
    needed
        <= deadline
            .saturating_duration_since(Instant::now())
            .as_secs_f64()
}

/// The wall time of a cheap stage: `candidates` plans of `iterations` at `per_iteration`
/// seconds each, `threads` at once.
fn cheap_stage_seconds(
    per_iteration: f64,
    iterations: usize,
    candidates: usize,
    threads: usize,
) -> f64 {
    let rounds = candidates.div_ceil(threads.max(1));
    per_iteration * (iterations * rounds) as f64
}

/// Plans `options`' task again from `start` and the quasi-Newton Hessian `hessian` a plan ended
/// with (where it stopped: it goes on), as `stage` of `route`, and keeps the result if it ranks
/// above the best plan so far: the polish of a cheap result, and the best plan `continued`
/// where the cheap stage could not finish in the time left.
fn plan_on(
    (model, scene, options): (&Model, &Scene, &PlanOptions),
    (start, hessian): (Controls, Option<optim::DenseMatrix>),
    (route, stage): (&str, &str),
    progress: &mut impl FnMut(Progress<'_>),
    tally_into: Tally<'_>,
) -> crate::Result<()> {
    progress(Progress::Stage { stage, route });
    let mut more = options.clone();
    more.initial_hessian = hessian;
    let result = plan(model, scene, &start, &more, |i| {
        progress(Progress::Iteration(i))
    })?;
    tally(route, stage, result, tally_into);
    Ok(())
}

/// Plans `model`'s task from `start`, searching other routes as `search` says (module docs).
/// `progress` sees the iterations of the sequential stages (the first plan, the goal stages and
/// the polish) and the start of every stage after the first plan.
pub fn plan_with_search(
    model: &Model,
    scene: &Scene,
    start: &Controls,
    options: &PlanOptions,
    search: &SearchOptions,
    mut progress: impl FnMut(Progress<'_>),
) -> crate::Result<PlanResult> {
    search.validate()?;
    let clock = Instant::now();
    // Under a deadline, a search that may follow the first plan leaves it a share of the time;
    // the guess may give way to its carry route (module docs, step 1).
    let (first_options, (first_route, first_start, screened)) = match search.mode {
        SearchMode::Auto | SearchMode::Always => {
            (time_share(options), first_start(model, start, options))
        }
        SearchMode::Off => (options.clone(), ("initial guess".into(), start.clone(), 0)),
    };
    let mut first = plan(model, scene, &first_start, &first_options, |i| {
        progress(Progress::Iteration(i))
    })?;
    first.evaluations += screened;
    // Stopped by the user's deadline or interrupt, not by the first plan's share of the time.
    let stopped =
        first.status == "interrupted" || (first.status == "time_limit" && out_of_time(options));
    let run = !stopped
        && match search.mode {
            SearchMode::Off => false,
            SearchMode::Auto => !first.task.achieved,
            SearchMode::Always => true,
        };
    let mut reports = vec![candidate_report(&first_route, "first", &first)];
    if !run {
        // A first plan from the carry route says so in a search section of its own.
        if first_route != "initial guess" {
            reports[0].kept = true;
            first.search = Some(SearchReport {
                mode: search.mode,
                simulations: first.evaluations,
                iterations: first.iterations,
                gradient_evaluations: first.gradient_evaluations,
                candidates: reports,
            });
        }
        return Ok(first);
    }
    let mut best = first;
    let mut best_report = 0;
    // The goal stage on the first plan: a plan that misses narrowly often reaches its targets
    // once they are a constraint rather than a cost, with no new route (under a deadline, in
    // half the time left, so that the routes still get the rest).
    goal_stage(
        model,
        scene,
        (options, true, search.warm_goal_within()),
        &first_route,
        &mut progress,
        (&mut best, &mut best_report, &mut reports),
    )?;
    let interrupted = best.status == "interrupted";
    if !(best.task.achieved && search.mode == SearchMode::Auto
        || interrupted
        || out_of_time(options))
    {
        let mut candidates = routes::propose(
            model,
            start,
            (options.task.delta, options.task.swept),
            search.random_starts,
            search.seed,
            search.max_candidates,
        );
        // The first plan's start is planned already; the guess it replaced is a candidate.
        if first_route != "initial guess" {
            candidates.retain(|c| c.controls.data() != first_start.data());
            candidates.insert(
                0,
                routes::Candidate {
                    route: "initial guess".into(),
                    controls: start.clone(),
                },
            );
            candidates.truncate(search.max_candidates);
        }
        // Where the cheap stage could not finish in the time left, its candidates would end
        // after a few iterations each: the best plan, stopped only by its share of the time,
        // goes on instead.
        let go_on = options.deadline.is_some_and(|deadline| {
            best.status == "time_limit"
                && !cheap_stage_fits(&best, search, candidates.len(), deadline)
        });
        let polished_best = if go_on {
            let route = reports[best_report].route.clone();
            let from = (
                controls_from_nested(model, &best.controls)?,
                best.hessian.clone(),
            );
            plan_on(
                (model, scene, options),
                from,
                (&route, "continued"),
                &mut progress,
                (&mut best, &mut best_report, &mut reports),
            )?;
            None
        } else {
            route_stages(
                model,
                scene,
                options,
                search,
                &candidates,
                &mut progress,
                (&mut best, &mut best_report, &mut reports),
            )?
        };
        if let Some(route) = polished_best {
            goal_stage(
                model,
                scene,
                (options, false, search.warm_goal_within()),
                &route,
                &mut progress,
                (&mut best, &mut best_report, &mut reports),
            )?;
        }
    }
    reports[best_report].kept = true;
    let simulations = reports.iter().map(|r| r.simulations).sum();
    let iterations = reports.iter().map(|r| r.iterations).sum();
    let gradient_evaluations = reports.iter().map(|r| r.gradient_evaluations).sum();
    best.search = Some(SearchReport {
        mode: search.mode,
        candidates: reports,
        simulations,
        iterations,
        gradient_evaluations,
    });
    best.wall_s = clock.elapsed().as_secs_f64();
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_stage_that_others_may_follow_gets_half_the_time_left() {
        let model = Model::from_scene(&Scene::builtin("u_obstacle").unwrap()).unwrap();
        let mut options = PlanOptions::for_model(&model);
        assert!(
            time_share(&options).deadline.is_none(),
            "no deadline, none made up"
        );
        let now = Instant::now();
        options.deadline = Some(now + Duration::from_secs(100));
        let share = time_share(&options).deadline.unwrap();
        let left = share.saturating_duration_since(now).as_secs_f64();
        assert!((49.0..=50.5).contains(&left), "{left}");
        // A deadline already past stays past.
        options.deadline = Some(now);
        assert!(time_share(&options).deadline.unwrap() <= Instant::now());
    }

    #[test]
    fn a_cheap_stage_runs_its_candidates_in_rounds_of_the_threads() {
        // Three candidates of 30 iterations at 2 s each on two threads: two rounds.
        assert_eq!(cheap_stage_seconds(2.0, 30, 3, 2), 120.0);
        assert_eq!(cheap_stage_seconds(2.0, 30, 2, 2), 60.0);
        assert_eq!(cheap_stage_seconds(2.0, 30, 0, 2), 0.0);
        // No thread count is taken as one.
        assert_eq!(cheap_stage_seconds(1.0, 10, 3, 0), 30.0);
    }

    #[test]
    fn a_failed_candidate_is_reported_with_infinite_l_and_reads_back() {
        let error = crate::Error::UnsafeStart("step 3: the cloth went through itself".into());
        let report = failed_report("random 0", "cheap", &error);
        assert_eq!(report.status, "failed");
        assert!(!report.kept && !report.safe && !report.achieved);
        let json = serde_json::to_string(&report).unwrap();
        assert!(
            json.contains("\"L\":null") && json.contains("went through itself"),
            "{json}"
        );
        let back: CandidateReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back.l, f64::INFINITY);
        assert_eq!(back.error, report.error);
    }
}
