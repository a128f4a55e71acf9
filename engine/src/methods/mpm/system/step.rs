//! One attempt at a step without splitting: each grain's projection, the contacts, Newton's
//! iterations on the nodal velocities with the contact solve between them, then the points'
//! move with their grains' converged fields (module documentation of [`super`]).

use rayon::prelude::*;

use super::System;
use crate::error::InstabilityCause;
use crate::math::Real;
use crate::methods::mpm::contact::FORCING;
use crate::methods::mpm::field::{Field, PointFailure, Scheme};
use crate::methods::mpm::grid::V2;
use crate::methods::soft::augment;
use crate::methods::soft::parts::{fail, StepFailure, StepReport};
use crate::methods::soft::trace::NewtonRecord;
use crate::methods::soft::{largest, REFRESH_RATIO};
use crate::nscd::NlgsReport;

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

/// Where a step's Newton iterations stand (what one iteration leaves the next).
#[derive(Debug, Clone, Copy)]
struct NewtonPace {
    /// The last relative correction (infinite before the first).
    last: Real,
    /// The next iteration assembles and factorises the matrix anew.
    refresh: bool,
    /// Iterations in a row with a matrix assembled at their own iterate.
    fresh_in_a_row: u32,
    /// The fraction of each correction taken ([`CYCLE_RATE`]).
    fraction: Real,
    /// The mass-weighted square of the previous iteration's correction.
    last_squared: Real,
}

impl Default for NewtonPace {
    /// Before the first iteration: a new matrix, the whole correction taken.
    fn default() -> Self {
        Self { last: Real::INFINITY, refresh: true, fresh_in_a_row: 0, fraction: 1.0, last_squared: 0.0 }
    }
}

impl NewtonPace {
    /// Whether iteration `it`, at the relative correction `relative` that shrank by `rate`,
    /// stalls ([`STALL_AFTER`]): at that rate Newton's tolerance would not be reached within
    /// the budget (`tolerance`, `budget`).
    fn stalled(&self, it: u32, relative: Real, rate: Real, (tolerance, budget): (Real, u32)) -> bool {
        if !(self.fresh_in_a_row >= 2 && it >= STALL_AFTER && rate > STALL_RATIO) {
            return false;
        }
        let needed = if rate < 1.0 { (tolerance / relative).ln() / rate.ln() } else { Real::INFINITY };
        Real::from(it) + needed > Real::from(budget)
    }

    /// After an iteration at the relative correction `relative` that shrank by `rate`:
    /// `cycling` (points switching, or the correction turning back) while it does not shrink
    /// halves the fraction taken, a fast contraction doubles it back ([`CYCLE_RATE`]); the
    /// matrix is kept while it contracts the correction fast enough.
    fn next(&mut self, relative: Real, rate: Real, cycling: bool) {
        if rate >= CYCLE_RATE && cycling {
            self.fraction = (0.5 * self.fraction).max(MIN_FRACTION);
        } else if rate < 0.6 {
            self.fraction = (2.0 * self.fraction).min(1.0);
        }
        self.refresh = relative > REFRESH_RATIO * self.last;
        self.last = relative;
    }
}

/// The mass-weighted root mean square over the `fields`' nodes of the velocity `of` picks.
fn rms(fields: &[Field], of: fn(&Field, usize) -> V2) -> Real {
    let (mut s, mut m) = (0.0, 0.0);
    for f in fields {
        for i in 0..f.nodes() {
            s += f.mass[i] * of(f, i).norm_squared();
            m += f.mass[i];
        }
    }
    (s / m.max(Real::MIN_POSITIVE)).sqrt()
}

impl System {
    fn point_failure(&self, f: PointFailure) -> StepFailure {
        let grain_of = |p: usize| self.grains.iter().position(|g| g.points.contains(&p)).unwrap_or(0);
        match f {
            PointFailure::LeftGrid(p) => fail(InstabilityCause::LeftGrid { grain: grain_of(p), point: p }),
            PointFailure::Inverted(p, j) => fail(InstabilityCause::Inverted { grain: grain_of(p), point: p, jacobian: j }),
        }
    }

    /// One step of `dt` without splitting; `stall_check`: the Newton iterations may end early
    /// ([`STALL_AFTER`]).
    pub(super) fn try_step(&mut self, dt: Real, stall_check: bool) -> Result<StepReport, StepFailure> {
        let sc = self.settings.scheme(dt);
        // 1. The fields.
        self.begin_fields()?;
        // 2. The candidate contacts.
        self.detect();
        let mut report = StepReport { contacts: self.contacts.len(), ..StepReport::default() };
        // 3. Newton.
        self.newton(&sc, stall_check, &mut report)?;
        // 4. The points.
        self.finish(&sc)?;
        Ok(report)
    }

    /// Every grain projects its points on its nodes (mass, velocity, internal force at the
    /// start).
    fn begin_fields(&mut self) -> Result<(), StepFailure> {
        let (grid, points, laws, ghost, rest) = (&self.grid, &self.points, &self.laws, self.ghost, self.settings.quasi_static);
        let begun: Result<(), PointFailure> = self
            .fields
            .par_iter_mut()
            .zip(&self.grains)
            .try_for_each(|(f, g)| f.begin(grid, points, g.points.clone(), laws[g.law].as_ref(), ghost, rest));
        begun.map_err(|e| self.point_failure(e))
    }

    /// Newton's iterations on the nodal velocities with the contact solve between them, until
    /// the correction is within Newton's tolerance; their iterations and sweeps into `report`.
    fn newton(&mut self, sc: &Scheme, stall_check: bool, report: &mut StepReport) -> Result<(), StepFailure> {
        let mut scale = self.velocity_scale(sc);
        let mass = self.fields.iter().map(|f| f.mass.iter().sum::<Real>()).sum::<Real>();
        let mut pace = NewtonPace::default();
        self.nlgs.settings.tolerance = self.settings.contact.tolerance;
        for it in 1..=self.settings.max_newton {
            report.newton = it;
            pace.fresh_in_a_row = if pace.refresh { pace.fresh_in_a_row + 1 } else { 0 };
            self.newton_free(sc, pace.refresh)?;
            if it <= DRIFT_ITERATIONS {
                self.measure_drifts(sc);
            }
            let solved = self.solve_contacts(sc, (mass, scale));
            report.sweeps += solved.iterations;
            self.tracer.count(it, report.sweeps, report.contacts);
            if !solved.converged {
                return Err(fail(solved.budget_failure(&self.settings.contact)));
            }
            let (dv2, m, against_last) = self.newton_update(pace.fraction);
            let reversed = it > 1 && against_last < REVERSAL * (dv2 * pace.last_squared).sqrt();
            pace.last_squared = dv2;
            let correction = (dv2 / m.max(Real::MIN_POSITIVE)).sqrt();
            if it == 1 {
                scale = scale.max(correction);
            }
            scale = scale.max(rms(&self.fields, |f, i| f.v[i]));
            let relative = correction / scale.max(Real::MIN_POSITIVE);
            self.trace_iteration(sc, (it, relative, solved.iterations, report.contacts), &pace, reversed);
            if relative <= self.settings.newton_tolerance {
                return Ok(());
            }
            // An attempt that converges too slowly to make it within the budget stops now.
            let rate = relative / pace.last;
            if stall_check && pace.stalled(it, relative, rate, (self.settings.newton_tolerance, self.settings.max_newton)) {
                return Err(fail(self.newton_budget(it, relative)));
            }
            // Points switching between elastic and plastic, or (at the last chance) the
            // correction turning back, while it does not shrink: a cycle (between the return
            // mapping's two branches, or a two-cycle of the iterates), which a shorter step
            // does not break ([`CYCLE_RATE`], [`REVERSAL`]).
            let switching = it > 1 && self.fields.iter().any(|f| f.switches > 0);
            pace.next(relative, rate, switching || (reversed && !stall_check));
            // The next contact solve is made a hundred times more accurate than this
            // correction (inexact Newton's forcing term).
            self.nlgs.settings.tolerance = (FORCING * relative).clamp(1e-12, self.settings.contact.tolerance);
        }
        Err(fail(self.newton_budget(self.settings.max_newton, pace.last)))
    }

    /// The velocity scale Newton's corrections are measured against: the walls', gravity's over
    /// the step, the nodes' at the start, and at least a thousandth of a cell per step (a
    /// packing at rest under fixed walls would otherwise measure its corrections against
    /// round-off: 24 iterations a step at equilibrium).
    fn velocity_scale(&self, sc: &Scheme) -> Real {
        let floor = 1e-3 * self.grid.h / sc.dt;
        let v_ref = self.walls.iter().map(|w| w.velocity.norm()).fold((self.settings.gravity.norm() * sc.dt).max(floor), Real::max);
        v_ref.max(rms(&self.fields, |f, i| f.v0[i]))
    }

    /// Traces Newton iteration `it` (its relative correction, its contact solve's sweeps and the
    /// contacts), with its points switching, the fraction taken, whether its matrix was new and
    /// the grains whose matrix was damped.
    fn trace_iteration(
        &mut self,
        sc: &Scheme,
        (it, relative, sweeps, contacts): (u32, Real, u32, usize),
        pace: &NewtonPace,
        reversed: bool,
    ) {
        if self.tracer.on() {
            let switching = self.fields.iter().map(|f| f.switches).sum();
            let damped = self.fields.iter().filter(|f| f.damped).count();
            let penalised = self.fields.iter().filter(|f| f.penalty > 0.0).count();
            let part = self.progress.part(sc.dt);
            let (fraction, refresh) = (pace.fraction, pace.refresh);
            self.tracer.emit(|| NewtonRecord {
                switching: Some(switching),
                fraction: Some(fraction),
                refreshed: Some(refresh),
                damped_grains: Some(damped),
                penalised_grains: Some(penalised),
                reversed: Some(reversed),
                ..NewtonRecord::iteration(part, it, relative, sweeps, contacts)
            });
        }
    }

    /// Ends a converged step: the points move with their grains' fields, the walls move, the
    /// wall forces and warm starts are kept.
    fn finish(&mut self, sc: &Scheme) -> Result<(), StepFailure> {
        self.move_points(sc)?;
        for w in &mut self.walls {
            w.point += w.velocity * sc.dt;
        }
        self.progress.end_part(&self.contacts, sc.dt);
        self.warm.remember(&self.contacts);
        Ok(())
    }

    /// Newton's budget spent after `iterations` with the last relative `correction`, naming
    /// the grain whose correction was the largest and whether its matrix was damped.
    fn newton_budget(&self, iterations: u32, correction: Real) -> InstabilityCause {
        let grain = largest(self.fields.iter().map(|f| f.last_correction));
        let damped = grain.is_some_and(|g| self.fields[g].damped);
        InstabilityCause::NewtonBudget { iterations, correction, tolerance: self.settings.newton_tolerance, grain, damped }
    }

    /// Assembles every grain's Newton residual at the current iterate — and, when `refresh`,
    /// its matrix, factorised — solves for its free correction (into `Field::correction`), and
    /// prepares its side of the contact problem (the block of `A⁻¹` only with a new matrix).
    fn newton_free(&mut self, sc: &Scheme, refresh: bool) -> Result<(), StepFailure> {
        let (points, laws, contacts) = (&self.points, &self.laws, &self.contacts);
        let out: Result<(), (usize, Option<PointFailure>)> =
            self.fields.par_iter_mut().zip(self.sides.par_iter_mut()).enumerate().try_for_each(|(g, (f, side))| {
                let grain = &self.grains[g];
                let law = laws[grain.law].as_ref();
                if refresh {
                    augment::with_contacts_of(side, contacts, |closed, count| {
                        f.assemble(points, grain.points.clone(), law, sc, (closed, count))
                    })
                    .map_err(|e| (g, e))?;
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
        let flip = self.flip;
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
