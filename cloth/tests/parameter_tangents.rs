//! Derivatives of rollouts with respect to the physical parameters (`Model::parameter_tangents`)
//! against central differences in the parameters' log-factors: stretch and bending stiffness, a
//! custom constraint type's stiffness, mass, gravity and friction; under Newton in free space, on
//! smooth contact with friction and with rigid contact rows; under XPBD in free space and on
//! rigid contact with its friction rows. And with respect to the controls (module `control_tangents`).

mod common;

use autodiff::Tensor;
use cloth::nalgebra::Vector3;
use cloth::scene::{ContactModel, CustomConstraint, ObstacleRole, SolverKind, Stiffness};
use cloth::{ConstraintRegistry, Model, NewtonSettings, Parameter, Scene, Solver};
use common::{behind, small_scene, BendKind, TriangleArea};
use proptest::prelude::*;

fn registry() -> ConstraintRegistry {
    let mut r = ConstraintRegistry::new();
    r.register("triangle_area", |input| {
        let rest = (input.rest.chunks_exact(3))
            .map(|t| {
                TriangleArea::area(
                    &t.iter()
                        .map(|&[x, y, z]| Vector3::new(x, y, z))
                        .collect::<Vec<_>>(),
                )
            })
            .collect();
        Ok(TriangleArea { rest })
    });
    r
}

/// `scene` with every grid triangle's area held by `triangle_area` of stiffness 50.
fn with_area(mut s: Scene) -> Scene {
    let cols = s.cloth.cols;
    let particles = (s.mesh().triangles().iter().flatten())
        .map(|&p| [p / cols, p % cols])
        .collect();
    s.custom_constraints = vec![CustomConstraint {
        kind: "triangle_area".into(),
        particles,
        stiffness: Stiffness::Finite(50.0),
        params: serde_json::Value::Null,
    }];
    s
}

/// The model of `scene` (Newton solved to 1e-12), starting at `start` when given.
fn model(scene: &Scene, start: Option<&Tensor>) -> Model {
    let mut m = Model::from_scene_with(scene, &registry()).unwrap();
    if let Solver::Newton(_) = m.solver {
        m.solver = Solver::Newton(NewtonSettings {
            tolerance: 1e-12,
            ..NewtonSettings::default()
        });
    }
    if let Some(x0) = start {
        m.start = x0.clone();
    }
    m
}

/// `Σ_t w_t · x_t` with weights from `seed` (the same for every call).
fn weighted(states: &[Tensor], seed: u64) -> f64 {
    let mut rng = common::XorShift::new(seed);
    states[1..]
        .iter()
        .map(|x| {
            rng.direction(x.data().len())
                .iter()
                .zip(x.data())
                .map(|(a, b)| a * b)
                .sum::<f64>()
        })
        .sum()
}

/// Checks every parameter's tangent of `Σ w·x` against a central difference of step `h` in its
/// log-factor, the scene's barrier pinned and its start held.
fn check(scene: &Scene, u: &Tensor, params: &[&str], seed: u64) -> Result<(), TestCaseError> {
    let mut scene = scene.clone();
    let base = model(&scene, None);
    Parameter::pin_contact(&mut scene, &base);
    let base = model(&scene, None);
    let states = base.simulate(u).unwrap();
    let params: Vec<Parameter> = params.iter().map(|p| Parameter::parse(p)).collect();
    let tangents = base.parameter_tangents(&states, u, &params).unwrap();
    // XPBD's contact and friction switch at many small kinks (a resting particle touches or not
    // at each sweep); a step of 1e-6 stays between them (1e-5 crossed one on a drawn case).
    let h: f64 = match base.solver {
        Solver::Newton(_) => 1e-5,
        Solver::Xpbd => 1e-6,
    };
    let magnitude = states[1..]
        .iter()
        .map(|x| x.data().iter().map(|v| v.abs()).sum::<f64>())
        .sum::<f64>();
    for (j, p) in params.iter().enumerate() {
        let at = |factor: f64| {
            let mut s = scene.clone();
            p.scale(&mut s, factor).unwrap();
            let m = model(&s, Some(&base.start));
            weighted(&m.simulate(u).unwrap(), seed)
        };
        let fd = (at(h.exp()) - at((-h).exp())) / (2.0 * h);
        let per_step: Vec<Tensor> = tangents.iter().map(|t| t[j].clone()).collect();
        let an = weighted(&per_step, seed);
        let scale: f64 = per_step
            .iter()
            .map(|t| t.data().iter().map(|v| v.abs()).sum::<f64>())
            .sum();
        prop_assert!(scale > 0.0, "{p}: the tangent is zero");
        // The difference's own round-off: ten ulps of the sum over the step.
        let roundoff = 10.0 * f64::EPSILON * magnitude / h;
        prop_assert!(
            (fd - an).abs() <= 1e-5 * scale + roundoff,
            "{p}: analytic {an:e}, central difference {fd:e} (scale {scale:e})"
        );
    }
    Ok(())
}

/// Both grippers moving by `motion` every step, the first 0.01 more along x.
fn controls(model: &Model, [dx, dy, dz]: [f64; 3]) -> Tensor {
    let mut u = model.zero_controls();
    for t in 0..model.task.horizon {
        u.row_mut(t)
            .copy_from_slice(&[dx + 0.01, dy, dz, dx, dy, dz]);
    }
    u
}

/// A 5 × 5 hanging cloth with distance bending, `T` 3, under Newton; `flat` lies it 0.01 above
/// the plane z = 0 with friction `mu` under smooth contact.
fn scene(flat: Option<f64>) -> Scene {
    scene_under(SolverKind::Newton, flat)
}

/// [`scene`] under `solver` (XPBD: 20 sweeps, rigid contact with its friction rows).
fn scene_under(solver: SolverKind, flat: Option<f64>) -> Scene {
    let mut s = small_scene(5, 5, 3, 20, 2e3, BendKind::Distance(20.0));
    s.physics.solver = Some(solver);
    if let Some(mu) = flat {
        s.cloth.top_left = [-0.5, -0.5, 0.01];
        s.cloth.down = [0.0, 1.0, 0.0];
        let mut floor = behind("plane", ObstacleRole::Collider);
        if let cloth::scene::Obstacle::Plane(p) = &mut floor {
            p.friction = Some(mu);
        }
        s.obstacles = vec![floor];
        if solver == SolverKind::Newton {
            s.physics.contact = common::contact_model(ContactModel::Smooth);
        }
    }
    s.validate().unwrap();
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4, ..ProptestConfig::default() })]

    /// A hanging cloth swung in free space.
    #[test]
    fn free_space_tangents_match_central_differences(
        dx in -0.1f64..0.1, dy in -0.1f64..0.1, dz in -0.05f64..0.05, seed in 1u64..1000,
    ) {
        let s = scene(None);
        let u = controls(&model(&s, None), [dx, dy, dz]);
        check(&s, &u, &["stretch", "bending", "mass", "gravity"], seed)?;
    }

    /// A flat cloth dragged over a floor with friction, under smooth contact.
    #[test]
    fn smooth_contact_tangents_match_central_differences(
        mu in 0.2f64..1.5, dx in 0.01f64..0.08, dy in -0.05f64..0.05, seed in 1u64..1000,
    ) {
        let s = scene(Some(mu));
        let u = controls(&model(&s, None), [dx, dy, -0.02]);
        check(&s, &u, &["stretch", "bending", "mass", "gravity", "friction"], seed)?;
    }
}

/// [`scene`] lying on a plate 4 cm thick instead of the floor (the same top face): narrower than
/// the cloth's edges (0.25), so its edges carry barrier points that press and rub on it too.
fn on_a_plate(mu: f64) -> Scene {
    let mut s = scene(Some(mu));
    s.obstacles = vec![cloth::scene::Obstacle::Box(cloth::scene::BoxSpec {
        center: [0.0, 0.0, -0.02],
        half_extents: [2.0, 2.0, 0.02],
        rotation: None,
        role: ObstacleRole::Collider,
        friction: Some(mu),
    })];
    s.validate().unwrap();
    assert!(
        model(&s, None).edge_barrier.is_some(),
        "edge points on the plate"
    );
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4, ..ProptestConfig::default() })]

    /// A flat cloth dragged over a plate narrower than its edges (edge points with friction).
    #[test]
    fn edge_contact_tangents_match_central_differences(
        mu in 0.2f64..1.5, dx in 0.01f64..0.08, dy in -0.05f64..0.05, seed in 1u64..1000,
    ) {
        let s = on_a_plate(mu);
        let u = controls(&model(&s, None), [dx, dy, -0.02]);
        check(&s, &u, &["stretch", "bending", "mass", "gravity", "friction"], seed)?;
    }

    /// XPBD in free space, a user's constraint type included.
    #[test]
    fn xpbd_free_space_tangents_match_central_differences(
        dx in -0.1f64..0.1, dy in -0.1f64..0.1, dz in -0.05f64..0.05, seed in 1u64..1000,
    ) {
        let s = with_area(scene_under(SolverKind::Xpbd, None));
        let u = controls(&model(&s, None), [dx, dy, dz]);
        check(&s, &u, &["stretch", "bending", "triangle_area", "mass", "gravity"], seed)?;
    }

    /// XPBD dragging a flat cloth over a floor: rigid contact rows with Coulomb friction.
    #[test]
    fn xpbd_friction_tangents_match_central_differences(
        mu in 0.2f64..1.5, dx in 0.01f64..0.08, dy in -0.05f64..0.05, seed in 1u64..1000,
    ) {
        let s = scene_under(SolverKind::Xpbd, Some(mu));
        let u = controls(&model(&s, None), [dx, dy, -0.02]);
        check(&s, &u, &["stretch", "bending", "mass", "gravity", "friction"], seed)?;
    }
}

/// A user's constraint type under Newton.
#[test]
fn custom_constraint_tangents_match_central_differences_under_newton() {
    let s = with_area(scene(None));
    let u = controls(&model(&s, None), [0.05, -0.03, 0.02]);
    check(&s, &u, &["triangle_area", "stretch"], 3).unwrap();
}

/// Rigid contact rows: the tangents stay in the contact planes and match central differences.
#[test]
fn rigid_contact_tangents_match_central_differences() {
    let mut s = scene(None);
    s.obstacles = vec![behind("box", ObstacleRole::Collider)];
    s.physics.contact = common::contact_model(ContactModel::Rigid);
    s.validate().unwrap();
    let u = controls(&model(&s, None), [0.0, 0.2, 0.0]);
    check(&s, &u, &["stretch", "bending", "mass", "gravity"], 7).unwrap();
}

/// A parameter the model has nothing of is an error naming it.
#[test]
fn missing_parameters_are_named_errors() {
    let s = scene(None);
    let m = model(&s, None);
    let u = m.zero_controls();
    let states = m.simulate(&u).unwrap();
    let err = m
        .parameter_tangents(&states, &u, &[Parameter::Friction])
        .unwrap_err()
        .to_string();
    assert!(err.contains("friction"), "{err}");
    let err = Parameter::parse("shear").value(&s).unwrap_err().to_string();
    assert!(err.contains("no parameter `shear`"), "{err}");
}

/// Derivatives with respect to the controls (`Model::newton_control_tangents`) against central
/// differences, in free space and on smooth contact with friction; and rollouts whose steps start
/// from guesses (`Model::simulate_newton_guided`): from their own states they are themselves,
/// from the tangents' prediction for nearby controls they are those controls' rollout.
mod control_tangents {
    use super::common::XorShift;
    use super::controls;
    use autodiff::Tensor;
    use cloth::{ClothError, Model, NewtonSettings, Solver};
    use proptest::prelude::*;

    /// The file's 5 × 5 cloth under Newton to 1e-12 ([`super::scene`]): hanging in free space,
    /// or (`mu`) lying on the floor with smooth contact of friction `mu`.
    fn model(mu: Option<f64>) -> Model {
        super::model(&super::scene(mu), None)
    }

    fn settings(m: &Model) -> NewtonSettings {
        match m.solver {
            Solver::Newton(s) => s,
            Solver::Xpbd => unreachable!("the models here are Newton's"),
        }
    }

    /// `u + s·du`.
    fn moved(u: &Tensor, du: &[f64], s: f64) -> Tensor {
        let mut v = u.clone();
        v.data_mut()
            .iter_mut()
            .zip(du)
            .for_each(|(a, d)| *a += s * d);
        v
    }

    /// Every step's tangent along a random control direction against a central difference of step
    /// 1e-6 (in metres per unit direction, the direction's largest entry 1).
    fn check(m: &Model, u: &Tensor, seed: u64) -> Result<(), TestCaseError> {
        let states = m.simulate(u).unwrap();
        let tangents = m.newton_control_tangents(&states, u).unwrap();
        let mut rng = XorShift::new(seed);
        let du = rng.direction(u.data().len());
        let largest = du.iter().fold(0.0f64, |a, d| a.max(d.abs()));
        let du: Vec<f64> = du.iter().map(|d| d / largest).collect();
        let h = 1e-6;
        let plus = m.simulate(&moved(u, &du, h)).unwrap();
        let minus = m.simulate(&moved(u, &du, -h)).unwrap();
        for t in 1..=m.task.horizon {
            let an = tangents.predict(t, &du);
            let scale = an.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            prop_assert!(scale > 0.0, "step {t}: the tangent is zero");
            for (i, a) in an.iter().enumerate() {
                let fd = (plus[t].data()[i] - minus[t].data()[i]) / (2.0 * h);
                prop_assert!(
                    (fd - a).abs() <= 1e-5 * scale + 1e-7,
                    "step {t}, coordinate {i}: tangent {a:e}, central difference {fd:e}"
                );
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 4, ..ProptestConfig::default() })]

        /// A hanging cloth swung in free space.
        #[test]
        fn free_space_control_tangents_match_central_differences(
            dx in -0.1f64..0.1, dy in -0.1f64..0.1, dz in -0.05f64..0.05, seed in 1u64..1000,
        ) {
            let m = model(None);
            check(&m, &controls(&m, [dx, dy, dz]), seed)?;
        }

        /// A flat cloth dragged over a floor with friction, under smooth contact.
        #[test]
        fn smooth_contact_control_tangents_match_central_differences(
            mu in 0.2f64..1.5, dx in 0.01f64..0.08, dy in -0.05f64..0.05, seed in 1u64..1000,
        ) {
            let m = model(Some(mu));
            check(&m, &controls(&m, [dx, dy, -0.02]), seed)?;
        }
    }

    /// The largest coordinate difference between two rollouts.
    fn distance(a: &[Tensor], b: &[Tensor]) -> f64 {
        a.iter()
            .zip(b)
            .flat_map(|(x, y)| x.data().iter().zip(y.data()).map(|(p, q)| (p - q).abs()))
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_rollout_guided_by_its_own_states_is_itself() {
        for mu in [None, Some(0.8)] {
            let m = model(mu);
            let u = controls(&m, [0.03, -0.02, -0.01]);
            let (states, _) = m.simulate_newton(&u, &settings(&m)).unwrap();
            let zero = vec![Tensor::zeros(m.n_particles(), 3); states.len()];
            let (guided, from_guess) = m
                .simulate_newton_guided(&u, &settings(&m), &states, &zero)
                .unwrap();
            assert_eq!(
                from_guess, m.task.horizon,
                "{mu:?}: every step from its guess"
            );
            let d = distance(&states, &guided.states);
            assert!(d < 1e-9, "{mu:?}: the guided rollout is {d:e} away");
        }
    }

    #[test]
    fn guided_by_the_tangents_prediction_a_trial_is_its_own_rollout() {
        for mu in [None, Some(0.8)] {
            let m = model(mu);
            let u = controls(&m, [0.03, -0.02, -0.01]);
            let (states, _) = m.simulate_newton(&u, &settings(&m)).unwrap();
            let tangents = m.newton_control_tangents(&states, &u).unwrap();
            let du = XorShift::new(7).direction(u.data().len());
            let trial = moved(&u, &du, 1e-3);
            let moves: Vec<Tensor> = (0..=m.task.horizon)
                .map(|t| {
                    let dx = tangents.predict(t, &du);
                    Tensor::new(m.n_particles(), 3, dx.iter().map(|d| 1e-3 * d).collect())
                })
                .collect();
            let guesses: Vec<Tensor> = (states.iter().zip(&moves))
                .map(|(x, d)| {
                    let mut g = x.clone();
                    g.add_assign(d);
                    g
                })
                .collect();
            let (plain, _) = m.simulate_newton(&trial, &settings(&m)).unwrap();
            let (guided, from_guess) = m
                .simulate_newton_guided(&trial, &settings(&m), &states, &moves)
                .unwrap();
            assert_eq!(from_guess, m.task.horizon, "{mu:?}");
            let d = distance(&plain, &guided.states);
            assert!(
                d < 1e-9,
                "{mu:?}: the guided trial is {d:e} from its plain rollout"
            );
            // The prediction itself is first order: its error is second order in the move.
            let predicted = distance(&plain, &guesses);
            assert!(predicted < 1e-4, "{mu:?}: predicted {predicted:e} off");
        }
    }

    #[test]
    fn guesses_that_do_not_match_the_model_are_named_errors() {
        let m = model(None);
        let u = controls(&m, [0.03, 0.0, 0.0]);
        let (states, _) = m.simulate_newton(&u, &settings(&m)).unwrap();
        let zero = vec![Tensor::zeros(m.n_particles(), 3); states.len()];
        let e = m
            .simulate_newton_guided(&u, &settings(&m), &states[1..], &zero)
            .err()
            .expect("too few guesses");
        assert!(matches!(e, ClothError::Guesses(_)), "{e}");
        assert!(
            e.to_string().contains("from: 3 states for a horizon of 3"),
            "{e}"
        );
        let mut wrong = zero.clone();
        wrong[2] = Tensor::zeros(4, 3);
        let e = m
            .simulate_newton_guided(&u, &settings(&m), &states, &wrong)
            .err()
            .expect("a move of the wrong shape");
        assert!(e.to_string().contains("moves: state 2 is 4 × 3"), "{e}");
    }
}
