//! How far a soft-grain method's system has gone ([`Progress`]): its steps and time, what they
//! cost, the level they are split at, the walls' loads of the last step and the length of its
//! last part — kept alike by every soft-grain method's system, and a step's bookkeeping
//! ([`step`], [`Progress::end_part`]) written once.

use nalgebra::Vector2;

use super::contact::{wall_impulses, VertexContact};
use super::parts::{Cost, Splitting, StepFailure, StepParts, StepReport};
use crate::math::Real;

type V2 = Vector2<Real>;

/// A soft-grain system's steps so far (module documentation).
#[derive(Debug, Clone)]
pub struct Progress {
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
    /// Duration of the last part of the last step, s (the step, or its last part when split):
    /// the contacts' impulses are over it.
    last_dt: Real,
}

impl Progress {
    /// No step done, at time 0, against `walls` walls; `dt`: the step, s (the last part's
    /// duration until a part is done).
    pub fn new(walls: usize, dt: Real) -> Self {
        Self {
            steps: 0,
            time: 0.0,
            totals: StepReport::default(),
            splitting: Splitting::default(),
            wall_impulse: vec![V2::zeros(); walls],
            wall_force: vec![V2::zeros(); walls],
            last_dt: dt,
        }
    }

    /// Duration of the last part of the last step, s: the contacts' impulses are over it.
    pub fn last_dt(&self) -> Real {
        self.last_dt
    }

    /// The part of `dt` (s) about to be done: its step's number, its start time (s) and `dt`
    /// (the trace's record of it).
    pub fn part(&self, dt: Real) -> (u64, Real, Real) {
        (self.steps + 1, self.time, dt)
    }

    /// What the steps cost since the start: Newton iterations, contact sweeps, step parts
    /// done and failed (done again as two halves), and the failures' causes.
    pub fn cost(&self) -> Cost {
        Cost::new(&self.totals, &self.splitting)
    }

    /// Ends a converged part of `dt` (s) whose contacts (with their impulses over it) are
    /// `contacts`: the walls' impulses of the part are added to the step's, their forces are
    /// those impulses over `dt`, and the clock moves on by `dt`.
    pub fn end_part(&mut self, contacts: &[VertexContact], dt: Real) {
        self.last_dt = dt;
        wall_impulses(contacts, &mut self.wall_force);
        for (impulse, p) in self.wall_impulse.iter_mut().zip(self.wall_force.iter_mut()) {
            *impulse += *p;
            *p /= dt;
        }
        self.time += dt;
    }
}

/// Advances `sys` by one step of `dt` (s), in parts where it fails ([`Splitting`]), and counts
/// it in its progress (`progress` picks that out of `sys`): the walls' impulses start from zero,
/// and a step done adds to the steps and the totals.
pub fn step<S: StepParts>(sys: &mut S, progress: fn(&mut S) -> &mut Progress, dt: Real) -> Result<StepReport, StepFailure> {
    let p = progress(sys);
    p.wall_impulse.iter_mut().for_each(|p| *p = V2::zeros());
    let mut splitting = std::mem::take(&mut p.splitting);
    let done = splitting.step(sys, dt);
    let p = progress(sys);
    p.splitting = splitting;
    let report = done?;
    p.steps += 1;
    p.totals.add(&report);
    Ok(report)
}
