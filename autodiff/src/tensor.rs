//! A dense, row-major `f64` tensor of rank 1 or 2.

use std::fmt;

/// Dense row-major `f64` data with `rows × cols` shape.
///
/// A 1-D tensor of length `n` is stored as an `n × 1` column; a scalar is `1 × 1`.
#[derive(Clone, PartialEq, Default)]
pub struct Tensor {
    data: Vec<f64>,
    rows: usize,
    cols: usize,
}

impl Tensor {
    /// A `rows × cols` tensor from row-major data.
    ///
    /// # Panics
    /// If `data.len() != rows * cols`.
    pub fn new(rows: usize, cols: usize, data: Vec<f64>) -> Self {
        assert_eq!(
            data.len(),
            rows * cols,
            "Tensor::new: {} values do not fill a {rows} × {cols} tensor",
            data.len()
        );
        Tensor { data, rows, cols }
    }

    /// A `rows × cols` tensor of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Tensor::new(rows, cols, vec![0.0; rows * cols])
    }

    /// A 1-D tensor (an `n × 1` column).
    pub fn vector(data: Vec<f64>) -> Self {
        let n = data.len();
        Tensor::new(n, 1, data)
    }

    /// A `1 × 1` tensor.
    pub fn scalar(v: f64) -> Self {
        Tensor::new(1, 1, vec![v])
    }

    /// A tensor from rows of equal width.
    ///
    /// # Panics
    /// If the rows differ in length.
    pub fn from_rows<const C: usize>(rows: &[[f64; C]]) -> Self {
        Tensor::new(rows.len(), C, rows.iter().flatten().copied().collect())
    }

    /// Number of rows.
    #[inline]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    #[inline]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// `(rows, cols)`.
    #[inline]
    pub fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    /// Number of elements.
    #[inline]
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True when the tensor holds no element.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The row-major data.
    #[inline]
    pub fn data(&self) -> &[f64] {
        &self.data
    }

    /// The row-major data, mutable.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [f64] {
        &mut self.data
    }

    /// Consumes the tensor, returning its row-major data.
    pub fn into_data(self) -> Vec<f64> {
        self.data
    }

    /// Row `r`.
    #[inline]
    pub fn row(&self, r: usize) -> &[f64] {
        &self.data[r * self.cols..(r + 1) * self.cols]
    }

    /// Row `r`, mutable.
    #[inline]
    pub fn row_mut(&mut self, r: usize) -> &mut [f64] {
        &mut self.data[r * self.cols..(r + 1) * self.cols]
    }

    /// Element `(r, c)`.
    #[inline]
    pub fn get(&self, r: usize, c: usize) -> f64 {
        self.data[r * self.cols + c]
    }

    /// The single value of a `1 × 1` tensor.
    ///
    /// # Panics
    /// If the tensor is not `1 × 1`.
    pub fn item(&self) -> f64 {
        assert_eq!(
            self.shape(),
            (1, 1),
            "Tensor::item on a {:?} tensor",
            self.shape()
        );
        self.data[0]
    }

    /// True when every element is finite.
    pub fn is_finite(&self) -> bool {
        self.data.iter().all(|v| v.is_finite())
    }

    /// Largest absolute element (0 for an empty tensor).
    pub fn max_abs(&self) -> f64 {
        self.data.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// Euclidean norm of all elements.
    pub fn norm(&self) -> f64 {
        self.data.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// Adds `other` element by element.
    ///
    /// # Panics
    /// On a shape mismatch.
    pub fn add_assign(&mut self, other: &Tensor) {
        assert_eq!(
            self.shape(),
            other.shape(),
            "Tensor::add_assign: shape mismatch"
        );
        for (a, b) in self.data.iter_mut().zip(&other.data) {
            *a += b;
        }
    }
}

impl fmt::Debug for Tensor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Tensor({}×{}) ", self.rows, self.cols)?;
        f.debug_list()
            .entries((0..self.rows).map(|r| self.row(r)))
            .finish()
    }
}
