//! Sparse Cholesky (`LLᵀ`) of the Newton matrix with faer's supernodal factorization: symbolic
//! analysis (elimination tree, column counts, supernodes) once per model, a numeric factorization
//! per Newton iteration. The pattern is already in its fill-reducing order
//! ([`super::ordering`]), so neither the matrix nor the right-hand sides are permuted (faer's
//! general entry point permutes the values on every factorization: 7% of its time at n = 40).
//! Everything runs sequentially (`Par::Seq`), so results do not depend on the thread count.

use super::assembly::Pattern;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::simplicial::{
    prefactorize_symbolic_cholesky, prefactorize_symbolic_cholesky_scratch,
};
use faer::sparse::linalg::cholesky::supernodal::{
    factorize_supernodal_numeric_llt, factorize_supernodal_numeric_llt_scratch,
    factorize_supernodal_symbolic_cholesky, factorize_supernodal_symbolic_cholesky_scratch,
    SupernodalLltRef, SymbolicSupernodalCholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

/// A Cholesky factorization of matrices with one pattern.
pub struct Factor {
    symbolic: SymbolicSupernodalCholesky<usize>,
    l_values: Vec<f64>,
    factored: bool,
    /// Scratch of the numeric factorization, kept between iterations (its contents do not
    /// matter; allocating it per iteration was 4% of a 40 × 40 rollout).
    scratch: MemBuffer,
}

impl Factor {
    /// The symbolic analysis of `pattern`'s matrix (its lower triangle in its own order).
    pub fn new(pattern: &Pattern) -> Factor {
        let n = pattern.n_dof;
        let lower =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        // faer's symbolic analysis reads the upper triangle: the lower one's rows are its columns.
        let (_, _, col_ptr, _, row_idx) = lower
            .to_row_major()
            .expect("transposing the pattern")
            .into_parts();
        let upper = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let mut etree = vec![0isize; n];
        let mut col_counts = vec![0usize; n];
        let mut buf = MemBuffer::new(StackReq::any_of(&[
            prefactorize_symbolic_cholesky_scratch::<usize>(n, row_idx.len()),
            factorize_supernodal_symbolic_cholesky_scratch::<usize>(n),
        ]));
        let etree = prefactorize_symbolic_cholesky(
            &mut etree,
            &mut col_counts,
            upper,
            MemStack::new(&mut buf),
        );
        let symbolic = factorize_supernodal_symbolic_cholesky(
            upper,
            etree,
            &col_counts,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .expect("symbolic Cholesky analysis of a valid pattern");
        let l_values = vec![0.0; symbolic.len_val()];
        let scratch = MemBuffer::new(factorize_supernodal_numeric_llt_scratch::<usize, f64>(
            &symbolic,
            Par::Seq,
            Default::default(),
        ));
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
        let ok = factorize_supernodal_numeric_llt::<usize, f64>(
            &mut self.l_values,
            SparseColMatRef::new(sym, values),
            LltRegularization::default(),
            &self.symbolic,
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
        SupernodalLltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
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
