//! Coulomb friction on colliders (`"friction": μ`): validation, model counts, physics with
//! numbers (a cloth on a plane tilted by θ sticks when μ > tan θ and slides by the predicted amount
//! when μ < tan θ), and the rollout gradient against central finite differences in the sticking and
//! sliding regimes, away from the stick/slip switch.

mod common;

use autodiff::update::update_rows;
use autodiff::Tensor;
use cloth::internals::{FrictionalContact, Regime};
use cloth::scene::{
    ContactModel, InitialControls, Obstacle, ObstacleRole, PlaneSpec, SolverKind, Target,
};
use cloth::Carry;
use cloth::{Model, Scene};
use common::{bitwise_eq, central, dot, small_scene, BendKind, XorShift};
use proptest::prelude::*;

/// Half the per-step gravity displacement `½gΔt²` of the scenes below (`g = 9.8`, `Δt = 0.1`).
const HALF_G_DT2: f64 = 0.5 * 9.8 * 0.01;

/// A collider plane with friction `mu`.
fn plane_with_friction(point: [f64; 3], normal: [f64; 3], mu: Option<f64>) -> Obstacle {
    Obstacle::Plane(PlaneSpec {
        point,
        normal,
        role: ObstacleRole::Collider,
        friction: mu,
    })
}

/// A `5 × 5` cloth (side 0.4) lying on a plane through the origin tilted by `theta` about the y
/// axis, no grippers, gravity `−9.8 ẑ`; the plane has friction `mu`.
fn tilted_scene(theta: f64, mu: Option<f64>, horizon: usize) -> Scene {
    let mut s = small_scene(5, 5, horizon, 30, 1e4, BendKind::None);
    let downhill = [theta.cos(), 0.0, -theta.sin()];
    s.cloth.top_left = [0.0; 3];
    s.cloth.right = downhill.map(|v| 0.4 * v);
    s.cloth.down = [0.0, 0.4, 0.0];
    s.controls.clear();
    s.task.targets = vec![Target {
        particle: [0, 0].into(),
        position: [0.0; 3],
    }];
    s.obstacles = vec![plane_with_friction(
        [0.0; 3],
        [theta.sin(), 0.0, theta.cos()],
        mu,
    )];
    s
}

/// Each particle's displacement from rest along the downhill direction at the last step.
fn downhill_displacements(scene: &Scene, theta: f64) -> Vec<f64> {
    let model = Model::from_scene(scene).unwrap();
    let states = model.simulate(&model.zero_controls()).unwrap();
    let (first, last) = (&states[0], states.last().unwrap());
    let downhill = [theta.cos(), 0.0, -theta.sin()];
    (0..first.rows())
        .map(|p| {
            (0..3)
                .map(|k| (last.get(p, k) - first.get(p, k)) * downhill[k])
                .sum()
        })
        .collect()
}

fn validation_error(scene: &Scene) -> String {
    scene.validate().unwrap_err().to_string()
}

#[test]
fn friction_is_validated_with_its_field_named() {
    let theta = 0.3;
    for bad in [-0.1, f64::NAN, f64::INFINITY] {
        let s = tilted_scene(theta, Some(bad), 2);
        let msg = validation_error(&s);
        assert!(msg.contains("obstacles[0].friction"), "{msg}");
    }
    let mut s = tilted_scene(theta, Some(0.5), 2);
    let Obstacle::Plane(p) = &mut s.obstacles[0] else {
        unreachable!()
    };
    p.role = ObstacleRole::Safety;
    let msg = validation_error(&s);
    assert!(msg.contains("obstacles[0].friction"), "{msg}");
    assert!(msg.contains("collider"), "{msg}");
    // `both` is a collider: allowed.
    let Obstacle::Plane(p) = &mut s.obstacles[0] else {
        unreachable!()
    };
    p.role = ObstacleRole::Both;
    s.validate().unwrap();
    // Newton's rigid model has no friction: a named error.
    let mut s = tilted_scene(theta, Some(0.5), 2);
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = common::contact_model(ContactModel::Rigid);
    let msg = validation_error(&s);
    assert!(msg.contains("obstacles[0].friction"), "{msg}");
    assert!(msg.contains("newton"), "{msg}");
}

#[test]
fn friction_parses_prints_and_reads_back() {
    let s = tilted_scene(0.3, Some(0.25), 2);
    let text = s.to_json_pretty();
    assert!(text.contains("\"friction\""), "{text}");
    let back = Scene::from_json_str(&text).unwrap();
    assert_eq!(back.obstacles[0].friction(), Some(0.25));
    // Absent stays absent when printed.
    let s = tilted_scene(0.3, None, 2);
    assert!(!s.to_json_pretty().contains("friction"));
}

/// Sets whose rows carry start positions (the frictional contact), with their row counts.
fn friction_sets(model: &Model) -> Vec<usize> {
    model
        .sets()
        .filter(|s| s.carry != Carry::Multiplier)
        .map(|s| s.index.rows())
        .collect()
}

#[test]
fn no_friction_rows_unless_a_collider_asks() {
    let theta = 0.3;
    let absent = Model::from_scene(&tilted_scene(theta, None, 4)).unwrap();
    let zero = Model::from_scene(&tilted_scene(theta, Some(0.0), 4)).unwrap();
    let some = Model::from_scene(&tilted_scene(theta, Some(0.4), 4)).unwrap();
    assert!(friction_sets(&absent).is_empty());
    assert!(friction_sets(&zero).is_empty());
    assert!(!absent.effects().contains("friction"));
    // One set, one row per free particle (all 25 here), in place of the collider's set.
    assert_eq!(friction_sets(&some), vec![25]);
    assert_eq!(some.sets_per_iteration(), absent.sets_per_iteration());
    assert_eq!(some.group("collider").unwrap().sets.len(), 1);
    assert!(some.effects().contains("friction"), "{}", some.effects());
    // `"friction": 0` is today's behaviour bit for bit.
    let u = absent.zero_controls();
    let (a, z) = (absent.simulate(&u).unwrap(), zero.simulate(&u).unwrap());
    assert!(a.iter().zip(&z).all(|(x, y)| bitwise_eq(x, y)));
    // A safety-only scene has no friction rows either.
    let mut safety = small_scene(4, 4, 2, 5, 1e4, BendKind::None);
    safety.obstacles = vec![common::plane(
        [0.0, 0.0, -5.0],
        [0.0, 0.0, 1.0],
        ObstacleRole::Safety,
    )];
    assert!(friction_sets(&Model::from_scene(&safety).unwrap()).is_empty());
}

/// θ = 30° (tan θ ≈ 0.577), 20 steps: the frictionless cloth slides `T·½gΔt²·sin θ` = 0.49 m.
const THETA: f64 = std::f64::consts::FRAC_PI_6;
const STEPS: usize = 20;

#[test]
fn a_cloth_on_a_tilted_plane_sticks_when_mu_exceeds_tan_theta() {
    for mu in [0.6, 0.8, 2.0] {
        assert!(mu > THETA.tan());
        let moved = downhill_displacements(&tilted_scene(THETA, Some(mu), STEPS), THETA);
        let worst = moved.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        // Sticking cancels the tangential displacement exactly, up to rounding.
        assert!(worst < 1e-12, "μ = {mu}: a particle slid {worst:e} m");
    }
}

#[test]
fn a_cloth_on_a_tilted_plane_slides_when_mu_is_below_tan_theta() {
    // Quasi-static steps have no momentum: each step's tangential pull ½gΔt² sin θ is reduced by
    // μ times the normal correction ½gΔt² cos θ.
    for mu in [None, Some(0.0), Some(0.1), Some(0.3), Some(0.5)] {
        let m = mu.unwrap_or(0.0);
        assert!(m < THETA.tan());
        let expected = STEPS as f64 * HALF_G_DT2 * (THETA.sin() - m * THETA.cos());
        let moved = downhill_displacements(&tilted_scene(THETA, mu, STEPS), THETA);
        for (p, d) in moved.iter().enumerate() {
            assert!(
                (d - expected).abs() < 1e-9,
                "μ = {m}: particle {p} slid {d} m, expected {expected} m"
            );
        }
        assert!(
            expected > 0.01,
            "μ = {m}: the cloth must slide ({expected} m)"
        );
    }
}

/// The regime of every frictional row at every projection of the rollout at `u` (the simulator's
/// own kernel, so the states are `simulate`'s), with whether the row's particle was inside the
/// table (`z < 0`, so the contact projected it).
fn regimes(model: &Model, friction: &FrictionalContact, u: &Tensor) -> Vec<(Regime, bool)> {
    let mut x_prev = model.start.clone();
    let mut out = Vec::new();
    for t in 0..model.task.horizon {
        let mut x = model.begin_step(&x_prev, &model.step_controls(u, t));
        let mut carries = model.initial_carries(&x_prev);
        for _ in 0..model.iterations {
            for (set, carry) in model.sets().zip(carries.iter_mut()) {
                if set.carry != Carry::Multiplier {
                    for k in 0..set.index.rows() {
                        let p = set.index.row(k)[0];
                        let row: Vec<f64> = x.row(p).iter().chain(carry.row(k)).copied().collect();
                        out.push((friction.regime(&row), row[2] < 0.0));
                    }
                }
                update_rows(set.projection.as_ref(), &set.index, &mut x, carry, None);
            }
        }
        x_prev = x;
    }
    out
}

/// A `rows × cols` cloth lying flat on a table (the plane `z = 0`) with friction `mu`, gripped at
/// two corners; targets: the far row moved by 0.2 along x.
fn table_scene(rows: usize, cols: usize, mu: f64, stretch: f64) -> Scene {
    let mut s = small_scene(rows, cols, 3, 20, stretch, BendKind::Distance(50.0));
    s.cloth.top_left = [-0.5, -0.5, 0.0];
    s.cloth.right = [1.0, 0.0, 0.0];
    s.cloth.down = [0.0, 1.0, 0.0];
    s.obstacles = vec![plane_with_friction(
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        Some(mu),
    )];
    s.task.targets = (0..cols)
        .map(|c| Target {
            particle: [rows - 1, c].into(),
            position: [-0.3 + c as f64 / (cols - 1) as f64, 0.5, 0.0],
        })
        .collect();
    s.task.initial_controls = InitialControls::Zeros;
    s.validate().unwrap();
    s
}

/// Checks `dL/dU` against central differences along random directions; returns the regimes seen.
fn check_fd(
    scene: &Scene,
    values: &[f64],
    seed: u64,
) -> Result<Vec<(Regime, bool)>, TestCaseError> {
    let model = Model::from_scene(scene).unwrap();
    let friction = FrictionalContact::from_obstacles(&scene.obstacles).unwrap();
    let u = common::controls_from(&model, values);
    let ev = model.evaluate(&u, 0.0, true).unwrap();
    let grad = ev.grad_l.unwrap();
    let l = |v: &Tensor| model.evaluate(v, 0.0, false).unwrap().metrics.l;
    let at_u = regimes(&model, &friction, &u);
    let mut rng = XorShift::new(seed);
    let h = 1e-6;
    for _ in 0..3 {
        let d = rng.direction(u.data().len());
        // Away from the switches: the same regimes at u ± 2h as at u.
        for s in [-2.0 * h, 2.0 * h] {
            let there = regimes(&model, &friction, &common::shifted(&u, &d, s));
            prop_assume!(there == at_u, "a row changes regime within the FD step");
        }
        let fd = central(&l, &u, &d, h);
        let ad = dot(grad.data(), &d);
        let scale = ev.metrics.l.abs().max(1.0);
        prop_assert!(
            (fd - ad).abs() <= 1e-5 * fd.abs().max(ad.abs()) + 1e-7 * scale,
            "dL·d: AD {ad}, FD {fd}"
        );
    }
    Ok(at_u)
}

fn drag_controls() -> impl Strategy<Value = Vec<f64>> {
    // Three steps × two grippers: in-plane drags of up to 5 cm, small lifts.
    prop::collection::vec((-0.05..0.05f64, -0.05..0.05f64, 0.0..0.01f64), 6)
        .prop_map(|v| v.into_iter().flat_map(|(a, b, c)| [a, b, c]).collect())
}

fn count(regimes: &[(Regime, bool)], which: Regime) -> usize {
    regimes.iter().filter(|&&(r, _)| r == which).count()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, max_global_rejects: 40, ..ProptestConfig::default() })]

    /// High friction and a softer cloth (a stiff one pulled by kinematic grippers must slide
    /// near them, whatever μ): most touching rows stick.
    #[test]
    fn rollout_gradient_matches_fd_while_sticking(
        rows in 3usize..5, cols in 3usize..5, stretch in 1.5..2.5f64,
        values in drag_controls(), seed in any::<u64>(),
    ) {
        let scene = table_scene(rows, cols, 3.0, 10f64.powf(stretch));
        let seen = check_fd(&scene, &values, seed)?;
        prop_assert!(count(&seen, Regime::Sticking) > count(&seen, Regime::Sliding));
    }

    /// Low friction: most touching rows slide.
    #[test]
    fn rollout_gradient_matches_fd_while_sliding(
        rows in 3usize..5, cols in 3usize..5, stretch in 2.5..4.0f64,
        values in drag_controls(), seed in any::<u64>(),
    ) {
        let scene = table_scene(rows, cols, 0.05, 10f64.powf(stretch));
        let seen = check_fd(&scene, &values, seed)?;
        prop_assert!(count(&seen, Regime::Sliding) > count(&seen, Regime::Sticking));
    }
}

#[test]
fn gradients_with_friction_are_the_same_whole_or_in_blocks_of_iterations() {
    let scene = table_scene(4, 4, 0.5, 1e3);
    let mut model = Model::from_scene(&scene).unwrap();
    let mut rng = XorShift::new(7);
    let values: Vec<f64> = (0..18).map(|_| rng.uniform(-0.04, 0.04)).collect();
    let u = common::controls_from(&model, &values);
    let whole = model.evaluate(&u, 0.0, true).unwrap().grad_l.unwrap();
    // A budget that fits a few iterations only: each step is re-recorded in blocks, the carries
    // (start positions, D, Λ) chained from block to block.
    model.checkpoint_budget = 3 * model.recorded_bytes_per_iteration();
    assert!(model.iterations_per_block() < model.iterations);
    let blocks = model.evaluate(&u, 0.0, true).unwrap().grad_l.unwrap();
    assert!(bitwise_eq(&whole, &blocks));
    assert!(whole.data().iter().any(|&g| g != 0.0));
}

/// The frictional rows of a cloth with more free particles than `PARALLEL_MIN_ROWS` (so a
/// 2-thread pool splits the set): the plain and the recorded rollouts agree bit for bit, and
/// `evaluate` (states, `dL/dU`) is bitwise the same in a 1- and a 2-thread pool.
#[test]
fn frictional_rows_are_deterministic_across_paths_and_threads() {
    use autodiff::rowfn::PARALLEL_MIN_ROWS;
    use autodiff::Tape;
    let scene = table_scene(24, 24, 0.5, 1e3);
    let model = Model::from_scene(&scene).unwrap();
    let rows = friction_sets(&model).into_iter().max().unwrap();
    assert!(rows >= PARALLEL_MIN_ROWS, "{rows} frictional rows");
    let mut rng = XorShift::new(11);
    let values: Vec<f64> = (0..18).map(|_| rng.uniform(-0.04, 0.04)).collect();
    let u = common::controls_from(&model, &values);
    // Plain against recorded, step by step on one tape.
    let plain = model.simulate(&u).unwrap();
    let mut tape = Tape::new();
    let mut x = tape.leaf(model.start.clone());
    for (t, want) in plain.iter().enumerate().skip(1) {
        let ut = tape.leaf(model.step_controls(&u, t - 1));
        x = model.record_step(&mut tape, x, ut);
        assert!(bitwise_eq(tape.value(x), want), "step {t}");
    }
    assert!(!bitwise_eq(&plain[0], plain.last().unwrap()));
    // One and two threads.
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| model.evaluate(&u, 0.0, true).unwrap())
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.metrics.l.to_bits(), two.metrics.l.to_bits());
    for (a, b) in one.states.iter().zip(&two.states) {
        assert!(bitwise_eq(a, b));
    }
    let (g1, g2) = (one.grad_l.unwrap(), two.grad_l.unwrap());
    assert!(bitwise_eq(&g1, &g2));
    assert!(g1.data().iter().any(|&g| g != 0.0));
}
