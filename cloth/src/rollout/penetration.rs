//! How deep a rollout's particles go into the colliders: the `max_penetration` metric.

use crate::model::Model;
use autodiff::Tensor;

/// The particle of a rollout that comes nearest to (or deepest into) the colliders.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Penetration {
    /// How far it is inside them (length units): minus its signed distance, so 0 on a
    /// collider's surface and negative (a clearance) when no particle touches one.
    pub depth: f64,
    /// The step `1..=T`.
    pub step: usize,
    /// The particle (flat index).
    pub particle: usize,
}

/// The deeper of two penetrations (the earlier one on a tie).
pub(crate) fn deeper(a: Option<Penetration>, b: Option<Penetration>) -> Option<Penetration> {
    match (a, b) {
        (Some(a), Some(b)) if b.depth > a.depth => Some(b),
        (a, b) => a.or(b),
    }
}

impl Model {
    /// The particle of state `x` (step `step`) deepest in the colliders, exactly (branch and
    /// bound over the particles); `None` without colliders.
    pub(crate) fn penetration(&self, x: &Tensor, step: usize) -> Option<Penetration> {
        if self.colliders.is_empty() {
            return None;
        }
        let (distance, particle) = crate::sdf::batch::deepest_particle(&self.colliders, x)?;
        Some(Penetration {
            depth: -distance,
            step,
            particle,
        })
    }
}
