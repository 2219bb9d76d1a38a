//! What `clothopt optimize` shows while it runs: a progress bar on a terminal, a line every few
//! seconds on stderr otherwise, a one-line estimate when the run is likely to take minutes, and
//! the best feasible plan so far written to `--out` every few seconds.

use clothopt::anytime::Watch;
use indicatif::{ProgressBar, ProgressStyle};
use optim::IterationInfo;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Seconds between progress lines (off a terminal) and between best-so-far files.
const EVERY: Duration = Duration::from_secs(5);

/// Runs whose estimate exceeds this get a one-line note.
const LONG_RUN: Duration = Duration::from_secs(60);

/// Progress of one `optimize` run.
pub struct Reporter {
    bar: ProgressBar,
    terminal: bool,
    verbose: bool,
    start: Instant,
    last_line: Instant,
    last_write: Instant,
    estimated: bool,
    /// Iteration budget of the whole run (all κ stages), for the estimate.
    budget: usize,
    /// Keeps the best feasible iterate (no deadline or stop flag: `plan` enforces those).
    watch: Watch,
    seen: usize,
    unsaved: bool,
}

impl Reporter {
    /// A reporter for a run of at most `budget` iterations.
    pub fn new(budget: usize, verbose: bool, tol_feasibility: f64) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let bar = if terminal {
            ProgressBar::new(budget as u64)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let now = Instant::now();
        Reporter {
            bar,
            terminal,
            verbose,
            start: now,
            last_line: now,
            last_write: now,
            estimated: false,
            budget,
            watch: Watch::new(None, None, tol_feasibility),
            seen: 0,
            unsaved: false,
        }
    }

    /// Shows one iteration. `save` writes the best feasible iterate so far (its point and
    /// violation) when it is due.
    pub fn iteration(&mut self, info: &IterationInfo, save: &mut dyn FnMut(&[f64], f64, usize)) {
        self.seen += 1;
        let elapsed = self.start.elapsed();
        let before = self.watch.best.as_ref().map(|b| b.objective);
        let _ = self.watch.observe(info);
        if self.watch.best.as_ref().map(|b| b.objective) != before {
            self.unsaved = true;
        }
        if self.verbose {
            self.bar.suspend(|| eprintln!("{info}"));
        }
        if !self.estimated && self.seen >= 2 {
            self.estimated = true;
            let per = elapsed.as_secs_f64() / (self.seen - 1) as f64;
            let total = per * self.budget as f64;
            if total > LONG_RUN.as_secs_f64() {
                self.bar.suspend(|| {
                    eprintln!(
                        "note: about {per:.1} s per iteration; up to {} iterations may take {:.0} min (--time-limit bounds the run; Ctrl-C writes the best plan so far)",
                        self.budget,
                        total / 60.0
                    )
                });
            }
        }
        self.bar.set_position(info.iteration as u64);
        self.bar.set_message(format!(
            "f {:.5} viol {:.1e} kkt {:.1e}",
            info.objective, info.constraint_violation, info.kkt_residual
        ));
        let now = Instant::now();
        if !self.terminal && !self.verbose && now - self.last_line >= EVERY {
            self.last_line = now;
            eprintln!(
                "[{:>6.1} s] iteration {}  objective {:.6}  violation {:.2e}  kkt {:.2e}",
                elapsed.as_secs_f64(),
                info.iteration,
                info.objective,
                info.constraint_violation,
                info.kkt_residual
            );
        }
        if self.unsaved && now - self.last_write >= EVERY {
            if let Some(best) = &self.watch.best {
                save(&best.x, best.violation, self.seen);
            }
            self.last_write = now;
            self.unsaved = false;
        }
    }

    /// Announces a search stage after the first plan: a line on stderr above the bar (which
    /// restarts for the stage's iterations) on a terminal or with `--verbose`; otherwise, like the
    /// progress lines, only once the run has taken [`EVERY`], so short runs stay quiet.
    pub fn stage(&mut self, stage: &str, route: &str) {
        self.bar.set_position(0);
        let elapsed = self.start.elapsed();
        if !self.terminal && !self.verbose && elapsed < EVERY {
            return;
        }
        let elapsed = elapsed.as_secs_f64();
        let what = match stage {
            "goal" => format!("goal stage (targets as constraints), route: {route}"),
            "goal_identity" => {
                format!("goal stage again from the identity Hessian, route: {route}")
            }
            "cheap" => format!("cheap stage, {route} in parallel"),
            "polished" => format!("polishing, route: {route}"),
            "restored" => {
                format!("the goal stage's plan on without its goal row, route: {route}")
            }
            "continued" => {
                format!("no time for the cheap stage; the best plan goes on, route: {route}")
            }
            other => format!("{other} stage, route: {route}"),
        };
        self.bar
            .suspend(|| eprintln!("[{elapsed:>6.1} s] search: {what}"));
    }

    /// Clears the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
