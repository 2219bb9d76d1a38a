//! The safety field along each particle's straight motion between two states `a → b`: what a
//! robot executing the plan sweeps through between the steps.
//!
//! A continuous per-step safety row is a soft minimum over the step-only row's entries (every
//! particle's distance to every primitive at `b`) and, for each particle whose path comes within
//! `40/κ` of the smallest path minimum or enters a collider (the entries that carry weight, see
//! [`NEGLIGIBLE_WEIGHT_EXPONENT`]), its path's minimum to each primitive, at the primitive's own
//! minimizing point, minus its crossing depth for a box the path enters
//! ([`Union::segment_components`]): the sample that catches a dip between the steps. Which
//! particles those are changes with the states, but only entries of weight below `e^−40` come
//! and go, so the row moves by at most `N·e^−40/κ` there: continuous to rounding,
//! with the minima's exact derivatives. Keeping the step-end entries keeps each state linearized
//! in its own row even where a path's minimum is at its start (a primitive whose distance is flat
//! along the path, e.g. a gripper moving parallel to a box's face, has its minimum at either end).

use crate::model::Model;
use crate::rollout::cost::NEGLIGIBLE_WEIGHT_EXPONENT;
use crate::sdf::batch::{deepest_along_segments, segment_distances_near_min};
use crate::sdf::rows::{ParticleSdfComponents, SegmentSdf, SegmentSdfComponents};
use crate::sdf::Union;
use autodiff::{DynRowFn, RowIndex, Tape, Tensor, Var};
use std::sync::Arc;

impl Model {
    /// Records the entries of a continuous safety row for the step from `x_prev` to `x`, for a
    /// soft minimum of sharpness `kappa` (module docs): the step-end components of every
    /// particle (`N × primitives`) followed by the path components of the particles whose path
    /// comes near. `None` without safety obstacles.
    ///
    /// The entries of the particle whose path comes nearest include its path's minima, so the
    /// soft minimum lies below the smallest distance along every path (a feasible row is truly
    /// feasible).
    pub fn record_swept_components_for_soft_min(
        &self,
        tape: &mut Tape,
        x_prev: Var,
        x: Var,
        kappa: f64,
    ) -> Option<Var> {
        self.safety_components.as_ref()?;
        let field = &self.safety_obstacles;
        let band = NEGLIGIBLE_WEIGHT_EXPONENT / kappa;
        let paths = segment_distances_near_min(field, tape.value(x_prev), tape.value(x), band);
        // Paths into a collider too: a box's entry there is minus its crossing depth, which
        // can lie far below the path's minimum, so such an entry may carry weight.
        let near = paths.iter().copied().fold(f64::INFINITY, f64::min) + band;
        let swept: Vec<usize> = (0..paths.len())
            .filter(|&p| paths[p] <= near || paths[p] < 0.0)
            .collect();
        let ends: Arc<dyn DynRowFn> = Arc::new(ParticleSdfComponents {
            field: field.clone(),
            bound: near,
        });
        let mut parts = vec![tape.map_rows(&ends, x)];
        if !swept.is_empty() {
            let index = Arc::new(RowIndex::single(swept));
            let a = tape.gather(x_prev, &index);
            let b = tape.gather(x, &index);
            let ab = tape.concat_cols(&[a, b]);
            let f: Arc<dyn DynRowFn> = Arc::new(SegmentSdfComponents {
                field: field.clone(),
            });
            parts.push(tape.map_rows(&f, ab));
        }
        Some(tape.concat_rows(&parts))
    }

    /// Records `−Σᵢ relu(δ − mᵢ)`, `mᵢ` the smallest signed distance to the safety obstacles along
    /// particle `i`'s path from `x_prev` to `x` (minus its crossing depth for a box the path
    /// enters, [`Union::segment_distance_within`]): the paper's scalar safety term over the
    /// motion between the states (0 only when every path keeps `δ`). The distances are exact up
    /// to `δ` (a lower bound above it, where `relu` is 0 either way). `None` without safety
    /// obstacles.
    pub fn record_swept_safety(
        &self,
        tape: &mut Tape,
        x_prev: Var,
        x: Var,
        delta: f64,
    ) -> Option<Var> {
        self.safety.as_ref()?;
        let f: Arc<dyn DynRowFn> = Arc::new(SegmentSdf {
            field: self.safety_obstacles.clone(),
            bound: delta,
        });
        let ab = tape.concat_cols(&[x_prev, x]);
        let sdf = tape.map_rows(&f, ab);
        Some(Self::record_safety_of_sdf(tape, sdf, delta))
    }

    /// The smallest signed distance to the safety obstacles along any particle's straight path
    /// from `a` to `b`, and that particle (the first on a tie): bitwise
    /// [`Model::min_sdf_between`]. `None` without safety obstacles.
    pub fn deepest_between(&self, a: &Tensor, b: &Tensor) -> Option<(f64, usize)> {
        if self.safety_obstacles.is_empty() {
            return None;
        }
        deepest_along_segments(&self.safety_obstacles, a, b)
    }

    /// The colliders' primitives other than planes (spheres, capsules, boxes, meshes): what a
    /// gripper, which no collider moves, must keep out of beyond the linear plane rows.
    pub fn colliders_without_planes(&self) -> Union {
        Union {
            planes: Vec::new(),
            ..self.colliders.clone()
        }
    }
}
