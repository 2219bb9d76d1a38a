//! The planner's safety rows with bounded mesh queries, against the exact ones, on states of a
//! rollout past a mesh safety obstacle (a tessellated sphere and a capsule's tessellation, each
//! with a sphere set beside it):
//! - `record_safety` (`C = −Σ relu(δ − SDF)`, exact only up to `δ`): value and gradient bitwise
//!   the exact distances';
//! - `record_sdf_components_for_soft_min` (exact only within `40/κ` of the state's smallest
//!   distance): the entries a soft minimum of sharpness `κ` weighs at least `e^−40` bitwise the
//!   exact ones, the soft minimum within `K·e^−40/κ` and its gradient within `1e−12` relative;
//!   without a mesh obstacle, bitwise the exact recording.

use autodiff::{soft_min_value, Tape, Tensor};
use cloth::internals::NEGLIGIBLE_WEIGHT_EXPONENT;
use cloth::nalgebra::Vector3;
use cloth::scene::{MeshSpec, Obstacle, ObstacleRole, SphereSetSpec};
use cloth::sdf::{sphere_surface, Capsule, MeshSdf, SignedDistance};
use cloth::{Model, Scene};

/// A 12 × 12 cloth dragged past a mesh safety obstacle (`which`: 0 a tessellated sphere, 1 a
/// tessellated capsule; `None`: only the sphere set that is always beside it).
fn scene(which: Option<usize>) -> Scene {
    let json = r#"{
        "name": "safety_rows",
        "cloth": {"rows": 12, "cols": 12, "top_left": [-0.5, -0.9, 0.6], "right": [1, 0, 0],
                  "down": [0, 0, -0.8], "particle_mass": 1.0},
        "material": {"stretch": 1000.0, "bending": {"model": "distance", "stiffness": 10.0}},
        "physics": {"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 20, "solver": "xpbd"},
        "controls": [[0, 0], [0, 11]],
        "task": {"horizon": 5, "targets": [{"particle": [11, 11], "position": [0.5, 0.5, 0]}],
                 "alpha": 1.0, "beta": 0.001, "initial_controls": "zeros"}
    }"#;
    let mut s = Scene::from_json_str(json).expect("scene");
    s.obstacles.push(Obstacle::Spheres(SphereSetSpec {
        centers: vec![[0.9, 0.0, 0.2]],
        radii: vec![0.15],
        role: ObstacleRole::Safety,
        friction: None,
    }));
    if let Some(which) = which {
        let (v, t) = match which {
            0 => sphere_surface([0.0, 0.0, 0.2], 0.25),
            _ => Capsule {
                a: [-0.2, 0.0, 0.1],
                b: [0.2, 0.05, 0.3],
                radius: 0.15,
            }
            .surface_triangles(),
        };
        s.obstacles.push(Obstacle::Mesh(MeshSpec {
            file: "obstacle.obj".into(),
            role: ObstacleRole::Safety,
            friction: None,
            surface: Some(MeshSdf::new(v, t)),
        }));
    }
    s.validate().expect("valid scene");
    s
}

/// Every state of a rollout that drags the grippers across the obstacle (y from −0.9 to 0.6).
fn states(model: &Model) -> Vec<Tensor> {
    let mut u = model.zero_controls();
    for t in 0..u.rows() {
        for k in 0..model.n_controls() {
            u.row_mut(t)[3 * k + 1] = 0.3;
        }
    }
    model.simulate(&u).expect("finite")
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_relu_sum_and_its_gradient_are_bitwise_those_of_exact_distances() {
    let delta = 0.1;
    for which in [0, 1] {
        let model = Model::from_scene(&scene(Some(which))).expect("model");
        let (mut within, mut bounded) = (0, 0);
        for x in &states(&model)[1..] {
            let run = |exact: bool| {
                let mut tape = Tape::new();
                let xv = tape.leaf(x.clone());
                let c = if exact {
                    let sdf = model.record_sdf(&mut tape, xv).expect("safety");
                    Model::record_safety_of_sdf(&mut tape, sdf, delta)
                } else {
                    model.record_safety(&mut tape, xv, delta).expect("safety")
                };
                let g = tape.backward(c).wrt(xv);
                (tape.value(c).item(), g)
            };
            let ((ce, ge), (cb, gb)) = (run(true), run(false));
            assert_eq!(ce.to_bits(), cb.to_bits());
            assert_eq!(bits(ge.data()), bits(gb.data()));
            for p in 0..x.rows() {
                let q = Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2));
                let exact = model.safety_obstacles.distance(&q);
                within += usize::from(exact <= delta);
                bounded += usize::from(model.safety_obstacles.distance_within(&q, delta) < exact);
            }
        }
        // Not vacuous: some particles are within δ (C < 0, a gradient), some far ones bounded.
        assert!(
            within > 0 && bounded > 0,
            "{within} within δ, {bounded} bounded"
        );
    }
}

/// The soft minimum of the recorded components and its gradient with respect to the state.
fn soft_min_and_gradient(
    model: &Model,
    x: &Tensor,
    kappa: f64,
    exact: bool,
) -> (Vec<f64>, f64, Tensor) {
    let mut tape = Tape::new();
    let xv = tape.leaf(x.clone());
    let comps = if exact {
        model.record_sdf_components(&mut tape, xv)
    } else {
        model.record_sdf_components_for_soft_min(&mut tape, xv, kappa)
    }
    .expect("safety");
    let s = tape.soft_min(comps, kappa);
    let g = tape.backward(s).wrt(xv);
    (tape.value(comps).data().to_vec(), tape.value(s).item(), g)
}

#[test]
fn soft_min_entries_that_matter_are_exact_and_the_rest_change_it_negligibly() {
    for which in [0, 1] {
        let model = Model::from_scene(&scene(Some(which))).expect("model");
        let mut bounded = 0;
        for kappa in [200.0, 3000.0] {
            for x in &states(&model)[1..] {
                let (ve, se, ge) = soft_min_and_gradient(&model, x, kappa, true);
                let (vb, sb, gb) = soft_min_and_gradient(&model, x, kappa, false);
                let m = ve.iter().copied().fold(f64::INFINITY, f64::min);
                assert_eq!(soft_min_value(&ve, kappa).to_bits(), se.to_bits());
                let mut k = 0;
                for (&e, &b) in ve.iter().zip(&vb) {
                    if kappa * (e - m) <= NEGLIGIBLE_WEIGHT_EXPONENT {
                        assert_eq!(
                            e.to_bits(),
                            b.to_bits(),
                            "κ = {kappa}: an entry that matters"
                        );
                    } else {
                        assert!(b <= e && kappa * (b - m) > NEGLIGIBLE_WEIGHT_EXPONENT);
                        k += usize::from(b != e);
                    }
                }
                bounded += k;
                let tiny = (-NEGLIGIBLE_WEIGHT_EXPONENT).exp();
                assert!(
                    (sb - se).abs() <= k as f64 * tiny / kappa,
                    "κ = {kappa}: {sb} vs {se}"
                );
                let scale = ge.data().iter().fold(0.0f64, |a, v| a.max(v.abs()));
                for (a, b) in ge.data().iter().zip(gb.data()) {
                    assert!((a - b).abs() <= 1e-12 * scale, "gradient {a} vs {b}");
                }
            }
        }
        assert!(bounded > 0, "mesh {which}: no entry was bounded");
    }
    // Without a mesh obstacle, every entry is exact: the same recording bit for bit.
    let model = Model::from_scene(&scene(None)).expect("model");
    for x in &states(&model)[1..] {
        let (ve, se, ge) = soft_min_and_gradient(&model, x, 3000.0, true);
        let (vb, sb, gb) = soft_min_and_gradient(&model, x, 3000.0, false);
        assert_eq!((bits(&ve), se.to_bits()), (bits(&vb), sb.to_bits()));
        assert_eq!(bits(ge.data()), bits(gb.data()));
    }
}
