//! Small matrix types used at the API boundary (Jacobians, norm-term matrices, Hessian guesses) and a few
//! dense vector kernels. Everything here is plain `Vec<f64>`: at the sizes this crate targets
//! (n ≲ a few hundred variables) the dense O(n²) loops are cheaper than any library call overhead.

use serde::{Deserialize, Serialize};

/// A dense, row-major `rows × cols` matrix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DenseMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl DenseMatrix {
    /// A `rows × cols` matrix of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// The `n × n` identity.
    pub fn identity(n: usize) -> Self {
        let mut m = Self::zeros(n, n);
        for i in 0..n {
            m.data[i * n + i] = 1.0;
        }
        m
    }

    /// Builds a matrix from row-major data; `None` if `data.len() != rows * cols`.
    pub fn from_row_major(rows: usize, cols: usize, data: Vec<f64>) -> Option<Self> {
        (data.len() == rows * cols).then_some(Self { rows, cols, data })
    }

    /// Builds a matrix from a slice of equally long rows; `None` if the rows differ in length.
    pub fn from_rows(rows: &[Vec<f64>]) -> Option<Self> {
        let cols = rows.first().map_or(0, Vec::len);
        if rows.iter().any(|r| r.len() != cols) {
            return None;
        }
        Some(Self {
            rows: rows.len(),
            cols,
            data: rows.iter().flatten().copied().collect(),
        })
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.cols
    }

    /// Square, symmetric to `1e-12·max(1, largest |entry|)`, and positive definite (a Cholesky
    /// factorization succeeds): what an initial Hessian must be.
    pub fn is_symmetric_positive_definite(&self) -> bool {
        let (n, data) = (self.rows, &self.data);
        let scale = norm_inf(data).max(1.0);
        self.cols == n
            && (0..n)
                .all(|i| (0..i).all(|j| (data[i * n + j] - data[j * n + i]).abs() <= 1e-12 * scale))
            && is_positive_definite(data, n)
    }

    /// Entry `(i, j)`. Panics if out of range (an index bug, not a data error).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        assert!(
            i < self.rows && j < self.cols,
            "DenseMatrix index out of range"
        );
        self.data[i * self.cols + j]
    }

    /// Sets entry `(i, j)`. Panics if out of range (an index bug, not a data error).
    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        assert!(
            i < self.rows && j < self.cols,
            "DenseMatrix index out of range"
        );
        self.data[i * self.cols + j] = value;
    }

    /// Row `i` as a slice.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// Row `i` as a mutable slice.
    pub fn row_mut(&mut self, i: usize) -> &mut [f64] {
        &mut self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// All entries, row-major.
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// All entries, row-major, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.data
    }

    /// Sets every entry to `value`.
    pub fn fill(&mut self, value: f64) {
        self.data.fill(value);
    }
}

/// A sparse matrix in triplet (coordinate) form; duplicate entries are summed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SparseMatrix {
    rows: usize,
    cols: usize,
    entries: Vec<(usize, usize, f64)>,
}

impl SparseMatrix {
    /// An empty `rows × cols` matrix.
    pub fn new(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            entries: Vec::new(),
        }
    }

    /// Adds `value` at `(i, j)` (summed with any earlier entry there). Out-of-range indices are
    /// reported when the solver validates the matrix.
    pub fn push(&mut self, i: usize, j: usize, value: f64) {
        self.entries.push((i, j, value));
    }

    /// Removes all entries, keeping the shape.
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.cols
    }

    /// The stored `(row, column, value)` triplets.
    pub fn entries(&self) -> &[(usize, usize, f64)] {
        &self.entries
    }
}

/// A constraint Jacobian (one row per constraint, one column per variable), dense or sparse.
///
/// The solver hands a zeroed [`Jacobian::Dense`] of the right shape to
/// [`Problem::inequality_jacobian`](crate::Problem::inequality_jacobian); fill it in place
/// (e.g. with [`Jacobian::set`] or [`Jacobian::dense_row_mut`]) or replace it with a
/// [`Jacobian::Sparse`] of the same shape.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Jacobian {
    /// Dense row-major storage.
    Dense(DenseMatrix),
    /// Triplet storage; duplicates are summed.
    Sparse(SparseMatrix),
}

impl Jacobian {
    /// A zero dense Jacobian of shape `rows × cols`.
    pub fn dense(rows: usize, cols: usize) -> Self {
        Jacobian::Dense(DenseMatrix::zeros(rows, cols))
    }

    /// Number of rows (constraints).
    pub fn nrows(&self) -> usize {
        match self {
            Jacobian::Dense(m) => m.nrows(),
            Jacobian::Sparse(m) => m.nrows(),
        }
    }

    /// Number of columns (variables).
    pub fn ncols(&self) -> usize {
        match self {
            Jacobian::Dense(m) => m.ncols(),
            Jacobian::Sparse(m) => m.ncols(),
        }
    }

    /// Dense: overwrites entry `(i, j)`. Sparse: appends a triplet (so set each entry once).
    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        match self {
            Jacobian::Dense(m) => m.set(i, j, value),
            Jacobian::Sparse(m) => m.push(i, j, value),
        }
    }

    /// Row `i` of a dense Jacobian, `None` for a sparse one.
    pub fn dense_row_mut(&mut self, i: usize) -> Option<&mut [f64]> {
        match self {
            Jacobian::Dense(m) if i < m.nrows() => Some(m.row_mut(i)),
            _ => None,
        }
    }

    /// Checks shape, indices and finiteness.
    pub(crate) fn validate(&self, rows: usize, cols: usize) -> Result<(), String> {
        if self.nrows() != rows || self.ncols() != cols {
            return Err(format!(
                "Jacobian has shape {}x{}, expected {rows}x{cols}",
                self.nrows(),
                self.ncols()
            ));
        }
        match self {
            Jacobian::Dense(m) => {
                if m.as_slice().iter().any(|v| !v.is_finite()) {
                    return Err("Jacobian has a non-finite entry".into());
                }
            }
            Jacobian::Sparse(m) => {
                for &(i, j, v) in m.entries() {
                    if i >= rows || j >= cols {
                        return Err(format!("Jacobian entry ({i}, {j}) is out of range"));
                    }
                    if !v.is_finite() {
                        return Err(format!("Jacobian entry ({i}, {j}) is not finite"));
                    }
                }
            }
        }
        Ok(())
    }

    /// Calls `f(i, j, v)` for every stored nonzero (dense: row-major order, zeros skipped).
    pub(crate) fn for_each_nonzero(&self, mut f: impl FnMut(usize, usize, f64)) {
        match self {
            Jacobian::Dense(m) => {
                for i in 0..m.nrows() {
                    for (j, &v) in m.row(i).iter().enumerate() {
                        if v != 0.0 {
                            f(i, j, v);
                        }
                    }
                }
            }
            Jacobian::Sparse(m) => {
                for &(i, j, v) in m.entries() {
                    f(i, j, v);
                }
            }
        }
    }

    /// Replaces the rows marked in `rows` by those of `other` (same shape).
    pub(crate) fn replace_rows(&mut self, other: &Jacobian, rows: &[bool]) {
        match self {
            Jacobian::Dense(m) => {
                for (i, _) in rows.iter().enumerate().filter(|(_, &r)| r) {
                    m.row_mut(i).fill(0.0);
                }
                other.for_each_nonzero(|i, j, v| {
                    if rows[i] {
                        let row = m.row_mut(i);
                        row[j] += v;
                    }
                });
            }
            Jacobian::Sparse(m) => {
                m.entries.retain(|e| !rows[e.0]);
                other.for_each_nonzero(|i, j, v| {
                    if rows[i] {
                        m.push(i, j, v);
                    }
                });
            }
        }
    }

    /// ∞-norm of every row.
    pub(crate) fn row_inf_norms(&self) -> Vec<f64> {
        let mut norms = vec![0.0_f64; self.nrows()];
        match self {
            Jacobian::Dense(_) => {
                self.for_each_nonzero(|i, _, v| norms[i] = norms[i].max(v.abs()));
            }
            Jacobian::Sparse(m) => {
                // Sum duplicates first.
                let mut e = m.entries.clone();
                e.sort_by_key(|t| (t.0, t.1));
                let mut k = 0;
                while k < e.len() {
                    let (i, j, mut v) = e[k];
                    k += 1;
                    while k < e.len() && e[k].0 == i && e[k].1 == j {
                        v += e[k].2;
                        k += 1;
                    }
                    norms[i] = norms[i].max(v.abs());
                }
            }
        }
        norms
    }

    /// Multiplies row `i` by `s[i]`.
    pub(crate) fn scale_rows(&mut self, s: &[f64]) {
        match self {
            Jacobian::Dense(m) => {
                for (i, &si) in s.iter().enumerate().take(m.nrows()) {
                    for v in m.row_mut(i) {
                        *v *= si;
                    }
                }
            }
            Jacobian::Sparse(m) => {
                for e in &mut m.entries {
                    e.2 *= s[e.0];
                }
            }
        }
    }

    /// `out = J x`.
    pub(crate) fn mul_vec(&self, x: &[f64], out: &mut [f64]) {
        match self {
            Jacobian::Dense(m) => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = dot(m.row(i), x);
                }
            }
            Jacobian::Sparse(m) => {
                out.fill(0.0);
                for &(i, j, v) in m.entries() {
                    out[i] += v * x[j];
                }
            }
        }
    }

    /// `out += scale · Jᵀ y`.
    pub(crate) fn tmul_add(&self, y: &[f64], scale: f64, out: &mut [f64]) {
        match self {
            Jacobian::Dense(m) => {
                for (i, &yi) in y.iter().enumerate() {
                    if yi != 0.0 {
                        axpy(scale * yi, m.row(i), out);
                    }
                }
            }
            Jacobian::Sparse(m) => {
                for &(i, j, v) in m.entries() {
                    out[j] += scale * v * y[i];
                }
            }
        }
    }
}

/// `xᵀy`.
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// `y += a·x`.
pub(crate) fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// ∞-norm (0 for an empty slice).
pub(crate) fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// Euclidean norm.
pub(crate) fn norm2(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

/// Symmetric dense matrix–vector product `out = M x` for row-major `n × n` `m`.
pub(crate) fn symv(m: &[f64], n: usize, x: &[f64], out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate().take(n) {
        *o = dot(&m[i * n..(i + 1) * n], x);
    }
}

/// Cholesky test for positive definiteness of a symmetric row-major `n × n` matrix.
pub(crate) fn is_positive_definite(m: &[f64], n: usize) -> bool {
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let mut d = m[j * n + j];
        for k in 0..j {
            d -= l[j * n + k] * l[j * n + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let djj = d.sqrt();
        l[j * n + j] = djj;
        for i in j + 1..n {
            let mut s = m[i * n + j];
            for k in 0..j {
                s -= l[i * n + k] * l[j * n + k];
            }
            l[i * n + j] = s / djj;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_positive_definite_check() {
        let m = |rows: &[&[f64]]| {
            DenseMatrix::from_rows(&rows.iter().map(|r| r.to_vec()).collect::<Vec<_>>()).unwrap()
        };
        assert!(m(&[&[2.0, 1.0], &[1.0, 2.0]]).is_symmetric_positive_definite());
        // Indefinite, singular, asymmetric, not square.
        assert!(!m(&[&[1.0, 2.0], &[2.0, 1.0]]).is_symmetric_positive_definite());
        assert!(!m(&[&[1.0, 1.0], &[1.0, 1.0]]).is_symmetric_positive_definite());
        assert!(!m(&[&[2.0, 1.0], &[1.0 + 1e-9, 2.0]]).is_symmetric_positive_definite());
        assert!(!m(&[&[2.0, 1.0, 0.0], &[1.0, 2.0, 0.0]]).is_symmetric_positive_definite());
    }

    #[test]
    fn dense_and_sparse_products_agree() {
        let rows = vec![vec![1.0, 0.0, 2.0], vec![0.0, -3.0, 4.0]];
        let dense = Jacobian::Dense(DenseMatrix::from_rows(&rows).unwrap());
        let mut s = SparseMatrix::new(2, 3);
        s.push(0, 0, 1.0);
        s.push(0, 2, 1.5);
        s.push(0, 2, 0.5); // duplicate, summed
        s.push(1, 1, -3.0);
        s.push(1, 2, 4.0);
        let mut sparse = Jacobian::Sparse(s);
        assert_eq!(dense.row_inf_norms(), vec![2.0, 4.0]);
        assert_eq!(sparse.row_inf_norms(), vec![2.0, 4.0]);
        let mut d2 = dense.clone();
        d2.scale_rows(&[2.0, 0.5]);
        sparse.scale_rows(&[2.0, 0.5]);
        let (mut u, mut v) = ([0.0; 2], [0.0; 2]);
        d2.mul_vec(&[1.0, 2.0, 3.0], &mut u);
        sparse.mul_vec(&[1.0, 2.0, 3.0], &mut v);
        assert_eq!(u, [14.0, 3.0]);
        assert_eq!(u, v);
        sparse.scale_rows(&[0.5, 2.0]);
        let x = [1.0, 2.0, 3.0];
        let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
        dense.mul_vec(&x, &mut a);
        sparse.mul_vec(&x, &mut b);
        assert_eq!(a, [7.0, 6.0]);
        assert_eq!(a, b);
        let y = [2.0, -1.0];
        let (mut c, mut d) = ([0.0; 3], [0.0; 3]);
        dense.tmul_add(&y, 1.0, &mut c);
        sparse.tmul_add(&y, 1.0, &mut d);
        assert_eq!(c, [2.0, 3.0, 0.0]);
        assert_eq!(c, d);
    }

    #[test]
    fn validation_catches_bad_jacobians() {
        let j = Jacobian::dense(2, 3);
        assert!(j.validate(2, 3).is_ok());
        assert!(j.validate(3, 2).is_err());
        let mut s = SparseMatrix::new(2, 3);
        s.push(2, 0, 1.0);
        assert!(Jacobian::Sparse(s).validate(2, 3).is_err());
        let mut d = Jacobian::dense(1, 1);
        d.set(0, 0, f64::NAN);
        assert!(d.validate(1, 1).is_err());
    }

    #[test]
    fn cholesky_detects_definiteness() {
        assert!(is_positive_definite(&[2.0, 1.0, 1.0, 2.0], 2));
        assert!(!is_positive_definite(&[1.0, 2.0, 2.0, 1.0], 2));
    }
}
