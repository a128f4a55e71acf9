//! The records of a contact that the solve and its schedule share: the walls ([`Wall`]), a
//! contact's second member ([`Other`]), the nodes that carry a contact on a grain ([`Support`]),
//! the contact itself ([`VertexContact`]), and the impulses the contacts give the walls
//! ([`wall_impulses`]).

use nalgebra::Vector2;

use crate::math::{Real, Vec3};
use crate::nscd::local::{Delassus, LocalLaw};
use crate::nscd::ContactFrame;

type V2 = Vector2<Real>;

/// A plane rigid wall: the points `x` with `(x − point)·normal >= 0` are on the grains' side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    /// A point of the plane, m.
    pub point: V2,
    /// Unit normal towards the grains.
    pub normal: V2,
    /// Velocity, m/s (imposed).
    pub velocity: V2,
    /// Friction coefficient with any grain.
    pub friction: Real,
}

/// The second member of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Other {
    /// Grain `grain` at its surface sample `slot`.
    Grain {
        /// Grain index.
        grain: u32,
        /// Index of the sample among the grain's ([`GrainContacts::samples`]).
        ///
        /// [`GrainContacts::samples`]: super::grain_contacts::GrainContacts::samples
        slot: u32,
    },
    /// Wall `wall`.
    Wall(u32),
}

/// Most nodes a [`Support`] holds: the material point method's place between two outline
/// vertices whose points' 3x3 stencils are at most a cell apart (a meshed grain's needs two).
pub const SUPPORT_NODES: usize = 16;

/// A point of a grain's surface where a contact acts, by the nodes of the grain's field that
/// carry it: its velocity is `Σ w_k v_k` and an impulse `P` there gives node `k` the impulse
/// `w_k P`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Local nodes of the grain's field, in increasing order.
    pub nodes: [u32; SUPPORT_NODES],
    /// Weights, summing to 1 (some may be negative).
    pub weights: [Real; SUPPORT_NODES],
    /// Entries used.
    pub len: u8,
}

impl Support {
    /// The nodes and weights.
    #[inline(always)]
    pub fn iter(&self) -> impl Iterator<Item = (usize, Real)> + '_ {
        self.nodes[..self.len as usize].iter().zip(&self.weights[..self.len as usize]).map(|(&s, &w)| (s as usize, w))
    }

    /// A support from `(node, weight)` entries, merging repeated nodes; `None` with more than
    /// [`SUPPORT_NODES`] nodes.
    pub fn from_entries(entries: &mut [(u32, Real)]) -> Option<Self> {
        entries.sort_unstable_by_key(|e| e.0);
        let mut s = Support { nodes: [0; SUPPORT_NODES], weights: [0.0; SUPPORT_NODES], len: 0 };
        for &(k, w) in entries.iter() {
            let n = s.len as usize;
            if n > 0 && s.nodes[n - 1] == k {
                s.weights[n - 1] += w;
            } else {
                if n == SUPPORT_NODES {
                    return None;
                }
                s.nodes[n] = k;
                s.weights[n] = w;
                s.len += 1;
            }
        }
        Some(s)
    }
}

/// One contact between grain `a` and a grain or a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexContact {
    /// The vertex of grain `a`'s outline the contact is measured from.
    pub vertex: usize,
    /// Where it is, m: midway between the vertex and its projection on the other outline or
    /// the wall (the contact point of the metrics).
    pub at: V2,
    /// First grain.
    pub a: u32,
    /// Its surface sample (index among the grain's [`GrainContacts::samples`]).
    ///
    /// [`GrainContacts::samples`]: super::grain_contacts::GrainContacts::samples
    pub slot: u32,
    /// Second member.
    pub b: Other,
    /// Frame; `n` points from `b` towards `a`.
    pub frame: ContactFrame,
    /// Gap along `n` at the step's start, m (negative: overlapping outlines).
    pub gap: Real,
    /// How much more the gap will be at the step's end than the contact's linear prediction
    /// says (m): measured at the step's first Newton iterates, the outlines moved where the
    /// iterate takes them and the gap measured anew between them (the vertex's own stretch
    /// and turn, the other outline turning and sliding under it).
    pub drift: Real,
    /// The law for the step (its `friction` the pair's coefficient).
    pub law: LocalLaw,
    /// Diagonal of the local Delassus block, 1/kg·m.
    pub w: Delassus,
    /// Impulse (local components), N·s/m.
    pub r: Vec3,
    /// Impulse scale of the criterion, N·s/m.
    pub scale: Real,
    /// Radius of grain `a`, m (the largest violation's unit).
    pub lever: Real,
    /// The segment of the other outline whose line alone holds the vertex: the second side of
    /// a reflex corner ([`candidates`]); `None` for a contact with the nearest segment or a
    /// wall.
    ///
    /// [`candidates`]: super::candidates::candidates
    pub line: Option<u32>,
    /// The segment of the other outline the contact was found against (the nearest one, or
    /// the line's; 0 for a wall): where [`measure_drifts`] measures its gap again.
    ///
    /// [`measure_drifts`]: super::drift::measure_drifts
    pub segment: u32,
}

impl VertexContact {
    /// Key of the contact across steps (vertex, grains or wall, and whether it is a reflex
    /// corner's second side), for the warm start.
    pub fn key(&self) -> (usize, u32, i64) {
        let other = match self.b {
            Other::Grain { grain, .. } if self.line.is_some() => grain as i64 + (1 << 32),
            Other::Grain { grain, .. } => grain as i64,
            Other::Wall(w) => -1 - w as i64,
        };
        (self.vertex, self.a, other)
    }

    /// Whether the contact carries a compressive impulse.
    pub fn active(&self) -> bool {
        self.r.x > 0.0
    }
}

/// The impulse the grains gave each wall through `contacts` (N·s/m), into `out` (one a wall).
pub fn wall_impulses(contacts: &[VertexContact], out: &mut [V2]) {
    out.iter_mut().for_each(|p| *p = V2::zeros());
    for c in contacts {
        if let Other::Wall(k) = c.b {
            let p = c.frame.to_global(&c.r);
            out[k as usize] -= V2::new(p.x, p.y);
        }
    }
}
