//! Newton's linear solves by conjugate gradients preconditioned with a reused factorization
//! (`cloth/src/newton/pcg.rs`): the iteration itself on random systems (converged means the
//! residual is within the tolerance; a matrix that is not positive definite is reported, never
//! solved), and whole rollouts with [`LinearSolver::PCG`] against the direct solver's: the same
//! minimizers within Newton's tolerance and the same gradients, which match central differences.

mod common;

use autodiff::Tensor;
use cloth::internals::{pcg, PcgEnd};
use cloth::nalgebra::{DMatrix, DVector};
use cloth::scene::{LinearSolverKind, SolverKind};
use cloth::{LinearSolver, Model, NewtonSettings, Scene, Solver, StepStats};
use common::XorShift;
use proptest::prelude::*;

/// A random `n × n` matrix with entries in `[−1, 1)`.
fn random_matrix(n: usize, rng: &mut XorShift) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |_, _| rng.uniform(-1.0, 1.0))
}

/// Runs [`pcg`] on `a x = b` with the dense preconditioner `m` (symmetric positive definite),
/// never giving up at a slow iteration, returning how it ended and `x`.
fn run(
    a: &DMatrix<f64>,
    m: &DMatrix<f64>,
    b: &DVector<f64>,
    tol: f64,
    max: usize,
) -> (PcgEnd, DVector<f64>) {
    let chol = m.clone().cholesky().expect("an SPD preconditioner");
    let mut x = vec![0.0; b.len()];
    let out = pcg(
        |v, y| y.copy_from_slice((a * DVector::from_column_slice(v)).as_slice()),
        |r| {
            let z = chol.solve(&DVector::from_column_slice(r));
            r.copy_from_slice(z.as_slice());
        },
        b.as_slice(),
        &mut x,
        (tol, max, f64::INFINITY),
    );
    (out.end, DVector::from_vec(x))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// On a random SPD system `A = BᵀB + I`, preconditioned with the factorization of a nearby
    /// SPD matrix `A + εCᵀC` (as Newton's reused factorization is of a nearby Hessian), conjugate
    /// gradients converge, and the true residual `‖b − Ax‖` is within the tolerance.
    #[test]
    fn pcg_residual_is_within_the_tolerance_on_random_spd_systems(
        n in 1usize..40,
        eps in 0.0f64..0.3,
        seed in 1u64..10_000,
    ) {
        let mut rng = XorShift::new(seed);
        let b_mat = random_matrix(n, &mut rng);
        let a = b_mat.transpose() * &b_mat + DMatrix::identity(n, n);
        let c = random_matrix(n, &mut rng);
        let m = &a + eps * c.transpose() * &c;
        let b = DVector::from_fn(n, |_, _| rng.uniform(-1.0, 1.0));
        let tol = 1e-10;
        let (end, x) = run(&a, &m, &b, tol, 10 * n + 10);
        prop_assert_eq!(end, PcgEnd::Converged);
        let residual = (&b - &a * &x).norm();
        prop_assert!(
            residual <= tol * b.norm() * 1.001 + 1e-13 * b.norm(),
            "‖b − Ax‖ = {residual:e}, ‖b‖ = {:e}", b.norm()
        );
    }
}

/// A symmetric matrix with a negative eigenvalue is reported, not solved: with the identity as
/// preconditioner, and with the factorization of a nearby positive definite matrix.
#[test]
fn pcg_reports_negative_curvature() {
    let a = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0, -0.5, 3.0]));
    let b = DVector::from_vec(vec![1.0, 1.0, 1.0, 1.0]);
    let (end, _) = run(&a, &DMatrix::identity(4, 4), &b, 1e-10, 20);
    assert_eq!(end, PcgEnd::NegativeCurvature);
    let m = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0, 0.5, 3.0]));
    let (end, _) = run(&a, &m, &b, 1e-10, 20);
    assert_eq!(end, PcgEnd::NegativeCurvature);
    // The iteration limit is reported too (Newton then factorizes).
    let hard = DMatrix::from_diagonal(&DVector::from_fn(30, |i, _| (1.0 + i as f64).powi(3)));
    let (end, _) = run(
        &hard,
        &DMatrix::identity(30, 30),
        &DVector::repeat(30, 1.0),
        1e-10,
        3,
    );
    assert_eq!(end, PcgEnd::NotConverged);
}

/// `scene` under Newton with `solver`.
fn newton_with(scene: &Scene, solver: LinearSolver, tolerance: f64) -> Model {
    let mut s = scene.clone();
    s.physics.solver = Some(SolverKind::Newton);
    let mut model = Model::from_scene(&s).unwrap();
    let Solver::Newton(settings) = model.solver else {
        unreachable!()
    };
    model.solver = Solver::Newton(NewtonSettings {
        linear_solver: solver,
        tolerance,
        ..settings
    });
    model
}

/// The summed statistics of a rollout.
fn total(stats: &[StepStats]) -> StepStats {
    stats.iter().fold(StepStats::default(), |mut a, s| {
        a.add_work(s);
        a
    })
}

/// Simulates `scene` with both linear solvers at `u`, asserts that every state agrees within
/// `bound` (each is a minimizer to Newton's tolerance) and that conjugate gradients did
/// replace factorizations; returns both models.
fn compare_rollouts(scene: &Scene, u: &Tensor, bound: f64) -> (Model, Model) {
    let direct = newton_with(scene, LinearSolver::Direct, 1e-10);
    let pcg = newton_with(scene, LinearSolver::PCG, 1e-10);
    let settings = |m: &Model| match m.solver {
        Solver::Newton(s) => s,
        Solver::Xpbd => unreachable!(),
    };
    let (xd, sd) = direct.simulate_newton(u, &settings(&direct)).unwrap();
    let (xp, sp) = pcg.simulate_newton(u, &settings(&pcg)).unwrap();
    let (td, tp) = (total(&sd), total(&sp));
    assert!(tp.pcg_solves > 0, "{tp:?}");
    assert_eq!(td.pcg_solves, 0);
    assert!(
        tp.factorizations < td.factorizations,
        "PCG {} factorizations, direct {}",
        tp.factorizations,
        td.factorizations
    );
    for (t, (a, b)) in xd.iter().zip(&xp).enumerate() {
        let diff = a
            .data()
            .iter()
            .zip(b.data())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= bound, "state {t}: max |Δx| = {diff:e}");
    }
    (direct, pcg)
}

/// `u_obstacle` at 20 × 20 (the compressed cloth buckles: branch following, saddles): PCG's
/// rollout has the direct one's states within 1e-8 (both are minimizers to the relative
/// residual 1e-10) and the same `∇L` within 1e-6 relative.
#[test]
fn pcg_rollout_matches_the_direct_one_on_u_obstacle() {
    let scene = Scene::builtin("u_obstacle")
        .unwrap()
        .refined(20, 20)
        .unwrap();
    let u = scene.initial_controls();
    let (direct, pcg) = compare_rollouts(&scene, &u, 1e-8);
    let delta = scene.task.delta;
    let gd = direct
        .evaluate_loss_gradient(&u, delta)
        .unwrap()
        .grad_l
        .unwrap();
    let gp = pcg
        .evaluate_loss_gradient(&u, delta)
        .unwrap()
        .grad_l
        .unwrap();
    let mut d = gd.clone();
    d.data_mut()
        .iter_mut()
        .zip(gp.data())
        .for_each(|(a, b)| *a -= b);
    assert!(d.norm() <= 1e-6 * gd.norm(), "|Δ∇L| = {:e}", d.norm());
}

/// `drop` with the cloth pressed onto its ground collider: active contact rows, whose tangent
/// projection the conjugate gradients keep.
#[test]
fn pcg_rollout_matches_the_direct_one_with_contacts() {
    let scene = Scene::builtin("drop").unwrap();
    let model = newton_with(&scene, LinearSolver::Direct, 1e-10);
    let u = common::lowered_and_dragged(&model);
    compare_rollouts(&scene, &u, 1e-8);
}

/// With PCG, `∇L` and `∇C` still match central differences of Newton's own `L` and `C` (along a
/// random direction, within 1e-6 of `|g|·|d|`) on a small swinging cloth with a safety sphere.
#[test]
fn pcg_gradients_match_central_differences() {
    let mut s = common::small_scene(5, 5, 3, 10, 2e3, common::BendKind::Distance(20.0));
    s.obstacles = vec![common::spheres(
        vec![[0.0, -1.2, 1.3]],
        vec![0.3],
        cloth::scene::ObstacleRole::Safety,
    )];
    let model = newton_with(&s, LinearSolver::PCG, 1e-13);
    let u = common::controls_from(&model, &[0.1; 18]);
    let delta = 0.3;
    let e = model.evaluate(&u, delta, true).unwrap();
    let mut rng = XorShift::new(11);
    let d = rng.direction(u.data().len());
    let h = 1e-5;
    let at = |sign: f64| {
        let mut v = u.clone();
        v.data_mut()
            .iter_mut()
            .zip(&d)
            .for_each(|(a, b)| *a += sign * h * b);
        model.evaluate(&v, delta, false).unwrap().metrics
    };
    let (plus, minus) = (at(1.0), at(-1.0));
    let dot = |g: &Tensor| g.data().iter().zip(&d).map(|(a, b)| a * b).sum::<f64>();
    let dn: f64 = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    for (name, fd, g) in [
        ("dL/dU", (plus.l - minus.l) / (2.0 * h), e.grad_l.unwrap()),
        ("dC/dU", (plus.c - minus.c) / (2.0 * h), e.grad_c.unwrap()),
    ] {
        let an = dot(&g);
        let scale = g.norm() * dn;
        assert!(
            (fd - an).abs() <= 1e-6 * scale + 1e-9,
            "{name}: analytic {an:e}, central difference {fd:e} (scale {scale:e})"
        );
    }
}

/// `physics.linear_solver` chooses the setting (`"direct"` by default and left out when
/// written); a bad value is a parse error that shows its field.
#[test]
fn scene_field_linear_solver() {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    scene.physics.solver = Some(SolverKind::Newton);
    let Solver::Newton(default) = scene.solver() else {
        unreachable!()
    };
    assert_eq!(default.linear_solver, LinearSolver::Direct);
    assert!(!scene.to_json_pretty().contains("linear_solver"));
    scene.physics.linear_solver = LinearSolverKind::Pcg;
    let text = scene.to_json_pretty();
    assert!(text.contains("\"linear_solver\": \"pcg\""), "{text}");
    let read = Scene::from_json_str(&text).unwrap();
    let Solver::Newton(settings) = read.solver() else {
        unreachable!()
    };
    assert_eq!(settings.linear_solver, LinearSolver::PCG);
    let bad = text.replace("\"pcg\"", "\"cg\"");
    let msg = Scene::from_json_str(&bad).unwrap_err().to_string();
    assert!(msg.contains("unknown variant `cg`"), "{msg}");
    assert!(msg.contains("\"linear_solver\": \"cg\""), "{msg}");
}
