//! Signed distances along straight segments: the closed forms for capsules and boxes against an
//! independent branch and bound and dense sampling; a mesh's minimum never above the true one,
//! exact for a path outside it, found where 65 samples miss a thin obstacle; sphere sets
//! unchanged bit for bit; and the gradient of each primitive's segment minimum (what the
//! continuous safety and gripper rows differentiate) against central differences.

use cloth::nalgebra::Vector3;
use cloth::sdf::{
    lipschitz_segment_min, Capsule, Cuboid, MeshSdf, Plane, SegmentMin, SignedDistance, SphereSet,
    Union, SEGMENT_TOLERANCE,
};
use proptest::prelude::*;

fn vec3(r: f64) -> impl Strategy<Value = Vector3<f64>> {
    [-r..r, -r..r, -r..r].prop_map(|[x, y, z]| Vector3::new(x, y, z))
}

fn quaternion() -> impl Strategy<Value = [f64; 4]> {
    [0.2..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64]
}

/// The smallest of `n + 1` evenly spaced samples of `f` along `a → b`.
fn sampled(f: &impl SignedDistance, a: &Vector3<f64>, b: &Vector3<f64>, n: usize) -> f64 {
    (0..=n)
        .map(|k| f.distance(&(a + (b - a) * (k as f64 / n as f64))))
        .fold(f64::INFINITY, f64::min)
}

/// An exact answer: its value is the distance at its point, no dense sample is below it, and the
/// independent branch and bound (tolerance 1e-10) brackets it.
fn check_exact(
    f: &impl SignedDistance,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    what: &str,
) -> Result<(), TestCaseError> {
    let m = f.segment_min(a, b);
    prop_assert!((0.0..=1.0).contains(&m.at), "{}: at {}", what, m.at);
    prop_assert_eq!(m.value, m.attained);
    let there = f.distance(&(a + (b - a) * m.at));
    prop_assert!(
        (m.value - there).abs() <= 1e-15 * (1.0 + there.abs()),
        "{}: {} vs {}",
        what,
        m.value,
        there
    );
    let dense = sampled(f, a, b, 2000);
    prop_assert!(
        m.value <= dense + 1e-12,
        "{}: {} above a sample {}",
        what,
        m.value,
        dense
    );
    let searched = lipschitz_segment_min(|p| f.distance(p), a, b, 1e-10);
    prop_assert!(
        searched.value <= m.value + 1e-12 && m.value <= searched.attained + 1e-12,
        "{}: exact {} outside the search's bracket [{}, {}]",
        what,
        m.value,
        searched.value,
        searched.attained
    );
    prop_assert_eq!(f.min_along_segment(a, b), m.value);
    Ok(())
}

/// A small closed mesh: a box's surface, thin along y.
fn thin_slab() -> MeshSdf {
    let (v, t) = Cuboid::new([0.0, 0.0, 0.0], [0.5, 0.004, 0.5], None).surface_triangles();
    MeshSdf::new(v, t)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn capsule_segment_minima_are_exact(a in vec3(1.5), b in vec3(1.5), p in vec3(1.0),
                                        q in vec3(1.0), radius in 0.05..0.5f64) {
        let capsule = Capsule { a: p.into(), b: q.into(), radius };
        check_exact(&capsule, &a, &b, "capsule")?;
        // A segment along the axis (parallel) and a point segment.
        check_exact(&capsule, &(p + Vector3::new(0.0, 0.0, 0.7)), &(q + Vector3::new(0.0, 0.0, 0.7)), "parallel")?;
        check_exact(&capsule, &a, &a, "point")?;
    }

    #[test]
    fn box_segment_minima_are_exact(a in vec3(1.5), b in vec3(1.5), c in vec3(0.5),
                                    h in [0.05..0.6f64, 0.05..0.6, 0.05..0.6], rot in quaternion()) {
        let cuboid = Cuboid::new(c.into(), h, Some(rot));
        check_exact(&cuboid, &a, &b, "box")?;
        check_exact(&cuboid, &a, &a, "point")?;
        // Straight through the centre: the minimum is inside, at the centre's depth.
        check_exact(&cuboid, &(c - (b - a)), &(c + (b - a)), "through")?;
    }

    #[test]
    fn sphere_and_plane_minima_are_the_closed_forms(a in vec3(1.5), b in vec3(1.5), c in vec3(1.0),
                                                    r in 0.05..0.5f64, n in vec3(1.0)) {
        let set = SphereSet { centers: vec![c.into(), (c * 0.5).into()], radii: vec![r, 0.5 * r] };
        let m = set.segment_min(&a, &b);
        // Bitwise the metric's closed form (`min_SDF_swept` of every sphere scene).
        prop_assert_eq!(m.value.to_bits(), set.min_along_segment(&a, &b).to_bits());
        check_exact(&set, &a, &b, "spheres")?;
        prop_assume!(n.norm() > 0.1);
        let plane = Plane { point: c.into(), normal: n.normalize().into() };
        check_exact(&plane, &a, &b, "plane")?;
    }

    #[test]
    fn mesh_minima_are_lower_bounds_within_the_tolerance(a in vec3(1.2), b in vec3(1.2)) {
        let (v, t) = Capsule { a: [0.0, 0.0, -0.5], b: [0.2, 0.1, 0.5], radius: 0.4 }.surface_triangles();
        let mesh = MeshSdf::new(v, t);
        let m = mesh.segment_min(&a, &b);
        let dense = sampled(&mesh, &a, &b, 4096);
        // Never above the true minimum: below every sample, and the samples' Lipschitz floor
        // (the true minimum is at least the dense minimum less half a sample spacing) within
        // the tolerance.
        prop_assert!(m.value <= dense + 1e-12, "{} above a sample {}", m.value, dense);
        prop_assert_eq!(m.attained, mesh.distance(&(a + (b - a) * m.at)));
        prop_assert!(m.gap() >= 0.0, "gap {}", m.gap());
        if m.value > 0.0 {
            // A path outside the mesh: exact to rounding (the BVH's segment search), so it is
            // also at least the samples' Lipschitz floor (the true minimum is at least the
            // dense minimum less half a sample spacing).
            let floor = dense - 0.5 * (b - a).norm() / 4096.0;
            prop_assert!(m.value >= floor - 1e-12, "{} below {}", m.value, floor);
            prop_assert!(m.gap() <= 1e-12, "gap {}", m.gap());
        }
    }

    /// Each primitive's segment minimum, as the rows see it, has the gradient central
    /// differences of the exact minimum measure (spheres, capsules, boxes outside and, for a
    /// path that enters one, minus its crossing depth; planes at `b`).
    #[test]
    fn segment_component_gradients_match_central_differences(
        a in vec3(1.5), d in vec3(0.8), c in vec3(0.4), p in vec3(0.6),
        h in [0.1..0.5f64, 0.1..0.5, 0.1..0.5], rot in quaternion(), dir in [vec3(1.0), vec3(1.0)],
    ) {
        // A path of zero length is a kink of its minimum (moving one end toward an obstacle
        // lowers it, away does not); the rows never see one but as a single point.
        prop_assume!(d.norm() > 0.05);
        let b = a + d;
        // Generic orientations: a path parallel to a box face or to a capsule's axis, where the
        // minimum is flat, is a kink of it (the smaller of its two ends).
        let tilt = [0.9, 0.3, -0.2, 0.25];
        let turn = [
            rot[0] * tilt[0] - rot[1] * tilt[1] - rot[2] * tilt[2] - rot[3] * tilt[3],
            rot[0] * tilt[1] + rot[1] * tilt[0] + rot[2] * tilt[3] - rot[3] * tilt[2],
            rot[0] * tilt[2] - rot[1] * tilt[3] + rot[2] * tilt[0] + rot[3] * tilt[1],
            rot[0] * tilt[3] + rot[1] * tilt[2] - rot[2] * tilt[1] + rot[3] * tilt[0],
        ];
        let axis = Vector3::new(0.31, 0.17, 0.23);
        let field = Union {
            spheres: vec![SphereSet { centers: vec![c.into()], radii: vec![0.3] }],
            planes: vec![Plane { point: [0.0, 0.0, -1.0], normal: [0.0, 0.6, 0.8] }],
            capsules: vec![Capsule { a: (p + axis).into(), b: (-p - axis).into(), radius: 0.2 }],
            boxes: vec![Cuboid::new((c * -1.0).into(), h, Some(turn))],
            ..Default::default()
        };
        let exact = |a: &Vector3<f64>, b: &Vector3<f64>| -> Vec<f64> {
            vec![
                field.spheres[0].min_along_segment(a, b),
                field.planes[0].distance(b),
                field.capsules[0].min_along_segment(a, b),
                // A box the path enters counts minus its crossing depth.
                match field.boxes[0].min_along_segment(a, b) {
                    m if m < 0.0 => -field.boxes[0].crossing_depth(a, b).unwrap_or(-m),
                    m => m,
                },
            ]
        };
        let with = field.segment_components_with_gradients(&a, &b);
        let values: Vec<f64> = with.iter().map(|(v, _)| *v).collect();
        let reference = exact(&a, &b);
        for (k, (v, e)) in values.iter().zip(&reference).enumerate() {
            prop_assert!((v - e).abs() <= 1e-12 * (1.0 + e.abs()), "component {}: {} vs {}", k, v, e);
        }
        let step = 1e-6;
        let (da, db) = (dir[0], dir[1]);
        let plus = exact(&(a + da * step), &(b + db * step));
        let minus = exact(&(a - da * step), &(b - db * step));
        for (k, (_, g)) in with.iter().enumerate() {
            let analytic: f64 = (0..3).map(|j| g[j] * da[j] + g[3 + j] * db[j]).sum();
            let fd = (plus[k] - minus[k]) / (2.0 * step);
            prop_assert!(
                (analytic - fd).abs() <= 1e-6 * (1.0 + analytic.abs()),
                "component {}: analytic {} vs central difference {}", k, analytic, fd
            );
        }
    }
}

#[test]
fn a_thin_mesh_between_samples_is_found() {
    // A 0.008-thick slab and a 2.03 m path through it: the 65 samples of the old default are
    // 0.032 m apart, at y = −0.017 and 0.015 on either side of the slab, so they never see it.
    let slab = thin_slab();
    let (a, b) = (Vector3::new(0.0, -1.0, 0.0), Vector3::new(0.0, 1.03, 0.0));
    let old = (0..=64)
        .map(|k| slab.distance(&(a + (b - a) * (k as f64 / 64.0))))
        .fold(f64::INFINITY, f64::min);
    assert!(old > 0.0, "the samples miss the slab: {old}");
    let m: SegmentMin = slab.segment_min(&a, &b);
    // The path crosses the slab's middle, 0.004 deep.
    assert!(
        (m.value + 0.004).abs() <= SEGMENT_TOLERANCE + 1e-12,
        "{m:?}"
    );
    assert!(m.value <= -0.004 + 1e-12, "a lower bound: {m:?}");
    assert!(slab.min_along_segment_within(&a, &b, 0.0) < 0.0);
}

#[test]
fn a_path_crossing_a_thin_box_or_capsule_between_samples_is_found() {
    let plate = Cuboid::new([0.0, 0.0, 0.0], [0.5, 0.004, 0.5], None);
    let pole = Capsule {
        a: [0.0, 0.0, -1.0],
        b: [0.0, 0.0, 1.0],
        radius: 0.004,
    };
    let (a, b) = (Vector3::new(0.0, -1.0, 0.0), Vector3::new(0.0, 1.03, 0.0));
    assert!(sampled(&plate, &a, &b, 64) > 0.0 && sampled(&pole, &a, &b, 64) > 0.0);
    // Exact: the path crosses both at their middle, 0.004 deep.
    assert!((plate.min_along_segment(&a, &b) + 0.004).abs() < 1e-15);
    assert!((pole.min_along_segment(&a, &b) + 0.004).abs() < 1e-15);
}
