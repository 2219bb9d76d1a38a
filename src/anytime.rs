//! Runs that respect the user's time: a deadline, an interrupt flag, and the best feasible iterate
//! seen so far (what a stopped run returns).

use cloth::RolloutLimits;
use optim::IterationInfo;
use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

/// Why a run was stopped before its solver finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The deadline ([`crate::plan::PlanOptions::deadline`]) passed.
    TimeLimit,
    /// The stop flag was raised (e.g. by SIGINT).
    Interrupted,
}

impl StopReason {
    /// The status name a stopped plan reports: `time_limit` or `interrupted`.
    pub fn status(self) -> &'static str {
        match self {
            StopReason::TimeLimit => "time_limit",
            StopReason::Interrupted => "interrupted",
        }
    }
}

/// The best feasible iterate of a run so far.
#[derive(Clone, Debug, PartialEq)]
pub struct Best {
    /// Its objective.
    pub objective: f64,
    /// The point.
    pub x: Vec<f64>,
    /// Its constraint violation (at most the feasibility tolerance).
    pub violation: f64,
}

/// Watches the iterations of a run: keeps the best feasible iterate (lowest objective among those
/// whose violation is within the feasibility tolerance) and stops the run at the deadline or when
/// the stop flag is raised. Once stopped, it stops every later stage at its first iteration.
#[derive(Debug)]
pub struct Watch {
    /// The deadline and the stop flag (no iteration schedule).
    limits: RolloutLimits,
    tol_feasibility: f64,
    /// The best feasible iterate so far.
    pub best: Option<Best>,
    /// Why the run was stopped, if it was.
    pub stopped: Option<StopReason>,
}

impl Watch {
    /// A watch with an optional deadline and stop flag; iterates with a violation at most
    /// `tol_feasibility` count as feasible.
    pub fn new(
        deadline: Option<Instant>,
        stop: Option<Arc<AtomicBool>>,
        tol_feasibility: f64,
    ) -> Self {
        Watch {
            limits: RolloutLimits {
                deadline,
                stop,
                ..RolloutLimits::default()
            },
            tol_feasibility,
            best: None,
            stopped: None,
        }
    }

    /// True when the deadline has passed or the stop flag is raised (without recording it).
    pub fn expired(&self) -> Option<StopReason> {
        if self.limits.stop_raised() {
            Some(StopReason::Interrupted)
        } else if self.limits.past_deadline() {
            Some(StopReason::TimeLimit)
        } else {
            None
        }
    }

    /// Records why the run stops when its deadline has passed or its flag is raised, as the
    /// next [`Watch::observe`] would: for a solver stopped inside an iteration (a line-search
    /// trial declined at the deadline), which calls back no more.
    pub fn notice(&mut self) {
        if self.stopped.is_none() {
            self.stopped = self.expired();
        }
    }

    /// The best feasible iterate to return instead of where a run ended, when that point is
    /// not feasible (`violation` above the feasibility tolerance) and the run did not converge:
    /// an iteration limit or a stall can leave the last iterate on the wrong side of a row the
    /// run had kept for many iterations before. Taken out of the watch.
    pub fn take_fallback(&mut self, converged: bool, violation: f64) -> Option<Best> {
        if converged || violation <= self.tol_feasibility {
            return None;
        }
        self.best.take()
    }

    /// Records `info` and says whether the solver may go on.
    pub fn observe(&mut self, info: &IterationInfo) -> ControlFlow<()> {
        let feasible = info.constraint_violation <= self.tol_feasibility;
        if feasible
            && info.objective.is_finite()
            && self
                .best
                .as_ref()
                .is_none_or(|b| info.objective < b.objective)
        {
            self.best = Some(Best {
                objective: info.objective,
                x: info.x.clone(),
                violation: info.constraint_violation,
            });
        }
        if self.stopped.is_none() {
            self.stopped = self.expired();
        }
        match self.stopped {
            Some(_) => ControlFlow::Break(()),
            None => ControlFlow::Continue(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::Ordering;

    fn info(objective: f64, violation: f64, x: f64) -> IterationInfo {
        IterationInfo {
            iteration: 0,
            objective,
            constraint_violation: violation,
            kkt_residual: 0.0,
            step_norm: 0.0,
            step_length: 0.0,
            penalty: 0.0,
            linearized_violation: 0.0,
            function_evaluations: 0,
            gradient_evaluations: 0,
            x: vec![x],
        }
    }

    #[test]
    fn keeps_the_best_feasible_iterate_and_stops_on_the_flag() {
        let flag = Arc::new(AtomicBool::new(false));
        let mut w = Watch::new(None, Some(flag.clone()), 1e-6);
        assert!(w.observe(&info(5.0, 0.0, 1.0)).is_continue());
        assert!(w.observe(&info(1.0, 0.5, 2.0)).is_continue()); // infeasible: not kept
        assert!(w.observe(&info(3.0, 1e-7, 3.0)).is_continue());
        assert_eq!(
            w.best.as_ref().map(|b| (b.objective, b.x.clone())),
            Some((3.0, vec![3.0]))
        );
        flag.store(true, Ordering::Relaxed);
        assert!(w.observe(&info(9.0, 0.0, 4.0)).is_break());
        assert_eq!(w.stopped, Some(StopReason::Interrupted));
        assert_eq!(
            w.best.as_ref().map(|b| (b.objective, b.x.clone())),
            Some((3.0, vec![3.0]))
        );
    }

    #[test]
    fn a_run_that_ends_infeasible_falls_back_on_its_best_feasible_iterate() {
        let mut w = Watch::new(None, None, 1e-6);
        assert!(w.observe(&info(3.0, 0.0, 1.0)).is_continue());
        assert!(w.observe(&info(2.0, 1e-4, 2.0)).is_continue());
        // Converged, or ended feasible: its own point.
        assert_eq!(w.take_fallback(true, 1e-4), None);
        assert_eq!(w.take_fallback(false, 1e-7), None);
        // Ended by a limit on the wrong side of a row: the best feasible one.
        let best = w.take_fallback(false, 1e-4).map(|b| (b.objective, b.x));
        assert_eq!(best, Some((3.0, vec![1.0])));
        // None seen: nothing to fall back on.
        let mut w = Watch::new(None, None, 1e-6);
        assert!(w.observe(&info(2.0, 1e-4, 2.0)).is_continue());
        assert_eq!(w.take_fallback(false, 1e-4), None);
    }

    #[test]
    fn a_past_deadline_stops_at_once() {
        let mut w = Watch::new(Some(Instant::now()), None, 1e-6);
        assert!(w.observe(&info(1.0, 0.0, 1.0)).is_break());
        assert_eq!(w.stopped.map(StopReason::status), Some("time_limit"));
    }

    #[test]
    fn noticing_records_a_stop_found_inside_an_iteration() {
        // A solver stopped by a declined line-search trial calls back no more: the watch is told.
        let mut w = Watch::new(None, None, 1e-6);
        w.notice();
        assert_eq!(w.stopped, None, "no deadline, no flag: nothing to record");
        let mut w = Watch::new(Some(Instant::now()), None, 1e-6);
        w.notice();
        assert_eq!(w.stopped, Some(StopReason::TimeLimit));
        // The first reason stays.
        let flag = Arc::new(AtomicBool::new(true));
        let mut w = Watch::new(None, Some(flag.clone()), 1e-6);
        w.notice();
        w.limits.deadline = Some(Instant::now());
        w.notice();
        assert_eq!(w.stopped, Some(StopReason::Interrupted));
    }
}
