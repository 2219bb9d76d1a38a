//! Signed distance fields of obstacles: sphere sets and planes (positive outside).
//!
//! Written generically over [`Real`], so the same code serves the simulator's colliders, the
//! safety constraint and their derivatives. Conventions: at a sphere's centre the distance is
//! `−r` with gradient 0 (the norm's convention); on a tie between spheres, the first sphere wins.

use crate::constraint::norm;
use autodiff::Real;
use nalgebra::Vector3;

/// A signed distance field, generic over the scalar type.
pub trait SignedDistance: Send + Sync + 'static {
    /// Signed distance of `p` (negative inside).
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R;
}

/// A union of spheres: `min_s (|p − c_s| − r_s)`.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereSet {
    /// Centres.
    pub centers: Vec<[f64; 3]>,
    /// Radii, one per centre.
    pub radii: Vec<f64>,
}

impl SignedDistance for SphereSet {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let mut best: Option<R> = None;
        for (c, &r) in self.centers.iter().zip(&self.radii) {
            let d = p - Vector3::new(R::cst(c[0]), R::cst(c[1]), R::cst(c[2]));
            let s = norm(&d) - r;
            best = Some(match best {
                Some(b) => b.min(s),
                None => s,
            });
        }
        best.unwrap_or_else(|| R::cst(f64::INFINITY))
    }
}

/// A half-space boundary `n·(p − q) = 0` with unit normal `n` pointing to the free side.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: [f64; 3],
    /// Unit normal (towards the outside).
    pub normal: [f64; 3],
}

impl SignedDistance for Plane {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let n = self.normal;
        (p[0] - self.point[0]) * n[0]
            + (p[1] - self.point[1]) * n[1]
            + (p[2] - self.point[2]) * n[2]
    }
}

/// The union of several obstacles: the minimum of their signed distances (first wins a tie).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Union {
    /// Sphere sets.
    pub spheres: Vec<SphereSet>,
    /// Planes.
    pub planes: Vec<Plane>,
}

impl Union {
    /// True when the union holds no obstacle.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty() && self.planes.is_empty()
    }
}

impl SignedDistance for Union {
    fn distance<R: Real>(&self, p: &Vector3<R>) -> R {
        let mut best: Option<R> = None;
        let mut take = |s: R| {
            best = Some(match best {
                Some(b) => b.min(s),
                None => s,
            })
        };
        for s in &self.spheres {
            take(s.distance(p));
        }
        for pl in &self.planes {
            take(pl.distance(p));
        }
        best.unwrap_or_else(|| R::cst(f64::INFINITY))
    }
}
