//! The fill-reducing elimination order of the Newton matrix, chosen on the particle graph.
//!
//! The matrix is made of 3 × 3 particle blocks, so the order is computed on the graph of free
//! particles (an edge where a constraint couples two of them) by faer's approximate minimum degree
//! and each particle's three coordinates are numbered together. [`super::assembly::Pattern`]
//! numbers its degrees of freedom in this order, so the matrix it assembles is already permuted:
//! the factorization ([`super::factor`]) needs no permutation of the values or the right-hand
//! sides per iteration. Measured on `u_obstacle` at n = 40 (4794 unknowns), the factor has the
//! same 762k stored entries as faer's AMD on the coordinates; a geometric nested dissection from
//! the rest positions (median splits along the longest axis, leaves of 8 to 64 particles) had
//! 10–23% more (the bending pairs couple particles two apart, so separators are thick).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::SymbolicSparseColMatRef;

/// The elimination position of each of `n` nodes of the undirected graph with `edges` (pairs of
/// node indices, any order, duplicates and self-loops allowed): a permutation of `0..n`.
/// Deterministic: it depends only on the graph as given.
pub(super) fn elimination_positions(n: usize, edges: &[(u32, u32)]) -> Vec<u32> {
    if n == 0 {
        return Vec::new();
    }
    // The symmetric pattern with its diagonal, sorted columns without duplicates.
    let mut adjacency: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    for &(a, b) in edges {
        let (a, b) = (a as usize, b as usize);
        if a != b {
            adjacency[a].push(b);
            adjacency[b].push(a);
        }
    }
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0);
    for rows in &mut adjacency {
        rows.sort_unstable();
        rows.dedup();
        row_idx.extend_from_slice(rows);
        col_ptr.push(row_idx.len());
    }
    let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
    let (mut order, mut position) = (vec![0usize; n], vec![0usize; n]);
    let mut scratch = MemBuffer::new(amd::order_scratch::<usize>(n, row_idx.len()));
    amd::order(
        &mut order,
        &mut position,
        pattern,
        amd::Control::default(),
        MemStack::new(&mut scratch),
    )
    .expect("minimum degree ordering of a valid pattern");
    position.into_iter().map(|p| p as u32).collect()
}

#[cfg(test)]
mod tests {
    use super::elimination_positions;

    /// A `w × h` grid graph with its diagonals (the stencil of a triangulated cloth).
    fn grid(w: u32, h: u32) -> Vec<(u32, u32)> {
        let mut e = Vec::new();
        for r in 0..h {
            for c in 0..w {
                let i = r * w + c;
                if c + 1 < w {
                    e.push((i, i + 1));
                }
                if r + 1 < h {
                    e.push((i, i + w));
                    if c + 1 < w {
                        e.push((i, i + w + 1));
                    }
                }
            }
        }
        e
    }

    #[test]
    fn positions_are_a_permutation_and_deterministic() {
        for (w, h) in [(1, 1), (2, 3), (7, 5), (20, 20)] {
            let n = (w * h) as usize;
            let pos = elimination_positions(n, &grid(w, h));
            let mut seen = vec![false; n];
            for &p in &pos {
                assert!(
                    !std::mem::replace(&mut seen[p as usize], true),
                    "{w}×{h}: {p} twice"
                );
            }
            assert!(seen.iter().all(|&s| s), "{w}×{h}: not a permutation");
            assert_eq!(pos, elimination_positions(n, &grid(w, h)));
        }
        assert!(elimination_positions(0, &[]).is_empty());
        // Isolated nodes, duplicate edges and self-loops are fine.
        let pos = elimination_positions(4, &[(0, 1), (1, 0), (2, 2)]);
        let mut sorted = pos.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, vec![0, 1, 2, 3]);
    }
}
