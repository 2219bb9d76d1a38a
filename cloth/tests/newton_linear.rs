//! Linear constraints under Newton (`Constraint::LINEAR`): their `k∇C∇Cᵀ` is summed once per
//! pattern instead of at every assembly. The Hessian and gradient assembled that way equal, to
//! round-off, those of the same constraint assembled term by term at every state.

use autodiff::Real;
use cloth::constraint::{Constraint, IsometricBending};
use cloth::internals::{HessianKind, Pattern};
use cloth::nalgebra::Vector3;
use cloth::scene::SolverKind;
use cloth::{Model, Scene};

/// Isometric bending without the claim of linearity: Newton assembles it term by term.
struct TermByTerm(IsometricBending);

impl Constraint for TermByTerm {
    const ARITY: usize = 4;
    fn c<R: Real>(&self, instance: usize, p: &[Vector3<R>]) -> R {
        self.0.c(instance, p)
    }
}

/// `u_obstacle` at 6 × 6 under Newton without bending, and its isometric bending stencils with
/// their particles (as the scene compiler builds them).
fn base() -> (Model, IsometricBending, Vec<usize>) {
    let mut scene = Scene::builtin("u_obstacle").unwrap().refined(6, 6).unwrap();
    scene.physics.solver = Some(SolverKind::Newton);
    scene.material.bending = None;
    let model = Model::from_scene(&scene).unwrap();
    let rest = |p: usize| {
        let r = model.rest_shape.row(p);
        Vector3::new(r[0], r[1], r[2])
    };
    let mut bending = IsometricBending {
        weights: Vec::new(),
        axis: Vec::new(),
    };
    let mut particles = Vec::new();
    for q in scene.mesh().dihedral_quads() {
        let w = IsometricBending::weights(&q.map(rest)).unwrap();
        for axis in 0..3 {
            bending.weights.push(w);
            bending.axis.push(axis);
            particles.extend(q);
        }
    }
    (model, bending, particles)
}

#[test]
fn a_linear_groups_hessian_summed_once_is_the_term_by_term_one() {
    let (mut linear, bending, particles) = base();
    let mut terms = linear.clone();
    let copy = IsometricBending {
        weights: bending.weights.clone(),
        axis: bending.axis.clone(),
    };
    linear
        .add_constraints("bending", bending, particles.clone(), 3.0)
        .unwrap();
    terms
        .add_constraints("bending", TermByTerm(copy), particles, 3.0)
        .unwrap();
    let (a, b) = (Pattern::new(&linear), Pattern::new(&terms));
    assert_eq!((a.nnz(), a.n_dof), (b.nnz(), b.n_dof));
    // A bent, stretched state and a predicted state beside it.
    let x: Vec<f64> = (linear.start.data().iter().enumerate())
        .map(|(i, v)| v + 0.05 * ((i as f64) * 0.37).sin())
        .collect();
    let xt: Vec<f64> = x.iter().map(|v| v - 0.01).collect();
    for kind in [HessianKind::Exact, HessianKind::Projected] {
        let (mut ga, mut gb) = (vec![0.0; a.n_dof], vec![0.0; b.n_dof]);
        let (mut va, mut vb) = (vec![0.0; a.nnz()], vec![0.0; b.nnz()]);
        a.assemble(&x, &xt, &mut ga, Some((&mut va, kind)));
        b.assemble(&x, &xt, &mut gb, Some((&mut vb, kind)));
        let scale = vb.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = va
            .iter()
            .zip(&vb)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-14 * scale, "{kind:?}: {worst:e} of {scale:e}");
        assert!(ga
            .iter()
            .zip(&gb)
            .all(|(p, q)| (p - q).abs() <= 1e-13 * (1.0 + q.abs())));
        // The bending group is there: without it the Hessian differs.
        let plain = Pattern::new(&base().0);
        let mut vp = vec![0.0; plain.nnz()];
        let mut gp = vec![0.0; plain.n_dof];
        plain.assemble(&x, &xt, &mut gp, Some((&mut vp, kind)));
        assert!(vp.iter().sum::<f64>() < va.iter().sum::<f64>() - 1.0);
    }
}
