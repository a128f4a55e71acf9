//! Contact between grains and with walls, found at the nodes of the grid (the multi-field
//! method of the sources: the habilitation N 1.2.2; Nezamabadi et al., Comput. Phys. Commun.
//! 237, 17, 2019) and acting at the grains' outer material points, solved by the shared
//! contact solver ([`crate::nscd`]).
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
//! (or the wall's plane). Only the node of each column within half a cell of the interface
//! along the normal is a contact: two grains share three rows of nodes around their interface
//! (quadratic splines reach a cell and a half), and a contact in every row locks a layer a
//! cell thick into a rigid punch.
//!
//! **Where a contact acts.** On each grain, at the centre of the point that sets its extent
//! (its depth along the normal), placed across the normal where the column's material is (the
//! mass-weighted mean: a column at a grain's edge holds material on one side of its node
//! only). The contact's velocity there is `Σ N_k(x_s) v_k` over the grain's nodes and its
//! impulse goes to them by the same weights ([`Support`]), so that the point that would pass
//! the other member moves with the constrained velocity. Two other places were tried and
//! measured on a disk squeezed between walls and on 16 disks pressed to 100 kPa (the grains of
//! `scenes/mpm_biaxial_2d.json`):
//! - the node's own velocity (the sources' nodal contact): the point clouds pass through each
//!   other and the walls while the nodes stay apart; the 16 disks reached Φ = 0.97 at 22 kPa
//!   with 7% of the box covered twice or beyond a wall;
//! - the grain's surface in the column (the point's extent, half a point spacing further out):
//!   exact on a flat face (a squeezed block's force within 0.25%), but on a round grain the
//!   wall crushes the outer points, which take the constraint through nodes that carry almost
//!   no mass, instead of pushing the grain (a disk squeezed to 10% pressed back at 3% of the
//!   force): the same 7%.
//!
//! At the points' centres the 16 disks stop at Φ = 0.838 at 99 kPa with 0.8% interpenetration;
//! the price is a boundary layer: the wall's traction reaches the outer quarter cell through
//! the grid (a squeezed block's force 0.8% off at ten cells, 4% for a law that yields).
//!
//! **Signorini condition.** On the relative normal velocity at the step's end:
//! `U_n >= min(0, (−gap + Δe) / h)`, `Δe` how much the two points' half extents along `n`
//! grew over the step at the Newton iterate (they shrink under compression, and the surfaces
//! then meet after the centres have closed the gap and that much more). A contact with a
//! positive gap may close it within the step and no more (CD's near pairs), and no contact
//! pushes the grains apart (no restitution: grains rebound by their elasticity). The growth is
//! taken at the first iterations of a step and then kept (`system::GROWTH_ITERATIONS`): a
//! target moving with every iterate kept a dense packing's Newton iterations from converging.
//! Without it, the lag of the surface behind the centre made a squeezed block's force 2.1%
//! high.
//!
//! **Where pressed grains still overlap (open, issue 25).** A step keeps its prediction —
//! measured on the 12-grain CI compaction, the contacts' overlaps at the step's end, predicted
//! from the converged velocities and the points' final extents, were those at its start to
//! within 0.5% — but the gap is measured anew at the next step from the points then in the
//! column: as grains slide and turn, points enter and leave a column and the outermost one
//! changes, and the measured gap jumps both ways by a fraction of a point spacing. With a
//! bound that never pushes apart this is a ratchet: a gap that jumps open is closed within the
//! step, one that jumps shut is kept. Summed over the contacts and the run, the jumps shut came
//! to 0.054 m and the contacts born already overlapping (a new node takes over a column as the
//! interface moves) to 0.072 m, against an overlap at the contacts of 0.006 m at the end (177
//! contacts, 37 µm each, a third of a point spacing). Pushing an overlap beyond a tenth of a
//! point spacing apart at a fiftieth per step (`cd`'s gap restoration) ended the ratchet on
//! the CI compaction (Φ 0.90 at 850 kPa with 0.7% of the box covered twice, against 415 kPa
//! and 2.6%; mean aspect ratio 1.13, against 1.07), but on the 300-grain compaction it turned
//! the same noise into energy — 7 J/m created against 23 J/m stored at Φ 0.905 — and a Newton
//! matrix lost its definiteness there after 23 minutes; 0.1 and 0.2 a step inverted points of
//! the CI compaction. So it was not kept: the measure itself must stop jumping. A gap between
//! the levels where each grain's interpolated density `Σ N_i m_i / h²` crosses half its
//! material's (smooth as points move) was tried on the CI compaction and was worse: 3.6% at
//! Φ 0.90, and 0.8% already at Φ 0.73 where the extents give 0.1% — that level lies inside the
//! round grains' outer points. So was a gap carried from step to step by the contact's
//! prediction (measured only when a contact is born): 3.6% at Φ 0.90, 0.3% already at Φ 0.67
//! — the samples' relative motion is not the surfaces', and the difference accumulates
//! unseen. So was a column whose surface is the lower envelope of the points' caps
//! (`ξ − e + a²/2e` for a point `a` across the column's line, continuous as points move):
//! 3.9% at Φ 0.90, 0.45% already at Φ 0.67 — a cap is rounder than the point's square, and
//! the corners between columns overlap. So were points as ellipses of their own area (`F`
//! of the disk of radius `side0 / √π`) for the gap — where the column's line crosses them —
//! and for the interpenetration raster alike: 4.3% at Φ 0.90, 0.3% at Φ 0.67. Still to try:
//! contacts per outer point (each point of a grain's surface against the other grain's
//! surface near it) instead of per column, so that no point enters or leaves a contact's
//! measure while the contact lasts.
//!
//! **Delassus operator.** A contact's velocity answers an impulse through its grain's Newton
//! matrix: `u = u_free + Hᵀ A⁻¹ H P`, `H` its weights. For each grain the block of
//! `Hᵀ A⁻¹ H` between its contacts' samples is computed with its factorised matrix, so that
//! every impulse a contact changes updates the velocities of all the samples of its grains at
//! once (the exact coupling through the grain's stiffness, not the nodes' mass alone). The
//! solver's local problems see the diagonal of each contact's block in its frame, and its
//! sweeps converge to the solution of the full coupled problem (each visit reads the
//! velocities the other contacts left).

use super::banded::dot;
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
    /// Grain `grain` at its surface sample `slot`.
    Grain {
        /// Grain index.
        grain: u32,
        /// Index of the sample among the grain's ([`GrainContacts::samples`]).
        slot: u32,
    },
    /// Wall `wall`.
    Wall(u32),
}

/// A point of a grain's surface where a contact acts, by the nodes of the grain's field that
/// carry it: its velocity is `Σ w_k v_k` and an impulse `P` there gives node `k` the impulse
/// `w_k P`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Support {
    /// Local nodes of the grain's field, in increasing order.
    pub nodes: [u32; 9],
    /// Weights, summing to 1.
    pub weights: [Real; 9],
    /// Entries used.
    pub len: u8,
}

impl Support {
    /// The nodes and weights.
    #[inline(always)]
    pub fn iter(&self) -> impl Iterator<Item = (usize, Real)> + '_ {
        self.nodes[..self.len as usize].iter().zip(&self.weights[..self.len as usize]).map(|(&s, &w)| (s as usize, w))
    }
}

/// The point of a grain whose surface is nearest the other member in a contact's column, and
/// its half extent along the normal at the step's start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct End {
    /// The point (index in [`Points`]); `u32::MAX` for a wall.
    pub point: u32,
    /// Its half extent along the contact's normal at the step's start, m.
    pub extent: Real,
}

impl End {
    /// A wall's end.
    pub const NONE: End = End { point: u32::MAX, extent: 0.0 };
}

/// One contact between grain `a` and a grain or a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodalContact {
    /// Grid node (linear index `i + nx j`) of the contact's column.
    pub node: usize,
    /// Where it acts, m: the surface sample of grain `a` against a wall, midway between the two
    /// grains' samples between grains.
    pub at: V2,
    /// First grain.
    pub a: u32,
    /// Its surface sample (index among the grain's [`GrainContacts::samples`]).
    pub slot: u32,
    /// Second member.
    pub b: Other,
    /// Frame; `n` points from `b` towards `a`.
    pub frame: ContactFrame,
    /// Gap along `n` at the step's start, m (negative: overlapping extents).
    pub gap: Real,
    /// The points that set the gap, of `a` and of `b`.
    pub ends: [End; 2],
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
    /// Scratch of the grain's size in unknowns, kept between solves (the columns of
    /// [`GrainContacts::invert`], the impulses' right-hand side of a Newton update).
    pub work: Vec<Real>,
    /// Where each column of [`GrainContacts::invert`] starts in `work`, and its first row.
    pub offsets: Vec<(usize, usize)>,
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

    /// Adds to the samples' velocities what an impulse `p` at sample `l` does to them.
    #[inline(always)]
    pub fn apply(&mut self, l: usize, p: &V2) {
        let n = 2 * self.samples.len();
        let (c0, c1) = (2 * l, 2 * l + 1);
        for (k, u) in self.u.iter_mut().enumerate() {
            let (r0, r1) = (2 * k * n, (2 * k + 1) * n);
            u.x += self.inverse[r0 + c0] * p.x + self.inverse[r0 + c1] * p.y;
            u.y += self.inverse[r1 + c0] * p.x + self.inverse[r1 + c1] * p.y;
        }
    }

    /// The samples' velocities for the nodal velocities `v` plus the correction `dv` (two
    /// entries a node).
    pub fn sample_velocities(&mut self, v: &[V2], dv: &[Real]) {
        self.u.clear();
        self.u.extend(self.samples.iter().map(|s| s.iter().map(|(k, w)| (v[k] + V2::new(dv[2 * k], dv[2 * k + 1])) * w).sum::<V2>()));
    }

    /// Adds the step's impulses of the grain's contacts to the nodal right-hand side `rhs` (two
    /// entries a node), by the samples' weights.
    pub fn spread_impulses(&self, contacts: &[NodalContact], rhs: &mut [Real]) {
        for (support, &(c, is_a)) in self.samples.iter().zip(&self.entries) {
            let ct = &contacts[c as usize];
            let p = ct.frame.to_global(&ct.r) * if is_a { 1.0 } else { -1.0 };
            for (k, w) in support.iter() {
                rhs[2 * k] += w * p.x;
                rhs[2 * k + 1] += w * p.y;
            }
        }
    }

    /// Computes `inverse` from the grain's factorised matrix `A = L Lᵀ`: for each unknown of
    /// each sample the column `y = L⁻¹ b`, `b` the sample's weights on that component
    /// (forward substitution from its first row), then the entries are the dot products
    /// `y_r · y_s`. Measured on a dense 60-grain compaction, full solves (one per unknown)
    /// took 45% of the run.
    pub fn invert(&mut self, field: &Field) {
        let m = 2 * self.samples.len();
        let size = 2 * field.nodes();
        self.inverse.clear();
        self.inverse.resize(m * m, 0.0);
        let (ys, at) = (&mut self.work, &mut self.offsets);
        ys.clear();
        at.clear();
        let mut b = [(0usize, 0.0 as Real); 9];
        for col in 0..m {
            let (s, d) = (col / 2, col % 2);
            let support = &self.samples[s];
            for (e, (k, w)) in b.iter_mut().zip(support.iter()) {
                *e = (2 * k + d, w);
            }
            let offset = ys.len();
            let r = field.matrix.append_forward(&b[..support.len as usize], ys);
            at.push((offset, r));
        }
        for x in 0..m {
            let (ox, r) = at[x];
            for y in 0..=x {
                let (oy, s) = at[y];
                let from = r.max(s);
                let dot = dot(&ys[ox + from - r..ox + size - r], &ys[oy + from - s..oy + size - s]);
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
        let ua = self.grains[k.a as usize].u[k.slot as usize];
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
        self.grains[k.a as usize].apply(k.slot as usize, &p2);
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
        let turn = Turn { omega, near: k.law.target < 0.0, scale: k.scale, lever: k.lever };
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
