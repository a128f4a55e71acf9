//! The implicit material point method with contact dynamics, one step at a time: grains as
//! clouds of points ([`super::points`]), each with its own nodal field ([`super::field`]),
//! touching at nodes ([`super::contact`]) through the shared contact solver.
//!
//! A step:
//! 1. each grain projects its points on its nodes (mass, velocity, internal force at the
//!    start);
//! 2. the contacts are found between the grains' outlines and with the walls, with their
//!    normals and gaps;
//! 3. Newton iterations on the nodal velocities of every grain at once: each grain assembles
//!    its residual and matrix and solves for its free correction (no contact impulse); the
//!    contact problem, with each grain's `A⁻¹` between its contacts' samples, is solved by the
//!    non-linear Gauss-Seidel sweeps of [`crate::nscd`] for the step's total impulses
//!    (warm-started from the previous iteration and step); each grain then takes its
//!    correction with the impulses. The iterations stop when the correction is below
//!    `newton_tolerance` times the velocity scale. The matrix (with its `A⁻¹` blocks) is
//!    assembled and factorised at the first iteration and kept as long as each iteration
//!    divides the correction by four or more (a modified Newton: the fixed point, where the
//!    residual balances the contact impulses, does not depend on the matrix, and the contact
//!    problem uses the same `A⁻¹` as the update, so the two stay consistent). The tangent and
//!    the factorisation were two thirds of an iteration's cost. While points switch between
//!    elastic and plastic and the correction does not shrink, only a fraction of it is taken
//!    ([`CYCLE_RATE`]);
//! 4. the points move with their nodes: displacement `Σ N_i u_i`, deformation gradient
//!    `(I + Σ u_i ⊗ ∇N_i) F`, history from the law, velocity by a FLIP/PIC blend.
//!
//! A step that fails (Newton or the contact solve over budget, a matrix that stays
//! indefinite, an inverted point) is done again in halves, and the steps after it keep parts
//! that short until ten in a row converge ([`crate::methods::soft::parts`]). In a dense packing
//! the grains' stress makes the geometric stiffness of their rotation outweigh their inertia
//! over a long step ([`super::field`]); the damped matrix then converges slowly, and such a step
//! is split.
//!
//! Momentum is conserved exactly by every iteration (the internal forces of a grain sum to
//! zero and the contact impulses are equal and opposite), whatever the convergence.

use rayon::prelude::*;

use super::contact::{
    self, candidates, enter, Against, Candidate, Entry, GrainContacts, Metric, Sides, Support, VertexContact, Wall, Warm, FORCING,
    SUPPORT_NODES,
};
use super::field::{Field, PointFailure, Scheme};
use super::grain::Grain;
use super::grid::{Grid, V2};
use super::points::Points;
use crate::constitutive::ConstitutiveLaw;
use crate::error::InstabilityCause;
use crate::math::Real;
use crate::methods::soft::parts::{fail, Splitting, StepParts};
pub use crate::methods::soft::parts::{StepFailure, StepReport};
use crate::methods::soft::trace::{NewtonRecord, Tracer};
use crate::methods::soft::{largest, REFRESH_RATIO};
use crate::nscd::{Convergence, Nlgs, NlgsReport};

/// The Newton iterations of a step that measure the contacts' drifts at their iterate; later
/// ones keep them (a target that moves with every iterate kept a dense packing's iterations
/// from converging).
const DRIFT_ITERATIONS: u32 = 2;

/// A Newton iteration from this one on that contracts the correction by less than
/// [`STALL_RATIO`], with the matrix assembled at its own iterate and the one before, ends the
/// attempt early when, at that rate, the tolerance would not be reached within the budget:
/// the part is then split at once instead of after the budget (not at the deepest level,
/// where the budget is the last chance).
const STALL_AFTER: u32 = 6;

/// See [`STALL_AFTER`].
const STALL_RATIO: Real = 0.5;

/// A Newton iteration that shrinks the correction by less than this factor while points
/// switch between elastic and plastic, or while the correction turns back on the previous one
/// ([`REVERSAL`]), halves the fraction of the next corrections taken (down to
/// [`MIN_FRACTION`]); one that shrinks it below 0.6 doubles it back (up to 1). With a
/// perfectly plastic law (hardening 0) a few points sit on the yield surface at the solution,
/// and Newton on the return mapping's two branches jumps between them, the correction
/// alternating without shrinking; taking a fraction of it breaks the cycle. The fraction scales
/// the update only, so the fixed point is unchanged, and every grain takes the same fraction,
/// so momentum stays conserved. The switching condition is there because damping on the rate
/// alone slowed iterations stalled for another reason (a grain on its positive-part tangent) to
/// a crawl (docs/methods/mpm.md, "Design measurements").
const CYCLE_RATE: Real = 0.9;

/// The mass-weighted cosine between an iteration's correction and the previous one below
/// which the correction has turned back ([`CYCLE_RATE`]). Newton can cycle with no point
/// switching: one grain on its own (undamped) matrix can take the same correction with the
/// opposite sign at every iteration until the budget is spent. Half of a correction that flips
/// sign lands on the fixed point along that mode. Only the last chance (the deepest split,
/// where the budget is spent whole) halves for a reversal: at every level it prolonged attempts
/// that were split in the end anyway, and cost the elastic compaction of `sable bench mpm` more
/// sweeps and time (docs/methods/mpm.md, "Design measurements").
const REVERSAL: Real = -0.5;

/// See [`CYCLE_RATE`].
const MIN_FRACTION: Real = 1.0 / 16.0;

/// Settings of the method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Time step, s.
    pub dt: Real,
    /// θ of the θ-method, in [½, 1] ([`super::field`]).
    pub theta: Real,
    /// FLIP fraction of the points' velocity update (1: pure FLIP, no damping of the modes the
    /// grid carries; 0: PIC).
    pub flip: Real,
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

/// The whole state of the method (module documentation).
pub struct System {
    /// Background grid.
    pub grid: Grid,
    /// Material points.
    pub points: Points,
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
    /// split), N·s/m: the wall's mean force over the step times the step.
    pub wall_impulse: Vec<V2>,
    /// The force the grains exert on each wall at the step's end, N/m: the impulse of its last
    /// part over that part's duration (backward Euler's end-of-step force; with θ < 1 the
    /// mean over the part).
    pub wall_force: Vec<V2>,
    /// The friction of every grain–grain contact when set (a stage's `friction`); otherwise
    /// the geometric mean of the two grains'. Wall contacts keep their own.
    pub pair_friction: Option<Real>,
    /// Duration of the last part of the last step, s (the step, or its last half when split):
    /// the contacts' impulses are over it.
    last_dt: Real,
    fields: Vec<Field>,
    sides: Vec<GrainContacts>,
    /// The contact solves' measure of their change (kept between solves).
    metric: Metric,
    /// The contacts' impulses of the last step, which the next one's solve starts from.
    pub warm: Warm,
    nlgs: Nlgs,
    /// Each grain's outline at the step's start, and where an iterate moves it (scratch kept
    /// between steps).
    outlines: Vec<Vec<V2>>,
    moved: Vec<Vec<V2>>,
    /// The Newton iterations' trace (off unless a sink is set).
    pub tracer: Tracer,
    /// The current part's Newton iterations, sweeps and contacts so far (for the trace).
    traced: (u32, u32, usize),
}

impl StepParts for System {
    fn try_part(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let (step, time) = (self.steps + 1, self.time);
        self.traced = (0, 0, 0);
        let done = self.try_step(dt, !last_chance);
        if self.tracer.on() {
            let traced = self.traced;
            self.tracer.end((step, time, dt), traced, done.as_ref().err().map(|f| &f.cause));
        }
        done
    }
}

impl System {
    /// A system at rest in time.
    pub fn new(
        grid: Grid,
        points: Points,
        grains: Vec<Grain>,
        laws: Vec<Box<dyn ConstitutiveLaw>>,
        walls: Vec<Wall>,
        settings: Settings,
    ) -> Self {
        let n = grains.len();
        let walls_len = walls.len();
        Self {
            grid,
            points,
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
            last_dt: settings.dt,
            pair_friction: None,
            fields: (0..n).map(|_| Field::default()).collect(),
            sides: vec![GrainContacts::default(); n],
            metric: Metric::default(),
            warm: Warm::default(),
            nlgs: Nlgs::new(settings.contact),
            outlines: vec![Vec::new(); n],
            moved: vec![Vec::new(); n],
            tracer: Tracer::default(),
            traced: (0, 0, 0),
        }
    }

    /// Duration of the last part of the last step, s: the contacts' impulses are over it.
    pub fn last_dt(&self) -> Real {
        self.last_dt
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.points.heap_bytes()
            + self.fields.iter().map(Field::heap_bytes).sum::<usize>()
            + self
                .sides
                .iter()
                .map(|s| {
                    (s.inverse.capacity() + s.work.capacity() + 2 * s.offsets.capacity() + 2 * s.entries.capacity() + 3 * s.u.capacity())
                        * 8
                        + s.samples.capacity() * std::mem::size_of::<Support>()
                })
                .sum::<usize>()
            + self.contacts.capacity() * std::mem::size_of::<VertexContact>()
            + self.nlgs.heap_bytes()
            + self.metric.heap_bytes()
            + self.grains.iter().map(|g| g.outline.vertices.capacity() * std::mem::size_of::<super::outline::Vertex>()).sum::<usize>()
            + self.outlines.iter().chain(&self.moved).map(|v| v.capacity() * std::mem::size_of::<V2>()).sum::<usize>()
    }

    /// Kinetic energy of the points, J/m (per metre of thickness).
    pub fn kinetic_energy(&self) -> Real {
        (0..self.points.len()).map(|p| 0.5 * self.points.mass[p] * self.points.v[p].norm_squared()).sum()
    }

    /// Energy stored in the grains' deformation, J/m (the elastic part for plastic laws).
    pub fn strain_energy(&self) -> Real {
        let mut e = 0.0;
        for g in &self.grains {
            let law = self.laws[g.law].as_ref();
            for p in g.points.clone() {
                e += self.points.vol0[p] * law.stored_energy(&self.points.f[p], &self.points.history[p]).unwrap_or(0.0);
            }
        }
        e
    }

    /// Mean grain diameter, m.
    pub fn mean_diameter(&self) -> Real {
        2.0 * self.grains.iter().map(|g| g.radius).sum::<Real>() / self.grains.len().max(1) as Real
    }

    fn point_failure(&self, f: PointFailure) -> StepFailure {
        let grain_of = |p: usize| self.grains.iter().position(|g| g.points.contains(&p)).unwrap_or(0);
        match f {
            PointFailure::LeftGrid(p) => fail(InstabilityCause::LeftGrid { grain: grain_of(p), point: p }),
            PointFailure::Inverted(p, j) => fail(InstabilityCause::Inverted { grain: grain_of(p), point: p, jacobian: j }),
        }
    }

    /// Advances one step of `settings.dt` (module documentation), in parts where it fails
    /// ([`Splitting`]): nothing has moved when a part fails (the points move only once the
    /// iterations converged).
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

    /// One step of `dt` without splitting; `stall_check`: the Newton iterations may end early
    /// ([`STALL_AFTER`]).
    fn try_step(&mut self, dt: Real, stall_check: bool) -> Result<StepReport, StepFailure> {
        let sc = Scheme { dt, theta: self.settings.theta, gravity: self.settings.gravity };
        // 1. The fields.
        {
            let (grid, points, laws) = (&self.grid, &self.points, &self.laws);
            let begun: Result<(), PointFailure> = self
                .fields
                .par_iter_mut()
                .zip(&self.grains)
                .try_for_each(|(f, g)| f.begin(grid, points, g.points.clone(), laws[g.law].as_ref()));
            if let Err(e) = begun {
                return Err(self.point_failure(e));
            }
        }
        // 2. The candidate contacts.
        self.detect();
        let mut report = StepReport { contacts: self.contacts.len(), ..StepReport::default() };
        // 3. Newton.
        // The velocity scale: the walls', gravity's over the step, and at least a thousandth of
        // a cell per step (a packing at rest under fixed walls would otherwise measure its
        // corrections against round-off: 24 iterations a step at equilibrium).
        let floor = 1e-3 * self.grid.h / sc.dt;
        let v_ref = self.walls.iter().map(|w| w.velocity.norm()).fold((self.settings.gravity.norm() * sc.dt).max(floor), Real::max);
        let rms = |fields: &[Field], of: fn(&Field, usize) -> V2| {
            let (mut s, mut m) = (0.0, 0.0);
            for f in fields {
                for i in 0..f.nodes() {
                    s += f.mass[i] * of(f, i).norm_squared();
                    m += f.mass[i];
                }
            }
            (s / m.max(Real::MIN_POSITIVE)).sqrt()
        };
        let mut scale = v_ref.max(rms(&self.fields, |f, i| f.v0[i]));
        let mass = self.fields.iter().map(|f| f.mass.iter().sum::<Real>()).sum::<Real>();
        let mut converged = false;
        let mut last = Real::INFINITY;
        let mut refresh = true;
        self.nlgs.settings.tolerance = self.settings.contact.tolerance;
        // Iterations in a row with a matrix assembled at their own iterate.
        let mut fresh_in_a_row = 0;
        // The fraction of each correction taken ([`CYCLE_RATE`]).
        let mut fraction: Real = 1.0;
        // The mass-weighted square of the previous iteration's correction.
        let mut last_squared: Real = 0.0;
        for it in 1..=self.settings.max_newton {
            report.newton = it;
            fresh_in_a_row = if refresh { fresh_in_a_row + 1 } else { 0 };
            self.newton_free(&sc, refresh)?;
            if it <= DRIFT_ITERATIONS {
                self.measure_drifts(&sc);
            }
            let solved = self.solve_contacts(&sc, (mass, scale));
            report.sweeps += solved.iterations;
            self.traced = (it, report.sweeps, report.contacts);
            if !solved.converged {
                return Err(fail(solved.budget_failure(&self.settings.contact)));
            }
            let (dv2, m, against_last) = self.newton_update(fraction);
            let reversed = it > 1 && against_last < REVERSAL * (dv2 * last_squared).sqrt();
            last_squared = dv2;
            let correction = (dv2 / m.max(Real::MIN_POSITIVE)).sqrt();
            if it == 1 {
                scale = scale.max(correction);
            }
            scale = scale.max(rms(&self.fields, |f, i| f.v[i]));
            let relative = correction / scale.max(Real::MIN_POSITIVE);
            if self.tracer.on() {
                let switching = self.fields.iter().map(|f| f.switches).sum();
                let damped = self.fields.iter().filter(|f| f.damped).count();
                let part = (self.steps + 1, self.time, sc.dt);
                self.tracer.emit(|| NewtonRecord {
                    switching: Some(switching),
                    fraction: Some(fraction),
                    refreshed: Some(refresh),
                    damped_grains: Some(damped),
                    reversed: Some(reversed),
                    ..NewtonRecord::iteration(part, it, relative, solved.iterations, report.contacts)
                });
            }
            if relative <= self.settings.newton_tolerance {
                converged = true;
                break;
            }
            // An attempt that converges too slowly to make it within the budget stops now.
            let rate = relative / last;
            if stall_check && fresh_in_a_row >= 2 && it >= STALL_AFTER && rate > STALL_RATIO {
                let needed = if rate < 1.0 { (self.settings.newton_tolerance / relative).ln() / rate.ln() } else { Real::INFINITY };
                if Real::from(it) + needed > Real::from(self.settings.max_newton) {
                    return Err(fail(self.newton_budget(it, relative)));
                }
            }
            // Points switching between elastic and plastic, or (at the last chance) the
            // correction turning back, while it does not shrink: a cycle (between the return
            // mapping's two branches, or a two-cycle of the iterates), which a shorter step
            // does not break ([`CYCLE_RATE`], [`REVERSAL`]).
            let switching = it > 1 && self.fields.iter().any(|f| f.switches > 0);
            if rate >= CYCLE_RATE && (switching || (reversed && !stall_check)) {
                fraction = (0.5 * fraction).max(MIN_FRACTION);
            } else if rate < 0.6 {
                fraction = (2.0 * fraction).min(1.0);
            }
            // The matrix is kept while it contracts the correction fast enough.
            refresh = relative > REFRESH_RATIO * last;
            // The next contact solve is made a hundred times more accurate than this
            // correction (inexact Newton's forcing term).
            self.nlgs.settings.tolerance = (FORCING * relative).clamp(1e-12, self.settings.contact.tolerance);
            last = relative;
        }
        if !converged {
            return Err(fail(self.newton_budget(self.settings.max_newton, last)));
        }
        // 4. The points.
        self.move_points(&sc)?;
        for w in &mut self.walls {
            w.point += w.velocity * sc.dt;
        }
        self.last_dt = sc.dt;
        let mut part = std::mem::take(&mut self.wall_force);
        contact::wall_impulses(&self.contacts, &mut part);
        for (impulse, p) in self.wall_impulse.iter_mut().zip(part.iter_mut()) {
            *impulse += *p;
            *p /= sc.dt;
        }
        self.wall_force = part;
        self.warm.remember(&self.contacts);
        self.time += sc.dt;
        Ok(report)
    }

    /// Newton's budget spent after `iterations` with the last relative `correction`, naming
    /// the grain whose correction was the largest and whether its matrix was damped.
    fn newton_budget(&self, iterations: u32, correction: Real) -> InstabilityCause {
        let grain = largest(self.fields.iter().map(|f| f.last_correction));
        let damped = grain.is_some_and(|g| self.fields[g].damped);
        InstabilityCause::NewtonBudget { iterations, correction, tolerance: self.settings.newton_tolerance, grain, damped }
    }

    /// Finds the contacts of the step, their frames, gaps, laws and warm starts, and each
    /// grain's samples: every vertex of a grain's outline within a cell of a wall, and of a
    /// grain's outline within a cell of a grain of higher index's — of any other grain's with
    /// [`Sides::Both`] — (module documentation of [`super::contact`]).
    fn detect(&mut self) {
        let h = self.grid.h;
        let mut shapes = std::mem::take(&mut self.outlines);
        for (g, at) in shapes.iter_mut().enumerate() {
            self.grains[g].outline.positions_into(&self.points, at);
        }
        for side in &mut self.sides {
            side.clear();
        }
        self.contacts.clear();
        let mut entries = Vec::with_capacity(2 * 9);
        for candidate in candidates(&shapes, &self.walls, h, self.settings.sides) {
            let e = match candidate {
                Candidate::Grain { a, k, b, near, line } => {
                    // Each side moves as its vertices do over the step (module documentation of
                    // [`super::contact`]): grain `b`'s place between its segment's two.
                    let next = (near.segment + 1) % shapes[b].len();
                    let support = self.vertex_support(a, &[(k, 1.0)], &mut entries);
                    let on_b = self.vertex_support(b, &[(near.segment, 1.0 - near.t), (next, near.t)], &mut entries);
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
                    Entry {
                        vertex: k,
                        at: shapes[g][k] - wall.normal * gap,
                        a: g as u32,
                        support: self.vertex_support(g, &[(k, 1.0)], &mut entries),
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

    /// Sets each contact's drift ([`VertexContact::drift`]) at the current iterate: every
    /// outline moved as the iterate moves its vertices, and the gap measured anew, against
    /// the gap the contact's supports predict.
    fn measure_drifts(&mut self, sc: &Scheme) {
        let mut moved = std::mem::take(&mut self.moved);
        let mut entries = Vec::with_capacity(9);
        for (g, (to, from)) in moved.iter_mut().zip(&self.outlines).enumerate() {
            let f = &self.fields[g];
            to.clear();
            // A grain without a contact has no sample: no contact reads its outline.
            if self.sides[g].is_empty() {
                continue;
            }
            to.extend(from.iter().enumerate().map(|(k, x)| {
                entries.clear();
                self.vertex_weights(g, k, 1.0, &mut entries);
                x + entries.iter().map(|&(i, w)| f.displacement(i as usize, sc) * w).sum::<V2>()
            }));
        }
        let fields = &self.fields;
        let displacement = |g: usize, s: &Support| s.iter().map(|(i, w)| fields[g].displacement(i, sc) * w).sum::<V2>();
        contact::measure_drifts(&mut self.contacts, &self.sides, &self.walls, &moved, sc.dt, displacement);
        self.moved = moved;
    }

    /// The support of the place `Σ t_k x_k` between vertices `(k, t_k)` of grain `g`'s outline
    /// (`entries` scratch). The two vertices' points' stencils together hold at most
    /// [`SUPPORT_NODES`] nodes while the points are less than about a cell apart along each
    /// axis; farther apart (a grain stretched that much) the place moves with the nearer
    /// vertex.
    fn vertex_support(&self, g: usize, at: &[(usize, Real)], entries: &mut Vec<(u32, Real)>) -> Support {
        entries.clear();
        for &(k, t) in at {
            self.vertex_weights(g, k, t, entries);
        }
        if let Some(s) = Support::from_entries(entries) {
            return s;
        }
        let k = at.iter().fold((0, Real::NEG_INFINITY), |best, &(k, t)| if t > best.1 { (k, t) } else { best }).0;
        entries.clear();
        self.vertex_weights(g, k, 1.0, entries);
        // One vertex moves the nine nodes of its point's stencil at most.
        Support::from_entries(entries).unwrap_or(Support { nodes: [0; SUPPORT_NODES], weights: [0.0; SUPPORT_NODES], len: 0 })
    }

    /// Appends to `out` the nodes of grain `g`'s field that move vertex `k` of its outline,
    /// each weight times `scale`: over a step the vertex, `x_p + F_p o`, moves by
    /// `Σ_i u_i (N_i(x_p) + ∇N_i(x_p) · F_p o)` for the nodal displacements `u_i` (the point's
    /// own displacement and the change of its `F`), so these weights give its velocity
    /// exactly, and an impulse on it reaches the nodes by them.
    fn vertex_weights(&self, g: usize, k: usize, scale: Real, out: &mut Vec<(u32, Real)>) {
        let v = self.grains[g].outline.vertices[k];
        let p = v.point as usize;
        let f = &self.fields[g];
        let fo = self.points.f[p] * v.offset;
        let st = f.stencils[p - self.grains[g].points.start];
        let nodes = f.stencil_nodes(&st);
        for a in 0..3 {
            for b in 0..3 {
                let i = nodes[a][b];
                if f.mass[i] > 0.0 {
                    out.push((i as u32, scale * (st.weight(a, b) + st.gradient(a, b).dot(&fo))));
                }
            }
        }
    }

    /// Assembles every grain's Newton residual at the current iterate — and, when `refresh`,
    /// its matrix, factorised — solves for its free correction (into `Field::correction`), and
    /// prepares its side of the contact problem (the block of `A⁻¹` only with a new matrix).
    fn newton_free(&mut self, sc: &Scheme, refresh: bool) -> Result<(), StepFailure> {
        let (points, laws) = (&self.points, &self.laws);
        let out: Result<(), (usize, Option<PointFailure>)> =
            self.fields.par_iter_mut().zip(self.sides.par_iter_mut()).enumerate().try_for_each(|(g, (f, side))| {
                let grain = &self.grains[g];
                let law = laws[grain.law].as_ref();
                if refresh {
                    f.assemble(points, grain.points.clone(), law, sc).map_err(|e| (g, e))?;
                } else {
                    f.assemble_residual(points, grain.points.clone(), law, sc).map_err(|e| (g, Some(e)))?;
                }
                f.count_switches(points, grain.points.clone());
                // The last correction becomes the previous one, and the previous one's buffer
                // takes the new correction.
                std::mem::swap(&mut f.correction, &mut f.previous);
                let mut dv = std::mem::take(&mut f.correction);
                dv.clear();
                dv.extend(f.residual.iter().flat_map(|r| [-r.x, -r.y]));
                f.solve(&mut dv);
                if !side.is_empty() {
                    if refresh {
                        super::contact::invert(side, f);
                    }
                    side.sample_velocities(&f.v, &dv);
                }
                f.correction = dv;
                Ok(())
            });
        match out {
            Ok(()) => Ok(()),
            Err((_, Some(p))) => Err(self.point_failure(p)),
            Err((g, None)) => Err(fail(InstabilityCause::NotPositiveDefinite { grain: g })),
        }
    }

    /// Sets each contact's Delassus block and impulse scale and solves the contact problem,
    /// its change measured for the grains' mass (kg/m) against Newton's velocity scale (m/s).
    fn solve_contacts(&mut self, sc: &Scheme, (mass, speed): (Real, Real)) -> NlgsReport {
        let d = self.mean_diameter();
        (self.metric.mass, self.metric.speed) = (mass, speed);
        super::contact::solve(&mut self.contacts, &mut self.sides, &self.walls, &mut self.nlgs, sc, d, &mut self.metric)
    }

    /// Adds `fraction` of each grain's correction with the contact impulses to its iterate;
    /// returns, summed over the grains' nodes, the mass-weighted squared (whole) correction,
    /// the mass, and the mass-weighted dot product of the correction with the previous
    /// iteration's (0 at the step's first).
    fn newton_update(&mut self, fraction: Real) -> (Real, Real, Real) {
        let contacts = &self.contacts;
        self.fields
            .par_iter_mut()
            .zip(self.sides.par_iter_mut())
            .map(|(f, side)| {
                let mut dv = std::mem::take(&mut f.correction);
                if !side.is_empty() {
                    let mut rhs = std::mem::take(&mut side.work);
                    rhs.clear();
                    rhs.resize(dv.len(), 0.0);
                    side.spread_impulses(contacts, &mut rhs);
                    f.solve(&mut rhs);
                    dv.iter_mut().zip(&rhs).for_each(|(d, r)| *d += r);
                    side.work = rhs;
                }
                let (mut s, mut m, mut dot) = (0.0, 0.0, 0.0);
                let previous = (f.previous.len() == dv.len()).then_some(&f.previous);
                for i in 0..f.nodes() {
                    let d = V2::new(dv[2 * i], dv[2 * i + 1]);
                    if f.mass[i] > 0.0 {
                        f.v[i] += d * fraction;
                        s += f.mass[i] * d.norm_squared();
                        m += f.mass[i];
                        if let Some(p) = previous {
                            dot += f.mass[i] * (d.x * p[2 * i] + d.y * p[2 * i + 1]);
                        }
                    }
                }
                f.last_correction = (s / m.max(Real::MIN_POSITIVE)).sqrt();
                f.correction = dv;
                (s, m, dot)
            })
            .reduce(|| (0.0, 0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2))
    }

    /// Moves the points with their grains' converged nodal fields.
    fn move_points(&mut self, sc: &Scheme) -> Result<(), StepFailure> {
        let flip = self.settings.flip;
        // The point's displacement, velocity change, interpolated velocity and new `F`.
        let kinematics = |f: &Field, q: usize, fp: &crate::constitutive::Mat2| {
            let st = f.stencils[q];
            let nodes = f.stencil_nodes(&st);
            let (mut u, mut dv, mut pic) = (V2::zeros(), V2::zeros(), V2::zeros());
            let mut inc = crate::constitutive::Mat2::identity();
            for a in 0..3 {
                for b in 0..3 {
                    let i = nodes[a][b];
                    let w = st.weight(a, b);
                    let ui = f.displacement(i, sc);
                    u += ui * w;
                    dv += (f.v[i] - f.v0[i]) * w;
                    pic += f.v[i] * w;
                    inc += ui * st.gradient(a, b).transpose();
                }
            }
            (u, dv, pic, inc * fp)
        };
        // First every point is checked, so that a failed step leaves them all as they were
        // (the step is then split, or the run stops on the state before it).
        for (g, grain) in self.grains.iter().enumerate() {
            let law = self.laws[grain.law].as_ref();
            for (q, p) in grain.points.clone().enumerate() {
                let (_, _, _, fnew) = kinematics(&self.fields[g], q, &self.points.f[p]);
                let j = fnew.determinant();
                if !(j > 0.0 && law.response(&fnew, &self.points.history[p]).is_some()) {
                    return Err(fail(InstabilityCause::Inverted { grain: g, point: p, jacobian: j }));
                }
            }
        }
        for (g, grain) in self.grains.iter().enumerate() {
            let law = self.laws[grain.law].as_ref();
            for (q, p) in grain.points.clone().enumerate() {
                let (u, dv, pic, fnew) = kinematics(&self.fields[g], q, &self.points.f[p]);
                let Some(r) = law.response(&fnew, &self.points.history[p]) else {
                    return Err(fail(InstabilityCause::Inverted { grain: g, point: p, jacobian: fnew.determinant() }));
                };
                self.points.history[p] = r.history;
                self.points.f[p] = fnew;
                self.points.x[p] += u;
                self.points.v[p] = (self.points.v[p] + dv) * flip + pic * (1.0 - flip);
            }
        }
        Ok(())
    }
}
