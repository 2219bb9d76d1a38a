//! Smooth contact (`physics.contact.model = "smooth"`, `cloth/src/contact/barrier.rs`): the cloth
//! stays strictly outside planes, spheres, capsules, boxes and meshes, never passes through a thin
//! one, its implicit gradients match central differences, the loss is smooth in the controls
//! (finite-difference slopes agree with the gradient from 1e-8 to 1e-4), and a scene that names
//! the rigid model simulates bitwise as one that names none.

mod common;

use autodiff::Tensor;
use cloth::scene::{BoxSpec, ContactModel, Obstacle, ObstacleRole, SolverKind};
use cloth::sdf::SignedDistance;
use cloth::{Model, Scene};
use cloth::{NewtonSettings, Solver};
use common::{behind, plane, small_scene, BendKind};
use proptest::prelude::*;

/// A 5 × 5 cloth of side 1 (edges 0.25, so the default `d̂` is 0.025), T = 3, smooth contact with
/// `obstacles`: hanging (x ∈ [−0.5, 0.5], y = −1.5, z ∈ [1, 2]), or `flat` 0.01 above the plane
/// z = 0; gripped at two corners.
fn scene(obstacles: Vec<Obstacle>, flat: bool) -> Scene {
    let mut s = small_scene(5, 5, 3, 100, 2e3, BendKind::Distance(20.0));
    if flat {
        s.cloth.top_left = [-0.5, -0.5, 0.01];
        s.cloth.down = [0.0, 1.0, 0.0];
    }
    s.obstacles = obstacles;
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = common::contact_model(ContactModel::Smooth);
    s.validate().unwrap();
    s
}

fn newton_model(s: &Scene) -> Model {
    let mut m = Model::from_scene(s).unwrap();
    m.solver = Solver::Newton(NewtonSettings {
        tolerance: 1e-12,
        ..NewtonSettings::default()
    });
    m
}

/// Both grippers moving by `motion` every step, the first by `0.01` more along x (no mirror
/// symmetry).
fn controls(model: &Model, [dx, dy, dz]: [f64; 3]) -> Tensor {
    let mut u = model.zero_controls();
    for t in 0..model.task.horizon {
        u.row_mut(t)
            .copy_from_slice(&[dx + 0.01, dy, dz, dx, dy, dz]);
    }
    u
}

/// Drag the flat cloth along the floor and press it down.
const DRAG: [f64; 3] = [0.05, 0.03, -0.02];
/// Push the hanging cloth towards +y into an obstacle behind it.
const PUSH: [f64; 3] = [0.0, 0.2, 0.0];

/// Every case: (name, obstacle, flat, motion).
fn cases() -> Vec<(&'static str, Obstacle, bool, [f64; 3])> {
    let mut cases = vec![("plane", behind("plane", ObstacleRole::Collider), true, DRAG)];
    for kind in ["sphere", "capsule", "box", "mesh"] {
        cases.push((kind, behind(kind, ObstacleRole::Collider), false, PUSH));
    }
    cases
}

/// The smallest collider distance over every free particle of `states[1..]`.
fn clearance(model: &Model, states: &[Tensor]) -> f64 {
    let mut min = f64::INFINITY;
    for x in &states[1..] {
        for p in (0..model.n_particles()).filter(|&p| model.inv_mass[p] > 0.0) {
            let r = x.row(p);
            min = min.min(
                model
                    .colliders
                    .distance(&cloth::nalgebra::Vector3::new(r[0], r[1], r[2])),
            );
        }
    }
    min
}

/// Every collider kind, pressed on by the cloth, holds every particle strictly outside and
/// within the barrier's reach (the contact is active), and every step converges.
#[test]
fn every_collider_kind_holds_the_cloth_strictly_outside() {
    for (name, obstacle, flat, motion) in cases() {
        let s = scene(vec![obstacle], flat);
        let m = newton_model(&s);
        let d_hat = m.contact_barrier.as_ref().unwrap().barrier.d_hat;
        assert!(
            (0.025..0.036).contains(&d_hat),
            "a tenth of the mean edge length: {d_hat}"
        );
        assert!(m.group("collider").is_none(), "no rigid collider rows");
        let u = controls(&m, motion);
        let states = m.simulate(&u).unwrap();
        let min = clearance(&m, &states);
        eprintln!("{name}: smallest distance {min:e} (d̂ {d_hat})");
        assert!(
            min > 0.0,
            "{name}: a particle reached the surface ({min:e})"
        );
        assert!(
            min < 0.5 * d_hat,
            "{name}: the contact is not pressed ({min:e})"
        );
        common::assert_minimizers(&m, &states, &u);
    }
}

/// A 2 mm thick plate behind the hanging cloth, wider and taller than it, and a push of 0.5 per
/// step through it: the grippers (held particles) pass, but no cloth particle does; every one
/// stays on the near side, held off the plate by the barrier.
#[test]
fn a_thin_plate_is_not_tunnelled_through() {
    let plate = Obstacle::Box(BoxSpec {
        center: [0.0, -1.4, 1.5],
        half_extents: [0.7, 0.001, 0.7],
        rotation: None,
        role: ObstacleRole::Collider,
        friction: None,
    });
    let s = scene(vec![plate], false);
    let m = newton_model(&s);
    let u = controls(&m, [0.0, 0.5, 0.0]);
    let states = m.simulate(&u).unwrap();
    let mut nearest = f64::INFINITY;
    for (t, x) in states.iter().enumerate() {
        for p in (0..m.n_particles()).filter(|&p| m.inv_mass[p] > 0.0) {
            let y = x.get(p, 1);
            assert!(
                y < -1.401,
                "step {t}: particle {p} at y = {y} passed the plate"
            );
            nearest = nearest.min(-1.401 - y);
        }
    }
    eprintln!("nearest particle {nearest:e} before the plate's face");
    assert!(clearance(&m, &states) > 0.0);
}

/// Naming no model is naming the default, bit for bit: the rigid one under XPBD, the smooth one
/// under Newton (the scene has a collider).
#[test]
fn naming_no_model_is_naming_the_default_bitwise() {
    for (solver, model) in [
        (SolverKind::Xpbd, ContactModel::Rigid),
        (SolverKind::Newton, ContactModel::Smooth),
    ] {
        let mut s = scene(vec![behind("box", ObstacleRole::Collider)], false);
        s.physics.solver = Some(solver);
        s.physics.contact = None;
        let plain = Model::from_scene(&s).unwrap();
        s.physics.contact = common::contact_model(model);
        let named = Model::from_scene(&s).unwrap();
        let u = controls(&plain, PUSH);
        let (a, b) = (plain.simulate(&u).unwrap(), named.simulate(&u).unwrap());
        for (x, y) in a.iter().zip(&b) {
            assert!(common::bitwise_eq(x, y), "{solver}");
        }
    }
}

/// `L` along a direction from a pressed contact: central differences at steps 1e-8 … 1e-4 agree
/// with the gradient's slope within 1e-3 relative for every collider kind (the rigid model's
/// kinks and jumps break this at contact).
#[test]
fn the_loss_is_smooth_in_the_controls() {
    for (name, obstacle, flat, motion) in cases() {
        let m = newton_model(&scene(vec![obstacle], flat));
        let u = controls(&m, motion);
        let e = m.evaluate(&u, 0.0, true).unwrap();
        let d = common::XorShift::new(7).direction(u.data().len());
        let slope = common::dot(e.grad_l.unwrap().data(), &d);
        let l = |v: &Tensor| m.evaluate(v, 0.0, false).unwrap().metrics.l;
        for h in [1e-8, 1e-7, 1e-6, 1e-5, 1e-4] {
            let fd = common::central(&l, &u, &d, h);
            let rel = (fd - slope).abs() / slope.abs();
            eprintln!("{name}: h {h:e}: slope {slope:e}, central difference {fd:e}, {rel:.1e}");
            assert!(
                rel <= 1e-3,
                "{name}: h {h:e}: {fd:e} vs {slope:e} ({rel:e})"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, .. ProptestConfig::default() })]

    /// `dL/dU` and `dC/dU` against central differences (step 1e-6) at controls jittered around
    /// a pressing motion, for every collider kind. Not 1e-5: near a contact the barrier's
    /// curvature gives that difference a truncation error of 1.4e-5 relative (the saved case;
    /// it falls as `h²`, to 1.4e-7 at 1e-6, measured).
    #[test]
    fn smooth_contact_gradients_match_central_differences(
        case in 0usize..5,
        jitter in proptest::collection::vec(-0.02f64..0.02, 18),
        seed in any::<u64>(),
    ) {
        let (_, obstacle, flat, motion) = cases().swap_remove(case);
        let m = newton_model(&scene(vec![obstacle], flat));
        let mut u = controls(&m, motion);
        for (v, j) in u.data_mut().iter_mut().zip(&jitter) {
            *v += j;
        }
        common::check_gradients_along_a_direction(&m, &u, seed, 0.0, 1e-6)?;
    }
}

/// A rest state lying on a collider starts at the barrier's resting height `d̂/2` (its free
/// particles; the grippers stay where the scene puts them) and simulates without entering it; one
/// deeper inside than `d̂` is rejected with the field and the particle named.
#[test]
fn a_rest_state_on_a_collider_starts_half_the_reach_above_it() {
    let mut s = scene(vec![behind("plane", ObstacleRole::Collider)], true);
    s.cloth.top_left[2] = 0.0;
    let m = newton_model(&s);
    let d_hat = m.contact_barrier.as_ref().unwrap().barrier.d_hat;
    for p in 0..m.n_particles() {
        let z = m.start.row(p)[2];
        let want = if m.inv_mass[p] > 0.0 {
            0.5 * d_hat
        } else {
            0.0
        };
        assert!(
            (z - want).abs() <= 1e-15,
            "particle {p}: z {z}, want {want}"
        );
    }
    let states = m.simulate(&m.zero_controls()).unwrap();
    let lowest = states
        .iter()
        .flat_map(|x| {
            (0..m.n_particles())
                .filter(|&p| m.inv_mass[p] > 0.0)
                .map(|p| x.row(p)[2])
        })
        .fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.0, "a particle reached the plane: z {lowest}");

    s.cloth.top_left[2] = -2.0 * d_hat;
    let err = Model::from_scene(&s).err().expect("rejected").to_string();
    assert!(
        err.starts_with("physics.contact.model: ")
            && err.contains("particle 1 at step 0 is")
            && err.contains("inside a collider")
            && !err.contains("  ")
            && !err.contains("default"),
        "{err}"
    );
    // Not named: the message says the model is the default and how to choose the rigid one.
    s.physics.contact = None;
    let err = Model::from_scene(&s).err().expect("rejected").to_string();
    assert!(err.contains("physics.contact.model \"rigid\""), "{err}");
}

/// A scene that names no contact model gets the smooth one under Newton when it has colliders,
/// and the rigid one otherwise (under XPBD, or without colliders: the latter keeps Newton's
/// branch following on by default).
#[test]
fn the_default_contact_model_is_smooth_under_newton_with_colliders() {
    let mut s = scene(vec![behind("plane", ObstacleRole::Collider)], true);
    s.physics.contact = None;
    assert_eq!(s.contact_model(), ContactModel::Smooth);
    assert!(Model::from_scene(&s).unwrap().contact_barrier.is_some());
    s.physics.solver = Some(SolverKind::Xpbd);
    assert_eq!(s.contact_model(), ContactModel::Rigid);
    let mut free = scene(vec![behind("sphere", ObstacleRole::Safety)], true);
    free.physics.contact = None;
    assert_eq!(free.contact_model(), ContactModel::Rigid);
    let Solver::Newton(settings) = free.solver() else {
        panic!("Newton")
    };
    assert_eq!(
        settings.load_halvings,
        NewtonSettings::default().load_halvings
    );
}

/// `½gΔt²` of the scenes (`g = 9.8`, `Δt = 0.1`).
const HALF_G_DT2: f64 = 0.5 * 9.8 * 0.01;

/// A `5 × 5` cloth (side 0.4, no grippers) lying `gap` above a plane through the origin tilted by
/// `theta` about the y axis, with friction `mu`, smooth contact, `horizon` steps.
fn tilted(theta: f64, mu: f64, horizon: usize) -> Scene {
    let mut s = scene(vec![], false);
    s.cloth.rows = 5;
    s.cloth.cols = 5;
    s.task.horizon = horizon;
    let (downhill, normal) = (
        [theta.cos(), 0.0, -theta.sin()],
        [theta.sin(), 0.0, theta.cos()],
    );
    let gap = 0.005;
    s.cloth.top_left = normal.map(|v| gap * v);
    s.cloth.right = downhill.map(|v| 0.4 * v);
    s.cloth.down = [0.0, 0.4, 0.0];
    s.controls.clear();
    s.task.targets.truncate(1);
    s.task.targets[0].particle = [0, 0].into();
    s.obstacles = vec![Obstacle::Plane(cloth::scene::PlaneSpec {
        point: [0.0; 3],
        normal,
        role: ObstacleRole::Collider,
        friction: Some(mu),
    })];
    s.validate().unwrap();
    s
}

/// The mean downhill displacement of the cloth's particles per step after the first two (the
/// first step lifts the cloth from its initial gap to where the barrier holds its weight, and the
/// second lags the friction's normal force there).
fn steady_slide(s: &Scene, theta: f64) -> f64 {
    let m = newton_model(s);
    let states = m.simulate(&m.zero_controls()).unwrap();
    let (first, last) = (&states[2], states.last().unwrap());
    let downhill = [theta.cos(), 0.0, -theta.sin()];
    let n = first.rows();
    (0..n)
        .map(|p| {
            (0..3)
                .map(|k| (last.get(p, k) - first.get(p, k)) * downhill[k])
                .sum::<f64>()
        })
        .sum::<f64>()
        / (n * (states.len() - 3)) as f64
}

/// On a plane tilted by θ = 0.3 (tan θ = 0.31) with μ = 0.6 the cloth holds: it creeps by less
/// than half the smoothing displacement ε per step (measured 0.3 ε; `ε tan θ/(2μ)` in theory),
/// where frictionless it slides `½gΔt² sin θ` = 17 ε per step. At θ = 30° with μ = 0.2 it slides
/// by `½gΔt²(sin θ − μ cos θ)` per step within 0.1% (measured: 0.016013 against 0.016013).
#[test]
fn friction_holds_below_tan_theta_and_slides_by_the_coulomb_amount_above() {
    let steps = 10;
    let theta = 0.3;
    let s = tilted(theta, 0.6, steps);
    let held = steady_slide(&s, theta);
    let eps = newton_model(&s)
        .contact_barrier
        .as_ref()
        .unwrap()
        .friction
        .as_ref()
        .unwrap()
        .epsilon;
    let free_slide = HALF_G_DT2 * theta.sin();
    eprintln!("held: {held:e} per step (ε {eps:e}, frictionless {free_slide:e})");
    assert!(held.abs() <= 0.5 * eps, "{held} vs ε {eps}");

    let theta = std::f64::consts::FRAC_PI_6;
    let mu = 0.2;
    let slid = steady_slide(&tilted(theta, mu, steps), theta);
    let expected = HALF_G_DT2 * (theta.sin() - mu * theta.cos());
    eprintln!("slid: {slid:e} per step, Coulomb {expected:e}");
    assert!(
        (slid - expected).abs() <= 1e-3 * expected,
        "{slid} vs {expected}"
    );
}

/// With friction on the floor, a dragged cloth's gradients match central differences (the
/// friction's dependence on the step's start included).
#[test]
fn smooth_friction_gradients_match_central_differences() {
    for (mu, seed) in [(0.3, 1u64), (1.5, 2)] {
        let mut s = scene(vec![behind("plane", ObstacleRole::Collider)], true);
        let cloth::scene::Obstacle::Plane(p) = &mut s.obstacles[0] else {
            unreachable!()
        };
        p.friction = Some(mu);
        s.validate().unwrap();
        let m = newton_model(&s);
        assert!(m.contact_barrier.as_ref().unwrap().friction.is_some());
        let u = controls(&m, DRAG);
        common::check_gradients_along_a_direction(&m, &u, seed, 0.0, 1e-5)
            .unwrap_or_else(|e| panic!("μ {mu}: {e}"));
    }
}

/// Under smooth contact a Newton step is one solve from the previous state unless the scene names
/// `physics.load_halvings`; the rigid model keeps branch following by default.
#[test]
fn smooth_contact_steps_are_one_solve_unless_the_scene_names_halvings() {
    let halvings = |s: &Scene| match Model::from_scene(s).unwrap().solver {
        Solver::Newton(settings) => settings.load_halvings,
        Solver::Xpbd => unreachable!(),
    };
    let mut s = scene(
        vec![plane(
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            ObstacleRole::Collider,
        )],
        true,
    );
    assert_eq!(halvings(&s), 0);
    s.physics.load_halvings = Some(3);
    assert_eq!(halvings(&s), 3);
    s.physics.load_halvings = None;
    s.physics.contact = None;
    assert_eq!(halvings(&s), 0, "the default model under Newton is smooth");
    s.physics.contact = common::contact_model(ContactModel::Rigid);
    assert_eq!(halvings(&s), NewtonSettings::default().load_halvings);
}
