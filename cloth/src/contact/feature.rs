//! Closed-form gradient and Hessian of the squared distance between a pair of nearest features
//! (two corners, a point and a line, a point and a plane, two lines) of self-contact.
//!
//! Every such distance is a minimum over an affine family: the difference of the two nearest
//! points is `r(θ) = Σᵢ cᵢ(θ) xᵢ` over the features' points `xᵢ`, with coefficients affine in at
//! most two parameters `θ` (the position along a line, the barycentric coordinates on a plane),
//! and `q(x) = min_θ |r(θ)|²`. With `θ*` the minimizer, `cᵢ = cᵢ(θ*)`, `gⱼ = ∂r/∂θⱼ` and
//! `G = [gⱼ · gₖ]`, the envelope theorem and the implicit function theorem give
//!
//! ```text
//! ∇ᵢ q = 2 cᵢ r,     ∇²ᵢₖ q = 2 (cᵢ cₖ I − Σⱼₗ Dᵢⱼ (G⁻¹)ⱼₗ Dₖₗᵀ),     Dᵢⱼ = (∂cᵢ/∂θⱼ) r + cᵢ gⱼ,
//! ```
//!
//! exact wherever `G` is invertible (a line of positive length, a triangle of positive area, two
//! lines that are not parallel: the cases the classification in [`super::distance`] picks). One
//! formula serves every kind; it costs a few dozen flops where nested forward duals on 12
//! coordinates cost thousands.

use autodiff::Real;
use nalgebra::{Matrix3, Vector3};

/// A pair of nearest features as an affine family of differences `r(θ)` between their points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Feature {
    /// How many of the pair's points the features involve (2, 3 or 4).
    len: usize,
    /// Which of the pair's four points, in order.
    points: [usize; 4],
    /// The coefficients of `r` at `θ = 0`.
    base: [f64; 4],
    /// How many parameters `θ` (0, 1 or 2).
    params: usize,
    /// `∂cᵢ/∂θⱼ`, one row per parameter.
    slopes: [[f64; 4]; 2],
}

impl Feature {
    /// Points `p` and `q`: `r = p − q`.
    pub(crate) fn point_point(p: usize, q: usize) -> Feature {
        Feature {
            len: 2,
            points: [p, q, 0, 0],
            base: [1.0, -1.0, 0.0, 0.0],
            params: 0,
            slopes: [[0.0; 4]; 2],
        }
    }

    /// Point `p` and the line through `a`, `b`: `r = p − a − t (b − a)`.
    pub(crate) fn point_line(p: usize, a: usize, b: usize) -> Feature {
        Feature {
            len: 3,
            points: [p, a, b, 0],
            base: [1.0, -1.0, 0.0, 0.0],
            params: 1,
            slopes: [[0.0, 1.0, -1.0, 0.0], [0.0; 4]],
        }
    }

    /// Point `p` and the plane through `a`, `b`, `c`: `r = p − a − u (b − a) − v (c − a)`.
    pub(crate) fn point_plane(p: usize, a: usize, b: usize, c: usize) -> Feature {
        Feature {
            len: 4,
            points: [p, a, b, c],
            base: [1.0, -1.0, 0.0, 0.0],
            params: 2,
            slopes: [[0.0, 1.0, -1.0, 0.0], [0.0, 1.0, 0.0, -1.0]],
        }
    }

    /// The line through `a₀`, `a₁` and the line through `b₀`, `b₁`:
    /// `r = a₀ + s (a₁ − a₀) − b₀ − t (b₁ − b₀)`.
    pub(crate) fn line_line(a0: usize, a1: usize, b0: usize, b1: usize) -> Feature {
        Feature {
            len: 4,
            points: [a0, a1, b0, b1],
            base: [1.0, 0.0, -1.0, 0.0],
            params: 2,
            slopes: [[-1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, -1.0]],
        }
    }

    /// Which of the pair's four points the features involve.
    pub(crate) fn involves(&self) -> [bool; 4] {
        let mut out = [false; 4];
        for &i in &self.points[..self.len] {
            out[i] = true;
        }
        out
    }

    /// The coefficients `cᵢ` (one per pair point, 0 for points not involved) and the difference
    /// `r = Σ cᵢ pᵢ` of the nearest points of the features of `p`, at the minimizer `θ*`, generic
    /// over the scalar (so that forward duals carry their derivatives along the points).
    pub(crate) fn closest<R: Real>(&self, p: &[Vector3<R>; 4]) -> ([R; 4], Vector3<R>) {
        let n = self.len;
        let combine = |c: &[f64; 4]| {
            (0..n).fold(Vector3::zeros(), |s: Vector3<R>, i| {
                s + p[self.points[i]] * R::cst(c[i])
            })
        };
        let r0 = combine(&self.base);
        let dirs = [combine(&self.slopes[0]), combine(&self.slopes[1])];
        let theta = match self.params {
            0 => [R::cst(0.0), R::cst(0.0)],
            1 => [-(dirs[0].dot(&r0) / dirs[0].dot(&dirs[0])), R::cst(0.0)],
            _ => {
                let (g00, g01, g11) = (
                    dirs[0].dot(&dirs[0]),
                    dirs[0].dot(&dirs[1]),
                    dirs[1].dot(&dirs[1]),
                );
                let cross = dirs[0].cross(&dirs[1]);
                let det = cross.dot(&cross);
                let b = [dirs[0].dot(&r0), dirs[1].dot(&r0)];
                [
                    -((g11 * b[0] - g01 * b[1]) / det),
                    -((g00 * b[1] - g01 * b[0]) / det),
                ]
            }
        };
        let mut c = [R::cst(0.0); 4];
        for i in 0..n {
            c[self.points[i]] = R::cst(self.base[i])
                + theta[0] * R::cst(self.slopes[0][i])
                + theta[1] * R::cst(self.slopes[1][i]);
        }
        (c, r0 + dirs[0] * theta[0] + dirs[1] * theta[1])
    }

    /// The squared distance `q` of the features of the pair's points `p`, with its gradient `g`
    /// (12 coordinates, the pair's points in order; zero for points not involved) and Hessian
    /// `h` (row-major 12 × 12).
    pub(crate) fn squared_derivatives(
        &self,
        p: &[Vector3<f64>; 4],
        g: &mut [f64; 12],
        h: &mut [f64; 144],
    ) -> f64 {
        let n = self.len;
        let point = |i: usize| &p[self.points[i]];
        let combine =
            |c: &[f64; 4]| (0..n).fold(Vector3::zeros(), |s: Vector3<f64>, i| s + point(i) * c[i]);
        let r0 = combine(&self.base);
        let dirs = [combine(&self.slopes[0]), combine(&self.slopes[1])];
        // The minimizer θ* of |r₀ + Σ θⱼ gⱼ|²: G θ = −[gⱼ · r₀], and G⁻¹.
        let (theta, g_inv) = match self.params {
            0 => ([0.0; 2], [[0.0; 2]; 2]),
            1 => {
                let inv = 1.0 / dirs[0].norm_squared();
                ([-dirs[0].dot(&r0) * inv, 0.0], [[inv, 0.0], [0.0, 0.0]])
            }
            _ => {
                let (g00, g01, g11) = (
                    dirs[0].norm_squared(),
                    dirs[0].dot(&dirs[1]),
                    dirs[1].norm_squared(),
                );
                // det G = |g₀ × g₁|² (Lagrange's identity), without the cancellation.
                let det = dirs[0].cross(&dirs[1]).norm_squared();
                let inv = [[g11 / det, -g01 / det], [-g01 / det, g00 / det]];
                let b = [dirs[0].dot(&r0), dirs[1].dot(&r0)];
                (
                    [
                        -(inv[0][0] * b[0] + inv[0][1] * b[1]),
                        -(inv[1][0] * b[0] + inv[1][1] * b[1]),
                    ],
                    inv,
                )
            }
        };
        let c: [f64; 4] = std::array::from_fn(|i| {
            self.base[i] + theta[0] * self.slopes[0][i] + theta[1] * self.slopes[1][i]
        });
        let r = r0 + dirs[0] * theta[0] + dirs[1] * theta[1];
        // Dᵢⱼ = (∂cᵢ/∂θⱼ) r + cᵢ gⱼ.
        let d: [[Vector3<f64>; 2]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|j| r * self.slopes[j][i] + dirs[j] * c[i])
        });
        g.fill(0.0);
        h.fill(0.0);
        for i in 0..n {
            let gi = r * (2.0 * c[i]);
            let pi = self.points[i];
            g[3 * pi..3 * pi + 3].copy_from_slice(gi.as_slice());
            for k in 0..n {
                let mut block = Matrix3::identity() * (c[i] * c[k]);
                for j in 0..self.params {
                    for l in 0..self.params {
                        block -= d[i][j] * d[k][l].transpose() * g_inv[j][l];
                    }
                }
                let pk = self.points[k];
                for a in 0..3 {
                    for b in 0..3 {
                        h[12 * (3 * pi + a) + 3 * pk + b] = 2.0 * block[(a, b)];
                    }
                }
            }
        }
        r.norm_squared()
    }
}

/// `c = |e₁ × e₂|²` of the edges `e₁ = p₁ − p₀`, `e₂ = p₃ − p₂`, with its gradient and Hessian
/// over the four points (12 coordinates, row-major 12 × 12).
pub(crate) fn cross_squared_derivatives(
    p: &[Vector3<f64>; 4],
    g: &mut [f64; 12],
    h: &mut [f64; 144],
) -> f64 {
    let (e1, e2) = (p[1] - p[0], p[3] - p[2]);
    let n = e1.cross(&e2);
    // ∇_{e₁} c = 2 e₂ × n, ∇_{e₂} c = 2 n × e₁; from c = |e₁|²|e₂|² − (e₁·e₂)²:
    // ∇²_{e₁e₁} = 2(|e₂|² I − e₂e₂ᵀ), ∇²_{e₂e₂} = 2(|e₁|² I − e₁e₁ᵀ),
    // ∇²_{e₁e₂} = 4 e₁e₂ᵀ − 2 e₂e₁ᵀ − 2 (e₁·e₂) I.
    let grad = [e2.cross(&n) * 2.0, n.cross(&e1) * 2.0];
    let i3 = Matrix3::<f64>::identity();
    let h11 = (i3 * e2.norm_squared() - e2 * e2.transpose()) * 2.0;
    let h22 = (i3 * e1.norm_squared() - e1 * e1.transpose()) * 2.0;
    let h12 = e1 * e2.transpose() * 4.0 - e2 * e1.transpose() * 2.0 - i3 * (2.0 * e1.dot(&e2));
    let hess = |a: usize, b: usize| match (a, b) {
        (0, 0) => h11,
        (1, 1) => h22,
        (0, 1) => h12,
        _ => h12.transpose(),
    };
    // Point i is −eₐ's start or +eₐ's end: (edge, sign).
    let role = |i: usize| (i / 2, if i % 2 == 0 { -1.0 } else { 1.0 });
    for i in 0..4 {
        let (ei, si) = role(i);
        g[3 * i..3 * i + 3].copy_from_slice((grad[ei] * si).as_slice());
        for k in 0..4 {
            let (ek, sk) = role(k);
            let block = hess(ei, ek) * (si * sk);
            for a in 0..3 {
                for b in 0..3 {
                    h[12 * (3 * i + a) + 3 * k + b] = block[(a, b)];
                }
            }
        }
    }
    n.norm_squared()
}

#[cfg(test)]
mod tests {
    use super::{cross_squared_derivatives, Feature};
    use crate::contact::distance::{line_line, point_line, point_plane, point_point};
    use autodiff::Dual;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    type D2 = Dual<Dual<f64, 12>, 12>;

    /// `f` of the four points with its gradient and Hessian by nested forward duals.
    fn by_duals(
        p: &[Vector3<f64>; 4],
        f: impl Fn(&[Vector3<D2>; 4]) -> D2,
    ) -> (f64, Vec<f64>, Vec<f64>) {
        let v: [Vector3<D2>; 4] = std::array::from_fn(|i| {
            Vector3::from_fn(|k, _| {
                let j = 3 * i + k;
                Dual {
                    re: Dual::variable(p[i][k], j),
                    eps: std::array::from_fn(|l| Dual::constant(if l == j { 1.0 } else { 0.0 })),
                }
            })
        });
        let r = f(&v);
        let g = (0..12).map(|a| r.re.eps[a]).collect();
        let h = (0..144).map(|k| r.eps[k / 12].eps[k % 12]).collect();
        (r.re.re, g, h)
    }

    fn close(a: &[f64], b: &[f64], what: &str) {
        let scale = b.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!((x - y).abs() <= 1e-9 * scale, "{what}[{i}]: {x} vs {y}");
        }
    }

    fn points() -> impl Strategy<Value = [Vector3<f64>; 4]> {
        prop::array::uniform4(prop::array::uniform3(-1.0..1.0f64))
            .prop_map(|a| a.map(Vector3::from))
    }

    /// A squared distance written directly, in nested duals.
    type DirectDistance = Box<dyn Fn(&[Vector3<D2>; 4]) -> D2>;

    proptest! {
        /// Each kind's closed form equals the nested-dual derivatives of its squared distance
        /// written directly (the functions `PointTriangle::distance` and `EdgeEdge::distance`
        /// evaluate).
        #[test]
        fn closed_forms_match_nested_duals(p in points()) {
            // Well-conditioned configurations only: a line of some length, a triangle of some
            // area, lines some way from parallel.
            let (e1, e2, e3) = (p[2] - p[1], p[3] - p[1], p[1] - p[0]);
            prop_assume!(e1.norm() > 0.1 && e1.cross(&e2).norm() > 0.05);
            prop_assume!(e3.cross(&(p[3] - p[2])).norm() > 0.05);
            let (mut g, mut h) = ([0.0; 12], [0.0; 144]);
            let cases: [(Feature, DirectDistance); 4] = [
                (Feature::point_point(0, 2), Box::new(|v| point_point(&v[0], &v[2]))),
                (Feature::point_line(3, 1, 2), Box::new(|v| point_line(&v[3], &v[1], &v[2]))),
                (
                    Feature::point_plane(0, 1, 2, 3),
                    Box::new(|v| point_plane(&v[0], &v[1], &v[2], &v[3])),
                ),
                (
                    Feature::line_line(0, 1, 2, 3),
                    Box::new(|v| line_line(&v[0], &v[1], &v[2], &v[3])),
                ),
            ];
            for (feature, f) in cases {
                let q = feature.squared_derivatives(&p, &mut g, &mut h);
                let (q_ref, g_ref, h_ref) = by_duals(&p, f);
                prop_assert!((q - q_ref).abs() <= 1e-12 * q_ref.max(1.0), "{feature:?}");
                close(&g, &g_ref, "gradient");
                close(&h, &h_ref, "Hessian");
            }
            let c = cross_squared_derivatives(&p, &mut g, &mut h);
            let (c_ref, g_ref, h_ref) = by_duals(&p, |v| {
                let n = (v[1] - v[0]).cross(&(v[3] - v[2]));
                n.dot(&n)
            });
            prop_assert!((c - c_ref).abs() <= 1e-12 * c_ref.max(1.0));
            close(&g, &g_ref, "cross gradient");
            close(&h, &h_ref, "cross Hessian");
        }
    }

    #[test]
    fn involved_points() {
        assert_eq!(
            Feature::point_line(3, 0, 1).involves(),
            [true, true, false, true]
        );
        assert_eq!(
            Feature::point_point(1, 2).involves(),
            [false, true, true, false]
        );
    }
}
