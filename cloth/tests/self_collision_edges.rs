//! Edge–edge self-contacts (`physics.self_collision.edge_edge`).
//!
//! The scene: two strips of one mesh cloth crossing edge-on. Strip A lies along x at z = 0
//! (half-width `w`, vertices every 0.1, held at its four corners, no gravity); strip B hangs in
//! the plane x = 0.05 (columns at y = ±0.05, ±0.15, …, rows at z = 0.05, 0.15, 0.25), wholly
//! gripped and lowered 0.1 per step through A. B's vertices never face A's triangles when
//! `w < 0.04` (and only two columns do when `w = 0.08`), so vertex–triangle contacts alone let
//! B's bottom edge pass through A; the edge–edge rows carry A down with it instead. (The
//! closed-form `∇C` of [`EdgeEdge`] against the dual path: `tests/overrides.rs`.)

mod common;

use autodiff::{Tape, Tensor};
use cloth::constraint::value_and_gradient;
use cloth::internals::{EdgeEdge, EdgePair};
use cloth::nalgebra::Vector3;
use cloth::ObjMesh;
use cloth::{crossings, intersections};
use cloth::{Model, Scene};
use common::bitwise_eq;
use proptest::prelude::*;
use std::path::Path;

/// Vertices of strip A (its first 22 particles; B's follow).
const A: usize = 22;

/// The strips scene: A of half-width `w`, thickness `h`, `steps` steps, edge–edge rows when
/// `edges`; targets on A's middle vertices (so `L` depends on where B pushes A).
fn strips(w: f64, h: f64, steps: usize, edges: bool) -> Scene {
    let mut obj = String::new();
    let mut faces = Vec::new();
    for i in 0..11 {
        for s in [-1.0, 1.0] {
            obj += &format!("v {} {} 0\n", -0.5 + 0.1 * i as f64, s * w);
        }
    }
    for i in 0..10 {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        faces.extend([[a, c, b], [b, c, d]]);
    }
    for j in 0..10 {
        for k in 0..3 {
            let (y, z) = (-0.45 + 0.1 * j as f64, 0.05 + 0.1 * k as f64);
            obj += &format!("v 0.05 {y} {z}\n");
        }
    }
    let b = |j: usize, k: usize| A + 3 * j + k;
    for j in 0..9 {
        for k in 0..2 {
            faces.extend([
                [b(j, k), b(j + 1, k), b(j, k + 1)],
                [b(j + 1, k), b(j + 1, k + 1), b(j, k + 1)],
            ]);
        }
    }
    for f in &faces {
        obj += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    let mesh = ObjMesh::parse(&obj, Path::new("strips.obj")).unwrap();
    let mut controls = vec![0, 1, 20, 21];
    controls.extend(A..A + 30);
    let json = format!(
        r#"{{
        "name": "strips", "cloth": {{"mesh": "strips.obj", "particle_mass": 1.0}},
        "material": {{"stretch": 1000.0}},
        "physics": {{"dt": 0.1, "gravity": [0, 0, 0], "iterations": 30, "solver": "xpbd",
                     "self_collision": {{"thickness": {h}, "edge_edge": {edges}}}}},
        "controls": {controls:?},
        "task": {{"horizon": {steps}, "targets": [
            {{"particle": 10, "position": [0.0, -0.03, -0.1]}},
            {{"particle": 11, "position": [0.0, 0.03, -0.1]}},
            {{"particle": 12, "position": [0.1, -0.03, -0.1]}}],
            "alpha": 1.0, "beta": 0.01, "initial_controls": "zeros"}}
    }}"#
    );
    let mut scene: Scene = serde_json::from_str(&json).unwrap();
    scene.cloth.mesh_data = Some(mesh);
    scene.validate().unwrap();
    scene
}

/// B lowered by 0.1 per step (A's corners held).
fn lower(model: &Model) -> Tensor {
    let mut u = model.zero_controls();
    for t in 0..u.rows() {
        for k in 4..model.n_controls() {
            u.row_mut(t)[3 * k + 2] = -0.1;
        }
    }
    u
}

/// The smallest distance between a segment of A and one of B (sampled finely).
fn strip_gap(model: &Model, x: &Tensor) -> f64 {
    let p = |i: usize| Vector3::new(x.get(i, 0), x.get(i, 1), x.get(i, 2));
    let edges =
        cloth::ClothMesh::from_triangles(x.rows(), model.triangles.to_vec()).stretch_edges();
    let (a, b): (Vec<[usize; 2]>, Vec<[usize; 2]>) = edges.iter().partition(|e| e[0] < A);
    let mut best = f64::INFINITY;
    for e in &a {
        for f in &b {
            for i in 0..=40 {
                let q = p(e[0]) + (p(e[1]) - p(e[0])) * (i as f64 / 40.0);
                // Distance from q to segment f.
                let d = p(f[1]) - p(f[0]);
                let s = ((q - p(f[0])).dot(&d) / d.dot(&d)).clamp(0.0, 1.0);
                best = best.min((q - (p(f[0]) + d * s)).norm());
            }
        }
    }
    best
}

#[test]
fn edge_edge_rows_keep_a_strip_from_passing_through_another_edge_on() {
    let h = 0.01;
    for w in [0.03, 0.08] {
        // Vertex–triangle contacts only: B's bottom edge passes through A.
        let model = Model::from_scene(&strips(w, h, 3, false)).unwrap();
        let u = lower(&model);
        let states = model.simulate(&u).unwrap();
        let crossed: usize = (1..states.len())
            .map(|t| {
                crossings(&model.triangles, &states[t - 1], &states[t])
                    .edge_edge
                    .len()
            })
            .sum();
        assert!(
            crossed >= 3,
            "w {w}: {crossed} edge–edge crossings without the rows"
        );
        let touching = states[1..]
            .iter()
            .map(|x| strip_gap(&model, x))
            .fold(f64::INFINITY, f64::min);
        assert!(touching < 1e-3, "w {w}: the strips met ({touching})");
        // With edge–edge rows: no crossing, no intersection, the strips a thickness apart, and A
        // carried down.
        let model = Model::from_scene(&strips(w, h, 3, true)).unwrap();
        let states = model.simulate(&u).unwrap();
        for t in 1..states.len() {
            let c = crossings(&model.triangles, &states[t - 1], &states[t]);
            assert!(
                c.edge_edge.is_empty() && c.vertex_triangle.is_empty(),
                "w {w} step {t}: {c:?}"
            );
            assert!(intersections(&model.triangles, &states[t]).is_empty());
            let gap = strip_gap(&model, &states[t]);
            assert!(gap >= 0.999 * h, "w {w} step {t}: gap {gap}");
        }
        let lowest = (0..A)
            .map(|i| states[3].get(i, 2))
            .fold(f64::INFINITY, f64::min);
        assert!(lowest < -0.2, "w {w}: A's lowest point {lowest}");
    }
}

#[test]
fn edge_edge_rows_are_absent_unless_asked_for() {
    for (edges, expect) in [(false, false), (true, true)] {
        let model = Model::from_scene(&strips(0.03, 0.01, 2, edges)).unwrap();
        let u = lower(&model);
        let x = model.simulate(&u).unwrap();
        let held = model.contact_pairs(&x[1], &model.step_controls(&u, 1));
        let pairs = model.edge_pairs(&x[1], &model.step_controls(&u, 1), &held);
        assert_eq!(!pairs.is_empty(), expect);
        let sets = model.contact_sets(&x[1], &model.step_controls(&u, 1));
        let vt = model
            .self_collision
            .as_ref()
            .unwrap()
            .projection_sets(&held, &model.inv_mass)
            .len();
        assert_eq!(
            sets.len() > vt,
            expect,
            "{} sets, {vt} vertex–triangle",
            sets.len()
        );
    }
    // Absent from the printed scene unless set.
    let text = serde_json::to_string(&strips(0.03, 0.01, 2, false).physics).unwrap();
    assert!(!text.contains("edge_edge"), "{text}");
}

/// The documented rule (`cloth/src/contact/edge_edge.rs`), every edge pair against every one of
/// its triangles.
fn brute_force(
    model: &Model,
    x: &Tensor,
    radius: f64,
    held: &[cloth::internals::ContactPair],
) -> Vec<EdgePair> {
    let sc = model.self_collision.as_ref().unwrap();
    let h = sc.thickness;
    let tris = &model.triangles;
    let p = |i: usize| Vector3::new(x.get(i, 0), x.get(i, 1), x.get(i, 2));
    let mesh = cloth::ClothMesh::from_triangles(x.rows(), tris.to_vec());
    let edges = mesh.stretch_edges();
    let key = |a: usize, b: usize| [a.min(b), a.max(b)];
    let mut of_edge: std::collections::HashMap<[usize; 2], Vec<usize>> = Default::default();
    let mut ring: Vec<std::collections::BTreeSet<usize>> =
        (0..x.rows()).map(|v| [v].into()).collect();
    for (k, t) in tris.iter().enumerate() {
        for j in 0..3 {
            of_edge
                .entry(key(t[j], t[(j + 1) % 3]))
                .or_default()
                .push(k);
            ring[t[j]].extend(t.iter().copied());
        }
    }
    let uses = |e: [usize; 2]| of_edge[&e].len();
    let mut is_held = vec![false; x.rows()];
    for c in held {
        is_held[c.vertex] = true;
    }
    let mut out = Vec::new();
    for (i, &e) in edges.iter().enumerate() {
        for &f in &edges[i + 1..] {
            let ok = |e: [usize; 2], f: [usize; 2]| {
                let (a, b, c, d) = (p(e[0]), p(e[1]), p(f[0]), p(f[1]));
                let (d1, d2, r) = (b - a, d - c, a - c);
                let (aa, bb, ee) = (d1.dot(&d1), d1.dot(&d2), d2.dot(&d2));
                let (cc, ff) = (d1.dot(&r), d2.dot(&r));
                let denom = aa * ee - bb * bb;
                if denom.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                    || d1.cross(&d2).norm_squared() == 0.0
                {
                    return false;
                }
                let (u, w) = ((bb * ff - cc * ee) / denom, (aa * ff - bb * cc) / denom);
                let n = d1.cross(&d2);
                if !((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&w))
                    || (c - a).dot(&n).abs() > radius * n.norm()
                {
                    return false;
                }
                let q = c + d2 * w;
                // Over a non-degenerate triangle of e (grown by h across border edges).
                of_edge[&e].iter().any(|&ti| {
                    let t = tris[ti];
                    let k = t.map(p);
                    let nt = (k[1] - k[0]).cross(&(k[2] - k[0]));
                    if nt.norm().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                        return false;
                    }
                    let nt = nt / nt.norm();
                    (0..3).all(|j| {
                        let inward = nt.cross(&(k[(j + 1) % 3] - k[j])).normalize();
                        let margin = if uses(key(t[j], t[(j + 1) % 3])) == 1 {
                            h
                        } else {
                            0.0
                        };
                        (q - k[j]).dot(&inward) >= -margin
                    })
                })
            };
            let four = [e[0], e[1], f[0], f[1]];
            if f.iter()
                .any(|&v| ring[e[0]].contains(&v) || ring[e[1]].contains(&v))
                || four.iter().all(|&v| is_held[v])
                || four.iter().all(|&v| model.inv_mass[v] == 0.0)
                || !(ok(e, f) || ok(f, e))
            {
                continue;
            }
            let side = (p(f[0]) - p(e[0])).dot(&(p(e[1]) - p(e[0])).cross(&(p(f[1]) - p(f[0]))));
            out.push(EdgePair {
                first: e,
                second: f,
                above: side >= 0.0,
            });
        }
    }
    out
}

#[test]
fn the_pair_search_lists_exactly_the_documented_pairs() {
    let mut checked = 0;
    // The strips, and a fold (grid cloth) with edge–edge rows, on every state.
    let mut fold = Scene::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/scenes/fold/fold_xpbd.json"
    ))
    .unwrap();
    fold.physics.self_collision.as_mut().unwrap().edge_edge = true;
    fold.physics.iterations = 40;
    fold.validate().unwrap();
    for scene in [
        strips(0.03, 0.01, 3, true),
        strips(0.08, 0.02, 3, true),
        fold,
    ] {
        let model = Model::from_scene(&scene).unwrap();
        let u = if model.n_controls() > 2 {
            lower(&model)
        } else {
            scene.initial_controls()
        };
        let states = model.simulate(&u).unwrap();
        for (t, x) in states[..states.len() - 1].iter().enumerate() {
            let ut = model.step_controls(&u, t);
            let held = model.contact_pairs(x, &ut);
            let sc = model.self_collision.as_ref().unwrap();
            let radius = model.contact_radius(sc.thickness, &ut);
            let found = model.edge_pairs(x, &ut, &held);
            let mut want = brute_force(&model, x, radius, &held);
            // The search lists pairs in edge-index order; the brute force in the same order.
            want.sort_by_key(|c| (c.first, c.second));
            let mut got = found.clone();
            got.sort_by_key(|c| (c.first, c.second));
            assert_eq!(got, want, "step {t}");
            checked += found.len();
        }
    }
    assert!(checked > 100, "{checked} pairs checked");
}

#[test]
fn rollouts_and_gradients_with_edge_rows_are_bitwise_identical_on_every_path_and_thread_count() {
    let model = Model::from_scene(&strips(0.03, 0.01, 3, true)).unwrap();
    let u = lower(&model);
    let plain = model.simulate(&u).unwrap();
    // The rows act (some step has edge–edge pairs).
    let pairs: usize = (0..3)
        .map(|t| {
            let ut = model.step_controls(&u, t);
            let held = model.contact_pairs(&plain[t], &ut);
            model.edge_pairs(&plain[t], &ut, &held).len()
        })
        .sum();
    assert!(pairs > 0);
    // The recorded path rebuilds the forward's contacts.
    let mut tape = Tape::new();
    let mut x = tape.leaf(model.start.clone());
    for t in 0..model.task.horizon {
        let ut = tape.leaf(model.step_controls(&u, t));
        x = model.record_step(&mut tape, x, ut);
        assert!(bitwise_eq(tape.value(x), &plain[t + 1]), "step {}", t + 1);
    }
    let run = |threads: usize, budget: usize| common::evaluate_in_pool(&model, &u, threads, budget);
    let reference = run(1, cloth::DEFAULT_CHECKPOINT_BUDGET);
    assert!(reference
        .grad_l
        .as_ref()
        .unwrap()
        .data()
        .iter()
        .any(|&g| g != 0.0));
    for (threads, budget) in [(2, cloth::DEFAULT_CHECKPOINT_BUDGET), (1, 0), (2, 0)] {
        let other = run(threads, budget);
        assert_eq!(other.metrics.l.to_bits(), reference.metrics.l.to_bits());
        for (a, b) in other.states.iter().zip(&reference.states) {
            assert!(bitwise_eq(a, b));
        }
        assert!(bitwise_eq(
            other.grad_l.as_ref().unwrap(),
            reference.grad_l.as_ref().unwrap()
        ));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, max_global_rejects: 24, ..ProptestConfig::default() })]

    /// `dL/dU` through the edge–edge rows (A pushed down by B's edge) against fourth-order
    /// central differences along a random direction, where the stencil crosses no kink.
    #[test]
    fn rollout_gradient_through_edge_contacts_matches_finite_differences(
        w in 0.02..0.035f64,
        noise in proptest::collection::vec(-0.01..0.01f64, 2 * 34 * 3),
        dir in proptest::collection::vec(-1.0..1.0f64, 2 * 34 * 3),
    ) {
        let with = Model::from_scene(&strips(w, 0.01, 2, true)).unwrap();
        let without = Model::from_scene(&strips(w, 0.01, 2, false)).unwrap();
        let mut u = lower(&with);
        for (x, n) in u.data_mut().iter_mut().zip(&noise) {
            *x += n;
        }
        // The rows act: A ends elsewhere with them.
        let (a, b) = (with.simulate(&u).unwrap(), without.simulate(&u).unwrap());
        let moved = (0..A).map(|p| (a[2].get(p, 2) - b[2].get(p, 2)).abs()).fold(0.0, f64::max);
        prop_assert!(moved > 1e-2, "edge rows moved A by {moved}");
        let ev = with.evaluate_loss_gradient(&u, 0.0).unwrap();
        let analytic: f64 = ev.grad_l.unwrap().data().iter().zip(&dir).map(|(a, b)| a * b).sum();
        let f = |s: f64| {
            let mut v = u.clone();
            for (x, d) in v.data_mut().iter_mut().zip(&dir) {
                *x += s * d;
            }
            with.evaluate(&v, 0.0, false).unwrap().metrics.l
        };
        let Ok(fd1) = common::smooth_derivative(f, 1e-7, 1e-6) else {
            return Err(TestCaseError::reject("the FD stencil crosses a kink"));
        };
        let err = (analytic - fd1).abs() / (analytic.abs().max(fd1.abs()) + 1e-8);
        prop_assert!(err <= 1e-6, "analytic {analytic} vs FD {fd1}: relative error {err:e}");
    }

}

/// Parallel edges have no normal: `C = −h` with gradient 0, and the projection leaves them.
#[test]
fn parallel_edges_are_left_alone() {
    let c = EdgeEdge {
        sides: vec![1.0],
        thickness: 0.01,
    };
    let x = [
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.005, 0.0, 1.0, 0.005, 0.0,
    ];
    let mut g = [1.0; 12];
    assert_eq!(value_and_gradient(&c, 0, &x, &mut g), -0.01);
    assert!(g.iter().all(|&v| v == 0.0));
}
