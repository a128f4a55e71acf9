//! The contact problem of a Newton iteration and its solve (module documentation of
//! [`super`]: "Criterion", "Delassus operator", "Pairs"): each contact's Signorini target,
//! Delassus diagonal and impulse scale ([`solve`]), the pairs' blocks of normal couplings
//! (`pair_blocks`, whatever their size), and the sweeps of the shared solver ([`Problem`]),
//! colour by colour on the solve's threads in the order of a [`Schedule`].

use nalgebra::Vector2;
use rayon::prelude::*;

use super::grain_contacts::{apply_rows, GrainContacts};
use super::records::{Other, VertexContact, Wall};
use crate::math::{Real, Vec3};
use crate::methods::soft::block;
use crate::methods::soft::schedule::Schedule;
use crate::methods::soft::Scheme;
use crate::nscd::local::within_disk;
use crate::nscd::local::Delassus;
use crate::nscd::sweep::{carry_local, measure_violation, tally_change, visit_local, ContactProblem, Pass, Sums, Turn};
use crate::nscd::{Nlgs, NlgsReport};

type V2 = Vector2<Real>;

/// The contact solve of a Newton iteration stops when a sweep changes the grains' velocities
/// by less than this fraction of the iteration's last correction, both relative to Newton's
/// velocity scale ([`super`]'s documentation, "Criterion"; or below the settings' tolerance,
/// if smaller). Gauss-Seidel's last change understates its error when it converges slowly, as
/// it does on a dense packing: with the settings' 1e-6 alone, the Newton iterations of a dense
/// compaction converged only as fast as the sweeps they added (a ratio of 0.4 an iteration,
/// twelve iterations a step); with this forcing, 5 to 7.
pub const FORCING: Real = 0.01;

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
    /// Each task's block of tangential couplings (`t_iᵀ W t_j`), laid out as `blocks`; empty
    /// when no contact has friction.
    tangential: Vec<Real>,
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
            + self.tangential.capacity() * 8
            + self.block_at.capacity() * 8
            + self.schedule.heap_bytes()
    }
}

/// A colour of a sweep with fewer contacts than this takes its turns on one thread.
const PARALLEL_CONTACTS: usize = 256;

/// Fewest tasks of a colour a thread is handed at once.
const TASKS_PER_THREAD_JOB: usize = 4;

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
                let at = self.metric.block_at[task]..self.metric.block_at[task + 1];
                let block = &self.metric.blocks[at.clone()];
                let tangential = self.metric.tangential.get(at).unwrap_or_default();
                let ua = std::mem::take(&mut self.grains[t.a as usize].u);
                let ub = t.b.map(|b| std::mem::take(&mut self.grains[b as usize].u)).unwrap_or_default();
                jobs.push((Pair { a: t.a, b: t.b, ua, ub }, mine, slots, (block, tangential)));
            }
            let (sides, walls) = (&*self.grains, self.walls);
            let run = |(pair, contacts, slots, blocks): &mut Job| {
                let (block, tangential) = *blocks;
                Turns { sides, walls, pair, contacts, block, tangential }.pass(slots, pass)
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

/// A task's turn in a colour of a sweep: its grains, its contacts, their impulses after the
/// previous sweep, and its blocks of normal and tangential couplings.
type Job<'c, 'b> = (Pair, &'c mut [VertexContact], &'c mut [Vec3], (&'b [Real], &'b [Real]));

/// A task's grains during a colour of a sweep: grain `a`'s sample velocities and, for a task
/// between two grains, the other's (empty against the walls), taken out of their sides.
struct Pair {
    a: u32,
    b: Option<u32>,
    ua: Vec<V2>,
    ub: Vec<V2>,
}

/// One task's contacts taking their turns ([`Problem::sweep`]): `contacts` and `block` (their
/// normal couplings, empty for a task of one contact) and `tangential` (their tangential
/// couplings, empty without friction) the task's own, its grains' velocities in `pair`, their
/// blocks of `A⁻¹` read from `sides`.
struct Turns<'s, 'p> {
    sides: &'s [GrainContacts],
    walls: &'s [Wall],
    pair: &'p mut Pair,
    contacts: &'p mut [VertexContact],
    block: &'p [Real],
    tangential: &'p [Real],
}

/// A thread's scratch for the pairs' block solves (allocated once a thread).
#[derive(Debug, Default)]
struct BlockScratch {
    u: Vec<Vec3>,
    old: Vec<Vec3>,
    q: Vec<Real>,
    x: Vec<Real>,
    bound: Vec<Real>,
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
                    if let Some(y) = carry_local(k.r, slot, beta, &k.law) {
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

    /// The turn of the task's contacts together ([`super`]'s documentation, "Pairs"): their normal
    /// impulses solved exactly with the rest frozen ([`block::complementary`]), then their
    /// tangential impulses, with friction, exactly within their new normal impulses' bounds
    /// ([`Turns::visit_tangential_block`]). Where an exact solve finds no solution (rounding on
    /// a singular block) each contact takes its own turn.
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
            let frictional = self.contacts.iter().any(|k| k.law.friction > 0.0 || k.r.y != 0.0);
            if frictional && !self.tangential.is_empty() && self.visit_tangential_block(omega, scratch) {
                for i in 0..m {
                    let k = self.contacts[i];
                    tally_change(scratch.old[i], k.r, &turn(&k), sums);
                }
                return;
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

    /// The task's tangential impulses solved together with their new normal impulses' bounds
    /// ([`block::boxed`]; module documentation of [`super`], "Pairs"): two grains' contacts that
    /// hold the same place twice give the tangential problem the slow directions they gave the
    /// normal one. False, changing nothing, where the exact solve finds no solution.
    fn visit_tangential_block(&mut self, omega: Real, scratch: &mut BlockScratch) -> bool {
        let m = self.contacts.len();
        scratch.q.clear();
        scratch.x.clear();
        scratch.bound.clear();
        for i in 0..m {
            let k = self.contacts[i];
            scratch.x.push(k.r.y);
            scratch.bound.push(k.law.friction * k.law.contact_part(k.r.x, k.law.target).max(0.0));
        }
        for i in 0..m {
            let row = &self.tangential[i * m..(i + 1) * m];
            let pushed: Real = row.iter().zip(&scratch.x).map(|(w, r)| w * r).sum();
            let u_t = self.contacts[i].frame.to_local(&self.velocity(i)).y;
            scratch.q.push(u_t - pushed);
        }
        // Within the bounds (`max`/`min`, not `clamp`: a NaN bound must not panic).
        for (x, b) in scratch.x.iter_mut().zip(&scratch.bound) {
            *x = x.max(-b).min(*b);
        }
        if !block::boxed(m, self.tangential, &scratch.q, &scratch.bound, &mut scratch.x, &mut scratch.solve) {
            return false;
        }
        for i in 0..m {
            let k = self.contacts[i];
            let r_t = k.r.y + (scratch.x[i] - k.r.y) * omega;
            if r_t != k.r.y {
                self.apply(i, &k.frame.to_global(&Vec3::new(0.0, r_t - k.r.y, 0.0)));
            }
            self.contacts[i].r.y = r_t;
        }
        true
    }
}

/// Solves the contact problem of a Newton iteration: sets each contact's Signorini target from
/// its gap and drift (a contact with a positive gap may close it within the step and no more,
/// one that overlaps may not overlap more, beyond the contact's linear prediction by its drift,
/// which may push them apart: [`super`]'s documentation), its Delassus diagonal and impulse
/// scale from its grains' blocks and sample velocities, then sweeps in the order of a
/// [`Schedule`] (which reorders `contacts` and renumbers `sides`' entries)
/// ([`Nlgs::solve_problem`], `mean_diameter` in m the violations' unit). A sweep's change is
/// measured in the grains' velocities ([`super`]'s documentation, "Criterion"):
/// `√(ΔPᵀ W ΔP / M)` relative to Newton's velocity scale, both in `metric`.
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
    let frictional = contacts.iter().any(|c| c.law.friction > 0.0 || c.r.y != 0.0);
    let (normal, tangential) = (&mut metric.blocks, &mut metric.tangential);
    pair_blocks(contacts, sides, &metric.schedule, (normal, frictional.then_some(tangential)), &mut metric.block_at);
    if !frictional {
        metric.tangential.clear();
    }
    let mut problem = Problem { contacts, grains: sides, walls, metric };
    nlgs.solve_problem(&mut problem, sc.dt, mean_diameter)
}

/// Each task's block of normal couplings `n_iᵀ W n_j` between its contacts (the sum over its
/// grains of `±n_iᵀ B_g(i, j) n_j`, `B_g` the grain's block of `A⁻¹` between the two contacts'
/// samples, the sign the product of the contacts' sides), row-major, in the schedule's order of
/// tasks; an empty block for a task of one contact.
///
/// Every task has its block, whatever its size: a grain held all round by the walls is one
/// task of all its boundary's contacts, whose Delassus block is dominated by the grain's rigid
/// motions (over a long step the inertia `M` is what holds them, the stiffness `(θh)² K` the
/// rest), and contact by contact Gauss-Seidel crawls on it (issue 70, docs/methods/fem.md,
/// "Design measurements"). A task's block holds a quarter of the entries of its grains' blocks
/// of `A⁻¹` at most (two unknowns a sample, one normal a contact), and its exact solve
/// factorises it in about `m³/6` operations, against at least `4m²` for the sweep to update its
/// samples' velocities along those blocks.
fn pair_blocks(
    contacts: &[VertexContact],
    sides: &[GrainContacts],
    schedule: &Schedule,
    (blocks, tangential): (&mut Vec<Real>, Option<&mut Vec<Real>>),
    at: &mut Vec<usize>,
) {
    at.clear();
    at.push(0);
    for t in &schedule.tasks {
        let m = t.contacts.len();
        let size = if m > 1 { m * m } else { 0 };
        at.push(at.last().copied().unwrap_or(0) + size);
    }
    let size = at.last().copied().unwrap_or(0);
    blocks.clear();
    blocks.resize(size, 0.0);
    fill_blocks(contacts, sides, schedule, at, blocks, |f| V2::new(f.n.x, f.n.y));
    if let Some(tangential) = tangential {
        tangential.clear();
        tangential.resize(size, 0.0);
        fill_blocks(contacts, sides, schedule, at, tangential, |f| V2::new(f.t1.x, f.t1.y));
    }
}

/// Each task's block of couplings `d_iᵀ W d_j` along the contacts' directions `d` (`direction`
/// of a contact's frame: its normal, or its tangent) into its slice of `blocks` ([`pair_blocks`]).
fn fill_blocks(
    contacts: &[VertexContact],
    sides: &[GrainContacts],
    schedule: &Schedule,
    at: &[usize],
    blocks: &mut [Real],
    direction: impl Fn(&crate::nscd::ContactFrame) -> V2 + Sync,
) {
    // Each task's block in its own slice, all tasks at once.
    let mut slices = Vec::with_capacity(schedule.tasks.len());
    let mut rest = blocks;
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
                let di = direction(&ki.frame);
                for (j, kj) in cs.iter().enumerate().take(i + 1) {
                    let Some((sj, aj)) = sample(kj, g) else { continue };
                    let dj = direction(&kj.frame);
                    let v = ai * aj * di.dot(&(side.block(si, sj) * dj));
                    out[i * m + j] += v;
                    if i != j {
                        out[j * m + i] += v;
                    }
                }
            }
        }
    });
}
