//! The Newton solver's forward pass: convergence on `u_obstacle`, its state against XPBD's
//! limit, degenerate geometry, and the solver settings' validation.

mod common;

use autodiff::Tensor;
use cloth::internals::NewtonSystem;
use cloth::scene::{ObstacleRole, SolverKind, Stiffness};
use cloth::{ClothError, Model, Scene};
use cloth::{NewtonSettings, Solver};
use common::{small_scene, spheres, BendKind};

fn newton_scene(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.physics.solver = Some(SolverKind::Newton);
    s
}

/// `‖∇Φ(x)‖ / ‖∇Φ(x̃)‖` for step `t`'s state `x` of a rollout.
fn relative_residual(model: &Model, states: &[Tensor], u: &Tensor, t: usize, x: &Tensor) -> f64 {
    let sys = NewtonSystem::new(model).unwrap();
    let xt = model.begin_step(&states[t - 1], &model.step_controls(u, t - 1));
    let mut g = vec![0.0; sys.pattern.n_dof];
    sys.pattern.assemble(xt.data(), xt.data(), &mut g, None);
    let r0 = g.iter().map(|v| v * v).sum::<f64>().sqrt();
    sys.pattern.assemble(x.data(), xt.data(), &mut g, None);
    g.iter().map(|v| v * v).sum::<f64>().sqrt() / r0
}

#[test]
fn newton_converges_on_u_obstacle_in_few_iterations() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let u = scene.initial_controls();
    let model = Model::from_scene(&newton_scene(&scene)).unwrap();
    assert_eq!(model.solver, Solver::Newton(NewtonSettings::default()));
    let (states, stats) = model
        .simulate_newton(&u, &NewtonSettings::default())
        .unwrap();
    for (t, s) in stats.iter().enumerate() {
        assert!(
            s.residual <= 1e-10 || s.at_roundoff,
            "step {}: {s:?}",
            t + 1
        );
        assert!(s.iterations <= 15, "step {}: {s:?}", t + 1);
        let r = relative_residual(&model, &states, &u, t + 1, &states[t + 1]);
        assert!(r <= 1e-9, "step {}: independent residual {r:e}", t + 1);
    }
    // `simulate` dispatches on the solver.
    assert_eq!(model.simulate(&u).unwrap(), states);
}

/// XPBD's Gauss–Seidel limit is not the minimizer of `Φ`: each projection moves particles along
/// `∇C` at the position it is applied, and the accumulated `Σ ∇C(x_k) Δλ_k` differs from
/// `∇C(x*) λ*` for nonlinear constraints. Measured on u_obstacle step 1: the relative `‖∇Φ‖`
/// of XPBD's state stalls at 1.7496e-2 from 1000 iterations on (3000: 1.7496e-2 too), and Newton's state (the minimizer)
/// has the lower `Φ` at every step.
#[test]
fn xpbd_limit_is_a_different_fixed_point_with_higher_energy() {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    let u = scene.initial_controls();
    let newton = Model::from_scene(&newton_scene(&scene)).unwrap();
    let (ns, _) = newton
        .simulate_newton(&u, &NewtonSettings::default())
        .unwrap();
    let mut residuals = Vec::new();
    for iterations in [1000, 3000] {
        scene.physics.iterations = iterations;
        let xpbd = Model::from_scene(&scene).unwrap();
        let xs = xpbd.simulate(&u).unwrap();
        residuals.push(relative_residual(&xpbd, &xs, &u, 1, &xs[1]));
        // Each step from the same previous state: Newton's Φ is the smaller.
        let sys = NewtonSystem::new(&xpbd).unwrap();
        let xt = xpbd.begin_step(&xs[0], &xpbd.step_controls(&u, 0));
        let (phi_n, phi_x) = (
            sys.pattern.energy(ns[1].data(), xt.data()),
            sys.pattern.energy(xs[1].data(), xt.data()),
        );
        assert!(phi_n < phi_x, "Φ Newton {phi_n} vs XPBD {phi_x}");
    }
    assert!((1e-2..3e-2).contains(&residuals[0]), "{residuals:?}");
    assert!(
        (residuals[0] - residuals[1]).abs() < 1e-4 * residuals[0],
        "XPBD has reached its own limit: {residuals:?}"
    );
}

#[test]
fn degenerate_geometry_stays_finite() {
    // A zero-length edge (two particles at one point) and degenerate triangles (a collapsed
    // row), with dihedral bending whose angle is undefined there.
    let mut scene = newton_scene(&small_scene(4, 4, 2, 10, 1e3, BendKind::Dihedral(1.0)));
    scene.physics.gravity = [0.0, 0.0, -9.8];
    let mut model = Model::from_scene(&scene).unwrap();
    let mut rest = model.start.clone();
    let p5 = rest.row(5).to_vec();
    rest.row_mut(6).copy_from_slice(&p5);
    model.start = rest;
    let u = model.zero_controls();
    match model.simulate(&u) {
        Ok(states) => {
            assert!(states
                .iter()
                .all(|s| s.data().iter().all(|v| v.is_finite())));
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(
                matches!(
                    e,
                    ClothError::NewtonNotConverged { .. } | ClothError::Diverged { .. }
                ),
                "{msg}"
            );
        }
    }
    // A particle exactly on a safety sphere's surface: the safety term's kink is outside Φ.
    let mut s = newton_scene(&small_scene(3, 3, 1, 10, 1e3, BendKind::None));
    let m = Model::from_scene(&s).unwrap();
    let p = m.start.row(4).to_vec();
    s.obstacles = vec![spheres(
        vec![[p[0], p[1] + 0.1, p[2]]],
        vec![0.1],
        ObstacleRole::Safety,
    )];
    let m = Model::from_scene(&s).unwrap();
    let e = m.evaluate(&m.zero_controls(), 0.0, true).unwrap();
    assert!(e.grad_c.unwrap().data().iter().all(|v| v.is_finite()));
}

#[test]
fn newton_rejects_rigid_constraints_naming_the_field() {
    let mut s = newton_scene(&small_scene(3, 3, 1, 10, 1e3, BendKind::None));
    s.material.stretch = Stiffness::Infinite;
    let e = Model::from_scene(&s).err().unwrap().to_string();
    assert!(e.contains("material.stretch") && e.contains("rigid"), "{e}");
    // Colliders are contact rows (tests/newton_contact.rs), accepted.
    let mut s = newton_scene(&small_scene(3, 3, 1, 10, 1e3, BendKind::None));
    s.obstacles = vec![spheres(
        vec![[0.0, 0.0, 0.0]],
        vec![0.1],
        ObstacleRole::Collider,
    )];
    assert!(Model::from_scene(&s).is_ok());
    // A rigid group added in code is caught when the model is solved.
    let s = small_scene(3, 3, 1, 10, f64::INFINITY, BendKind::None);
    let mut m = Model::from_scene(&s).unwrap();
    m.solver = Solver::Newton(NewtonSettings::default());
    let e = m.simulate(&m.zero_controls()).err().unwrap().to_string();
    assert!(e.contains("`stretch`") && e.contains("rigid"), "{e}");
}

#[test]
fn newton_settings_are_validated_with_their_json_path() {
    let base = small_scene(3, 3, 1, 10, 1e3, BendKind::None);
    for (tol, ok) in [(1e-8, true), (0.0, false), (1.0, false), (f64::NAN, false)] {
        let mut s = newton_scene(&base);
        s.physics.tolerance = Some(tol);
        let r = s.validate();
        assert_eq!(r.is_ok(), ok, "tolerance {tol}: {r:?}");
        if let Err(e) = r {
            assert!(e.to_string().contains("physics.tolerance"), "{e}");
        }
    }
    let mut s = newton_scene(&base);
    s.physics.max_newton_iterations = Some(0);
    let e = s.validate().err().unwrap().to_string();
    assert!(e.contains("physics.max_newton_iterations"), "{e}");
    let mut s = newton_scene(&base);
    s.physics.load_steps = Some(0);
    let e = s.validate().err().unwrap().to_string();
    assert!(e.contains("physics.load_steps"), "{e}");
    s.physics.load_steps = Some(3);
    let Solver::Newton(settings) = s.solver() else {
        panic!("newton scene");
    };
    assert_eq!(settings.load_steps, 3);
    // Too few iterations is a named error, not a silent state.
    let mut s = newton_scene(&base);
    s.physics.max_newton_iterations = Some(1);
    let m = Model::from_scene(&s).unwrap();
    let e = m.simulate(&m.zero_controls()).err().unwrap();
    assert!(
        matches!(
            e,
            ClothError::NewtonNotConverged {
                step: 1,
                iterations: 1,
                ..
            }
        ),
        "{e}"
    );
    // JSON: a solver the scene does not name is not written, "newton" round-trips.
    let mut unnamed = base.clone();
    unnamed.physics.solver = None;
    let json = serde_json::to_value(&unnamed).unwrap();
    assert!(json["physics"].get("solver").is_none());
    let mut v = json.clone();
    v["physics"]["solver"] = serde_json::json!("newton");
    v["physics"]["tolerance"] = serde_json::json!(1e-9);
    let s: Scene = serde_json::from_value(v).unwrap();
    assert_eq!(s.physics.solver, Some(SolverKind::Newton));
    assert_eq!(
        s.solver(),
        Solver::Newton(NewtonSettings {
            tolerance: 1e-9,
            max_iterations: cloth::DEFAULT_MAX_ITERATIONS,
            ..NewtonSettings::default()
        })
    );
}

/// A step whose Newton iteration comes to rest at a saddle of `Φ` (measured on a heavy 25 × 25
/// cloth at a plan's controls: step 8 stopped at round-off with an indefinite exact Hessian,
/// which was the error `NewtonSaddle`, and before that a panic in the implicit gradient) leaves
/// it along the exact Hessian's unstable mode and ends at a minimizer. Newton's path meets that
/// saddle without chord steps; with them (the default) the same step's path does not, and ends
/// at the same states.
#[test]
fn a_saddle_of_phi_is_left_along_its_unstable_mode() {
    let mut scene = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/routes/ball_25.json"
    ))
    .unwrap();
    scene.cloth.particle_mass = 1.0;
    let model = Model::from_scene(&newton_scene(&scene)).unwrap();
    const U: [[[f64; 3]; 3]; 10] = [
        [
            [
                -0.0022241379552590122,
                0.005207765064453623,
                -0.0396318039551599,
            ],
            [
                -0.0036104055750879878,
                -0.00310910793961452,
                -0.039611958971740704,
            ],
            [
                -0.0053225416542530685,
                -0.006347468376320792,
                -0.03883470382698251,
            ],
        ],
        [
            [
                -0.0022241379529490666,
                0.005207765064317012,
                -0.03963180395681043,
            ],
            [
                -0.003610405576434779,
                -0.0031091079398280794,
                -0.03961195896548435,
            ],
            [
                -0.00532254165423708,
                -0.006347468376425775,
                -0.038834703827585124,
            ],
        ],
        [
            [
                -0.002224137951800403,
                0.005207765064461331,
                -0.03963180395853441,
            ],
            [
                -0.003610405580065516,
                -0.003109107936921595,
                -0.03961195896510648,
            ],
            [
                -0.005322541654462796,
                -0.006347468376668553,
                -0.03883470382865551,
            ],
        ],
        [
            [
                -0.002224137950336627,
                0.00520776506453022,
                -0.03963180396095079,
            ],
            [
                -0.00361040558310752,
                -0.0031091079339899226,
                -0.039611958969402276,
            ],
            [
                -0.005322541654891997,
                -0.006347468376549631,
                -0.03883470383027571,
            ],
        ],
        [
            [
                -0.0022241379485640877,
                0.005207765064344188,
                -0.03963180396429196,
            ],
            [
                -0.0036104055845826337,
                -0.0031091079319296145,
                -0.039611958974192736,
            ],
            [
                -0.005322541655454753,
                -0.006347468376340048,
                -0.03883470383205809,
            ],
        ],
        [
            [
                -0.0022241379467421675,
                0.0052077650640685235,
                -0.039631803967937786,
            ],
            [
                -0.0036104055849637603,
                -0.003109107930801349,
                -0.03961195897879449,
            ],
            [
                -0.005322541656015551,
                -0.0063474683760220306,
                -0.03883470383377739,
            ],
        ],
        [
            [
                -0.0022241379452855132,
                0.005207765063793385,
                -0.039631803971381094,
            ],
            [
                -0.0036104055848196885,
                -0.003109107930136211,
                -0.03961195898176347,
            ],
            [
                -0.005322541656485952,
                -0.006347468375292327,
                -0.03883470383531157,
            ],
        ],
        [
            [
                -0.0022241379444049116,
                0.00520776506360869,
                -0.03963180397362578,
            ],
            [
                -0.003610405584224142,
                -0.0031091079297498924,
                -0.03961195898441078,
            ],
            [
                -0.005322541656856143,
                -0.00634746837497177,
                -0.03883470383635065,
            ],
        ],
        [
            [
                -0.0022241379439195586,
                0.005207765063456137,
                -0.039631803974923954,
            ],
            [
                -0.003610405583604292,
                -0.0031091079295647007,
                -0.03961195898632506,
            ],
            [
                -0.0053225416570631115,
                -0.006347468374866094,
                -0.03883470383693516,
            ],
        ],
        [
            [
                -0.0022241379436643296,
                0.005207765063392006,
                -0.03963180397557877,
            ],
            [
                -0.0036104055831357425,
                -0.00310910792942546,
                -0.0396119589871474,
            ],
            [
                -0.005322541657164176,
                -0.0063474683748071786,
                -0.03883470383718801,
            ],
        ],
    ];
    let u = Tensor::new(10, 9, U.iter().flatten().flatten().copied().collect());
    let Solver::Newton(default) = model.solver else {
        unreachable!()
    };
    let settings = NewtonSettings {
        chord_steps: false,
        ..default
    };
    let (states, stats) = model.simulate_newton(&u, &settings).unwrap();
    assert!(stats[7].escapes >= 1, "step 8: {:?}", stats[7]);
    let (chord, chord_stats) = model.simulate_newton(&u, &default).unwrap();
    for (a, b) in states.iter().zip(&chord) {
        let d = a.data().iter().zip(b.data()).map(|(p, q)| (p - q).abs());
        assert!(d.fold(0.0, f64::max) < 1e-9);
    }
    let count = |s: &[cloth::StepStats]| -> usize { s.iter().map(|s| s.factorizations).sum() };
    assert!(count(&chord_stats) < count(&stats));
    assert_eq!(
        chord_stats[7].escapes, 0,
        "with chord steps: {:?}",
        chord_stats[7]
    );
    assert_eq!(
        stats.iter().map(|s| s.escapes).sum::<usize>(),
        stats[7].escapes
    );
    // Every returned state is a minimizer: the exact Hessian is positive definite there.
    common::assert_minimizers(&model, &states, &u);
    // And the gradient there is defined (this used to panic).
    let ev = model.evaluate_loss_gradient(&u, model.task.delta).unwrap();
    assert!(ev.grad_l.unwrap().data().iter().all(|g| g.is_finite()));
}

/// `physics.shift_stalled` (default true) reaches the solver, and where the projected Hessian
/// stalls (`drop` lowered onto the ground under smooth contact, 25 × 25) the shifted one ends every
/// step at the same tolerance with a tenth fewer Newton iterations or more (measured: 233 against
/// 290; 266 against 451 while the collider filter's lengths were powers of one half).
#[test]
fn shifting_a_stalled_projected_hessian_converges_with_fewer_iterations() {
    let mut scene = newton_scene(&Scene::builtin("drop").unwrap().refined(25, 25).unwrap());
    scene.physics.contact = common::contact_model(cloth::scene::ContactModel::Smooth);
    let with = Model::from_scene(&scene).unwrap();
    scene.physics.shift_stalled = Some(false);
    let without = Model::from_scene(&scene).unwrap();
    let settings = |m: &Model| match m.solver {
        Solver::Newton(s) => s,
        Solver::Xpbd => panic!("a Newton model"),
    };
    assert!(settings(&with).shift_stalled && !settings(&without).shift_stalled);
    let u = common::lowered_and_dragged(&with);
    let mut iterations = [0, 0];
    for (k, m) in [&with, &without].into_iter().enumerate() {
        let (_, stats) = m.simulate_newton(&u, &settings(m)).unwrap();
        iterations[k] = stats.iter().map(|s| s.iterations).sum::<usize>();
        // Every step ends at the solver's tolerance (its own test: a positive definite exact
        // Hessian there, or the solve would have gone on).
        assert!(stats
            .iter()
            .all(|s| s.residual <= NewtonSettings::default().tolerance || s.at_roundoff));
    }
    assert!(
        10 * iterations[0] < 9 * iterations[1],
        "{iterations:?} (with, without)"
    );
}

/// Where the smallest load increment's solve meets the tolerance at a saddle whose unstable mode
/// is found but along which no step lowers `Φ` by more than its round-off (u_obstacle refined to
/// 50 × 50, step 2), the solve gives up at once (`NewtonSaddle`, and the branch following halves
/// the increment). It used to search the same mode again at every following iterate, all within
/// round-off of the saddle, until its steps were round-off and it gave up anyway: the same
/// states, but here 4 searches instead of 2, and at 80 × 80 169 instead of 4 (113 s against 20 s).
#[test]
fn a_saddle_too_shallow_to_leave_is_searched_once() {
    let scene = Scene::builtin("u_obstacle")
        .unwrap()
        .refined(50, 50)
        .unwrap();
    let model = Model::from_scene(&newton_scene(&scene)).unwrap();
    let Solver::Newton(settings) = model.solver else {
        unreachable!("a Newton scene")
    };
    let rollout = model
        .simulate_newton_keeping(&scene.initial_controls(), &settings, 0)
        .unwrap();
    let searches = rollout.kept.saddle_searches();
    assert!(
        searches <= 3,
        "{searches} searches for a saddle's unstable mode"
    );
}
