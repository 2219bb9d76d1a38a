//! Row index maps: which rows of a tensor each batch row reads.

/// For each of `rows()` batch rows, `arity` row indices into some tensor.
///
/// A constraint touching particles `i` and `j` is one batch row `[i, j]` of an arity-2 index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RowIndex {
    arity: usize,
    idx: Vec<usize>,
    disjoint: bool,
    bound: usize,
}

impl RowIndex {
    /// A map from row-major `idx` (`rows × arity`).
    ///
    /// # Panics
    /// If `arity == 0` or `idx.len()` is not a multiple of `arity`.
    pub fn new(arity: usize, idx: Vec<usize>) -> Self {
        assert!(arity > 0, "RowIndex::new: arity must be positive");
        assert!(
            idx.len() % arity == 0,
            "RowIndex::new: {} indices do not form rows of arity {arity}",
            idx.len()
        );
        let disjoint = {
            let mut sorted = idx.clone();
            sorted.sort_unstable();
            sorted.windows(2).all(|w| w[0] != w[1])
        };
        let bound = idx.iter().max().map_or(0, |m| m + 1);
        RowIndex {
            arity,
            idx,
            disjoint,
            bound,
        }
    }

    /// An arity-1 map.
    pub fn single(idx: Vec<usize>) -> Self {
        RowIndex::new(1, idx)
    }

    /// Indices per batch row.
    #[inline]
    pub fn arity(&self) -> usize {
        self.arity
    }

    /// Number of batch rows.
    #[inline]
    pub fn rows(&self) -> usize {
        self.idx.len() / self.arity
    }

    /// The indices of batch row `k`.
    #[inline]
    pub fn row(&self, k: usize) -> &[usize] {
        &self.idx[k * self.arity..(k + 1) * self.arity]
    }

    /// All indices, row-major.
    #[inline]
    pub fn as_slice(&self) -> &[usize] {
        &self.idx
    }

    /// True when no index appears twice (the rows can be updated in parallel).
    #[inline]
    pub fn is_disjoint(&self) -> bool {
        self.disjoint
    }

    /// One past the largest index (0 when empty).
    #[inline]
    pub fn bound(&self) -> usize {
        self.bound
    }
}
