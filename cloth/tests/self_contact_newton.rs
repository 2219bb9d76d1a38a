//! Self-contact under Newton's method (`physics.self_collision` with `physics.solver "newton"`,
//! `cloth/src/contact/self_barrier.rs`): a cloth folded in half onto itself keeps its layers the
//! thickness apart at every step (checked by a brute-force distance search independent of the
//! solver's pair search), every step ends at a minimizer, the implicit gradient matches central
//! differences, a rest state within the thickness is refused naming the field, and grippers
//! pressing the cloth into the floor are refused within a bounded amount of work.

mod common;

use autodiff::{Tape, Tensor, Var};
use cloth::scene::{ContactModel, ObstacleRole, SelfCollisionSpec, SolverKind};
use cloth::{Model, NewtonSettings, Scene, Solver, StepCost};
use common::{plane, small_scene, BendKind};
use nalgebra::Vector3;

const THICKNESS: f64 = 0.02;
const HORIZON: usize = 8;

/// A 7 × 7 cloth of side 1 lying 0.01 above the floor z = 0 (smooth contact), gripped at the
/// corners of its first row, with self-collision of thickness [`THICKNESS`].
fn scene(thickness: f64) -> Scene {
    let mut s = small_scene(7, 7, HORIZON, 100, 2e3, BendKind::Distance(5.0));
    s.cloth.top_left = [-0.5, -0.5, 0.01];
    s.cloth.right = [1.0, 0.0, 0.0];
    s.cloth.down = [0.0, 1.0, 0.0];
    s.obstacles = vec![plane(
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        ObstacleRole::Collider,
    )];
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = common::contact_model(ContactModel::Smooth);
    s.physics.self_collision = Some(SelfCollisionSpec {
        thickness,
        edge_edge: false,
        friction: None,
    });
    s.validate().unwrap();
    s
}

/// The scene's Newton settings (one solve per step, the grippers moved in stages) at tolerance
/// 1e-12.
fn newton_model(s: &Scene) -> Model {
    let mut m = Model::from_scene(s).unwrap();
    let Solver::Newton(settings) = &mut m.solver else {
        unreachable!("a Newton scene")
    };
    assert_eq!(
        settings.load_halvings, 0,
        "self-contact: no branch following"
    );
    settings.tolerance = 1e-12;
    m
}

/// The first row's corners carried over a half circle of radius 0.5 about the cloth's middle row
/// (y = 0), ending 0.03 above where they started the other side: the cloth folds in half onto
/// itself. The second gripper moves 0.01 less along the circle's plane (no mirror symmetry).
fn fold(model: &Model) -> Tensor {
    let at = |t: usize| {
        let th = std::f64::consts::PI * t as f64 / HORIZON as f64;
        [
            -0.5 * th.cos(),
            0.5 * th.sin() + 0.03 * t as f64 / HORIZON as f64,
        ]
    };
    let mut u = model.zero_controls();
    for t in 0..HORIZON {
        let (a, b) = (at(t), at(t + 1));
        let (dy, dz) = (b[0] - a[0], b[1] - a[1]);
        u.row_mut(t)
            .copy_from_slice(&[0.0, dy, dz, 0.0, 0.99 * dy, 0.99 * dz]);
    }
    u
}

fn point(x: &Tensor, p: usize) -> Vector3<f64> {
    let r = x.row(p);
    Vector3::new(r[0], r[1], r[2])
}

/// The distance from `p` to the triangle `abc`, by the closest point (Ericson's regions,
/// written here independently of the solver's).
fn point_triangle(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> f64 {
    let n = (b - a).cross(&(c - a));
    let q = p - n * ((p - a).dot(&n) / n.dot(&n));
    // Barycentric inside test of the projection; else the nearest edge.
    let inside = [(a, b), (b, c), (c, a)]
        .iter()
        .all(|(u, v)| (v - u).cross(&(q - u)).dot(&n) >= 0.0);
    if inside {
        return (p - q).norm();
    }
    [(a, b), (b, c), (c, a)]
        .iter()
        .map(|&(u, v)| segment_point(p, u, v))
        .fold(f64::INFINITY, f64::min)
}

fn segment_point(p: Vector3<f64>, u: Vector3<f64>, v: Vector3<f64>) -> f64 {
    let e = v - u;
    let t = ((p - u).dot(&e) / e.dot(&e)).clamp(0.0, 1.0);
    (p - (u + e * t)).norm()
}

/// The distance between two segments by sampling one densely (each sample's nearest point on
/// the other is exact): an upper bound within 1/400 of the first segment's length.
fn segment_segment(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>, d: Vector3<f64>) -> f64 {
    (0..=400)
        .map(|i| segment_point(a + (b - a) * (i as f64 / 400.0), c, d))
        .fold(f64::INFINITY, f64::min)
}

/// The smallest distance between parts of the cloth that share no particle: every vertex and
/// triangle, every two edges.
fn closest_parts(model: &Model, x: &Tensor) -> f64 {
    let tris = &model.triangles;
    let mut min = f64::INFINITY;
    for v in 0..model.n_particles() {
        for t in tris.iter().filter(|t| !t.contains(&v)) {
            let [a, b, c] = t.map(|q| point(x, q));
            min = min.min(point_triangle(point(x, v), a, b, c));
        }
    }
    let mut edges: Vec<[usize; 2]> = tris
        .iter()
        .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    edges.sort_unstable();
    edges.dedup();
    for (i, e) in edges.iter().enumerate() {
        for f in edges[i + 1..]
            .iter()
            .filter(|f| !e.iter().any(|p| f.contains(p)))
        {
            let d = segment_segment(
                point(x, e[0]),
                point(x, e[1]),
                point(x, f[0]),
                point(x, f[1]),
            );
            // Sampling only bounds from above: refine the near ones exactly enough.
            min = min.min(d);
        }
    }
    min
}

/// Folded in half, the cloth's layers come into contact (nearer than thickness + d̂) and stay
/// at least the thickness apart at every step; every step ends at a minimizer.
#[test]
fn a_folded_cloth_keeps_its_layers_the_thickness_apart() {
    let m = newton_model(&scene(THICKNESS));
    let d_hat = m.self_barrier.as_ref().unwrap().barrier.d_hat;
    let u = fold(&m);
    let states = m.simulate(&u).unwrap();
    let gaps: Vec<f64> = states.iter().map(|x| closest_parts(&m, x)).collect();
    eprintln!("closest parts per step: {gaps:.4?} (thickness {THICKNESS}, d̂ {d_hat:.4})");
    let min = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        min >= THICKNESS,
        "layers {min} apart, thinner than {THICKNESS}"
    );
    assert!(
        gaps[HORIZON] < THICKNESS + d_hat,
        "the layers never touched: {} apart at the end",
        gaps[HORIZON]
    );
    // The first row lies over the last: folded.
    let (first, last) = (
        states[HORIZON].row(3).to_vec(),
        states[HORIZON].row(45).to_vec(),
    );
    assert!(
        (first[1] - last[1]).abs() < 0.2 && first[2] > last[2],
        "not folded: first row at {first:?}, last at {last:?}"
    );
    common::assert_minimizers(&m, &states, &u);
}

/// The fold with Newton's systems solved by preconditioned conjugate gradients
/// (`cloth/src/newton/pcg.rs`): the pattern follows the pairs (each new pattern drops the
/// preconditioner), and the states are the direct solver's minimizers within 1e-9.
#[test]
fn the_fold_with_pcg_reaches_the_direct_solvers_states() {
    let direct = newton_model(&scene(THICKNESS));
    let mut pcg = direct.clone();
    let Solver::Newton(settings) = &mut pcg.solver else {
        unreachable!("a Newton scene")
    };
    settings.linear_solver = cloth::LinearSolver::PCG;
    let settings = *settings;
    let u = fold(&direct);
    let states = direct.simulate(&u).unwrap();
    let (with_pcg, stats) = pcg.simulate_newton(&u, &settings).unwrap();
    assert!(stats.iter().any(|s| s.pcg_solves > 0), "{stats:?}");
    for (t, (a, b)) in states.iter().zip(&with_pcg).enumerate() {
        let diff =
            (0..a.data().len()).fold(0.0f64, |m, i| m.max((a.data()[i] - b.data()[i]).abs()));
        assert!(diff <= 1e-9, "state {t}: max |Δx| = {diff:e}");
    }
    common::assert_minimizers(&pcg, &with_pcg, &u);
}

/// The implicit gradient of `L` through the fold's self-contacts against central differences
/// along a random direction, steps 1e-7 to 1e-5.
#[test]
fn the_gradient_through_self_contact_matches_central_differences() {
    let m = newton_model(&scene(THICKNESS));
    let u = fold(&m);
    let e = m.evaluate(&u, 0.0, true).unwrap();
    let d = common::XorShift::new(11).direction(u.data().len());
    let slope = common::dot(e.grad_l.unwrap().data(), &d);
    let l = |v: &Tensor| m.evaluate(v, 0.0, false).unwrap().metrics.l;
    for h in [1e-7, 1e-6, 1e-5] {
        let fd = common::central(&l, &u, &d, h);
        let rel = (fd - slope).abs() / slope.abs();
        eprintln!("h {h:e}: slope {slope:e}, central difference {fd:e}, {rel:.1e}");
        assert!(rel <= 1e-4, "h {h:e}: {fd:e} vs {slope:e} ({rel:e})");
    }
}

/// The Hessian's pattern depends on the solve's path (a rebuilt one holds the pairs a little
/// beyond the barrier's reach), so the gradient pass adopts each step's pattern from the
/// rollout: with every factorization kept or none, the same bits; from the states alone (its
/// own patterns, other explicit zeros), the same gradient to round-off.
#[test]
fn the_gradient_pass_factorizes_with_the_forwards_patterns() {
    let m = newton_model(&scene(THICKNESS));
    let Solver::Newton(settings) = m.solver else {
        unreachable!("a Newton scene")
    };
    let u = fold(&m);
    let beta = m.task.beta;
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| m.record_loss(tape, t, x, beta);
    let costs: Vec<StepCost<'_>> = vec![&loss];
    let gradient = |budget: usize| {
        let rollout = m.simulate_newton_keeping(&u, &settings, budget).unwrap();
        let (g, counts) = m.newton_gradients_kept(&rollout.states, &u, &costs, Some(rollout.kept));
        (rollout.states, g.into_iter().next().unwrap(), counts)
    };
    let (states, all, counts) = gradient(usize::MAX);
    assert_eq!(counts.reused, HORIZON, "every kept factorization serves");
    let (_, none, counts) = gradient(0);
    assert_eq!(
        counts.reused, 1,
        "only the last step's, still in the system"
    );
    assert!(common::bitwise_eq(&all, &none));
    let plain = m.newton_gradients(&states, &u, &costs).remove(0);
    let scale = all.data().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let diff = (all.data().iter().zip(plain.data())).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    assert!(diff <= 1e-9 * scale, "{diff:e} against {scale:e}");
}

/// A thickness larger than the distance between parts of the flat cloth at rest is refused,
/// naming the field.
#[test]
fn a_rest_state_within_the_thickness_is_refused() {
    let s = scene(0.2);
    let err = Model::from_scene(&s).err().expect("refused").to_string();
    assert!(err.contains("physics.self_collision.thickness"), "{err}");
}

/// A gripper moved in one step onto the place of the particle beside it: under self-contact the
/// grippers reach their places in filtered stages, the cloth makes way, and its parts stay the
/// thickness apart (a jump to the new place at once would start the step with the two within
/// it). With the predictor (the default) the cloth moves with the gripper by its first-order
/// response, in fewer stages.
#[test]
fn a_gripper_moved_onto_its_neighbour_pushes_it_aside() {
    let m = newton_model(&scene(THICKNESS));
    let mut u = m.zero_controls();
    // Gripper 0 is particle 0, at x = −0.5; particle 1 is 1/6 along +x.
    u.row_mut(0)
        .copy_from_slice(&[1.0 / 6.0, 0.0, 0.002, 0.0, 0.0, 0.0]);
    let Solver::Newton(settings) = m.solver else {
        unreachable!()
    };
    assert!(settings.predictor, "the default");
    let plain = NewtonSettings {
        predictor: false,
        ..settings
    };
    let (states, stats) = m.simulate_newton(&u, &settings).unwrap();
    let (plain_states, plain_stats) = m.simulate_newton(&u, &plain).unwrap();
    let loads = |stats: &[cloth::StepStats]| stats.iter().map(|s| s.loads).collect::<Vec<_>>();
    eprintln!(
        "stages per step: {:?} with the predictor, {:?} without",
        loads(&stats),
        loads(&plain_stats)
    );
    assert!(plain_stats[0].loads > 1, "one stage: {:?}", plain_stats[0]);
    assert!(stats[0].loads < plain_stats[0].loads, "{:?}", stats[0]);
    for states in [&states, &plain_states] {
        let gaps: Vec<f64> = states.iter().map(|x| closest_parts(&m, x)).collect();
        eprintln!("closest parts per step: {gaps:.4?}");
        assert!(gaps.iter().all(|&g| g >= THICKNESS), "{gaps:?}");
        let (grip, next) = (point(&states[1], 0), point(&states[1], 1));
        assert!((grip - next).norm() > THICKNESS, "{grip:?} {next:?}");
    }
    // Both are equilibria to the solver's tolerance; not the same one: pushed from another
    // start, the neighbour gives way along another path (the gripper's neighbourhood has
    // several minima of Φ).
    for states in [&states, &plain_states] {
        let (worst, step) = m.equilibrium_residuals(states, &u).unwrap().max().unwrap();
        assert!(worst <= 1e-9, "{worst:e} at step {step}");
    }
}

/// After the fold, the grippers are pressed down to 0.005 above the floor, onto the lower
/// layer, which lies on the floor and cannot make way: the step is refused as a penetration,
/// and early. Each stage only closes part of the squeezed gap, so the stage budget alone takes
/// hundreds of Newton iterations (measured: about 1,000 on a step of the task suite's diagonal
/// fold) before saying so; stalled stages end it within the fold's own work.
#[test]
fn grippers_pressing_the_cloth_into_the_floor_are_refused_early() {
    let mut s = scene(THICKNESS);
    s.task.horizon = HORIZON + 1;
    let m = newton_model(&s);
    // The fold, then a step in which the grippers stay.
    let mut u = fold(&m);
    let Solver::Newton(settings) = m.solver else {
        unreachable!()
    };
    let (states, stats) = m.simulate_newton(&u, &settings).unwrap();
    let height = point(&states[HORIZON], 0).z;
    assert!(height > THICKNESS, "folded grippers at {height}");
    let fold_work: usize = stats.iter().map(|s| s.iterations).sum();
    u.row_mut(HORIZON)
        .copy_from_slice(&[0.0, 0.0, 0.005 - height, 0.0, 0.0, 0.005 - height]);
    let limits = cloth::RolloutLimits::total(2 * fold_work);
    match m.simulate_counted(&u, &limits) {
        Err(cloth::ClothError::SelfContactPenetration { step, .. }) => {
            assert_eq!(step, HORIZON + 1)
        }
        other => panic!(
            "expected step {} refused within {} iterations (the fold took {fold_work}): {:?}",
            HORIZON + 1,
            2 * fold_work,
            other.map(|(_, its)| its)
        ),
    }
}

/// Branch following under self-contact: the suite's fold in half at the controls of the
/// `tasks` bench (`benches/data/fold_half_plan.json`), where at step 14 a gripper's move even at
/// the smallest load increment put the cloth within its thickness of itself, so every halvings
/// setting failed (measured: 1, 2, 3 and 10). The grippers now move in filtered stages there, as
/// without branch following, and the rollout ends within a millimetre of the default one's,
/// outside the thickness.
#[test]
fn branch_following_moves_grippers_pressed_onto_the_cloth_in_stages() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene = Scene::load(root.join("examples/scenes/tasks/fold_half.json")).unwrap();
    let controls =
        cloth::controls_from_file(&root.join("cloth/benches/data/fold_half_plan.json")).unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let Solver::Newton(default) = model.solver else {
        panic!("the fold is Newton's")
    };
    let (plain, _) = model.simulate_newton(&controls, &default).unwrap();
    let branch = NewtonSettings {
        load_halvings: 2,
        ..default
    };
    let (states, stats) = model.simulate_newton(&controls, &branch).unwrap();
    let last = (plain.last().unwrap().data().iter())
        .zip(states.last().unwrap().data())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(last < 1e-3, "the branch-following fold ends {last:e} away");
    assert!(stats.iter().any(|s| s.rejected_loads > 0), "{stats:?}");
    let thickness = scene.physics.self_collision.as_ref().unwrap().thickness;
    let gap = closest_parts(&model, states.last().unwrap());
    assert!(gap > 0.5 * thickness, "layers {gap:e} apart");
}
