//! The held-clearance rows (`src/problem/step_rows.rs`): under smooth self-contact, one row per
//! step keeps every gripper's particle off the triangles not incident to it. Their Jacobian,
//! pulled back through the Newton rollout, matches central differences on a cloth folded onto
//! itself; they are labelled; they are off by default, and a scene without self-contact has none.

mod common;
use cloth::scene::{
    ContactModel, ContactSpec, Obstacle, ObstacleRole, PlaneSpec, SelfCollisionSpec, SolverKind,
};
use cloth::{Model, Scene, Solver};
use clothopt::problem::{RowLabel, TaskOptions, TrajectoryProblem, HELD_MARGIN};
use common::{noise, row_derivatives, small};
use optim::Problem;

const HORIZON: usize = 8;

/// A 7 × 7 cloth of side 1 lying 0.01 above the floor (smooth contact), gripped at the corners
/// of its first row, self-collision of thickness 0.02, Newton at tolerance 1e-12.
fn model() -> Model {
    let mut s: Scene = small(7, 7, HORIZON, 100);
    s.cloth.top_left = [-0.5, -0.5, 0.01];
    s.cloth.right = [1.0, 0.0, 0.0];
    s.cloth.down = [0.0, 1.0, 0.0];
    s.obstacles = vec![Obstacle::Plane(PlaneSpec {
        point: [0.0; 3],
        normal: [0.0, 0.0, 1.0],
        role: ObstacleRole::Collider,
        friction: None,
    })];
    s.physics.solver = Some(SolverKind::Newton);
    s.physics.contact = Some(ContactSpec {
        model: ContactModel::Smooth,
        d_hat: None,
        stiffness: None,
        friction_epsilon: None,
    });
    s.physics.self_collision = Some(SelfCollisionSpec {
        thickness: 0.02,
        edge_edge: false,
        friction: None,
    });
    s.validate().unwrap();
    let mut m = Model::from_scene(&s).unwrap();
    let Solver::Newton(settings) = &mut m.solver else {
        unreachable!("a Newton scene")
    };
    settings.tolerance = 1e-12;
    m
}

/// The first row's corners carried over a half circle of radius 0.5 about the middle row,
/// ending `end` above where they started the other side: the cloth folds onto itself and the
/// held corners come down near its other half.
fn fold(end: f64) -> Vec<f64> {
    let at = |t: usize| {
        let th = std::f64::consts::PI * t as f64 / HORIZON as f64;
        [
            -0.5 * th.cos(),
            0.5 * th.sin() + end * t as f64 / HORIZON as f64,
        ]
    };
    (0..HORIZON)
        .flat_map(|t| {
            let (a, b) = (at(t), at(t + 1));
            let (dy, dz) = (b[0] - a[0], b[1] - a[1]);
            [0.0, dy, dz, 0.0, 0.99 * dy, 0.99 * dz]
        })
        .collect()
}

/// The rows of the held clearance, with their steps.
fn held_rows(p: &TrajectoryProblem) -> Vec<(usize, usize)> {
    p.row_labels()
        .iter()
        .enumerate()
        .filter_map(|(r, l)| match *l {
            RowLabel::HeldClearance { step } => Some((r, step)),
            _ => None,
        })
        .collect()
}

/// One row per step; at the fold's end the held corners lie within a few centimetres of the
/// cloth's other half, so the last rows are small and vary with the controls. Their directional
/// derivatives along random directions match central differences (through the rollout's
/// implicit gradients: the triangles the corners face move with the controls too).
#[test]
fn held_clearance_rows_match_central_differences() {
    let m = model();
    // Off by default (`TaskOptions::held_clearance`): no such row.
    assert!(held_rows(&TrajectoryProblem::new(&m, TaskOptions::for_model(&m))).is_empty());
    let options = TaskOptions {
        held_clearance: true,
        ..TaskOptions::for_model(&m)
    };
    let mut p = TrajectoryProblem::new(&m, options);
    let rows = held_rows(&p);
    assert_eq!(
        rows.iter().map(|&(_, s)| s).collect::<Vec<_>>(),
        (1..=HORIZON).collect::<Vec<_>>()
    );
    let x = fold(0.035);
    let mut c = vec![0.0; p.num_inequalities()];
    p.inequalities(&x, &mut c).unwrap();
    let last = c[rows[HORIZON - 1].0];
    // The corners end about 0.035 above their start, the other half 0.01 up, less the thickness
    // 0.02 and the margin: a gap of a few millimetres, well inside the first steps' gaps.
    assert!(last > 0.0 && last < 0.02, "last row {last}");
    assert!(c[rows[0].0] > last, "{c:?}");
    // The row is the smallest gap less the margin, the soft minimum at most half the margin
    // below the true one here (few pairs near).
    let margin = HELD_MARGIN * m.self_barrier.as_ref().unwrap().barrier.d_hat;
    let states = p.states(&x).unwrap();
    let exact = m.min_held_gap(&states[HORIZON]).unwrap() - margin;
    assert!(
        last <= exact && last >= exact - 0.5 * margin,
        "{last} against {exact}"
    );
    for seed in 0..2 {
        let d = noise(40 + seed, x.len());
        let derivatives = row_derivatives(&mut p, &x, &d, 1e-6);
        for &(r, step) in &rows {
            let (an, fd) = derivatives[r];
            assert!(
                (an - fd).abs() <= 1e-5 * an.abs().max(1.0),
                "step {step}: {an:e} vs central difference {fd:e}"
            );
        }
        let (an, _) = derivatives[rows[HORIZON - 1].0];
        assert!(
            an.abs() > 1e-3,
            "the last row moves with the controls: {an:e}"
        );
    }
}

/// Without self-contact no row holds the grippers off the cloth.
#[test]
fn a_scene_without_self_contact_has_no_held_clearance_rows() {
    let s = small(5, 5, 4, 20);
    let m = Model::from_scene(&s).unwrap();
    let options = TaskOptions {
        held_clearance: true,
        ..TaskOptions::for_model(&m)
    };
    assert!(held_rows(&TrajectoryProblem::new(&m, options)).is_empty());
}
