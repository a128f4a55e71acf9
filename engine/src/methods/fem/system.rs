//! Meshed grains touching through contact dynamics, one step at a time (FEM-CD;
//! Nezamabadi 2020, §1.2.3, as LMGC90 does it): each grain a [`Body`], the contacts between their boundaries
//! and with walls those of every soft-grain method ([`crate::methods::soft::contact`]).
//!
//! **Contacts.** A boundary node of one grain within `reach` of the boundary of another grain
//! (the nearest segment, its outward normal and the signed gap; at a reflex corner of that
//! boundary, the segment beyond the corner too: [`contact::candidates()`]), as for the material
//! point method's outlines. A node acts through itself, a place on a segment through the
//! segment's two nodes with the weights of its position: the contact moves exactly as the
//! nodes do. A boundary node within `reach` of a wall touches it. `reach` is the longest
//! boundary segment of any grain. By default both grains' nodes are held outside the other's
//! boundary (the symmetric two-pass treatment, [`contact::Sides::Both`]); where the boundaries
//! lie flat on each other the two sets of contacts are redundant, and the contact solves
//! measure their change in the grains' velocities ([`contact::solve()`]). One-sided
//! (`symmetric_contact: false`, only the nodes of the grain of lower index) the other grain's
//! nodes cross the first's segments by the sagitta of the boundary's chord, `s²/8R` for
//! segments `s` on a radius `R` (3% of an element with eight across the diameter), and further
//! once boundaries are dented, and the contacts that push the first grain's nodes back out of
//! the dents do work ([`contact`]'s module documentation).
//!
//! **A step** ([`System::step`]) is that of the material point method
//! ([`crate::methods::mpm::system`]) on meshed grains: each grain's residual and matrix at the
//! iterate, its free correction, the contact problem with each grain's `A⁻¹` between its
//! contacts' samples (assembled from the block between the samples' nodes, which the grain
//! keeps with its factor: [`crate::methods::soft::node_block`]), the drift
//! of each gap at the first two iterates (the other boundary turning and sliding under the
//! node), then each grain takes its correction with the impulses.
//!
//! **Kept matrices.** Each grain keeps its last matrix, its factor and its contacts' blocks while
//! they contract its own largest nodal correction by four or more an iteration
//! ([`REFRESH_RATIO`]) or once that correction is within Newton's tolerance (a modified Newton
//! iteration: the fixed point does not depend on the matrix). A part as long as the last
//! converged one starts with the same matrices: a grain's mesh does not change, and in a loose
//! packing its matrix hardly does; only the nodes new to a grain's contacts are solved for,
//! with the kept factors. A grain that needed a new matrix after a part's first iteration
//! starts the next part with one. A grain without contacts whose correction is within the
//! tolerance is left where it is by the part's further iterations, which the grains in contact
//! need. Each grain decides for itself: one decision for all grains, on the largest correction
//! of any, cost a loose packing a Newton iteration more a step (docs/methods/fem.md, "Design
//! measurements").
//!
//! Where Newton converged the drifts are measured once more: a contact whose drift moved since
//! the first iterates by more than [`DRIFT_TOLERANCE`] times the longest boundary segment had
//! its gap predicted from a geometry the step left behind, and — if it carries an impulse or
//! may close by the part's end (an open one leaves the solution as it is whatever its drift) —
//! the part fails ([`InstabilityCause::ContactDrift`]): without this check grains rearranging
//! fast went into each other. A part that fails so, or on Newton or the contact solve over
//! budget, a matrix not positive definite or an inverted element, is done again in halves, down
//! to a sixteenth, and the next steps keep parts that short until ten in a row pass
//! ([`crate::methods::soft::parts`]); the shortest part is kept as it converged.
//!
//! Momentum is conserved exactly by every iteration: the internal forces of a grain sum to zero
//! and the contact impulses are equal and opposite.

use nalgebra::Vector2;
use rayon::prelude::*;

use super::body::{add_correction, Body, BodyFailure};
use crate::constitutive::ConstitutiveLaw;
use crate::error::InstabilityCause;
use crate::math::Real;
use crate::methods::soft::contact::{
    self, candidates, enter, Against, Candidate, Entry, GrainContacts, Metric, Sides, Support, VertexContact, Wall, Warm,
};
use crate::methods::soft::node_block::Half;
use crate::methods::soft::parts::{fail, Splitting, StepParts};
pub use crate::methods::soft::parts::{StepFailure, StepReport};
use crate::methods::soft::trace::{NewtonRecord, Tracer};
use crate::methods::soft::{largest, Scheme, REFRESH_RATIO};
use crate::nscd::{Convergence, Nlgs};

type V2 = Vector2<Real>;

/// The Newton iterations of a step that measure the contacts' drifts at their iterate.
const DRIFT_ITERATIONS: u32 = 2;

/// How far a contact's drift may move between the first iterates and the converged one, in
/// units of the longest boundary segment, before the part fails and is split (module
/// documentation).
pub const DRIFT_TOLERANCE: Real = 2e-2;

/// How far the current iterate moves the place `s` of grain `g`'s boundary over the step, m.
fn support_displacement(grains: &[Grain], g: usize, s: &Support, sc: &Scheme) -> V2 {
    s.iter().map(|(k, w)| grains[g].body.increment(k, sc) * w).sum()
}

/// Settings of the method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Time step, s.
    pub dt: Real,
    /// θ of the θ-method, in [½, 1].
    pub theta: Real,
    /// Gravity, m/s².
    pub gravity: V2,
    /// Newton's tolerance on the velocity correction, relative to the velocity scale.
    pub newton_tolerance: Real,
    /// Newton's budget of iterations a step.
    pub max_newton: u32,
    /// The contact solver's settings.
    pub contact: Convergence,
    /// Which grains' vertices the contacts between grains hold outside the other's outline.
    pub sides: Sides,
}

/// A meshed grain.
#[derive(Debug)]
pub struct Grain {
    /// Its mesh and state.
    pub body: Body,
    /// Its law (index in [`System::laws`]).
    pub law: usize,
    /// Friction coefficient.
    pub friction: Real,
    /// Radius of the disk it was meshed from, m.
    pub radius: Real,
}

fn body_failure(grain: usize, f: BodyFailure, tolerance: Real) -> StepFailure {
    fail(match f {
        BodyFailure::BadMesh { element } | BodyFailure::Inverted { element, .. } => {
            let jacobian = if let BodyFailure::Inverted { jacobian, .. } = f { jacobian } else { 0.0 };
            InstabilityCause::InvertedElement { grain, element, jacobian }
        }
        BodyFailure::NotPositiveDefinite => InstabilityCause::NotPositiveDefinite { grain },
        BodyFailure::NewtonBudget { iterations, correction } => {
            InstabilityCause::NewtonBudget { iterations, correction, tolerance, grain: Some(grain), damped: false }
        }
    })
}

/// The whole state of the method (module documentation).
pub struct System {
    /// Grains.
    pub grains: Vec<Grain>,
    /// Constitutive laws, indexed by [`Grain::law`].
    pub laws: Vec<Box<dyn ConstitutiveLaw>>,
    /// Walls.
    pub walls: Vec<Wall>,
    /// Settings.
    pub settings: Settings,
    /// The contacts of the last step, with their impulses.
    pub contacts: Vec<VertexContact>,
    /// Steps done.
    pub steps: u64,
    /// Time, s.
    pub time: Real,
    /// Newton iterations and contact sweeps since the start.
    pub totals: StepReport,
    /// The level the steps are split at, and the parts done and failed since the start.
    pub splitting: Splitting,
    /// The impulse the grains gave each wall over the last step (all its parts when it was
    /// split), N·s/m.
    pub wall_impulse: Vec<V2>,
    /// The force the grains exert on each wall at the step's end, N/m: the impulse of the last
    /// part over its duration.
    pub wall_force: Vec<V2>,
    /// The friction of every grain–grain contact when set; otherwise the geometric mean of the
    /// two grains'.
    pub pair_friction: Option<Real>,
    /// How near a boundary node must come to another boundary or a wall to be a contact, m.
    pub reach: Real,
    last_dt: Real,
    sides: Vec<GrainContacts>,
    /// The contact solves' measure of their change (kept between solves).
    metric: Metric,
    /// The Newton iterations' trace (off unless a sink is set).
    pub tracer: Tracer,
    /// The current part's Newton iterations, sweeps and contacts so far (for the trace).
    traced: (u32, u32, usize),
    corrections: Vec<Vec<Real>>,
    /// The contacts' impulses of the last step, by key, from which the next step's contact
    /// solve starts.
    pub warm: Warm,
    nlgs: Nlgs,
    outlines: Vec<Vec<V2>>,
    /// The contacts' drifts before they are measured again (scratch kept between steps).
    drifts: Vec<Real>,
    /// The part length every grain's factorised matrix was assembled for, s, when the last
    /// part converged with it (module documentation: the next part of that length keeps it).
    kept: Option<Real>,
    /// Each grain's pace of the Newton iterations.
    pace: Vec<Pace>,
}

/// A grain's Newton iterations (module documentation).
#[derive(Debug, Clone, Copy, Default)]
struct Pace {
    /// Its next iteration assembles and factorises its matrix anew.
    refresh: bool,
    /// It has no contact in the part and its last correction was within Newton's tolerance:
    /// the part's next iterations leave it where it is.
    done: bool,
    /// It needed a new matrix after the first iteration of the last part: the next part starts
    /// with one.
    refreshed: bool,
    /// Its largest nodal correction at the last iteration and at the one before, m/s.
    correction: Real,
    last: Real,
}

impl StepParts for System {
    fn try_part(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let (step, time) = (self.steps + 1, self.time);
        self.traced = (0, 0, 0);
        let done = self.try_step(dt, last_chance);
        if self.tracer.on() {
            let traced = self.traced;
            self.tracer.end((step, time, dt), traced, done.as_ref().err().map(|f| &f.cause));
        }
        done
    }

    /// A failed part leaves the velocities where its iterations took them.
    fn undo_part(&mut self) {
        for g in &mut self.grains {
            g.body.v.clone_from(&g.body.v0);
        }
    }
}

impl System {
    /// A system of `grains` and `walls`.
    pub fn new(grains: Vec<Grain>, laws: Vec<Box<dyn ConstitutiveLaw>>, walls: Vec<Wall>, settings: Settings) -> Self {
        let n = grains.len();
        let reach = grains
            .iter()
            .map(|g| {
                let b = &g.body.mesh.boundary;
                (0..b.len())
                    .map(|k| (g.body.mesh.nodes[b[k] as usize] - g.body.mesh.nodes[b[(k + 1) % b.len()] as usize]).norm())
                    .fold(0.0, Real::max)
            })
            .fold(0.0, Real::max);
        let walls_len = walls.len();
        Self {
            grains,
            laws,
            walls,
            settings,
            contacts: Vec::new(),
            steps: 0,
            time: 0.0,
            totals: StepReport::default(),
            splitting: Splitting::default(),
            wall_impulse: vec![V2::zeros(); walls_len],
            wall_force: vec![V2::zeros(); walls_len],
            pair_friction: None,
            reach,
            last_dt: settings.dt,
            sides: vec![GrainContacts::default(); n],
            metric: Metric::default(),
            tracer: Tracer::default(),
            traced: (0, 0, 0),
            corrections: vec![Vec::new(); n],
            warm: Warm::default(),
            nlgs: Nlgs::new(settings.contact),
            outlines: vec![Vec::new(); n],
            drifts: Vec::new(),
            kept: None,
            pace: vec![Pace::default(); n],
        }
    }

    /// Duration of the last part of the last step, s: the contacts' impulses are over it.
    pub fn last_dt(&self) -> Real {
        self.last_dt
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.grains.iter().map(|g| g.body.heap_bytes()).sum::<usize>()
            + self
                .sides
                .iter()
                .map(|s| {
                    (s.inverse.capacity() + s.work.capacity()) * 8
                        + s.samples.capacity() * std::mem::size_of::<Support>()
                        + s.nodes.heap_bytes()
                })
                .sum::<usize>()
            + self.corrections.iter().map(|c| c.capacity() * 8).sum::<usize>()
            + self.contacts.capacity() * std::mem::size_of::<VertexContact>()
            + self.metric.heap_bytes()
            + self.outlines.iter().map(|o| o.capacity() * std::mem::size_of::<V2>()).sum::<usize>()
    }

    /// Kinetic energy, J/m.
    pub fn kinetic_energy(&self) -> Real {
        self.grains.iter().map(|g| g.body.kinetic_energy()).sum()
    }

    /// Energy stored in the grains, J/m.
    pub fn strain_energy(&self) -> Real {
        self.grains.iter().map(|g| g.body.strain_energy(self.laws[g.law].as_ref())).sum()
    }

    /// Total momentum, kg·m/s per m.
    pub fn momentum(&self) -> V2 {
        self.grains.iter().flat_map(|g| g.body.mass.iter().zip(&g.body.v).map(|(m, v)| v * *m)).sum()
    }

    /// Mean grain diameter, m.
    pub fn mean_diameter(&self) -> Real {
        2.0 * self.grains.iter().map(|g| g.radius).sum::<Real>() / self.grains.len().max(1) as Real
    }

    /// Advances one step of `settings.dt`, in parts where it fails ([`Splitting`]).
    pub fn step(&mut self) -> Result<StepReport, StepFailure> {
        self.wall_impulse.iter_mut().for_each(|p| *p = V2::zeros());
        let mut splitting = std::mem::take(&mut self.splitting);
        let done = splitting.step(self, self.settings.dt);
        self.splitting = splitting;
        let report = done?;
        self.steps += 1;
        self.totals.newton += report.newton;
        self.totals.sweeps += report.sweeps;
        self.totals.contacts = report.contacts;
        Ok(report)
    }

    /// One part of `dt` without splitting; `last_chance`: it cannot be split further.
    fn try_step(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let sc = Scheme { dt, theta: self.settings.theta, gravity: self.settings.gravity };
        self.grains.par_iter_mut().for_each(|g| g.body.begin());
        self.detect();
        let mut report = StepReport { contacts: self.contacts.len(), ..StepReport::default() };
        let v_ref =
            self.walls.iter().map(|w| w.velocity.norm()).fold((self.settings.gravity.norm() * dt).max(1e-3 * self.reach / dt), Real::max);
        // Largest nodal speeds and corrections (a mass-weighted mean, as for the material
        // point method, left 2.3% of the CI compaction's box covered twice at Φ 0.90). The
        // contact solves start at the settings' tolerance and follow the corrections down
        // (the forcing term below): at the settings' tolerance alone, the corrections of the
        // shortest parts stalled at 1.1–1.4 times Newton's tolerance, the floor the contact
        // solve's error set, and the compaction stopped on the Newton budget at Φ 0.82–0.89.
        // Newton converges only on a solve asked for Newton's tolerance or less (a looser
        // settings' tolerance serves only the first iterations).
        let speed = |grains: &[Grain]| grains.iter().flat_map(|g| g.body.v.iter().map(|v| v.norm())).fold(0.0, Real::max);
        let mut scale = v_ref.max(speed(&self.grains));
        let mass = self.grains.iter().map(|g| g.body.mass.iter().sum::<Real>()).sum::<Real>();
        let tolerance = self.settings.newton_tolerance;
        let floor = contact::FORCING * tolerance;
        self.nlgs.settings.tolerance = self.settings.contact.tolerance;
        let mut last = Real::INFINITY;
        // A part as long as the last keeps the matrices of the grains that did not need new
        // ones in it (module documentation).
        let same = self.kept == Some(dt);
        self.kept = None;
        for p in &mut self.pace {
            *p = Pace { refresh: !same || p.refreshed, done: false, refreshed: false, correction: 0.0, last: Real::INFINITY };
        }
        for it in 1..=self.settings.max_newton {
            report.newton = it;
            self.newton_free(&sc, it == 1)?;
            if it <= DRIFT_ITERATIONS {
                self.measure_drifts(&sc);
            }
            let d = self.mean_diameter();
            let asked = self.nlgs.settings.tolerance;
            (self.metric.mass, self.metric.speed) = (mass, scale);
            let solved = contact::solve(&mut self.contacts, &mut self.sides, &self.walls, &mut self.nlgs, &sc, d, &mut self.metric);
            report.sweeps += solved.iterations;
            self.traced = (it, report.sweeps, report.contacts);
            if !solved.converged {
                return Err(fail(solved.budget_failure(&self.settings.contact)));
            }
            let correction = self.newton_update();
            scale = scale.max(speed(&self.grains));
            let relative = correction / scale.max(Real::MIN_POSITIVE);
            if self.tracer.on() {
                let refreshed = self.pace.iter().filter(|p| p.refresh && !p.done).count();
                let part = (self.steps + 1, self.time, sc.dt);
                self.tracer.emit(|| NewtonRecord {
                    refreshed_grains: Some(refreshed),
                    ..NewtonRecord::iteration(part, it, relative, solved.iterations, report.contacts)
                });
            }
            if relative <= tolerance && asked <= tolerance {
                // Where Newton converged, the gaps between the moved outlines are measured
                // again: contacts that moved on from where their drifts were measured make the
                // part fail (it is split), unless it is the shortest.
                let limit = DRIFT_TOLERANCE * self.reach;
                let moved = self.remeasure_drifts(&sc, limit);
                if moved > limit && !last_chance {
                    return Err(fail(InstabilityCause::ContactDrift { drift: moved, limit }));
                }
                self.finish(&sc)?;
                self.kept = Some(dt);
                return Ok(report);
            }
            // A grain keeps its matrix while it contracts its correction fast enough, or once
            // its correction is within Newton's tolerance; one without contacts is then done.
            let converged = tolerance * scale;
            for (p, side) in self.pace.iter_mut().zip(&self.sides) {
                p.done = side.is_empty() && p.correction <= converged;
                p.refresh = p.correction > converged && p.correction > REFRESH_RATIO * p.last;
                p.refreshed |= p.refresh;
                p.last = p.correction;
            }
            // The next contact solve is made a hundred times more accurate than this
            // correction (inexact Newton's forcing term, as for the material point method).
            // A correction already within Newton's tolerance (one its loose first solve left
            // unconfirmed) asks for no less than a hundredth of that tolerance: on the CI
            // compaction a solve asked for 1e-12 ran out of its 20,000 sweeps at 1.5e-9.
            self.nlgs.settings.tolerance = (contact::FORCING * relative).max(floor).min(self.settings.contact.tolerance);
            last = relative;
        }
        let grain = largest(self.pace.iter().map(|p| p.correction));
        Err(fail(InstabilityCause::NewtonBudget {
            iterations: self.settings.max_newton,
            correction: last,
            tolerance,
            grain,
            damped: false,
        }))
    }

    /// Each grain's boundary at the step's start, and the step's contacts (module
    /// documentation).
    fn detect(&mut self) {
        let mut shapes = std::mem::take(&mut self.outlines);
        for (g, at) in shapes.iter_mut().enumerate() {
            let b = &self.grains[g].body;
            at.clear();
            at.extend(b.mesh.boundary.iter().map(|&k| b.position(k as usize)));
        }
        for side in &mut self.sides {
            side.clear();
        }
        self.contacts.clear();
        let node = |g: usize, k: usize| self.grains[g].body.mesh.boundary[k];
        for candidate in candidates(&shapes, &self.walls, self.reach, self.settings.sides) {
            let e = match candidate {
                Candidate::Grain { a, k, b, near, line } => {
                    let next = (near.segment + 1) % shapes[b].len();
                    let on_b = Support::from_entries(&mut [(node(b, near.segment), 1.0 - near.t), (node(b, next), near.t)]);
                    let (Some(support), Some(on_b)) = (Support::from_entries(&mut [(node(a, k), 1.0)]), on_b) else { continue };
                    Entry {
                        vertex: k,
                        at: shapes[a][k] - near.normal * (0.5 * near.gap),
                        a: a as u32,
                        support,
                        b: Against::Grain { grain: b as u32, support: on_b },
                        normal: near.normal,
                        gap: near.gap,
                        friction: self.pair_friction.unwrap_or_else(|| (self.grains[a].friction * self.grains[b].friction).sqrt()),
                        lever: self.grains[a].radius,
                        line: line.then_some(near.segment as u32),
                        segment: near.segment as u32,
                    }
                }
                Candidate::Wall { g, k, w, gap } => {
                    let wall = self.walls[w];
                    let Some(support) = Support::from_entries(&mut [(node(g, k), 1.0)]) else { continue };
                    Entry {
                        vertex: k,
                        at: shapes[g][k] - wall.normal * gap,
                        a: g as u32,
                        support,
                        b: Against::Wall(w as u32),
                        normal: wall.normal,
                        gap,
                        friction: (self.grains[g].friction * wall.friction).sqrt(),
                        lever: self.grains[g].radius,
                        line: None,
                        segment: 0,
                    }
                }
            };
            enter(&mut self.contacts, &mut self.sides, &self.warm, e);
        }
        self.outlines = shapes;
    }

    /// Every grain's residual at the iterate and — when its [`Pace::refresh`] says so — its
    /// matrix, factorised, its free correction, and its side of the contact problem (the block
    /// of the inverse with a new matrix or, at the `first` iteration, with the kept one for the
    /// part's new contacts; otherwise the last one's, [`REFRESH_RATIO`]).
    fn newton_free(&mut self, sc: &Scheme, first: bool) -> Result<(), StepFailure> {
        let laws = &self.laws;
        let tolerance = self.settings.newton_tolerance;
        let pace = &self.pace;
        self.grains.par_iter_mut().zip(self.sides.par_iter_mut()).zip(self.corrections.par_iter_mut()).enumerate().try_for_each(
            |(g, ((grain, side), dv))| {
                let Pace { refresh, done, .. } = pace[g];
                if done {
                    return Ok(());
                }
                let body = &mut grain.body;
                body.iterate(laws[grain.law].as_ref(), sc, refresh).map_err(|f| body_failure(g, f, tolerance))?;
                dv.clear();
                dv.extend(body.residual.iter().map(|r| -r));
                body.matrix.solve(dv);
                if side.is_empty() {
                    return Ok(());
                }
                if refresh || first {
                    let n = 2 * body.nodes();
                    let fixed = &body.fixed;
                    let factor = body.matrix.generation();
                    let matrix = &mut body.matrix;
                    let project = |cols: &mut [Real]| {
                        for col in cols.chunks_exact_mut(n.max(1)) {
                            for &(d, _) in fixed {
                                col[d] = 0.0;
                            }
                        }
                    };
                    side.invert_by_nodes(n, factor, |cols, half| {
                        project(cols);
                        match half {
                            Half::Forward => matrix.forward(cols),
                            Half::Full => {
                                matrix.solve(cols);
                                project(cols);
                            }
                        }
                    });
                }
                side.sample_velocities(&body.v, dv);
                Ok(())
            },
        )
    }

    /// Sets each contact's drift at the current iterate: every boundary moved as the iterate
    /// moves its nodes and the gap measured anew, against the gap the contact's supports
    /// predict.
    fn measure_drifts(&mut self, sc: &Scheme) {
        let moved: Vec<Vec<V2>> = self
            .grains
            .iter()
            .zip(&self.outlines)
            .zip(&self.sides)
            .map(|((g, from), side)| {
                if side.is_empty() {
                    return Vec::new();
                }
                g.body.mesh.boundary.iter().zip(from).map(|(&k, x)| x + g.body.increment(k as usize, sc)).collect()
            })
            .collect();
        let grains = &self.grains;
        let displacement = |g: usize, s: &Support| support_displacement(grains, g, s, sc);
        contact::measure_drifts(&mut self.contacts, &self.sides, &self.walls, &moved, sc.dt, displacement);
    }

    /// Measures the contacts' drifts anew at the current iterate; returns the largest change, m,
    /// over the contacts whose drift matters: those that carry an impulse, and those whose gap
    /// at the part's end, with the new drift, is within `limit` (m). A contact that stays open
    /// whatever its drift leaves the solution as it is (the contacts that failed the parts of
    /// a 100-grain compaction past Φ 0.83 were mostly one such contact among 1,300, a gap of
    /// 1.0–1.3 mm open, its drift moved by 30 µm).
    fn remeasure_drifts(&mut self, sc: &Scheme, limit: Real) -> Real {
        let mut before = std::mem::take(&mut self.drifts);
        before.clear();
        before.extend(self.contacts.iter().map(|c| c.drift));
        self.measure_drifts(sc);
        let grains = &self.grains;
        let sides = &self.sides;
        let displacement = |g: usize, slot: u32| support_displacement(grains, g, &sides[g].samples[slot as usize], sc);
        let moved = self
            .contacts
            .iter()
            .zip(&before)
            .filter(|(c, _)| {
                let n = V2::new(c.frame.n.x, c.frame.n.y);
                let ub = match c.b {
                    contact::Other::Grain { grain, slot } => displacement(grain as usize, slot),
                    contact::Other::Wall(w) => self.walls[w as usize].velocity * sc.dt,
                };
                let end_gap = c.gap + (displacement(c.a as usize, c.slot) - ub).dot(&n) + c.drift;
                c.r.x > 0.0 || end_gap <= limit
            })
            .map(|(c, d)| (c.drift - d).abs())
            .fold(0.0, Real::max);
        self.drifts = before;
        moved
    }

    /// Adds each grain's correction with the contact impulses to its iterate; returns the
    /// largest nodal correction, m/s (each grain's in its [`Pace::correction`]).
    fn newton_update(&mut self) -> Real {
        let contacts = &self.contacts;
        self.grains
            .par_iter_mut()
            .zip(self.sides.par_iter_mut())
            .zip(self.corrections.par_iter_mut())
            .zip(self.pace.par_iter_mut())
            .map(|(((grain, side), dv), pace)| {
                if pace.done {
                    return pace.correction;
                }
                let body = &mut grain.body;
                if !side.is_empty() {
                    let mut rhs = std::mem::take(&mut side.work);
                    rhs.clear();
                    rhs.resize(dv.len(), 0.0);
                    side.spread_impulses(contacts, &mut rhs);
                    for &(d, _) in &body.fixed {
                        rhs[d] = 0.0;
                    }
                    body.matrix.solve(&mut rhs);
                    dv.iter_mut().zip(&rhs).for_each(|(d, r)| *d += r);
                    side.work = rhs;
                }
                pace.correction = add_correction(&mut body.v, dv);
                pace.correction
            })
            .reduce(|| 0.0, Real::max)
    }

    /// Ends a converged step: the grains move, the walls move, the wall forces and warm
    /// starts are kept.
    fn finish(&mut self, sc: &Scheme) -> Result<(), StepFailure> {
        let laws = &self.laws;
        let tolerance = self.settings.newton_tolerance;
        // Every grain is checked first, so that a failure leaves them all as they were.
        self.grains
            .par_iter_mut()
            .enumerate()
            .try_for_each(|(g, grain)| grain.body.settle(laws[grain.law].as_ref(), sc).map_err(|f| body_failure(g, f, tolerance)))?;
        self.grains.par_iter_mut().for_each(|grain| grain.body.commit(sc));
        for w in &mut self.walls {
            w.point += w.velocity * sc.dt;
        }
        self.last_dt = sc.dt;
        contact::wall_impulses(&self.contacts, &mut self.wall_force);
        for (impulse, p) in self.wall_impulse.iter_mut().zip(self.wall_force.iter_mut()) {
            *impulse += *p;
            *p /= sc.dt;
        }
        self.warm.remember(&self.contacts);
        self.time += sc.dt;
        Ok(())
    }
}
