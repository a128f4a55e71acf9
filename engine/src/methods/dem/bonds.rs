//! The attraction between the primaries of one aggregate in DEM (the bonded particle method's
//! soft grains, [`crate::particles::aggregate`]; the law is [`AttractionLj`],
//! Nezamabadi 2020, §1.2.1, eq. 1.12).
//!
//! The attraction is a pair force of its own, beside the contact laws: the primaries of one
//! aggregate attract at every gap up to the bond's cut-off, touching or not, and touch through
//! their material's contact law like any two particles. So the pair scan of [`super::forces`],
//! which looks only at touching pairs, is left as it is, and the bonded pairs have their own
//! list: at each neighbour build, the pairs of the Verlet list (which reaches the largest
//! cut-off, see `Dem::new`) whose two particles belong to one aggregate, grouped by the block of
//! their first particle like the contact records. Each force evaluation writes one record per
//! bonded pair within its cut-off, which the gather adds after the block's contacts (in block
//! order: the result does not depend on the number of threads), the stability guard counts in
//! the bond energy `U` of [`AttractionLj::energy`], and the contact records report with the
//! contact of the same pair, if it touches.

use rayon::prelude::*;

use super::pair_state::PairForce;
use super::tasks::PARTICLE_BLOCK;
use super::Dem;
use crate::contact::attraction_lj::AttractionLj;
use crate::contact::ContactOutput;
use crate::geometry::{Domain, NeighborList};
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// The bonded pairs of one block of particles and their forces at the last evaluation.
#[derive(Debug, Clone, Default)]
pub(crate) struct BondBlock {
    /// Index in the neighbour list of each pair whose particles share an aggregate.
    pub q: Vec<u32>,
    /// One record per listed pair attracting at the last evaluation (within its cut-off), in
    /// the order of `q`.
    pub forces: Vec<PairForce>,
    /// The index in the neighbour list of each record of `forces`.
    pub held: Vec<u32>,
    /// The smallest and largest second particle of `forces` (`(u32::MAX, 0)` for none), which
    /// the gather's reach must cover.
    pub reach: (u32, u32),
}

/// The bonded pairs of every block ([`BondBlock`]); empty in a scene without aggregates.
#[derive(Debug, Clone, Default)]
pub(crate) struct Bonds {
    pub blocks: Vec<BondBlock>,
}

impl Bonds {
    /// No aggregate in the scene.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.blocks.iter().map(|b| (b.q.capacity() + b.held.capacity()) * 4 + b.forces.capacity() * std::mem::size_of::<PairForce>()).sum()
    }

    /// Lists again, after a neighbour build, the pairs of `nl` whose particles share an
    /// aggregate; with no aggregate in `p`, leaves the list empty.
    pub fn rebuild(&mut self, nl: &NeighborList, p: &Particles) {
        if p.aggregate_count() == 0 {
            self.blocks.clear();
            return;
        }
        let n = p.len();
        self.blocks.resize_with(n.div_ceil(PARTICLE_BLOCK), BondBlock::default);
        self.blocks.par_iter_mut().enumerate().for_each(|(b, block)| {
            block.q.clear();
            block.forces.clear();
            block.held.clear();
            for i in b * PARTICLE_BLOCK..((b + 1) * PARTICLE_BLOCK).min(n) {
                let (s, e) = (nl.start[i] as usize, nl.start[i + 1] as usize);
                for (q, pr) in nl.pair[s..e].iter().enumerate() {
                    if p.bonding(i, pr.j as usize).is_some() {
                        block.q.push((s + q) as u32);
                    }
                }
            }
        });
    }

    /// Evaluates the attraction of every listed pair, with each block's reach.
    pub fn evaluate(&mut self, nl: &NeighborList, p: &Particles, domain: &Domain) {
        self.blocks.par_iter_mut().for_each(|block| {
            block.forces.clear();
            block.held.clear();
            block.reach = (u32::MAX, 0);
            for &q in &block.q {
                let Some(f) = pair_force(nl, p, domain, q as usize) else { continue };
                block.reach = (block.reach.0.min(f.j), block.reach.1.max(f.j));
                block.forces.push(f);
                block.held.push(q);
            }
        });
    }

    /// The bond energy of the listed pairs of each block, J (J/m in 2D): `U` summed over the
    /// pairs within their cut-off (negative: a bound aggregate).
    pub fn energies(&self, nl: &NeighborList, p: &Particles, domain: &Domain) -> Vec<Real> {
        self.blocks
            .par_iter()
            .map(|block| {
                block
                    .q
                    .iter()
                    .filter_map(|&q| {
                        let (bond, gap, ri, rj) = bonded_gap(nl, p, domain, q as usize)?;
                        Some(bond.energy(gap, ri, rj))
                    })
                    .sum()
            })
            .collect()
    }
}

/// The bond of listed pair `q`, its gap (m, negative in contact) and the two radii, if its
/// particles share an aggregate.
fn bonded_gap(nl: &NeighborList, p: &Particles, domain: &Domain, q: usize) -> Option<(AttractionLj, Real, Real, Real)> {
    let (i, j) = (nl.pi[q] as usize, nl.pair[q].j as usize);
    let bond = p.bonding(i, j)?.attraction;
    let (d, _) = nl.separation(q, &p.pos, domain);
    let (ri, rj) = (p.radius[i], p.radius[j]);
    Some((bond, d.norm() - ri - rj, ri, rj))
}

/// The attraction of listed pair `q` on its first particle, if within the cut-off.
fn pair_force(nl: &NeighborList, p: &Particles, domain: &Domain, q: usize) -> Option<PairForce> {
    let (i, j) = (nl.pi[q], nl.pair[q].j);
    let bond = p.bonding(i as usize, j as usize)?.attraction;
    let (d, _) = nl.separation(q, &p.pos, domain);
    let dist = d.norm();
    let (ri, rj) = (p.radius[i as usize], p.radius[j as usize]);
    let gap = dist - ri - rj;
    if gap > bond.range() || dist == 0.0 {
        return None;
    }
    // Negative: along -n, towards j.
    let force = d * (bond.force(gap, ri, rj) / dist);
    Some(PairForce { i, j, out: ContactOutput { force, torque_i: Vec3::zeros(), torque_j: Vec3::zeros() } })
}

impl Dem {
    /// The bonded pairs' attraction ([`Bonds::evaluate`]), with each block's reach widened to
    /// its bond records.
    pub(crate) fn bond_forces(&mut self) {
        self.bonds.evaluate(&self.nl, &self.w.p, &self.w.domain);
        for (r, b) in self.reach.iter_mut().zip(&self.bonds.blocks) {
            *r = (r.0.min(b.reach.0), r.1.max(b.reach.1));
        }
    }

    /// The bond energy of every bonded pair, J (J/m in 2D).
    pub(crate) fn bond_energy(&self) -> Real {
        self.bonds.energies(&self.nl, &self.w.p, &self.w.domain).iter().sum()
    }

    /// Diagonal of the bonded pairs' virial `Σ f ⊗ (r_i − r_j)` at the last evaluation, N·m
    /// (per m in 2D): summed per block, then in block order (the same for any thread count).
    pub(crate) fn bond_virial(&self) -> Vec3 {
        let per_block: Vec<Vec3> = self
            .bonds
            .blocks
            .par_iter()
            .map(|block| {
                block.forces.iter().zip(&block.held).fold(Vec3::zeros(), |acc, (f, &q)| {
                    acc + f.out.force.component_mul(&self.nl.separation(q as usize, &self.w.p.pos, &self.w.domain).0)
                })
            })
            .collect();
        per_block.iter().fold(Vec3::zeros(), |a, b| a + b)
    }

    /// The attraction of each bonded pair within its cut-off at the last evaluation: the two
    /// particles (i < j), the force on i, N, and the branch vector `r_i − r_j`, m.
    pub(crate) fn bond_records(&self) -> Vec<(u32, u32, Vec3, Vec3)> {
        let mut out = Vec::new();
        for block in &self.bonds.blocks {
            for (f, &q) in block.forces.iter().zip(&block.held) {
                let (d, _) = self.nl.separation(q as usize, &self.w.p.pos, &self.w.domain);
                out.push((f.i, f.j, f.out.force, d));
            }
        }
        out
    }
}
