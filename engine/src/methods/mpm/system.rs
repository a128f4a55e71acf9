//! The implicit material point method with contact dynamics, one step at a time: grains as
//! clouds of points ([`super::points`]), each with its own nodal field ([`super::field`]),
//! touching at nodes ([`super::contact`]) through the shared contact solver.
//!
//! A step:
//! 1. each grain projects its points on its nodes (mass, velocity, mass gradient, internal
//!    force at the start);
//! 2. the candidate contacts are found at the nodes two grains share and near the walls,
//!    with their normals and gaps;
//! 3. Newton iterations on the nodal velocities of every grain at once: each grain assembles
//!    its residual and matrix and solves for its free correction (no contact impulse); the
//!    contact problem, with each grain's `A⁻¹` between its contact nodes, is solved by the
//!    non-linear Gauss-Seidel sweeps of [`crate::nscd`] for the step's total impulses
//!    (warm-started from the previous iteration and step); each grain then takes its
//!    correction with the impulses. The iterations stop when the correction is below
//!    `newton_tolerance` times the velocity scale. The matrix (with its `A⁻¹` blocks) is
//!    assembled and factorised at the first iteration and kept as long as each iteration
//!    divides the correction by four or more (a modified Newton: the fixed point, where the
//!    residual balances the contact impulses, does not depend on the matrix, and the contact
//!    problem uses the same `A⁻¹` as the update, so the two stay consistent). The tangent and
//!    the factorisation were two thirds of an iteration's cost;
//! 4. the points move with their nodes: displacement `Σ N_i u_i`, deformation gradient
//!    `(I + Σ u_i ⊗ ∇N_i) F`, history from the law, velocity by a FLIP/PIC blend.
//!
//! A step that fails (Newton or the contact solve over budget, a matrix that stays
//! indefinite, an inverted point) is done again in halves, and the steps after it keep parts
//! that short until ten in a row converge ([`System::step`]). In a dense packing the grains'
//! stress makes the geometric stiffness of their rotation outweigh their inertia over a long
//! step ([`super::field`]); the damped matrix then converges slowly (measured on a 60-grain
//! compaction past Φ 0.85: the correction shrinking by 0.88 an iteration, the budget of 25
//! spent), and trying every step whole first cost a 300-grain compaction more than half its
//! time.
//!
//! Momentum is conserved exactly by every iteration (the internal forces of a grain sum to
//! zero and the contact impulses are equal and opposite), whatever the convergence.

use std::collections::HashMap;

use rayon::prelude::*;

use super::contact::{extent, End, GrainContacts, NodalContact, Other, Problem, Support, Wall};
use super::field::{Field, PointFailure, Scheme};
use super::grid::{Grid, V2};
use super::points::{Grain, Points};
use crate::constitutive::ConstitutiveLaw;
use crate::error::InstabilityCause;
use crate::math::{Real, Vec3};
use crate::nscd::local::{Delassus, LocalLaw};
use crate::nscd::{ContactFrame, Convergence, Nlgs, NlgsReport};

/// A Newton iteration that reduces the correction by less than this factor makes the next one
/// assemble and factorise the matrix anew; otherwise the next one keeps it (module
/// documentation).
const REFRESH_RATIO: Real = 0.25;

/// The contact solve of a Newton iteration stops at a relative change of the impulses below
/// this fraction of the last iteration's relative correction (or below the settings'
/// tolerance, if smaller). Gauss-Seidel's last change understates its error when it converges
/// slowly, as it does on a dense packing: with the settings' 1e-6 alone, the Newton iterations
/// of a dense compaction converged only as fast as the sweeps they added (a ratio of 0.4 an
/// iteration, twelve iterations a step); with this forcing, 5 to 7.
const FORCING: Real = 0.01;

/// The Newton iterations of a step that update the contacts' targets with the growth of their
/// points' extents at the iterate; later ones keep them (a target that moves with every
/// iterate kept a dense packing's iterations from converging).
const GROWTH_ITERATIONS: u32 = 2;

/// The deepest a step is split: into `2^MAX_DEPTH` parts.
const MAX_DEPTH: u32 = 4;

/// Steps in a row without a failure after which the next one tries parts twice as long.
const CALM_STEPS: u32 = 10;

/// A Newton iteration from this one on that contracts the correction by less than
/// [`STALL_RATIO`], with the matrix assembled at its own iterate and the one before, ends the
/// attempt early when, at that rate, the tolerance would not be reached within the budget:
/// the part is then split at once instead of after the budget (not at the deepest level,
/// where the budget is the last chance).
const STALL_AFTER: u32 = 6;

/// See [`STALL_AFTER`].
const STALL_RATIO: Real = 0.5;

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
}

/// What a step cost.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
    /// Newton iterations.
    pub newton: u32,
    /// Contact-solver sweeps, over all iterations.
    pub sweeps: u32,
    /// Candidate nodal contacts.
    pub contacts: usize,
}

/// Why a step failed (the method turns it into an [`crate::EngineError::Unstable`]).
#[derive(Debug, Clone, PartialEq)]
pub struct StepFailure {
    /// What happened.
    pub cause: InstabilityCause,
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
    /// The nodal contacts of the last step, with their impulses.
    pub contacts: Vec<NodalContact>,
    /// Steps done.
    pub steps: u64,
    /// Time, s.
    pub time: Real,
    /// Newton iterations and contact sweeps since the start.
    pub totals: StepReport,
    /// Step parts that failed and were done again as two halves, since the start.
    pub substeps: u64,
    /// Step parts done since the start (a step is one part unless it was split).
    pub parts: u64,
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
    /// The level the next step starts at ([`System::step`]).
    depth: u32,
    /// Steps since the last failure at `depth`.
    calm: u32,
    fields: Vec<Field>,
    sides: Vec<GrainContacts>,
    warm: HashMap<(usize, u32, i64), Vec3>,
    nlgs: Nlgs,
}

fn fail(cause: InstabilityCause) -> StepFailure {
    StepFailure { cause }
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
            substeps: 0,
            parts: 0,
            wall_impulse: vec![V2::zeros(); walls_len],
            wall_force: vec![V2::zeros(); walls_len],
            last_dt: settings.dt,
            depth: 0,
            calm: 0,
            pair_friction: None,
            fields: (0..n).map(|_| Field::default()).collect(),
            sides: vec![GrainContacts::default(); n],
            warm: HashMap::new(),
            nlgs: Nlgs::new(settings.contact),
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
            + self.contacts.capacity() * std::mem::size_of::<NodalContact>()
            + self.nlgs.heap_bytes()
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

    /// Advances one step of `settings.dt` (module documentation), as `2^depth` equal parts,
    /// `depth` the level the last steps needed. A part whose Newton iterations or contact solve
    /// do not converge, or whose matrix stays indefinite, is done again as two halves, down to
    /// a sixteenth of the step (nothing has moved when they fail: the points move only once the
    /// iterations converged); past that the failure is returned. The next steps start at the
    /// deepest level this one reached, and go one level coarser after [`CALM_STEPS`] steps
    /// without a failure: the grains of a dense packing are pressed hard enough that a step
    /// can be longer than the time their rotation takes to run away (the geometric stiffness
    /// of a squeezed grain outweighs its inertia, module documentation of
    /// [`super::field`]), and a failed attempt costs its whole Newton budget.
    pub fn step(&mut self) -> Result<StepReport, StepFailure> {
        self.wall_impulse.iter_mut().for_each(|p| *p = V2::zeros());
        let start = self.depth;
        let parts = 1u32 << start;
        let mut report = StepReport::default();
        let mut deepest = start;
        for _ in 0..parts {
            let (part, depth) = self.advance(self.settings.dt / Real::from(parts), start)?;
            report.newton += part.newton;
            report.sweeps += part.sweeps;
            report.contacts = part.contacts;
            deepest = deepest.max(depth);
        }
        if deepest > start {
            self.depth = deepest;
            self.calm = 0;
        } else {
            self.calm += 1;
            if self.calm >= CALM_STEPS && self.depth > 0 {
                self.depth -= 1;
                self.calm = 0;
            }
        }
        self.steps += 1;
        self.totals.newton += report.newton;
        self.totals.sweeps += report.sweeps;
        self.totals.contacts = report.contacts;
        Ok(report)
    }

    /// Advances by `dt`, splitting it on a recoverable failure (`depth` halvings of the step so
    /// far); returns the cost and the deepest level a part needed.
    fn advance(&mut self, dt: Real, depth: u32) -> Result<(StepReport, u32), StepFailure> {
        match self.try_step(dt, depth < MAX_DEPTH) {
            Err(f)
                if depth < MAX_DEPTH
                    && matches!(
                        f.cause,
                        InstabilityCause::NewtonBudget { .. }
                            | InstabilityCause::NotPositiveDefinite { .. }
                            | InstabilityCause::SolverBudget { .. }
                            | InstabilityCause::Inverted { .. }
                    ) =>
            {
                self.substeps += 1;
                let (a, da) = self.advance(0.5 * dt, depth + 1)?;
                let (b, db) = self.advance(0.5 * dt, depth + 1)?;
                Ok((StepReport { newton: a.newton + b.newton, sweeps: a.sweeps + b.sweeps, contacts: b.contacts }, da.max(db)))
            }
            Err(f) => Err(f),
            Ok(r) => {
                self.parts += 1;
                Ok((r, depth))
            }
        }
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
        let mut converged = false;
        let mut last = Real::INFINITY;
        let mut refresh = true;
        self.nlgs.settings.tolerance = self.settings.contact.tolerance;
        // Iterations in a row with a matrix assembled at their own iterate.
        let mut fresh_in_a_row = 0;
        for it in 1..=self.settings.max_newton {
            report.newton = it;
            fresh_in_a_row = if refresh { fresh_in_a_row + 1 } else { 0 };
            self.newton_free(&sc, refresh)?;
            let solved = self.solve_contacts(&sc, it <= GROWTH_ITERATIONS);
            report.sweeps += solved.iterations;
            if !solved.converged {
                let s = self.settings.contact;
                return Err(fail(InstabilityCause::SolverBudget {
                    iterations: solved.iterations,
                    change: solved.last.change,
                    violation: solved.last.violation,
                    tolerance: s.tolerance,
                    violation_tolerance: s.violation_tolerance,
                    worst: solved.last.worst,
                    worst_tolerance: s.worst_tolerance,
                }));
            }
            let (dv2, m) = self.newton_update();
            let correction = (dv2 / m.max(Real::MIN_POSITIVE)).sqrt();
            if it == 1 {
                scale = scale.max(correction);
            }
            scale = scale.max(rms(&self.fields, |f, i| f.v[i]));
            let relative = correction / scale.max(Real::MIN_POSITIVE);
            if relative <= self.settings.newton_tolerance {
                converged = true;
                break;
            }
            // An attempt that converges too slowly to make it within the budget stops now.
            let rate = relative / last;
            if stall_check && fresh_in_a_row >= 2 && it >= STALL_AFTER && rate > STALL_RATIO {
                let needed = if rate < 1.0 { (self.settings.newton_tolerance / relative).ln() / rate.ln() } else { Real::INFINITY };
                if Real::from(it) + needed > Real::from(self.settings.max_newton) {
                    return Err(fail(InstabilityCause::NewtonBudget {
                        iterations: it,
                        correction: relative,
                        tolerance: self.settings.newton_tolerance,
                    }));
                }
            }
            // The matrix is kept while it contracts the correction fast enough.
            refresh = relative > REFRESH_RATIO * last;
            // The next contact solve is made a hundred times more accurate than this
            // correction (inexact Newton's forcing term).
            self.nlgs.settings.tolerance = (FORCING * relative).clamp(1e-12, self.settings.contact.tolerance);
            last = relative;
        }
        if !converged {
            return Err(fail(InstabilityCause::NewtonBudget {
                iterations: self.settings.max_newton,
                correction: last,
                tolerance: self.settings.newton_tolerance,
            }));
        }
        // 4. The points.
        self.move_points(&sc)?;
        for w in &mut self.walls {
            w.point += w.velocity * sc.dt;
        }
        self.wall_force.iter_mut().for_each(|p| *p = V2::zeros());
        self.last_dt = sc.dt;
        for c in &self.contacts {
            if let Other::Wall(k) = c.b {
                let p = c.frame.to_global(&c.r);
                self.wall_impulse[k as usize] -= V2::new(p.x, p.y);
                self.wall_force[k as usize] -= V2::new(p.x, p.y) / sc.dt;
            }
        }
        self.warm.clear();
        for c in &self.contacts {
            if c.r != Vec3::zeros() {
                self.warm.insert(c.key(), c.r);
            }
        }
        self.time += sc.dt;
        Ok(report)
    }

    /// Finds the candidate contacts of the step, their frames, gaps, laws and warm starts, and
    /// each grain's contact nodes.
    fn detect(&mut self) {
        let (grid, h) = (self.grid, self.grid.h);
        // Grid node, grain, local node, for every node with mass.
        let mut at: Vec<(usize, u32, u32)> = Vec::new();
        for (g, f) in self.fields.iter().enumerate() {
            for k in 0..f.nodes() {
                if f.mass[k] > 0.0 {
                    let (i, j) = f.grid_node(k);
                    at.push((i + grid.nx * j, g as u32, k as u32));
                }
            }
        }
        at.sort_unstable();
        struct Candidate {
            node: usize,
            a: u32,
            ka: u32,
            b: Option<(u32, u32)>,
            wall: u32,
            n: V2,
            x: V2,
        }
        let mut cands: Vec<Candidate> = Vec::new();
        let mut s = 0;
        while s < at.len() {
            let mut e = s + 1;
            while e < at.len() && at[e].0 == at[s].0 {
                e += 1;
            }
            for x in s..e {
                for y in x + 1..e {
                    let (node, ga, ka) = at[x];
                    let (_, gb, kb) = at[y];
                    let d = self.fields[ga as usize].mass_gradient[ka as usize] - self.fields[gb as usize].mass_gradient[kb as usize];
                    let len = d.norm();
                    if len > 0.0 && len.is_finite() {
                        cands.push(Candidate {
                            node,
                            a: ga,
                            ka,
                            b: Some((gb, kb)),
                            wall: 0,
                            n: d / len,
                            x: grid.node_position(node % grid.nx, node / grid.nx),
                        });
                    }
                }
            }
            s = e;
        }
        for (g, f) in self.fields.iter().enumerate() {
            for k in 0..f.nodes() {
                if f.mass[k] == 0.0 {
                    continue;
                }
                let (i, j) = f.grid_node(k);
                let x = grid.node_position(i, j);
                for (w, wall) in self.walls.iter().enumerate() {
                    if (x - wall.point).dot(&wall.normal) < 2.5 * h {
                        cands.push(Candidate {
                            node: i + grid.nx * j,
                            a: g as u32,
                            ka: k as u32,
                            b: None,
                            wall: w as u32,
                            n: wall.normal,
                            x,
                        });
                    }
                }
            }
        }
        // Gaps from the points of each stencil: per grain, each local node's candidates.
        let mut lo = vec![Real::INFINITY; cands.len()];
        let mut hi = vec![Real::NEG_INFINITY; cands.len()];
        // The point that sets each extent (grain `a`'s, then grain `b`'s), and the mass-weighted
        // place across the normal of each grain's points in the column with their mass (a
        // column at a grain's edge holds material on one side of its node only).
        let mut extreme = vec![[u32::MAX; 2]; cands.len()];
        let mut across_sum = vec![[V2::zeros(); 2]; cands.len()];
        let mut by_grain: Vec<Vec<(u32, u32, bool)>> = vec![Vec::new(); self.grains.len()];
        for (c, k) in cands.iter().enumerate() {
            by_grain[k.a as usize].push((k.ka, c as u32, true));
            match k.b {
                Some((gb, kb)) => by_grain[gb as usize].push((kb, c as u32, false)),
                None => hi[c] = (self.walls[k.wall as usize].point - k.x).dot(&k.n),
            }
        }
        for (g, list) in by_grain.iter_mut().enumerate() {
            if list.is_empty() {
                continue;
            }
            list.sort_unstable();
            let f = &self.fields[g];
            let grain = &self.grains[g];
            for (q, p) in grain.points.clone().enumerate() {
                let st = f.stencils[q];
                for a in 0..3 {
                    for b in 0..3 {
                        let k = f.local(st.base[0] + a, st.base[1] + b) as u32;
                        let first = list.partition_point(|e| e.0 < k);
                        for &(_, c, is_a) in list[first..].iter().take_while(|e| e.0 == k) {
                            let cand = &cands[c as usize];
                            let node = cand.x;
                            // Only the points in the node's own column along the normal
                            // (within half a cell across it): the gap at the node's place,
                            // not the nearest one over the stencil's three cells.
                            let across = (self.points.x[p] - node).dot(&V2::new(-cand.n.y, cand.n.x));
                            if across.abs() > 0.5 * h {
                                continue;
                            }
                            let (l, u) = extent(&self.points, p, &node, &cand.n);
                            let c = c as usize;
                            let m = self.points.mass[p];
                            across_sum[c][usize::from(!is_a)] += V2::new(m * across, m);
                            if is_a && l < lo[c] {
                                lo[c] = l;
                                extreme[c][0] = p as u32;
                            } else if !is_a && u > hi[c] {
                                hi[c] = u;
                                extreme[c][1] = p as u32;
                            }
                        }
                    }
                }
            }
        }
        // The contacts within a cell of touching, with each grain's samples.
        for side in &mut self.sides {
            side.clear();
        }
        self.contacts.clear();
        for (c, k) in cands.iter().enumerate() {
            let gap = lo[c] - hi[c];
            // Only the nodes within half a cell of the interface along the normal (one a
            // column): a constraint in every column of every node the two fields share (three
            // rows with quadratic splines) would lock a layer a cell thick into a rigid punch.
            let middle = match k.b {
                Some(_) => 0.5 * (lo[c] + hi[c]),
                None => lo[c],
            };
            if gap.is_nan() || gap > h || middle < -0.5 * h || middle >= 0.5 * h {
                continue;
            }
            // Each grain's contact in the node's column acts at `x_node + d n + a t`: `d` the
            // depth of the centre of the point that sets its extent, `a` where the column's
            // material is across the normal, moving with the velocity the field gives it there
            // (the nodes of its stencil share the impulse by their weights, those the grain has
            // no mass at left out). Module documentation of [`super::contact`] for why there.
            let t = V2::new(-k.n.y, k.n.x);
            let sample = |side: usize| {
                let p = extreme[c][side] as usize;
                let [m, w] = [across_sum[c][side].x, across_sum[c][side].y];
                k.x + k.n * (self.points.x[p] - k.x).dot(&k.n) + t * (m / w)
            };
            let ends = |side: usize| {
                let p = extreme[c][side] as usize;
                End { point: p as u32, extent: self.points.half_extent(p, &k.n) }
            };
            let at_a = sample(0);
            let Some(support_a) = self.surface_support(k.a, &at_a) else {
                continue;
            };
            let mut end = [ends(0), End::NONE];
            let (b, friction, at) = match k.b {
                Some((gb, _)) => {
                    end[1] = ends(1);
                    let at_b = sample(1);
                    let Some(support_b) = self.surface_support(gb, &at_b) else {
                        continue;
                    };
                    let index = self.contacts.len() as u32;
                    let slot = self.sides[gb as usize].push(support_b, index, false);
                    let friction = self
                        .pair_friction
                        .unwrap_or_else(|| (self.grains[k.a as usize].friction * self.grains[gb as usize].friction).sqrt());
                    (Other::Grain { grain: gb, slot }, friction, 0.5 * (at_a + at_b))
                }
                None => {
                    let friction = (self.grains[k.a as usize].friction * self.walls[k.wall as usize].friction).sqrt();
                    (Other::Wall(k.wall), friction, at_a)
                }
            };
            self.push_contact(k.node, at, k.a, support_a, b, k.n, gap, friction, end);
        }
    }

    /// The nodes of grain `g` that carry its field at `x`, with their weights renormalised over
    /// those where it has mass, in increasing order; `None` if there are none.
    fn surface_support(&self, g: u32, x: &V2) -> Option<Support> {
        let st = self.grid.stencil(x)?;
        let f = &self.fields[g as usize];
        let mut list: [(u32, Real); 9] = [(0, 0.0); 9];
        let mut len = 0;
        let mut total = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                let (i, j) = (st.base[0] + a, st.base[1] + b);
                if i < f.i0 || j < f.j0 || i >= f.i0 + f.wx || j >= f.j0 + f.wy {
                    continue;
                }
                let k = f.local(i, j);
                let wt = st.weight(a, b);
                if f.mass[k] == 0.0 || wt == 0.0 {
                    continue;
                }
                list[len] = (k as u32, wt);
                len += 1;
                total += wt;
            }
        }
        if len == 0 {
            return None;
        }
        list[..len].sort_unstable_by_key(|e| e.0);
        let mut support = Support { nodes: [0; 9], weights: [0.0; 9], len: len as u8 };
        for (l, &(k, w)) in list[..len].iter().enumerate() {
            support.nodes[l] = k;
            support.weights[l] = w / total;
        }
        Some(support)
    }

    /// Adds a contact of the step, warm-started, and enters it at grain `a` with its sample
    /// (grain `b`'s, if any, is entered).
    #[allow(clippy::too_many_arguments)]
    fn push_contact(&mut self, node: usize, at: V2, a: u32, support: Support, b: Other, n: V2, gap: Real, friction: Real, ends: [End; 2]) {
        let frame = ContactFrame::new(2, Vec3::new(n.x, n.y, 0.0));
        // The Signorini target is set by the step's first iterations (`solve_contacts`).
        let law = LocalLaw { target: 0.0, friction, cohesion: 0.0, viscosity: 0.0 };
        let index = self.contacts.len() as u32;
        let slot = self.sides[a as usize].push(support, index, true);
        let mut contact = NodalContact {
            node,
            at,
            a,
            slot,
            b,
            frame,
            gap,
            ends,
            law,
            w: Delassus { n: 0.0, t: 0.0 },
            r: Vec3::zeros(),
            scale: 0.0,
            lever: self.grains[a as usize].radius,
        };
        contact.r = self.warm.get(&contact.key()).copied().unwrap_or_else(Vec3::zeros);
        self.contacts.push(contact);
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
                let mut dv = std::mem::take(&mut f.correction);
                dv.clear();
                dv.extend(f.residual.iter().flat_map(|r| [-r.x, -r.y]));
                f.solve(&mut dv);
                if !side.is_empty() {
                    if refresh {
                        side.invert(f);
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

    /// Sets each contact's Delassus block and impulse scale and solves the contact problem.
    fn solve_contacts(&mut self, sc: &Scheme, update_targets: bool) -> NlgsReport {
        let g = self.settings.gravity.norm() * sc.dt;
        let (fields, grains, points) = (&self.fields, &self.grains, &self.points);
        // How much the half extent along `n` of the point at an end of a contact has grown
        // over the step at the current iterate.
        let growth = |end: &End, grain: u32, n: &V2| {
            if end.point == u32::MAX {
                return 0.0;
            }
            let g = grain as usize;
            let q = end.point as usize - grains[g].points.start;
            points.half_extent_of(&fields[g].f_new[q], end.point as usize, n) - end.extent
        };
        for c in &mut self.contacts {
            // The surfaces meet at the step's end if the centres close the gap less what the
            // points' extents grew (a compressed point's surface falls behind its centre): the
            // approach allowed grows by what they shrank, and the contact never pushes the
            // grains apart for a point that grew (no work from the points' squares turning).
            let n = V2::new(c.frame.n.x, c.frame.n.y);
            let b_grain = match c.b {
                Other::Grain { grain, .. } => grain,
                Other::Wall(_) => 0,
            };
            if update_targets {
                let grown = growth(&c.ends[0], c.a, &n) + growth(&c.ends[1], b_grain, &n);
                c.law.target = ((-c.gap + grown) / sc.dt).min(0.0);
            }
            let sa = &self.sides[c.a as usize];
            let mut w = sa.block(c.slot as usize, c.slot as usize);
            let ua = sa.u[c.slot as usize];
            let mut speed = ua.norm();
            let ub = match c.b {
                Other::Grain { grain, slot } => {
                    let sb = &self.sides[grain as usize];
                    w += sb.block(slot as usize, slot as usize);
                    speed += sb.u[slot as usize].norm();
                    sb.u[slot as usize]
                }
                Other::Wall(k) => self.walls[k as usize].velocity,
            };
            let t = V2::new(c.frame.t1.x, c.frame.t1.y);
            c.w = Delassus { n: n.dot(&(w * n)), t: t.dot(&(w * t)) };
            let u_n = (ua - ub).dot(&n);
            c.scale = (u_n.abs() + g + 1e-6 * speed) / c.w.n;
        }
        let d = self.mean_diameter();
        let mut problem = Problem { contacts: &mut self.contacts, grains: &mut self.sides, walls: &self.walls };
        self.nlgs.solve_problem(&mut problem, sc.dt, d)
    }

    /// Adds each grain's correction with the contact impulses to its iterate; returns the
    /// mass-weighted squared correction and the mass.
    fn newton_update(&mut self) -> (Real, Real) {
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
                let (mut s, mut m) = (0.0, 0.0);
                for i in 0..f.nodes() {
                    let d = V2::new(dv[2 * i], dv[2 * i + 1]);
                    if f.mass[i] > 0.0 {
                        f.v[i] += d;
                        s += f.mass[i] * d.norm_squared();
                        m += f.mass[i];
                    }
                }
                f.correction = dv;
                (s, m)
            })
            .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
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
