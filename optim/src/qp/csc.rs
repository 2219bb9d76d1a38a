//! Assembling sparse matrices for Clarabel: triplets compressed to CSC.

use clarabel::algebra::CscMatrix;

/// Triplets pushed in increasing row order, compressed to CSC by a stable counting sort on columns
/// (so rows stay sorted within a column); duplicates are merged.
pub(super) struct TripletBuilder {
    rows: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl TripletBuilder {
    pub(super) fn with_capacity(cap: usize) -> Self {
        Self {
            rows: Vec::with_capacity(cap),
            cols: Vec::with_capacity(cap),
            vals: Vec::with_capacity(cap),
        }
    }

    pub(super) fn push(&mut self, r: usize, c: usize, v: f64) {
        self.rows.push(r);
        self.cols.push(c);
        self.vals.push(v);
    }

    pub(super) fn into_csc(self, m: usize, n: usize) -> CscMatrix<f64> {
        let nnz = self.vals.len();
        let mut colptr = vec![0usize; n + 1];
        for &c in &self.cols {
            colptr[c + 1] += 1;
        }
        for j in 0..n {
            colptr[j + 1] += colptr[j];
        }
        let mut next = colptr.clone();
        let mut rowval = vec![0usize; nnz];
        let mut nzval = vec![0.0; nnz];
        for idx in 0..nnz {
            let c = self.cols[idx];
            let dst = next[c];
            rowval[dst] = self.rows[idx];
            nzval[dst] = self.vals[idx];
            next[c] += 1;
        }
        // Sort within columns if needed (sparse user input may be out of order) and merge duplicates.
        let mut out_colptr = vec![0usize; n + 1];
        let mut out_rows = Vec::with_capacity(nnz);
        let mut out_vals = Vec::with_capacity(nnz);
        for j in 0..n {
            let (a, b) = (colptr[j], colptr[j + 1]);
            let mut seg: Vec<(usize, f64)> = (a..b).map(|i| (rowval[i], nzval[i])).collect();
            if !seg.windows(2).all(|w| w[0].0 < w[1].0) {
                seg.sort_by_key(|e| e.0);
            }
            for (r, v) in seg {
                if out_rows.len() > out_colptr[j] && out_rows.last() == Some(&r) {
                    if let Some(last) = out_vals.last_mut() {
                        *last += v;
                    }
                } else {
                    out_rows.push(r);
                    out_vals.push(v);
                }
            }
            out_colptr[j + 1] = out_rows.len();
        }
        CscMatrix::new(m, n, out_colptr, out_rows, out_vals)
    }
}
