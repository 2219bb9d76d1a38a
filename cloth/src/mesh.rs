//! Cloth topology: [`ClothMesh`] (particles, triangles, stretch edges in a canonical order, bending
//! stencils from triangle adjacency) and [`GridMesh`], the rectangular grid as one way to make it.
//!
//! # Conventions (fixed, so results agree with other implementations of the paper)
//!
//! * Particle `(r, c)` (row `r` from the top, column `c`) has index `p = r·cols + c`.
//! * Every grid cell with top-left corner `a = (r,c)`, `b = (r,c+1)`, `d = (r+1,c)`, `e = (r+1,c+1)` is
//!   split by the diagonal `a–e` into the triangles `(a, b, e)` and `(a, e, d)`, in that order; cells are
//!   visited row-major.
//! * Edges ([`GridMesh::stretch_edges`]) are listed as all horizontal edges `(r,c)–(r,c+1)` row-major, then
//!   all vertical edges `(r,c)–(r+1,c)` row-major, then all diagonals `(r,c)–(r+1,c+1)` row-major, each
//!   stored as `[i, j]` with `i < j`.
//! * Interior edges (shared by two triangles) keep that order; [`GridMesh::bending_pairs`] and
//!   [`GridMesh::dihedral_quads`] list one entry per interior edge.
//!
//! For a `10 × 10` grid there are 162 triangles, 261 edges and 225 interior edges.

use std::collections::HashMap;

/// A `rows × cols` grid of particles triangulated along the `(r,c)–(r+1,c+1)` diagonals.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridMesh {
    rows: usize,
    cols: usize,
    triangles: Vec<[usize; 3]>,
}

impl GridMesh {
    /// Builds the grid mesh of `rows × cols` particles.
    ///
    /// Degenerate grids (`rows` or `cols` equal to 1) have no triangles; `rows == 0` or `cols == 0` gives an
    /// empty mesh (scenes reject those sizes during validation).
    pub fn new(rows: usize, cols: usize) -> GridMesh {
        let cells = rows.saturating_sub(1) * cols.saturating_sub(1);
        let mut triangles = Vec::with_capacity(2 * cells);
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols.saturating_sub(1) {
                let a = r * cols + c;
                let b = a + 1;
                let d = a + cols;
                let e = d + 1;
                triangles.push([a, b, e]);
                triangles.push([a, e, d]);
            }
        }
        GridMesh {
            rows,
            cols,
            triangles,
        }
    }

    /// Number of particle rows.
    #[cfg(any(test, feature = "internals"))]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of particle columns.
    #[cfg(any(test, feature = "internals"))]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Index of particle `(r, c)`: `r·cols + c`. Does not check bounds.
    pub fn index(&self, r: usize, c: usize) -> usize {
        r * self.cols + c
    }

    /// `(row, col)` of particle index `p` (inverse of [`GridMesh::index`]).
    #[cfg(any(test, feature = "internals"))]
    pub fn row_col(&self, p: usize) -> (usize, usize) {
        (p / self.cols, p % self.cols)
    }

    /// Number of particles, `rows · cols`.
    pub fn n_particles(&self) -> usize {
        self.rows * self.cols
    }

    /// The triangles, two per cell in row-major cell order: `(a, b, e)` then `(a, e, d)` (see the module
    /// docs). All are consistently oriented: for a cloth laid out along vectors `right` (columns) and `down`
    /// (rows), every triangle's normal `(p1 − p0) × (p2 − p0)` points along `right × down`.
    #[cfg(any(test, feature = "internals"))]
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// Every mesh edge once, in canonical order: horizontal `(r,c)–(r,c+1)` row-major, then vertical
    /// `(r,c)–(r+1,c)` row-major, then diagonals `(r,c)–(r+1,c+1)` row-major; each as `[i, j]` with `i < j`.
    ///
    /// Count: `rows·(cols−1) + (rows−1)·cols + (rows−1)·(cols−1)` (261 for `10 × 10`).
    ///
    /// For a one-row or one-column strip (no triangles) this still returns the chain of grid edges, so a
    /// strip behaves like a rope rather than a set of free particles.
    pub fn stretch_edges(&self) -> Vec<[usize; 2]> {
        let (rows, cols) = (self.rows, self.cols);
        let h = rows * cols.saturating_sub(1);
        let v = rows.saturating_sub(1) * cols;
        let dg = rows.saturating_sub(1) * cols.saturating_sub(1);
        let mut edges = Vec::with_capacity(h + v + dg);
        for r in 0..rows {
            for c in 0..cols.saturating_sub(1) {
                edges.push([self.index(r, c), self.index(r, c + 1)]);
            }
        }
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols {
                edges.push([self.index(r, c), self.index(r + 1, c)]);
            }
        }
        for r in 0..rows.saturating_sub(1) {
            for c in 0..cols.saturating_sub(1) {
                edges.push([self.index(r, c), self.index(r + 1, c + 1)]);
            }
        }
        edges
    }

    /// The cloth topology of this grid: its triangles with the grid's canonical edge order.
    pub fn topology(&self) -> ClothMesh {
        ClothMesh {
            n_particles: self.n_particles(),
            triangles: self.triangles.clone(),
            edges: self.stretch_edges(),
        }
    }

    /// The paper's distance-type bending pairs ([`ClothMesh::bending_pairs`] of
    /// [`GridMesh::topology`]): one per interior edge in the order of [`GridMesh::stretch_edges`].
    ///
    /// Count: `(rows−2)·(cols−1) + (rows−1)·(cols−2) + (rows−1)·(cols−1)` (225 for `10 × 10`).
    #[cfg(any(test, feature = "internals"))]
    pub fn bending_pairs(&self) -> Vec<[usize; 2]> {
        self.topology().bending_pairs()
    }

    /// Dihedral-bending stencils ([`ClothMesh::dihedral_quads`] of [`GridMesh::topology`]), one
    /// per interior edge in the order of [`GridMesh::stretch_edges`].
    #[cfg(any(test, feature = "internals"))]
    pub fn dihedral_quads(&self) -> Vec<[usize; 4]> {
        self.topology().dihedral_quads()
    }
}

/// The topology of a cloth of any shape: its particles, triangles and stretch edges in a canonical
/// order, from which the bending stencils follow by triangle adjacency.
///
/// A grid (`GridMesh::topology` in `cloth/src/mesh.rs`) lists its edges in the grid order of the
/// module docs; a mesh read from a file ([`ClothMesh::from_triangles`]) lists them in order of
/// first use: triangles in file order, each triangle's edges `(t₀,t₁)`, `(t₁,t₂)`, `(t₂,t₀)`.
/// Either way the order, and so the colouring, depends only on the triangle list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClothMesh {
    n_particles: usize,
    triangles: Vec<[usize; 3]>,
    edges: Vec<[usize; 2]>,
}

impl ClothMesh {
    /// The topology of `n_particles` particles joined by `triangles` (vertex indices below
    /// `n_particles`; a scene's mesh cloth is checked for that, for degenerate triangles and for
    /// edges shared by more than two triangles before it gets here).
    pub fn from_triangles(n_particles: usize, triangles: Vec<[usize; 3]>) -> ClothMesh {
        let mut seen = std::collections::HashSet::with_capacity(3 * triangles.len());
        let mut edges = Vec::with_capacity(3 * triangles.len() / 2 + 1);
        for tri in &triangles {
            for k in 0..3 {
                let (i, j) = (tri[k], tri[(k + 1) % 3]);
                let e = [i.min(j), i.max(j)];
                if seen.insert(e) {
                    edges.push(e);
                }
            }
        }
        ClothMesh {
            n_particles,
            triangles,
            edges,
        }
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.n_particles
    }

    /// The triangles, as given (a grid's are consistently oriented, see `GridMesh::triangles` in
    /// `cloth/src/mesh.rs`).
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// Every edge once, in canonical order (see the type's docs), each as `[i, j]` with `i < j`.
    pub fn stretch_edges(&self) -> Vec<[usize; 2]> {
        self.edges.clone()
    }

    /// Maps every triangle edge `[i, j]` (`i < j`) to the vertices opposite it, in triangle order.
    fn edge_opposites(&self) -> HashMap<[usize; 2], Vec<usize>> {
        let mut map: HashMap<[usize; 2], Vec<usize>> =
            HashMap::with_capacity(3 * self.triangles.len());
        for tri in &self.triangles {
            for k in 0..3 {
                let (i, j, o) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
                map.entry([i.min(j), i.max(j)]).or_default().push(o);
            }
        }
        map
    }

    /// The paper's distance-type bending pairs: for each interior edge, in the order of
    /// [`ClothMesh::stretch_edges`], the two vertices opposite it, as `[i, j]` with `i < j`.
    pub fn bending_pairs(&self) -> Vec<[usize; 2]> {
        self.dihedral_quads()
            .into_iter()
            .map(|[_, _, o0, o1]| [o0.min(o1), o0.max(o1)])
            .collect()
    }

    /// Dihedral-bending stencils, one per interior edge (an edge shared by exactly two triangles)
    /// in the order of [`ClothMesh::stretch_edges`]: `[e0, e1, o0, o1]` where `e0 < e1` are the
    /// shared edge's vertices, `o0` is the vertex opposite the edge in the triangle that comes
    /// **first** in [`ClothMesh::triangles`] and `o1` the one opposite it in the later triangle
    /// (`o0`, `o1` are not sorted).
    pub fn dihedral_quads(&self) -> Vec<[usize; 4]> {
        let opp = self.edge_opposites();
        self.edges
            .iter()
            .filter_map(|e| match opp.get(e).map(Vec::as_slice) {
                Some(&[o0, o1]) => Some([e[0], e[1], o0, o1]),
                _ => None,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts(rows: usize, cols: usize) -> (usize, usize, usize, usize) {
        let m = GridMesh::new(rows, cols);
        (
            m.triangles().len(),
            m.stretch_edges().len(),
            m.bending_pairs().len(),
            m.dihedral_quads().len(),
        )
    }

    #[test]
    fn counts_10x10() {
        let m = GridMesh::new(10, 10);
        assert_eq!(m.n_particles(), 100);
        assert_eq!(counts(10, 10), (162, 261, 225, 225));
    }

    #[test]
    fn counts_small_and_odd() {
        assert_eq!(counts(1, 1), (0, 0, 0, 0));
        // strips: no triangles, a rope of grid edges, no bending
        assert_eq!(counts(1, 5), (0, 4, 0, 0));
        assert_eq!(counts(5, 1), (0, 4, 0, 0));
        // one cell: 5 edges, only the diagonal is interior
        assert_eq!(counts(2, 2), (2, 5, 1, 1));
        // 3 rows × 5 cols: h = 3·4, v = 2·5, d = 2·4; interior h = 1·4, v = 2·3, d = 8
        assert_eq!(counts(3, 5), (16, 12 + 10 + 8, 4 + 6 + 8, 18));
        assert_eq!(counts(5, 3), (16, 10 + 12 + 8, 6 + 4 + 8, 18));
        assert_eq!(counts(0, 4), (0, 0, 0, 0));
    }

    #[test]
    fn counts_match_closed_form() {
        for rows in 1..9 {
            for cols in 1..9 {
                let (t, s, b, q) = counts(rows, cols);
                let (r1, c1) = (rows - 1, cols - 1);
                assert_eq!(t, 2 * r1 * c1);
                assert_eq!(s, rows * c1 + r1 * cols + r1 * c1);
                let interior = rows.saturating_sub(2) * c1 + r1 * cols.saturating_sub(2) + r1 * c1;
                assert_eq!(b, interior, "{rows}x{cols}");
                assert_eq!(q, interior);
                // Euler: V − E + F = 1 for a triangulated rectangle with at least one cell
                if rows > 1 && cols > 1 {
                    assert_eq!(rows * cols + t, s + 1);
                }
            }
        }
    }

    #[test]
    fn index_and_row_col() {
        let m = GridMesh::new(3, 5);
        assert_eq!(m.index(0, 0), 0);
        assert_eq!(m.index(1, 0), 5);
        assert_eq!(m.index(2, 4), 14);
        for p in 0..m.n_particles() {
            let (r, c) = m.row_col(p);
            assert_eq!(m.index(r, c), p);
        }
    }

    #[test]
    fn triangle_order_2x3() {
        let m = GridMesh::new(2, 3);
        // cells (0,0) and (0,1): a=0,b=1,d=3,e=4 and a=1,b=2,d=4,e=5
        assert_eq!(m.triangles(), &[[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]);
    }

    #[test]
    fn stretch_edge_order_10x10() {
        let e = GridMesh::new(10, 10).stretch_edges();
        // horizontal row 0, then row 1
        assert_eq!(&e[..3], &[[0, 1], [1, 2], [2, 3]]);
        assert_eq!(e[8], [8, 9]);
        assert_eq!(e[9], [10, 11]);
        assert_eq!(e[89], [98, 99]);
        // vertical, row-major
        assert_eq!(&e[90..93], &[[0, 10], [1, 11], [2, 12]]);
        assert_eq!(e[179], [89, 99]);
        // diagonals, row-major
        assert_eq!(&e[180..183], &[[0, 11], [1, 12], [2, 13]]);
        assert_eq!(e[189], [10, 21]);
        assert_eq!(e[260], [88, 99]);
        assert!(e.iter().all(|&[i, j]| i < j));
    }

    #[test]
    fn bending_order_10x10() {
        let m = GridMesh::new(10, 10);
        let b = m.bending_pairs();
        // first interior edge: horizontal (1,0)–(1,1) = [10, 11]; above it triangle (a,e,d) of cell (0,0)
        // has opposite vertex (0,0) = 0, below it (a,b,e) of cell (1,0) has opposite (2,1) = 21
        assert_eq!(b[0], [0, 21]);
        assert_eq!(b[1], [1, 22]);
        assert_eq!(b[9], [10, 31]);
        // 8·9 = 72 interior horizontal edges, then the first interior vertical edge (0,1)–(1,1):
        // left cell (0,0) triangle (a,b,e) opposite (0,0) = 0; right cell (0,1) triangle (a,e,d) opposite (1,2)
        assert_eq!(b[72], [0, 12]);
        // 72 + 72 = 144: first diagonal (0,0)–(1,1): opposites b = (0,1) = 1 and d = (1,0) = 10
        assert_eq!(b[144], [1, 10]);
        assert_eq!(b[224], [89, 98]);
        assert!(b.iter().all(|&[i, j]| i < j));

        let q = m.dihedral_quads();
        assert_eq!(q[0], [10, 11, 0, 21]);
        assert_eq!(q[72], [1, 11, 0, 12]);
        assert_eq!(q[144], [0, 11, 1, 10]);
    }

    /// Every bending pair / dihedral quad belongs to two distinct triangles that share its edge.
    #[test]
    fn pairs_and_quads_come_from_adjacent_triangles() {
        for (rows, cols) in [(2, 2), (3, 5), (5, 3), (4, 4), (10, 10), (2, 7)] {
            let m = GridMesh::new(rows, cols);
            let tris = m.triangles();
            let edges = m.stretch_edges();
            let pairs = m.bending_pairs();
            let quads = m.dihedral_quads();
            assert_eq!(pairs.len(), quads.len());
            let mut last_edge_pos = None;
            for (pair, quad) in pairs.iter().zip(&quads) {
                let [e0, e1, o0, o1] = *quad;
                assert!(e0 < e1);
                assert_eq!(*pair, [o0.min(o1), o0.max(o1)]);
                let t0 = tris
                    .iter()
                    .position(|t| t.contains(&e0) && t.contains(&e1) && t.contains(&o0))
                    .expect("first triangle exists");
                let t1 = tris
                    .iter()
                    .position(|t| t.contains(&e0) && t.contains(&e1) && t.contains(&o1))
                    .expect("second triangle exists");
                assert!(t0 < t1, "o0 must come from the earlier triangle");
                assert_ne!(o0, o1);
                // exactly two triangles contain the edge
                let n = tris
                    .iter()
                    .filter(|t| t.contains(&e0) && t.contains(&e1))
                    .count();
                assert_eq!(n, 2);
                // quads follow the canonical edge order
                let pos = edges.iter().position(|&e| e == [e0, e1]).expect("edge");
                if let Some(last) = last_edge_pos {
                    assert!(last < pos);
                }
                last_edge_pos = Some(pos);
            }
            // and every edge shared by two triangles has a quad
            let interior = edges
                .iter()
                .filter(|&&[i, j]| {
                    tris.iter()
                        .filter(|t| t.contains(&i) && t.contains(&j))
                        .count()
                        == 2
                })
                .count();
            assert_eq!(interior, quads.len());
        }
    }

    #[test]
    fn every_triangle_edge_is_a_stretch_edge_once() {
        for (rows, cols) in [(2, 2), (3, 5), (10, 10)] {
            let m = GridMesh::new(rows, cols);
            let mut from_tris: Vec<[usize; 2]> = m
                .triangles()
                .iter()
                .flat_map(|t| {
                    [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].map(|(i, j)| [i.min(j), i.max(j)])
                })
                .collect();
            from_tris.sort_unstable();
            from_tris.dedup();
            let mut edges = m.stretch_edges();
            let n = edges.len();
            edges.sort_unstable();
            edges.dedup();
            assert_eq!(edges.len(), n, "no duplicate edges");
            assert_eq!(edges, from_tris);
        }
    }

    #[test]
    fn triangles_share_orientation() {
        // signed area in the (c, r) plane has the same sign for all triangles
        let m = GridMesh::new(4, 6);
        let signs: Vec<bool> = m
            .triangles()
            .iter()
            .map(|t| {
                let p = t.map(|i| {
                    let (r, c) = m.row_col(i);
                    (c as f64, r as f64)
                });
                let area =
                    (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1);
                area > 0.0
            })
            .collect();
        assert!(signs.iter().all(|&s| s == signs[0]));
    }

    #[test]
    fn a_triangle_list_gives_edges_in_first_use_order_and_the_same_stencils_as_the_grid() {
        let grid = GridMesh::new(4, 5);
        let from_list = ClothMesh::from_triangles(20, grid.triangles().to_vec());
        // Same edge set, first-use order.
        let mut a = from_list.stretch_edges();
        let mut b = grid.stretch_edges();
        assert_eq!(&a[..5], &[[0, 1], [1, 6], [0, 6], [5, 6], [0, 5]]);
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        // Every stencil of the grid appears, for the same edge, in the list's topology.
        let mut qa = from_list.dihedral_quads();
        let mut qb = grid.dihedral_quads();
        // interior edges: 2·4 horizontal + 3·3 vertical + 3·4 diagonal
        assert_eq!(qa.len(), 29);
        qa.sort_unstable();
        qb.sort_unstable();
        assert_eq!(qa, qb);
        assert_eq!(grid.topology().stretch_edges(), grid.stretch_edges());
    }

    #[test]
    fn boundary_edges_have_no_stencil() {
        // Two triangles sharing the edge 1–2 and a third hanging off edge 2–3.
        let m = ClothMesh::from_triangles(5, vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
        assert_eq!(m.stretch_edges().len(), 7);
        assert_eq!(m.dihedral_quads(), vec![[1, 2, 0, 3], [2, 3, 1, 4]]);
        assert_eq!(m.bending_pairs(), vec![[0, 3], [1, 4]]);
    }
}
