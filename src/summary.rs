//! The human-readable summary of a plan — the verdict line, the run's counts, the route search's
//! candidates and the metrics table — shared by `clothopt optimize` and Python's `Plan.summary()`.

use crate::result::{MotionCheck, PlanResult};
use std::fmt::Write;

impl PlanResult {
    /// The summary as lines of text (ending in a newline); `timing` adds the wall time, which
    /// `--no-timing` leaves out so the text is reproducible.
    pub fn summary(&self, timing: bool) -> String {
        let mut s = String::new();
        // Writing into a `String` cannot fail.
        let _ = self.write_summary(&mut s, timing);
        s
    }

    fn write_summary(&self, s: &mut String, timing: bool) -> std::fmt::Result {
        let m = &self.metrics;
        let caveat = self.physics.as_ref().and_then(|p| p.caveat());
        let verdict = if self.task.achieved {
            format!("task achieved{}", caveat.unwrap_or_default())
        } else {
            format!("task NOT achieved ({})", self.task.reason.name())
        };
        let checked = match self.safety.check {
            MotionCheck::Continuous => "",
            MotionCheck::StepOnly => {
                " (step-only check: safety judged at the steps, not on the motion between them)"
            }
        };
        writeln!(s, "{verdict}{checked}: {}", self.task.explanation)?;
        writeln!(
            s,
            "scene {}  δ = {}  status {}  ({})",
            self.scene, self.delta, self.status, self.message
        )?;
        let wall = if timing {
            format!("  wall {:.2} s", self.wall_s)
        } else {
            String::new()
        };
        let per_stage = self
            .stages
            .iter()
            .map(|st| match st.kappa {
                Some(k) => format!("κ = {k}: {} {}", st.iterations, st.status),
                None => format!("{} {}", st.iterations, st.status),
            })
            .collect::<Vec<_>>()
            .join(", ");
        match &self.search {
            // The whole run's counts: the kept plan may be a stage that did little (one the
            // deadline stopped at once), while the search ran many.
            Some(search) if search.iterations > 0 => writeln!(
                s,
                "iterations {} in all, the kept plan's {} ({per_stage})  simulations {}  gradients {}{wall}",
                search.iterations,
                self.iterations,
                search.simulations,
                search.gradient_evaluations
            )?,
            _ => writeln!(
                s,
                "iterations {} ({per_stage})  simulations {}  gradients {}{wall}",
                self.iterations, self.evaluations, self.gradient_evaluations
            )?,
        }
        if let Some(physics) = &self.physics {
            writeln!(s, "{}", physics.summary_line())?;
        }
        if let Some(check) = &self.check {
            writeln!(s, "{}", check.summary())?;
        }
        if let Some(search) = &self.search {
            writeln!(
                s,
                "route search ({} stages after the first plan, {} simulations in all):",
                search.candidates.len() - 1,
                search.simulations
            )?;
            for c in &search.candidates {
                writeln!(
                    s,
                    "  {} {:<9} {:<16} safe {:<5} achieved {:<5} L {:>10.5} G {:>9.5}  {}",
                    if c.kept { "*" } else { " " },
                    c.stage,
                    c.status,
                    c.safe,
                    c.achieved,
                    c.l,
                    c.g,
                    c.route
                )?;
            }
        }
        writeln!(s, "{:>10} {:>12}", "metric", "value")?;
        for (k, v) in [
            ("G", m.g),
            ("αT", m.alpha_t),
            ("βE", m.beta_e),
            ("L", m.l),
            ("C", m.c),
            ("min SDF", m.min_sdf),
            ("swept SDF", m.min_sdf_swept),
            ("max strain", self.strain.max),
        ] {
            writeln!(s, "{k:>10} {v:>12.6}")?;
        }
        if let Some(measures) = &self.measures {
            if let Some(v) = measures.coverage {
                writeln!(
                    s,
                    "{:>10} {v:>12.6}  (normalized, along gravity)",
                    "coverage"
                )?;
            }
            if let Some(v) = measures.mean_particle_distance {
                writeln!(
                    s,
                    "{:>10} {v:>12.6}  (mean particle distance to its target)",
                    "layout"
                )?;
            }
        }
        if let Some(c) = self.safety.surface {
            writeln!(
                s,
                "{:>10} {:>12.6}  (the cloth's surface: triangle {} at step {})",
                "surface", c.distance, c.triangle, c.step
            )?;
        }
        if let Some(l) = self.safety.layers {
            let nearest = l
                .nearest
                .map_or("none within the thickness".to_string(), |p| {
                    format!(
                        "{:.6} (vertex {}, triangle {} at step {})",
                        p.distance, p.vertex, p.triangle, p.step
                    )
                });
            writeln!(
                s,
                "{:>10} {nearest}; {} crossings between steps",
                "layers", l.crossings
            )?;
        }
        if let Some(p) = m.max_penetration {
            writeln!(
                s,
                "{:>10} {:>12.6}  (particle {} at step {}; negative: clearance)",
                "penetration", p.depth, p.particle, p.step
            )?;
        }
        Ok(())
    }
}
