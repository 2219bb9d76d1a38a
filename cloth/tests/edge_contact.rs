//! Smooth contact along the edges (`cloth/src/contact/edge_points.rs`): a rail narrower than the
//! cloth's edges catches the cloth instead of passing between its particles, every edge point
//! stays strictly outside it, the states are minimizers, the implicit gradients match central
//! differences, and scenes without a narrow collider get no points.

mod common;

use autodiff::Tensor;
use cloth::scene::{BoxSpec, CapsuleSpec, ContactModel, Obstacle, ObstacleRole, SolverKind};
use cloth::sdf::SignedDistance;
use cloth::{Model, NewtonSettings, Scene, Solver};
use common::{small_scene, BendKind};
use proptest::prelude::*;

/// Steps: enough for the cloth to follow its grippers past the rail.
const HORIZON: usize = 8;
/// The rail's height: between the hanging cloth's rows at z = 1.5 and 1.25.
const RAIL_Z: f64 = 1.375;
/// The rail's axis lies this far along y (the cloth hangs at y = −1.5).
const RAIL_Y: f64 = -1.44;

/// The 5 × 5 hanging cloth of side 1 (edges 0.25, diagonals 0.35; x ∈ [−0.5, 0.5], y = −1.5,
/// z ∈ [1, 2]), T = [`HORIZON`], smooth contact, with a horizontal rail 4 cm across (`radius` 0.02) in
/// front of it, between two rows of particles, with friction `mu` on the rail.
fn scene_with(mu: Option<f64>) -> Scene {
    let mut s = small_scene(5, 5, HORIZON, 100, 2e3, BendKind::Distance(20.0));
    s.obstacles = vec![Obstacle::Capsule(CapsuleSpec {
        a: [-1.0, RAIL_Y, RAIL_Z],
        b: [1.0, RAIL_Y, RAIL_Z],
        radius: 0.02,
        role: ObstacleRole::Collider,
        friction: mu,
    })];
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = common::contact_model(ContactModel::Smooth);
    s.validate().unwrap();
    s
}

/// The frictionless rail.
fn scene() -> Scene {
    scene_with(None)
}

fn newton_model(s: &Scene) -> Model {
    let mut m = Model::from_scene(s).unwrap();
    m.solver = Solver::Newton(NewtonSettings {
        tolerance: 1e-12,
        ..NewtonSettings::default()
    });
    m
}

/// Both grippers carried over the rail (+y, 0.1 per step; the second 0.01 less, no symmetry).
fn over_the_rail(model: &Model) -> Tensor {
    let mut u = model.zero_controls();
    for t in 0..model.task.horizon {
        u.row_mut(t)
            .copy_from_slice(&[0.0, 0.1, 0.0, 0.0, 0.09, 0.0]);
    }
    u
}

/// The free particles below the rail: their largest y at the last state.
fn lowest_rows_front(model: &Model, x: &Tensor) -> f64 {
    (0..model.n_particles())
        .filter(|&p| model.inv_mass[p] > 0.0 && x.get(p, 2) < RAIL_Z - 0.05)
        .map(|p| x.get(p, 1))
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Without edge points the rail passes between the rows and the whole cloth is carried past it
/// (the rows below it end in front of its axis); with them the rail catches the cloth: the rows
/// below hang behind it, and every edge point of every state stays strictly outside.
#[test]
fn a_rail_narrower_than_the_edges_catches_the_cloth() {
    let m = newton_model(&scene());
    let edges = m
        .edge_barrier
        .clone()
        .expect("edge points against the rail");
    assert_eq!(edges.spacing, 0.02, "half the rail's width");
    let u = over_the_rail(&m);

    let mut particles_only = m.clone();
    particles_only.edge_barrier = None;
    let passed = particles_only.simulate(&u).unwrap();
    let front = lowest_rows_front(&m, passed.last().unwrap());
    eprintln!("particles only: the lower rows end at y = {front}");
    assert!(front > RAIL_Y + 0.05, "the cloth passes the rail: {front}");

    let states = m.simulate(&u).unwrap();
    let behind = lowest_rows_front(&m, states.last().unwrap());
    eprintln!("with edge points: the lower rows end at y = {behind}");
    assert!(
        behind < RAIL_Y - 0.02,
        "the rail holds the lower rows: {behind}"
    );
    let mut nearest = f64::INFINITY;
    for x in &states[1..] {
        for p in &edges.points {
            let q = p.position(x.data());
            let d = (edges.barrier.field).distance(&cloth::nalgebra::Vector3::from(q));
            nearest = nearest.min(d);
        }
    }
    let d_hat = edges.barrier.barrier.d_hat;
    eprintln!("nearest edge point {nearest:e} (d̂ {d_hat:e})");
    assert!(
        nearest > 0.0 && nearest < d_hat,
        "pressed, outside: {nearest:e}"
    );
    common::assert_minimizers(&m, &states, &u);
}

/// A scene whose colliders are all wider than its edges has no edge points.
#[test]
fn no_points_without_a_narrow_collider() {
    let mut s = scene();
    if let Obstacle::Capsule(c) = &mut s.obstacles[0] {
        (c.radius, c.a[1], c.b[1]) = (0.2, -1.0, -1.0);
    }
    assert!(Model::from_scene(&s).unwrap().edge_barrier.is_none());
}

/// A start with an edge through the rail is refused, naming the edge.
#[test]
fn a_start_with_an_edge_through_the_rail_is_refused() {
    let mut s = scene();
    if let Obstacle::Capsule(c) = &mut s.obstacles[0] {
        c.a[1] = -1.5;
        c.b[1] = -1.5;
    }
    let Err(err) = Model::from_scene(&s) else {
        panic!("a start through the rail was accepted");
    };
    let err = err.to_string();
    assert!(
        err.contains("obstacles") && err.contains("edge between particles"),
        "{err}"
    );
}

/// A `5 × 5` cloth (side 0.4, edges 0.1, no grippers) lying 5 mm above a plate 4 cm thick
/// (narrower than its edges) tilted by `theta` about the y axis, with friction `mu`.
fn on_a_tilted_plate(theta: f64, mu: f64, horizon: usize) -> Scene {
    let mut s = scene();
    s.task.horizon = horizon;
    let (downhill, normal) = (
        [theta.cos(), 0.0, -theta.sin()],
        [theta.sin(), 0.0, theta.cos()],
    );
    s.cloth.top_left = normal.map(|v| 0.005 * v);
    s.cloth.right = downhill.map(|v| 0.4 * v);
    s.cloth.down = [0.0, 0.4, 0.0];
    s.controls.clear();
    s.task.targets.truncate(1);
    s.task.targets[0].particle = [0, 0].into();
    let half = 0.5 * theta;
    s.obstacles = vec![Obstacle::Box(BoxSpec {
        center: normal.map(|v| -0.02 * v),
        half_extents: [1.0, 1.0, 0.02],
        rotation: Some([half.cos(), 0.0, half.sin(), 0.0]),
        role: ObstacleRole::Collider,
        friction: Some(mu),
    })];
    s.validate().unwrap();
    s
}

/// The cloth's mean downhill displacement per step after the first two (the first lifts it to
/// where the barrier holds its weight, the second lags the friction's normal force there).
fn steady_slide(m: &Model, theta: f64) -> f64 {
    let states = m.simulate(&m.zero_controls()).unwrap();
    let (first, last) = (&states[2], states.last().unwrap());
    let downhill = [theta.cos(), 0.0, -theta.sin()];
    let n = first.rows();
    let total: f64 = (0..n)
        .map(|p| {
            (0..3)
                .map(|k| (last.get(p, k) - first.get(p, k)) * downhill[k])
                .sum::<f64>()
        })
        .sum();
    total / (n * (states.len() - 3)) as f64
}

/// On a plate narrower than the cloth's edges, tilted by θ = 0.3 (tan θ = 0.31) with μ = 0.6,
/// the edge points carry part of the cloth's weight; rubbing as the particles do, they let it
/// hold (creeping less than half the smoothing displacement per step), where frictionless
/// points would let it slide.
#[test]
fn edge_points_on_a_narrow_plate_rub_as_the_particles_do() {
    let theta = 0.3;
    let m = newton_model(&on_a_tilted_plate(theta, 0.6, 10));
    let edges = m.edge_barrier.clone().expect("points against the plate");
    let eps = edges
        .barrier
        .friction
        .as_ref()
        .expect("the plate's friction")
        .epsilon;
    let held = steady_slide(&m, theta);
    let mut frictionless = m.clone();
    let mut points = (*edges).clone();
    points.barrier.friction = None;
    frictionless.edge_barrier = Some(std::sync::Arc::new(points));
    let slid = steady_slide(&frictionless, theta);
    eprintln!("rubbing points: {held:e} per step; frictionless points: {slid:e} (ε {eps:e})");
    assert!(held.abs() <= 0.5 * eps, "{held} vs ε {eps}");
    assert!(slid > 5.0 * eps, "frictionless points let it slide: {slid}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, .. ProptestConfig::default() })]

    /// `dL/dU` and `dC/dU` against central differences (step 1e-6, as for the particles'
    /// barrier) at controls jittered around the carry over the rail, where the edge points press
    /// on it, frictionless or rubbing (the friction's dependence on the step's start included).
    #[test]
    fn edge_contact_gradients_match_central_differences(
        jitter in proptest::collection::vec(-0.02f64..0.02, 6 * HORIZON),
        seed in any::<u64>(),
        mu in proptest::option::of(0.2f64..1.0),
    ) {
        let m = newton_model(&scene_with(mu));
        let mut u = over_the_rail(&m);
        for (v, j) in u.data_mut().iter_mut().zip(&jitter) {
            *v += j;
        }
        common::check_gradients_along_a_direction(&m, &u, seed, 0.0, 1e-6)?;
    }
}
