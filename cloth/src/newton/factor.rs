//! Sparse Cholesky (`LLᵀ`) of the Newton matrix with faer: symbolic analysis (fill-reducing
//! ordering, elimination tree) once per model, a numeric factorization per Newton iteration.
//! Everything runs sequentially (`Par::Seq`), so results do not depend on the thread count.

use super::assembly::Pattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LltRef, SymbolicCholesky};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// A Cholesky factorization of matrices with one pattern.
pub struct Factor {
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    factored: bool,
    /// Scratch of the numeric factorization, kept between iterations (its contents do not
    /// matter; allocating it per iteration was 4% of a 40 × 40 rollout).
    scratch: MemBuffer,
}

impl Factor {
    /// The symbolic analysis of `pattern`'s lower triangle.
    pub fn new(pattern: &Pattern) -> Factor {
        let n = pattern.n_dof;
        let sym =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Lower, Default::default(), Default::default())
                .expect("symbolic Cholesky analysis of a valid pattern");
        let l_values = vec![0.0; symbolic.len_val()];
        let scratch = MemBuffer::new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        );
        Factor {
            symbolic,
            l_values,
            factored: false,
            scratch,
        }
    }

    /// Factorizes the matrix with `values` in `pattern`; false if it is not positive definite.
    pub fn factorize(&mut self, pattern: &Pattern, values: &[f64]) -> bool {
        let n = pattern.n_dof;
        let sym =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        let a = SparseColMatRef::new(sym, values);
        let ok = self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.scratch),
                Default::default(),
            )
            .is_ok();
        self.factored = ok;
        ok
    }

    /// Solves `A X = B` in place for the `n × k` column-major `b` (after a successful
    /// [`Factor::factorize`]).
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) {
        assert!(
            self.factored,
            "Factor::solve_in_place before a successful factorization"
        );
        let n = self.symbolic.nrows();
        let mut buf = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        let rhs = MatMut::from_column_major_slice_mut(b, n, k);
        LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut buf),
        );
    }

    /// Bytes of the numeric factor.
    pub fn factor_bytes(&self) -> usize {
        self.l_values.len() * std::mem::size_of::<f64>()
    }
}
