//! One part of a step without splitting: each grain's residual, matrix and free correction,
//! the contact solve between them, Newton's iterations to convergence, the drifts checked once
//! more, then the grains and walls moved (module documentation of [`super`]).

use rayon::prelude::*;

use super::{Grain, Pace, System, DRIFT_TOLERANCE};
use crate::error::InstabilityCause;
use crate::math::Real;
use crate::methods::fem::body::{add_correction, BodyFailure};
use crate::methods::soft::augment;
use crate::methods::soft::contact;
use crate::methods::soft::node_block::Half;
use crate::methods::soft::parts::{fail, StepFailure, StepReport};
use crate::methods::soft::trace::NewtonRecord;
use crate::methods::soft::{largest, Scheme, REFRESH_RATIO};

/// The Newton iterations of a step that measure the contacts' drifts at their iterate.
const DRIFT_ITERATIONS: u32 = 2;

fn body_failure(grain: usize, f: BodyFailure, tolerance: Real) -> StepFailure {
    fail(match f {
        BodyFailure::BadMesh { element } | BodyFailure::Inverted { element, .. } => {
            let jacobian = if let BodyFailure::Inverted { jacobian, .. } = f { jacobian } else { 0.0 };
            InstabilityCause::InvertedElement { grain, element, jacobian }
        }
        BodyFailure::NotPositiveDefinite => InstabilityCause::NotPositiveDefinite { grain },
        BodyFailure::NewtonBudget { iterations, correction, damped } => {
            InstabilityCause::NewtonBudget { iterations, correction, tolerance, grain: Some(grain), damped }
        }
    })
}

impl System {
    /// One part of `dt` without splitting; `last_chance`: it cannot be split further.
    pub(super) fn try_step(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let sc = self.settings.scheme(dt);
        let rest = self.settings.quasi_static;
        self.grains.par_iter_mut().for_each(|g| g.body.begin(rest));
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
        self.reset_pace(dt);
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
            self.tracer.count(it, report.sweeps, report.contacts);
            if !solved.converged {
                return Err(fail(solved.budget_failure(&self.settings.contact)));
            }
            let correction = self.newton_update();
            scale = scale.max(speed(&self.grains));
            let relative = correction / scale.max(Real::MIN_POSITIVE);
            self.trace_iteration(sc.dt, it, relative, solved.iterations, report.contacts);
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
            self.update_pace(tolerance * scale);
            // The next contact solve is made a hundred times more accurate than this
            // correction (inexact Newton's forcing term, as for the material point method).
            // A correction already within Newton's tolerance (one its loose first solve left
            // unconfirmed) asks for no less than a hundredth of that tolerance: on the CI
            // compaction a solve asked for 1e-12 ran out of its 20,000 sweeps at 1.5e-9.
            self.nlgs.settings.tolerance = (contact::FORCING * relative).max(floor).min(self.settings.contact.tolerance);
            last = relative;
        }
        let grain = largest(self.pace.iter().map(|p| p.correction));
        let damped = grain.is_some_and(|g| self.grains[g].body.damped);
        Err(fail(InstabilityCause::NewtonBudget { iterations: self.settings.max_newton, correction: last, tolerance, grain, damped }))
    }

    /// Starts a part's pace: a part as long as the last keeps the matrices of the grains that
    /// did not need new ones in it (module documentation).
    fn reset_pace(&mut self, dt: Real) {
        let same = self.kept == Some(dt);
        self.kept = None;
        for p in &mut self.pace {
            *p = Pace { refresh: !same || p.refreshed, done: false, refreshed: false, correction: 0.0, last: Real::INFINITY };
        }
    }

    /// After a Newton iteration: a grain keeps its matrix while it contracts its correction
    /// fast enough, or once its correction is within `converged`; one without contacts is then
    /// done.
    fn update_pace(&mut self, converged: Real) {
        for (p, side) in self.pace.iter_mut().zip(&self.sides) {
            p.done = side.is_empty() && p.correction <= converged;
            p.refresh = p.correction > converged && p.correction > REFRESH_RATIO * p.last;
            p.refreshed |= p.refresh;
            p.last = p.correction;
        }
    }

    /// Traces Newton iteration `it` of a part of `dt`, with the grains whose matrix it refreshed.
    fn trace_iteration(&mut self, dt: Real, it: u32, relative: Real, sweeps: u32, contacts: usize) {
        if self.tracer.on() {
            let refreshed = self.pace.iter().filter(|p| p.refresh && !p.done).count();
            let damped = self.grains.iter().filter(|g| g.body.damped).count();
            let penalised = self.grains.iter().filter(|g| g.body.penalty > 0.0).count();
            let part = self.progress.part(dt);
            self.tracer.emit(|| NewtonRecord {
                refreshed_grains: Some(refreshed),
                damped_grains: Some(damped),
                penalised_grains: Some(penalised),
                ..NewtonRecord::iteration(part, it, relative, sweeps, contacts)
            });
        }
    }

    /// Every grain's residual at the iterate and — when its [`Pace::refresh`] says so — its
    /// matrix, factorised, its free correction, and its side of the contact problem (the block
    /// of the inverse with a new matrix or, at the `first` iteration, with the kept one for the
    /// part's new contacts; otherwise the last one's, [`REFRESH_RATIO`]).
    fn newton_free(&mut self, sc: &Scheme, first: bool) -> Result<(), StepFailure> {
        let laws = &self.laws;
        let tolerance = self.settings.newton_tolerance;
        let pace = &self.pace;
        let contacts = &self.contacts;
        self.grains.par_iter_mut().zip(self.sides.par_iter_mut()).zip(self.corrections.par_iter_mut()).enumerate().try_for_each(
            |(g, ((grain, side), dv))| {
                let Pace { refresh, done, .. } = pace[g];
                if done {
                    return Ok(());
                }
                let body = &mut grain.body;
                let law = laws[grain.law].as_ref();
                let iterated = if refresh {
                    augment::with_contacts_of(side, contacts, |closed, count| body.iterate(law, sc, true, (closed, count)))
                } else {
                    body.iterate(law, sc, false, (&[], 0))
                };
                iterated.map_err(|f| body_failure(g, f, tolerance))?;
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
        self.progress.end_part(&self.contacts, sc.dt);
        self.warm.remember(&self.contacts);
        Ok(())
    }
}
