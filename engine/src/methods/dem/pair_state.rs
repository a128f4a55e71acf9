//! What an interacting pair carries from one step to the next, stored densely.
//!
//! Only a few percent of the pairs of a Verlet list touch at any time in a gas (about 2% in the
//! standard benchmark), and every listed pair keeps touching in a dense bed, so the springs and
//! forces live in compact lists per interacting pair rather than in arrays indexed by the list:
//! the force stage reads and writes them as streams, and memory follows the number of contacts.
//! Lists are grouped by the block of particles that owns the pair's first particle and sorted by
//! pair index within a block, so the force stage finds the springs of a touching pair by a merge
//! walk, and a neighbour rebuild only renumbers them.
//!
//! A block keeps parallel lists: the springs (the state carried to the next step,
//! double-buffered by the force stage), the rolling springs and bridges (only when a law of the
//! scene has them) and the forces of the last evaluation (read by the gather and the metrics,
//! written once a step). Keeping the forces out of the carried state halves what a step reads
//! and writes per contact, and what the contacts hold in memory. Every list is a column of one
//! field (structure of arrays): the contact laws compute a batch of pairs field by field, and
//! their results go into the lists as whole slices.

use crate::contact::ContactOutput;
use crate::geometry::NeighborList;
use crate::math::Vec3;

/// Optional pair state (rolling spring, capillary bridge), used only when a law needs it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct PairExtra {
    /// Rolling spring, rad.
    pub roll: Vec3,
    /// A capillary bridge joins the pair.
    pub bridge: bool,
}

/// A column of three components (x, y, z), one entry per pair.
pub(crate) type Columns = [Vec<f64>; 3];

fn column_bytes(c: &Columns) -> usize {
    c.iter().map(|v| v.capacity() * std::mem::size_of::<f64>()).sum()
}

fn at(c: &Columns, k: usize) -> Vec3 {
    Vec3::new(c[0][k], c[1][k], c[2][k])
}

/// The carried state of a block's interacting pairs, in pair order, field by field.
#[derive(Debug, Clone, Default)]
pub(crate) struct PairSprings {
    /// Index of each pair in the current neighbour list.
    pub q: Vec<u32>,
    /// Tangential springs, m.
    pub xi: Columns,
    /// Rolling springs and bridges (empty when no law needs them).
    pub extras: Vec<PairExtra>,
}

impl PairSprings {
    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// The spring of pair `k`, m.
    pub fn xi(&self, k: usize) -> Vec3 {
        at(&self.xi, k)
    }

    /// Empties the lists (keeping their memory).
    pub fn clear(&mut self) {
        self.q.clear();
        self.xi.iter_mut().for_each(Vec::clear);
        self.extras.clear();
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.q.capacity() * 4 + column_bytes(&self.xi) + self.extras.capacity() * std::mem::size_of::<PairExtra>()
    }
}

/// What an interacting pair (touching, or held by a capillary bridge) exerted at the last force
/// evaluation. One record per pair: the gather reads the whole of it, in order.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct PairForce {
    /// First particle (i < j).
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Force on i and torques.
    pub out: ContactOutput,
}

/// One interacting pair as the metrics and the guard read it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PairView {
    /// Index in the neighbour list.
    pub q: u32,
    /// Particles (i < j).
    pub i: u32,
    /// See `i`.
    pub j: u32,
    /// Tangential spring, m.
    pub xi: Vec3,
    /// Force and torques of the last evaluation.
    pub out: ContactOutput,
    /// Rolling spring and bridge, when the scene has them.
    pub extra: Option<PairExtra>,
}

/// The interacting pairs of one block of particles: their springs and, parallel to them, the
/// forces of the last evaluation.
#[derive(Debug, Clone, Default)]
pub(crate) struct PairBlock {
    /// Carried state.
    pub state: PairSprings,
    /// Forces of the last evaluation.
    pub forces: Vec<PairForce>,
}

impl PairBlock {
    /// Number of interacting pairs.
    pub fn len(&self) -> usize {
        self.forces.len()
    }

    /// Each pair, in order.
    pub fn pairs(&self) -> impl Iterator<Item = PairView> + '_ {
        self.forces.iter().enumerate().map(move |(k, f)| PairView {
            q: self.state.q[k],
            i: f.i,
            j: f.j,
            xi: self.state.xi(k),
            out: f.out,
            extra: self.state.extras.get(k).copied(),
        })
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.state.heap_bytes() + self.forces.capacity() * std::mem::size_of::<PairForce>()
    }
}

/// Renumbers the pairs after the neighbour list was rebuilt. Particle indices do not change at
/// a rebuild, so each pair keeps its block; a pair that is no longer listed (it cannot interact
/// any more) is dropped. Order within a block is kept, since pair indices follow (i, j).
pub(crate) fn renumber(blocks: &mut [PairBlock], nl: &NeighborList) {
    use rayon::prelude::*;
    blocks.par_iter_mut().for_each(|b| {
        let (s, f) = (&mut b.state, &mut b.forces);
        let mut kept = 0;
        for k in 0..f.len() {
            let Some(q) = nl.find(f[k].i, f[k].j) else { continue };
            s.q[kept] = q as u32;
            f[kept] = f[k];
            for a in s.xi.iter_mut() {
                a[kept] = a[k];
            }
            if !s.extras.is_empty() {
                s.extras[kept] = s.extras[k];
            }
            kept += 1;
        }
        s.q.truncate(kept);
        f.truncate(kept);
        s.xi.iter_mut().for_each(|a| a.truncate(kept));
        if !s.extras.is_empty() {
            s.extras.truncate(kept);
        }
    });
}
