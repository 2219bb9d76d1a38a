//! Sparse Cholesky (`LLᵀ`) of the Newton matrix with faer's supernodal factorization: symbolic
//! analysis (elimination tree, column counts, supernodes) once per model, a numeric factorization
//! per Newton iteration. The pattern is already in its fill-reducing order
//! ([`super::ordering`]), so neither the matrix nor the right-hand sides are permuted (faer's
//! general entry point permutes the values on every factorization: 7% of its time at n = 40).
//! Everything runs sequentially (`Par::Seq`), so results do not depend on the thread count.
//!
//! A [`Factor`] keeps the matrix of its numeric factorization: asked to factorize a matrix equal
//! bit for bit to it, it reuses the factorization without work (the same bits: the numeric
//! factorization is deterministic). A factorization can be copied out ([`Factor::current`]) and
//! put back ([`Factor::insert`]): the rollout keeps each step's final one for the implicit
//! gradient ([`super::continuation`]).
//!
//! After [`Factor::keep_on_failure`], a failed factorization leaves the last successful one in
//! place (the numeric factorization writes into a spare buffer, swapped in on success, at the
//! cost of a second factor's memory): it is the preconditioner of [`super::pcg`], which a matrix
//! that is not positive definite must not take away. A new pattern (`Factor::swap_analysis`)
//! drops it.

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

/// What a `Factor` (`cloth/src/newton/factor.rs`) has done since it was made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FactorCounts {
    /// Numeric factorizations that succeeded.
    pub factorized: usize,
    /// Numeric factorizations that stopped at a non-positive pivot (the matrix is not positive
    /// definite).
    pub failed: usize,
    /// Requests answered by a kept factorization of the same matrix, without work.
    pub reused: usize,
}

impl FactorCounts {
    /// The counts since `earlier` (an earlier reading of the same factor).
    pub fn since(self, earlier: FactorCounts) -> FactorCounts {
        FactorCounts {
            factorized: self.factorized - earlier.factorized,
            failed: self.failed - earlier.failed,
            reused: self.reused - earlier.reused,
        }
    }
}

/// One numeric factorization and the matrix it factorizes (values in the pattern, bit for bit).
#[derive(Clone, Default)]
pub struct NumericFactor {
    l_values: Vec<f64>,
    matrix: Vec<f64>,
}

impl NumericFactor {
    /// Bytes held (the factor and the matrix).
    pub fn bytes(&self) -> usize {
        (self.l_values.len() + self.matrix.len()) * std::mem::size_of::<f64>()
    }
}

/// A Cholesky factorization of matrices with one pattern.
pub struct Factor {
    symbolic: SymbolicSupernodalCholesky<usize>,
    numeric: NumericFactor,
    /// With [`Factor::keep_on_failure`]: the buffer the next numeric factorization writes into
    /// (swapped with `numeric`'s on success, so a failure keeps the last successful one).
    spare: Vec<f64>,
    keep: bool,
    /// The last factorization succeeded (or a factorization was inserted).
    valid: bool,
    /// `numeric` holds a successful factorization (perhaps of an earlier matrix than the last
    /// one asked for).
    any: bool,
    counts: FactorCounts,
    /// Scratch of the numeric factorization, kept between iterations (its contents do not
    /// matter; allocating it per iteration was 4% of a 40 × 40 rollout).
    scratch: MemBuffer,
}

impl Factor {
    /// Swaps this factor's symbolic analysis with `other`'s (of another pattern of the same
    /// degrees of freedom: self-contact's), keeping the counts; no factorization is valid after,
    /// as with a new analysis (`other` keeps nothing numeric either).
    pub(super) fn swap_analysis(&mut self, other: &mut Factor) {
        std::mem::swap(&mut self.symbolic, &mut other.symbolic);
        std::mem::swap(&mut self.scratch, &mut other.scratch);
        for f in [&mut *self, other] {
            f.numeric = NumericFactor::default();
            f.spare = Vec::new();
            (f.valid, f.any) = (false, false);
        }
    }

    /// From now on a failed factorization keeps the last successful one (for
    /// [`Factor::solve_in_place`], as a preconditioner), in a second buffer.
    pub fn keep_on_failure(&mut self) {
        self.keep = true;
    }

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
        let scratch = MemBuffer::new(factorize_supernodal_numeric_llt_scratch::<usize, f64>(
            &symbolic,
            Par::Seq,
            Default::default(),
        ));
        Factor {
            symbolic,
            numeric: NumericFactor::default(),
            spare: Vec::new(),
            keep: false,
            valid: false,
            any: false,
            counts: FactorCounts::default(),
            scratch,
        }
    }

    /// Factorizes the matrix with `values` in `pattern`; false if it is not positive definite.
    /// A matrix equal bit for bit to the current factorization's is not factorized again.
    pub fn factorize(&mut self, pattern: &Pattern, values: &[f64]) -> bool {
        if self.holds(values) {
            self.counts.reused += 1;
            self.valid = true;
            return true;
        }
        let n = pattern.n_dof;
        let sym =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        // With `keep`, into the spare (faer zeroes it first, so its old contents do not matter).
        let target = if self.keep {
            &mut self.spare
        } else {
            &mut self.numeric.l_values
        };
        target.resize(self.symbolic.len_val(), 0.0);
        let ok = factorize_supernodal_numeric_llt::<usize, f64>(
            target,
            SparseColMatRef::new(sym, values),
            LltRegularization::default(),
            &self.symbolic,
            Par::Seq,
            MemStack::new(&mut self.scratch),
            Default::default(),
        )
        .is_ok();
        self.valid = ok;
        let numeric = &mut self.numeric;
        if ok {
            if self.keep {
                std::mem::swap(&mut numeric.l_values, &mut self.spare);
            }
            self.any = true;
            numeric.matrix.clear();
            numeric.matrix.extend_from_slice(values);
            self.counts.factorized += 1;
        } else {
            // In place, the failed factorization overwrote the last good one.
            self.any &= self.keep;
            self.counts.failed += 1;
        }
        ok
    }

    /// A copy of the current factorization (after a successful [`Factor::factorize`]), to
    /// [`Factor::insert`] later.
    ///
    /// # Panics
    /// If the last factorization failed.
    pub fn current(&self) -> NumericFactor {
        assert!(self.valid, "Factor::current after a failed factorization");
        self.numeric.clone()
    }

    /// Makes `numeric` (from [`Factor::current`] of a factor of the same pattern) the current
    /// factorization, so that factorizing its matrix reuses it.
    ///
    /// # Panics
    /// If `numeric` is of another pattern.
    pub fn insert(&mut self, numeric: NumericFactor) {
        assert_eq!(
            numeric.l_values.len(),
            self.symbolic.len_val(),
            "Factor::insert of another pattern's factor"
        );
        self.numeric = numeric;
        self.valid = true;
        self.any = true;
    }

    /// The last successful factorization (or insertion) is of the matrix with `values`, bit for
    /// bit.
    pub fn holds(&self, values: &[f64]) -> bool {
        self.any && same(&self.numeric.matrix, values)
    }

    /// A successful factorization of this pattern is at hand ([`Factor::solve_in_place`] may
    /// be called), perhaps of an earlier matrix than the last one asked for.
    pub fn has_factorization(&self) -> bool {
        self.any
    }

    /// Solves `A X = B` in place for the `n × k` column-major `b` with the last successful
    /// factorization ([`Factor::factorize`] or [`Factor::insert`]), `A` its matrix: after a
    /// failed factorization, an earlier matrix's.
    ///
    /// # Panics
    /// If no factorization of this pattern has succeeded.
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) {
        assert!(
            self.any,
            "Factor::solve_in_place before a successful factorization"
        );
        let n = self.symbolic.nrows();
        let mut buf = MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq));
        let rhs = MatMut::from_column_major_slice_mut(b, n, k);
        SupernodalLltRef::new(&self.symbolic, &self.numeric.l_values).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut buf),
        );
    }

    /// The counts of factorizations and reuses so far.
    pub fn counts(&self) -> FactorCounts {
        self.counts
    }

    /// Bytes of one numeric factor.
    #[cfg(any(test, feature = "internals"))]
    pub fn factor_bytes(&self) -> usize {
        self.symbolic.len_val() * std::mem::size_of::<f64>()
    }

    /// Bytes of one [`Factor::current`]: the factor and the matrix.
    pub fn kept_bytes(&self) -> usize {
        self.numeric.bytes()
    }
}

/// `a` and `b` hold the same bits (a `−0` differs from a `+0`, and a NaN matches itself).
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}
