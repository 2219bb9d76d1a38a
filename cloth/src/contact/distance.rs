//! Unsigned distances between the cloth's primitives for smooth self-contact: a vertex and a
//! triangle, and two edges, after IPC (Li et al. 2020, §4 and its supplement).
//!
//! Each distance is piecewise: which feature pair is nearest (the vertex and the triangle's face,
//! one of its edges or one of its corners; the two edges' interiors, an end of one and the other,
//! or two ends) is classified in `f64` ([`PointTriangle::classify`], [`EdgeEdge::classify`]), and
//! the squared distance of that feature pair is written once (`point_point`, `point_line`,
//! `point_plane`; generic, so that tests check [`super::feature`]'s closed-form gradient and
//! Hessian against nested duals). Across a boundary between two kinds the squared
//! distance and its gradient agree (it is C¹); only its curvature jumps. The `f64` distances
//! ([`PointTriangle::distance`], [`EdgeEdge::distance`]) are the same functions' values.

use crate::sdf::closest_between_segments_within;
use autodiff::Real;
use nalgebra::Vector3;

/// Which features of a vertex–triangle pair are nearest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PointTriangle {
    /// The triangle's interior: the distance to its plane.
    Face,
    /// The edge between the triangle's corners `i` and `j` (0, 1, 2): the distance to its line.
    Edge(u8, u8),
    /// The triangle's corner `i`.
    Corner(u8),
}

/// Which features of an edge–edge pair are nearest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeEdge {
    /// Both interiors: the distance between the two lines.
    Lines,
    /// End `i` (0 or 1) of the first edge and the second edge's line.
    FirstEnd(u8),
    /// End `j` (0 or 1) of the second edge and the first edge's line.
    SecondEnd(u8),
    /// End `i` of the first edge and end `j` of the second.
    Ends(u8, u8),
}

/// `|p − q|²`.
#[inline]
pub(crate) fn point_point<R: Real>(p: &Vector3<R>, q: &Vector3<R>) -> R {
    let d = p - q;
    d.dot(&d)
}

/// Squared distance from `p` to the line through `a` and `b`: `|(a − p) × (b − p)|² / |b − a|²`.
#[inline]
pub(crate) fn point_line<R: Real>(p: &Vector3<R>, a: &Vector3<R>, b: &Vector3<R>) -> R {
    let c = (a - p).cross(&(b - p));
    let e = b - a;
    c.dot(&c) / e.dot(&e)
}

/// Squared distance from `p` to the plane through `a`, `b`, `c`.
#[inline]
pub(crate) fn point_plane<R: Real>(
    p: &Vector3<R>,
    a: &Vector3<R>,
    b: &Vector3<R>,
    c: &Vector3<R>,
) -> R {
    let n = (b - a).cross(&(c - a));
    let h = (p - a).dot(&n);
    h * h / n.dot(&n)
}

/// Squared distance between the line through `a₀`, `a₁` and the line through `b₀`, `b₁` (the
/// segments' distance itself comes from their nearest points, better conditioned when nearly
/// parallel; this form is the reference for [`super::feature`]'s closed form).
#[cfg(test)]
pub(crate) fn line_line<R: Real>(
    a0: &Vector3<R>,
    a1: &Vector3<R>,
    b0: &Vector3<R>,
    b1: &Vector3<R>,
) -> R {
    let n = (a1 - a0).cross(&(b1 - b0));
    let h = (b0 - a0).dot(&n);
    h * h / n.dot(&n)
}

impl PointTriangle {
    /// The nearest features of `p` and the triangle `t` (Ericson, "Real-Time Collision
    /// Detection" §5.1.5: the Voronoi region of the triangle the point projects into).
    pub fn classify(p: &Vector3<f64>, t: [&Vector3<f64>; 3]) -> PointTriangle {
        let [a, b, c] = t;
        let (ab, ac, ap) = (b - a, c - a, p - a);
        let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return PointTriangle::Corner(0);
        }
        let bp = p - b;
        let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
        if d3 >= 0.0 && d4 <= d3 {
            return PointTriangle::Corner(1);
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return PointTriangle::Edge(0, 1);
        }
        let cp = p - c;
        let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
        if d6 >= 0.0 && d5 <= d6 {
            return PointTriangle::Corner(2);
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return PointTriangle::Edge(0, 2);
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            return PointTriangle::Edge(1, 2);
        }
        PointTriangle::Face
    }

    /// The squared distance of the classified features of `p` and the triangle `t`.
    #[inline]
    pub fn squared<R: Real>(self, p: &Vector3<R>, t: [&Vector3<R>; 3]) -> R {
        match self {
            PointTriangle::Face => point_plane(p, t[0], t[1], t[2]),
            PointTriangle::Edge(i, j) => point_line(p, t[i as usize], t[j as usize]),
            PointTriangle::Corner(i) => point_point(p, t[i as usize]),
        }
    }

    /// The distance from `p` to the triangle `t` (`f64`).
    pub fn distance(p: &Vector3<f64>, t: [&Vector3<f64>; 3]) -> f64 {
        Self::classify(p, t).squared(p, t).max(0.0).sqrt()
    }
}

impl EdgeEdge {
    /// The nearest features of the segments `a₀a₁` and `b₀b₁` (Ericson §5.1.9, with parallel
    /// segments falling to an end: their lines' distance has no unique nearest pair).
    pub fn classify(a: [&Vector3<f64>; 2], b: [&Vector3<f64>; 2]) -> EdgeEdge {
        let (s, t) = closest_parameters(a, b);
        let end = |v: f64| -> Option<u8> {
            if v <= 0.0 {
                Some(0)
            } else if v >= 1.0 {
                Some(1)
            } else {
                None
            }
        };
        match (end(s), end(t)) {
            (None, None) => EdgeEdge::Lines,
            (Some(i), None) => EdgeEdge::FirstEnd(i),
            (None, Some(j)) => EdgeEdge::SecondEnd(j),
            (Some(i), Some(j)) => EdgeEdge::Ends(i, j),
        }
    }

    /// The distance between the segments `a₀a₁` and `b₀b₁` (`f64`), from their nearest points
    /// (well conditioned for nearly parallel segments too).
    pub fn distance(a: [&Vector3<f64>; 2], b: [&Vector3<f64>; 2]) -> f64 {
        let (s, t) = closest_parameters(a, b);
        let p = a[0] + (a[1] - a[0]) * s;
        let q = b[0] + (b[1] - b[0]) * t;
        (p - q).norm()
    }
}

/// The parameters `(s, t) ∈ [0, 1]²` of the nearest points `a₀ + s(a₁ − a₀)` and
/// `b₀ + t(b₁ − b₀)` of two segments; nearly parallel ones (`sin²` of their angle at most 1e-14,
/// where the lines' nearest points are ill-conditioned) fall to an end of the first.
fn closest_parameters(a: [&Vector3<f64>; 2], b: [&Vector3<f64>; 2]) -> (f64, f64) {
    closest_between_segments_within(a[0], a[1], b[0], b[1], 1e-14)
}

#[cfg(test)]
mod tests {
    use super::{EdgeEdge, PointTriangle};
    use nalgebra::Vector3;

    /// The distance from `p` to the triangle by dense sampling of the triangle (an upper bound
    /// within the sampling's resolution).
    fn sampled_point_triangle(p: &Vector3<f64>, t: [&Vector3<f64>; 3]) -> f64 {
        let n = 400;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let q = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                best = best.min((p - q).norm());
            }
        }
        best
    }

    fn sampled_segments(a: [&Vector3<f64>; 2], b: [&Vector3<f64>; 2]) -> f64 {
        let n = 2000;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            let q = a[0] + (a[1] - a[0]) * (i as f64 / n as f64);
            // The nearest point of the second segment to q, exactly.
            let e = b[1] - b[0];
            let t = ((q - b[0]).dot(&e) / e.dot(&e)).clamp(0.0, 1.0);
            best = best.min((q - (b[0] + e * t)).norm());
        }
        best
    }

    #[test]
    fn point_triangle_distance_matches_sampling_in_every_region() {
        let t = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.2, 0.9, 0.1),
        ];
        let tri = [&t[0], &t[1], &t[2]];
        let mut kinds = std::collections::HashSet::new();
        for p in [
            [0.3, 0.3, 0.5],
            [-0.5, -0.5, 0.2],
            [1.5, -0.2, 0.1],
            [0.2, 1.5, 0.3],
            [0.5, -0.6, 0.2],
            [-0.6, 0.5, -0.3],
            [0.9, 0.8, 0.4],
        ] {
            let p = Vector3::from(p);
            kinds.insert(PointTriangle::classify(&p, tri));
            let d = PointTriangle::distance(&p, tri);
            let s = sampled_point_triangle(&p, tri);
            assert!(d <= s + 1e-12 && s - d < 3e-3, "{p:?}: {d} vs sampled {s}");
        }
        assert_eq!(kinds.len(), 7, "every region visited: {kinds:?}");
    }

    #[test]
    fn edge_edge_distance_matches_sampling_for_every_kind() {
        let cases = [
            // crossing interiors
            (
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                [[0.5, -0.5, 0.3], [0.5, 0.5, 0.3]],
            ),
            // an end of the first over the second's interior
            (
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                [[1.2, -0.5, 0.3], [1.2, 0.5, 0.3]],
            ),
            // an end of the second over the first's interior
            (
                [[0.5, -0.5, 0.3], [0.5, 0.5, 0.3]],
                [[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]],
            ),
            // two ends
            (
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                [[1.3, 0.2, 0.1], [2.0, 1.0, 0.0]],
            ),
            // parallel
            (
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                [[0.4, 0.1, 0.2], [1.4, 0.1, 0.2]],
            ),
        ];
        for (a, b) in cases {
            let (a, b) = (a.map(Vector3::from), b.map(Vector3::from));
            let (a, b) = ([&a[0], &a[1]], [&b[0], &b[1]]);
            let d = EdgeEdge::distance(a, b);
            let s = sampled_segments(a, b);
            assert!(
                (d - s).abs() < 1e-6,
                "{a:?} {b:?}: {d} vs sampled {s} ({:?})",
                EdgeEdge::classify(a, b)
            );
        }
    }
}
