//! Normalized coverage, the cloth benchmarks' measure of how spread out a cloth lies (SoftGym's
//! ClothFlatten, DaXBench's unfold): the area the cloth covers seen along gravity (its shadow on
//! the surface it lies on), over its flat area.
//!
//! SoftGym rasterizes every particle as a disc on a 100 × 100 grid over the cloth's bounding box;
//! here the cloth's triangles are rasterized, so the measure does not depend on a particle
//! radius: a grid of about [`CELLS`] cells along the longer side of the projected bounding box,
//! a cell covered when its centre lies in a projected triangle. A flat square seen face-on covers
//! exactly its area, a square folded in half exactly half of it (the grid tiles the bounding box,
//! so every cell centre of a rectangle lies inside it); other outlines are within about one cell
//! along their perimeter.

use crate::model::Model;
use autodiff::Tensor;
use nalgebra::Vector3;

/// Cells along the longer side of the projected bounding box.
pub const CELLS: usize = 1024;

impl Model {
    /// The area of the cloth's projection along gravity at state `x` over the area of its rest
    /// shape; `None` without gravity (no "down" to project along) or for a cloth of no area.
    pub fn coverage(&self, x: &Tensor) -> Option<f64> {
        let g = self.gravity_step?;
        let down = Vector3::from(g).normalize();
        let flat = self.rest_area();
        if flat <= 0.0 || !down.iter().all(|c| c.is_finite()) {
            return None;
        }
        let (e1, e2) = plane_basis(&down);
        let points: Vec<[f64; 2]> = x
            .data()
            .chunks_exact(3)
            .map(|p| {
                let p = Vector3::new(p[0], p[1], p[2]);
                [p.dot(&e1), p.dot(&e2)]
            })
            .collect();
        Some(projected_area(&points, &self.triangles) / flat)
    }

    /// The total area of the cloth's triangles in its rest shape.
    pub fn rest_area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| {
                    let r = self.rest_shape.row(i);
                    Vector3::new(r[0], r[1], r[2])
                });
                0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
            })
            .sum()
    }
}

/// Two orthonormal directions spanning the plane normal to the unit vector `n`: the world axis
/// least aligned with `n`, made orthogonal to it, and `n × e₁`, so that a cloth lying in the
/// `xy` plane under gravity `−z` is seen along its own axes.
fn plane_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let axis = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e1 = Vector3::zeros();
    e1[axis] = 1.0;
    let e1 = (e1 - n * n.dot(&e1)).normalize();
    (e1, n.cross(&e1).normalize())
}

/// The area of the union of `triangles` over the 2-D `points`, rasterized on a grid of about
/// [`CELLS`] cells along the longer side of their bounding box (module docs).
pub fn projected_area(points: &[[f64; 2]], triangles: &[[usize; 3]]) -> f64 {
    let used = triangles.iter().flatten().map(|&i| points[i]);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in used {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let size = [hi[0] - lo[0], hi[1] - lo[1]];
    let longest = size[0].max(size[1]);
    if longest.is_nan() || longest <= 0.0 || !longest.is_finite() {
        return 0.0;
    }
    let cells = size.map(|s| ((s / longest * CELLS as f64).ceil() as usize).max(1));
    let step = [size[0] / cells[0] as f64, size[1] / cells[1] as f64];
    let mut covered = vec![false; cells[0] * cells[1]];
    // Cell (i, j)'s centre, in the grid's units; a triangle's corners mapped to the same units.
    let to_grid = |p: [f64; 2]| {
        [0, 1].map(|k| {
            if step[k] > 0.0 {
                (p[k] - lo[k]) / step[k]
            } else {
                0.5
            }
        })
    };
    for t in triangles {
        let [a, b, c] = t.map(|i| to_grid(points[i]));
        let area2 = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area2 == 0.0 || !area2.is_finite() {
            continue;
        }
        // The cells whose centres `n + ½` lie within the triangle's extent along axis `k`.
        let range = |k: usize| {
            let min = a[k].min(b[k]).min(c[k]);
            let max = a[k].max(b[k]).max(c[k]);
            let first = (min - 0.5).ceil().max(0.0);
            let last = (max - 0.5).floor().min(cells[k] as f64 - 1.0);
            (first <= last).then_some((first as usize, last as usize))
        };
        let (Some((i0, i1)), Some((j0, j1))) = (range(0), range(1)) else {
            continue;
        };
        let sign = area2.signum();
        let inside = |p: [f64; 2], q: [f64; 2], x: f64, y: f64| {
            ((q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])) * sign >= 0.0
        };
        for j in j0..=j1 {
            let y = j as f64 + 0.5;
            for i in i0..=i1 {
                let x = i as f64 + 0.5;
                if inside(a, b, x, y) && inside(b, c, x, y) && inside(c, a, x, y) {
                    covered[j * cells[0] + i] = true;
                }
            }
        }
    }
    let count = covered.iter().filter(|&&c| c).count();
    count as f64 * step[0].max(0.0) * step[1].max(0.0)
}
