//! The scene format's obstacles: safety margins and colliders (serde, unknown fields rejected).

use serde::{Deserialize, Serialize};

use crate::geometry::unit;

/// An obstacle; JSON objects tagged by `"type"`: `"spheres"`, `"plane"`, `"capsule"`, `"box"` or
/// `"mesh"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Obstacle {
    /// A union of spheres (`{"type": "spheres", "centers": [...], "radii": [...], "role": ...}`).
    Spheres(SphereSetSpec),
    /// A half-space bounded by a plane (`{"type": "plane", "point": [...], "normal": [...], "role": ...}`).
    Plane(PlaneSpec),
    /// A capsule (`{"type": "capsule", "a": [...], "b": [...], "radius": r, "role": ...}`).
    Capsule(CapsuleSpec),
    /// A box (`{"type": "box", "center": [...], "half_extents": [...], "rotation": [w, x, y, z], "role": ...}`).
    Box(BoxSpec),
    /// A closed triangle mesh read from an OBJ file (`{"type": "mesh", "file": "tool.obj", "role": ...}`).
    Mesh(MeshSpec),
}

impl Obstacle {
    /// How the obstacle is used.
    pub fn role(&self) -> ObstacleRole {
        match self {
            Obstacle::Spheres(s) => s.role,
            Obstacle::Plane(p) => p.role,
            Obstacle::Capsule(c) => c.role,
            Obstacle::Box(b) => b.role,
            Obstacle::Mesh(m) => m.role,
        }
    }

    /// Its JSON `"type"`: `spheres`, `plane`, `capsule`, `box` or `mesh`.
    pub fn kind(&self) -> &'static str {
        match self {
            Obstacle::Spheres(_) => "spheres",
            Obstacle::Plane(_) => "plane",
            Obstacle::Capsule(_) => "capsule",
            Obstacle::Box(_) => "box",
            Obstacle::Mesh(_) => "mesh",
        }
    }

    /// The friction coefficient `"friction"` as written (`None` when absent).
    pub fn friction(&self) -> Option<f64> {
        match self {
            Obstacle::Spheres(s) => s.friction,
            Obstacle::Plane(p) => p.friction,
            Obstacle::Capsule(c) => c.friction,
            Obstacle::Box(b) => b.friction,
            Obstacle::Mesh(m) => m.friction,
        }
    }

    /// Multiplies the friction coefficient by `factor` (nothing where none is written).
    pub fn scale_friction(&mut self, factor: f64) {
        let mu = match self {
            Obstacle::Spheres(s) => &mut s.friction,
            Obstacle::Plane(p) => &mut p.friction,
            Obstacle::Capsule(c) => &mut c.friction,
            Obstacle::Box(b) => &mut b.friction,
            Obstacle::Mesh(m) => &mut m.friction,
        };
        if let Some(mu) = mu {
            *mu *= factor;
        }
    }
}

/// The points within `radius` of the segment `a–b`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CapsuleSpec {
    /// One end of the axis.
    pub a: [f64; 3],
    /// The other end of the axis (may equal `a`: a sphere).
    pub b: [f64; 3],
    /// Radius (> 0).
    pub radius: f64,
    /// How the obstacle is used.
    pub role: ObstacleRole,
    /// Coulomb friction coefficient `μ ≥ 0` of a collider (absent: frictionless); see
    /// `cloth/src/contact/friction.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A box: centre, half extents along its axes, and an optional rotation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Centre.
    pub center: [f64; 3],
    /// Half extents along the box's own axes (each > 0).
    pub half_extents: [f64; 3],
    /// Rotation from the box's axes to the world as a quaternion `[w, x, y, z]` (any nonzero
    /// length; normalised). Default: axis-aligned.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f64; 4]>,
    /// How the obstacle is used.
    pub role: ObstacleRole,
    /// Coulomb friction coefficient `μ ≥ 0` of a collider (absent: frictionless); see
    /// `cloth/src/contact/friction.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A closed triangle mesh from a Wavefront OBJ file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// The OBJ file, relative to the scene file (or to the working directory for a scene given as
    /// text). It must be a closed, consistently oriented triangle mesh.
    pub file: String,
    /// How the obstacle is used.
    pub role: ObstacleRole,
    /// Coulomb friction coefficient `μ ≥ 0` of a collider (absent: frictionless); see
    /// `cloth/src/contact/friction.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// The field read from `file` when the scene was loaded ([`crate::Scene::load`]); `None` until then.
    #[serde(skip)]
    pub surface: Option<crate::sdf::MeshSdf>,
}

/// A union of spheres; its signed distance is `min_s (|x − c_s| − r_s)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSetSpec {
    /// Sphere centres.
    pub centers: Vec<[f64; 3]>,
    /// Sphere radii (one per centre, each > 0).
    pub radii: Vec<f64>,
    /// How the obstacle is used.
    pub role: ObstacleRole,
    /// Coulomb friction coefficient `μ ≥ 0` of a collider (absent: frictionless); see
    /// `cloth/src/contact/friction.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A plane through `point`; the free side is the one `normal` points to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    /// A point on the plane.
    pub point: [f64; 3],
    /// Normal pointing to the free side, as written in the file (any nonzero length);
    /// use [`PlaneSpec::normalized`] for the unit normal.
    pub normal: [f64; 3],
    /// How the obstacle is used.
    pub role: ObstacleRole,
    /// Coulomb friction coefficient `μ ≥ 0` of a collider (absent: frictionless); see
    /// `cloth/src/contact/friction.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

impl PlaneSpec {
    /// The unit normal `normal/|normal|`. Validation guarantees `normal` is finite and nonzero; for an
    /// unvalidated zero or non-finite normal the result is NaN.
    pub fn normalized(&self) -> [f64; 3] {
        unit(&self.normal).unwrap_or([f64::NAN; 3])
    }
}

/// How an obstacle takes part in the problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObstacleRole {
    /// Only a safety constraint for the optimizer (not simulated). JSON `"safety"`.
    Safety,
    /// A physical collider projected by the simulator (not a safety constraint). JSON `"collider"`.
    Collider,
    /// Both a safety constraint and a physical collider. JSON `"both"`.
    Both,
}

impl ObstacleRole {
    /// True if the optimizer treats the obstacle as a safety constraint (`safety` or `both`).
    pub fn is_safety(&self) -> bool {
        matches!(self, ObstacleRole::Safety | ObstacleRole::Both)
    }

    /// True if the simulator projects particles out of the obstacle (`collider` or `both`).
    pub fn is_collider(&self) -> bool {
        matches!(self, ObstacleRole::Collider | ObstacleRole::Both)
    }
}
