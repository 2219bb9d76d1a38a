//! Compiling a scene into a [`Model`]: rest geometry, one constraint group per effect the scene
//! calls for (coloured into independent sets), colliders, self-collision, the safety field, the
//! task and the step solver.

use super::{ConstraintGroup, Model, TaskSpec};
use crate::constraint::{
    Collision, Constraint, DihedralBending, Distance, IsometricBending, MAX_ARITY,
};
use crate::contact::barrier::{Barrier, ColliderBarrier};
use crate::contact::edge_points::EdgeBarrier;
use crate::contact::friction::FrictionalContact;
use crate::contact::self_barrier::{PairKind, SelfBarrier};
use crate::contact::self_collision::SelfCollision;
use crate::contact::self_friction::SelfFriction;
use crate::contact::smooth_friction::FrictionParams;
use crate::error::ClothError;
use crate::newton::settings::{NewtonSettings, Solver};
use crate::newton::terms::Terms;
use crate::rollout::held_clearance::held_pairs;
use crate::rollout::strain::EdgeStrain;
use crate::scene::{
    BendingModel, ContactModel, Obstacle, Scene, SceneError, SolverKind, Stiffness,
};
use crate::sdf::rows::{ParticleSdf, ParticleSdfComponents};
use crate::sdf::{SignedDistance, Union};
use crate::xpbd::coloring::{greedy_coloring, independent_sets};
use crate::xpbd::projection::Projection;
use crate::xpbd::set::{Carry, ProjectionSet};
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tensor};
use nalgebra::Vector3;
use std::sync::Arc;

/// Default [`Model::checkpoint_budget`]: 32 MiB (`u_obstacle` steps fit whole up to a 20 × 20
/// mesh).
pub const DEFAULT_CHECKPOINT_BUDGET: usize = 32 << 20;

/// `½ k C²` of each constraint of a type.
struct Energy<C> {
    constraint: Arc<C>,
    stiffness: f64,
}

impl<C: Constraint> RowFn for Energy<C> {
    fn n_in(&self) -> usize {
        3 * C::ARITY
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let mut p = [Vector3::<R>::zeros(); MAX_ARITY];
        for (i, pi) in p.iter_mut().take(C::ARITY).enumerate() {
            *pi = Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        }
        let c = self.constraint.c(row, &p[..C::ARITY]);
        out[0] = c * c * (0.5 * self.stiffness);
    }
}

impl Model {
    /// Compiles a validated scene's built-in effects (everything but `custom_constraints`), the
    /// cloth at step 0 at `start` (particle order) or else at its rest shape. Under smooth contact
    /// every free particle of the rest shape within `d̂/2` of a collider (of a start, within
    /// `d̂/100`) is moved out to `d̂/2` ([`settle_start_outside`]); under Newton's self-contact step 0 must keep the cloth's parts
    /// farther apart than the thickness. [`Model::from_scene`] places the scene's initial state
    /// with it (`crate::start`).
    pub(crate) fn compile(scene: &Scene, start: Option<&[[f64; 3]]>) -> Result<Model, ClothError> {
        scene.validate()?;
        let mesh = scene.mesh();
        let rest_pos = scene.rest_positions();
        let n = rest_pos.len();
        let start_pos = start.unwrap_or(&rest_pos);
        let controls = scene.control_indices();
        let mut inv_mass = vec![1.0 / scene.cloth.particle_mass; n];
        for &c in &controls {
            inv_mass[c] = 0.0;
        }
        let g = scene.physics.gravity;
        let dt = scene.physics.dt;
        let gravity_step = (g != [0.0; 3]).then(|| g.map(|gi| 0.5 * gi * dt * dt));
        let task = &scene.task;
        let target_positions: Vec<f64> = scene.target_positions().into_iter().flatten().collect();
        let mut model = Model {
            start: Tensor::new(n, 3, start_pos.iter().flatten().copied().collect()),
            rest_shape: Tensor::new(n, 3, rest_pos.iter().flatten().copied().collect()),
            triangles: mesh.triangles().into(),
            inv_mass,
            controls: Arc::new(RowIndex::single(controls)),
            gravity_step,
            dt,
            iterations: scene.physics.iterations,
            groups: Vec::new(),
            safety: None,
            safety_components: None,
            safety_obstacles: Arc::new(Union::default()),
            colliders: Union::default(),
            task: TaskSpec {
                horizon: task.horizon,
                targets: Arc::new(RowIndex::single(scene.target_indices())),
                target_positions: Tensor::new(target_positions.len() / 3, 3, target_positions),
                alpha: task.alpha,
                beta: task.beta,
                delta: task.delta,
                limits: task.limits.clone(),
                tolerance: scene.tolerance(),
            },
            strain: None,
            held: None,
            checkpoint_budget: DEFAULT_CHECKPOINT_BUDGET,
            tapes: Default::default(),
            solver: scene.solver(),
            self_collision: None,
            contact_barrier: None,
            edge_barrier: None,
            self_barrier: None,
            start_report: None,
        };

        let edges = mesh.stretch_edges();
        let rest: Vec<f64> = edges
            .iter()
            .map(|&[i, j]| model.rest_distance(i, j))
            .collect();
        let mean_edge = rest.iter().sum::<f64>() / rest.len().max(1) as f64;
        let (strained, strain_rest): (Vec<[usize; 2]>, Vec<f64>) = edges
            .iter()
            .zip(&rest)
            .filter(|&(_, &l)| l > 0.0)
            .map(|(&e, &l)| (e, l))
            .unzip();
        if !strained.is_empty() {
            let f: Arc<dyn DynRowFn> = Arc::new(EdgeStrain { rest: strain_rest });
            model.strain = Some((f, Arc::new(RowIndex::new(2, flatten(&strained)))));
        }
        model.add_constraints(
            "stretch",
            Distance { rest },
            flatten(&edges),
            scene.material.stretch.value(),
        )?;
        if let Some(bending) = &scene.material.bending {
            let k = bending.stiffness.value();
            match bending.model {
                BendingModel::Distance => {
                    let pairs = mesh.bending_pairs();
                    let rest = pairs
                        .iter()
                        .map(|&[i, j]| model.rest_distance(i, j))
                        .collect();
                    model.add_constraints("bending", Distance { rest }, flatten(&pairs), k)?;
                }
                BendingModel::Dihedral => {
                    let quads = mesh.dihedral_quads();
                    let rest = quads
                        .iter()
                        .map(|q| DihedralBending::angle(&q.map(|p| model.rest_point(p))))
                        .collect();
                    model.add_constraints(
                        "bending",
                        DihedralBending { rest },
                        flatten(&quads),
                        k,
                    )?;
                }
                BendingModel::Isometric => {
                    let (bending, stencils) = isometric_bending(&model, &mesh.dihedral_quads())?;
                    model.add_constraints("bending", bending, flatten(&stencils), k)?;
                }
            }
        }
        let (colliders, safety) = split_obstacles(&scene.obstacles);
        if !colliders.is_empty() && scene.contact_model() == ContactModel::Smooth {
            model.colliders = colliders.clone();
            let barrier = collider_barrier(scene, mean_edge, colliders);
            // A rest shape lies on the surfaces it touches; a given start may already rest at the
            // barrier's height (below d̂/2), and only one nearer than d̂/100 is moved.
            let below = if start.is_some() { 0.01 } else { 0.5 };
            let named = scene.physics.contact.is_some();
            settle_start_outside(&mut model, &barrier, below, named)?;
            let rest: Vec<f64> = (edges.iter())
                .map(|&[i, j]| model.rest_distance(i, j))
                .collect();
            let free = |p: usize| model.inv_mass[p] > 0.0;
            let on_edges = EdgeBarrier::new(&barrier, &edges, &rest, free);
            if let Some(e) = &on_edges {
                check_edges_outside(&model, e)?;
            }
            model.edge_barrier = on_edges.map(Arc::new);
            model.contact_barrier = Some(Arc::new(barrier));
        } else if !colliders.is_empty() {
            let free: Vec<usize> = (0..n).filter(|&p| model.inv_mass[p] > 0.0).collect();
            model.colliders = colliders.clone();
            model.add_constraints(
                "collider",
                Collision { sdf: colliders },
                free.clone(),
                f64::INFINITY,
            )?;
            if let Some(friction) = FrictionalContact::from_obstacles(&scene.obstacles) {
                let group = model.groups.last_mut().expect("the collider group");
                group.sets = vec![friction.projection_set(free)];
            }
        }
        if let Some(sc) = &scene.physics.self_collision {
            let triangles = model.triangles.clone();
            let contacts = SelfCollision::new(sc.thickness, triangles, n);
            model.self_collision = Some(Arc::new(contacts.with_edge_edge(sc.edge_edge)));
            if scene.solver_kind() == SolverKind::Newton {
                let shape = barrier_shape(scene, mean_edge);
                let mut barrier = SelfBarrier::new(
                    sc.thickness,
                    shape,
                    scene.physics.dt * scene.physics.dt,
                    model.triangles.clone(),
                    model.rest_shape.data(),
                    &model.inv_mass,
                );
                barrier.friction = sc.friction.filter(|&mu| mu > 0.0).map(|mu| SelfFriction {
                    mu,
                    epsilon: friction_epsilon(scene, &shape),
                });
                check_start_apart(&model, &barrier, start.is_some())?;
                model.held = held_pairs(&barrier, model.controls.as_slice());
                model.self_barrier = Some(Arc::new(barrier));
            }
        }
        if !safety.is_empty() {
            let field = Arc::new(safety);
            let bound = f64::INFINITY;
            model.safety = Some(Arc::new(ParticleSdf {
                field: field.clone(),
                bound,
            }));
            model.safety_components = Some(Arc::new(ParticleSdfComponents {
                field: field.clone(),
                bound,
            }));
            model.safety_obstacles = field;
        }
        Ok(model)
    }

    fn rest_point(&self, p: usize) -> Vector3<f64> {
        let r = self.rest_shape.row(p);
        Vector3::new(r[0], r[1], r[2])
    }

    fn rest_distance(&self, i: usize, j: usize) -> f64 {
        (self.rest_point(i) - self.rest_point(j)).norm()
    }

    /// Adds constraints of type `C` to the sweep, after the existing groups.
    ///
    /// `particles` lists each constraint's `C::ARITY` particles, row-major; constraint `k` is
    /// evaluated as instance `k` of `constraint`. The constraints are greedily coloured into
    /// independent sets in the given order. `stiffness` is `k` (`f64::INFINITY` for rigid).
    pub fn add_constraints<C: Constraint>(
        &mut self,
        name: &str,
        constraint: C,
        particles: Vec<usize>,
        stiffness: f64,
    ) -> Result<(), ClothError> {
        let invalid = |reason: String| ClothError::InvalidConstraint {
            name: name.to_string(),
            reason,
        };
        if !(1..=MAX_ARITY).contains(&C::ARITY) {
            return Err(invalid(format!(
                "arity {} is outside 1..={MAX_ARITY}",
                C::ARITY
            )));
        }
        if particles.len() % C::ARITY != 0 {
            return Err(invalid(format!(
                "{} particle indices do not form groups of {}",
                particles.len(),
                C::ARITY
            )));
        }
        if let Some(&p) = particles.iter().find(|&&p| p >= self.n_particles()) {
            return Err(invalid(format!(
                "particle {p} out of range ({} particles)",
                self.n_particles()
            )));
        }
        if stiffness.is_nan() || stiffness <= 0.0 {
            return Err(invalid(format!(
                "stiffness must be positive, got {stiffness}"
            )));
        }
        let rows: Vec<&[usize]> = particles.chunks_exact(C::ARITY).collect();
        if let Some(k) = rows
            .iter()
            .position(|r| (1..r.len()).any(|i| r[..i].contains(&r[i])))
        {
            return Err(invalid(format!("constraint {k} names a particle twice")));
        }
        let compliance = Stiffness::from_value(stiffness).compliance(self.dt);
        if !compliance.is_finite() {
            return Err(invalid(format!(
                "stiffness {stiffness} is too small: its compliance 1/(k·dt²) is not finite"
            )));
        }
        let constraint = Arc::new(constraint);
        let colors = greedy_coloring(&rows, self.n_particles());
        let sets = independent_sets(&colors)
            .into_iter()
            .map(|members| {
                let idx: Vec<usize> = members
                    .iter()
                    .flat_map(|&k| rows[k].iter().copied())
                    .collect();
                let w = idx.iter().map(|&p| self.inv_mass[p]).collect();
                let projection = Projection::new(constraint.clone(), members, w, compliance);
                ProjectionSet {
                    projection: Arc::new(projection),
                    index: Arc::new(RowIndex::new(C::ARITY, idx)),
                    carry: Carry::Multiplier,
                }
            })
            .collect();
        let energy = (!C::INEQUALITY && stiffness.is_finite()).then(|| {
            let f: Arc<dyn DynRowFn> = Arc::new(Energy {
                constraint: constraint.clone(),
                stiffness,
            });
            (f, Arc::new(RowIndex::new(C::ARITY, particles.clone())))
        });
        self.groups.push(ConstraintGroup {
            name: name.to_string(),
            count: rows.len(),
            sets,
            energy,
            terms: Arc::new(Terms::new(constraint, particles, compliance)),
        });
        Ok(())
    }
}

fn flatten<const K: usize>(rows: &[[usize; K]]) -> Vec<usize> {
    rows.iter().flatten().copied().collect()
}

/// The barrier's shape with the scene's `physics.contact` settings or their defaults: `d̂` a
/// tenth of the stretch edges' mean rest length `mean_edge`, `κ` `m·|g|/d̂` (`m/Δt²` without
/// gravity).
fn barrier_shape(scene: &Scene, mean_edge: f64) -> Barrier {
    let spec = scene.physics.contact.as_ref();
    let d_hat = spec.and_then(|c| c.d_hat).unwrap_or(0.1 * mean_edge);
    let dt = scene.physics.dt;
    let g = scene
        .physics
        .gravity
        .iter()
        .map(|v| v * v)
        .sum::<f64>()
        .sqrt();
    let m = scene.cloth.particle_mass;
    let kappa = spec.and_then(|c| c.stiffness).unwrap_or(if g > 0.0 {
        m * g / d_hat
    } else {
        m / (dt * dt)
    });
    Barrier { d_hat, kappa }
}

/// Smooth friction's smoothing slip `ε`: `physics.contact.friction_epsilon`, else a tenth of
/// the barrier's reach.
fn friction_epsilon(scene: &Scene, barrier: &Barrier) -> f64 {
    (scene.physics.contact.as_ref())
        .and_then(|c| c.friction_epsilon)
        .unwrap_or(0.1 * barrier.d_hat)
}

/// The smooth contact potential of `colliders` with the scene's `physics.contact` settings or
/// their defaults ([`barrier_shape`]).
fn collider_barrier(scene: &Scene, mean_edge: f64, colliders: Union) -> ColliderBarrier {
    let barrier = barrier_shape(scene, mean_edge);
    let dt = scene.physics.dt;
    let mu = component_friction(&scene.obstacles);
    assert_eq!(
        mu.len(),
        colliders.component_count(),
        "a coefficient per primitive"
    );
    let friction = mu.iter().any(|&m| m > 0.0).then(|| FrictionParams {
        mu,
        epsilon: friction_epsilon(scene, &barrier),
    });
    ColliderBarrier {
        field: Arc::new(colliders),
        barrier,
        dt2: dt * dt,
        friction,
    }
}

/// The friction coefficient of every primitive of the colliders' union, in its component order
/// (each sphere of every sphere set, then planes, capsules, boxes and meshes, each in obstacle
/// order, as [`Union::extend`] appends them); 0 where an obstacle names none.
fn component_friction(obstacles: &[Obstacle]) -> Vec<f64> {
    let mut buckets: [Vec<f64>; 5] = Default::default();
    for o in obstacles.iter().filter(|o| o.role().is_collider()) {
        let mu = o.friction().unwrap_or(0.0);
        match o {
            Obstacle::Spheres(s) => buckets[0].extend(std::iter::repeat_n(mu, s.radii.len())),
            Obstacle::Plane(_) => buckets[1].push(mu),
            Obstacle::Capsule(_) => buckets[2].push(mu),
            Obstacle::Box(_) => buckets[3].push(mu),
            Obstacle::Mesh(_) => buckets[4].push(mu),
        }
    }
    buckets.concat()
}

impl Model {
    /// This model with the cloth at step 0 at `positions` (particle order) as given, no recipe
    /// and no settling, and a horizon of `horizon` steps: what a check simulates from a state
    /// the scene does not start in (where a task's targets settle, `clothopt::target_check`).
    /// Under smooth contact the free particles nearer a collider than `d̂/100` are moved out to
    /// `d̂/2`, as for a given start. Nothing else is checked: a state through itself or inside a
    /// collider fails when simulated.
    ///
    /// # Errors
    /// `positions` not one per particle, or a particle deeper in a collider than `d̂`.
    pub fn placed_at(&self, positions: &[[f64; 3]], horizon: usize) -> Result<Model, ClothError> {
        if positions.len() != self.n_particles() {
            return Err(SceneError::Invalid {
                field: "positions".into(),
                reason: format!(
                    "{} positions for {} particles",
                    positions.len(),
                    self.n_particles()
                ),
            }
            .into());
        }
        let mut model = self.clone();
        model.start = Tensor::new(positions.len(), 3, positions.concat());
        model.start_report = None;
        model.task.horizon = horizon;
        if let Some(barrier) = &self.contact_barrier {
            settle_start_outside(&mut model, barrier, 0.01, true)?;
        }
        Ok(model)
    }
}

/// Smooth contact: every free particle of step 0 that is nearer to the colliders than
/// `below · d̂` — on a surface, or inside by less than `d̂` — starts at `d̂/2` outside, moved along
/// the colliders' distance gradient (a cloth lying on a table under the rigid model lies at the
/// barrier's resting height under the smooth one: about `0.4–0.7 d̂`). The constraints' rest
/// lengths are those of the scene's geometry. A particle deeper inside is an error.
fn settle_start_outside(
    model: &mut Model,
    barrier: &ColliderBarrier,
    below: f64,
    named: bool,
) -> Result<(), ClothError> {
    let target = 0.5 * barrier.barrier.d_hat;
    for p in (0..model.n_particles()).filter(|&p| model.inv_mass[p] > 0.0) {
        let r = model.start.row(p);
        let mut q = Vector3::new(r[0], r[1], r[2]);
        let mut d = barrier.field.distance(&q);
        if d >= below * barrier.barrier.d_hat {
            continue;
        }
        if d <= -barrier.barrier.d_hat {
            return Err(SceneError::Invalid {
                field: "physics.contact.model".into(),
                reason: format!(
                    "the smooth contact model needs the cloth outside the colliders, but \
                     particle {p} at step 0 is {:e} inside a collider (more than \
                     physics.contact.d_hat {:e}); move the cloth or the colliders apart{}",
                    -d,
                    barrier.barrier.d_hat,
                    if named {
                        ""
                    } else {
                        " (the smooth model is Newton's default with colliders; \
                         physics.contact.model \"rigid\" projects the cloth out instead)"
                    }
                ),
            }
            .into());
        }
        // Newton's method on d(q) = d̂/2 along the gradient (exact in one step for a plane).
        for _ in 0..16 {
            let (dist, grad) = barrier.field.distance_gradient(&q);
            d = dist;
            if d >= target * (1.0 - 1e-12) {
                break;
            }
            q += grad * ((target - d) / grad.norm_squared().max(f64::MIN_POSITIVE));
        }
        if d <= 0.0 {
            return Err(SceneError::Invalid {
                field: "physics.contact.model".into(),
                reason: format!(
                    "particle {p} at step 0 could not be moved out of the colliders \
                     (signed distance {d:e}); move the cloth or the colliders apart"
                ),
            }
            .into());
        }
        model.start.row_mut(p).copy_from_slice(q.as_slice());
    }
    Ok(())
}

/// Smooth contact along the edges: step 0 must hold every edge outside the colliders narrower
/// than it (the barrier is infinite inside).
fn check_edges_outside(model: &Model, edges: &EdgeBarrier) -> Result<(), ClothError> {
    match edges.penetration(model.start.data()) {
        None => Ok(()),
        Some((point, distance)) => Err(SceneError::Invalid {
            field: "obstacles".into(),
            reason: format!(
                "the smooth contact model needs the cloth's edges outside the colliders \
                 narrower than them, but at step 0 the edge between particles {} and {} is \
                 {:e} inside one, {} of the way along it; move the cloth or the colliders apart",
                point.a, point.b, -distance, point.t
            ),
        }
        .into()),
    }
}

/// Self-contact under Newton: step 0 must hold every part of the cloth farther than the
/// thickness from every other (the barrier is infinite within it). `initial` says that step 0 is
/// the scene's `cloth.initial_state` (else its rest shape), for the error's field.
fn check_start_apart(
    model: &Model,
    barrier: &SelfBarrier,
    initial: bool,
) -> Result<(), ClothError> {
    match barrier.penetration(model.start.data()) {
        None => Ok(()),
        Some((pair, gap)) => {
            let (field, what, fix) = if initial {
                (
                    "cloth.initial_state",
                    "the initial state",
                    "give a start whose layers lie farther apart, or a smaller \
                     physics.self_collision.thickness",
                )
            } else {
                (
                    "physics.self_collision.thickness",
                    "the rest state",
                    "choose a thickness below the cloth's edge length",
                )
            };
            Err(SceneError::Invalid {
                field: field.into(),
                reason: format!(
                    "{what} has particles {:?} {:e} closer than the thickness {} (a {} pair); \
                     Newton's self-contact barrier needs them apart: {fix}",
                    pair.particles,
                    -gap,
                    barrier.thickness,
                    match pair.kind {
                        PairKind::PointTriangle => "vertex–triangle",
                        PairKind::EdgeEdge(_) => "edge–edge",
                    }
                ),
            }
            .into())
        }
    }
}

/// Splits a scene's obstacles into the physical colliders and the safety constraint's obstacles.
fn split_obstacles(obstacles: &[Obstacle]) -> (Union, Union) {
    let (mut colliders, mut safety) = (Union::default(), Union::default());
    for o in obstacles {
        let role = o.role();
        if role.is_collider() {
            colliders.extend(o.field());
        }
        if role.is_safety() {
            safety.extend(o.field());
        }
    }
    (colliders, safety)
}

impl Scene {
    /// The solver the scene's physics describe, with Newton's defaults filled in. Under smooth
    /// contact (and with self-contact, always smooth under Newton) a step is one solve from the
    /// previous state unless the scene asks for branch
    /// following (`load_halvings` defaults to 0): the step filter keeps that descent from
    /// crossing a surface, as IPC's incremental potential does, and the halvings multiplied the
    /// work by ~60 where the cloth settles on a table (docs/physics.md "Smooth contact").
    pub fn solver(&self) -> Solver {
        let physics = &self.physics;
        match self.solver_kind() {
            SolverKind::Xpbd => Solver::Xpbd,
            SolverKind::Newton => {
                let d = NewtonSettings::default();
                // Self-contact under Newton is a barrier too (`contact::self_barrier`).
                let smooth = self.contact_model() == ContactModel::Smooth
                    || physics.self_collision.is_some();
                let halvings = if smooth { 0 } else { d.load_halvings };
                Solver::Newton(NewtonSettings {
                    tolerance: physics.tolerance.unwrap_or(d.tolerance),
                    max_iterations: physics.max_newton_iterations.unwrap_or(d.max_iterations),
                    load_steps: physics.load_steps.unwrap_or(d.load_steps),
                    load_halvings: physics.load_halvings.unwrap_or(halvings),
                    linear_solver: physics.linear_solver.setting(),
                    shift_stalled: physics.shift_stalled.unwrap_or(d.shift_stalled),
                    predictor: physics.predictor.unwrap_or(d.predictor),
                    ..d
                })
            }
        }
    }
}

/// The isometric bending instances of `quads` (three per stencil, one per axis) and their
/// particles, from the rest positions: an error names the first stencil that is degenerate or
/// not flat at rest (the model's energy is the bending of a flat rest shape).
fn isometric_bending(
    model: &Model,
    quads: &[[usize; 4]],
) -> Result<(IsometricBending, Vec<[usize; 4]>), ClothError> {
    let mut bending = IsometricBending {
        weights: Vec::with_capacity(3 * quads.len()),
        axis: Vec::with_capacity(3 * quads.len()),
    };
    let mut stencils = Vec::with_capacity(3 * quads.len());
    let invalid = |reason: String| ClothError::InvalidConstraint {
        name: "bending".into(),
        reason,
    };
    for q in quads {
        let p = q.map(|i| model.rest_point(i));
        let w = IsometricBending::weights(&p).ok_or_else(|| {
            invalid(format!(
                "isometric bending: a triangle on edge ({}, {}) is degenerate at rest",
                q[0], q[1]
            ))
        })?;
        let angle = DihedralBending::angle(&p);
        if angle.abs() > 1e-6 {
            return Err(invalid(format!(
                "isometric bending needs a flat rest shape, but the triangles on edge ({}, {}) \
                 meet at {angle:.2e} rad from flat at rest (use the dihedral model)",
                q[0], q[1]
            )));
        }
        for axis in 0..3 {
            bending.weights.push(w);
            bending.axis.push(axis);
            stencils.push(*q);
        }
    }
    Ok((bending, stencils))
}
