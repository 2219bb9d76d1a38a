//! `TrajectoryProblem`'s objective gradient and constraint Jacobian against central differences.

mod common;
use cloth::{Model, Scene};
use clothopt::plan::initial_controls;
use clothopt::problem::{SafetyForm, TaskOptions, TrajectoryProblem};
use common::noise;
use optim::{Jacobian, Problem};

fn check(form: SafetyForm, swept: bool) {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let mut options = TaskOptions::for_model(&model);
    options.safety = Some(form);
    options.swept = swept;
    options.kappa = 30.0;
    let mut p = TrajectoryProblem::new(&model, options);
    let n = p.num_variables();
    let m = p.num_inequalities();
    let mut x = initial_controls(&scene, &model).unwrap().into_data();
    // Move the cloth into the obstacle's neighbourhood so the safety rows are non-trivial.
    for (t, chunk) in x.chunks_mut(6).enumerate() {
        chunk[1] += 0.1 * (t as f64 / 10.0);
    }
    for (v, d) in x.iter_mut().zip(noise(7, n)) {
        *v += 0.02 * d;
    }
    let mut g = vec![0.0; n];
    p.gradient(&x, &mut g).unwrap();
    let mut jac = Jacobian::dense(m, n);
    p.inequality_jacobian(&x, &mut jac).unwrap();
    let Jacobian::Dense(jac) = jac else {
        panic!("dense")
    };
    let h = 1e-6;
    for seed in 0..3 {
        let d = noise(100 + seed, n);
        let at = |s: f64, p: &mut TrajectoryProblem| {
            let xs: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + s * b).collect();
            let f = p.objective(&xs).unwrap();
            let mut c = vec![0.0; m];
            p.inequalities(&xs, &mut c).unwrap();
            (f, c)
        };
        let (fp, cp) = at(h, &mut p);
        let (fm, cm) = at(-h, &mut p);
        let fd = (fp - fm) / (2.0 * h);
        let an: f64 = g.iter().zip(&d).map(|(a, b)| a * b).sum();
        assert!(
            (fd - an).abs() <= 1e-6 * an.abs().max(1.0),
            "objective: {an} vs FD {fd}"
        );
        for r in 0..m {
            let fd = (cp[r] - cm[r]) / (2.0 * h);
            let an: f64 = jac.row(r).iter().zip(&d).map(|(a, b)| a * b).sum();
            assert!(
                (fd - an).abs() <= 1e-6 * an.abs().max(1.0),
                "row {r}: {an} vs FD {fd}"
            );
        }
    }
}

#[test]
fn per_step_safety_derivatives_match_central_differences() {
    check(SafetyForm::PerStep, false);
}

#[test]
fn swept_per_step_safety_derivatives_match_central_differences() {
    check(SafetyForm::PerStep, true);
}

#[test]
fn scalar_safety_derivatives_match_central_differences() {
    check(SafetyForm::Scalar, false);
}

#[test]
fn aggregate_safety_derivatives_match_central_differences() {
    check(SafetyForm::Aggregate, true);
}

#[test]
fn drop_has_one_floor_row_per_control_point_and_step() {
    let scene = Scene::builtin("drop").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    assert_eq!(
        model.colliders.planes.len(),
        1,
        "the ground is a collider the problem must see"
    );
    let mut p = TrajectoryProblem::new(&model, TaskOptions::for_model(&model));
    // No safety obstacles; one row per control point per step: 2 × 10.
    assert_eq!(p.num_inequalities(), 20);
    // Pushing both control points down by 0.2 per step violates the rows from step 8 on (z₀ = 1.5).
    let n = p.num_variables();
    let x: Vec<f64> = (0..n)
        .map(|i| if i % 3 == 2 { -0.2 } else { 0.0 })
        .collect();
    let mut c = vec![0.0; 20];
    p.inequalities(&x, &mut c).unwrap();
    let violated = c.iter().filter(|&&v| v < 0.0).count();
    assert_eq!(
        violated,
        2 * 3,
        "steps 8, 9, 10 for both control points: {c:?}"
    );
    assert!(
        (c[9] - (1.5 - 2.0)).abs() < 1e-12,
        "z after 10 steps = 1.5 − 10·0.2: {}",
        c[9]
    );
}

/// The Jacobian with some safety rows skipped (what the SQP's Jacobian reuse asks for): the wanted
/// rows and the collider rows equal the full Jacobian's, the skipped rows are zero, and the
/// objective gradient that follows reuses the same backward pass.
#[test]
fn jacobian_rows_skip_only_the_unwanted_safety_rows() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let options = TaskOptions::for_model(&model);
    let mut x = initial_controls(&scene, &model).unwrap().into_data();
    let shake = noise(7, x.len());
    for (v, d) in x.iter_mut().zip(shake) {
        *v += 0.02 * d;
    }
    let mut full = TrajectoryProblem::new(&model, options.clone());
    let (n, m) = (full.num_variables(), full.num_inequalities());
    let mut g_full = vec![0.0; n];
    full.gradient(&x, &mut g_full).unwrap();
    let mut j_full = Jacobian::dense(m, n);
    full.inequality_jacobian(&x, &mut j_full).unwrap();
    let (Jacobian::Dense(j_full), rows) = (j_full, model.task.horizon) else {
        panic!("dense")
    };
    let wanted: Vec<bool> = (0..m).map(|r| r >= rows || r % 3 == 1).collect();
    let mut part = TrajectoryProblem::new(&model, options);
    let mut j_part = Jacobian::dense(m, n);
    part.inequality_jacobian_rows(&x, &wanted, &mut j_part)
        .unwrap();
    let mut g_part = vec![0.0; n];
    part.gradient(&x, &mut g_part).unwrap();
    let Jacobian::Dense(j_part) = j_part else {
        panic!("dense")
    };
    assert_eq!(g_part, g_full);
    assert_eq!(part.gradient_evaluations, 1);
    for (r, &w) in wanted.iter().enumerate() {
        if w {
            assert_eq!(j_part.row(r), j_full.row(r), "row {r}");
        } else {
            assert!(j_part.row(r).iter().all(|&v| v == 0.0), "row {r}");
            assert!(
                j_full.row(r).iter().any(|&v| v != 0.0),
                "row {r} is trivial"
            );
        }
    }
    // Asking for every row afterwards pulls back again; asking for a subset again does not.
    part.inequality_jacobian_rows(&x, &wanted, &mut Jacobian::dense(m, n))
        .unwrap();
    assert_eq!(part.gradient_evaluations, 1);
    part.inequality_jacobian(&x, &mut Jacobian::dense(m, n))
        .unwrap();
    assert_eq!(part.gradient_evaluations, 2);
}
