//! Contacts between soft grains' outlines and with walls, each grain acting through its own
//! nodes (the multi-field method of the sources, Nezamabadi 2020, §1.2.2–1.2.3), solved by the
//! shared contact solver ([`crate::nscd`]). How a method finds its contacts and which of its
//! nodes carry each one ([`Support`]) is its own ([`crate::methods::mpm::contact`],
//! [`crate::methods::fem`]); what they are once found is here.
//!
//! **Signorini condition.** On the relative normal velocity at the step's end:
//! `U_n >= (−max(gap, 0) − drift) / h`: a contact with a positive gap may close it within the
//! step and no more, one that overlaps may not overlap more (no restitution: grains rebound by
//! their elasticity). A negative drift (the outlines moved closer than the linear prediction)
//! makes the target positive: the contact then pushes its grains apart along the normal of the
//! step's start, and that push does work on the nodes although the true gap does not open.
//! The target is not capped at zero: capping it removes that work but leaves the outlines
//! overlapping several times more; holding both sides (below) removes most of the pushes.
//!
//! **Sides.** With one side held ([`Sides::One`]) only the vertices of the grain of lower index
//! are held outside the other's outline, so the other's vertices enter it, the first grain's
//! vertices then sit in the dents they left, and the contacts that push them out do work: with
//! meshed grains, more than the walls do, and the dissipated energy falls below zero. With both
//! grains' vertices held ([`Sides::Both`]) neither outline's vertices enter the other, and the
//! dissipated energy stays positive. Both is `fem`'s default. `mpm` keeps one side by default
//! for elastic grains, whose pushes and overlap are small and for which both sides cost 2.6
//! times the time; for plastic grains both sides are its default
//! ([`crate::methods::mpm::MpmParams::symmetric_contact`]). The measurements are in docs/methods/fem.md
//! and docs/methods/mpm.md ("Design measurements").
//!
//! **Criterion.** Where two outlines lie flat on each other the two sets of contacts are
//! redundant: an impulse moved from one grain's vertex to the other's nearby changes no node's
//! force, so the impulses are not unique, and a change measured on them stalls while the
//! velocities have converged. The solves therefore measure a sweep's change in the grains'
//! velocities, in the units of the correction of the Newton iteration they serve:
//! `√(ΔPᵀ W ΔP / M)` for the impulses' change `ΔP` over the sweep, the Delassus operator
//! `W = H A⁻¹ Hᵀ` and the grains' mass `M` (an upper bound of the mass-weighted root mean
//! square of the nodes' velocity change, since `A ≥ M`), relative to Newton's velocity scale.
//! [`FORCING`] then asks each solve for a hundredth of Newton's last correction in the same
//! units. Measured relative to the impulses' own size instead, the tolerance meant nothing in
//! Newton's units: the solves stopped after one sweep, and Newton's corrections, each the change
//! of that one sweep, stalled above Newton's tolerance.
//!
//! **Delassus operator.** A contact's velocity answers an impulse through its grain's Newton
//! matrix: `u = u_free + Hᵀ A⁻¹ H P`, `H` its weights. For each grain the block of
//! `Hᵀ A⁻¹ H` between its contacts' samples is computed with its factorised matrix, so that
//! every impulse a contact changes updates the velocities of all the samples of its grains at
//! once (the exact coupling through the grain's stiffness, not the nodes' mass alone). The
//! solver's local problems see the diagonal of each contact's block in its frame, and its
//! sweeps converge to the solution of the full coupled problem (each visit reads the
//! velocities the other contacts left).
//!
//! **Pairs.** The contacts of one pair of grains (or of one grain with the walls) take their
//! turn together: their normal impulses are solved exactly as one small complementarity
//! problem with every other impulse frozen ([`super::block`]), then each tangential impulse on
//! its own with its new bound. Gauss-Seidel one contact at a time crawls along the pair's own
//! slow directions: where two boundaries lie flat on each other, moving impulse from one
//! grain's nodes to the other's nearby ones, or between the nearly parallel normals of a vertex
//! in a dent's reflex corner, changes the velocities by almost nothing, and past jamming most
//! of the error such a solve leaves lies along those directions; solved pair by pair, they
//! converge in a few sweeps (docs/methods/fem.md).

use std::collections::HashMap;

use nalgebra::Vector2;
use rayon::prelude::*;

use super::block;
use super::node_block::NodeBlock;
use super::polygon::{bounding_box, nearest, Nearest};
use super::schedule::Schedule;
use super::Scheme;
use crate::math::{Real, Vec3};
use crate::nscd::local::within_disk;
use crate::nscd::local::{Delassus, LocalLaw};
use crate::nscd::nlgs::{carry_local, measure_violation, tally_change, visit_local, ContactProblem, Pass, Sums, Turn};
use crate::nscd::{ContactFrame, Nlgs, NlgsReport};

type V2 = Vector2<Real>;

/// The contact solve of a Newton iteration stops when a sweep changes the grains' velocities
/// by less than this fraction of the iteration's last correction, both relative to Newton's
/// velocity scale (module documentation; or below the settings' tolerance, if smaller).
/// Gauss-Seidel's last change understates its error when it converges slowly, as it does on a
/// dense packing: with the settings' 1e-6 alone, the Newton iterations of a dense compaction
/// converged only as fast as the sweeps they added (a ratio of 0.4 an iteration, twelve
/// iterations a step); with this forcing, 5 to 7.
pub const FORCING: Real = 0.01;

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
    pub line: Option<u32>,
    /// The segment of the other outline the contact was found against (the nearest one, or
    /// the line's; 0 for a wall): where [`measure_drifts`] measures its gap again.
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
}

/// The contact problem of a Newton iteration, as the shared solver sweeps it: colour by colour,
/// the tasks of a colour at once ([`Schedule`]).
pub struct Problem<'a> {
    /// The contacts, in the schedule's order.
    pub contacts: &'a mut [VertexContact],
    /// Each grain's side.
    pub grains: &'a mut [GrainContacts],
    /// The walls.
    pub walls: &'a [Wall],
    /// The sweeps' change measured in the grains' velocities ([`solve`]), and the schedule.
    pub metric: &'a mut Metric,
}

/// What the change of a sweep in the grains' velocities needs ([`solve`]), and the order of the
/// sweeps; a method keeps one between solves, so that its buffers are not allocated again at
/// every Newton iteration.
#[derive(Debug, Default)]
pub struct Metric {
    /// The grains' mass, kg/m.
    pub mass: Real,
    /// Newton's velocity scale, m/s.
    pub speed: Real,
    /// Each contact's impulse (global, N·s/m) and relative velocity (m/s) after the last sweep.
    last: Vec<(V2, V2)>,
    /// Each task's block of normal couplings (`n_iᵀ W n_j` between its contacts, row-major),
    /// one after the other in the schedule's order of tasks ([`block`]).
    blocks: Vec<Real>,
    /// Where each task's block starts in `blocks` (one more entry than tasks).
    block_at: Vec<usize>,
    /// The contacts' order in a sweep.
    schedule: Schedule,
}

impl Metric {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.last.capacity() * std::mem::size_of::<(V2, V2)>()
            + self.blocks.capacity() * 8
            + self.block_at.capacity() * 8
            + self.schedule.heap_bytes()
    }
}

/// A colour of a sweep with fewer contacts than this takes its turns on one thread.
const PARALLEL_CONTACTS: usize = 256;

/// Fewest tasks of a colour a thread is handed at once.
const TASKS_PER_THREAD_JOB: usize = 4;

/// A grain's sample velocities `u` changed by an impulse `p` at sample `l` (`inverse`, the grain's
/// [`GrainContacts::inverse`] over `u.len()` samples; [`GrainContacts::apply`]).
#[inline(always)]
fn apply_rows(inverse: &[Real], u: &mut [V2], l: usize, p: &V2) {
    let n = 2 * u.len();
    let (row0, row1) = inverse[2 * l * n..(2 * l + 2) * n].split_at(n);
    for ((u, a), b) in u.iter_mut().zip(row0.chunks_exact(2)).zip(row1.chunks_exact(2)) {
        u.x += a[0] * p.x + b[0] * p.y;
        u.y += a[1] * p.x + b[1] * p.y;
    }
}

impl Problem<'_> {
    /// Relative velocity of contact `c` (global), m/s.
    fn velocity(&self, c: usize) -> V2 {
        let k = &self.contacts[c];
        let ua = self.grains[k.a as usize].u[k.slot as usize];
        let ub = match k.b {
            Other::Grain { grain, slot } => self.grains[grain as usize].u[slot as usize],
            Other::Wall(w) => self.walls[w as usize].velocity,
        };
        ua - ub
    }

    /// Contact `c`'s impulse (global, N·s/m) and relative velocity (m/s).
    fn state(&self, c: usize) -> (V2, V2) {
        let k = &self.contacts[c];
        let p = k.frame.to_global(&k.r);
        (V2::new(p.x, p.y), self.velocity(c))
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
        for k in self.contacts.iter() {
            if k.r != Vec3::zeros() {
                let p = k.frame.to_global(&k.r);
                let p = V2::new(p.x, p.y);
                self.grains[k.a as usize].apply(k.slot as usize, &p);
                if let Other::Grain { grain, slot } = k.b {
                    self.grains[grain as usize].apply(slot as usize, &(-p));
                }
            }
        }
        let mut last = std::mem::take(&mut self.metric.last);
        last.clear();
        last.extend((0..self.contacts.len()).map(|c| self.state(c)));
        self.metric.last = last;
    }

    /// The colours one after the other, the tasks of a colour at once on the solve's threads,
    /// each with its grains' sample velocities taken out of their sides for the colour; what
    /// they add to the criterion is summed in the tasks' order, whatever the threads.
    fn sweep(&mut self, last: &mut [Vec3], pass: Pass) -> Sums {
        let schedule = std::mem::take(&mut self.metric.schedule);
        let mut sums = Sums::default();
        for colour in &schedule.colours {
            let tasks = &schedule.tasks[colour.clone()];
            let (Some(first), Some(end)) = (tasks.first(), tasks.last()) else { continue };
            let span = first.contacts.start..end.contacts.end;
            let colour_contacts = span.len();
            let mut contacts = &mut self.contacts[span.clone()];
            let mut lasts = &mut last[span];
            let mut jobs = Vec::with_capacity(tasks.len());
            for (k, t) in tasks.iter().enumerate() {
                let len = t.contacts.len();
                let (mine, rest) = std::mem::take(&mut contacts).split_at_mut(len);
                contacts = rest;
                let (slots, rest) = std::mem::take(&mut lasts).split_at_mut(len);
                lasts = rest;
                let task = colour.start + k;
                let block = &self.metric.blocks[self.metric.block_at[task]..self.metric.block_at[task + 1]];
                let ua = std::mem::take(&mut self.grains[t.a as usize].u);
                let ub = t.b.map(|b| std::mem::take(&mut self.grains[b as usize].u)).unwrap_or_default();
                jobs.push((Pair { a: t.a, b: t.b, ua, ub }, mine, slots, block));
            }
            let (sides, walls) = (&*self.grains, self.walls);
            let run = |(pair, contacts, slots, block): &mut (Pair, &mut [VertexContact], &mut [Vec3], &[Real])| {
                Turns { sides, walls, pair, contacts, block }.pass(slots, pass)
            };
            // A colour of few contacts is done on the calling thread: handing it out costs more
            // than it saves (the loose part of a compaction sweeps a few times a Newton iteration).
            let done: Vec<Sums> = if colour_contacts < PARALLEL_CONTACTS {
                jobs.iter_mut().map(run).collect()
            } else {
                jobs.par_iter_mut().with_min_len(TASKS_PER_THREAD_JOB).map(run).collect()
            };
            for (Pair { a, b, ua, ub }, ..) in jobs {
                self.grains[a as usize].u = ua;
                if let Some(b) = b {
                    self.grains[b as usize].u = ub;
                }
            }
            for d in done {
                sums += d;
            }
        }
        self.metric.schedule = schedule;
        if let Pass::Solve { .. } = pass {
            // `ΔPᵀ W ΔP` over the iterate's change since the last sweep (the momentum's carry
            // included): the free velocities do not change within a solve, so the change of
            // the contacts' velocities is `W ΔP`.
            let mut change2 = 0.0;
            let mut last = std::mem::take(&mut self.metric.last);
            for (c, (p0, u0)) in last.iter_mut().enumerate() {
                let (p, u) = self.state(c);
                change2 += (p - *p0).dot(&(u - *u0));
                (*p0, *u0) = (p, u);
            }
            self.metric.last = last;
            sums.change2 = change2.max(0.0);
            sums.size2 = self.metric.mass * self.metric.speed * self.metric.speed;
        }
        sums
    }
}

/// A task's grains during a colour of a sweep: grain `a`'s sample velocities and, for a task
/// between two grains, the other's (empty against the walls), taken out of their sides.
struct Pair {
    a: u32,
    b: Option<u32>,
    ua: Vec<V2>,
    ub: Vec<V2>,
}

/// One task's contacts taking their turns ([`Problem::sweep`]): `contacts` and `block` (their
/// normal couplings, empty for a task too large to take at once) the task's own, its grains'
/// velocities in `pair`, their blocks of `A⁻¹` read from `sides`.
struct Turns<'s, 'p> {
    sides: &'s [GrainContacts],
    walls: &'s [Wall],
    pair: &'p mut Pair,
    contacts: &'p mut [VertexContact],
    block: &'p [Real],
}

/// A thread's scratch for the pairs' block solves (allocated once a thread).
#[derive(Debug, Default)]
struct BlockScratch {
    u: Vec<Vec3>,
    old: Vec<Vec3>,
    q: Vec<Real>,
    x: Vec<Real>,
    solve: block::Scratch,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<BlockScratch> = std::cell::RefCell::new(BlockScratch::default());
}

impl Turns<'_, '_> {
    /// The pass over the task's contacts, `slots` their impulses after the previous sweep.
    fn pass(&mut self, slots: &mut [Vec3], pass: Pass) -> Sums {
        let mut sums = Sums::default();
        match pass {
            Pass::Solve { omega } => {
                if self.contacts.len() > 1 && !self.block.is_empty() {
                    self.visit_block(omega, &mut sums);
                } else {
                    for c in 0..self.contacts.len() {
                        self.visit_one(c, omega, &mut sums);
                    }
                }
            }
            Pass::Carry { beta } => {
                for (c, slot) in slots.iter_mut().enumerate() {
                    let k = self.contacts[c];
                    if let Some(y) = carry_local(k.r, slot, beta, &k.law, || 0.0) {
                        self.apply(c, &k.frame.to_global(&(y - k.r)));
                        self.contacts[c].r = y;
                    }
                }
            }
        }
        sums
    }

    /// The sample velocities of grain `g` (one of the task's two).
    #[inline(always)]
    fn u(&self, g: u32) -> &[V2] {
        if g == self.pair.a {
            &self.pair.ua
        } else {
            &self.pair.ub
        }
    }

    /// Relative velocity of contact `c` (global), m/s.
    #[inline(always)]
    fn velocity(&self, c: usize) -> Vec3 {
        let k = &self.contacts[c];
        let ua = self.u(k.a)[k.slot as usize];
        let ub = match k.b {
            Other::Grain { grain, slot } => self.u(grain)[slot as usize],
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
        let pair = &mut *self.pair;
        let a = pair.a;
        let (ua, ub) = (&mut pair.ua, &mut pair.ub);
        apply_rows(&self.sides[k.a as usize].inverse, if k.a == a { ua } else { ub }, k.slot as usize, &p2);
        if let Other::Grain { grain, slot } = k.b {
            let u = if grain == a { &mut pair.ua } else { &mut pair.ub };
            apply_rows(&self.sides[grain as usize].inverse, u, slot as usize, &(-p2));
        }
    }

    /// Contact `c`'s turn in a sweep ([`visit_local`]).
    fn visit_one(&mut self, c: usize, omega: Real, sums: &mut Sums) {
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

    /// The turn of the task's contacts together (module documentation, "Pairs"): their normal
    /// impulses solved exactly with the rest frozen ([`block::complementary`]), then each one's
    /// tangential impulse on its own with its new normal impulse's bound. Where the exact solve
    /// finds no solution (rounding on a singular block) each takes its own turn.
    fn visit_block(&mut self, omega: Real, sums: &mut Sums) {
        SCRATCH.with(|cell| {
            let mut guard = cell.borrow_mut();
            let scratch = &mut *guard;
            let m = self.contacts.len();
            scratch.u.clear();
            scratch.old.clear();
            for c in 0..m {
                let k = &self.contacts[c];
                scratch.u.push(k.frame.to_local(&self.velocity(c)));
                scratch.old.push(k.r);
            }
            // The normal velocities with the task's normal impulses taken out, minus the targets.
            scratch.q.clear();
            for i in 0..m {
                let row = &self.block[i * m..(i + 1) * m];
                let pushed: Real = row.iter().zip(&scratch.old).map(|(w, r)| w * r.x).sum();
                scratch.q.push(scratch.u[i].x - pushed - self.contacts[i].law.target);
            }
            scratch.x.clear();
            scratch.x.extend(scratch.old.iter().map(|r| r.x.max(0.0)));
            if !block::complementary(m, self.block, &scratch.q, &mut scratch.x, &mut scratch.solve) {
                for c in 0..m {
                    self.visit_one(c, omega, sums);
                }
                return;
            }
            let turn = |k: &VertexContact| Turn { omega, near: k.law.target < 0.0, scale: k.scale, lever: k.lever };
            for i in 0..m {
                let k = self.contacts[i];
                measure_violation(scratch.u[i].x, &k.law, &turn(&k), sums);
                let r_old = scratch.old[i].x;
                let r_n = r_old + (scratch.x[i] - r_old) * omega;
                if r_n != r_old {
                    self.apply(i, &k.frame.to_global(&Vec3::new(r_n - r_old, 0.0, 0.0)));
                }
                self.contacts[i].r.x = r_n;
            }
            for i in 0..m {
                let k = self.contacts[i];
                if k.law.friction > 0.0 || k.r.y != 0.0 {
                    let u_t = k.frame.to_local(&self.velocity(i)).y - k.w.t * k.r.y;
                    let bound = k.law.friction * k.law.contact_part(k.r.x, k.law.target).max(0.0);
                    let (sticking, _) = within_disk(-u_t / k.w.t, 0.0, bound);
                    let r_t = k.r.y + (sticking - k.r.y) * omega;
                    if r_t != k.r.y {
                        self.apply(i, &k.frame.to_global(&Vec3::new(0.0, r_t - k.r.y, 0.0)));
                    }
                    self.contacts[i].r.y = r_t;
                }
                tally_change(scratch.old[i], self.contacts[i].r, &turn(&k), sums);
            }
        });
    }
}

/// Solves the contact problem of a Newton iteration: sets each contact's Signorini target from
/// its gap and drift (a contact with a positive gap may close it within the step and no more,
/// one that overlaps may not overlap more, beyond the contact's linear prediction by its drift,
/// which may push them apart: module documentation), its Delassus diagonal and impulse scale
/// from its grains' blocks and sample velocities, then sweeps in the order of a [`Schedule`]
/// (which reorders `contacts` and renumbers `sides`' entries) ([`Nlgs::solve_problem`],
/// `mean_diameter` in m the violations' unit). A sweep's change is measured in the grains'
/// velocities (module documentation): `√(ΔPᵀ W ΔP / M)` relative to Newton's velocity scale,
/// both in `metric`.
pub fn solve(
    contacts: &mut [VertexContact],
    sides: &mut [GrainContacts],
    walls: &[Wall],
    nlgs: &mut Nlgs,
    sc: &Scheme,
    mean_diameter: Real,
    metric: &mut Metric,
) -> NlgsReport {
    metric.schedule.order(contacts, sides);
    let g = sc.gravity.norm() * sc.dt;
    for c in contacts.iter_mut() {
        let n = V2::new(c.frame.n.x, c.frame.n.y);
        c.law.target = (-c.gap.max(0.0) - c.drift) / sc.dt;
        let sa = &sides[c.a as usize];
        let mut w = sa.block(c.slot as usize, c.slot as usize);
        let ua = sa.u[c.slot as usize];
        let mut speed = ua.norm();
        let ub = match c.b {
            Other::Grain { grain, slot } => {
                let sb = &sides[grain as usize];
                w += sb.block(slot as usize, slot as usize);
                speed += sb.u[slot as usize].norm();
                sb.u[slot as usize]
            }
            Other::Wall(k) => walls[k as usize].velocity,
        };
        let t = V2::new(c.frame.t1.x, c.frame.t1.y);
        c.w = Delassus { n: n.dot(&(w * n)), t: t.dot(&(w * t)) };
        let u_n = (ua - ub).dot(&n);
        c.scale = (u_n.abs() + g + 1e-6 * speed) / c.w.n;
    }
    pair_blocks(contacts, sides, &metric.schedule, &mut metric.blocks, &mut metric.block_at);
    let mut problem = Problem { contacts, grains: sides, walls, metric };
    nlgs.solve_problem(&mut problem, sc.dt, mean_diameter)
}

/// Most contacts a task takes together ([`block`]); a task with more takes its turns contact
/// by contact.
pub const BLOCK: usize = 64;

/// Each task's block of normal couplings `n_iᵀ W n_j` between its contacts (the sum over its
/// grains of `±n_iᵀ B_g(i, j) n_j`, `B_g` the grain's block of `A⁻¹` between the two contacts'
/// samples, the sign the product of the contacts' sides), row-major, in the schedule's order of
/// tasks; an empty block for a task of one contact or of more than [`BLOCK`].
fn pair_blocks(contacts: &[VertexContact], sides: &[GrainContacts], schedule: &Schedule, blocks: &mut Vec<Real>, at: &mut Vec<usize>) {
    at.clear();
    at.push(0);
    for t in &schedule.tasks {
        let m = t.contacts.len();
        let size = if m > 1 && m <= BLOCK { m * m } else { 0 };
        at.push(at.last().copied().unwrap_or(0) + size);
    }
    blocks.clear();
    blocks.resize(at.last().copied().unwrap_or(0), 0.0);
    // Each task's block in its own slice, all tasks at once.
    let mut slices = Vec::with_capacity(schedule.tasks.len());
    let mut rest = blocks.as_mut_slice();
    for w in at.windows(2) {
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(w[1] - w[0]);
        slices.push(mine);
        rest = tail;
    }
    schedule.tasks.par_iter().zip(slices.into_par_iter()).with_min_len(16).for_each(|(t, out)| {
        if out.is_empty() {
            return;
        }
        let cs = &contacts[t.contacts.clone()];
        let m = cs.len();
        // A contact's samples: on its first grain (+), on its second (−).
        let sample = |k: &VertexContact, g: u32| -> Option<(usize, Real)> {
            if k.a == g {
                Some((k.slot as usize, 1.0))
            } else {
                match k.b {
                    Other::Grain { grain, slot } if grain == g => Some((slot as usize, -1.0)),
                    _ => None,
                }
            }
        };
        for g in std::iter::once(t.a).chain(t.b) {
            let side = &sides[g as usize];
            for (i, ki) in cs.iter().enumerate() {
                let Some((si, ai)) = sample(ki, g) else { continue };
                let ni = V2::new(ki.frame.n.x, ki.frame.n.y);
                for (j, kj) in cs.iter().enumerate().take(i + 1) {
                    let Some((sj, aj)) = sample(kj, g) else { continue };
                    let nj = V2::new(kj.frame.n.x, kj.frame.n.y);
                    let v = ai * aj * ni.dot(&(side.block(si, sj) * nj));
                    out[i * m + j] += v;
                    if i != j {
                        out[j * m + i] += v;
                    }
                }
            }
        }
    });
}

/// Where a contact may act at the start of a step (found by [`candidates`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Candidate {
    /// Vertex `k` of grain `a`'s outline near the outline of grain `b` (`b > a` unless
    /// [`Sides::Both`]).
    Grain {
        /// The vertex's grain.
        a: usize,
        /// The vertex.
        k: usize,
        /// The other grain.
        b: usize,
        /// The segment of `b`'s outline nearest the vertex, and the gap.
        near: Nearest,
        /// Whether the contact holds the vertex on the outer side of `near`'s line only: the
        /// second side of a reflex corner of `b`'s outline ([`candidates`]); otherwise its
        /// gap follows the outline's nearest segment as the grains move.
        line: bool,
    },
    /// Vertex `k` of grain `g`'s outline near wall `w`.
    Wall {
        /// The grain.
        g: usize,
        /// The vertex.
        k: usize,
        /// The wall.
        w: usize,
        /// Gap along the wall's normal, m.
        gap: Real,
    },
}

/// Which grain's vertices a pair of grains holds outside the other's outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sides {
    /// The grain of lower index's only (one pass): between two convex outlines the other
    /// grain's vertices can cross a segment by at most the sagitta of the segment's chord,
    /// but once outlines are dented they go in further, and the contacts then push back
    /// with work (module documentation).
    One,
    /// Both grains' vertices against the other's outline (two passes; no grain privileged).
    /// Where the outlines lie flat on each other the two sets of contacts are redundant: their
    /// impulses are not unique (the solve's change is measured on the velocities, [`solve`]).
    Both,
}

/// The step's candidates, in a fixed order: every vertex of an outline within `reach` (m) of the
/// outline of a grain of higher index — and, with [`Sides::Both`], of lower index — (the
/// nearest segment; pairs whose boxes come within `reach`, by a sweep along x), then every
/// vertex within `reach` of a wall.
///
/// Where the nearest segment ends at a reflex corner of the other outline (a dent: the
/// outline turns towards the vertex by more than [`REFLEX_TURN`]) and the vertex is within
/// `reach` of the segment beyond the corner, that segment's line is a second contact of the
/// vertex. Outside a dent is the intersection of the two sides' outer half-planes, so the
/// vertex must stay outside both lines: held by the nearest segment's line alone, a vertex
/// sliding past the corner went into the grain beyond it (the second contact halved the meshed
/// grains' overlap: docs/methods/fem.md). At a convex corner the outside is the union of the
/// half-planes, and the nearest segment alone is right.
pub fn candidates(shapes: &[Vec<V2>], walls: &[Wall], reach: Real, sides: Sides) -> Vec<Candidate> {
    let boxes: Vec<(V2, V2)> = shapes.iter().map(|x| bounding_box(x)).collect();
    let mut order: Vec<usize> = (0..shapes.len()).filter(|&g| !shapes[g].is_empty()).collect();
    order.sort_unstable_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x).then(a.cmp(&b)));
    let mut pairs = Vec::new();
    for (i, &a) in order.iter().enumerate() {
        for &b in &order[i + 1..] {
            if boxes[b].0.x > boxes[a].1.x + reach {
                break;
            }
            if boxes[b].0.y <= boxes[a].1.y + reach && boxes[a].0.y <= boxes[b].1.y + reach {
                pairs.push((a.min(b), a.max(b)));
            }
        }
    }
    pairs.sort_unstable();
    if sides == Sides::Both {
        pairs = pairs.into_iter().flat_map(|(a, b)| [(a, b), (b, a)]).collect();
    }
    let mut out = Vec::new();
    for (a, b) in pairs {
        let (lo, hi) = (boxes[b].0 - V2::repeat(reach), boxes[b].1 + V2::repeat(reach));
        for (k, x) in shapes[a].iter().enumerate() {
            if x.x < lo.x || x.y < lo.y || x.x > hi.x || x.y > hi.y {
                continue;
            }
            let Some(near) = nearest(&shapes[b], x) else { continue };
            if near.gap.is_nan() || near.gap > reach {
                continue;
            }
            out.push(Candidate::Grain { a, k, b, near, line: false });
            let n = shapes[b].len();
            for (corner, beyond) in [(near.segment, (near.segment + n - 1) % n), ((near.segment + 1) % n, (near.segment + 1) % n)] {
                if beyond == near.segment || !reflex(&shapes[b], corner) {
                    continue;
                }
                if let Some(side) = on_segment(&shapes[b], beyond, x).filter(|s| s.1 <= reach) {
                    out.push(Candidate::Grain { a, k, b, near: side.0, line: true });
                }
            }
        }
    }
    for (g, x) in shapes.iter().enumerate() {
        for (k, x) in x.iter().enumerate() {
            for (w, wall) in walls.iter().enumerate() {
                let gap = (x - wall.point).dot(&wall.normal);
                if gap.is_nan() || gap > reach {
                    continue;
                }
                out.push(Candidate::Wall { g, k, w, gap });
            }
        }
    }
    out
}

/// The least turn, `sin` of the angle between a corner's two sides, that makes it reflex for
/// [`candidates`]: below it the two lines nearly coincide, a second contact would be redundant
/// with the first (the solver's impulses slide between redundant contacts without end), and a
/// vertex sliding past the corner in a step goes in by at most this times its slide.
pub const REFLEX_TURN: Real = 0.02;

/// Whether vertex `k` of the counter-clockwise polygon `x` is a reflex corner: the outline turns
/// clockwise there by more than [`REFLEX_TURN`].
fn reflex(x: &[V2], k: usize) -> bool {
    let n = x.len();
    let (e1, e2) = (x[k] - x[(k + n - 1) % n], x[(k + 1) % n] - x[k]);
    let cross = e1.x * e2.y - e1.y * e2.x;
    cross < -REFLEX_TURN * e1.norm() * e2.norm()
}

/// Segment `k` of the counter-clockwise polygon `x` as seen from `at`: where `at` projects on
/// it (clamped), the outward normal, the distance from its line; and the distance from the
/// segment itself, m. `None` for a degenerate segment.
fn on_segment(x: &[V2], k: usize, at: &V2) -> Option<(Nearest, Real)> {
    let (a, b) = (x[k], x[(k + 1) % x.len()]);
    let d = b - a;
    let len = d.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    let t = ((at - a).dot(&d) / (len * len)).clamp(0.0, 1.0);
    let normal = V2::new(d.y / len, -d.x / len);
    Some((Nearest { segment: k, t, normal, gap: (at - a).dot(&normal) }, (at - (a + d * t)).norm()))
}

/// The impulses of the last solve kept for the next step's warm start, by contact key.
#[derive(Debug, Clone, Default)]
pub struct Warm(HashMap<(usize, u32, i64), Vec3>);

impl Warm {
    /// Keeps the impulses of `contacts` (those not zero), forgetting the others.
    pub fn remember(&mut self, contacts: &[VertexContact]) {
        self.0.clear();
        for c in contacts {
            if c.r != Vec3::zeros() {
                self.0.insert(c.key(), c.r);
            }
        }
    }

    /// The impulse kept for `contact`'s key, or zero.
    pub fn start(&self, contact: &VertexContact) -> Vec3 {
        self.0.get(&contact.key()).copied().unwrap_or_else(Vec3::zeros)
    }

    /// Every kept impulse with its key ([`VertexContact::key`]), in the keys' order (a saved
    /// state's).
    pub fn entries(&self) -> Vec<((usize, u32, i64), Vec3)> {
        let mut all: Vec<_> = self.0.iter().map(|(k, r)| (*k, *r)).collect();
        all.sort_unstable_by_key(|e| e.0);
        all
    }

    /// Keeps `entries` ([`Warm::entries`]) for the next step.
    pub fn restore(&mut self, entries: impl IntoIterator<Item = ((usize, u32, i64), Vec3)>) {
        self.0 = entries.into_iter().collect();
    }
}

/// The second member of a contact being entered: a grain with the support its place has on
/// it, or a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Against {
    /// Grain `grain`, its place carried by `support`.
    Grain {
        /// Grain index.
        grain: u32,
        /// The place on its outline.
        support: Support,
    },
    /// Wall index.
    Wall(u32),
}

/// A contact of the step to enter ([`enter`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// The vertex of grain `a`'s outline it is measured from.
    pub vertex: usize,
    /// The contact point, m.
    pub at: V2,
    /// First grain.
    pub a: u32,
    /// The vertex's support on grain `a`.
    pub support: Support,
    /// Second member.
    pub b: Against,
    /// Unit normal from `b` towards `a`.
    pub normal: V2,
    /// Gap along it, m.
    pub gap: Real,
    /// Friction coefficient of the pair.
    pub friction: Real,
    /// Radius of grain `a`, m.
    pub lever: Real,
    /// The segment whose line alone holds the vertex ([`VertexContact::line`]).
    pub line: Option<u32>,
    /// The segment of the other outline it was found against ([`VertexContact::segment`]).
    pub segment: u32,
}

/// Adds a contact of the step, warm-started, with its samples on its grains' sides.
pub fn enter(contacts: &mut Vec<VertexContact>, sides: &mut [GrainContacts], warm: &Warm, e: Entry) {
    let index = contacts.len() as u32;
    let b = match e.b {
        Against::Grain { grain, support } => Other::Grain { grain, slot: sides[grain as usize].push(support, index, false) },
        Against::Wall(w) => Other::Wall(w),
    };
    let slot = sides[e.a as usize].push(e.support, index, true);
    let mut contact = VertexContact {
        vertex: e.vertex,
        at: e.at,
        a: e.a,
        slot,
        b,
        frame: ContactFrame::new(2, Vec3::new(e.normal.x, e.normal.y, 0.0)),
        gap: e.gap,
        drift: 0.0,
        // The Signorini target is set by each solve ([`solve`]).
        law: LocalLaw { target: 0.0, friction: e.friction, cohesion: 0.0, viscosity: 0.0 },
        w: Delassus { n: 0.0, t: 0.0 },
        r: Vec3::zeros(),
        scale: 0.0,
        lever: e.lever,
        line: e.line,
        segment: e.segment,
    };
    contact.r = warm.start(&contact);
    contacts.push(contact);
}

/// Sets each contact's drift ([`VertexContact::drift`]) at the current iterate: `moved` each
/// grain's outline where the iterate takes it (empty for a grain without a contact),
/// `displacement(grain, support)` the iterate's displacement of a place over the step (m), the
/// walls moving at their velocity over `dt` (s).
pub fn measure_drifts(
    contacts: &mut [VertexContact],
    sides: &[GrainContacts],
    walls: &[Wall],
    moved: &[Vec<V2>],
    dt: Real,
    displacement: impl Fn(usize, &Support) -> V2,
) {
    for c in contacts {
        let n = V2::new(c.frame.n.x, c.frame.n.y);
        let x = moved[c.a as usize][c.vertex];
        let ua = displacement(c.a as usize, &sides[c.a as usize].samples[c.slot as usize]);
        let (ub, now) = match c.b {
            Other::Grain { grain, slot } => {
                let ub = displacement(grain as usize, &sides[grain as usize].samples[slot as usize]);
                let outline = &moved[grain as usize];
                let now = match c.line {
                    Some(k) => on_segment(outline, k as usize, &x).map(|s| s.0.gap),
                    None => sliding(outline, c.segment as usize, &x),
                };
                (ub, now.unwrap_or(c.gap))
            }
            Other::Wall(w) => {
                let wall = &walls[w as usize];
                let ub = wall.velocity * dt;
                (ub, (x - wall.point - ub).dot(&wall.normal))
            }
        };
        c.drift = now - (c.gap + (ua - ub).dot(&n));
    }
}

/// The gap (m) of a vertex at `x` from `outline` (moved by the iterate), for a contact found
/// against segment `own` ([`measure_drifts`]): from that segment or from a neighbour across a
/// convex corner, whichever is nearer (the outline sliding under the vertex). Not from any
/// other segment: at a reflex corner the vertex's second contact holds it on the other side's
/// line ([`candidates`]), and the gap from the outline's nearest segment jumps there: a vertex
/// moved nearer the dent's other side would see a large negative drift within a part and push
/// its grains apart fast enough for Newton to diverge (docs/methods/mpm.md).
fn sliding(outline: &[V2], own: usize, x: &V2) -> Option<Real> {
    let n = outline.len();
    let mut best = on_segment(outline, own % n, x);
    for (corner, side) in [(own % n, (own + n - 1) % n), ((own + 1) % n, (own + 1) % n)] {
        if side == own % n || reflex(outline, corner) {
            continue;
        }
        if let Some(s) = on_segment(outline, side, x) {
            if best.is_none_or(|b| s.1 < b.1) {
                best = Some(s);
            }
        }
    }
    best.map(|s| s.0.gap)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertex in a dent of the other outline touches both sides of its reflex corner; a
    /// vertex at a convex corner only the nearest side.
    #[test]
    fn a_vertex_in_a_dent_touches_both_sides_of_the_reflex_corner() {
        // Grain 1: a pentagon whose top dips to a reflex corner at the origin (vertex 3).
        let dented = vec![V2::new(-2.0, -2.0), V2::new(2.0, -2.0), V2::new(2.0, 1.0), V2::new(0.0, 0.0), V2::new(-2.0, 1.0)];
        // Grain 0: a triangle with a vertex in the dent, one by the convex corner (2, 1) and
        // one out of reach.
        let probe = vec![V2::new(0.2, 0.3), V2::new(2.3, 1.3), V2::new(1.0, 3.0)];
        let found = candidates(&[probe, dented], &[], 1.0, Sides::One);
        let of = |k: usize| -> Vec<(Nearest, bool)> {
            found
                .iter()
                .filter_map(|c| match *c {
                    Candidate::Grain { a: 0, k: v, b: 1, near, line } if v == k => Some((near, line)),
                    _ => None,
                })
                .collect()
        };
        let dent = of(0);
        assert_eq!(dent.len(), 2, "{dent:?}");
        let (near, line) = dent[0];
        assert!(!line && near.segment == 2 && (near.gap - 0.4 / 5f64.sqrt()).abs() < 1e-12, "{near:?}");
        let (side, line) = dent[1];
        assert!(line && side.segment == 3 && (side.gap - 0.8 / 5f64.sqrt()).abs() < 1e-12, "{side:?}");
        assert!((side.normal - V2::new(1.0, 2.0) / 5f64.sqrt()).norm() < 1e-12);
        assert_eq!(of(1).len(), 1, "a convex corner: {:?}", of(1));
        assert!(of(2).is_empty());
        assert_eq!(found.len(), 3);
    }

    /// A contact's gap is measured again on its own segment, or on a neighbour across a convex
    /// corner, never across a reflex one, where the outline's nearest segment would jump.
    #[test]
    fn the_gap_slides_across_convex_corners_only() {
        let dented = vec![V2::new(-2.0, -2.0), V2::new(2.0, -2.0), V2::new(2.0, 1.0), V2::new(0.0, 0.0), V2::new(-2.0, 1.0)];
        // Past the reflex corner (0, 0) the nearest segment is the dent's other side, whose
        // line the vertex is behind; the contact keeps its own segment's line.
        let x = V2::new(-0.3, 0.05);
        let near = nearest(&dented, &x).expect("nearest");
        assert!(near.segment == 3 && near.gap < 0.0, "{near:?}");
        let gap = sliding(&dented, 2, &x).expect("gap");
        assert!((gap - 0.4 / 5f64.sqrt()).abs() < 1e-12, "{gap}");
        // Past the convex corner (2, 1) it slides on to the side x = 2.
        let gap = sliding(&dented, 2, &V2::new(2.3, 0.5)).expect("gap");
        assert!((gap - 0.3).abs() < 1e-12, "{gap}");
    }

    /// One side holds only the vertices of the grain of lower index outside the other; both
    /// sides the other's vertices too, each against the nearest segment of the first.
    #[test]
    fn both_sides_hold_the_vertices_of_either_grain() {
        // Two unit squares, grain 1 shifted by (0.9, 0.2): each has one corner 0.1 inside the
        // other, and one 0.2 outside it.
        let square = |x0: Real, y0: Real| vec![V2::new(x0, y0), V2::new(x0 + 1.0, y0), V2::new(x0 + 1.0, y0 + 1.0), V2::new(x0, y0 + 1.0)];
        let shapes = [square(0.0, 0.0), square(0.9, 0.2)];
        let pairs = |sides| -> Vec<(usize, usize, usize, Real)> {
            candidates(&shapes, &[], 0.5, sides)
                .into_iter()
                .filter_map(|c| match c {
                    Candidate::Grain { a, k, b, near, line: false } => Some((a, k, b, near.gap)),
                    _ => None,
                })
                .collect()
        };
        let close = |x: Real, y: Real| (x - y).abs() < 1e-12;
        let one = pairs(Sides::One);
        assert!(one.iter().all(|&(a, _, b, _)| (a, b) == (0, 1)), "{one:?}");
        assert!(one.iter().any(|&(_, k, _, gap)| k == 2 && close(gap, -0.1)), "{one:?}");
        assert!(one.iter().any(|&(_, k, _, gap)| k == 1 && close(gap, 0.2)), "{one:?}");
        let both = pairs(Sides::Both);
        let back: Vec<_> = both.iter().filter(|&&(a, _, b, _)| (a, b) == (1, 0)).collect();
        assert_eq!(back.len(), 2, "{both:?}");
        assert!(back.iter().any(|&&(_, k, _, gap)| k == 0 && close(gap, -0.1)), "{back:?}");
        assert!(back.iter().any(|&&(_, k, _, gap)| k == 3 && close(gap, 0.2)), "{back:?}");
        assert_eq!(both.len(), one.len() + back.len());
    }
}
