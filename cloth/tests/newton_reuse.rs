//! Factorizations reused across a Newton rollout and its gradients. Each step's final
//! factorization (the exact Hessian at its converged state, the convergence test's) kept by the
//! forward gives the implicit gradients bit for bit without a factorization, and only where the
//! gradient pass assembles the very same matrix; the budget bounds what is kept. Chord steps end
//! at the same minimizers with fewer factorizations.

mod common;

use autodiff::{Tape, Tensor, Var};
use cloth::internals::NewtonSystem;
use cloth::scene::{ContactModel, ObstacleRole, SolverKind};
use cloth::StepCost;
use cloth::StepStats;
use cloth::{Model, RolloutLimits, Scene};
use cloth::{NewtonSettings, Solver};
use common::{assert_minimizers, bitwise_eq, plane, small_scene, BendKind, XorShift};

/// Newton's settings of `model`.
fn settings(model: &Model) -> NewtonSettings {
    match model.solver {
        Solver::Newton(s) => s,
        Solver::Xpbd => panic!("a Newton model"),
    }
}

/// `u_obstacle` refined to `n × n` under Newton, at its initial guess plus a small random change
/// (so that no step is exactly symmetric).
fn u_obstacle(n: usize, seed: u64) -> (Model, Tensor) {
    let mut scene = Scene::builtin("u_obstacle").unwrap().refined(n, n).unwrap();
    scene.physics.solver = Some(SolverKind::Newton);
    let model = Model::from_scene(&scene).unwrap();
    let mut u = scene.initial_controls();
    let mut rng = XorShift::new(seed);
    for v in u.data_mut() {
        *v += 1e-3 * rng.uniform(-1.0, 1.0);
    }
    (model, u)
}

/// A 5 × 5 cloth lowered onto a floor (a collider plane) and dragged: active contact rows.
fn on_the_floor() -> (Model, Tensor) {
    let mut s = small_scene(5, 5, 4, 100, 2e3, BendKind::Distance(20.0));
    s.obstacles = vec![plane(
        [0.0, 0.0, 1.2],
        [0.0, 0.0, 1.0],
        ObstacleRole::Collider,
    )];
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = common::contact_model(ContactModel::Rigid);
    s.validate().unwrap();
    let model = Model::from_scene(&s).unwrap();
    let mut u = model.zero_controls();
    for t in 0..model.task.horizon {
        u.row_mut(t)
            .copy_from_slice(&[0.06, 0.02, -0.25, 0.05, 0.02, -0.25]);
    }
    (model, u)
}

fn cases() -> Vec<(&'static str, Model, Tensor)> {
    let (a, ua) = u_obstacle(8, 1);
    let (b, ub) = u_obstacle(12, 2);
    let (c, uc) = on_the_floor();
    vec![
        ("u_obstacle 8", a, ua),
        ("u_obstacle 12", b, ub),
        ("floor", c, uc),
    ]
}

#[test]
fn kept_factorizations_give_the_same_gradients_bit_for_bit() {
    for (name, model, u) in cases() {
        let set = settings(&model);
        let horizon = model.task.horizon;
        let beta = model.task.beta;
        let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| model.record_loss(tape, t, x, beta);
        // A second cost through the same factorizations: half the elastic energy.
        let other = |tape: &mut Tape, _: usize, _: Var, x: Var| {
            model.record_energy(tape, x).map(|e| tape.scale(e, 0.5))
        };
        let costs: Vec<StepCost<'_>> = vec![&loss, &other];
        let (states, _) = model.simulate_newton(&u, &set).unwrap();
        let (plain, counts) = model.newton_gradients_kept(&states, &u, &costs, None);
        assert_eq!((counts.factorized, counts.reused), (horizon, 0), "{name}");
        let one = model
            .simulate_newton_keeping(&u, &set, usize::MAX)
            .unwrap()
            .kept
            .bytes()
            / horizon;
        for (budget, kept) in [(usize::MAX, horizon), (3 * one, 3), (one - 1, 0)] {
            let rollout = model.simulate_newton_keeping(&u, &set, budget).unwrap();
            assert_eq!(rollout.kept.steps(), kept, "{name}: budget {budget}");
            assert!(rollout.kept.bytes() <= budget);
            for (a, b) in rollout.states.iter().zip(&states) {
                assert!(bitwise_eq(a, b), "{name}: keeping changed the rollout");
            }
            let (grads, counts) =
                model.newton_gradients_kept(&rollout.states, &u, &costs, Some(rollout.kept));
            // The first steps' are kept; the last step's is the forward's last factorization,
            // still in the system.
            let reused = kept + usize::from(kept < horizon);
            assert_eq!(
                (counts.factorized, counts.reused),
                (horizon - reused, reused),
                "{name}: budget {budget}"
            );
            for (g, p) in grads.iter().zip(&plain) {
                assert!(bitwise_eq(g, p), "{name}: budget {budget}");
            }
        }
    }
}

#[test]
fn a_kept_factorization_serves_only_its_own_matrix() {
    // Factorizations kept at controls `u` and a gradient pass over the rollout of other
    // controls: every step's matrix differs, so each is factorized, and the gradients are
    // those of the other rollout.
    let (model, u) = u_obstacle(8, 3);
    let set = settings(&model);
    let mut v = u.clone();
    v.data_mut().iter_mut().for_each(|a| *a += 1e-6);
    let beta = model.task.beta;
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| model.record_loss(tape, t, x, beta);
    let costs: Vec<StepCost<'_>> = vec![&loss];
    let at_u = model.simulate_newton_keeping(&u, &set, usize::MAX).unwrap();
    let (states_v, _) = model.simulate_newton(&v, &set).unwrap();
    let (plain, _) = model.newton_gradients_kept(&states_v, &v, &costs, None);
    let (grads, counts) = model.newton_gradients_kept(&states_v, &v, &costs, Some(at_u.kept));
    assert_eq!((counts.factorized, counts.reused), (model.task.horizon, 0));
    assert!(bitwise_eq(&grads[0], &plain[0]));
}

#[test]
fn evaluate_keeps_factorizations_within_the_checkpoint_budget() {
    let (mut model, u) = u_obstacle(12, 4);
    let delta = model.task.delta;
    let beta = model.task.beta;
    let loss = |tape: &mut Tape, t: usize, _: Var, x: Var| model.record_loss(tape, t, x, beta);
    let recorded = model.simulate_recording(&u, &[&loss]).unwrap();
    let (steps, bytes) = recorded.kept_factorizations().unwrap();
    assert_eq!(steps, model.task.horizon, "12 × 12 fits the default budget");
    assert!(bytes <= model.checkpoint_budget);
    let kept = model.evaluate(&u, delta, true).unwrap();
    model.checkpoint_budget = 0;
    let refactorized = model.evaluate(&u, delta, true).unwrap();
    assert!(bitwise_eq(
        kept.grad_l.as_ref().unwrap(),
        refactorized.grad_l.as_ref().unwrap()
    ));
    assert!(bitwise_eq(
        kept.grad_c.as_ref().unwrap(),
        refactorized.grad_c.as_ref().unwrap()
    ));
}

/// The factorizations of a rollout.
fn factorizations(stats: &[StepStats]) -> usize {
    stats.iter().map(|s| s.factorizations).sum()
}

#[test]
fn chord_steps_end_at_the_same_minimizers_with_fewer_factorizations() {
    for (name, model, u) in cases() {
        let chord = settings(&model);
        assert!(chord.chord_steps, "chord steps are the default");
        let newton = NewtonSettings {
            chord_steps: false,
            ..chord
        };
        let (a, sa) = model.simulate_newton(&u, &chord).unwrap();
        let (b, sb) = model.simulate_newton(&u, &newton).unwrap();
        for t in 1..a.len() {
            let scale = b[t].data().iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let d = a[t]
                .data()
                .iter()
                .zip(b[t].data())
                .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
            assert!(d <= 1e-8 * scale, "{name}: step {t} differs by {d:.3e}");
            let s = &sa[t - 1];
            assert!(
                s.residual <= chord.tolerance || s.at_roundoff,
                "{name}: {s:?}"
            );
        }
        assert_minimizers(&model, &a, &u);
        if name == "floor" {
            let mut system = NewtonSystem::new(&model).unwrap();
            let xt = model.begin_step(&a[2], &model.step_controls(&u, 2));
            assert!(system.factorize_exact(a[3].data(), xt.data()));
            assert!(system.contacts.n_active() > 0, "particles on the floor");
        }
        assert!(
            sa.iter().map(|s| s.chord_steps).sum::<usize>() > 0,
            "{name}"
        );
        assert!(sb.iter().all(|s| s.chord_steps == 0));
        assert!(
            factorizations(&sa) < factorizations(&sb),
            "{name}: {} vs {}",
            factorizations(&sa),
            factorizations(&sb)
        );
    }
}

#[test]
fn chord_steps_do_not_change_the_gradients_beyond_the_tolerance() {
    let (mut model, u) = u_obstacle(12, 5);
    let delta = model.task.delta;
    let chord = model.evaluate_loss_gradient(&u, delta).unwrap();
    model.solver = Solver::Newton(NewtonSettings {
        chord_steps: false,
        ..settings(&model)
    });
    let newton = model.evaluate_loss_gradient(&u, delta).unwrap();
    let (a, b) = (chord.grad_l.unwrap(), newton.grad_l.unwrap());
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff: Vec<f64> = a.data().iter().zip(b.data()).map(|(p, q)| p - q).collect();
    let rel = norm(&diff) / norm(b.data());
    assert!(rel < 1e-7, "{rel:.3e}");
}

#[test]
fn a_counted_rollout_stops_past_its_bound_and_names_the_step() {
    let (model, u) = on_the_floor();
    let (states, stats) = model.simulate_newton(&u, &settings(&model)).unwrap();
    let per_step: Vec<usize> = stats.iter().map(|s| s.iterations).collect();
    let work: usize = per_step.iter().sum();
    assert!(per_step[0] >= 2, "{per_step:?}");
    // Unbounded: the same states and each step's Newton iterations.
    let (counted, w) = model
        .simulate_counted(&u, &RolloutLimits::default())
        .unwrap();
    assert_eq!(w, per_step);
    assert!(states.iter().zip(&counted).all(|(a, b)| bitwise_eq(a, b)));
    let expect_exceeded =
        |limits: &RolloutLimits, at: (usize, usize)| match model.simulate_counted(&u, limits) {
            Err(cloth::ClothError::NewtonWorkExceeded {
                step,
                iterations,
                bound,
            }) => assert_eq!((step, iterations), at, "bound {bound}"),
            other => panic!("expected NewtonWorkExceeded, got {other:?}"),
        };
    // A total bound the first two steps pass: stops in step 2, at the bound.
    let bound = per_step[0] + per_step[1] - 1;
    expect_exceeded(&RolloutLimits::total(bound), (2, bound));
    // A schedule holding step 1 below its work stops there, however loose the total.
    let schedule = RolloutLimits {
        cumulative_iterations: vec![per_step[0] - 1, usize::MAX],
        ..RolloutLimits::default()
    };
    expect_exceeded(&schedule, (1, per_step[0] - 1));
    // Exactly the rollout's work, in all or step by step, is within the bound.
    assert!(model
        .simulate_counted(&u, &RolloutLimits::total(work))
        .is_ok());
    let cumulative: Vec<usize> = per_step
        .iter()
        .scan(0, |sum, w| {
            *sum += w;
            Some(*sum)
        })
        .collect();
    let exact = RolloutLimits {
        cumulative_iterations: cumulative,
        ..RolloutLimits::default()
    };
    assert!(model.simulate_counted(&u, &exact).is_ok());
    // A deadline already past stops the rollout before its first step, naming it.
    let past = RolloutLimits {
        deadline: Some(std::time::Instant::now()),
        ..RolloutLimits::default()
    };
    let stopped = |m: &Model| {
        matches!(
            m.simulate_counted(&u, &past),
            Err(cloth::ClothError::RolloutStopped { step: 1 })
        )
    };
    assert!(stopped(&model));
    // XPBD counts no work and is never held to it, but stops at the deadline too.
    let mut xpbd = model.clone();
    xpbd.solver = Solver::Xpbd;
    let zero = xpbd.simulate_counted(&u, &RolloutLimits::total(0)).unwrap();
    assert_eq!(zero.1, vec![0; per_step.len()]);
    assert!(stopped(&xpbd));
}
