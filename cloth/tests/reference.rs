//! The built-in scenes against the reference values of the spec (an independent implementation
//! agrees with them to 1e-14).

use cloth::{Model, Scene};
use common::XorShift;

mod common;

#[test]
fn u_obstacle_initial_guess_matches_reference() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let ev = model
        .evaluate(&scene.initial_controls(), scene.task.delta, false)
        .unwrap();
    let m = ev.metrics;
    println!("{m:?}");
    assert!((m.l - 4.680198820574).abs() < 1e-11, "L = {}", m.l);
    assert!((m.g - 4.462299623814).abs() < 1e-11, "G = {}", m.g);
    assert!((m.e - 2178.99196760).abs() < 1e-7, "E = {}", m.e);
}

/// A deterministic pseudo-random direction in [-1, 1]^n.
fn direction(seed: u64, n: usize) -> Vec<f64> {
    XorShift::new(seed).direction(n)
}

#[test]
fn u_obstacle_gradient_matches_central_differences_along_random_directions() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    // Away from the T kink: perturb the all-equal initial guess so consecutive controls differ.
    let mut u = scene.initial_controls();
    let jitter = direction(99, u.len());
    for (v, j) in u.data_mut().iter_mut().zip(jitter) {
        *v += 0.05 * j;
    }
    let delta = scene.task.delta;
    let ev = model.evaluate(&u, delta, true).unwrap();
    let (gl, gc) = (ev.grad_l.unwrap(), ev.grad_c.unwrap());
    let h = 1e-6;
    for seed in 0..5 {
        let d = direction(seed, u.len());
        let shifted = |s: f64| {
            let mut v = u.clone();
            for (x, di) in v.data_mut().iter_mut().zip(&d) {
                *x += s * di;
            }
            model.evaluate(&v, delta, false).unwrap().metrics
        };
        let (p, m) = (shifted(h), shifted(-h));
        let fd_l = (p.l - m.l) / (2.0 * h);
        let fd_c = (p.c - m.c) / (2.0 * h);
        let an_l: f64 = gl.data().iter().zip(&d).map(|(g, di)| g * di).sum();
        let an_c: f64 = gc.data().iter().zip(&d).map(|(g, di)| g * di).sum();
        println!("dir {seed}: dL {an_l:.10} vs FD {fd_l:.10}; dC {an_c:.10} vs FD {fd_c:.10}");
        assert!(
            (an_l - fd_l).abs() <= 1e-6 * fd_l.abs().max(1.0),
            "dL: {an_l} vs {fd_l}"
        );
        assert!(
            (an_c - fd_c).abs() <= 1e-6 * fd_c.abs().max(1.0),
            "dC: {an_c} vs {fd_c}"
        );
    }
}

/// `dL/dU` of `u_obstacle` at its initial guess from the independent JAX implementation of the
/// same spec (`shared/anchors/jax_ref/bench_jax.py U 10 100`), float64.
const JAX_GRAD_L: [[f64; 6]; 10] = [
    [
        -0.18061283423485325,
        -1.5658223114560623,
        0.9354367949804584,
        -0.09100346291725006,
        -0.835489713148398,
        0.4959975035087216,
    ],
    [
        -0.16007215508960498,
        -1.5601187553326248,
        0.9002702917620673,
        -0.099144626313447,
        -0.8313485685640739,
        0.47723629065062795,
    ],
    [
        -0.1340791170060676,
        -1.5476819360505414,
        0.8517631427891411,
        -0.11133494299663968,
        -0.8240740951911927,
        0.4494729578705326,
    ],
    [
        -0.10280885231362652,
        -1.5313727839467959,
        0.7864752741369688,
        -0.12615309281998557,
        -0.8152021589643353,
        0.4112295634209206,
    ],
    [
        -0.06672596849076379,
        -1.5104965273607898,
        0.7008361391230573,
        -0.14200978754263335,
        -0.8040673263222996,
        0.36055854098179246,
    ],
    [
        -0.025553603453683946,
        -1.4830892939697575,
        0.5899298544439097,
        -0.15689972713925004,
        -0.7874973017113023,
        0.2962356208700946,
    ],
    [
        0.022026163428657822,
        -1.4420990675784144,
        0.4470782546248413,
        -0.16754213411608707,
        -0.7590045250356997,
        0.2169247261742592,
    ],
    [
        0.07238183711933197,
        -1.3671544673363936,
        0.26526195202458164,
        -0.16538846638877602,
        -0.7048773963913579,
        0.12168250602161729,
    ],
    [
        0.11708830107935012,
        -1.20513750748923,
        0.05640205699582329,
        -0.14035786478629153,
        -0.5953960150074745,
        0.01863758116189371,
    ],
    [
        0.12335855573185535,
        -0.8182953415623561,
        -0.11350990026557313,
        -0.07739842877619618,
        -0.3721219427530264,
        -0.05312086433225144,
    ],
];

#[test]
fn u_obstacle_gradient_matches_independent_jax_implementation() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let ev = model
        .evaluate(&scene.initial_controls(), scene.task.delta, true)
        .unwrap();
    let g = ev.grad_l.unwrap();
    let mut worst: f64 = 0.0;
    for (t, row) in JAX_GRAD_L.iter().enumerate() {
        for (j, &want) in row.iter().enumerate() {
            worst = worst.max((g.get(t, j) - want).abs());
        }
    }
    println!("max |dL/dU - JAX| = {worst:.3e}");
    assert!(worst < 1e-10, "max deviation from the JAX gradient {worst}");
}
