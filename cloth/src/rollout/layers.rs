//! How close a self-colliding cloth's layers come: the verdict's check that the cloth neither
//! passes through itself nor presses its layers closer than half its thickness.

use crate::contact::distance::PointTriangle;
use crate::model::Model;
use autodiff::Tensor;
use nalgebra::Vector3;

/// The nearest vertex–triangle pair of a state outside each other's 1-ring (the pairs the
/// self-collision acts on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerGap {
    /// Their unsigned distance (length units).
    pub distance: f64,
    /// The vertex (particle index).
    pub vertex: usize,
    /// The triangle (index into the cloth's triangles).
    pub triangle: usize,
}

impl Model {
    /// The nearest vertex–triangle pair of state `x` among those within `reach` (the 1-ring and
    /// pairs of two fixed parts left out, as the self-collision's pair search does; the first
    /// pair on a tie). `None` without self-collision or when no pair is that near.
    pub fn layer_gap(&self, x: &Tensor, reach: f64) -> Option<LayerGap> {
        let sc = self.self_collision.as_ref()?;
        let point = |p: usize| Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2));
        let mut best: Option<LayerGap> = None;
        for pair in sc.find_pairs(x, reach, &self.inv_mass) {
            let [a, b, c] = self.triangles[pair.triangle].map(point);
            let distance = PointTriangle::distance(&point(pair.vertex), [&a, &b, &c]);
            if distance <= reach && best.is_none_or(|g| distance < g.distance) {
                best = Some(LayerGap {
                    distance,
                    vertex: pair.vertex,
                    triangle: pair.triangle,
                });
            }
        }
        best
    }
}
