//! The fit's text summary, shared by the CLI and Python.

use super::{FitResult, FitStatus};

impl FitResult {
    /// The text `clothopt fit` prints: the status and counts, a line per parameter (start, fitted,
    /// standard error, flags), the tracking error and its RMS per step; `timing` false leaves out
    /// the wall time.
    pub fn summary(&self, timing: bool) -> String {
        let r = self;
        let wall = if timing {
            format!(", {:.1} s", r.wall_s)
        } else {
            String::new()
        };
        let status = match r.status {
            FitStatus::Converged => "converged",
            FitStatus::Stalled => "stalled (no damped step lowered the error)",
            FitStatus::IterationLimit => "stopped at the iteration limit",
        };
        let mut s = format!(
            "fit {}: {status} after {} iterations ({} simulations{wall}); ",
            r.scene, r.iterations, r.simulations
        );
        s += &format!(
            "{} tracked points, noise {:.3e} ({})\n",
            r.points, r.noise.value, r.noise.source
        );
        s += &format!(
            "{:>12} {:>12} {:>12} {:>12} {:>9}  note\n",
            "parameter", "start", "fitted", "std error", "relative"
        );
        for (name, p) in &r.parameters {
            let (se, rel) = match (p.std_error, p.relative_std_error) {
                (Some(a), Some(b)) => (format!("{a:.4e}"), format!("{:.2}%", 100.0 * b)),
                _ => ("—".into(), "—".into()),
            };
            let mut note = Vec::new();
            if !p.identifiable {
                note.push("NOT identifiable from these observations");
            }
            if p.at_bound {
                note.push("at its bound");
            }
            s += &format!(
                "{name:>12} {:>12.5e} {:>12.5e} {se:>12} {rel:>9}  {}\n",
                p.start,
                p.value,
                note.join("; ")
            );
        }
        s += &format!(
            "tracking error: RMS {:.4e} at the start → {:.4e} fitted (largest {:.4e})\n",
            r.rms_error_start, r.rms_error, r.max_error
        );
        let steps: Vec<String> = (r.residual_per_step.iter().enumerate())
            .filter_map(|(t, e)| e.map(|e| format!("{t}: {e:.2e}")))
            .collect();
        s += &format!("RMS per step  {}\n", steps.join("  "));
        s
    }
}
