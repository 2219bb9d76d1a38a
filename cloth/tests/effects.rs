//! A scene compiles to the effects it calls for, and absent effects cost nothing: shown by the
//! compiled model's groups, projection counts and colour sets, and by the number of nodes a
//! recorded step puts on the tape.
//!
//! A recorded step (`Model::record_step`, with the caller's two leaves `x_prev` and `u`) has
//! `2 + [2 if gravity] + [3 if controls] + S + 2·iterations·S` nodes for `S` colour sets: gravity is
//! a leaf and an add, the controls a gather, an add and a row assignment, each set one `λ` leaf and
//! per iteration one update node plus its carried `λ`.

mod common;

use autodiff::{Tape, Tensor};
use cloth::scene::{Bending, BendingModel, ObstacleRole, Stiffness};
use cloth::{Model, Scene};
use common::{plane, spheres};

/// One `record_step` on a fresh tape (with its two leaves).
fn recorded_step(model: &Model) -> Tape {
    let mut tape = Tape::new();
    let x = tape.leaf(model.start.clone());
    let u = tape.leaf(Tensor::zeros(model.n_controls(), 3));
    model.record_step(&mut tape, x, u);
    tape
}

/// Nodes recorded by one `record_step` (including the two leaves).
fn step_nodes(model: &Model) -> usize {
    recorded_step(model).len()
}

/// Bytes held by one recorded step.
fn step_bytes(model: &Model) -> usize {
    recorded_step(model).memory_bytes()
}

fn model(scene: &Scene) -> Model {
    scene.validate().unwrap();
    Model::from_scene(scene).unwrap()
}

/// `(count, sets)` of a group.
fn group(model: &Model, name: &str) -> Option<(usize, usize)> {
    model.group(name).map(|g| (g.count, g.sets.len()))
}

#[test]
fn ten_by_ten_has_261_stretch_and_225_bending_in_6_plus_6_sets() {
    let m = model(&Scene::builtin("u_obstacle").unwrap());
    assert_eq!(group(&m, "stretch"), Some((261, 6)));
    assert_eq!(group(&m, "bending"), Some((225, 6)));
    let names: Vec<&str> = m.groups.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["stretch", "bending"]);
    assert_eq!(m.projections_per_iteration(), 486);
    assert_eq!(m.sets_per_iteration(), 12);
    // Every set is independent: no particle twice; together the sets cover the group once.
    for g in &m.groups {
        let rows: usize = g.sets.iter().map(|s| s.index.rows()).sum();
        assert_eq!(rows, g.count, "{}", g.name);
        assert!(g.sets.iter().all(|s| s.index.is_disjoint()), "{}", g.name);
    }
    assert_eq!(
        m.effects(),
        "stretch (261 constraints, 6 sets), bending (225 constraints, 6 sets), gravity, safety SDF"
    );
    // 2 + 2 + 3 + 12 + 2·100·12
    assert_eq!(step_nodes(&m), 2419);
}

#[test]
fn dihedral_bending_gives_225_constraints() {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    scene.material.bending = Some(Bending {
        model: BendingModel::Dihedral,
        stiffness: Stiffness::Finite(100.0),
    });
    let m = model(&scene);
    assert_eq!(group(&m, "stretch"), Some((261, 6)));
    // Four particles per constraint (the two triangles of an interior edge): more colours.
    assert_eq!(group(&m, "bending"), Some((225, 13)));
    assert_eq!(m.projections_per_iteration(), 486);
    assert_eq!(m.sets_per_iteration(), 19);
    assert!(m.group("bending").unwrap().energy.is_some());
}

#[test]
fn without_bending_there_is_no_bending_group_and_225_fewer_projections() {
    let with = Scene::builtin("u_obstacle").unwrap();
    let mut without = with.clone();
    without.material.bending = None;
    let (a, b) = (model(&with), model(&without));
    assert!(b.group("bending").is_none());
    assert_eq!(b.groups.len(), 1);
    assert_eq!(
        a.projections_per_iteration() - b.projections_per_iteration(),
        225
    );
    assert_eq!(b.projections_per_iteration(), 261);
    assert_eq!(a.sets_per_iteration() - b.sets_per_iteration(), 6);
    // The recorded step loses the 6 bending sets: 6 λ leaves and 2·100·6 update nodes.
    assert_eq!(step_nodes(&a), 2419);
    assert_eq!(step_nodes(&b), 1213);
    // And the memory of the saved inputs: each bending row saved 7 values per iteration.
    assert!(step_bytes(&b) + 225 * 100 * 7 * 8 <= step_bytes(&a));
    // The elastic energy records one group instead of two (gather, map, sum + the add).
    let energy_nodes = |m: &Model| {
        let mut tape = Tape::new();
        let x = tape.leaf(m.start.clone());
        m.record_energy(&mut tape, x).unwrap();
        tape.len()
    };
    assert_eq!(energy_nodes(&a), 1 + 3 + 3 + 1);
    assert_eq!(energy_nodes(&b), 1 + 3);
}

#[test]
fn zero_gravity_has_no_gravity_step_and_a_smaller_recorded_step() {
    let with = Scene::builtin("swing").unwrap();
    let mut without = with.clone();
    without.physics.gravity = [0.0; 3];
    let (a, b) = (model(&with), model(&without));
    let g = a.gravity_step.unwrap();
    assert_eq!(g[0], 0.0);
    assert_eq!(g[1], 0.0);
    assert!((g[2] - (-0.049)).abs() < 1e-15, "½gΔt² = {}", g[2]);
    assert!(b.gravity_step.is_none());
    assert!(!b.effects().contains("gravity"));
    // Exactly the gravity leaf and its add are gone.
    assert_eq!(step_nodes(&a), 2419);
    assert_eq!(step_nodes(&b), 2417);
    // Without gravity and controls nothing pulls the cloth: it stays at rest to rounding.
    let states = b.simulate(&b.zero_controls()).unwrap();
    let moved = states
        .last()
        .unwrap()
        .data()
        .iter()
        .zip(b.start.data())
        .fold(0.0f64, |m, (x, r)| m.max((x - r).abs()));
    assert!(moved < 1e-12, "moved by {moved:e}");
}

#[test]
fn without_obstacles_there_is_no_sdf_work_and_c_is_zero() {
    let scene = Scene::builtin("swing").unwrap();
    assert!(scene.obstacles.is_empty());
    let m = model(&scene);
    assert!(m.safety.is_none());
    assert!(m.safety_obstacles.is_empty());
    assert!(m.group("collider").is_none());
    // Recording the safety terms adds nothing to the tape.
    let mut tape = Tape::new();
    let x = tape.leaf(m.start.clone());
    assert!(m.record_sdf(&mut tape, x).is_none());
    assert!(m.record_safety(&mut tape, x, 0.2).is_none());
    assert_eq!(tape.len(), 1);
    // C = 0, min SDF = ∞, dC/dU = 0 exactly, whatever δ.
    let u = Scene::builtin("u_obstacle").unwrap().initial_controls();
    let ev = m.evaluate(&u, 0.4, true).unwrap();
    assert_eq!(ev.metrics.c, 0.0);
    assert_eq!(ev.metrics.min_sdf, f64::INFINITY);
    let gc = ev.grad_c.unwrap();
    assert_eq!(gc.shape(), u.shape());
    assert!(gc.data().iter().all(|&v| v == 0.0));
    assert!(ev.grad_l.unwrap().norm() > 0.0);
    // The u_obstacle's spheres, by contrast, are SDF work but no collider.
    let u_obstacle = model(&Scene::builtin("u_obstacle").unwrap());
    assert!(u_obstacle.safety.is_some());
    assert_eq!(u_obstacle.safety_obstacles.spheres.len(), 1);
    assert_eq!(u_obstacle.safety_obstacles.spheres[0].centers.len(), 18);
    assert!(u_obstacle.group("collider").is_none());
}

#[test]
fn drop_has_a_collider_group_of_98_free_particles() {
    let m = model(&Scene::builtin("drop").unwrap());
    assert_eq!(group(&m, "collider"), Some((98, 1)));
    let collider = m.group("collider").unwrap();
    assert!(
        collider.energy.is_none(),
        "an inequality carries no elastic energy"
    );
    // The gripped corners (inverse mass 0) are not in it.
    let particles = collider.sets[0].index.as_slice();
    assert!(!particles.contains(&0) && !particles.contains(&9));
    assert_eq!(m.projections_per_iteration(), 261 + 225 + 98);
    assert_eq!(m.sets_per_iteration(), 13);
    // The ground is a collider, not a safety obstacle.
    assert!(m.safety.is_none());
    // One more set: one more λ leaf and 2·100 more nodes than without the ground.
    let mut scene = Scene::builtin("drop").unwrap();
    scene.obstacles.clear();
    let bare = model(&scene);
    assert!(bare.group("collider").is_none());
    assert_eq!(step_nodes(&m) - step_nodes(&bare), 201);
}

#[test]
fn obstacle_roles_select_collider_and_safety_work() {
    let base = Scene::builtin("swing").unwrap();
    let with = |role: ObstacleRole| {
        let mut s = base.clone();
        s.obstacles
            .push(spheres(vec![[0.0, 0.0, 1.0]], vec![0.25], role));
        s.obstacles
            .push(plane([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], role));
        model(&s)
    };
    let safety = with(ObstacleRole::Safety);
    assert!(safety.safety.is_some() && safety.group("collider").is_none());
    let collider = with(ObstacleRole::Collider);
    assert!(collider.safety.is_none());
    assert_eq!(group(&collider, "collider"), Some((98, 1)));
    let both = with(ObstacleRole::Both);
    assert!(both.safety.is_some());
    assert_eq!(group(&both, "collider"), Some((98, 1)));
    // One collider group for any number of collider obstacles (their union); the plane's normal
    // is normalised.
    assert_eq!(both.safety_obstacles.planes[0].normal, [0.0, 0.0, 1.0]);
}
