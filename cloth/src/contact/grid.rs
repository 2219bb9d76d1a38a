//! A uniform grid of boxes (the self-contact pair searches' broad phase): the vertices of a state
//! for [`crate::contact::self_collision`], the edges for [`crate::contact::edge_edge`].

use autodiff::Tensor;
use nalgebra::Vector3;

/// An axis-aligned box `(lo, hi)`.
pub(crate) type Aabb = (Vector3<f64>, Vector3<f64>);

/// Items bucketed by their boxes in a uniform grid over the boxes' bounds (counting sort: each
/// cell's items in increasing order; an item is in every cell its box touches, a point in one).
pub(crate) struct BoxGrid {
    origin: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// Cell `c`'s items: `order[start[c]..start[c + 1]]`; empty when the grid could not be
    /// built (non-finite coordinates), then every query returns every item.
    start: Vec<usize>,
    order: Vec<usize>,
    n: usize,
}

impl BoxGrid {
    /// The grid of `x`'s vertices (`N × 3`), with cells as in [`BoxGrid::new`].
    pub(crate) fn of_points(x: &Tensor, cell: f64) -> BoxGrid {
        let boxes: Vec<Aabb> = (0..x.rows())
            .map(|p| {
                let v = Vector3::new(x.get(p, 0), x.get(p, 1), x.get(p, 2));
                (v, v)
            })
            .collect();
        BoxGrid::new(&boxes, cell)
    }

    /// The grid of `boxes` with cells of edge `cell` (larger when that would make more than
    /// eight cells per item).
    pub(crate) fn new(boxes: &[Aabb], cell: f64) -> BoxGrid {
        let n = boxes.len();
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for b in boxes {
            lo = lo.inf(&b.0);
            hi = hi.sup(&b.1);
        }
        let mut grid = BoxGrid {
            origin: lo,
            cell,
            dims: [1; 3],
            start: Vec::new(),
            order: Vec::new(),
            n,
        };
        let span = hi - lo;
        if !(span.iter().all(|s| s.is_finite()) && cell > 0.0 && cell.is_finite()) {
            return grid;
        }
        let dims = |c: f64| span.map(|s| (s / c).floor() + 1.0);
        while dims(grid.cell).product() > 8.0 * n as f64 + 8.0 {
            grid.cell *= 2.0;
        }
        let d = dims(grid.cell);
        grid.dims = [d.x as usize, d.y as usize, d.z as usize];
        let mut start = vec![0usize; grid.dims.iter().product::<usize>() + 1];
        for b in boxes {
            grid.for_cells(b, |c| start[c + 1] += 1);
        }
        for c in 1..start.len() {
            start[c] += start[c - 1];
        }
        let mut next = start.clone();
        let mut order = vec![0; start[start.len() - 1]];
        for (p, b) in boxes.iter().enumerate() {
            grid.for_cells(b, |c| {
                order[next[c]] = p;
                next[c] += 1;
            });
        }
        grid.start = start;
        grid.order = order;
        grid
    }

    /// Calls `f` with every cell the box `b` touches (one cell for a point).
    fn for_cells(&self, b: &Aabb, mut f: impl FnMut(usize)) {
        let (a, z) = (self.key(&b.0), self.key(&b.1));
        for l in a[2]..=z[2] {
            for j in a[1]..=z[1] {
                for i in a[0]..=z[0] {
                    f(self.index(&[i, j, l]));
                }
            }
        }
    }

    /// The cell coordinates of `v`, clamped to the grid.
    fn key(&self, v: &Vector3<f64>) -> [usize; 3] {
        std::array::from_fn(|k| {
            let c = ((v[k] - self.origin[k]) / self.cell).floor();
            // `as` saturates (NaN to 0); the clamp keeps the key in the grid.
            (c.max(0.0) as usize).min(self.dims[k] - 1)
        })
    }

    fn index(&self, key: &[usize; 3]) -> usize {
        (key[2] * self.dims[1] + key[1]) * self.dims[0] + key[0]
    }

    /// Appends every item in the cells the box `lo..hi` touches (all items when the grid is
    /// empty or the box covers more cells than there are items); an item whose box spans
    /// several of those cells is appended once per cell.
    pub(crate) fn candidates(&self, lo: &Vector3<f64>, hi: &Vector3<f64>, out: &mut Vec<usize>) {
        if self.start.is_empty() || !(lo.iter().chain(hi.iter()).all(|c| c.is_finite())) {
            return out.extend(0..self.n);
        }
        let (a, b) = (self.key(lo), self.key(hi));
        let cells: usize = (0..3).map(|k| b[k] - a[k] + 1).product();
        if cells > self.n {
            return out.extend(0..self.n);
        }
        for l in a[2]..=b[2] {
            for j in a[1]..=b[1] {
                let row = self.index(&[a[0], j, l]);
                let (first, last) = (row, row + b[0] - a[0]);
                out.extend_from_slice(&self.order[self.start[first]..self.start[last + 1]]);
            }
        }
    }
}
