//! The progress test ([`SqpSettings::progress_window`](crate::SqpSettings::progress_window)): a
//! run whose iterates have stopped lowering the objective (and, where they are infeasible, the
//! violation) ends `NoProgress`, saying by how much each fell, when either
//!
//! - the line search kept cutting the QP's steps: the quadratic model promises decreases the
//!   function does not deliver at any step length tried (noise, roughness, or a gradient that
//!   does not match the function); or
//! - the steps were taken whole but the KKT residual did not fall at a linear rate of 0.8 an
//!   iteration either (an order of magnitude over 10), at feasible iterates that all meet the
//!   problem's own goal ([`Problem::goal_reached`](crate::Problem::goal_reached)): the model's
//!   steps are too short to go anywhere (a quasi-Newton model whose curvature was learnt from a
//!   step the line search cut a thousand-fold keeps them tiny), and the caller already has what
//!   it asked for. Elsewhere such a window may be the slow stretch of a descent that still pays
//!   (Table I's δ = 0.4 plan crawls so before it converges 0.025 lower), so it goes on.
//!
//! A condition beside the objective's is needed. Near a minimizer of a smooth problem the
//! objective also stops changing, but there the SQP takes unit steps (the second-order correction
//! prevents the Maratos effect) and its KKT residual falls by orders of magnitude within a few
//! iterations, so the test must not stop it (the `towel` scene's last 10 iterations change its
//! objective by less than 1e-8 at α = 1).

use std::collections::VecDeque;
use std::fmt;

/// One iterate as the test sees it.
#[derive(Clone, Copy, Debug)]
struct Entry {
    objective: f64,
    /// Max-norm constraint violation.
    violation: f64,
    /// Line-search step length of the step that led here (1 for the starting point).
    alpha: f64,
    /// KKT residual, once the iterate's QP gave multipliers (infinite until then).
    kkt: f64,
    /// The iterate is feasible and meets the problem's goal.
    goal: bool,
}

/// A window of whole steps is stuck when its smallest KKT residual is at least this rate to the
/// power of its length times the residual at its start (0.107 over 10 iterations): a run
/// converging linearly at a faster rate falls below it, a superlinear one by far.
const KKT_RATE: f64 = 0.8;

/// The objective, feasibility and step length of the most recent iterates, as many as the test
/// looks back.
pub(super) struct Progress {
    window: Option<usize>,
    tol: f64,
    /// An iterate whose violation is at most this is feasible.
    tol_feasibility: f64,
    /// The last `window + 1` iterates, oldest first.
    recent: VecDeque<Entry>,
}

/// What the test measured when it fired.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct NoProgress {
    /// Objective decrease over the window (negative if it rose).
    pub decrease: f64,
    /// `decrease / max(1, |f|)` at the current iterate.
    pub relative: f64,
    /// The window's length in iterations.
    pub iterations: usize,
    /// The tolerance it was held to.
    pub tol: f64,
    /// The longest step length of the window's steps.
    pub largest_alpha: f64,
    /// For a window with whole steps, the KKT residual at its start and the smallest one in it
    /// (`None` when every step was cut).
    pub kkt: Option<(f64, f64)>,
    /// For a window with infeasible iterates, the violation at its start and end (`None` when
    /// every iterate was feasible).
    pub violation: Option<(f64, f64)>,
}

impl Progress {
    /// A test over `window` iterations (`None`: never fires) with relative tolerance `tol`, for
    /// a run whose feasibility tolerance is `tol_feasibility`.
    pub fn new(window: Option<usize>, tol: f64, tol_feasibility: f64) -> Self {
        Progress {
            window,
            tol,
            tol_feasibility,
            recent: VecDeque::new(),
        }
    }

    /// Records an iterate of max-norm violation `violation`: the starting point (`alpha` 1), then
    /// each accepted step's, with the line search's step length `alpha`.
    pub fn record(&mut self, objective: f64, violation: f64, alpha: f64) {
        let Some(window) = self.window else {
            return;
        };
        self.recent.push_back(Entry {
            objective,
            violation,
            alpha,
            kkt: f64::INFINITY,
            goal: false,
        });
        while self.recent.len() > window + 1 {
            self.recent.pop_front();
        }
    }

    /// Annotates the latest iterate with what is known of it once its QP gave multipliers: its
    /// KKT residual, and whether it meets the problem's goal (`goal_reached`; only a feasible
    /// iterate counts).
    pub fn annotate_last(&mut self, kkt: f64, goal_reached: bool) {
        let tol_feasibility = self.tol_feasibility;
        if let Some(last) = self.recent.back_mut() {
            last.kkt = kkt;
            last.goal = goal_reached && last.violation <= tol_feasibility;
        }
    }

    /// The measured decrease when the last `window` iterations together lowered the objective by
    /// less than `tol · max(1, |f|)`, and, where an iterate of the window is infeasible, also
    /// lowered the violation by less than `tol` times its value at the window's start, and
    /// either every step was shortened by the line search (`α < 1`) or every iterate of the
    /// window is feasible and meets the problem's goal and the smallest KKT residual of the
    /// window's iterates is at least [`KKT_RATE`]`^window` of the one at its start; `None`
    /// otherwise (also before `window` iterations have been taken).
    pub fn stalled(&self) -> Option<NoProgress> {
        let window = self.window?;
        if self.recent.len() < window + 1 {
            return None;
        }
        let (first, last) = (self.recent.front()?, self.recent.back()?);
        let steps = self.recent.iter().skip(1);
        let largest_alpha = steps.clone().map(|e| e.alpha).fold(0.0, f64::max);
        let kkt = if largest_alpha >= 1.0 {
            let smallest = steps.map(|e| e.kkt).fold(f64::INFINITY, f64::min);
            let floor = KKT_RATE.powi(i32::try_from(window).unwrap_or(i32::MAX)) * first.kkt;
            let goal = self.recent.iter().all(|e| e.goal);
            if !(goal && first.kkt.is_finite() && smallest >= floor) {
                return None;
            }
            Some((first.kkt, smallest))
        } else {
            None
        };
        let decrease = first.objective - last.objective;
        let relative = decrease / last.objective.abs().max(1.0);
        let feasible = |e: &Entry| e.violation <= self.tol_feasibility;
        let violation =
            (!self.recent.iter().all(feasible)).then_some((first.violation, last.violation));
        let violation_stuck = violation.is_none_or(|(start, end)| start - end < self.tol * start);
        (relative < self.tol && violation_stuck).then_some(NoProgress {
            decrease,
            relative,
            iterations: window,
            tol: self.tol,
            largest_alpha,
            violation,
            kkt,
        })
    }
}

impl fmt::Display for NoProgress {
    /// `no progress: the objective fell by 3.21e-9 (relative 3.21e-9 < tol_progress 1e-6) over
    /// the last 10 iterations, all at feasible points, every step cut by the line search (α ≤
    /// 1.0e-2)`; a window of whole steps ends `…, whole steps among them, at iterates that all
    /// meet the goal, while the KKT residual fell slower than 0.8 an iteration (…)`; with
    /// infeasible iterates, `… over the last 10 iterations, the violation from
    /// 4.74e-3 to 4.74e-3, every step cut …`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let points = match self.violation {
            None => "all at feasible points".to_string(),
            Some((start, end)) => format!("the violation from {start:.2e} to {end:.2e}"),
        };
        let steps = match self.kkt {
            None => format!(
                "every step cut by the line search (α ≤ {:.1e})",
                self.largest_alpha
            ),
            Some((start, smallest)) => format!(
                "whole steps among them, at iterates that all meet the goal, while the KKT residual fell slower than 0.8 an iteration ({start:.2e}, at least {smallest:.2e} since)"
            ),
        };
        write!(
            f,
            "no progress: the objective fell by {:.2e} (relative {:.2e} < tol_progress {:.0e}) over the last {} iterations, {points}, {steps}",
            self.decrease, self.relative, self.tol, self.iterations
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records a feasible iterate.
    fn feasible(p: &mut Progress, objective: f64, alpha: f64) {
        p.record(objective, 0.0, alpha);
    }

    #[test]
    fn fires_only_after_a_full_window_of_feasible_iterates_without_progress() {
        let mut p = Progress::new(Some(3), 1e-6, 1e-8);
        feasible(&mut p, 10.0, 1.0);
        for _ in 0..2 {
            feasible(&mut p, 10.0, 0.5);
            assert_eq!(p.stalled(), None, "fewer than 3 iterations so far");
        }
        feasible(&mut p, 10.0 - 5e-6, 0.25);
        let stall = p.stalled().expect("3 iterations, 5e-7 relative");
        assert_eq!(stall.iterations, 3);
        assert_eq!(stall.largest_alpha, 0.5);
        assert_eq!(stall.violation, None);
        assert!((stall.decrease - 5e-6).abs() < 1e-15);
        assert!((stall.relative - 5e-7).abs() < 1e-12);
        // A real decrease in the window: no verdict.
        feasible(&mut p, 9.0, 0.5);
        assert_eq!(p.stalled(), None);
    }

    #[test]
    fn an_infeasible_window_stalls_only_when_its_violation_is_stuck_too() {
        let mut p = Progress::new(Some(3), 1e-6, 1e-8);
        p.record(9.0, 0.5, 1.0);
        // The violation falls while the objective does not: progress.
        for v in [0.4, 0.3, 0.2] {
            p.record(9.0, v, 0.5);
        }
        assert_eq!(p.stalled(), None, "the violation fell from 0.5 to 0.2");
        // Both stuck: no progress.
        for _ in 0..3 {
            p.record(9.0, 0.2, 0.5);
        }
        let stall = p
            .stalled()
            .expect("neither the objective nor the violation fell");
        assert_eq!(stall.violation, Some((0.2, 0.2)));
        // Reaching feasibility is progress.
        p.record(9.0, 0.0, 0.5);
        assert_eq!(p.stalled(), None, "the violation fell from 0.2 to 0");
        // A fall of the violation by more than `tol` of its start is progress.
        let mut q = Progress::new(Some(1), 1e-3, 1e-8);
        q.record(1.0, 1e-2, 1.0);
        q.record(1.0, 1e-2 - 2e-5, 0.5);
        assert_eq!(q.stalled(), None, "2e-3 of the violation");
        q.record(1.0, 1e-2 - 2.5e-5, 0.5);
        let stall = q.stalled().expect("5e-4 of the violation");
        assert_eq!(stall.violation, Some((1e-2 - 2e-5, 1e-2 - 2.5e-5)));
    }

    #[test]
    fn a_unit_step_in_the_window_is_progress_of_its_own() {
        let mut p = Progress::new(Some(3), 1e-6, 1e-8);
        feasible(&mut p, 1.0, 1.0);
        for alpha in [0.1, 1.0, 0.1] {
            feasible(&mut p, 1.0, alpha);
        }
        assert_eq!(p.stalled(), None, "the model's full step was accepted");
        feasible(&mut p, 1.0, 0.1);
        assert_eq!(p.stalled(), None, "the unit step is the window's first");
        feasible(&mut p, 1.0, 0.1);
        assert!(
            p.stalled().is_some(),
            "it left the window (the iterate it reached starts it)"
        );
    }

    /// Records a feasible iterate that meets the goal, reached by a whole step, with its KKT
    /// residual.
    fn whole(p: &mut Progress, objective: f64, kkt: f64) {
        p.record(objective, 0.0, 1.0);
        p.annotate_last(kkt, true);
    }

    #[test]
    fn whole_steps_stall_only_while_the_kkt_residual_falls_slower_than_linearly() {
        let mut p = Progress::new(Some(3), 1e-6, 1e-8);
        whole(&mut p, 1.0, 0.3);
        for kkt in [0.2, 0.35, 0.1] {
            whole(&mut p, 1.0, kkt);
        }
        assert_eq!(p.stalled(), None, "0.1 is below 0.8³ of 0.3: converging");
        for _ in 0..2 {
            whole(&mut p, 1.0, 0.15);
            assert_eq!(p.stalled(), None, "the window still holds 0.1");
        }
        whole(&mut p, 1.0, 0.15);
        let stall = p.stalled().expect("from 0.1 the smallest is 0.15");
        assert_eq!(stall.kkt, Some((0.1, 0.15)));
        assert_eq!(stall.largest_alpha, 1.0);
        assert!(stall.to_string().contains("whole steps among them"));
        // The objective falling is progress whatever the residual does.
        whole(&mut p, 0.5, 0.05);
        assert_eq!(p.stalled(), None);
    }

    #[test]
    fn whole_steps_stall_only_at_feasible_iterates_that_meet_the_goal() {
        let mut p = Progress::new(Some(2), 1e-6, 1e-8);
        whole(&mut p, 1.0, 0.5);
        p.record(1.0, 0.0, 1.0);
        p.annotate_last(0.5, false);
        whole(&mut p, 1.0, 0.5);
        assert_eq!(
            p.stalled(),
            None,
            "an iterate of the window misses the goal"
        );
        p.record(1.0, 1e-3, 1.0);
        p.annotate_last(0.5, true);
        assert_eq!(
            p.stalled(),
            None,
            "iterates of the window miss the goal or are infeasible"
        );
        whole(&mut p, 1.0, 0.5);
        whole(&mut p, 1.0, 0.5);
        assert!(
            p.stalled().is_none(),
            "the infeasible one still starts the window"
        );
        whole(&mut p, 1.0, 0.5);
        assert!(p.stalled().is_some());
    }

    #[test]
    fn whole_steps_from_an_iterate_without_a_kkt_residual_are_not_judged() {
        let mut p = Progress::new(Some(2), 1e-6, 1e-8);
        // Feasible and at the goal, but no QP gave multipliers.
        for _ in 0..3 {
            p.record(1.0, 0.0, 1.0);
            p.annotate_last(f64::INFINITY, true);
        }
        assert_eq!(p.stalled(), None, "no KKT residual is known in the window");
        for _ in 0..3 {
            whole(&mut p, 1.0, 0.5);
        }
        assert!(p.stalled().is_some());
    }

    #[test]
    fn is_absolute_below_one_and_relative_above() {
        let mut small = Progress::new(Some(1), 1e-6, 1e-8);
        feasible(&mut small, 1e-3, 1.0);
        feasible(&mut small, 1e-3 - 2e-6, 0.5);
        assert_eq!(small.stalled(), None, "2e-6 absolute at |f| < 1");
        let mut large = Progress::new(Some(1), 1e-6, 1e-8);
        feasible(&mut large, 1e4, 1.0);
        feasible(&mut large, 1e4 - 2e-3, 0.5);
        assert!(large.stalled().is_some(), "2e-7 relative at |f| = 1e4");
    }

    #[test]
    fn off_never_fires() {
        let mut p = Progress::new(None, 1e-6, 1e-8);
        for _ in 0..100 {
            feasible(&mut p, 1.0, 1e-3);
        }
        assert_eq!(p.stalled(), None);
        assert!(p.recent.is_empty());
    }

    #[test]
    fn message_states_the_measurement() {
        let mut m = NoProgress {
            decrease: 3.21e-9,
            relative: 3.21e-9,
            iterations: 10,
            tol: 1e-6,
            largest_alpha: 1e-2,
            violation: None,
            kkt: None,
        };
        assert_eq!(
            m.to_string(),
            "no progress: the objective fell by 3.21e-9 (relative 3.21e-9 < tol_progress 1e-6) over the last 10 iterations, all at feasible points, every step cut by the line search (α ≤ 1.0e-2)"
        );
        m.violation = Some((4.74e-3, 4.7399e-3));
        assert_eq!(
            m.to_string(),
            "no progress: the objective fell by 3.21e-9 (relative 3.21e-9 < tol_progress 1e-6) over the last 10 iterations, the violation from 4.74e-3 to 4.74e-3, every step cut by the line search (α ≤ 1.0e-2)"
        );
        m.violation = None;
        m.largest_alpha = 1.0;
        m.kkt = Some((0.299, 0.133));
        assert_eq!(
            m.to_string(),
            "no progress: the objective fell by 3.21e-9 (relative 3.21e-9 < tol_progress 1e-6) over the last 10 iterations, all at feasible points, whole steps among them, at iterates that all meet the goal, while the KKT residual fell slower than 0.8 an iteration (2.99e-1, at least 1.33e-1 since)"
        );
    }
}
