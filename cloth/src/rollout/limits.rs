//! What a counted rollout ([`crate::Model::simulate_counted`]) may spend before it gives up: a
//! schedule of Newton iterations step by step, a deadline and a stop flag.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Limits of a counted rollout. The default holds it to nothing.
#[derive(Clone, Debug, Default)]
pub struct RolloutLimits {
    /// Newton iterations the rollout may have taken by the end of each step, cumulative (entry
    /// `t` for step `t + 1`); steps past the list's end are held to its last entry, and an empty
    /// list holds none. Past it the rollout stops with
    /// [`ClothError::NewtonWorkExceeded`](crate::ClothError::NewtonWorkExceeded).
    pub cumulative_iterations: Vec<usize>,
    /// The rollout stops with [`ClothError::RolloutStopped`](crate::ClothError::RolloutStopped)
    /// once this instant has passed (checked before every step and every Newton iteration).
    pub deadline: Option<Instant>,
    /// The rollout stops, as at the deadline, once this flag is raised (e.g. by SIGINT).
    pub stop: Option<Arc<AtomicBool>>,
}

impl RolloutLimits {
    /// At most `iterations` Newton iterations in all, no deadline.
    pub fn total(iterations: usize) -> Self {
        RolloutLimits {
            cumulative_iterations: vec![iterations],
            ..Self::default()
        }
    }

    /// The Newton iterations allowed by the end of step `step` (1-based).
    pub fn iterations_by(&self, step: usize) -> usize {
        let last = self.cumulative_iterations.len().saturating_sub(1);
        self.cumulative_iterations
            .get(step.saturating_sub(1).min(last))
            .copied()
            .unwrap_or(usize::MAX)
    }

    /// True once the deadline has passed or the stop flag is raised.
    pub fn halted(&self) -> bool {
        self.stop_raised() || self.past_deadline()
    }

    /// True once the stop flag is raised.
    pub fn stop_raised(&self) -> bool {
        self.stop
            .as_ref()
            .is_some_and(|s| s.load(Ordering::Relaxed))
    }

    /// True once the deadline has passed.
    pub fn past_deadline(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_holds_later_steps_to_its_last_entry() {
        let limits = RolloutLimits {
            cumulative_iterations: vec![3, 10],
            ..RolloutLimits::default()
        };
        assert_eq!(
            (1..=4).map(|t| limits.iterations_by(t)).collect::<Vec<_>>(),
            [3, 10, 10, 10]
        );
        assert_eq!(RolloutLimits::default().iterations_by(2), usize::MAX);
        assert_eq!(RolloutLimits::total(7).iterations_by(5), 7);
    }

    #[test]
    fn halted_by_a_past_deadline_or_the_flag() {
        assert!(!RolloutLimits::default().halted());
        let past = RolloutLimits {
            deadline: Some(Instant::now()),
            ..RolloutLimits::default()
        };
        assert!(past.halted());
        let flag = Arc::new(AtomicBool::new(false));
        let flagged = RolloutLimits {
            stop: Some(flag.clone()),
            ..RolloutLimits::default()
        };
        assert!(!flagged.halted());
        flag.store(true, Ordering::Relaxed);
        assert!(flagged.halted());
    }
}
