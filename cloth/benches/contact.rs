//! The price of contacts at n = 40 (a 40 × 40 cloth, 1 × 1, lying on a ground collider, its
//! row-0 edge carried over a half circle onto the far edge in 10 steps, 50 Gauss–Seidel
//! iterations per step), forward (`Model::evaluate(.., false)`) and forward + ∇L
//! (`Model::evaluate_loss_gradient`):
//! - `plain`: the fold without self-collision (the cloth passes through itself);
//! - `self_collision`: the same with `physics.self_collision.thickness = 0.01` (the flap lands
//!   on the bottom layer, so contacts exist; the bench prints how many pairs per step);
//! - `self_collision_edges`: the same with edge–edge contacts too
//!   (`physics.self_collision.edge_edge`);
//! - `mesh_collider`, `mesh_safety`: `plain` plus a closed mesh obstacle of 5120 triangles (an
//!   icosphere of radius 0.1 generated here, four subdivisions of an icosahedron) in the crease,
//!   so the cloth folds over it, as a collider and as a safety obstacle (`δ = 0.02`);
//! - `friction`: `plain` with Coulomb friction `μ = 0.5` on the ground (the cloth lies on it, so
//!   every free particle's frictional row acts).
//!
//! The targets (issue 18): self-collision ≤ +50%, a 5k-triangle mesh obstacle ≤ +30% over
//! `plain` (friction has none). Single thread, as the targets are stated:
//! `RAYON_NUM_THREADS=1 cargo bench -p cloth --bench contact`.
//!
//! With `CONTACT_ONCE=<case>/<forward|forward_grad_l>` in the environment the bench instead runs
//! that one evaluation once and exits (no criterion), for instruction counts of exactly one
//! evaluation: `RAYON_NUM_THREADS=1 CONTACT_ONCE=friction/forward_grad_l valgrind
//! --tool=callgrind --collect-atstart=no --toggle-collect='*evaluate_with*' BENCH_BINARY`.

use autodiff::Tensor;
use cloth::scene::{MeshSpec, Obstacle, ObstacleRole, SelfCollisionSpec};
use cloth::sdf::MeshSdf;
use cloth::{Model, Scene};
use criterion::{criterion_group, BenchmarkId, Criterion};
use std::collections::HashMap;
use std::hint::black_box;

const N: usize = 40;
const FOLD: usize = 10;
const DELTA: f64 = 0.02;

/// The fold scene: `N × N`, lying at z = 0 on a ground collider (`friction` as its JSON
/// `"friction"` member, or frictionless when `None`), gripped at the row-0 corners.
fn fold_scene(friction: Option<f64>) -> Scene {
    let friction = friction.map_or(String::new(), |mu| format!(r#", "friction": {mu}"#));
    let json = format!(
        r#"{{
        "name": "fold_bench",
        "cloth": {{"rows": {N}, "cols": {N}, "top_left": [0, 0, 0], "right": [1, 0, 0],
                   "down": [0, 1, 0], "particle_mass": 1.0}},
        "material": {{"stretch": 10000.0, "bending": {{"model": "distance", "stiffness": 100.0}}}},
        "physics": {{"dt": 0.1, "gravity": [0, 0, -9.8], "iterations": 50}},
        "controls": [[0, 0], [0, {last}]],
        "obstacles": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "role": "collider"{friction}}}],
        "task": {{"horizon": {FOLD}, "targets": [
                    {{"particle": [0, 0], "position": [0, 1, 0.05]}},
                    {{"particle": [0, {last}], "position": [1, 1, 0.05]}}],
                 "alpha": 1.0, "beta": 0.0001, "initial_controls": "zeros"}}
        }}"#,
        last = N - 1
    );
    Scene::from_json_str(&json).expect("fold scene")
}

/// Both grippers over `y = 0.5 − 0.5·cos θ`, `z = 0.5·sin θ + 0.02·θ/π`, `θ = 0 … π`.
fn fold_controls(model: &Model) -> Tensor {
    let at = |t: usize| {
        let th = std::f64::consts::PI * t as f64 / FOLD as f64;
        [
            0.5 - 0.5 * th.cos(),
            0.5 * th.sin() + 0.02 * th / std::f64::consts::PI,
        ]
    };
    let mut u = model.zero_controls();
    for t in 0..FOLD {
        let (a, b) = (at(t), at(t + 1));
        for k in 0..model.n_controls() {
            u.row_mut(t)[3 * k + 1] = b[0] - a[0];
            u.row_mut(t)[3 * k + 2] = b[1] - a[1];
        }
    }
    u
}

/// An icosphere: an icosahedron subdivided `levels` times, projected onto the sphere
/// (`20·4^levels` triangles, outward-oriented).
fn icosphere(center: [f64; 3], radius: f64, levels: usize) -> MeshSdf {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<[f64; 3]> = vec![
        [-1.0, p, 0.0],
        [1.0, p, 0.0],
        [-1.0, -p, 0.0],
        [1.0, -p, 0.0],
        [0.0, -1.0, p],
        [0.0, 1.0, p],
        [0.0, -1.0, -p],
        [0.0, 1.0, -p],
        [p, 0.0, -1.0],
        [p, 0.0, 1.0],
        [-p, 0.0, -1.0],
        [-p, 0.0, 1.0],
    ];
    let mut triangles: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoints: HashMap<(usize, usize), usize> = HashMap::new();
        let mut mid = |a: usize, b: usize, vertices: &mut Vec<[f64; 3]>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (va, vb) = (vertices[a], vertices[b]);
                vertices.push([0, 1, 2].map(|k| 0.5 * (va[k] + vb[k])));
                vertices.len() - 1
            })
        };
        let mut next = Vec::with_capacity(4 * triangles.len());
        for &[a, b, c] in &triangles {
            let (ab, bc, ca) = (
                mid(a, b, &mut vertices),
                mid(b, c, &mut vertices),
                mid(c, a, &mut vertices),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    let vertices = vertices
        .into_iter()
        .map(|v| {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [0, 1, 2].map(|k| center[k] + radius * v[k] / l)
        })
        .collect();
    MeshSdf::new(vertices, triangles)
}

/// The bench's cases by name, in the order they are measured.
fn cases() -> Vec<(&'static str, Scene)> {
    let plain = fold_scene(None);
    let mut with_sc = plain.clone();
    with_sc.physics.self_collision = Some(SelfCollisionSpec {
        thickness: 0.01,
        edge_edge: false,
        friction: None,
    });
    let mut with_edges = with_sc.clone();
    if let Some(sc) = with_edges.physics.self_collision.as_mut() {
        sc.edge_edge = true;
    }
    let sphere = icosphere([0.5, 0.5, 0.12], 0.1, 4);
    eprintln!("mesh obstacle: {} triangles", sphere.triangle_count());
    let with_mesh = |role: ObstacleRole| {
        let mut s = plain.clone();
        s.obstacles.push(Obstacle::Mesh(MeshSpec {
            file: "icosphere.obj".into(),
            role,
            friction: None,
            surface: Some(sphere.clone()),
        }));
        s.validate().expect("valid scene");
        s
    };
    vec![
        ("plain", plain.clone()),
        ("self_collision", with_sc),
        ("self_collision_edges", with_edges),
        ("mesh_collider", with_mesh(ObstacleRole::Collider)),
        ("mesh_safety", with_mesh(ObstacleRole::Safety)),
        ("friction", fold_scene(Some(0.5))),
    ]
}

/// One evaluation of one case (`CONTACT_ONCE=<case>/<forward|forward_grad_l>`), for callgrind.
fn once(spec: &str) {
    let (case, mode) = spec.split_once('/').expect("CONTACT_ONCE=<case>/<mode>");
    let (_, scene) = cases()
        .into_iter()
        .find(|(name, _)| *name == case)
        .expect("a case of the bench");
    let model = Model::from_scene(&scene).expect("model");
    let u = fold_controls(&model);
    let eval = match mode {
        "forward" => model.evaluate(&u, DELTA, false),
        "forward_grad_l" => model.evaluate_loss_gradient(&u, DELTA),
        other => panic!("unknown mode {other}"),
    }
    .expect("finite");
    // A fingerprint of the gradient's bits, so runs before and after a change can be compared.
    let bits = eval.grad_l.map_or(0, |g| {
        g.data()
            .iter()
            .fold(0u64, |h, v| h.rotate_left(5) ^ v.to_bits())
    });
    eprintln!(
        "{case}/{mode}: L = {:.17e}, dL/dU bits {bits:016x}",
        eval.metrics.l
    );
}

fn contacts(c: &mut Criterion) {
    let cases = cases();
    let mut group = c.benchmark_group("fold_n40");
    group.sample_size(10);
    for (name, scene) in cases {
        let model = Model::from_scene(&scene).expect("model");
        let u = fold_controls(&model);
        let states = model.simulate(&u).expect("finite");
        let pairs: Vec<(usize, usize)> = (0..FOLD)
            .map(|t| {
                let ut = model.step_controls(&u, t);
                let held = model.contact_pairs(&states[t], &ut);
                (held.len(), model.edge_pairs(&states[t], &ut, &held).len())
            })
            .collect();
        eprintln!(
            "{name}: {}; (vertex–triangle, edge–edge) pairs per step {pairs:?}",
            model.effects()
        );
        group.bench_with_input(BenchmarkId::new("forward", name), &name, |b, _| {
            b.iter(|| black_box(model.evaluate(&u, DELTA, false).expect("finite")))
        });
        group.bench_with_input(BenchmarkId::new("forward_grad_l", name), &name, |b, _| {
            b.iter(|| black_box(model.evaluate_loss_gradient(&u, DELTA).expect("finite")))
        });
    }
    group.finish();
}

criterion_group!(benches, contacts);

fn main() {
    if let Ok(spec) = std::env::var("CONTACT_ONCE") {
        return once(&spec);
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
