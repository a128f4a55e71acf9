//! What an interacting pair carries from one step to the next, stored densely.
//!
//! Only a few percent of the pairs of a Verlet list touch at any time (about 2% in the standard
//! benchmark), so the springs and forces live in one compact record per interacting pair rather
//! than in arrays indexed by the list: the force stage then reads and writes them as a stream
//! instead of one cache miss per contact, and memory follows the number of contacts, not the
//! number of listed pairs. Records are grouped by the block of particles that owns the pair's
//! first particle and sorted by pair index within a block, so the force stage finds the record of
//! a touching pair by a merge walk, and a neighbour rebuild only renumbers them.

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

/// One interacting pair (touching, or held by a capillary bridge) at the last force evaluation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct PairContact {
    /// Index of the pair in the current neighbour list.
    pub q: u32,
    /// First particle (i < j).
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Tangential spring, m.
    pub xi: Vec3,
    /// Rolling spring and bridge state.
    pub extra: PairExtra,
    /// Force on i and torques, at the last evaluation.
    pub out: ContactOutput,
}

/// Renumbers the records after the neighbour list was rebuilt. Particle indices do not change
/// at a rebuild, so each record keeps its block; a pair that is no longer listed (it cannot
/// interact any more) is dropped. Order within a block is kept, since pair indices follow (i, j).
pub(crate) fn renumber(blocks: &mut [Vec<PairContact>], nl: &NeighborList) {
    use rayon::prelude::*;
    blocks.par_iter_mut().for_each(|list| {
        list.retain_mut(|c| match nl.find(c.i, c.j) {
            Some(q) => {
                c.q = q as u32;
                true
            }
            None => false,
        });
    });
}
