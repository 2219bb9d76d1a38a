//! Self-collision (`physics.self_collision`): a cloth folded onto itself keeps its layers apart by
//! the thickness, and without self-collision they meet; the contact sets are deterministic and
//! absent unless asked for; hard cases stay finite.
//!
//! The scene: a square cloth lying flat on a ground collider (z = 0), its row-0 edge gripped at both
//! corners and carried over a half circle onto the far edge (a fold in half about y = 0.5), then
//! left to settle for a few steps under gravity.

mod common;

use autodiff::Tensor;
use cloth::constraint::hessian_vector;
use cloth::internals::{SelfCollision, VertexTriangle};
use cloth::{Model, Scene};
use nalgebra::Vector3;
use std::sync::Arc;

/// The fold scene (`n × n` grid of side 1, `fold` steps over the half circle, then `rest` steps),
/// with `physics.self_collision` when `thickness` is given.
pub fn fold_scene(n: usize, fold: usize, rest: usize, thickness: Option<f64>) -> Scene {
    let sc = thickness.map_or(String::new(), |h| {
        format!(r#", "self_collision": {{"thickness": {h}}}"#)
    });
    let json = format!(
        r#"{{
        "name": "fold_test",
        "cloth": {{"rows": {n}, "cols": {n}, "top_left": [0, 0, 0], "right": [1, 0, 0],
                   "down": [0, 1, 0], "particle_mass": 1.0}},
        "material": {{"stretch": 10000.0, "bending": {{"model": "distance", "stiffness": 100.0}}}},
        "physics": {{"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 50, "solver": "xpbd"{sc}}},
        "controls": [[0, 0], [0, {last}]],
        "obstacles": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "role": "collider"}}],
        "task": {{"horizon": {horizon}, "targets": [
                    {{"particle": [0, 0], "position": [0, 1, 0.05]}},
                    {{"particle": [0, {last}], "position": [1, 1, 0.05]}}],
                 "alpha": 1.0, "beta": 0.0001, "initial_controls": "zeros"}}
        }}"#,
        last = n - 1,
        horizon = fold + rest,
    );
    Scene::from_json_str(&json).unwrap()
}

/// The fold's controls: both grippers over `y = 0.5 − 0.5·cos θ`, `z = 0.5·sin θ + z_end·θ/π`,
/// `θ = 0 … π` in `fold` equal steps, then `rest` steps of zero.
pub fn fold_controls(model: &Model, fold: usize, z_end: f64) -> Tensor {
    let at = |t: usize| {
        let th = std::f64::consts::PI * t as f64 / fold as f64;
        [
            0.5 - 0.5 * th.cos(),
            0.5 * th.sin() + z_end * th / std::f64::consts::PI,
        ]
    };
    let mut u = model.zero_controls();
    for t in 0..fold {
        let (a, b) = (at(t), at(t + 1));
        for k in 0..model.n_controls() {
            u.row_mut(t)[3 * k + 1] = b[0] - a[0];
            u.row_mut(t)[3 * k + 2] = b[1] - a[1];
        }
    }
    u
}

/// Distance from `p` to the triangle `(a, b, c)` (closest point, edges and corners included).
fn point_triangle(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> f64 {
    // Ericson, Real-Time Collision Detection, 5.1.5.
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.norm();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.norm();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (p - (a + ab * (d1 / (d1 - d3)))).norm();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.norm();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).norm();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).norm();
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (p - (a + ab * v + ac * w)).norm()
}

fn point(x: &Tensor, p: usize) -> Vector3<f64> {
    Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2))
}

/// The smallest distance between a vertex of one layer and a triangle of the other, in `x`: the
/// flap is rows `0 ..= n/2 − 2`, the bottom rows `n/2 + 1 ..` (the rows by the crease, which
/// bends rather than touches, are left out), both ways round.
pub fn layer_gap(model: &Model, n: usize, x: &Tensor) -> f64 {
    let row = |p: usize| p / n;
    let flap = |p: usize| row(p) + 2 <= n / 2;
    let bottom = |p: usize| row(p) > n / 2;
    let mut gap = f64::INFINITY;
    for t in model.triangles.iter() {
        for (tri_side, vertex_side) in [
            (
                &bottom as &dyn Fn(usize) -> bool,
                &flap as &dyn Fn(usize) -> bool,
            ),
            (&flap, &bottom),
        ] {
            if !t.iter().all(|&q| tri_side(q)) {
                continue;
            }
            let [a, b, c] = t.map(|q| point(x, q));
            for p in (0..x.rows()).filter(|&p| vertex_side(p)) {
                gap = gap.min(point_triangle(point(x, p), a, b, c));
            }
        }
    }
    gap
}

const N: usize = 10;
const FOLD: usize = 16;
const REST: usize = 6;
const H: f64 = 0.02;

#[test]
fn a_folded_cloth_keeps_its_layers_a_thickness_apart_and_without_self_collision_they_meet() {
    let with = Model::from_scene(&fold_scene(N, FOLD, REST, Some(H))).unwrap();
    let without = Model::from_scene(&fold_scene(N, FOLD, REST, None)).unwrap();
    let u = fold_controls(&with, FOLD, 2.0 * H);
    let (sa, sb) = (with.simulate(&u).unwrap(), without.simulate(&u).unwrap());
    let gap_with = sa[1..]
        .iter()
        .map(|x| layer_gap(&with, N, x))
        .fold(f64::INFINITY, f64::min);
    let final_with = layer_gap(&with, N, sa.last().unwrap());
    let final_without = layer_gap(&without, N, sb.last().unwrap());
    let settled = &sa[sa.len() - 2];
    let pairs = with.contact_pairs(settled, &Tensor::zeros(2, 3));
    eprintln!(
        "gap with {gap_with} (final {final_with}), without {final_without}, pairs {}",
        pairs.len()
    );
    // Measured: 71 pairs in the settled state; the smallest gap over every step 0.019978
    // (0.9989 h); without self-collision the flap lies on the bottom layer, 1.0e-6 from it.
    assert!(pairs.len() >= N * N / 4, "{} pairs", pairs.len());
    assert!(gap_with >= 0.99 * H, "gap {gap_with}");
    assert!(final_without < 1e-3 * H, "gap without {final_without}");
}

#[test]
fn self_collision_is_absent_unless_the_scene_asks_for_it() {
    let flat = |m: &Model| m.contact_sets(&m.start, &m.step_controls(&m.zero_controls(), 0));
    // Every built-in but `fold` leaves it out; `fold` asks for it and gets it.
    for &(name, _) in Scene::builtin_names() {
        let scene = Scene::builtin(name).unwrap();
        let model = Model::from_scene(&scene).unwrap();
        let asked = scene.physics.self_collision.is_some();
        assert_eq!(asked, name == "fold", "{name}");
        assert_eq!(model.self_collision.is_some(), asked, "{name}");
        assert_eq!(model.effects().contains("self-collision"), asked, "{name}");
        if !asked {
            assert!(flat(&model).is_empty(), "{name}");
        }
    }
    let with = Model::from_scene(&fold_scene(N, FOLD, REST, Some(H))).unwrap();
    let without = Model::from_scene(&fold_scene(N, FOLD, REST, None)).unwrap();
    assert!(without.self_collision.is_none());
    // Self-collision adds no rows to the model's own groups: its rows exist per step only.
    let counts = |m: &Model| {
        let groups: Vec<_> = m
            .groups
            .iter()
            .map(|g| (g.name.clone(), g.count, g.sets.len()))
            .collect();
        (
            groups,
            m.projections_per_iteration(),
            m.sets_per_iteration(),
        )
    };
    assert_eq!(counts(&with), counts(&without));
    assert!(
        with.effects().contains("self-collision (thickness 0.02)"),
        "{}",
        with.effects()
    );
    // The flat rest state has no contact: every vertex lies in the plane of the triangles, but
    // projects inside only its own (excluded) triangles.
    assert!(flat(&with).is_empty());
    // Folded, the layers touch: the step from the folded state has contact rows.
    let u = fold_controls(&with, FOLD, 2.0 * H);
    let states = without.simulate(&u).unwrap();
    let folded = states.last().unwrap();
    let zero = Tensor::zeros(2, 3);
    assert!(without.contact_pairs(folded, &zero).is_empty());
    let pairs = with.contact_pairs(folded, &zero);
    assert!(pairs.len() >= N * N / 4, "{} pairs", pairs.len());
    let rows: usize = with
        .contact_sets(folded, &zero)
        .iter()
        .map(|s| s.index.rows())
        .sum();
    assert_eq!(rows, pairs.len());
}

#[test]
fn contact_sets_are_independent_and_in_pair_order() {
    let model = Model::from_scene(&fold_scene(N, FOLD, REST, Some(H))).unwrap();
    let u = fold_controls(&model, FOLD, 2.0 * H);
    let states = model.simulate(&u).unwrap();
    let x = &states[FOLD + 1];
    let zero = Tensor::zeros(2, 3);
    let pairs = model.contact_pairs(x, &zero);
    assert!(!pairs.is_empty());
    assert!(pairs
        .windows(2)
        .all(|w| (w[0].vertex, w[0].triangle) < (w[1].vertex, w[1].triangle)));
    let sc = model.self_collision.as_ref().unwrap();
    for c in &pairs {
        assert!(!sc.excludes(c.vertex, c.triangle));
        assert!(!model.triangles[c.triangle].contains(&c.vertex));
    }
    let sets = model.contact_sets(x, &zero);
    let mut seen = 0;
    for s in &sets {
        let mut ps: Vec<usize> = (0..s.index.rows())
            .flat_map(|k| s.index.row(k).to_vec())
            .collect();
        let len = ps.len();
        ps.sort_unstable();
        ps.dedup();
        assert_eq!(ps.len(), len, "a colour set shares a particle");
        seen += s.index.rows();
    }
    assert_eq!(seen, pairs.len());
    // Greedy in pair order: the first pair is in the first set, first row.
    let [a, b, c] = model.triangles[pairs[0].triangle];
    assert_eq!(sets[0].index.row(0), &[pairs[0].vertex, a, b, c]);
}

fn bitwise_eq(a: &Tensor, b: &Tensor) -> bool {
    a.shape() == b.shape()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn rollouts_and_gradients_with_contacts_are_bitwise_identical_on_every_path_and_thread_count() {
    // A 32 × 32 cloth: its first contact set holds more rows than the parallel threshold, so two
    // threads really split it.
    let n = 24;
    let mut scene = fold_scene(n, 10, 2, Some(0.01));
    scene.physics.iterations = 20;
    let model = Model::from_scene(&scene).unwrap();
    let u = fold_controls(&model, 10, 0.02);
    let states = model.simulate(&u).unwrap();
    let largest = (1..=model.task.horizon)
        .flat_map(|t| model.contact_sets(&states[t - 1], &model.step_controls(&u, t - 1)))
        .map(|s| s.index.rows())
        .max()
        .unwrap_or(0);
    eprintln!("largest contact set {largest} rows");
    assert!(largest >= 20, "largest contact set {largest}");
    let run = |threads: usize, budget: usize| common::evaluate_in_pool(&model, &u, threads, budget);
    let reference = run(1, cloth::DEFAULT_CHECKPOINT_BUDGET);
    for (t, x) in states.iter().enumerate() {
        assert!(bitwise_eq(x, &reference.states[t]), "state {t}");
    }
    // 2 threads; the re-recording path (no first-forward recording); blocks of iterations.
    let per_iteration = model.recorded_bytes_per_iteration();
    for (threads, budget) in [
        (2, cloth::DEFAULT_CHECKPOINT_BUDGET),
        (1, 0),
        (2, 0),
        (1, 2 * 7 * per_iteration),
        (2, 2 * 7 * per_iteration),
    ] {
        let other = run(threads, budget);
        assert_eq!(other.metrics.l.to_bits(), reference.metrics.l.to_bits());
        for (t, x) in other.states.iter().enumerate() {
            assert!(
                bitwise_eq(x, &reference.states[t]),
                "state {t} ({threads} threads, budget {budget})"
            );
        }
        assert!(
            bitwise_eq(
                other.grad_l.as_ref().unwrap(),
                reference.grad_l.as_ref().unwrap()
            ),
            "dL/dU ({threads} threads, budget {budget})"
        );
    }
}

#[test]
fn the_recorded_step_rebuilds_the_forward_contacts() {
    let model = Model::from_scene(&fold_scene(N, FOLD, REST, Some(H))).unwrap();
    let u = fold_controls(&model, FOLD, 2.0 * H);
    let plain = model.simulate(&u).unwrap();
    let mut tape = autodiff::Tape::new();
    let mut x = tape.leaf(model.start.clone());
    for t in 0..model.task.horizon {
        let ut = tape.leaf(model.step_controls(&u, t));
        x = model.record_step(&mut tape, x, ut);
        assert!(bitwise_eq(tape.value(x), &plain[t + 1]), "step {}", t + 1);
    }
}

#[test]
fn hard_cases_stay_finite() {
    use cloth::constraint::{hessian_vector_by_duals, value_and_gradient};
    let c = VertexTriangle {
        sides: vec![1.0, -1.0],
        thickness: 0.0,
    };
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let cases: [([f64; 3], [[f64; 3]; 3]); 4] = [
        ([0.5, 0.0, 0.0], tri), // on an edge, in the plane
        ([0.0, 0.0, 0.0], tri), // coincident with a corner
        ([0.2, 0.2, 0.0], tri), // inside, in the plane (zero thickness: C = 0)
        (
            [0.2, 0.2, 0.1],
            [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        ), // zero-area triangle
    ];
    for (k, (p, t)) in cases.iter().enumerate() {
        let x: Vec<f64> = std::iter::once(p).chain(t).flatten().copied().collect();
        for instance in 0..2 {
            let mut g = [0.0; 12];
            let v = value_and_gradient(&c, instance, &x, &mut g);
            let mut hv = [1.0; 12];
            hessian_vector_by_duals(&c, instance, &x, &mut hv);
            assert!(
                v.is_finite() && g.iter().chain(&hv).all(|e| e.is_finite()),
                "case {k}: {v} {g:?} {hv:?}"
            );
        }
    }
    // The pair search: a vertex exactly on an edge and one coincident with a corner both count
    // (edges included), on the normal's side; the zero-area triangle is skipped.
    let triangles: Arc<[[usize; 3]]> = vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]].into();
    let sc = SelfCollision::new(0.0, triangles, 9);
    let x = Tensor::new(
        9,
        3,
        vec![
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, // triangle 0 in z = 0
            0.5, 0.0, 0.0, 3.0, 0.0, 0.0, 3.0, 1.0, 0.0, // vertex 3 on triangle 0's edge
            0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 6.0, 0.0,
            0.0, // vertex 6 on triangle 0's corner; zero area
        ],
    );
    let pairs = sc.find_pairs(&x, 0.1, &[1.0; 9]);
    let found: Vec<(usize, usize, bool)> = pairs
        .iter()
        .map(|c| (c.vertex, c.triangle, c.above))
        .collect();
    // (Vertex 1, a corner of triangle 0, also lies on triangle 1's edge.)
    assert_eq!(found, [(1, 1, true), (3, 0, true), (6, 0, true)]);
    // Whole rollouts with zero thickness and with the grippers landing on the bottom corners.
    for (h, z_end) in [(0.0, 0.0), (H, 0.0), (0.0, 2.0 * H)] {
        let model = Model::from_scene(&fold_scene(N, FOLD, REST, Some(h))).unwrap();
        let u = fold_controls(&model, FOLD, z_end);
        let ev = model.evaluate(&u, 0.0, true).unwrap();
        assert!(ev.grad_l.unwrap().data().iter().all(|g| g.is_finite()));
    }
}

#[test]
fn a_bad_thickness_is_a_named_error_and_newton_takes_self_collision() {
    for h in [-0.01, f64::NAN, f64::INFINITY] {
        let mut scene = fold_scene(4, 2, 0, Some(0.01));
        scene.physics.self_collision.as_mut().unwrap().thickness = h;
        let err = scene.validate().unwrap_err().to_string();
        assert!(
            err.contains("physics.self_collision.thickness"),
            "{h}: {err}"
        );
    }
    // Under Newton self-collision is a barrier (`tests/self_contact_newton.rs`), not an error.
    let mut scene = fold_scene(4, 2, 0, Some(0.01));
    scene.obstacles.clear();
    scene.physics.solver = Some(cloth::scene::SolverKind::Newton);
    scene.validate().unwrap();
    assert!(Model::from_scene(&scene).unwrap().self_barrier.is_some());
}

mod gradients {
    //! Finite-difference checks of `dL/dU` through active self-contacts.
    //!
    //! A 6 × 6 fold (h 0.02–0.05, 30 iterations), the fold's controls plus uniform noise of ±0.01,
    //! targets on the flap's second row (free particles, pressed onto the bottom layer by the
    //! fold), `β = 0.01`. The directional derivative along random directions is compared with a
    //! Richardson central difference at `1e-7`, cases whose stencil crosses a kink left out
    //! ([`common::smooth_derivative`]), and cases whose noise keeps the contacts from moving the
    //! cloth by 1 mm.
    use super::*;
    use common::shifted;
    use proptest::prelude::*;

    const STEP: f64 = 1e-7;

    const SIZE: usize = 8;
    const FOLD_STEPS: usize = 8;
    const STEPS: usize = 11;

    fn scene(h: f64) -> Scene {
        let n = SIZE;
        let mut s = fold_scene(n, FOLD_STEPS, STEPS - FOLD_STEPS, Some(h));
        s.physics.iterations = 30;
        s.task.beta = 0.01;
        s.task.targets = (0..n)
            .map(|c| cloth::scene::Target {
                particle: [1, c].into(),
                position: [c as f64 / (n - 1) as f64, 1.0 - 1.0 / (n - 1) as f64, h],
            })
            .collect();
        s.validate().unwrap();
        s
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 12, max_global_rejects: 12, ..ProptestConfig::default() })]
        #[test]
        fn rollout_gradient_through_self_contacts_matches_finite_differences(
            h in 0.02..0.05f64,
            noise in proptest::collection::vec(-0.01..0.01f64, STEPS * 6),
            dir in proptest::collection::vec(-1.0..1.0f64, STEPS * 6),
        ) {
            let with = Model::from_scene(&scene(h)).unwrap();
            let mut without_scene = scene(h);
            without_scene.physics.self_collision = None;
            let without = Model::from_scene(&without_scene).unwrap();
            let u = shifted(&fold_controls(&with, FOLD_STEPS, 2.0 * h), &noise, 1.0);
            // The contacts act: the layers end apart with them and not without.
            let (a, b) = (with.simulate(&u).unwrap(), without.simulate(&u).unwrap());
            let moved = (0..a[STEPS].rows()).map(|p| (a[STEPS].get(p, 2) - b[STEPS].get(p, 2)).abs()).fold(0.0, f64::max);
            // A case whose noise keeps the layers from pressing tests no contact: left out.
            if moved <= 1e-3 {
                return Err(TestCaseError::reject("the contacts barely act"));
            }
            let ev = with.evaluate_loss_gradient(&u, 0.0).unwrap();
            let g = ev.grad_l.unwrap();
            let analytic: f64 = g.data().iter().zip(&dir).map(|(a, b)| a * b).sum();
            let f = |s: f64| with.evaluate(&shifted(&u, &dir, s), 0.0, false).unwrap().metrics.l;
            let fd = common::smooth_derivative(f, STEP, 1e-6);
            eprintln!("h {h:.4}: analytic {analytic:.9e} fd {fd:?}");
            let Ok(fd1) = fd else {
                return Err(TestCaseError::reject("the FD stencil crosses a kink"));
            };
            let err = (analytic - fd1).abs() / (analytic.abs().max(fd1.abs()) + 1e-8 * ev.metrics.l.abs().max(1.0));
            prop_assert!(err <= 1e-6, "analytic {analytic} vs FD {fd1}: relative error {err:e}");
        }
    }
}

mod overrides {
    //! The closed-form `∇C` of [`VertexTriangle`] and the `∇²C·v` derived from it agree with the
    //! generic dual path ([`cloth::constraint::Generic`]).
    use super::*;
    use cloth::constraint::{value_and_gradient, Generic};
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn closed_form_gradient_and_hessian_match_the_dual_path(
            x in proptest::collection::vec(-1.0..1.0f64, 12),
            v in proptest::collection::vec(-1.0..1.0f64, 12),
            above in any::<bool>(),
            h in 0.0..0.1f64,
        ) {
            let c = VertexTriangle { sides: vec![if above { 1.0 } else { -1.0 }], thickness: h };
            let generic = Generic(c.clone());
            let (mut g, mut gg) = ([0.0; 12], [0.0; 12]);
            let value = value_and_gradient(&c, 0, &x, &mut g);
            let reference = value_and_gradient(&generic, 0, &x, &mut gg);
            prop_assert_eq!(value.to_bits(), reference.to_bits());
            let scale = gg.iter().fold(1.0f64, |m, e| m.max(e.abs()));
            for k in 0..12 {
                prop_assert!((g[k] - gg[k]).abs() <= 1e-12 * scale, "∇C[{}]: {} vs {}", k, g[k], gg[k]);
            }
            let (mut hv, mut hvg) = ([0.0; 12], [0.0; 12]);
            hv.copy_from_slice(&v);
            hvg.copy_from_slice(&v);
            hessian_vector(&c, 0, &x, &mut hv);
            hessian_vector(&generic, 0, &x, &mut hvg);
            let scale = hvg.iter().fold(1.0f64, |m, e| m.max(e.abs()));
            for k in 0..12 {
                prop_assert!((hv[k] - hvg[k]).abs() <= 1e-10 * scale, "∇²C·v[{}]: {} vs {}", k, hv[k], hvg[k]);
            }
        }
    }
}
