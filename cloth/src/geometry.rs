//! Shared vector helpers: the generic norm constraints and SDFs differentiate through, and the
//! `f64` array and slice helpers scene validation, tessellation and the Newton solver use. A leaf module: it imports nothing
//! from the crate.

use autodiff::Real;
use nalgebra::Vector3;

/// `|v|` through [`Real::sqrt`], so a zero vector has gradient 0.
#[inline]
pub fn norm<R: Real>(v: &Vector3<R>) -> R {
    v.dot(v).sqrt()
}

/// `|v|` of a plain `f64` triple.
pub fn norm3(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `a · b` of two `f64` slices, summed in order.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The Euclidean norm of an `f64` slice, [`dot`] with itself.
pub fn euclidean(v: &[f64]) -> f64 {
    dot(v, v).sqrt()
}

/// `v/|v|`, computed after scaling by the largest component so that neither tiny nor huge finite
/// vectors underflow or overflow; `None` for a zero or non-finite vector.
pub fn unit(v: &[f64; 3]) -> Option<[f64; 3]> {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(m.is_finite() && m > 0.0) {
        return None;
    }
    let s = v.map(|x| x / m);
    let n = norm3(&s);
    Some(s.map(|x| x / n))
}

/// The cross product `a × b` of plain `f64` triples.
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A `Vector3<R>` of constants from an `f64` triple.
#[inline(always)]
pub fn constant<R: Real>(v: &[f64; 3]) -> Vector3<R> {
    Vector3::new(R::cst(v[0]), R::cst(v[1]), R::cst(v[2]))
}

/// Particle `i`'s position in a row of coordinates (`x[3i..3i + 3]`).
#[inline(always)]
pub fn point<R: Real>(x: &[R], i: usize) -> Vector3<R> {
    Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2])
}

/// Writes one vector per particle into a row of coordinates: `g[3i..3i + 3] = parts[i]` (the
/// inverse of [`point`]).
#[inline(always)]
pub fn write_points<R: Real, const K: usize>(g: &mut [R], parts: [Vector3<R>; K]) {
    for (i, v) in parts.iter().enumerate() {
        g[3 * i..3 * i + 3].copy_from_slice(v.as_slice());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_survives_tiny_and_huge_vectors() {
        assert_eq!(unit(&[0.0; 3]), None);
        assert_eq!(unit(&[f64::NAN, 0.0, 0.0]), None);
        let u = unit(&[3e-300, 4e-300, 0.0]).unwrap();
        assert!((u[0] - 0.6).abs() < 1e-15 && (u[1] - 0.8).abs() < 1e-15);
        let u = unit(&[3e300, 4e300, 0.0]).unwrap();
        assert!((u[0] - 0.6).abs() < 1e-15 && (u[1] - 0.8).abs() < 1e-15);
        assert_eq!(cross(&[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(norm3(&[3.0, 4.0, 0.0]), 5.0);
    }
}
