//! The self-contact pair search against brute force: on every state of a fold (flat, bending,
//! folded onto itself) and of a crumpled random cloth, the grid search lists exactly the pairs
//! the documented rule admits when every vertex is tested against every triangle.

use autodiff::Tensor;
use cloth::internals::ContactPair;
use cloth::nalgebra::Vector3;
use cloth::{Model, Scene};
use std::collections::HashMap;

/// An `n × n` fold of side 1 on a ground collider with self-collision of thickness `h`.
fn fold_scene(n: usize, fold: usize, h: f64) -> Scene {
    let json = format!(
        r#"{{
        "name": "fold_pairs",
        "cloth": {{"rows": {n}, "cols": {n}, "top_left": [0, 0, 0], "right": [1, 0, 0],
                   "down": [0, 1, 0], "particle_mass": 1.0}},
        "material": {{"stretch": 10000.0, "bending": {{"model": "distance", "stiffness": 100.0}}}},
        "physics": {{"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 30, "solver": "xpbd",
                     "self_collision": {{"thickness": {h}}}}},
        "controls": [[0, 0], [0, {last}]],
        "obstacles": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "role": "collider"}}],
        "task": {{"horizon": {fold}, "targets": [{{"particle": [0, 0], "position": [0, 1, 0.05]}}],
                 "alpha": 1.0, "beta": 0.0001, "initial_controls": "zeros"}}
        }}"#,
        last = n - 1,
    );
    Scene::from_json_str(&json).unwrap()
}

/// Both grippers over a half circle onto the far edge in `fold` steps.
fn fold_controls(model: &Model, fold: usize) -> Tensor {
    let at = |t: usize| {
        let th = std::f64::consts::PI * t as f64 / fold as f64;
        [
            0.5 - 0.5 * th.cos(),
            0.5 * th.sin() + 0.02 * th / std::f64::consts::PI,
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

/// The documented rule, every vertex against every triangle (the same arithmetic as the search).
fn brute_force(model: &Model, x: &Tensor, radius: f64) -> Vec<ContactPair> {
    let sc = model.self_collision.as_ref().expect("self-collision");
    let h = sc.thickness;
    let tris = &model.triangles;
    let edge = |a: usize, b: usize| (a.min(b), a.max(b));
    let mut uses: HashMap<(usize, usize), usize> = HashMap::new();
    for &[a, b, c] in tris.iter() {
        for e in [edge(a, b), edge(b, c), edge(c, a)] {
            *uses.entry(e).or_default() += 1;
        }
    }
    let point = |p: usize| Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2));
    let mut pairs = Vec::new();
    for p in 0..x.rows() {
        for (k, &tri) in tris.iter().enumerate() {
            let [a, b, c] = tri.map(point);
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let n = n / len;
            let q = point(p);
            let d = (q - a).dot(&n);
            let inside = |e0: &Vector3<f64>, e1: &Vector3<f64>, border: bool| {
                let e = e1 - e0;
                let margin = if border { h * e.norm() } else { 0.0 };
                e.cross(&(q - e0)).dot(&n) >= -margin
            };
            let border = |i: usize, j: usize| uses[&edge(tri[i], tri[j])] == 1;
            let movable = tri.iter().any(|&v| model.inv_mass[v] > 0.0) || model.inv_mass[p] > 0.0;
            if d.abs() <= radius
                && inside(&a, &b, border(0, 1))
                && inside(&b, &c, border(1, 2))
                && inside(&c, &a, border(2, 0))
                && movable
                && !sc.excludes(p, k)
            {
                pairs.push(ContactPair {
                    vertex: p,
                    triangle: k,
                    above: d >= 0.0,
                });
            }
        }
    }
    pairs
}

#[test]
fn the_grid_search_finds_exactly_the_brute_force_pairs() {
    let fold = 8;
    for h in [0.0, 0.02, 0.08] {
        let model = Model::from_scene(&fold_scene(12, fold, h)).unwrap();
        let u = fold_controls(&model, fold);
        let states = model.simulate(&u).unwrap();
        let mut found = 0;
        for (t, state) in states.iter().enumerate().take(fold) {
            let ut = model.step_controls(&u, t);
            let sc = model.self_collision.as_ref().unwrap();
            for radius in [model.contact_radius(sc.thickness, &ut), h + 0.03] {
                let pairs = sc.find_pairs(state, radius, &model.inv_mass);
                assert_eq!(
                    pairs,
                    brute_force(&model, state, radius),
                    "h {h}, step {t}, radius {radius}"
                );
                found += pairs.len();
            }
        }
        assert!(found > 0, "the fold has contacts (h {h})");
    }
}

#[test]
fn a_crumpled_cloth_gets_exactly_the_brute_force_pairs() {
    // Every vertex displaced at random (a deterministic generator): triangles at every angle.
    let model = Model::from_scene(&fold_scene(10, 1, 0.05)).unwrap();
    let mut x = model.start.clone();
    let mut seed = 11u64;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for v in x.data_mut() {
        *v += 0.15 * next();
    }
    let sc = model.self_collision.as_ref().unwrap();
    for radius in [0.0, 0.05, 0.2, 0.6] {
        let pairs = sc.find_pairs(&x, radius, &model.inv_mass);
        assert_eq!(pairs, brute_force(&model, &x, radius), "radius {radius}");
        assert!(radius == 0.0 || !pairs.is_empty());
    }
}
