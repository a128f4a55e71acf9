//! The block of a grain's `A⁻¹` between the nodes its contacts' samples rest on, kept while
//! the grain keeps its factorised matrix: the samples' block ([`GrainContacts::inverse`]) is
//! assembled from it by the samples' weights.
//!
//! A sample is a node (a grain's own boundary vertex) or a place on a boundary segment (the
//! other grain's vertex against it: two nodes). Held between nodes rather than samples, the
//! block needs no new solve when a vertex slides along a segment (its weights change, its nodes
//! do not) nor when a contact that ended comes back, and with both grains' vertices held
//! ([`super::contact::Sides::Both`]) a node carries two samples where boundaries lie flat on
//! each other, so that a new block takes half the forward solves and a quarter of the dot
//! products. A node new to a block kept with the same factor is added with full solves of its
//! two columns (its entries against every held node read off them).
//!
//! [`GrainContacts::inverse`]: super::contact::GrainContacts::inverse

use super::contact::records::Support;
use crate::math::Real;

/// Which solve [`GrainContacts::invert_by_nodes`] asks its caller for, in place on columns of
/// the grain's unknowns stored one after the other (each projected on the grain's free
/// unknowns by the caller, before and after).
///
/// [`GrainContacts::invert_by_nodes`]: super::contact::GrainContacts::invert_by_nodes
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Half {
    /// `y = L⁻¹ Pᵀ b` for the factorisation `A = P L Lᵀ Pᵀ`: `bᵀ A⁻¹ c = y_b · y_c`.
    Forward,
    /// `x = A⁻¹ b`.
    Full,
}

/// `A⁻¹` between held nodes (module documentation).
#[derive(Debug, Default, Clone)]
pub struct NodeBlock {
    /// The generation of the factor it was computed with (the caller's count).
    factor: Option<u64>,
    /// The held nodes, in the block's order.
    nodes: Vec<u32>,
    /// Each node's index in `nodes`, [`NOT_HELD`] for a node not held (as long as the grain's
    /// nodes, grown on demand).
    index: Vec<u32>,
    /// `(2H)x(2H)`, row-major, for `H` held nodes, two unknowns a node.
    inverse: Vec<Real>,
    /// The nodes the samples need, then those of them not held (scratch kept between calls).
    needed: Vec<u32>,
}

const NOT_HELD: u32 = u32::MAX;

impl NodeBlock {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.inverse.capacity() * 8 + (self.nodes.capacity() + self.index.capacity() + self.needed.capacity()) * 4
    }

    /// Nodes held.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when no node is held.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The samples' block `Hᵀ A⁻¹ H` into `out` (`(2S)x(2S)`, row-major), from the held nodes'
    /// block brought up to the samples' nodes first: anew when `factor` (the generation of the
    /// grain's factorised matrix, counted by the caller) changed, otherwise only for nodes not
    /// held. `solve(cols, half)` does [`Half`]'s solve on the columns `cols`, each `unknowns`
    /// long; `work` is scratch.
    pub fn samples_block(
        &mut self,
        samples: &[Support],
        unknowns: usize,
        factor: u64,
        work: &mut Vec<Real>,
        solve: impl FnMut(&mut [Real], Half),
        out: &mut Vec<Real>,
    ) {
        self.hold(samples, unknowns, factor, work, solve);
        self.samples_inverse(samples, out);
    }

    fn at(&self, r: usize, c: usize) -> Real {
        self.inverse[r * 2 * self.nodes.len() + c]
    }

    /// Holds the nodes of `samples` for the factor `factor`: with a new factor, all of them
    /// anew (forward halves and their dot products); with the same, only the nodes not held yet
    /// (full solves), and the held nodes no sample needs are dropped once they are more than
    /// those needed. `work` is scratch.
    fn hold(&mut self, samples: &[Support], unknowns: usize, factor: u64, work: &mut Vec<Real>, mut solve: impl FnMut(&mut [Real], Half)) {
        let nodes = unknowns / 2;
        if self.index.len() < nodes {
            self.index.resize(nodes, NOT_HELD);
        }
        let mut needed = std::mem::take(&mut self.needed);
        needed.clear();
        needed.extend(samples.iter().flat_map(|s| s.nodes[..s.len as usize].iter().copied()));
        needed.sort_unstable();
        needed.dedup();
        if self.factor != Some(factor) {
            self.factor = Some(factor);
            self.set(&needed);
            self.by_forward(unknowns, work, &mut solve);
        } else {
            let unused = self.nodes.iter().filter(|&&k| needed.binary_search(&k).is_err()).count();
            if unused > needed.len() {
                self.keep(&needed);
            }
            let index = &self.index;
            needed.retain(|&k| index[k as usize] == NOT_HELD);
            if !needed.is_empty() {
                self.add_by_solves(&needed, unknowns, work, &mut solve);
            }
        }
        self.needed = needed;
    }

    /// Holds exactly `nodes`, the block not computed.
    fn set(&mut self, nodes: &[u32]) {
        for &k in &self.nodes {
            self.index[k as usize] = NOT_HELD;
        }
        self.nodes.clear();
        self.nodes.extend_from_slice(nodes);
        for (i, &k) in self.nodes.iter().enumerate() {
            self.index[k as usize] = i as u32;
        }
        let m = 2 * self.nodes.len();
        self.inverse.clear();
        self.inverse.resize(m * m, 0.0);
    }

    /// Keeps only the held nodes among `needed` (sorted), with their block.
    fn keep(&mut self, needed: &[u32]) {
        let kept: Vec<usize> = (0..self.nodes.len()).filter(|&i| needed.binary_search(&self.nodes[i]).is_ok()).collect();
        let (m, n) = (2 * self.nodes.len(), 2 * kept.len());
        let mut inverse = vec![0.0; n * n];
        for (a, &i) in kept.iter().enumerate() {
            for (b, &j) in kept.iter().enumerate() {
                for (da, db) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    inverse[(2 * a + da) * n + 2 * b + db] = self.inverse[(2 * i + da) * m + 2 * j + db];
                }
            }
        }
        let nodes: Vec<u32> = kept.iter().map(|&i| self.nodes[i]).collect();
        self.set(&nodes);
        self.inverse = inverse;
    }

    /// The whole block from forward halves of the held nodes' columns: the dot products of
    /// [`Half::Forward`]'s columns, over the rows where they are not zero. (Full solves for
    /// `A⁻¹ b` were 35% of the dense part of a 60-grain finite-element compaction; the halves
    /// made a Newton iteration 18% cheaper, measured with `sable bench fem --grains 40 --phi
    /// 0.9` when the blocks were between samples.)
    fn by_forward(&mut self, unknowns: usize, cols: &mut Vec<Real>, solve: &mut impl FnMut(&mut [Real], Half)) {
        let m = 2 * self.nodes.len();
        cols.clear();
        cols.resize(m * unknowns, 0.0);
        for (i, &k) in self.nodes.iter().enumerate() {
            for d in 0..2 {
                cols[(2 * i + d) * unknowns + 2 * k as usize + d] = 1.0;
            }
        }
        solve(cols, Half::Forward);
        gram(cols, unknowns, m, &mut self.inverse);
    }

    /// Adds the nodes `new` (none held yet) to the block, from full solves of their columns.
    fn add_by_solves(&mut self, new: &[u32], unknowns: usize, cols: &mut Vec<Real>, solve: &mut impl FnMut(&mut [Real], Half)) {
        let c = 2 * new.len();
        cols.clear();
        cols.resize(c * unknowns, 0.0);
        for (i, &k) in new.iter().enumerate() {
            for d in 0..2 {
                cols[(2 * i + d) * unknowns + 2 * k as usize + d] = 1.0;
            }
        }
        solve(cols, Half::Full);
        let old = self.nodes.len();
        let (m, n) = (2 * old, 2 * (old + new.len()));
        let mut inverse = vec![0.0; n * n];
        for r in 0..m {
            inverse[r * n..r * n + m].copy_from_slice(&self.inverse[r * m..(r + 1) * m]);
        }
        let mut nodes = std::mem::take(&mut self.nodes);
        nodes.extend_from_slice(new);
        // Column `m + j` (a new node's unknown) against every held unknown `r`, read off its
        // solve; between two new unknowns the later column's value, mirrored, so that the block
        // stays symmetric to the last bit.
        for j in 0..c {
            let x = &cols[j * unknowns..(j + 1) * unknowns];
            for (r, &k) in nodes.iter().enumerate().flat_map(|(i, k)| [(2 * i, k), (2 * i + 1, k)]) {
                if r >= m + j {
                    break;
                }
                let v = x[2 * k as usize + r % 2];
                inverse[r * n + m + j] = v;
                inverse[(m + j) * n + r] = v;
            }
            inverse[(m + j) * n + m + j] = x[2 * nodes[(m + j) / 2] as usize + j % 2];
        }
        self.set(&nodes);
        self.inverse = inverse;
    }

    /// The samples' block `Hᵀ A⁻¹ H` into `out` (`(2S)x(2S)`, row-major), by their weights from
    /// the held nodes' block (every sample's nodes held): the lower triangle computed, the
    /// upper its mirror, so that it is symmetric to the last bit.
    fn samples_inverse(&self, samples: &[Support], out: &mut Vec<Real>) {
        let m = 2 * samples.len();
        out.clear();
        out.resize(m * m, 0.0);
        for x in 0..m {
            let (s, dx) = (&samples[x / 2], x % 2);
            for y in 0..=x {
                let (t, dy) = (&samples[y / 2], y % 2);
                let mut v = 0.0;
                for (k, wk) in s.iter() {
                    let r = 2 * self.index[k] as usize + dx;
                    for (l, wl) in t.iter() {
                        v += wk * wl * self.at(r, 2 * self.index[l] as usize + dy);
                    }
                }
                out[x * m + y] = v;
                out[y * m + x] = v;
            }
        }
    }
}

/// `out = Yᵀ Y` (`m x m`, row-major) for the `m` columns `cols` of `unknowns` entries each,
/// row by row of `Y` over the columns not zero on the row: forward halves are sparse (a column
/// of the lower factor reaches only the rows below it on its elimination path), and a loop of
/// whole dot products took as long as the halves themselves. (faer's dense product was tried:
/// once it had run, the whole program ran 2.5 times slower, the steps without a contact too —
/// measured, the cause not found.) The lower triangle is summed, the upper is its mirror.
fn gram(cols: &[Real], unknowns: usize, m: usize, out: &mut Vec<Real>) {
    out.clear();
    out.resize(m * m, 0.0);
    let mut nz: Vec<(usize, Real)> = Vec::with_capacity(m);
    for k in 0..unknowns {
        nz.clear();
        nz.extend((0..m).filter_map(|x| {
            let v = cols[x * unknowns + k];
            (v != 0.0).then_some((x, v))
        }));
        for (i, &(x, vx)) in nz.iter().enumerate() {
            let row = &mut out[x * m..(x + 1) * m];
            for &(y, vy) in &nz[..=i] {
                row[y] += vx * vy;
            }
        }
    }
    for x in 0..m {
        for y in 0..x {
            out[y * m + x] = out[x * m + y];
        }
    }
}
