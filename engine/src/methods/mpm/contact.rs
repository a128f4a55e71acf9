//! Contact between grains and with walls at the nodes of the grid (the multi-field method of
//! the sources: the habilitation N 1.2.2; Nezamabadi et al., Comput. Phys. Commun. 237, 17,
//! 2019), solved by the shared contact solver ([`crate::nscd`]).
//!
//! **Candidates.** Every grid node where two grains both have mass is a candidate contact
//! between them; a node of a grain within two cells and a half of a wall is one between the
//! grain and the wall. The normal, from the second member towards the first, is that of the
//! two mass fields, `n = (∇m_a − ∇m_b) / |∇m_a − ∇m_b|` (Bardenhagen et al. 2001), or the
//! wall's.
//!
//! **Gap.** Nodes are shared a cell and a half before the grains touch, so the mass fields
//! alone would make grains collide early. The gap along `n` at the node is measured from the
//! points of each grain in the node's own column (within half a cell across the normal):
//! each point covers the parallelogram its deformation gradient makes of the square it was
//! placed as, and the gap is the distance between grain `a`'s nearest extent and grain `b`'s
//! (or the wall's plane). A contact with a positive gap may close it within the step and no
//! more: the Signorini condition on the relative normal velocity at the step's end is
//! `U_n >= −gap / h` (CD's near pairs), and `U_n >= 0` once touching (no restitution: grains
//! rebound by their elasticity).
//!
//! **Which nodes, which velocity.** Two grains share three rows of nodes around their
//! interface (quadratic splines reach a cell and a half); constraining all of them locks a
//! layer a cell thick into a rigid punch. Only the node of each column within half a cell of
//! the interface along the normal is a contact: between grains, the sources' nodal contact
//! on the node's velocity. Against a wall the constraint is on the velocity of the grain's
//! *surface* in that column, `Σ N_k(x_s) v_k` at the sample `x_s` (the column's lowest
//! extent, where its material is across the normal), and the impulse goes to the nodes by
//! the same weights ([`Support`]). A constraint on the node's velocity instead lets the
//! surface lag the wall by the part of the field carried by the nodes inside: measured on a
//! block squeezed between walls, the force 8.6% low at ten cells (0.25% with the samples),
//! and the Hertz half-width 9% wide at thirty cells a radius (2% narrow with them). One
//! sample a column keeps as many constraints as the surface has nodes: a constraint at every
//! surface point (two a cell) over-constrains it (Hertz peak pressure 64% high, the
//! compaction test six times longer).
//!
//! **Delassus operator.** A node's velocity answers an impulse through its grain's Newton
//! matrix: `v = v_free + A⁻¹ Hᵀ P`. For each grain the columns of `A⁻¹` at its contact nodes
//! (every node of a surface sample's support) are computed with its factorised matrix, so
//! that every impulse a contact changes updates
//! the velocities of all the contact nodes of its grains at once (the exact coupling through
//! the grain's stiffness, not the node's mass alone). The solver's local problems see the
//! diagonal of each contact's block in its frame, and its sweeps converge to the solution of
//! the full coupled problem (each visit reads the velocities the other contacts left).

use super::field::Field;
use super::grid::V2;
use super::points::Points;
use crate::math::{Real, Vec3};
use crate::nscd::local::{Delassus, LocalLaw};
use crate::nscd::nlgs::{carry_local, visit_local, ContactProblem, Sums, Turn};
use crate::nscd::ContactFrame;

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
    /// Grain `grain` at its contact node `slot`.
    Grain {
        /// Grain index.
        grain: u32,
        /// Index of the node among the grain's contact nodes.
        slot: u32,
    },
    /// Wall `wall`.
    Wall(u32),
}

/// The contact nodes of the first grain a contact moves, with their weights: the contact's
/// velocity is `Σ w_k v_k` and its impulse `P` gives node `k` the impulse `w_k P`. One node of
/// weight 1 between grains; the stencil of the surface sample against a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Slots (indices among the grain's contact nodes).
    pub slots: [u32; 9],
    /// Weights, summing to 1.
    pub weights: [Real; 9],
    /// Entries used.
    pub len: u8,
}

impl Support {
    /// The slots and weights.
    #[inline(always)]
    pub fn iter(&self) -> impl Iterator<Item = (usize, Real)> + '_ {
        self.slots[..self.len as usize].iter().zip(&self.weights[..self.len as usize]).map(|(&s, &w)| (s as usize, w))
    }
}

/// One contact between grain `a` and a grain or a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodalContact {
    /// Grid node (linear index `i + nx j`): the shared node between grains, the node of the
    /// surface's column against a wall.
    pub node: usize,
    /// Where it acts, m: the node between grains, the surface sample against a wall.
    pub at: V2,
    /// First grain.
    pub a: u32,
    /// Its nodes.
    pub support: Support,
    /// Second member.
    pub b: Other,
    /// Frame; `n` points from `b` towards `a`.
    pub frame: ContactFrame,
    /// Gap along `n` at the step's start, m (negative: overlapping extents).
    pub gap: Real,
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
}

impl NodalContact {
    /// Key of the contact across steps (node, grains or wall), for the warm start.
    pub fn key(&self) -> (usize, u32, i64) {
        let other = match self.b {
            Other::Grain { grain, .. } => grain as i64,
            Other::Wall(w) => -1 - w as i64,
        };
        (self.node, self.a, other)
    }

    /// Whether the contact carries a compressive impulse.
    pub fn active(&self) -> bool {
        self.r.x > 0.0
    }
}

/// A grain's side of the contact problem: its contact nodes, the block of `A⁻¹` between them
/// and their velocities during the solve.
#[derive(Debug, Default, Clone)]
pub struct GrainContacts {
    /// Local node of each slot.
    pub nodes: Vec<usize>,
    /// `A⁻¹` between the slots' unknowns, `(2C)x(2C)`, row-major.
    pub inverse: Vec<Real>,
    /// Velocities of the slots during the solve, m/s.
    pub u: Vec<V2>,
    /// Contacts, sides (`true`: the grain is `a`) and weights at each slot.
    pub entries: Vec<Vec<(u32, bool, Real)>>,
    /// Slot of each local node of the grain's field (`u32::MAX`: none), for the step.
    pub slot_of: Vec<u32>,
    /// Scratch of the grain's size in unknowns, kept between solves (the columns of
    /// [`GrainContacts::invert`], the impulses' right-hand side of a Newton update).
    pub work: Vec<Real>,
    /// Where each column of [`GrainContacts::invert`] starts in `work`.
    pub offsets: Vec<usize>,
}

impl GrainContacts {
    /// Slots.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when the grain has no contact node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The slot of the grain's local node `k`, given one if it has none yet.
    pub fn slot(&mut self, k: usize) -> u32 {
        if self.slot_of[k] == u32::MAX {
            self.slot_of[k] = self.nodes.len() as u32;
            self.nodes.push(k);
            self.entries.push(Vec::new());
        }
        self.slot_of[k]
    }

    /// The 2x2 block of `A⁻¹` between slots `k` and `l`.
    #[inline(always)]
    pub fn block(&self, k: usize, l: usize) -> nalgebra::Matrix2<Real> {
        let n = 2 * self.nodes.len();
        let at = |r: usize, c: usize| self.inverse[r * n + c];
        nalgebra::Matrix2::new(at(2 * k, 2 * l), at(2 * k, 2 * l + 1), at(2 * k + 1, 2 * l), at(2 * k + 1, 2 * l + 1))
    }

    /// Adds to the slots' velocities what an impulse `p` at slot `l` does to them.
    #[inline(always)]
    pub fn apply(&mut self, l: usize, p: &V2) {
        let n = 2 * self.nodes.len();
        let (c0, c1) = (2 * l, 2 * l + 1);
        for (k, u) in self.u.iter_mut().enumerate() {
            let (r0, r1) = (2 * k * n, (2 * k + 1) * n);
            u.x += self.inverse[r0 + c0] * p.x + self.inverse[r0 + c1] * p.y;
            u.y += self.inverse[r1 + c0] * p.x + self.inverse[r1 + c1] * p.y;
        }
    }

    /// Computes `inverse` from the grain's factorised matrix `A = L Lᵀ`: for each unknown `r`
    /// of its contact nodes the column `yᵣ = L⁻¹ eᵣ` (forward substitution from row `r`), then
    /// `(A⁻¹)ᵣₛ = yᵣ · yₛ`. Measured on a dense 60-grain compaction, the full solves this
    /// replaces (one per unknown) took 45% of the run.
    pub fn invert(&mut self, field: &Field) {
        let m = 2 * self.nodes.len();
        let size = 2 * field.nodes();
        self.inverse.clear();
        self.inverse.resize(m * m, 0.0);
        let (ys, at) = (&mut self.work, &mut self.offsets);
        ys.clear();
        at.clear();
        for col in 0..m {
            let r = 2 * self.nodes[col / 2] + col % 2;
            at.push(ys.len());
            field.matrix.append_forward_unit(r, ys);
        }
        for x in 0..m {
            let r = 2 * self.nodes[x / 2] + x % 2;
            for y in 0..=x {
                let s = 2 * self.nodes[y / 2] + y % 2;
                let from = r.max(s);
                let (a, b) = (&ys[at[x] + from - r..at[x] + size - r], &ys[at[y] + from - s..at[y] + size - s]);
                let dot: Real = a.iter().zip(b).map(|(p, q)| p * q).sum();
                self.inverse[x * m + y] = dot;
                self.inverse[y * m + x] = dot;
            }
        }
    }
}

/// The contact problem of a Newton iteration, as the shared solver sweeps it.
pub struct Problem<'a> {
    /// The contacts.
    pub contacts: &'a mut [NodalContact],
    /// Each grain's side.
    pub grains: &'a mut [GrainContacts],
    /// The walls.
    pub walls: &'a [Wall],
}

impl Problem<'_> {
    /// Relative velocity of contact `c` (global), m/s.
    #[inline(always)]
    fn velocity(&self, c: usize) -> Vec3 {
        let k = &self.contacts[c];
        let side = &self.grains[k.a as usize];
        let ua: V2 = k.support.iter().map(|(s, w)| side.u[s] * w).sum();
        let ub = match k.b {
            Other::Grain { grain, slot } => self.grains[grain as usize].u[slot as usize],
            Other::Wall(w) => self.walls[w as usize].velocity,
        };
        let d = ua - ub;
        Vec3::new(d.x, d.y, 0.0)
    }

    /// Applies the global impulse `p` (on `a`, `−p` on `b`).
    #[inline(always)]
    fn apply(&mut self, c: usize, p: &Vec3) {
        let k = self.contacts[c];
        let p2 = V2::new(p.x, p.y);
        let side = &mut self.grains[k.a as usize];
        for (s, w) in k.support.iter() {
            side.apply(s, &(p2 * w));
        }
        if let Other::Grain { grain, slot } = k.b {
            self.grains[grain as usize].apply(slot as usize, &(-p2));
        }
    }
}

impl ContactProblem for Problem<'_> {
    fn len(&self) -> usize {
        self.contacts.len()
    }

    fn impulse(&self, c: usize) -> Vec3 {
        self.contacts[c].r
    }

    fn warm_start(&mut self) {
        for c in 0..self.contacts.len() {
            let k = self.contacts[c];
            if k.r != Vec3::zeros() {
                self.apply(c, &k.frame.to_global(&k.r));
            }
        }
    }

    fn visit(&mut self, c: usize, omega: Real, sums: &mut Sums) {
        let u_now = self.contacts[c].frame.to_local(&self.velocity(c));
        let k = self.contacts[c];
        let turn = Turn { omega, near: k.gap > 0.0, scale: k.scale, lever: k.lever };
        let (r, _) = visit_local(u_now, &k.w, &k.law, k.r, turn, sums);
        let dr = r - k.r;
        if dr != Vec3::zeros() {
            self.apply(c, &k.frame.to_global(&dr));
        }
        self.contacts[c].r = r;
    }

    fn carry(&mut self, c: usize, last: &mut Vec3, beta: Real) {
        let k = self.contacts[c];
        if let Some(y) = carry_local(k.r, last, beta, &k.law, || 0.0) {
            self.apply(c, &k.frame.to_global(&(y - k.r)));
            self.contacts[c].r = y;
        }
    }
}

/// The extents of the points of a stencil along a direction: the least `ξ − e` of grain `a`'s
/// points and the largest `ξ + e` of grain `b`'s, `ξ = (x_p − x_node)·n`, `e` the point's half
/// extent along `n`.
pub fn extent(points: &Points, p: usize, node: &V2, n: &V2) -> (Real, Real) {
    let xi = (points.x[p] - node).dot(n);
    let e = points.half_extent(p, n);
    (xi - e, xi + e)
}
