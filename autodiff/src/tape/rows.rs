//! Row-wise reductions and concatenations recorded on a [`Tape`]: sums, norms, dot products,
//! extremes, the soft minimum, and stacking by rows or columns.

use super::{Op, Tape, Var};
use crate::tensor::Tensor;

impl Tape {
    /// Sum of all elements (`1 × 1`), in row-major order.
    pub fn sum(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let s = self.nodes[ia].value.data().iter().sum::<f64>();
        let mut out = self.alloc(1);
        out[0] = s;
        self.push(Op::Sum { a: ia }, Tensor::new(1, 1, out))
    }

    /// Sum of each row (`rows × 1`).
    pub fn row_sum(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let r = self.nodes[ia].value.rows();
        let mut out = self.alloc(r);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.nodes[ia].value.row(i).iter().sum();
        }
        self.push(Op::RowSum { a: ia }, Tensor::vector(out))
    }

    /// Euclidean norm of each row (`rows × 1`); a zero row has gradient 0.
    pub fn row_norm(&mut self, a: Var) -> Var {
        let ia = self.check(a);
        let r = self.nodes[ia].value.rows();
        let mut out = self.alloc(r);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.nodes[ia]
                .value
                .row(i)
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt();
        }
        self.push(Op::RowNorm { a: ia }, Tensor::vector(out))
    }

    /// `Σ aᵢ bᵢ` over same-shaped tensors (`1 × 1`).
    pub fn dot(&mut self, a: Var, b: Var) -> Var {
        let (ia, ib) = (self.check(a), self.check(b));
        assert_eq!(
            self.nodes[ia].value.shape(),
            self.nodes[ib].value.shape(),
            "dot: shape mismatch"
        );
        let s = self.nodes[ia]
            .value
            .data()
            .iter()
            .zip(self.nodes[ib].value.data())
            .map(|(x, y)| x * y)
            .sum::<f64>();
        let mut out = self.alloc(1);
        out[0] = s;
        self.push(Op::Dot { a: ia, b: ib }, Tensor::new(1, 1, out))
    }

    fn row_arg(&mut self, a: Var, better: fn(f64, f64) -> bool) -> Var {
        let ia = self.check(a);
        let (r, c) = self.nodes[ia].value.shape();
        assert!(c > 0, "row min/max of a tensor with no column");
        let mut out = self.alloc(r);
        let mut arg = Vec::with_capacity(r);
        for (i, o) in out.iter_mut().enumerate() {
            let row = self.nodes[ia].value.row(i);
            let mut best = 0;
            for j in 1..c {
                if better(row[j], row[best]) {
                    best = j;
                }
            }
            arg.push(best);
            *o = row[best];
        }
        self.push(Op::RowArg { a: ia, arg }, Tensor::vector(out))
    }

    /// Minimum of each row (`rows × 1`); on a tie the first minimal column gets the gradient.
    pub fn row_min(&mut self, a: Var) -> Var {
        self.row_arg(a, |x, best| x < best)
    }

    /// Maximum of each row (`rows × 1`); on a tie the first maximal column gets the gradient.
    pub fn row_max(&mut self, a: Var) -> Var {
        self.row_arg(a, |x, best| x > best)
    }

    /// Smooth minimum of all elements, `−(1/κ) log Σᵢ exp(−κ aᵢ)` (`1 × 1`), computed stably.
    ///
    /// It never exceeds the true minimum and lies within `ln(count)/κ` of it; its gradient is the
    /// softmax weights `exp(−κ(aᵢ − result))`, summing to 1.
    ///
    /// # Panics
    /// If `a` is empty or `kappa` is not positive and finite.
    pub fn soft_min(&mut self, a: Var, kappa: f64) -> Var {
        let ia = self.check(a);
        assert!(
            kappa > 0.0 && kappa.is_finite(),
            "soft_min: kappa must be positive and finite"
        );
        let v = self.nodes[ia].value.data();
        assert!(!v.is_empty(), "soft_min of an empty tensor");
        let s = soft_min_value(v, kappa);
        self.push(Op::SoftMin { a: ia, kappa }, Tensor::scalar(s))
    }

    /// Stacks tensors with equal column counts on top of each other.
    pub fn concat_rows(&mut self, parts: &[Var]) -> Var {
        let ids: Vec<usize> = parts.iter().map(|&p| self.check(p)).collect();
        assert!(!ids.is_empty(), "concat_rows: nothing to concatenate");
        let c = self.nodes[ids[0]].value.cols();
        let total = ids.iter().map(|&i| self.nodes[i].value.len()).sum();
        let mut out = self.spare(total);
        let mut rows = 0;
        for &i in &ids {
            let v = &self.nodes[i].value;
            assert_eq!(v.cols(), c, "concat_rows: column counts differ");
            out.extend_from_slice(v.data());
            rows += v.rows();
        }
        self.push(Op::ConcatRows { parts: ids }, Tensor::new(rows, c, out))
    }

    /// Places tensors with equal row counts side by side.
    pub fn concat_cols(&mut self, parts: &[Var]) -> Var {
        let ids: Vec<usize> = parts.iter().map(|&p| self.check(p)).collect();
        assert!(!ids.is_empty(), "concat_cols: nothing to concatenate");
        let r = self.nodes[ids[0]].value.rows();
        let c: usize = ids.iter().map(|&i| self.nodes[i].value.cols()).sum();
        let mut out = self.spare(r * c);
        for row in 0..r {
            for &i in &ids {
                let v = &self.nodes[i].value;
                assert_eq!(v.rows(), r, "concat_cols: row counts differ");
                out.extend_from_slice(v.row(row));
            }
        }
        self.push(Op::ConcatCols { parts: ids }, Tensor::new(r, c, out))
    }
}

/// `−(1/κ) log Σ exp(−κ xᵢ)`, shifted by the minimum so no exponential overflows: the value of
/// [`Tape::soft_min`].
pub fn soft_min_value(x: &[f64], kappa: f64) -> f64 {
    let m = x.iter().copied().fold(f64::INFINITY, f64::min);
    let sum: f64 = x.iter().map(|&xi| (-kappa * (xi - m)).exp()).sum();
    m - sum.ln() / kappa
}

/// The gradient of [`soft_min_value`]: the softmax weights `exp(−κ(xᵢ − s))`, summing to 1.
pub fn soft_min_weights(x: &[f64], kappa: f64) -> Vec<f64> {
    let s = soft_min_value(x, kappa);
    x.iter().map(|&xi| (-kappa * (xi - s)).exp()).collect()
}
