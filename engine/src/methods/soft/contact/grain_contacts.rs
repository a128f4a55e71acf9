//! A grain's side of the contact problem ([`GrainContacts`]): the surface samples where its
//! contacts act, the block of `A⁻¹` between them (from the nodes' block a grain keeps with its
//! factor, [`NodeBlock`]), and the samples' velocities that every impulse updates during a solve.

use nalgebra::Vector2;

use super::records::{Support, VertexContact};
use crate::math::Real;
use crate::methods::soft::node_block::{Half, NodeBlock};

type V2 = Vector2<Real>;

/// A grain's side of the contact problem: the surface samples where its contacts act, the
/// block of `A⁻¹` between them and their velocities during the solve.
#[derive(Debug, Default, Clone)]
pub struct GrainContacts {
    /// The samples, one for each contact the grain takes part in.
    pub samples: Vec<Support>,
    /// The contact of each sample and the grain's side in it (`true`: the grain is `a`).
    pub entries: Vec<(u32, bool)>,
    /// `A⁻¹` between the samples' unknowns, `(2S)x(2S)`, row-major: `(Hᵀ A⁻¹ H)` for the
    /// samples' weights `H`.
    pub inverse: Vec<Real>,
    /// Velocities of the samples during the solve, m/s.
    pub u: Vec<V2>,
    /// Scratch of the grain's size in unknowns, kept between solves (the columns of `mpm`'s
    /// `invert` and of [`GrainContacts::invert_by_nodes`], the impulses' right-hand side of a
    /// Newton update).
    pub work: Vec<Real>,
    /// Where each column of `mpm`'s `invert` starts in `work`, and its first row.
    pub offsets: Vec<(usize, usize)>,
    /// `A⁻¹` between the samples' nodes, kept while the grain's factor is
    /// ([`GrainContacts::invert_by_nodes`]).
    pub nodes: NodeBlock,
}

impl GrainContacts {
    /// Samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when the grain has no contact.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Forgets the step's samples.
    pub fn clear(&mut self) {
        self.samples.clear();
        self.entries.clear();
    }

    /// Adds a sample for contact `contact` (the grain its first member when `is_a`).
    pub fn push(&mut self, support: Support, contact: u32, is_a: bool) -> u32 {
        self.samples.push(support);
        self.entries.push((contact, is_a));
        self.samples.len() as u32 - 1
    }

    /// The 2x2 block of `A⁻¹` between samples `k` and `l`.
    #[inline(always)]
    pub fn block(&self, k: usize, l: usize) -> nalgebra::Matrix2<Real> {
        let n = 2 * self.samples.len();
        let at = |r: usize, c: usize| self.inverse[r * n + c];
        nalgebra::Matrix2::new(at(2 * k, 2 * l), at(2 * k, 2 * l + 1), at(2 * k + 1, 2 * l), at(2 * k + 1, 2 * l + 1))
    }

    /// Adds to the samples' velocities what an impulse `p` at sample `l` does to them: the
    /// columns of sample `l` in [`GrainContacts::inverse`], read as its rows (the matrix is
    /// symmetric, built so to the last bit). Read down the columns, a stride of a row apart,
    /// this was two thirds of a dense plastic compaction's time (the contact sweeps' `visit`
    /// and `carry`); along the rows the same sums come out bit for bit.
    #[inline(always)]
    pub fn apply(&mut self, l: usize, p: &V2) {
        apply_rows(&self.inverse, &mut self.u, l, p);
    }

    /// The samples' velocities for the nodal velocities `v` plus the correction `dv` (two
    /// entries a node).
    pub fn sample_velocities(&mut self, v: &[V2], dv: &[Real]) {
        self.u.clear();
        self.u.extend(self.samples.iter().map(|s| s.iter().map(|(k, w)| (v[k] + V2::new(dv[2 * k], dv[2 * k + 1])) * w).sum::<V2>()));
    }

    /// Adds the step's impulses of the grain's contacts to the nodal right-hand side `rhs` (two
    /// entries a node), by the samples' weights.
    pub fn spread_impulses(&self, contacts: &[VertexContact], rhs: &mut [Real]) {
        for (support, &(c, is_a)) in self.samples.iter().zip(&self.entries) {
            let ct = &contacts[c as usize];
            let p = ct.frame.to_global(&ct.r) * if is_a { 1.0 } else { -1.0 };
            for (k, w) in support.iter() {
                rhs[2 * k] += w * p.x;
                rhs[2 * k + 1] += w * p.y;
            }
        }
    }

    /// [`GrainContacts::inverse`] from the held nodes' block ([`NodeBlock`]), which is brought
    /// up to the samples' nodes first: anew when `factor` (the generation of the grain's
    /// factorised matrix, counted by the caller) changed, otherwise only for nodes not held.
    /// `solve(cols, half)` does [`Half`]'s solve on the columns `cols`, each `unknowns` long.
    pub fn invert_by_nodes(&mut self, unknowns: usize, factor: u64, solve: impl FnMut(&mut [Real], Half)) {
        self.nodes.samples_block(&self.samples, unknowns, factor, &mut self.work, solve, &mut self.inverse);
    }
}

/// A grain's sample velocities `u` changed by an impulse `p` at sample `l` (`inverse`, the grain's
/// [`GrainContacts::inverse`] over `u.len()` samples; [`GrainContacts::apply`]).
#[inline(always)]
pub(super) fn apply_rows(inverse: &[Real], u: &mut [V2], l: usize, p: &V2) {
    let n = 2 * u.len();
    let (row0, row1) = inverse[2 * l * n..(2 * l + 2) * n].split_at(n);
    for ((u, a), b) in u.iter_mut().zip(row0.chunks_exact(2)).zip(row1.chunks_exact(2)) {
        u.x += a[0] * p.x + b[0] * p.y;
        u.y += a[1] * p.x + b[1] * p.y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// A symmetric positive definite matrix of `n` unknowns, and its Cholesky factor.
    fn spd(n: usize) -> (DMatrix<Real>, DMatrix<Real>) {
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as Real / 11.0 - 0.4);
        let a = &b * b.transpose() + DMatrix::identity(n, n) * (n as Real);
        let l = a.clone().cholesky().expect("positive definite").l();
        (a, l)
    }

    fn solver<'a>(a: &'a DMatrix<Real>, l: &'a DMatrix<Real>) -> impl FnMut(&mut [Real], Half) + 'a {
        let n = a.nrows();
        move |cols: &mut [Real], half: Half| {
            for col in cols.chunks_exact_mut(n) {
                let b = nalgebra::DVector::from_column_slice(col);
                let x = match half {
                    Half::Forward => l.solve_lower_triangular(&b).expect("regular"),
                    Half::Full => a.clone().cholesky().expect("positive definite").solve(&b),
                };
                col.copy_from_slice(x.as_slice());
            }
        }
    }

    fn support(entries: &[(u32, Real)]) -> Support {
        Support::from_entries(&mut entries.to_vec()).expect("small")
    }

    /// `Hᵀ A⁻¹ H` for the samples, directly.
    fn direct(a: &DMatrix<Real>, samples: &[Support]) -> DMatrix<Real> {
        let n = a.nrows();
        let h = DMatrix::from_fn(n, 2 * samples.len(), |r, c| {
            samples[c / 2].iter().filter(|&(k, _)| 2 * k + c % 2 == r).map(|(_, w)| w).sum::<Real>()
        });
        h.transpose() * a.clone().try_inverse().expect("regular") * h
    }

    #[test]
    fn the_samples_block_is_that_of_the_inverse_whether_nodes_are_new_held_or_dropped() {
        let (a, l) = spd(24);
        let mut side = GrainContacts::default();
        let check = |side: &GrainContacts, what: &str| {
            let want = direct(&a, &side.samples);
            let m = 2 * side.samples.len();
            for x in 0..m {
                for y in 0..m {
                    let got = side.inverse[x * m + y];
                    assert!((got - want[(x, y)]).abs() < 1e-12, "{what}: ({x}, {y}) {got} against {}", want[(x, y)]);
                    assert_eq!(got.to_bits(), side.inverse[y * m + x].to_bits(), "{what}: not symmetric at ({x}, {y})");
                }
            }
        };
        // A vertex and a place on a segment sharing a node: three nodes for two samples.
        side.push(support(&[(3, 1.0)]), 0, true);
        side.push(support(&[(3, 0.3), (4, 0.7)]), 1, false);
        side.invert_by_nodes(24, 1, solver(&a, &l));
        assert_eq!(side.nodes.len(), 2);
        check(&side, "anew");
        // The place slides on and a node is added by full solves, with the same factor.
        side.clear();
        side.push(support(&[(3, 1.0)]), 0, true);
        side.push(support(&[(4, 0.9), (5, 0.1)]), 1, false);
        side.push(support(&[(9, 1.0)]), 2, true);
        side.invert_by_nodes(24, 1, solver(&a, &l));
        assert_eq!(side.nodes.len(), 4);
        check(&side, "added");
        // Most held nodes no longer needed: they are dropped.
        side.clear();
        side.push(support(&[(11, -0.2), (10, 1.2)]), 0, true);
        side.invert_by_nodes(24, 1, solver(&a, &l));
        assert_eq!(side.nodes.len(), 2);
        check(&side, "dropped");
        // A new factor computes the block anew, from forward halves.
        let mut calls = Vec::new();
        let mut inner = solver(&a, &l);
        side.invert_by_nodes(24, 2, |cols: &mut [Real], half| {
            calls.push(half);
            inner(cols, half)
        });
        assert_eq!(calls, vec![Half::Forward]);
        check(&side, "new factor");
    }
}
