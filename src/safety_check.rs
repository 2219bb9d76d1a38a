//! The verdict's safety checks beyond the optimizer's rows, on the re-simulated rollout of a
//! plan: what a robot executing it would sweep through.
//!
//! - *Continuous check* (the default; [`TaskOptions::swept`]): the straight motion of every
//!   particle between consecutive steps keeps `δ` from the safety obstacles, within
//!   [`SAFETY_TOLERANCE`]; each path's minimum is exact for spheres, planes, capsules and boxes
//!   and a lower bound for meshes ([`cloth::sdf::SignedDistance::segment_min`]). A particle whose
//!   rest state already lies within `δ` ([`start_inside_margin`]) counts from its step-1 state:
//!   no plan can move where the cloth starts, and step 0 is judged on its own.
//! - *Surface*: no safety obstacle cuts into the cloth's surface (its triangles: a thin obstacle
//!   can pass between particles that all keep `δ`) by more than [`SURFACE_TOLERANCE`], at the
//!   steps and, under the continuous check, swept between them (a certified minimum,
//!   [`cloth::sdf::surface::surface_minimum`]). A rest state the obstacles already cut is judged
//!   from its step-1 state, as the particles are.
//! - *Layers* (with self-collision): no vertex nearer than half the thickness to a triangle
//!   outside its 1-ring at a step, and no vertex–triangle or edge–edge pair passing through
//!   each other between the steps ([`cloth::crossings`]).
//! - *Grippers*: no gripper inside a collider (by more than the feasibility tolerance), at the
//!   steps and, under the continuous check, on its motion between them. Grippers have infinite
//!   mass, so no collider pushes them out.
//! - *Penetration*: no particle inside a collider at a step by more than the feasibility
//!   tolerance (`metrics.max_penetration`).
//!
//! Each failure is a sentence in [`SafetyReport::failures`]; a plan with any is not safe.

use crate::problem::{start_inside_margin, TaskOptions};
use crate::result::{
    GripperClearance, LayerClearance, LayerPair, MotionCheck, PathMinimum, SafetyReport,
    SurfaceClearance, SAFETY_TOLERANCE, SURFACE_TOLERANCE,
};
use autodiff::Tensor;
use cloth::nalgebra::Vector3;
use cloth::sdf::surface::surface_minimum;
use cloth::sdf::SignedDistance;
use cloth::{Metrics, Model, Penetration};

/// The safety report of a rollout `states` (with its `metrics`) planned with `task`: the checks
/// of the module docs, failures beyond `tol_feasibility` for the colliders and
/// [`SAFETY_TOLERANCE`] for the margin.
pub fn check_safety(
    model: &Model,
    states: &[Tensor],
    metrics: &Metrics,
    task: &TaskOptions,
    tol_feasibility: f64,
) -> SafetyReport {
    let check = if task.swept {
        MotionCheck::Continuous
    } else {
        MotionCheck::StepOnly
    };
    let mut failures = Vec::new();
    let between_steps = task
        .swept
        .then(|| between_steps(model, states, task.delta))
        .flatten();
    if let Some(m) = between_steps {
        if m.distance < task.delta - SAFETY_TOLERANCE {
            failures.push(format!(
                "between steps {} and {} particle {} comes to {:.4} of the safety obstacles{}, inside δ = {}",
                m.step - 1,
                m.step,
                m.particle,
                m.distance,
                if m.distance < 0.0 { " (inside one)" } else { "" },
                task.delta
            ));
        }
    }
    let surface = surface(model, states, task.swept, task.delta);
    if let Some(s) = surface {
        if s.distance < -SURFACE_TOLERANCE {
            let when = when(task.swept, s.step);
            failures.push(format!(
                "a safety obstacle passes through the cloth {when}: {:.4} deep into triangle {}, between its particles",
                -s.distance, s.triangle
            ));
        }
    }
    let layers = layers(model, states);
    if let (Some(sc), Some(l)) = (&model.self_collision, layers) {
        if let Some(p) = too_near(sc.thickness, &l) {
            failures.push(format!(
                "the cloth's layers come {:.4} apart at step {} (vertex {}, triangle {}), less than half the thickness {}",
                p.distance, p.step, p.vertex, p.triangle, sc.thickness
            ));
        }
        if let Some(step) = l.first_crossing_step {
            failures.push(format!(
                "the cloth passes through itself between steps {} and {} ({} crossing pairs in all)",
                step - 1,
                step,
                l.crossings
            ));
        }
    }
    let grippers = grippers(model, states, task.swept);
    if let Some(g) = grippers {
        if g.distance < -tol_feasibility {
            let when = when(task.swept, g.step);
            failures.push(format!(
                "gripper {} goes {:.4} inside the colliders {when}",
                g.gripper, -g.distance
            ));
        }
    }
    if let Some(p) = penetrating(model, metrics, tol_feasibility) {
        failures.push(format!(
            "particle {} is {:.4} inside the colliders at step {}",
            p.particle, p.depth, p.step
        ));
    }
    SafetyReport {
        check,
        between_steps,
        surface,
        layers,
        grippers,
        failures,
    }
}

/// Under XPBD, a hint for a plan whose rollout leaves contacts unresolved — the cloth's layers
/// within half the thickness or passing through each other, or particles inside the colliders by
/// more than `tol_feasibility` (the failures of `report` and `metrics` that [`check_safety`]
/// names): XPBD projects contacts and self-collision a fixed number of sweeps per step, so some
/// stay unresolved whatever the controls, while Newton's contact and self-contact barriers keep
/// every iterate apart. `None` under Newton, without such failures, or where Newton cannot solve
/// the model.
pub fn physics_hint(
    model: &Model,
    report: &SafetyReport,
    metrics: &Metrics,
    tol_feasibility: f64,
) -> Option<String> {
    if !matches!(model.solver, cloth::Solver::Xpbd) || model.supports_newton().is_err() {
        return None;
    }
    let layers = match (&model.self_collision, &report.layers) {
        (Some(sc), Some(l)) => {
            l.first_crossing_step.is_some() || too_near(sc.thickness, l).is_some()
        }
        _ => false,
    };
    let colliders = penetrating(model, metrics, tol_feasibility).is_some();
    let what = match (layers, colliders) {
        (true, true) => "the cloth's layers and the colliders",
        (true, false) => "the cloth's layers",
        (false, true) => "the colliders",
        (false, false) => return None,
    };
    Some(format!(
        "XPBD (this scene's physics) projects contacts a fixed number of sweeps per step and leaves some unresolved whatever the controls, here against {what}; Newton physics (--physics newton, or physics.solver \"newton\" in the scene) keeps the cloth apart with contact barriers and may give a safe plan"
    ))
}

/// The layers' nearest pair when it is nearer than half the `thickness` (the layer check's
/// failure at a step).
fn too_near(thickness: f64, layers: &LayerClearance) -> Option<LayerPair> {
    layers.nearest.filter(|p| p.distance < 0.5 * thickness)
}

/// The deepest particle inside the colliders when it is deeper than `tol_feasibility` and not a
/// gripper (the penetration check's failure).
fn penetrating(model: &Model, metrics: &Metrics, tol_feasibility: f64) -> Option<Penetration> {
    metrics
        .max_penetration
        .filter(|p| p.depth > tol_feasibility && !model.controls.as_slice().contains(&p.particle))
}

/// The smallest signed distance to the safety obstacles along every particle's straight motion
/// between consecutive states (module docs); `None` without safety obstacles.
fn between_steps(model: &Model, states: &[Tensor], delta: f64) -> Option<PathMinimum> {
    let inside = start_inside_margin(model, delta);
    let mut best: Option<PathMinimum> = None;
    for t in 1..states.len() {
        let start = if t == 1 && !inside.is_empty() {
            let mut a = states[0].clone();
            for &p in &inside {
                a.row_mut(p).copy_from_slice(states[1].row(p));
            }
            a
        } else {
            states[t - 1].clone()
        };
        let (distance, particle) = model.deepest_between(&start, &states[t])?;
        if best.is_none_or(|b| distance < b.distance) {
            best = Some(PathMinimum {
                distance,
                step: t,
                particle,
            });
        }
    }
    best
}

/// When a finding at step `step` happened: on the motion from the step before under the
/// continuous check (`swept`), at the step otherwise.
fn when(swept: bool, step: usize) -> String {
    if swept {
        format!("between steps {} and {}", step - 1, step)
    } else {
        format!("at step {step}")
    }
}

/// The cloth's surface nearest to the safety obstacles (module docs); `None` without them.
fn surface(model: &Model, states: &[Tensor], swept: bool, delta: f64) -> Option<SurfaceClearance> {
    const TOL: f64 = SURFACE_TOLERANCE;
    let field = &model.safety_obstacles;
    // The rest state alone: the step-only check of a one-step "rollout" that stays there.
    let rest = vec![states.first()?.clone(); 2];
    let rest_cut = surface_minimum(field, &model.triangles, &rest, (false, false), 0.0, TOL)
        .is_some_and(|m| m.value < -TOL);
    let m = surface_minimum(
        field,
        &model.triangles,
        states,
        (swept, rest_cut),
        delta,
        TOL,
    )?;
    // Within the tolerance of the minimum, unless the search ran out of boxes first: then its
    // certified bound, which is what the check may promise.
    let certified = m.value - m.lower <= TOL;
    Some(SurfaceClearance {
        distance: if m.value < delta && certified {
            m.value
        } else {
            m.lower
        },
        step: m.step,
        triangle: m.triangle,
    })
}

/// The cloth's nearest layers at the steps and its crossings between them (module docs); `None`
/// without self-collision.
fn layers(model: &Model, states: &[Tensor]) -> Option<LayerClearance> {
    let thickness = model.self_collision.as_ref()?.thickness;
    let mut out = LayerClearance::default();
    for t in 1..states.len() {
        if let Some(g) = model.layer_gap(&states[t], thickness) {
            if out.nearest.is_none_or(|p| g.distance < p.distance) {
                out.nearest = Some(LayerPair {
                    distance: g.distance,
                    step: t,
                    vertex: g.vertex,
                    triangle: g.triangle,
                });
            }
        }
        let c = cloth::crossings(&model.triangles, &states[t - 1], &states[t]);
        let count = c.vertex_triangle.len() + c.edge_edge.len();
        if count > 0 && out.first_crossing_step.is_none() {
            out.first_crossing_step = Some(t);
        }
        out.crossings += count;
    }
    Some(out)
}

/// The gripper nearest to the colliders (all of them, planes included) at the steps and, when
/// `swept`, on its straight motion from the step before (from its step-1 position for a gripper
/// that starts inside one); `None` without colliders.
fn grippers(model: &Model, states: &[Tensor], swept: bool) -> Option<GripperClearance> {
    let field = &model.colliders;
    if field.is_empty() {
        return None;
    }
    let mut best: Option<GripperClearance> = None;
    for (gripper, &p) in model.controls.as_slice().iter().enumerate() {
        let at = |t: usize| Vector3::from_fn(|j, _| states[t].get(p, j));
        let starts_inside = field.distance(&at(0)) < 0.0;
        for t in 1..states.len() {
            let distance = if swept && !(t == 1 && starts_inside) {
                field.min_along_segment(&at(t - 1), &at(t))
            } else {
                field.distance(&at(t))
            };
            if best.is_none_or(|b| distance < b.distance) {
                best = Some(GripperClearance {
                    distance,
                    step: t,
                    gripper,
                });
            }
        }
    }
    best
}
