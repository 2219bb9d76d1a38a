//! A step's self-contact colour sets: the pairs found at the step's start (vertex–triangle, then
//! edge–edge when asked for) turned into colour sets projected after the model's own.

use crate::contact::edge_edge::EdgePair;
use crate::contact::self_collision::ContactPair;
use crate::geometry::norm;
use crate::model::Model;
use crate::xpbd::set::ProjectionSet;
use autodiff::Tensor;
use nalgebra::Vector3;

impl Model {
    /// The query radius of a step with controls `u` (`n_controls × 3`): `h + 2δ`, `δ` the largest
    /// control displacement plus the gravity step (see `cloth/src/contact/self_collision.rs`).
    pub fn contact_radius(&self, thickness: f64, u: &Tensor) -> f64 {
        let fastest = (0..u.rows())
            .map(|k| norm(&Vector3::new(u.get(k, 0), u.get(k, 1), u.get(k, 2))))
            .fold(0.0, f64::max);
        let fall = self
            .gravity_step
            .map_or(0.0, |g| norm(&Vector3::new(g[0], g[1], g[2])));
        thickness + 2.0 * (fastest + fall)
    }

    /// The self-contact pairs of a step from `x_prev` with controls `u` (empty without
    /// `physics.self_collision`).
    pub fn contact_pairs(&self, x_prev: &Tensor, u: &Tensor) -> Vec<ContactPair> {
        match &self.self_collision {
            None => Vec::new(),
            Some(sc) => sc.find_pairs(x_prev, self.contact_radius(sc.thickness, u), &self.inv_mass),
        }
    }

    /// The edge–edge pairs of a step from `x_prev` with controls `u`, given its vertex–triangle
    /// pairs `held` (empty unless `physics.self_collision.edge_edge`).
    pub fn edge_pairs(&self, x_prev: &Tensor, u: &Tensor, held: &[ContactPair]) -> Vec<EdgePair> {
        match &self.self_collision {
            Some(sc) if sc.edge_edge => {
                let radius = self.contact_radius(sc.thickness, u);
                sc.find_edge_pairs(x_prev, radius, &self.inv_mass, held)
            }
            _ => Vec::new(),
        }
    }

    /// The colour sets of a step's self-contacts, projected after the model's own sets: the
    /// vertex–triangle sets, then the edge–edge ones (none without `physics.self_collision`).
    pub fn contact_sets(&self, x_prev: &Tensor, u: &Tensor) -> Vec<ProjectionSet> {
        let Some(sc) = &self.self_collision else {
            return Vec::new();
        };
        let pairs = self.contact_pairs(x_prev, u);
        let mut sets = sc.projection_sets(&pairs, &self.inv_mass);
        let edges = self.edge_pairs(x_prev, u, &pairs);
        sets.extend(sc.edge_projection_sets(&edges, &self.inv_mass));
        sets
    }
}
