//! The target term as a residual norm (`TargetModel::GaussNewton`): its residual and Jacobian
//! against the rollout and central differences, and its consistency with the smooth objective
//! of `TargetModel::Bfgs` (the same `G`, the same gradient of `G + βE`).

mod common;

use cloth::Model;
use clothopt::problem::{TargetModel, TaskOptions, TrajectoryProblem};
use common::{noise, small};
use optim::{Jacobian, Problem};
use proptest::prelude::*;

/// A 4 × 4 hanging cloth, `T = 4`, its bottom row of 4 targets, with elastic energy.
fn model() -> Model {
    let mut s = small(4, 4, 4, 30);
    s.task.beta = 0.01;
    s.validate().unwrap();
    Model::from_scene(&s).unwrap()
}

fn problem(model: &Model, target_model: TargetModel) -> TrajectoryProblem<'_> {
    let mut options = TaskOptions::for_model(model);
    options.target_model = target_model;
    TrajectoryProblem::new(model, options)
}

fn residual(p: &mut TrajectoryProblem<'_>, x: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; p.residual_norms()[0].dimension];
    p.residual(x, 0, &mut r).unwrap();
    r
}

fn jacobian(p: &mut TrajectoryProblem<'_>, x: &[f64]) -> optim::DenseMatrix {
    let rows = p.residual_norms()[0].dimension;
    let mut jac = Jacobian::dense(rows, p.num_variables());
    // The SQP asks for the rows' Jacobian first; the residual's reuses that backward pass.
    let mut rows_jac = Jacobian::dense(p.num_inequalities(), p.num_variables());
    p.inequality_jacobian(x, &mut rows_jac).unwrap();
    let before = p.gradient_evaluations;
    p.residual_jacobian(x, 0, &mut jac).unwrap();
    assert_eq!(
        p.gradient_evaluations, before,
        "one backward pass per point"
    );
    let Jacobian::Dense(jac) = jac else {
        panic!("dense")
    };
    jac
}

#[test]
fn the_residual_is_declared_only_by_the_gauss_newton_model() {
    let model = model();
    let gn = problem(&model, TargetModel::GaussNewton);
    let declared = gn.residual_norms();
    assert_eq!(declared.len(), 1);
    assert_eq!(declared[0].dimension, 3 * 4);
    assert_eq!(declared[0].weight, 1.0);
    assert!(problem(&model, TargetModel::Bfgs)
        .residual_norms()
        .is_empty());
    assert_eq!(
        TaskOptions::for_model(&model).target_model,
        TargetModel::default()
    );
}

#[test]
fn the_residual_is_the_final_target_error_and_its_norm_is_g() {
    let model = model();
    let (mut gn, mut bfgs) = (
        problem(&model, TargetModel::GaussNewton),
        problem(&model, TargetModel::Bfgs),
    );
    let x: Vec<f64> = noise(3, gn.num_variables())
        .iter()
        .map(|v| 0.2 * v)
        .collect();
    let r = residual(&mut gn, &x);
    let states = model.simulate(&gn.controls(&x)).unwrap();
    let last = states.last().unwrap();
    for k in 0..model.task.targets.rows() {
        let particle = model.task.targets.row(k)[0];
        for j in 0..3 {
            let expected = last.row(particle)[j] - model.task.target_positions.row(k)[j];
            assert_eq!(r[3 * k + j], expected);
        }
    }
    // G + βE (smooth, BFGS model) = βE (smooth, Gauss–Newton model) + ‖r‖.
    let g = r.iter().map(|v| v * v).sum::<f64>().sqrt();
    let (with, without) = (bfgs.objective(&x).unwrap(), gn.objective(&x).unwrap());
    assert!(
        (with - (without + g)).abs() <= 1e-12 * with.max(1.0),
        "{with} vs {without} + {g}"
    );
    // ∇(G + βE) = ∇(βE) + Jᵀr/‖r‖.
    let n = gn.num_variables();
    let (mut g_with, mut g_without) = (vec![0.0; n], vec![0.0; n]);
    bfgs.gradient(&x, &mut g_with).unwrap();
    let jac = jacobian(&mut gn, &x);
    gn.gradient(&x, &mut g_without).unwrap();
    for i in 0..n {
        let jtr: f64 = (0..r.len()).map(|k| jac.get(k, i) * r[k] / g).sum();
        let scale = g_with[i].abs().max(1e-3);
        assert!(
            (g_with[i] - g_without[i] - jtr).abs() <= 1e-9 * scale,
            "entry {i}: {} vs {} + {jtr}",
            g_with[i],
            g_without[i]
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    /// Every entry of the residual's Jacobian against central differences along a random
    /// direction, at random controls.
    #[test]
    fn residual_jacobian_matches_central_differences(
        seed in 0u64..1000,
        scale in 0.05f64..0.3,
    ) {
        let model = model();
        let mut p = problem(&model, TargetModel::GaussNewton);
        let n = p.num_variables();
        let x: Vec<f64> = noise(seed, n).iter().map(|v| scale * v).collect();
        let d = noise(seed + 7919, n);
        let jac = jacobian(&mut p, &x);
        let mut along = |h: f64| {
            let xp: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + h * b).collect();
            let xm: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a - h * b).collect();
            let (rp, rm) = (residual(&mut p, &xp), residual(&mut p, &xm));
            rp.iter().zip(&rm).map(|(a, b)| (a - b) / (2.0 * h)).collect::<Vec<f64>>()
        };
        // Richardson extrapolation of two central differences (as for the goal row).
        let h = 2e-6;
        let (coarse, fine) = (along(h), along(h / 2.0));
        for k in 0..jac.nrows() {
            let an: f64 = jac.row(k).iter().zip(&d).map(|(a, b)| a * b).sum();
            let fd = (4.0 * fine[k] - coarse[k]) / 3.0;
            prop_assert!((fd - an).abs() <= 1e-6 * an.abs().max(1.0), "entry {}: {} vs FD {}", k, an, fd);
        }
    }
}
