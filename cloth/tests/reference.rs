//! The built-in scenes against the reference values of the spec (an independent implementation
//! agrees with them to 1e-14).

use autodiff::Tensor;
use cloth::{Model, Scene};

fn initial(scene: &Scene) -> Tensor {
    let u = scene.initial_controls_array();
    Tensor::new(
        u.len(),
        3 * scene.controls.len(),
        u.into_iter().flatten().flatten().collect(),
    )
}

#[test]
fn u_obstacle_initial_guess_matches_reference() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    let ev = model
        .evaluate(&initial(&scene), scene.task.delta, false)
        .unwrap();
    let m = ev.metrics;
    println!("{m:?}");
    assert!((m.l - 4.680198820574).abs() < 1e-11, "L = {}", m.l);
    assert!((m.g - 4.462299623814).abs() < 1e-11, "G = {}", m.g);
    assert!((m.e - 2178.99196760).abs() < 1e-7, "E = {}", m.e);
}

/// A deterministic pseudo-random direction in [-1, 1]^n (xorshift), so the test needs no RNG crate.
fn direction(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
        .collect()
}

#[test]
fn u_obstacle_gradient_matches_central_differences_along_random_directions() {
    let scene = Scene::builtin("u_obstacle").unwrap();
    let model = Model::from_scene(&scene).unwrap();
    // Away from the T kink: perturb the all-equal initial guess so consecutive controls differ.
    let mut u = initial(&scene);
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
