//! Robot limits (`task.limits`): every limit holds on the re-simulated plan of a scene whose
//! unconstrained plan violates it; every new row's Jacobian matches central differences.

mod common;
use cloth::scene::{Limits, Target, Workspace};
use cloth::{Model, Scene};
use clothopt::plan::{plan, PlanOptions};
use clothopt::problem::{TaskOptions, TrajectoryProblem};
use clothopt::result::{controls_from_nested, gripper_positions, PlanResult};
use common::{noise, row_derivatives, small};
use optim::{Jacobian, Problem};
use proptest::prelude::*;

/// A 5 × 5 hanging cloth, `T = 4`, whose bottom row should end twice as wide as the cloth at
/// y = 1, z = 1.5: reaching it takes long steps, a wide gripper separation and a stretch.
fn stretching_scene(limits: Limits) -> Scene {
    let mut s = small(5, 5, 4, 30);
    s.task.targets = (0..5)
        .map(|c| Target {
            particle: [4, c].into(),
            position: [-1.0 + 0.5 * c as f64, 1.0, 1.5],
        })
        .collect();
    s.task.limits = limits;
    s.validate().unwrap();
    s
}

/// What a limit is checked against: the re-simulated rollout of a plan.
struct Measured {
    max_step: f64,
    max_y: f64,
    separation: (f64, f64),
    max_strain: f64,
}

fn solve(scene: &Scene) -> (Model, PlanResult) {
    let model = Model::from_scene(scene).unwrap();
    let start = clothopt::plan::initial_controls(scene, &model).unwrap();
    let result = plan(
        &model,
        scene,
        &start,
        &PlanOptions::for_model(&model),
        |_| {},
    )
    .unwrap();
    (model, result)
}

/// Re-simulates the plan's controls and measures every limited quantity.
fn measure(model: &Model, result: &PlanResult) -> Measured {
    let controls = controls_from_nested(model, &result.controls).unwrap();
    let states = model.simulate(&controls).unwrap();
    let grippers = gripper_positions(model, &states);
    let dist = |a: &[f64; 3], b: &[f64; 3]| {
        (0..3)
            .map(|j| (a[j] - b[j]) * (a[j] - b[j]))
            .sum::<f64>()
            .sqrt()
    };
    let max_step = grippers
        .windows(2)
        .flat_map(|w| w[0].iter().zip(&w[1]).map(|(a, b)| dist(a, b)))
        .fold(0.0, f64::max);
    let max_y = grippers
        .iter()
        .flatten()
        .map(|p| p[1])
        .fold(f64::NEG_INFINITY, f64::max);
    let separations: Vec<f64> = grippers.iter().map(|g| dist(&g[0], &g[1])).collect();
    let separation = (
        separations.iter().copied().fold(f64::INFINITY, f64::min),
        separations.iter().copied().fold(0.0, f64::max),
    );
    let max_strain = model
        .max_strain_per_step(&states)
        .into_iter()
        .fold(0.0, f64::max);
    // The result reports the same rollout.
    assert_eq!(result.gripper_positions, grippers);
    assert_eq!(result.strain.max, max_strain);
    Measured {
        max_step,
        max_y,
        separation,
        max_strain,
    }
}

/// Slack for a limit on the re-simulated plan: the SQP's feasibility tolerance.
const SLACK: f64 = 1e-6;

#[test]
fn every_limit_holds_on_the_resimulated_plan() {
    let (model, free) = solve(&stretching_scene(Limits::default()));
    let m = measure(&model, &free);
    // The unconstrained plan: long steps, forward, apart and stretched.
    assert!(m.max_step > 0.4, "max step {}", m.max_step);
    assert!(m.max_y > 0.0, "max y {}", m.max_y);
    assert!(m.separation.1 > 1.3, "separation {:?}", m.separation);
    assert!(m.max_strain > 0.1, "strain {}", m.max_strain);

    let step = 0.6 * m.max_step;
    let (model, r) = solve(&stretching_scene(Limits {
        max_step: Some(step),
        ..Limits::default()
    }));
    let got = measure(&model, &r);
    assert!(r.is_feasible(), "{}", r.message);
    assert!(got.max_step <= step + SLACK, "{} > {step}", got.max_step);

    let y = -1.5 + 0.5 * (m.max_y + 1.5);
    let (model, r) = solve(&stretching_scene(Limits {
        workspace: Some(Workspace {
            min: [-10.0, -10.0, -10.0],
            max: [10.0, y, 10.0],
        }),
        ..Limits::default()
    }));
    let got = measure(&model, &r);
    assert!(r.is_feasible(), "{}", r.message);
    assert!(got.max_y <= y + SLACK, "{} > {y}", got.max_y);

    let wide = 1.0 + 0.5 * (m.separation.1 - 1.0);
    let (model, r) = solve(&stretching_scene(Limits {
        gripper_separation: Some([0.9, wide]),
        ..Limits::default()
    }));
    let got = measure(&model, &r);
    assert!(r.is_feasible(), "{}", r.message);
    assert!(
        got.separation.1 <= wide + SLACK,
        "{:?} vs {wide}",
        got.separation
    );
    assert!(
        got.separation.0 >= 0.9 - SLACK,
        "{:?} vs 0.9",
        got.separation
    );

    let strain = 0.3 * m.max_strain;
    let (model, r) = solve(&stretching_scene(Limits {
        max_strain: Some(strain),
        ..Limits::default()
    }));
    let got = measure(&model, &r);
    assert!(r.is_feasible(), "{}", r.message);
    assert!(
        got.max_strain <= strain + SLACK,
        "{} > {strain}",
        got.max_strain
    );
}

#[test]
fn gripper_separation_minimum_holds() {
    // Targets squeezed to a tenth of the cloth's width pull the grippers together.
    let squeeze = |limits: Limits| {
        let mut s = stretching_scene(limits);
        for (c, t) in s.task.targets.iter_mut().enumerate() {
            t.position[0] = -0.05 + 0.025 * c as f64;
        }
        s
    };
    let (model, free) = solve(&squeeze(Limits::default()));
    let m = measure(&model, &free);
    assert!(m.separation.0 < 0.6, "separation {:?}", m.separation);
    let (model, r) = solve(&squeeze(Limits {
        gripper_separation: Some([0.8, 2.0]),
        ..Limits::default()
    }));
    let got = measure(&model, &r);
    assert!(r.is_feasible(), "{}", r.message);
    assert!(got.separation.0 >= 0.8 - SLACK, "{:?}", got.separation);
}

fn all_limits() -> Limits {
    Limits {
        max_step: Some(0.3),
        workspace: Some(Workspace {
            min: [-2.0, -2.0, 1.0],
            max: [2.0, 2.0, 3.0],
        }),
        gripper_separation: Some([0.5, 1.5]),
        max_strain: Some(0.05),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    /// Every row (strain, step, separation, workspace) against central differences along a random
    /// direction, at random controls.
    #[test]
    fn limit_rows_match_central_differences(seed in 0u64..1000, scale in 0.05f64..0.3) {
        let scene = stretching_scene(all_limits());
        let model = Model::from_scene(&scene).unwrap();
        let mut options = TaskOptions::for_model(&model);
        // A gentler smooth maximum keeps the FD error of the strain rows small.
        options.strain_kappa = 50.0;
        let mut p = TrajectoryProblem::new(&model, options);
        let (n, m) = (p.num_variables(), p.num_inequalities());
        // 4 strain + 8 step + 8 separation + 48 workspace rows.
        prop_assert_eq!(m, 4 + 8 + 8 + 48);
        let x: Vec<f64> = noise(seed, n).iter().map(|v| scale * v).collect();
        let d = noise(seed + 7919, n);
        // The strain rows' third derivative is large at the larger scales: at seed 602, scale
        // 0.29, h = 1e-6 leaves a truncation error of 3.6e-5 of row 2 (it falls as h², to 3.7e-7
        // at 1e-7, round-off still below 1e-8).
        let rows = row_derivatives(&mut p, &x, &d, 1e-7);
        for (r, &(an, fd)) in rows.iter().enumerate() {
            prop_assert!((fd - an).abs() <= 1e-5 * an.abs().max(1.0), "row {}: {} vs FD {}", r, an, fd);
        }
        // The strain rows are not trivially flat.
        let mut jac = Jacobian::dense(m, n);
        p.inequality_jacobian(&x, &mut jac).unwrap();
        let Jacobian::Dense(jac) = jac else { panic!("dense") };
        prop_assert!((0..4).any(|r| jac.row(r).iter().any(|&v| v != 0.0)));
    }
}

/// A limit no plan can meet (the hanging cloth stretches more than 1e-6 under gravity at every
/// step): the result is not safe, and its warning names the most violated row.
#[test]
fn an_unmeetable_limit_is_named_in_the_warning() {
    let scene = stretching_scene(Limits {
        max_strain: Some(1e-6),
        ..Limits::default()
    });
    let model = Model::from_scene(&scene).unwrap();
    let start = clothopt::plan::initial_controls(&scene, &model).unwrap();
    let mut options = PlanOptions::for_model(&model);
    options.iterations = 10;
    let result = plan(&model, &scene, &start, &options, |_| {}).unwrap();
    assert!(!result.task.achieved);
    assert!(
        result.constraint_violation > 1e-4,
        "{}",
        result.constraint_violation
    );
    let warning = result
        .warnings
        .iter()
        .find(|w| w.contains("violates the optimizer's rows"))
        .expect("a violation warning");
    assert!(
        warning.contains("(most: limit max_strain at step "),
        "{warning}"
    );
}

#[test]
fn row_labels_read_as_names() {
    use clothopt::problem::RowLabel;
    let cases = [
        (RowLabel::Safety { step: Some(3) }, "safety at step 3"),
        (RowLabel::Safety { step: None }, "safety (whole rollout)"),
        (
            RowLabel::ColliderPlane {
                plane: 0,
                control: 1,
                step: 2,
            },
            "collider plane 0 under control point 1 at step 2",
        ),
        (
            RowLabel::Limit {
                limit: "max_strain",
                step: 4,
            },
            "limit max_strain at step 4",
        ),
    ];
    for (label, text) in cases {
        assert_eq!(label.to_string(), text);
    }
}
