//! The built-in constraints' closed-form derivatives ([`Constraint::gradient`],
//! [`Constraint::hessian_vectors`]) against the generic dual path ([`Generic`]), which stays the
//! reference.
//!
//! Every built-in: [`Distance`], [`DihedralBending`], [`IsometricBending`], [`Collision`] with a [`SphereSet`], a
//! [`Plane`] and a [`Union`] of both, and the self-contacts `VertexTriangle` and `EdgeEdge`
//! (nearly parallel edges among them). Inputs are random, and half of them near-degenerate: nearly
//! coincident particles (offsets down to 1e-12), flat and folded (`φ ≈ 0`, `φ ≈ ±π`) dihedrals,
//! nearly collinear triangles, particles near a sphere's centre, near-ties between obstacles.
//!
//! Tolerance: `|override − generic| ≤ 1e-12·max(‖override‖∞, ‖generic‖∞)` for `∇C` and for
//! `∇²C·v` (relative to the vector, since a component may cancel to zero); `C` itself must be
//! bitwise equal (the overrides evaluate `C` by the same operations).
//!
//! At the exact kinks the overrides follow the dual path's conventions (module docs of
//! `cloth::constraint`): `kinks_follow_the_dual_conventions` checks each one.

mod common;

use cloth::constraint::{
    hessian_vector, Collision, Constraint, DihedralBending, Distance, Generic, IsometricBending,
};
use cloth::sdf::{Plane, SphereSet, Union};
use common::XorShift;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Relative tolerance of an override against the generic derivative.
const REL: f64 = 1e-12;

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// `C`, `∇C` and `∇²C·v` of one instance.
fn derivatives<C: Constraint>(c: &C, x: &[f64], v: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
    let d = 3 * C::ARITY;
    let mut g = vec![0.0; d];
    let value = c.gradient(0, x, &mut g);
    let mut hv = v.to_vec();
    hessian_vector(c, 0, x, &mut hv);
    (value, g, hv)
}

/// Checks `c`'s overrides against [`Generic`] at `x` along `v`.
fn check<C: Constraint + Clone>(c: &C, x: &[f64], v: &[f64]) -> Result<(), TestCaseError> {
    let (value, g, hv) = derivatives(c, x, v);
    let (value_ref, g_ref, hv_ref) = derivatives(&Generic(c.clone()), x, v);
    prop_assert_eq!(value.to_bits(), value_ref.to_bits(), "C at {:?}", x);
    for (what, a, b) in [("∇C", &g, &g_ref), ("∇²C·v", &hv, &hv_ref)] {
        prop_assert!(
            a.iter().all(|t| t.is_finite()),
            "{} not finite at {:?}",
            what,
            x
        );
        let tol = REL * inf_norm(a).max(inf_norm(b));
        for (j, (p, q)) in a.iter().zip(b).enumerate() {
            prop_assert!(
                (p - q).abs() <= tol,
                "{what}[{j}] at {x:?}: override {p:e} vs generic {q:e} (tol {tol:e})"
            );
        }
    }
    Ok(())
}

/// A random point in `[-2, 2]³`.
fn point(rng: &mut XorShift) -> [f64; 3] {
    [0, 1, 2].map(|_| rng.uniform(-2.0, 2.0))
}

/// A scale `10^-k`, `k` uniform in 0..=12: how close a near-degenerate input is to its kink.
fn small(rng: &mut XorShift) -> f64 {
    10f64.powi(-((rng.next_f64() * 13.0) as i32))
}

/// `p + s·(random direction)`.
fn near(p: [f64; 3], s: f64, rng: &mut XorShift) -> [f64; 3] {
    let d = point(rng);
    [p[0] + s * d[0], p[1] + s * d[1], p[2] + s * d[2]]
}

fn flat(points: &[[f64; 3]]) -> Vec<f64> {
    points.iter().flatten().copied().collect()
}

/// Four points of a bending quad: random, or near one of its degenerate configurations.
fn quad(rng: &mut XorShift) -> Vec<f64> {
    let (p0, p1) = (point(rng), point(rng));
    let e = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
    let on_edge = |t: f64| [p0[0] + t * e[0], p0[1] + t * e[1], p0[2] + t * e[2]];
    let p2 = point(rng);
    // p2 reflected through the edge's line: coplanar, on the other side (φ = 0).
    let t = {
        let a = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
        (a[0] * e[0] + a[1] * e[1] + a[2] * e[2]) / (e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    };
    let foot = on_edge(t);
    let mirror = [0, 1, 2].map(|k| 2.0 * foot[k] - p2[k]);
    let p3 = match (rng.next_f64() * 5.0) as usize {
        0 => point(rng),
        1 => near(mirror, small(rng), rng), // nearly flat
        2 => near(p2, small(rng), rng),     // nearly folded onto itself (φ ≈ ±π)
        3 => {
            // nearly collinear second triangle
            let s = small(rng);
            near(on_edge(rng.uniform(-1.0, 2.0)), s, rng)
        }
        _ => near(on_edge(rng.uniform(-1.0, 2.0)), 1e-3, rng), // slivers
    };
    flat(&[p0, p1, p2, p3])
}

fn obstacles(rng: &mut XorShift) -> SphereSet {
    SphereSet {
        centers: vec![point(rng), point(rng)],
        radii: vec![rng.uniform(0.1, 1.0), rng.uniform(0.1, 1.0)],
    }
}

fn plane(rng: &mut XorShift) -> Plane {
    let n = point(rng);
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-3);
    Plane {
        point: point(rng),
        normal: n.map(|v| v / l),
    }
}

/// A particle anywhere, or near the first sphere's centre.
fn particle(rng: &mut XorShift, spheres: &SphereSet) -> Vec<f64> {
    if rng.next_f64() < 0.5 {
        point(rng).to_vec()
    } else {
        near(spheres.centers[0], small(rng), rng).to_vec()
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn distance_matches_generic(seed in any::<u64>()) {
        let mut rng = XorShift::new(seed);
        let c = Distance { rest: vec![rng.uniform(0.0, 1.0)] };
        let p0 = point(&mut rng);
        let p1 = if rng.next_f64() < 0.5 { point(&mut rng) } else { { let s = small(&mut rng); near(p0, s, &mut rng) } };
        let x = flat(&[p0, p1]);
        check(&c, &x, &rng.direction(6))?;
        // ∇C is bitwise the dual path's (both scale by 1/|p₀ − p₁|), up to the sign of a zero:
        // where p₀ and p₁ share a coordinate the closed form negates 0 (−0) and the dual path sums
        // zeros (+0).
        let (mut g, mut g_ref) = ([0.0; 6], [0.0; 6]);
        c.gradient(0, &x, &mut g);
        Generic(c.clone()).gradient(0, &x, &mut g_ref);
        let bits = |g: [f64; 6]| g.map(|v| if v == 0.0 { 0 } else { v.to_bits() });
        prop_assert_eq!(bits(g), bits(g_ref));
    }

    #[test]
    fn dihedral_matches_generic(seed in any::<u64>()) {
        let mut rng = XorShift::new(seed);
        let c = DihedralBending { rest: vec![rng.uniform(-3.0, 3.0)] };
        check(&c, &quad(&mut rng), &rng.direction(12))?;
    }

    #[test]
    fn isometric_matches_generic(seed in any::<u64>()) {
        let mut rng = XorShift::new(seed);
        let weights: [f64; 4] = std::array::from_fn(|_| rng.uniform(-5.0, 5.0));
        for axis in 0..3 {
            let c = IsometricBending { weights: vec![weights], axis: vec![axis] };
            check(&c, &quad(&mut rng), &rng.direction(12))?;
        }
    }

    #[test]
    fn colliders_match_generic(seed in any::<u64>()) {
        let mut rng = XorShift::new(seed);
        let spheres = obstacles(&mut rng);
        let x = particle(&mut rng, &spheres);
        let v = rng.direction(3);
        let pl = plane(&mut rng);
        check(&Collision { sdf: spheres.clone() }, &x, &v)?;
        check(&Collision { sdf: pl.clone() }, &x, &v)?;
        let union = Union { spheres: vec![spheres], planes: vec![pl], ..Default::default() };
        check(&Collision { sdf: union }, &x, &v)?;
    }
}

/// The exact kinks: each override returns the dual path's convention, stated as a number.
#[test]
fn kinks_follow_the_dual_conventions() {
    let v12: Vec<f64> = (0..12).map(|k| 0.1 * k as f64 - 0.5).collect();
    // Coincident particles: C = −d⁰, ∇C = 0, ∇²C·v = 0.
    let dist = Distance { rest: vec![0.25] };
    let x = [0.3, -0.2, 1.0, 0.3, -0.2, 1.0];
    for (value, g, hv) in [
        derivatives(&dist, &x, &v12[..6]),
        derivatives(&Generic(dist.clone()), &x, &v12[..6]),
    ] {
        assert_eq!(value, -0.25);
        assert_eq!(g, vec![0.0; 6]);
        assert_eq!(hv, vec![0.0; 6]);
    }
    // A degenerate first triangle (p₂ on the edge's line): sin φ = cos φ = 0, so C = −φ⁰ and
    // both derivatives are 0.
    let bend = DihedralBending { rest: vec![0.5] };
    let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.2, 0.7, 0.1];
    for (value, g, hv) in [
        derivatives(&bend, &x, &v12),
        derivatives(&Generic(bend.clone()), &x, &v12),
    ] {
        assert_eq!(value, -0.5);
        assert_eq!(g, vec![0.0; 12]);
        assert_eq!(hv, vec![0.0; 12]);
    }
    // A flat quad (φ = 0) is smooth: ∇φ on p₂ is ±|e|/|n₁|² n₁, here (0, 0, ∓2) for unit edge
    // and height ½.
    let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.5, -0.5, 0.0];
    let (value, g, _) = derivatives(&bend, &x, &v12);
    assert_eq!(value, -0.5);
    assert!(
        (g[8].abs() - 2.0).abs() < 1e-15 && g[6] == 0.0 && g[7] == 0.0,
        "{g:?}"
    );
    // At a sphere's centre: C = −r, gradient 0, ∇²C·v = 0.
    let spheres = SphereSet {
        centers: vec![[1.0, 2.0, 3.0], [1.0, 2.0, 4.0]],
        radii: vec![0.5, 0.5],
    };
    let col = Collision {
        sdf: spheres.clone(),
    };
    for (value, g, hv) in [
        derivatives(&col, &[1.0, 2.0, 3.0], &v12[..3]),
        derivatives(&Generic(col.clone()), &[1.0, 2.0, 3.0], &v12[..3]),
    ] {
        assert_eq!(value, -0.5);
        assert_eq!(g, vec![0.0; 3]);
        assert_eq!(hv, vec![0.0; 3]);
    }
    // A tie between the two spheres (midway between centres): the first sphere's gradient,
    // (0, 0, −1), as `Real::min`.
    let tie = [1.0, 2.0, 3.5];
    for (value, g, _) in [
        derivatives(&col, &tie, &v12[..3]),
        derivatives(&Generic(col.clone()), &tie, &v12[..3]),
    ] {
        assert_eq!(value, 0.0);
        assert_eq!(g, vec![0.0, 0.0, 1.0]);
    }
    // A tie between a sphere and a plane in a union: the sphere (listed first) wins.
    let union = Collision {
        sdf: Union {
            spheres: vec![spheres],
            planes: vec![Plane {
                point: [0.0, 0.0, 0.0],
                normal: [1.0, 0.0, 0.0],
            }],
            ..Default::default()
        },
    };
    // The first sphere: |(0, 1.5, 0)| − 0.5 = 1; the plane: x = 1; the second sphere: 1.30.
    let p = [1.0, 3.5, 3.0];
    for (value, g, _) in [
        derivatives(&union, &p, &v12[..3]),
        derivatives(&Generic(union.clone()), &p, &v12[..3]),
    ] {
        assert_eq!(value, 1.0);
        assert_eq!(g, vec![0.0, 1.0, 0.0]);
    }
}

/// Two edges of self-contact: random, or nearly parallel (the edge–edge normal's kink) or nearly
/// meeting.
fn edge_pair(rng: &mut XorShift) -> Vec<f64> {
    let (p0, p1, p2) = (point(rng), point(rng), point(rng));
    let p3 = match (rng.next_f64() * 3.0) as usize {
        0 => point(rng),
        // p₂p₃ nearly parallel to p₀p₁.
        1 => near([0, 1, 2].map(|k| p2[k] + p1[k] - p0[k]), small(rng), rng),
        _ => near(p0, small(rng), rng),
    };
    flat(&[p0, p1, p2, p3])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// The self-contacts: a vertex over a triangle, and two edges' lines (either side).
    #[test]
    fn self_contacts_match_generic(seed in any::<u64>()) {
        use cloth::internals::EdgeEdge;
        use cloth::internals::VertexTriangle;
        let mut rng = XorShift::new(seed);
        let (side, h) = (if rng.next_f64() < 0.5 { 1.0 } else { -1.0 }, rng.uniform(0.0, 0.1));
        let v = rng.direction(12);
        check(&EdgeEdge { sides: vec![side], thickness: h }, &edge_pair(&mut rng), &v)?;
        check(&VertexTriangle { sides: vec![side], thickness: h }, &quad(&mut rng), &v)?;
    }
}
