//! The surface minimum (`cloth::sdf::surface::surface_minimum`) against dense sampling: over
//! random triangles moving between random states near spheres, capsules, boxes and a mesh, its
//! lower bound is below every sampled point of the swept (or resting) surface, and the value it
//! found is within the tolerance of the samples' smallest wherever that is below the cap.

use autodiff::Tensor;
use cloth::nalgebra::Vector3;
use cloth::sdf::surface::surface_minimum;
use cloth::sdf::{Capsule, Cuboid, MeshSdf, SignedDistance, SphereSet, Union};
use proptest::prelude::*;

fn field(kind: usize) -> Union {
    match kind % 4 {
        0 => Union {
            spheres: vec![SphereSet {
                centers: vec![[0.1, -0.2, 0.0], [-0.3, 0.2, 0.1]],
                radii: vec![0.25, 0.15],
            }],
            ..Union::default()
        },
        1 => Union {
            capsules: vec![Capsule {
                a: [0.0, 0.0, -1.0],
                b: [0.1, 0.05, 1.0],
                radius: 0.05,
            }],
            ..Union::default()
        },
        2 => Union {
            boxes: vec![Cuboid::new([0.0, 0.1, 0.0], [0.3, 0.2, 0.1], None)],
            ..Union::default()
        },
        _ => {
            let (v, t) = Capsule {
                a: [0.0, 0.0, -0.3],
                b: [0.1, 0.1, 0.3],
                radius: 0.2,
            }
            .surface_triangles();
            Union {
                meshes: vec![MeshSdf::new(v, t)],
                ..Union::default()
            }
        }
    }
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    [-0.8..0.8f64, -0.8..0.8f64, -0.8..0.8f64]
}

/// The patch's point at parameters `(t, u, w)` (the module's parametrization).
fn at(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3], t: f64, u: f64, w: f64) -> Vector3<f64> {
    let y = |p: &[[f64; 3]; 3]| {
        let [p0, p1, p2] = p.map(Vector3::from);
        p0 + (p1 - p0) * u + (p2 - p1) * (u * w)
    };
    y(a) * (1.0 - t) + y(b) * t
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn the_bound_is_below_every_sample_and_the_value_near_their_minimum(
        kind in 0usize..4,
        a in [point(), point(), point()],
        b in [point(), point(), point()],
        swept in any::<bool>(),
    ) {
        let field = field(kind);
        let states = [Tensor::from_rows(&a), Tensor::from_rows(&b)];
        let (cap, tol) = (0.3, 1e-3);
        let m = surface_minimum(&field, &[[0, 1, 2]], &states, (swept, false), cap, tol).unwrap();
        let start = if swept { a } else { b };
        let n = 24;
        let mut smallest = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n {
                for k in 0..=n {
                    let (t, u, w) = (i as f64 / n as f64, j as f64 / n as f64, k as f64 / n as f64);
                    smallest = smallest.min(field.distance(&at(&start, &b, t, u, w)));
                }
            }
        }
        prop_assert!(m.lower <= smallest + 1e-12, "{m:?} above the sample {smallest}");
        prop_assert!(m.lower <= m.value);
        if smallest < cap - tol {
            prop_assert!(m.value <= smallest + tol, "{m:?} misses the sample {smallest}");
        } else {
            prop_assert!(m.lower >= cap - tol - 1e-12 || m.value < cap, "{m:?}");
        }
    }
}
