//! The isometric (quadratic) bending model, [`IsometricBending`] (Bergou et al. 2006), against
//! the geometry it stands for:
//! - a flat stencil in any rigid pose has zero bending (the cotangent weights' linear precision);
//! - a flat stencil folded about its shared edge by `θ` (an isometric bend) has
//!   `Σₐ Cₐ² = (3‖e‖²/(A₀ + A₁))·(2 sin(θ/2))²`, the discrete-shells hinge energy, for every
//!   `θ` up to a crease folded flat (`θ = π`);
//! - that energy is smooth through the fold, where the dihedral angle jumps by `2π` and the
//!   distance model's two particles meet;
//! - a scene whose rest shape is not flat is refused, naming the edge.

mod common;

use cloth::constraint::{Constraint, DihedralBending, IsometricBending};
use cloth::scene::{Bending, BendingModel, Stiffness};
use cloth::{Model, Scene};
use common::XorShift;
use nalgebra::{Rotation3, Vector3};

/// A random flat stencil in the plane `z = 0`: shared edge `p₀p₁` along `x`, `p₂` below it and
/// `p₃` above it, no angle near 0 or π.
fn flat_stencil(rng: &mut XorShift) -> [Vector3<f64>; 4] {
    let length = rng.uniform(0.5, 2.0);
    [
        Vector3::zeros(),
        Vector3::new(length, 0.0, 0.0),
        Vector3::new(rng.uniform(-0.3, 1.3) * length, -rng.uniform(0.3, 1.0), 0.0),
        Vector3::new(rng.uniform(-0.3, 1.3) * length, rng.uniform(0.3, 1.0), 0.0),
    ]
}

/// `p₃` rotated by `θ` about the shared edge `p₀p₁`.
fn folded(p: &[Vector3<f64>; 4], theta: f64) -> [Vector3<f64>; 4] {
    let axis = nalgebra::Unit::new_normalize(p[1] - p[0]);
    let r = Rotation3::from_axis_angle(&axis, theta);
    [p[0], p[1], p[2], p[0] + r * (p[3] - p[0])]
}

/// `Σₐ Cₐ²` of the three instances (one per axis) of a stencil with weights `w`.
fn energy(w: [f64; 4], p: &[Vector3<f64>; 4]) -> f64 {
    let bending = IsometricBending {
        weights: vec![w; 3],
        axis: vec![0, 1, 2],
    };
    (0..3).map(|a| bending.c(a, p).powi(2)).sum()
}

/// A random rigid motion.
fn rigid(rng: &mut XorShift) -> impl Fn(&Vector3<f64>) -> Vector3<f64> {
    let axis = Vector3::new(
        rng.uniform(-1.0, 1.0),
        rng.uniform(-1.0, 1.0),
        rng.uniform(-1.0, 1.0),
    );
    let r =
        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), rng.uniform(-3.0, 3.0));
    let t = Vector3::new(
        rng.uniform(-5.0, 5.0),
        rng.uniform(-5.0, 5.0),
        rng.uniform(-5.0, 5.0),
    );
    move |p| r * p + t
}

#[test]
fn flat_stencils_have_no_bending_in_any_pose() {
    let mut rng = XorShift::new(7);
    for _ in 0..200 {
        let rest = flat_stencil(&mut rng);
        let w = IsometricBending::weights(&rest).unwrap();
        assert!(w.iter().sum::<f64>().abs() < 1e-12, "weights sum {:?}", w);
        let motion = rigid(&mut rng);
        let moved = rest.map(|p| motion(&p));
        let e = energy(w, &moved);
        assert!(e < 1e-24, "flat stencil moved rigidly: Σ C² = {e:e}");
    }
}

#[test]
fn a_folded_hinge_has_the_discrete_shells_energy_up_to_a_flat_crease() {
    let mut rng = XorShift::new(11);
    for _ in 0..100 {
        let rest = flat_stencil(&mut rng);
        let w = IsometricBending::weights(&rest).unwrap();
        let e0 = rest[1] - rest[0];
        let area =
            0.5 * (e0.cross(&(rest[2] - rest[0])).norm() + e0.cross(&(rest[3] - rest[0])).norm());
        let motion = rigid(&mut rng);
        for theta in [1e-3, 0.3, 1.0, 2.5, 3.1, std::f64::consts::PI] {
            let bent = folded(&rest, theta).map(|p| motion(&p));
            let expected = 3.0 * e0.norm_squared() / area * (2.0 * (theta / 2.0).sin()).powi(2);
            let e = energy(w, &bent);
            assert!(
                (e - expected).abs() <= 1e-10 * expected.max(1e-12),
                "θ = {theta}: Σ C² = {e}, the hinge energy {expected}"
            );
        }
    }
}

/// Folding through a flat crease (`θ` from `π − h` to `π + h`): the isometric energy changes by
/// `O(h²)` (it is even about `π`), the dihedral angle's constraint jumps by about `2π`, and the
/// distance model's pair of opposite particles passes through a point where it meets.
#[test]
fn the_energy_is_smooth_through_a_crease_folded_flat() {
    let pi = std::f64::consts::PI;
    // A square split along its diagonal: p₂ and p₃ meet when folded flat.
    let rest = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(1.0, 1.0, 0.0),
        Vector3::new(1.0, 0.0, 0.0),
        Vector3::new(0.0, 1.0, 0.0),
    ];
    let w = IsometricBending::weights(&rest).unwrap();
    let dihedral = DihedralBending { rest: vec![0.0] };
    for h in [1e-2, 1e-4, 1e-6] {
        let (before, after) = (folded(&rest, pi - h), folded(&rest, pi + h));
        let iso = (energy(w, &after) - energy(w, &before)).abs();
        assert!(
            iso < 1e-9,
            "isometric energy changed by {iso:e} across the fold (h = {h})"
        );
        let jump = (dihedral.c(0, &after) - dihedral.c(0, &before)).abs();
        assert!(
            (jump - 2.0 * pi).abs() < 4.0 * h,
            "dihedral constraint changed by {jump} across the fold (h = {h})"
        );
        // The pair (p₂, p₃) is at distance ~√2·h there: the distance model's direction
        // (p₂ − p₃)/|p₂ − p₃| is undefined at the fold.
        let gap = (before[2] - before[3]).norm();
        assert!(gap < 1.5 * h, "pair at {gap} (h = {h})");
    }
}

#[test]
fn a_scene_whose_rest_shape_is_not_flat_is_refused_naming_the_edge() {
    let mut scene = Scene::builtin("fold").unwrap();
    scene.material.bending = Some(Bending {
        model: BendingModel::Isometric,
        stiffness: Stiffness::Finite(1.0),
    });
    // The built-in fold's towel is flat: the model compiles.
    Model::from_scene(&scene).expect("a flat towel");
    // Lift one vertex of its mesh: the stencils around it are bent at rest.
    let mut bent = scene.clone();
    let mesh = bent
        .cloth
        .mesh_data
        .as_mut()
        .expect("the fold's towel is a mesh");
    mesh.vertices[100][2] += 0.05;
    let Err(err) = Model::from_scene(&bent) else {
        panic!("a bent rest shape was accepted");
    };
    let err = err.to_string();
    assert!(
        err.contains("isometric bending needs a flat rest shape") && err.contains("edge ("),
        "{err}"
    );
}
