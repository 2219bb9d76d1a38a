//! Step 0: where the cloth starts relative to the obstacles.
//!
//! The optimizer's safety rows cover steps `1..=T`; the rest state is fixed by the scene, so a
//! cloth that starts inside an obstacle (or inside a safety obstacle's margin) cannot be made safe
//! by any plan. [`start_intrusions`] finds, for every obstacle, its deepest intrusion at step 0.

use autodiff::Tensor;
use cloth::scene::{Obstacle, ParticleRef, Scene};
use cloth::StartReport;

/// The deepest intrusion of the rest state into one obstacle.
#[derive(Clone, Debug, PartialEq)]
pub struct Intrusion {
    /// Index in `obstacles`.
    pub obstacle: usize,
    /// The sphere within a sphere set; `None` for a plane.
    pub sphere: Option<usize>,
    /// The particle: `[row, col]` on a grid cloth, a vertex index on a mesh cloth.
    pub particle: ParticleRef,
    /// The particle's signed distance to the primitive (negative inside).
    pub distance: f64,
    /// The obstacle is a safety obstacle (its margin `δ` applies).
    pub safety: bool,
    /// The obstacle's JSON type: `spheres`, `plane`, `capsule`, `box` or `mesh`.
    pub kind: &'static str,
}

impl Intrusion {
    /// `obstacles[2] (spheres), sphere 5` or `obstacles[0] (plane)`.
    pub fn name(&self) -> String {
        match self.sphere {
            Some(s) => format!("obstacles[{}] (spheres), sphere {s}", self.obstacle),
            None => format!("obstacles[{}] ({})", self.obstacle, self.kind),
        }
    }
}

/// For each obstacle, the particle of step 0 (`start`, `N × 3`: [`cloth::Model::start`])
/// closest to (or deepest inside) it, when that particle is inside the obstacle or, for safety
/// obstacles, within `delta` of it.
pub fn start_intrusions(scene: &Scene, start: &Tensor, delta: f64) -> Vec<Intrusion> {
    let rest: Vec<[f64; 3]> = start
        .data()
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    let cols = scene.cloth.cols.max(1);
    let mesh = scene.cloth.is_mesh();
    let mut out = Vec::new();
    for (o, obstacle) in scene.obstacles.iter().enumerate() {
        let safety = obstacle.role().is_safety();
        let limit = if safety { delta } else { 0.0 };
        let mut deepest: Option<Intrusion> = None;
        let kind = obstacle.kind();
        let mut consider = |sphere: Option<usize>, particle: usize, distance: f64| {
            if distance < limit && deepest.as_ref().is_none_or(|d| distance < d.distance) {
                deepest = Some(Intrusion {
                    obstacle: o,
                    sphere,
                    particle: if mesh {
                        ParticleRef::Vertex(particle)
                    } else {
                        ParticleRef::Grid([particle / cols, particle % cols])
                    },
                    distance,
                    safety,
                    kind,
                });
            }
        };
        match obstacle {
            Obstacle::Spheres(set) => {
                for (s, (c, &r)) in set.centers.iter().zip(&set.radii).enumerate() {
                    for (i, p) in rest.iter().enumerate() {
                        let d = (0..3).map(|j| (p[j] - c[j]).powi(2)).sum::<f64>().sqrt() - r;
                        consider(Some(s), i, d);
                    }
                }
            }
            Obstacle::Plane(plane) => {
                let n = plane.normalized();
                for (i, p) in rest.iter().enumerate() {
                    let d = (0..3).map(|j| n[j] * (p[j] - plane.point[j])).sum();
                    consider(None, i, d);
                }
            }
            other => {
                for (i, p) in rest.iter().enumerate() {
                    consider(None, i, other.signed_distance(*p));
                }
            }
        }
        out.extend(deepest);
    }
    out
}

/// The error for a start inside an obstacle, or `None`; and warnings for a start inside a safety
/// margin but outside the obstacle.
pub fn judge_start(scene: &Scene, start: &Tensor, delta: f64) -> (Option<String>, Vec<String>) {
    let mut error = None;
    let mut warnings = Vec::new();
    for i in start_intrusions(scene, start, delta) {
        let at = match i.particle {
            ParticleRef::Grid([r, c]) => format!("particle [{r}, {c}]"),
            ParticleRef::Vertex(v) => format!("particle {v}"),
        };
        if i.distance < 0.0 {
            if error.is_none() {
                error = Some(format!(
                    "the cloth starts inside {} at depth {:.4} ({at}): no plan can make step 0 safe; move the cloth or the obstacle (or allow it with --allow-unsafe-start)",
                    i.name(),
                    -i.distance
                ));
            }
        } else {
            warnings.push(format!(
                "the cloth starts {:.4} from {}, inside the margin δ = {delta} ({at}); step 0 is fixed, so the plan's safety covers steps 1..T only",
                i.distance,
                i.name()
            ));
        }
    }
    (error, warnings)
}

/// The warning a start placed from `cloth.initial_state` gets when placing it changed it:
/// settled by quasi-static steps, or particles lifted out of the colliders' barrier reach.
pub fn start_warning(report: &StartReport) -> Option<String> {
    if report.settle_steps == 0 && report.lifted == 0 {
        return None;
    }
    let mut how = Vec::new();
    if report.lifted > 0 {
        how.push(format!(
            "{} particles within d̂/2 of a collider moved out to d̂/2",
            report.lifted
        ));
    }
    if report.settle_steps > 0 {
        how.push(format!(
            "settled by {} quasi-static steps of the scene's physics with the grippers held",
            report.settle_steps
        ));
    }
    let (moved, particle) = report.moved;
    Some(format!(
        "cloth.initial_state ({}) was not at rest: {}; step 0 lies up to {moved:.4e} from it          (particle {particle})",
        report.source,
        how.join(", then ")
    ))
}
