//! The frictional contact's closed-form adjoint (`RowFn::vjp` of `FrictionalContact`) against its
//! reference, the engine's dual-derived VJP of the same row (`autodiff::vjp_by_duals`), and
//! against central differences of the row: on every collider kind (a tilted plane, two spheres, a
//! capsule, a rotated box, a tessellated sphere as a mesh) alone and together, in every regime
//! (free, sticking, sliding; with and without a contact projection this iteration).

use autodiff::{vjp_by_duals, RowFn};
use cloth::internals::{FrictionalContact, Regime, CARRY_WIDTH};
use cloth::scene::{
    BoxSpec, CapsuleSpec, MeshSpec, Obstacle, ObstacleRole, PlaneSpec, SphereSetSpec,
};
use cloth::sdf::{sphere_surface, MeshSdf};
use proptest::prelude::*;
use proptest::strategy::ValueTree;

const W: usize = 3 + CARRY_WIDTH;

/// The colliders, each with its friction coefficient; all of them near the origin, so a point in
/// `[-0.6, 0.6]³` is near some surface.
fn colliders() -> Vec<Obstacle> {
    let role = ObstacleRole::Collider;
    let (vertices, triangles) = sphere_surface([0.3, -0.3, 0.0], 0.25);
    vec![
        Obstacle::Plane(PlaneSpec {
            point: [0.0, 0.0, -0.2],
            normal: [0.3, -0.2, 1.0],
            role,
            friction: Some(0.4),
        }),
        Obstacle::Spheres(SphereSetSpec {
            centers: vec![[-0.3, 0.2, 0.1], [0.2, 0.3, 0.0]],
            radii: vec![0.2, 0.15],
            role,
            friction: Some(0.8),
        }),
        Obstacle::Capsule(CapsuleSpec {
            a: [-0.4, -0.3, 0.0],
            b: [0.0, -0.2, 0.3],
            radius: 0.1,
            role,
            friction: Some(0.3),
        }),
        Obstacle::Box(BoxSpec {
            center: [0.0, 0.0, 0.2],
            half_extents: [0.15, 0.1, 0.05],
            rotation: Some([0.9, 0.2, -0.3, 0.1]),
            role,
            friction: Some(0.6),
        }),
        Obstacle::Mesh(MeshSpec {
            file: "sphere.obj".into(),
            role,
            friction: Some(0.5),
            surface: Some(MeshSdf::new(vertices, triangles)),
        }),
    ]
}

/// The frictional contact of collider `which` (0–4), or of all of them (5).
fn contact(which: usize) -> FrictionalContact {
    let all = colliders();
    let chosen = if which < all.len() {
        vec![all[which].clone()]
    } else {
        all
    };
    FrictionalContact::from_obstacles(&chosen).expect("friction > 0")
}

/// A row: position, start position, `D`, `Λ`.
fn row_input() -> impl Strategy<Value = [f64; W]> {
    (
        prop::array::uniform3(-0.6..0.6f64),
        // Small moves (mostly sticking) and large ones (mostly sliding).
        prop_oneof![
            prop::array::uniform3(-0.003..0.003f64),
            prop::array::uniform3(-0.08..0.08f64)
        ],
        prop_oneof![Just(0.0), 0.0..0.05f64],
        prop::array::uniform3(-0.003..0.003f64),
    )
        .prop_map(|(p, moved, depth, lambda)| {
            let mut x = [0.0; W];
            x[..3].copy_from_slice(&p);
            for k in 0..3 {
                x[3 + k] = p[k] - moved[k];
            }
            x[6] = depth;
            x[7..].copy_from_slice(&lambda);
            x
        })
}

/// `Jᵀa` by the closed form and by duals.
fn both(f: &FrictionalContact, x: &[f64; W], a: &[f64; W]) -> ([f64; W], [f64; W]) {
    let (mut closed, mut duals) = ([0.0; W], [0.0; W]);
    RowFn::vjp(f, 0, x, a, &mut closed);
    vjp_by_duals(f, 0, x, a, &mut duals);
    (closed, duals)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// The closed form agrees with the dual path to rounding, in every regime.
    #[test]
    fn closed_form_adjoint_matches_the_dual_path(
        which in 0usize..6, x in row_input(), a in prop::array::uniform10(-1.0..1.0f64),
    ) {
        let f = contact(which);
        let (closed, duals) = both(&f, &x, &a);
        let scale = duals.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for k in 0..W {
            prop_assert!(
                (closed[k] - duals[k]).abs() <= 1e-12 * scale,
                "entry {k}: closed {} duals {} ({:?})", closed[k], duals[k], f.regime(&x)
            );
        }
    }

    /// And with central differences of the row, where the regime is the same at `x ± 2h` (away
    /// from the switches).
    #[test]
    fn closed_form_adjoint_matches_central_differences(
        which in 0usize..6, x in row_input(), a in prop::array::uniform10(-1.0..1.0f64),
        d in prop::array::uniform10(-1.0..1.0f64),
    ) {
        let f = contact(which);
        let h = 1e-7;
        let at = |s: f64| {
            let y: [f64; W] = std::array::from_fn(|k| x[k] + s * d[k]);
            let mut out = [0.0; W];
            f.eval(0, &y, &mut out);
            (out, f.regime(&y), contact_now(&f, &y))
        };
        let (_, regime, touch) = at(0.0);
        for s in [-2.0 * h, 2.0 * h] {
            let (_, r, t) = at(s);
            prop_assume!(r == regime && t == touch);
        }
        let (plus, minus) = (at(h).0, at(-h).0);
        let fd: f64 = (0..W).map(|k| a[k] * (plus[k] - minus[k]) / (2.0 * h)).sum();
        let (closed, _) = both(&f, &x, &a);
        let ad: f64 = (0..W).map(|k| closed[k] * d[k]).sum();
        prop_assert!((fd - ad).abs() <= 1e-6 * (1.0 + ad.abs()), "AD {ad}, FD {fd} ({regime:?})");
    }

    /// Several seeds at once give each seed's adjoint, bit for bit.
    #[test]
    fn seeds_share_one_linearization_bitwise(
        which in 0usize..6, x in row_input(),
        a in prop::collection::vec(-1.0..1.0f64, 3 * W),
    ) {
        let f = contact(which);
        let mut together = vec![0.0; 3 * W];
        RowFn::vjp_seeds(&f, 0, &x, &a, &mut together);
        for s in 0..3 {
            let mut one = [0.0; W];
            RowFn::vjp(&f, 0, &x, &a[s * W..(s + 1) * W], &mut one);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&together[s * W..(s + 1) * W]), bits(&one));
        }
    }
}

/// Whether the row's contact projects (its nearest field's distance is negative): the other
/// switch, besides the regime, where the row is not differentiable.
fn contact_now(f: &FrictionalContact, x: &[f64]) -> bool {
    let mut out = [0.0; W];
    f.eval(0, x, &mut out);
    out[6] != x[6]
}

/// The random rows above reach every regime, with and without a contact this iteration, on every
/// collider (so the proptests above test each branch of the adjoint).
#[test]
fn the_sampled_rows_cover_every_branch() {
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let strategy = row_input();
    for which in 0..6 {
        let f = contact(which);
        let mut seen = Vec::new();
        for _ in 0..2000 {
            let x = strategy.new_tree(&mut runner).unwrap().current();
            let branch = (f.regime(&x), contact_now(&f, &x));
            if !seen.contains(&branch) {
                seen.push(branch);
            }
        }
        for want in [
            (Regime::Free, false),
            (Regime::Sticking, false),
            (Regime::Sticking, true),
            (Regime::Sliding, false),
            (Regime::Sliding, true),
        ] {
            assert!(
                seen.contains(&want),
                "collider {which}: {want:?} never sampled ({seen:?})"
            );
        }
    }
}
