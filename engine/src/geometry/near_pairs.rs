//! A second, tighter level under the Verlet list: the listed pairs whose gap was below `gap` at
//! the last filtering. Between two neighbour-list builds the force stage scans only these, and
//! filters the full list again when particles may have closed the margin.
//!
//! Why: a Verlet list must hold every pair that may touch before the next rebuild, so with a
//! skin of 0.1 d it lists about 4.7 pairs per sphere in a dense gas, of which a few percent
//! touch; scanning them all every step was the largest cost of a DEM step. The near level keeps
//! the pairs within a much smaller margin (a fraction of the skin) and is refreshed from the full
//! list every few steps, which costs one scan of the list, instead of every step.
//!
//! It is exact, by the same argument as the Verlet skin: a pair left out had a gap of at least
//! `gap` at filtering; since then each particle moved by at most `moved` (the sum over steps of
//! the largest displacement in the step) and the periodic images by the change of box lengths
//! and Lees-Edwards offset, so while `2 moved + changes < gap` the pair cannot touch. Filtering
//! never moves a particle, so when it happens does not change the result.

use super::Domain;
use crate::math::{Real, Vec3};

/// One pair of the near level: its index in the neighbour list, its particles and image.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NearPair {
    /// Index of the pair in the neighbour list.
    pub q: u32,
    /// First particle.
    pub i: u32,
    /// Second particle.
    pub j: u32,
    /// Periodic image of j seen by i.
    pub image: [i8; 3],
}

/// The near level, one list per block of particles (pairs in neighbour-list order).
#[derive(Debug, Clone, Default)]
pub struct NearPairs {
    /// Pairs per block.
    pub blocks: Vec<Vec<NearPair>>,
    /// Margin: pairs with `|r_i - r_j| < R_i + R_j + gap` at filtering are kept, m.
    pub gap: Real,
    /// Number of filterings so far.
    pub filters: u64,
    moved: Real,
    stale: bool,
    ref_offset: Real,
    ref_len: Vec3,
}

impl NearPairs {
    /// An empty near level for `blocks` blocks with margin `gap` (m); stale until filtered.
    pub fn new(blocks: usize, gap: Real) -> Self {
        Self { blocks: vec![Vec::new(); blocks], gap, stale: true, ..Default::default() }
    }

    /// Records that no particle moved by more than `distance` (m) since the last call.
    #[inline]
    pub fn add_motion(&mut self, distance: Real) {
        self.moved += distance;
    }

    /// Forces a filtering at the next force evaluation (the list was rebuilt, or particles were
    /// moved from outside).
    pub fn invalidate(&mut self) {
        self.stale = true;
    }

    /// True if a pair left out at the last filtering may touch now.
    pub fn is_stale(&self, domain: &Domain) -> bool {
        if self.stale {
            return true;
        }
        let mut closing = 2.0 * self.moved;
        if domain.shifted_images() {
            closing += (domain.le_offset - self.ref_offset).abs();
        }
        for a in 0..domain.dim {
            if domain.periodic[a] {
                closing += (domain.length(a) - self.ref_len[a]).abs();
            }
        }
        // A relative margin far above rounding (positions ~1e-16 relative) and far below any use.
        closing.is_nan() || closing >= (1.0 - 1e-9) * self.gap
    }

    /// Marks the level as filtered now (the caller has refilled `blocks`).
    pub fn filtered(&mut self, domain: &Domain) {
        self.stale = false;
        self.moved = 0.0;
        self.ref_offset = domain.le_offset;
        self.ref_len = domain.hi - domain.lo;
        self.filters += 1;
    }

    /// Number of pairs held.
    pub fn len(&self) -> usize {
        self.blocks.iter().map(Vec::len).sum()
    }

    /// True if no pair is held.
    pub fn is_empty(&self) -> bool {
        self.blocks.iter().all(Vec::is_empty)
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.blocks.iter().map(|b| b.capacity() * std::mem::size_of::<NearPair>()).sum::<usize>()
            + self.blocks.capacity() * std::mem::size_of::<Vec<NearPair>>()
    }
}
