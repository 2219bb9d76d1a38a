//! Scene validation: every bad value is rejected with the path of its field.

use super::format::*;
use super::obstacles::*;
use super::{invalid, Scene, SceneError, MAX_COORDINATE, MAX_HORIZON, MAX_PARTICLES};
use crate::geometry::{cross, norm3, unit};

fn counted(n: usize, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

pub(super) fn check_finite(field: &str, x: f64) -> Result<(), SceneError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(invalid(field, format!("must be finite, got {x}")))
    }
}

/// Finite, with magnitude at most [`MAX_COORDINATE`].
pub(super) fn check_coordinate(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x.abs() <= MAX_COORDINATE {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("magnitude {x:e} exceeds the limit of {MAX_COORDINATE:e}"),
        ))
    }
}

pub(super) fn check_vec3(field: &str, v: &[f64; 3]) -> Result<(), SceneError> {
    for (k, &x) in v.iter().enumerate() {
        check_coordinate(&format!("{field}[{k}]"), x)?;
    }
    Ok(())
}

pub(super) fn check_positive(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x > 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be positive, got {x}")))
    }
}

pub(super) fn check_non_negative(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x >= 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be non-negative, got {x}")))
    }
}

/// `physics.contact`: a positive, bounded `d_hat` and a positive `stiffness`, both only for the
/// smooth model, which needs Newton's method.
fn validate_contact(c: &ContactSpec, solver: SolverKind) -> Result<(), SceneError> {
    if let Some(d) = c.d_hat {
        check_positive("physics.contact.d_hat", d)?;
        check_coordinate("physics.contact.d_hat", d)?;
    }
    if let Some(k) = c.stiffness {
        check_positive("physics.contact.stiffness", k)?;
    }
    if let Some(e) = c.friction_epsilon {
        check_positive("physics.contact.friction_epsilon", e)?;
        check_coordinate("physics.contact.friction_epsilon", e)?;
    }
    match c.model {
        ContactModel::Rigid => {
            let only_smooth = |field: &str| {
                invalid(
                    field,
                    "only the smooth contact model has a barrier; remove it or set \
                     physics.contact.model to \"smooth\"",
                )
            };
            if c.d_hat.is_some() {
                return Err(only_smooth("physics.contact.d_hat"));
            }
            if c.stiffness.is_some() {
                return Err(only_smooth("physics.contact.stiffness"));
            }
            if c.friction_epsilon.is_some() {
                return Err(only_smooth("physics.contact.friction_epsilon"));
            }
        }
        ContactModel::Smooth if solver != SolverKind::Newton => {
            return Err(invalid(
                "physics.contact.model",
                "the smooth contact model is a potential in Newton's energy: it needs \
                 physics.solver \"newton\"",
            ));
        }
        ContactModel::Smooth => {}
    }
    Ok(())
}

/// `friction`: finite and ≥ 0, and only on an obstacle the simulator collides with.
fn validate_friction(base: &str, obstacle: &Obstacle) -> Result<(), SceneError> {
    let Some(mu) = obstacle.friction() else {
        return Ok(());
    };
    let field = format!("{base}.friction");
    check_non_negative(&field, mu)?;
    if !obstacle.role().is_collider() {
        return Err(invalid(
            field,
            "friction acts only on a physical collider; use role \"collider\" or \"both\", \
             or remove it",
        ));
    }
    Ok(())
}

fn check_stiffness(field: &str, k: &Stiffness) -> Result<(), SceneError> {
    match *k {
        Stiffness::Infinite => Ok(()),
        Stiffness::Finite(x) if x.is_finite() && x > 0.0 => Ok(()),
        Stiffness::Finite(x) => Err(invalid(
            field,
            format!("must be a positive finite number or \"inf\", got {x}"),
        )),
    }
}

impl Scene {
    /// Checks every value; the first problem found is returned as [`SceneError::Invalid`] naming the field.
    ///
    /// Rejects: non-finite numbers anywhere; length-like values (coordinates, vector components,
    /// radii, `delta`) beyond [`MAX_COORDINATE`] in magnitude; `rows`/`cols` of 0 or more than
    /// [`MAX_PARTICLES`] particles; a zero `right` (when `cols > 1`) or `down` (when `rows > 1`), or
    /// parallel `right` and `down`; `particle_mass ≤ 0` or so small that its inverse overflows;
    /// non-positive stiffness, or one so small that the compliance `1/(k·dt²)` overflows; `dt ≤ 0`, or
    /// `dt²` not a normal number up to [`MAX_COORDINATE`]; `iterations = 0`; control particles
    /// out of range or repeated; sphere sets that are empty, whose radii and centres differ in number, or
    /// with a radius `≤ 0`; a zero plane normal; `horizon` of 0 or above [`MAX_HORIZON`]; no targets, a
    /// target out of range or repeated; negative `alpha`, `beta`, `delta`; initial controls of the wrong
    /// shape. No control particles at all is allowed.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.validate_cloth()?;
        self.validate_initial_state()?;
        self.validate_material()?;
        self.validate_physics()?;
        self.validate_controls()?;
        self.validate_obstacles()?;
        self.validate_task()?;
        self.validate_custom_constraints()
    }

    fn validate_cloth(&self) -> Result<(), SceneError> {
        let c = &self.cloth;
        if c.is_mesh() {
            self.validate_cloth_mesh()?;
            return self.validate_particle_mass();
        }
        if c.rows == 0 {
            return Err(invalid("cloth.rows", "must be at least 1, got 0"));
        }
        if c.cols == 0 {
            return Err(invalid("cloth.cols", "must be at least 1, got 0"));
        }
        match c.rows.checked_mul(c.cols) {
            Some(n) if n <= MAX_PARTICLES => {}
            _ => {
                return Err(invalid(
                    "cloth",
                    format!(
                        "{} × {} particles exceed the limit of {MAX_PARTICLES}",
                        c.rows, c.cols
                    ),
                ))
            }
        }
        check_vec3("cloth.top_left", &c.top_left)?;
        check_vec3("cloth.right", &c.right)?;
        check_vec3("cloth.down", &c.down)?;
        let (ur, ud) = (unit(&c.right), unit(&c.down));
        if c.cols > 1 && ur.is_none() {
            return Err(invalid(
                "cloth.right",
                format!("zero-length vector, but cloth.cols = {} > 1", c.cols),
            ));
        }
        if c.rows > 1 && ud.is_none() {
            return Err(invalid(
                "cloth.down",
                format!("zero-length vector, but cloth.rows = {} > 1", c.rows),
            ));
        }
        if let (true, true, Some(ur), Some(ud)) = (c.rows > 1, c.cols > 1, ur, ud) {
            // sine of the angle between right and down
            if norm3(&cross(&ur, &ud)) <= 1e-9 {
                return Err(invalid(
                    "cloth.down",
                    "parallel to cloth.right (the cloth would be degenerate)",
                ));
            }
        }
        self.validate_particle_mass()
    }

    /// A mesh cloth: read, within the particle and coordinate limits.
    fn validate_cloth_mesh(&self) -> Result<(), SceneError> {
        let file = self.cloth.mesh.as_deref().unwrap_or_default();
        let Some(mesh) = &self.cloth.mesh_data else {
            return Err(invalid(
                "cloth.mesh",
                format!(
                    "`{file}` has not been read (Scene::load and Scene::from_json_str read it; \
                     a scene built in code calls Scene::load_files)"
                ),
            ));
        };
        if mesh.vertices.len() > MAX_PARTICLES {
            return Err(invalid(
                "cloth.mesh",
                format!(
                    "{} vertices exceed the limit of {MAX_PARTICLES}",
                    mesh.vertices.len()
                ),
            ));
        }
        for (v, p) in mesh.vertices.iter().enumerate() {
            check_vec3(&format!("cloth.mesh (`{file}` vertex {})", v + 1), p)?;
        }
        Ok(())
    }

    fn validate_particle_mass(&self) -> Result<(), SceneError> {
        let c = &self.cloth;
        check_positive("cloth.particle_mass", c.particle_mass)?;
        if !(1.0 / c.particle_mass).is_finite() {
            return Err(invalid(
                "cloth.particle_mass",
                format!("{:e} is too small: its inverse overflows", c.particle_mass),
            ));
        }
        Ok(())
    }

    fn validate_material(&self) -> Result<(), SceneError> {
        check_stiffness("material.stretch", &self.material.stretch)?;
        if let Some(b) = &self.material.bending {
            check_stiffness("material.bending.stiffness", &b.stiffness)?;
        }
        Ok(())
    }

    fn validate_physics(&self) -> Result<(), SceneError> {
        let p = &self.physics;
        check_positive("physics.dt", p.dt)?;
        let dt2 = p.dt * p.dt;
        if !(dt2.is_normal() && dt2 <= MAX_COORDINATE) {
            return Err(invalid(
                "physics.dt",
                format!(
                    "{:e} is out of range: dt² must be a normal number at most {MAX_COORDINATE:e}",
                    p.dt
                ),
            ));
        }
        check_vec3("physics.gravity", &p.gravity)?;
        if p.iterations == 0 {
            return Err(invalid("physics.iterations", "must be at least 1, got 0"));
        }
        if let Some(tol) = p.tolerance {
            check_finite("physics.tolerance", tol)?;
            if !(tol > 0.0 && tol < 1.0) {
                return Err(invalid(
                    "physics.tolerance",
                    format!("must be in (0, 1), got {tol}"),
                ));
            }
        }
        if p.load_steps == Some(0) {
            return Err(invalid("physics.load_steps", "must be at least 1, got 0"));
        }
        if let Some(h) = p.load_halvings {
            let max = super::format::MAX_LOAD_HALVINGS;
            if h > max {
                return Err(invalid(
                    "physics.load_halvings",
                    format!("must be at most {max}, got {h}"),
                ));
            }
        }
        if p.max_newton_iterations == Some(0) {
            return Err(invalid(
                "physics.max_newton_iterations",
                "must be at least 1, got 0",
            ));
        }
        if let Some(sc) = &p.self_collision {
            check_non_negative("physics.self_collision.thickness", sc.thickness)?;
            if let Some(mu) = sc.friction {
                check_non_negative("physics.self_collision.friction", mu)?;
                let choice = self.physics_choice();
                if mu > 0.0 && choice.solver != SolverKind::Newton {
                    return Err(invalid(
                        "physics.self_collision.friction",
                        format!(
                            "cloth–cloth friction is a potential of Newton's method, but this \
                             scene runs XPBD ({})",
                            choice.reason.describe()
                        ),
                    ));
                }
            }
        }
        if let Some(c) = &p.contact {
            validate_contact(c, self.solver_kind())?;
        }
        if self.solver_kind() == SolverKind::Newton {
            self.validate_newton()?;
        }
        // The XPBD compliance α̃ = 1/(k·dt²) must be a finite number (a projection divides by it).
        let mut stiffnesses = vec![("material.stretch", self.material.stretch)];
        if let Some(b) = &self.material.bending {
            stiffnesses.push(("material.bending.stiffness", b.stiffness));
        }
        for (field, k) in stiffnesses {
            let compliance = k.compliance(p.dt);
            if !compliance.is_finite() {
                return Err(invalid(
                    field,
                    format!(
                        "{:e} is too small for physics.dt = {:e}: the compliance 1/(k·dt²) overflows",
                        k.value(),
                        p.dt
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Newton's method needs a finite energy: no rigid material (colliders are contact rows,
    /// solved by its active set, or a barrier; self-collision is a barrier).
    fn validate_newton(&self) -> Result<(), SceneError> {
        let rigid = "is rigid (infinite stiffness), which physics.solver \"newton\" does not \
                     support; give it a finite stiffness or use \"xpbd\"";
        if self.material.stretch == Stiffness::Infinite {
            return Err(invalid("material.stretch", rigid));
        }
        if let Some(b) = &self.material.bending {
            if b.stiffness == Stiffness::Infinite {
                return Err(invalid("material.bending.stiffness", rigid));
            }
        }
        let smooth = self.contact_model() == ContactModel::Smooth;
        if let Some(i) = (!smooth)
            .then(|| self.obstacles.iter().position(|o| o.friction().is_some()))
            .flatten()
        {
            return Err(invalid(
                format!("obstacles[{i}].friction"),
                "friction under physics.solver \"newton\" needs the smooth contact model \
                 (physics.contact.model \"smooth\"); remove it, use that model, or use \
                 physics.solver \"xpbd\"",
            ));
        }
        Ok(())
    }

    /// Checks that a particle reference lies on the cloth and has its kind: `[row, col]` on a
    /// grid, a vertex index on a mesh cloth.
    pub(super) fn check_particle(
        &self,
        field: &str,
        particle: ParticleRef,
    ) -> Result<(), SceneError> {
        match (particle, self.cloth.is_mesh()) {
            (ParticleRef::Grid([r, c]), false) => {
                if r >= self.cloth.rows {
                    return Err(invalid(
                        field,
                        format!("row {r} out of range (cloth.rows = {})", self.cloth.rows),
                    ));
                }
                if c >= self.cloth.cols {
                    return Err(invalid(
                        field,
                        format!("col {c} out of range (cloth.cols = {})", self.cloth.cols),
                    ));
                }
                Ok(())
            }
            (ParticleRef::Vertex(v), true) => {
                let n = self.n_particles();
                if v >= n {
                    return Err(invalid(
                        field,
                        format!("vertex {v} out of range (cloth.mesh has {n} vertices, 0-based)"),
                    ));
                }
                Ok(())
            }
            (ParticleRef::Grid([r, c]), true) => Err(invalid(
                field,
                format!("[{r}, {c}] is a grid particle, but the cloth is a mesh (cloth.mesh): name a vertex index"),
            )),
            (ParticleRef::Vertex(v), false) => Err(invalid(
                field,
                format!("{v} is a vertex index, but the cloth is a grid: name the particle as [row, col]"),
            )),
        }
    }

    fn validate_controls(&self) -> Result<(), SceneError> {
        for (i, &particle) in self.controls.iter().enumerate() {
            let field = format!("controls[{i}]");
            self.check_particle(&field, particle)?;
            if let Some(j) = self.controls[..i].iter().position(|&o| o == particle) {
                return Err(invalid(
                    field,
                    format!("particle {particle} duplicates controls[{j}]"),
                ));
            }
        }
        Ok(())
    }

    fn validate_obstacles(&self) -> Result<(), SceneError> {
        for (i, obstacle) in self.obstacles.iter().enumerate() {
            let base = format!("obstacles[{i}]");
            match obstacle {
                Obstacle::Spheres(s) => {
                    if s.centers.is_empty() {
                        return Err(invalid(
                            format!("{base}.centers"),
                            "a sphere set needs at least one sphere",
                        ));
                    }
                    if s.radii.len() != s.centers.len() {
                        return Err(invalid(
                            format!("{base}.radii"),
                            format!(
                                "{} radii for {} centers (need one radius per center)",
                                s.radii.len(),
                                s.centers.len()
                            ),
                        ));
                    }
                    for (j, c) in s.centers.iter().enumerate() {
                        check_vec3(&format!("{base}.centers[{j}]"), c)?;
                    }
                    for (j, &r) in s.radii.iter().enumerate() {
                        check_positive(&format!("{base}.radii[{j}]"), r)?;
                        check_coordinate(&format!("{base}.radii[{j}]"), r)?;
                    }
                }
                Obstacle::Capsule(c) => {
                    check_vec3(&format!("{base}.a"), &c.a)?;
                    check_vec3(&format!("{base}.b"), &c.b)?;
                    check_positive(&format!("{base}.radius"), c.radius)?;
                    check_coordinate(&format!("{base}.radius"), c.radius)?;
                }
                Obstacle::Box(b) => {
                    check_vec3(&format!("{base}.center"), &b.center)?;
                    for (k, &h) in b.half_extents.iter().enumerate() {
                        check_positive(&format!("{base}.half_extents[{k}]"), h)?;
                        check_coordinate(&format!("{base}.half_extents[{k}]"), h)?;
                    }
                    if let Some(q) = &b.rotation {
                        for (k, &x) in q.iter().enumerate() {
                            check_coordinate(&format!("{base}.rotation[{k}]"), x)?;
                        }
                        let m = q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                        if m == 0.0 {
                            return Err(invalid(
                                format!("{base}.rotation"),
                                "zero quaternion; give [w, x, y, z] of nonzero length",
                            ));
                        }
                    }
                }
                Obstacle::Mesh(m) => {
                    if m.surface.is_none() {
                        return Err(invalid(
                            format!("{base}.file"),
                            format!(
                                "`{}` has not been read (Scene::load and Scene::from_json_str read it; \
                                 a scene built in code calls Scene::load_files)",
                                m.file
                            ),
                        ));
                    }
                }
                Obstacle::Plane(p) => {
                    check_vec3(&format!("{base}.point"), &p.point)?;
                    check_vec3(&format!("{base}.normal"), &p.normal)?;
                    if unit(&p.normal).is_none() {
                        return Err(invalid(
                            format!("{base}.normal"),
                            "zero vector; a plane needs a nonzero normal",
                        ));
                    }
                }
            }
            validate_friction(&base, obstacle)?;
        }
        Ok(())
    }

    fn validate_task(&self) -> Result<(), SceneError> {
        let t = &self.task;
        if t.horizon == 0 {
            return Err(invalid("task.horizon", "must be at least 1, got 0"));
        }
        if t.horizon > MAX_HORIZON {
            return Err(invalid(
                "task.horizon",
                format!("{} exceeds the limit of {MAX_HORIZON}", t.horizon),
            ));
        }
        if t.target_mesh.is_some() {
            self.validate_target_mesh()?;
        } else if t.targets.is_empty() {
            return Err(invalid("task.targets", "at least one target is required"));
        }
        for (i, target) in t.targets.iter().enumerate() {
            let field = format!("task.targets[{i}].particle");
            self.check_particle(&field, target.particle)?;
            if let Some(j) = t.targets[..i]
                .iter()
                .position(|o| o.particle == target.particle)
            {
                return Err(invalid(
                    field,
                    format!("particle {} duplicates task.targets[{j}]", target.particle),
                ));
            }
            check_vec3(&format!("task.targets[{i}].position"), &target.position)?;
        }
        check_non_negative("task.alpha", t.alpha)?;
        check_non_negative("task.beta", t.beta)?;
        check_non_negative("task.delta", t.delta)?;
        check_coordinate("task.delta", t.delta)?;
        if let Some(tol) = t.tolerance {
            if !(tol.is_finite() && tol > 0.0) {
                return Err(invalid(
                    "task.tolerance",
                    format!("must be a finite number > 0, got {tol}"),
                ));
            }
            check_coordinate("task.tolerance", tol)?;
        }
        let m = self.controls.len();
        match &t.initial_controls {
            InitialControls::Zeros => {}
            InitialControls::Constant(v) => {
                let field = "task.initial_controls.constant";
                if v.len() != m {
                    return Err(invalid(
                        field,
                        format!(
                            "{} given, need one per control particle ({m})",
                            counted(v.len(), "vector", "vectors")
                        ),
                    ));
                }
                for (k, u) in v.iter().enumerate() {
                    check_vec3(&format!("{field}[{k}]"), u)?;
                }
            }
            InitialControls::Explicit(steps) => {
                let field = "task.initial_controls.explicit";
                if steps.len() != t.horizon {
                    return Err(invalid(
                        field,
                        format!(
                            "{} given, need task.horizon = {}",
                            counted(steps.len(), "step", "steps"),
                            t.horizon
                        ),
                    ));
                }
                for (s, step) in steps.iter().enumerate() {
                    if step.len() != m {
                        return Err(invalid(
                            format!("{field}[{s}]"),
                            format!(
                                "{} given, need one per control particle ({m})",
                                counted(step.len(), "vector", "vectors")
                            ),
                        ));
                    }
                    for (k, u) in step.iter().enumerate() {
                        check_vec3(&format!("{field}[{s}][{k}]"), u)?;
                    }
                }
            }
        }
        self.validate_limits()
    }

    /// `task.target_mesh`: only on a mesh cloth, in place of `task.targets`, read, finite.
    fn validate_target_mesh(&self) -> Result<(), SceneError> {
        let t = &self.task;
        let file = t.target_mesh.as_deref().unwrap_or_default();
        if !self.cloth.is_mesh() {
            return Err(invalid(
                "task.target_mesh",
                "needs a mesh cloth (cloth.mesh) whose topology it shares; a grid names targets in task.targets",
            ));
        }
        if !t.targets.is_empty() {
            return Err(invalid(
                "task.targets",
                "give either task.targets or task.target_mesh (every vertex of it is a target), not both",
            ));
        }
        let Some(vertices) = &t.target_mesh_data else {
            return Err(invalid(
                "task.target_mesh",
                format!(
                    "`{file}` has not been read (Scene::load and Scene::from_json_str read it; \
                     a scene built in code calls Scene::load_files)"
                ),
            ));
        };
        if vertices.len() != self.n_particles() {
            return Err(invalid(
                "task.target_mesh",
                format!(
                    "`{file}` has {} vertices, the cloth has {}",
                    vertices.len(),
                    self.n_particles()
                ),
            ));
        }
        for (v, p) in vertices.iter().enumerate() {
            check_vec3(&format!("task.target_mesh (`{file}` vertex {})", v + 1), p)?;
        }
        Ok(())
    }
}
