//! Recording tapes kept between evaluations.
//!
//! Every evaluation with gradients records its steps on tapes. Fresh tapes allocate and
//! first-touch every recorded buffer anew (`malloc`, `free`, zeroing and page faults were ≈ 10%
//! of a rollout with its gradient); a [`TapeCache`] hands the previous evaluation's tapes back,
//! cleared, with their buffers, so a repeated evaluation (an optimizer's) reuses them.

use autodiff::Tape;
use std::sync::Mutex;

/// Cleared tapes with their buffers, kept for the next evaluation; at most
/// [`crate::Model::checkpoint_budget`] bytes in all.
///
/// Cloning gives an empty cache (a cloned model does not share its tapes).
#[derive(Default)]
pub struct TapeCache(Mutex<Vec<Tape>>);

impl Clone for TapeCache {
    fn clone(&self) -> Self {
        TapeCache::default()
    }
}

impl TapeCache {
    /// A kept tape (empty, with its buffers), or a new one.
    pub fn take(&self) -> Tape {
        self.lock().pop().unwrap_or_default()
    }

    /// Clears `tape` and keeps it while the kept tapes' bytes ([`Tape::reserved_bytes`]) stay
    /// within `budget`; drops it otherwise.
    pub fn give(&self, mut tape: Tape, budget: usize) {
        tape.clear();
        let mut kept = self.lock();
        let held: usize = kept.iter().map(Tape::reserved_bytes).sum();
        if held + tape.reserved_bytes() <= budget {
            kept.push(tape);
        }
    }

    /// Bytes held by the kept tapes.
    pub fn bytes(&self) -> usize {
        self.lock().iter().map(Tape::reserved_bytes).sum()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Tape>> {
        // A panic while holding the lock leaves only cleared tapes behind: still usable.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}
