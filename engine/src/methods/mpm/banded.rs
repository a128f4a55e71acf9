//! Symmetric banded matrices and their Cholesky factorisation: the linear solver of a grain's
//! Newton iterations.
//!
//! A grain's nodal unknowns, numbered along the shorter side of its box of nodes, couple only
//! within a band of `4 w + 5` unknowns (`w` nodes across: a point couples the nodes of its 3x3
//! stencil, at most two apart along each axis, two unknowns a node), so the factorisation
//! costs `n b²/2` with no fill outside the band. For the sources' grains (10–20 cells across)
//! that is well below a millisecond per grain; the matrix `M + (θh)² K` is symmetric positive
//! definite for hyperelastic laws at steps where the mass term dominates the geometric
//! stiffness, and the factorisation says so when it is not.

use crate::math::Real;

/// `Σ a_k b_k` over the shorter of the two slices, in four interleaved partial sums: a single
/// running sum waits on each addition (floating-point sums are not reordered by the compiler),
/// four let the additions overlap and vectorise. The factorisation, the solves and the contact
/// blocks spend nearly all their time here (measured: 47% of a dense compaction's run with
/// one sum).
#[inline(always)]
pub fn dot(a: &[Real], b: &[Real]) -> Real {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0 as Real; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = (acc[0] + acc[2]) + (acc[1] + acc[3]);
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// A symmetric matrix of size `n` whose entries vanish beyond `bandwidth` from the diagonal,
/// stored as its lower band row by row: entry `(i, j)`, `i - bandwidth <= j <= i`, at
/// `i (bandwidth + 1) + j + bandwidth - i`.
#[derive(Debug, Clone, Default)]
pub struct Banded {
    n: usize,
    bandwidth: usize,
    data: Vec<Real>,
}

impl Banded {
    /// Resets to an all-zero `n`x`n` matrix of half-bandwidth `bandwidth` (keeps the storage).
    pub fn reset(&mut self, n: usize, bandwidth: usize) {
        self.n = n;
        self.bandwidth = bandwidth;
        self.data.clear();
        self.data.resize(n * (bandwidth + 1), 0.0);
    }

    /// Size.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True for a 0x0 matrix.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.data.capacity() * std::mem::size_of::<Real>()
    }

    #[inline(always)]
    fn index(&self, i: usize, j: usize) -> usize {
        i * (self.bandwidth + 1) + j + self.bandwidth - i
    }

    /// Adds `v` to entry `(i, j)` of the lower triangle (`j <= i`, within the band).
    #[inline(always)]
    pub fn add_lower(&mut self, i: usize, j: usize, v: Real) {
        debug_assert!(j <= i && i - j <= self.bandwidth);
        let k = self.index(i, j);
        self.data[k] += v;
    }

    /// Whether entry `(i, j)` (either triangle) lies within the band.
    pub fn within(&self, i: usize, j: usize) -> bool {
        i.abs_diff(j) <= self.bandwidth && i.max(j) < self.n
    }

    /// Entry `(i, j)` (either triangle; zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> Real {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        if i - j > self.bandwidth {
            0.0
        } else {
            self.data[self.index(i, j)]
        }
    }

    /// Copies the entries into `to` (to [`Banded::restore`] them after a failed factorisation).
    pub fn save(&self, to: &mut Vec<Real>) {
        to.clear();
        to.extend_from_slice(&self.data);
    }

    /// Sets the entries to those [`Banded::save`]d from a matrix of the same shape.
    pub fn restore(&mut self, from: &[Real]) {
        self.data.copy_from_slice(from);
    }

    /// Multiplies the diagonal by `1 + factor` (before [`Banded::factorise`]).
    pub fn scale_diagonal(&mut self, factor: Real) {
        for i in 0..self.n {
            let k = self.index(i, i);
            self.data[k] *= 1.0 + factor;
        }
    }

    /// Factorises in place into `L` (`A = L Lᵀ`); on failure, the first row whose pivot was not
    /// positive.
    pub fn factorise(&mut self) -> Result<(), usize> {
        let bw = self.bandwidth;
        let stride = bw + 1;
        for i in 0..self.n {
            let lo = i.saturating_sub(bw);
            for j in lo..=i {
                // Σ_k L_ik L_jk over the columns both rows hold, k in [max(lo, j - bw), j).
                let k0 = lo.max(j.saturating_sub(bw));
                let ri = i * stride + bw - i;
                let rj = j * stride + bw - j;
                let s = self.data[ri + j] - dot(&self.data[ri + k0..ri + j], &self.data[rj + k0..rj + j]);
                if i == j {
                    if s.is_nan() || s <= 0.0 || s.is_infinite() {
                        return Err(i);
                    }
                    self.data[ri + i] = s.sqrt();
                } else {
                    let d = self.data[rj + j];
                    self.data[ri + j] = s / d;
                }
            }
        }
        Ok(())
    }

    /// Appends `y = L⁻¹ b` from row `r` on to `out` (after [`Banded::factorise`]), for a sparse
    /// `b` given as `(row, value)` pairs in increasing rows, `r` the first (the entries of `y`
    /// before it vanish): `n − r` values; returns `r`. With these columns, the entries of
    /// `A⁻¹` between two such vectors are the dot products `bᵀ A⁻¹ c = y_b · y_c`, at about a
    /// quarter of the cost of full solves when few are wanted.
    pub fn append_forward(&self, b: &[(usize, Real)], out: &mut Vec<Real>) -> usize {
        let bw = self.bandwidth;
        let stride = bw + 1;
        let base = out.len();
        let Some(&(r, _)) = b.first() else {
            return self.n;
        };
        debug_assert!(b.windows(2).all(|w| w[0].0 < w[1].0));
        out.reserve(self.n - r);
        let mut next = 0;
        for i in r..self.n {
            let ri = i * stride + bw - i;
            let lo = i.saturating_sub(bw).max(r);
            let s = dot(&self.data[ri + lo..ri + i], &out[base + lo - r..base + i - r]);
            let mut rhs = 0.0;
            if next < b.len() && b[next].0 == i {
                rhs = b[next].1;
                next += 1;
            }
            out.push((rhs - s) / self.data[ri + i]);
        }
        r
    }

    /// Solves `L Lᵀ x = b` in place (after [`Banded::factorise`]).
    pub fn solve(&self, x: &mut [Real]) {
        let bw = self.bandwidth;
        let stride = bw + 1;
        for i in 0..self.n {
            let lo = i.saturating_sub(bw);
            let ri = i * stride + bw - i;
            let s = dot(&self.data[ri + lo..ri + i], &x[lo..i]);
            x[i] = (x[i] - s) / self.data[ri + i];
        }
        for i in (0..self.n).rev() {
            let ri = i * stride + bw - i;
            x[i] /= self.data[ri + i];
            let xi = x[i];
            let lo = i.saturating_sub(bw);
            for (v, l) in x[lo..i].iter_mut().zip(&self.data[ri + lo..ri + i]) {
                *v -= l * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A banded matrix of size `n` and half-bandwidth `bw` with entries `entry(i, j)` in its
    /// band, and the same matrix dense.
    fn pair(n: usize, bw: usize, entry: impl Fn(usize, usize) -> Real) -> (Banded, nalgebra::DMatrix<Real>) {
        let mut a = Banded::default();
        a.reset(n, bw);
        let mut dense = nalgebra::DMatrix::<Real>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(bw)..=i {
                let v = entry(i, j);
                a.add_lower(i, j, v);
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
        }
        (a, dense)
    }

    #[test]
    fn cholesky_solves_a_banded_system() {
        let n = 40;
        let (mut a, dense) = pair(n, 5, |i, j| if i == j { 10.0 + i as Real * 0.1 } else { ((i * 7 + j * 3) % 5) as Real * 0.3 - 0.6 });
        let b: Vec<Real> = (0..n).map(|i| (i as Real * 0.37).sin()).collect();
        let mut x = b.clone();
        a.factorise().expect("positive definite");
        a.solve(&mut x);
        let r = &dense * nalgebra::DVector::from_vec(x) - nalgebra::DVector::from_vec(b);
        assert!(r.norm() < 1e-12, "residual {}", r.norm());
    }

    #[test]
    fn forward_columns_give_the_inverse() {
        let n = 30;
        let (mut a, dense) = pair(n, 4, |i, j| if i == j { 8.0 + i as Real * 0.2 } else { ((i * 5 + j * 11) % 7) as Real * 0.2 - 0.6 });
        let inv = dense.try_inverse().expect("invertible");
        a.factorise().expect("positive definite");
        // Unit vectors and combinations of a few of them (a surface sample's weights).
        let vectors: Vec<Vec<(usize, Real)>> = vec![
            vec![(3, 1.0)],
            vec![(4, 1.0)],
            vec![(17, 1.0)],
            vec![(29, 1.0)],
            vec![(5, 0.25), (9, 0.5), (13, 0.25)],
            vec![(20, 0.7), (22, 0.3)],
        ];
        let dense_of = |b: &[(usize, Real)]| {
            let mut v = nalgebra::DVector::<Real>::zeros(n);
            b.iter().for_each(|&(i, x)| v[i] = x);
            v
        };
        let mut ys = Vec::new();
        let mut at = Vec::new();
        let mut start = Vec::new();
        for b in &vectors {
            at.push(ys.len());
            start.push(a.append_forward(b, &mut ys));
        }
        for (x, bx) in vectors.iter().enumerate() {
            for (y, by) in vectors.iter().enumerate() {
                let (r, s) = (start[x], start[y]);
                let m = r.max(s);
                let dot: Real = (m..n).map(|k| ys[at[x] + k - r] * ys[at[y] + k - s]).sum();
                let exact = dense_of(bx).dot(&(&inv * dense_of(by)));
                assert!((dot - exact).abs() < 1e-14, "({x}, {y}): {dot} against {exact}");
            }
        }
    }

    #[test]
    fn an_indefinite_matrix_is_refused() {
        let mut a = Banded::default();
        a.reset(3, 1);
        a.add_lower(0, 0, 1.0);
        a.add_lower(1, 0, 2.0);
        a.add_lower(1, 1, 1.0);
        a.add_lower(2, 2, 1.0);
        assert_eq!(a.factorise(), Err(1));
    }
}
