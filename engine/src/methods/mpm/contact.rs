//! Contact between grains and with walls, measured between the grains' outlines
//! ([`super::outline`]) and acting through their own nodal fields, solved by the shared
//! contact solver ([`crate::nscd`]): the multi-field method of the sources (the habilitation
//! N 1.2.2; Nezamabadi et al., Comput. Phys. Commun. 237, 17, 2019) — each grain its own
//! field, so that grains touch, slide and part by contact, not through a shared grid.
//!
//! **Candidates.** Every vertex of a grain's outline within a cell of a wall, and every vertex
//! of a grain's outline within a cell of the outline of a grain of higher index (the pairs
//! whose outlines' boxes come within a cell). One side only: between two convex outlines the
//! other grain's vertices can then cross a segment by at most the sagitta of a chord a cell
//! long.
//!
//! **Gap and normal.** From the vertex to the nearest segment of the other outline, along that
//! segment's outward normal (negative inside), or to the wall's plane; the normal points from
//! the second member towards the first.
//!
//! **How a contact moves.** A vertex `x_p + F_p o` moves over a step by
//! `Σ u_i (N_i(x_p) + ∇N_i(x_p) · F_p o)` for the nodal displacements `u_i` — its point's
//! displacement and the change of its `F`, as the points are moved — so the contact's
//! velocity is `Σ w_i v_i` with those weights (on the other side the place between the
//! segment's two vertices, their weights blended), and its impulse reaches the nodes by the
//! same weights ([`Support`]): the step keeps the gap it predicts, and the contact does no
//! work its kinematics do not see. The price is the outer layer: the traction reaches the
//! grid through the outer points' fields extrapolated linearly to the outline, which with
//! quadratic splines loads the outer nodes a sixteenth more than the splines' values there,
//! and the outer points take more of the strain than the bulk (a squeezed block's wall force
//! 4.7% low at 10 cells, 3.2% at 20; an elastic disk's Hertz half-width 2.6% narrow at 20
//! cells across the radius, settling about 4.5% narrow). Measured before, with the same
//! solver:
//! - contacts on the nodes' velocities (the sources' nodal contact): the point clouds pass
//!   through each other and the walls while the nodes stay apart; 16 disks pressed to 100 kPa
//!   reached Φ = 0.97 at 22 kPa with 7% of the box covered twice or beyond a wall;
//! - one contact per node column, acting at the centre of the column's outermost point, its
//!   gap from the points' extents and their growth over the step as the target: a squeezed
//!   block within 0.8%, but pressed grains overlapped — 2.6% of the box at Φ 0.90 on the
//!   12-grain CI compaction, 3.3% at Φ 0.937 on the 300-grain one, most of the densification
//!   past Φ 0.9 — because the gap, measured anew each step from the points then in the
//!   column, jumped both ways as points entered and left it, and a bound that never pushes
//!   apart kept every jump shut (a ratchet; summed over the CI run, 0.054 m shut and 0.072 m
//!   born overlapping). Smoothed measures of the same columns (a half-density level, the
//!   envelope of the points' caps, the points as ellipses) gave 3.6 to 4.3%; pushing overlaps
//!   apart at a fiftieth a step created energy at full size (7 J/m against 23 stored).
//!
//! **Drift.** The contact's prediction is linear in the step's displacements. The outlines'
//! gap at the step's end also holds what is not: the other outline turning and sliding under
//! the vertex (a grain of the CI compaction spins up to 4,000 rad/s as the packing rearranges,
//! 0.2 rad a step: the flat faces its neighbours pressed into it come round under their
//! vertices). At the first `system::DRIFT_ITERATIONS` Newton iterates every outline
//! is moved where the iterate takes it and each contact's gap measured anew; its difference
//! from the linear prediction, the drift, joins the contact's target. Measured on the CI
//! compaction at Φ 0.90: 3.2% of the box covered twice without the drift, 0.38% with it; on the
//! 300-grain compaction 1.2% at Φ 0.93 (0.66% at Φ 0.88). Measured at every iterate instead,
//! the drift gave 0.24% on the CI compaction and 0.12% on the 300-grain one at Φ 0.88, but its
//! Newton iterations slowed (28 to 84 a step) and failed their budget there at a sixteenth of
//! the step (step 4,513). Doing a step again in halves whenever it left a contact 2% of a cell
//! deeper than allowed gave 0.25% on the CI compaction, but split the 300-grain compaction's
//! dense steps down to a sixteenth (Φ 0.84 after 11 minutes). The drift must be second order: with the contacts' impulses and velocities at the outer
//! points' centres (the outline's offset from them left to the drift, or in the velocity
//! only), the drift held most of the motion, changed after the iterates it was measured at,
//! and the CI compaction reached 3.3 to 3.6% overlap.
//!
//! **Signorini condition.** On the relative normal velocity at the step's end:
//! `U_n >= (−max(gap, 0) − drift) / h`: a contact with a positive gap may close it within the
//! step and no more, one that overlaps may not overlap more, and none pushes the grains apart
//! (no restitution: grains rebound by their elasticity).
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

/// Most nodes a [`Support`] holds: a place between two vertices whose points' 3x3 stencils
/// are at most a cell apart.
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
}

impl VertexContact {
    /// Key of the contact across steps (vertex, grains or wall), for the warm start.
    pub fn key(&self) -> (usize, u32, i64) {
        let other = match self.b {
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
        let mut b = [(0usize, 0.0 as Real); SUPPORT_NODES];
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
    pub contacts: &'a mut [VertexContact],
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
