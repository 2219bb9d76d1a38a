//! The Newton solver's forward pass: its state against XPBD's converged one, convergence
//! statistics, and the solver settings' validation.

mod common;

use autodiff::Tensor;
use cloth::newton::{NewtonSettings, Solver};
use cloth::scene::SolverKind;
use cloth::{Model, Scene};

fn rel_diff(a: &Tensor, b: &Tensor) -> f64 {
    let d: f64 = a.data().iter().zip(b.data()).map(|(x, y)| (x - y).powi(2)).sum();
    let n: f64 = b.data().iter().map(|y| y * y).sum();
    (d / n).sqrt()
}

fn newton(scene: &Scene) -> Model {
    let mut s = scene.clone();
    s.physics.solver = SolverKind::Newton;
    Model::from_scene(&s).unwrap()
}

#[test]
fn newton_equals_converged_xpbd_on_u_obstacle() {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    let u = scene.initial_controls();
    let nm = newton(&scene);
    let (states, stats) = nm
        .simulate_newton(&u, &NewtonSettings::default())
        .unwrap();
    scene.physics.iterations = 3000;
    let xm = Model::from_scene(&scene).unwrap();
    let xs = xm.simulate(&u).unwrap();
    for t in 1..states.len() {
        let r = rel_diff(&states[t], &xs[t]);
        eprintln!("step {t}: {:?}, relative distance to XPBD-3000 {r:e}", stats[t - 1]);
    }
    let r = rel_diff(states.last().unwrap(), xs.last().unwrap());
    assert!(r < 1e-8, "final state {r:e} from XPBD at 3000 iterations");
}

#[test]
fn probe_xpbd_residual() {
    let mut scene = Scene::builtin("u_obstacle").unwrap();
    let u = scene.initial_controls();
    for iters in [100, 1000, 3000, 10000] {
        scene.physics.iterations = iters;
        let xm = Model::from_scene(&scene).unwrap();
        let xs = xm.simulate(&u).unwrap();
        let sys = cloth::newton::solve::NewtonSystem::new(&xm).unwrap();
        let xt = xm.begin_step(&xs[0], &xm.step_controls(&u, 0));
        let mut g = vec![0.0; sys.pattern.n_dof];
        sys.pattern.assemble(xt.data(), xt.data(), &mut g, None);
        let r0: f64 = g.iter().map(|v| v * v).sum::<f64>().sqrt();
        sys.pattern.assemble(xs[1].data(), xt.data(), &mut g, None);
        let r: f64 = g.iter().map(|v| v * v).sum::<f64>().sqrt();
        eprintln!("xpbd {iters}: relative ∇Φ at step 1 {:e}", r / r0);
    }
}
