//! A symmetric positive-definite sparse matrix with a fixed pattern and its Cholesky factor, by
//! faer (approximate-minimum-degree ordering, simplicial or supernodal as faer chooses): the
//! Newton matrix of one finite-element grain. The pattern — which unknowns an element couples —
//! is set once per mesh, so the ordering and the symbolic factorisation are computed once and
//! every Newton iteration only refills the values and factorises them again.
//!
//! Only the lower triangle is stored (column-compressed). The solves run on one thread: a grain's
//! matrix is small (a few hundred unknowns) and the grains are solved in parallel.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, supernodal, LltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::math::Real;

/// Why a pattern could not be analysed, or a matrix factorised.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SparseError {
    /// The symbolic analysis failed (out of memory, or an index past the matrix).
    #[error("the sparse pattern could not be analysed: {0}")]
    Pattern(String),
    /// The matrix is not numerically positive definite.
    #[error("the matrix is not positive definite")]
    NotPositiveDefinite,
}

/// A symmetric matrix of fixed pattern and its factor (module documentation).
pub struct SparseSpd {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Entries of the lower triangle, in the pattern's order.
    values: Vec<Real>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<Real>,
    factorised: bool,
    generation: u64,
    scratch: MemBuffer,
}

impl std::fmt::Debug for SparseSpd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseSpd").field("n", &self.n).field("entries", &self.values.len()).field("factorised", &self.factorised).finish()
    }
}

impl SparseSpd {
    /// A zero matrix of size `n` whose lower triangle may hold the entries `(row, col)` of
    /// `pairs` (either order; repeats are merged), with its symbolic factorisation.
    pub fn new(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Result<Self, SparseError> {
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
        for i in 0..n {
            columns[i].push(i);
        }
        for (r, c) in pairs {
            let (r, c) = (r.max(c), r.min(c));
            if r >= n {
                return Err(SparseError::Pattern(format!("entry ({r}, {c}) past the size {n}")));
            }
            columns[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for col in &mut columns {
            col.sort_unstable();
            col.dedup();
            row_idx.extend_from_slice(col);
            col_ptr.push(row_idx.len());
        }
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, Default::default(), Default::default())
            .map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        let req = symbolic
            .factorize_numeric_llt_scratch::<Real>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<Real>(1, Par::Seq));
        let scratch = MemBuffer::try_new(req).map_err(|e| SparseError::Pattern(format!("{e:?}")))?;
        let factor = vec![0.0; symbolic.len_val()];
        let values = vec![0.0; row_idx.len()];
        Ok(Self { n, col_ptr, row_idx, values, symbolic, factor, factorised: false, generation: 0, scratch })
    }

    /// Size.
    pub fn size(&self) -> usize {
        self.n
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.col_ptr.capacity() + self.row_idx.capacity()) * std::mem::size_of::<usize>()
            + (self.values.capacity() + self.factor.capacity()) * std::mem::size_of::<Real>()
    }

    /// Where entry `(row, col)` of the lower triangle (either order) is stored; `None` outside
    /// the pattern.
    pub fn slot(&self, r: usize, c: usize) -> Option<usize> {
        let (r, c) = (r.max(c), r.min(c));
        let (lo, hi) = (*self.col_ptr.get(c)?, *self.col_ptr.get(c + 1)?);
        self.row_idx[lo..hi].binary_search(&r).ok().map(|k| lo + k)
    }

    /// Sets every entry to zero.
    pub fn clear(&mut self) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        self.factorised = false;
    }

    /// Adds `v` to the entry at `slot` ([`SparseSpd::slot`]).
    #[inline(always)]
    pub fn add_at(&mut self, slot: usize, v: Real) {
        self.values[slot] += v;
    }

    /// Copies the entries into `to` (to put them back with [`SparseSpd::restore`]).
    pub fn save(&self, to: &mut Vec<Real>) {
        to.clear();
        to.extend_from_slice(&self.values);
    }

    /// Puts back entries [`SparseSpd::save`] copied (of this pattern).
    pub fn restore(&mut self, from: &[Real]) {
        self.values.copy_from_slice(from);
        self.factorised = false;
    }

    /// Entry `(row, col)` (either order; zero outside the pattern).
    pub fn get(&self, r: usize, c: usize) -> Real {
        self.slot(r, c).map_or(0.0, |s| self.values[s])
    }

    /// Sets row and column `i` to the unit vector times `diagonal` (a prescribed unknown).
    pub fn isolate(&mut self, i: usize, diagonal: Real) {
        for c in 0..=i {
            if let Some(s) = self.slot(i, c) {
                self.values[s] = 0.0;
            }
        }
        for s in self.col_ptr[i]..self.col_ptr[i + 1] {
            self.values[s] = 0.0;
        }
        if let Some(s) = self.slot(i, i) {
            self.values[s] = diagonal;
        }
    }

    /// `y = A x` (the stored lower triangle mirrored).
    pub fn multiply(&self, x: &[Real], y: &mut [Real]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.n {
            for s in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[s];
                y[r] += self.values[s] * x[c];
                if r != c {
                    y[c] += self.values[s] * x[r];
                }
            }
        }
    }

    /// Factorises the current values.
    pub fn factorise(&mut self) -> Result<(), SparseError> {
        self.factorised = false;
        self.generation += 1;
        let pattern = SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(pattern, &self.values);
        self.symbolic
            .factorize_numeric_llt::<Real>(
                &mut self.factor,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.scratch),
                Default::default(),
            )
            .map_err(|_| SparseError::NotPositiveDefinite)?;
        self.factorised = true;
        Ok(())
    }

    /// How many factorisations were begun: a factor is the same as long as this count is.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Solves `A x = b` in place with the last factorisation, for the `b.len() / size` right-hand
    /// sides stored one after the other.
    ///
    /// # Panics
    /// If the matrix was not factorised since its last change, or `b` is not a whole number of
    /// columns (both are the caller's bugs, not the input's).
    pub fn solve(&mut self, b: &mut [Real]) {
        assert!(self.factorised, "solve before factorise");
        let columns = b.len() / self.n.max(1);
        assert_eq!(columns * self.n, b.len(), "right-hand sides of the wrong length");
        if columns == 0 {
            return;
        }
        if columns > 1 {
            let req = self.symbolic.solve_in_place_scratch::<Real>(columns, Par::Seq);
            if self.scratch.len() < req.unaligned_bytes_required() {
                self.scratch = MemBuffer::new(req.or(self.symbolic.factorize_numeric_llt_scratch::<Real>(Par::Seq, Default::default())));
            }
        }
        let rhs = MatMut::from_column_major_slice_mut(b, self.n, columns);
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.scratch));
    }

    /// `y = L⁻¹ Pᵀ b` in place for the `b.len() / size` columns of `b` stored one after the
    /// other, with the last factorisation `A = P L Lᵀ Pᵀ`: for two columns `b`, `c`,
    /// `bᵀ A⁻¹ c = y_b · y_c`. Half a solve, and less: a simplicial factor's columns are visited
    /// only where `y` is not zero, which a right-hand side with a few entries (a contact's
    /// nodes) leaves on most of them.
    ///
    /// # Panics
    /// As [`SparseSpd::solve`].
    pub fn forward(&mut self, b: &mut [Real]) {
        assert!(self.factorised, "solve before factorise");
        let n = self.n;
        let columns = b.len() / n.max(1);
        assert_eq!(columns * n, b.len(), "right-hand sides of the wrong length");
        let mut first = vec![n; columns];
        if columns == 0 {
            return;
        }
        let mut x = vec![0.0; n];
        for (col, start) in b.chunks_exact_mut(n).zip(first.iter_mut()) {
            if let Some(perm) = self.symbolic.perm() {
                for (i, &f) in perm.arrays().0.iter().enumerate() {
                    x[i] = col[f];
                }
                col.copy_from_slice(&x);
            }
            *start = col.iter().position(|&v| v != 0.0).unwrap_or(n);
        }
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(symbolic) => {
                // Column j of L: its diagonal first, then the rows below it.
                let l = symbolic.factor();
                let (ptr, rows) = (l.col_ptr(), l.row_idx());
                for (col, &start) in b.chunks_exact_mut(n).zip(&first) {
                    for j in start..n {
                        if col[j] == 0.0 {
                            continue;
                        }
                        let (lo, hi) = (ptr[j], ptr[j + 1]);
                        let v = col[j] / self.factor[lo];
                        col[j] = v;
                        for s in lo + 1..hi {
                            col[rows[s]] -= self.factor[s] * v;
                        }
                    }
                }
            }
            SymbolicCholeskyRaw::Supernodal(symbolic) => {
                let req = symbolic.solve_in_place_scratch::<Real>(columns, Par::Seq);
                let mut scratch = MemBuffer::new(req);
                let rhs = MatMut::from_column_major_slice_mut(b, n, columns);
                supernodal::SupernodalLltRef::new(symbolic, &self.factor).l_solve_with_conj(
                    Conj::No,
                    rhs,
                    Par::Seq,
                    MemStack::new(&mut scratch),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1D Laplacian plus a diagonal shift, against a dense solve.
    #[test]
    fn solves_a_tridiagonal_system_and_refuses_an_indefinite_one() {
        let n = 50;
        let mut a = SparseSpd::new(n, (1..n).map(|i| (i, i - 1))).expect("pattern");
        let fill = |a: &mut SparseSpd, shift: Real| {
            a.clear();
            for i in 0..n {
                let d = a.slot(i, i).expect("diagonal");
                a.add_at(d, 2.0 + shift);
                if i > 0 {
                    let s = a.slot(i - 1, i).expect("off-diagonal");
                    a.add_at(s, -1.0);
                }
            }
        };
        fill(&mut a, 0.01);
        a.factorise().expect("positive definite");
        let x: Vec<Real> = (0..n).map(|i| (i as Real * 0.3).sin()).collect();
        let mut b = vec![0.0; 2 * n];
        a.multiply(&x, &mut b[..n]);
        a.multiply(&x.iter().map(|v| 2.0 * v).collect::<Vec<_>>(), &mut b[n..]);
        a.solve(&mut b);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-10, "{i}: {} against {}", b[i], x[i]);
            assert!((b[n + i] - 2.0 * x[i]).abs() < 1e-10);
        }
        fill(&mut a, -0.5);
        assert_eq!(a.factorise(), Err(SparseError::NotPositiveDefinite));
    }

    /// `bᵀ A⁻¹ c` from the forward halves ([`SparseSpd::forward`]) against full solves, for
    /// right-hand sides of two entries (as a contact's) on a diagonally dominant matrix coupling
    /// the nodes of a 12 × 12 grid to those two rows and columns away (a fill-reducing
    /// ordering, a simplicial factor with fill-in) and of a 60 × 60 grid (a supernodal factor).
    #[test]
    fn forward_halves_give_the_inverse_between_right_hand_sides() {
        for side in [12, 60] {
            let n = side * side;
            // Each node coupled to those up to two rows and columns away (the larger grid's
            // fill makes faer choose supernodes).
            let mut pairs = Vec::new();
            for i in 0..side {
                for j in 0..side {
                    for (di, dj) in [(0, 1), (1, -2), (1, -1), (1, 0), (1, 1), (1, 2), (0, 2), (2, -2), (2, -1), (2, 0), (2, 1), (2, 2)] {
                        let (i2, j2) = (i as i64 + di, j as i64 + dj);
                        if i2 < side as i64 && (0..side as i64).contains(&j2) {
                            pairs.push((i * side + j, (i2 * side as i64 + j2) as usize));
                        }
                    }
                }
            }
            let mut a = SparseSpd::new(n, pairs.iter().copied()).expect("pattern");
            let supernodal = matches!(a.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_));
            assert_eq!(supernodal, side == 60, "the factor's kind at {side} × {side}");
            for k in 0..n {
                let d = a.slot(k, k).expect("diagonal");
                a.add_at(d, 4.0);
            }
            for &(r, c) in &pairs {
                let s = a.slot(r, c).expect("entry");
                a.add_at(s, -0.1);
            }
            a.factorise().expect("positive definite");
            let columns = 6;
            let mut b = vec![0.0; columns * n];
            for c in 0..columns {
                b[c * n + (37 * c + 5) % n] = 1.0;
                b[c * n + (53 * c + 70) % n] = -0.5;
            }
            let mut solved = b.clone();
            a.solve(&mut solved);
            let mut halves = b.clone();
            a.forward(&mut halves);
            for x in 0..columns {
                for y in 0..columns {
                    let want: Real = (0..n).map(|k| b[x * n + k] * solved[y * n + k]).sum();
                    let got: Real = (0..n).map(|k| halves[x * n + k] * halves[y * n + k]).sum();
                    assert!((got - want).abs() < 1e-12 * want.abs().max(1e-3), "{side}: ({x}, {y}): {got} against {want}");
                }
            }
        }
    }
}
