//! A soft-grain method's step done in parts: a part that fails in a way a shorter one can
//! mend (Newton or the contact solve over budget, a matrix that stays indefinite, an inverted
//! point or element, contacts whose geometry outran their linearisation) is done again as two
//! halves, down to `2^MAX_DEPTH` parts; past that the failure is the step's.
//!
//! The next steps start at the deepest level this one reached, and go one level coarser after
//! [`CALM_STEPS`] steps without a failure: in a dense packing the grains are pressed hard
//! enough that a whole step is longer than the time their rotation takes to run away (the
//! geometric stiffness of a squeezed grain outweighs its inertia) or than the time their
//! contacts stay on the same segments, and every failed attempt costs Newton iterations (trying
//! every step whole first cost a 300-grain MPM compaction more than half its time).

use std::collections::BTreeMap;

use crate::error::InstabilityCause;
use crate::math::Real;

/// The deepest a step is split: into `2^MAX_DEPTH` parts (the bound a saved state's
/// `split_depth` is checked against).
pub const MAX_DEPTH: u32 = crate::scene::state_points::MAX_SPLIT_DEPTH;

/// Steps in a row without a failure after which the next one tries parts twice as long.
pub const CALM_STEPS: u32 = 10;

/// What a step (or a part of one) cost.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
    /// Newton iterations.
    pub newton: u32,
    /// Contact-solver sweeps, over all iterations.
    pub sweeps: u32,
    /// Contacts (of the last part).
    pub contacts: usize,
}

impl StepReport {
    /// Adds the cost of `other`, done after this one (its contacts are the last).
    pub fn add(&mut self, other: &StepReport) {
        self.newton += other.newton;
        self.sweeps += other.sweeps;
        self.contacts = other.contacts;
    }
}

/// What a soft-grain method's steps cost since the start.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Cost {
    /// Newton iterations.
    pub newton: u64,
    /// Contact-solver sweeps.
    pub sweeps: u64,
    /// Step parts that failed and were done again as two halves.
    pub failed: u64,
    /// Step parts done (a step is one part unless it was split).
    pub parts: u64,
    /// The failed parts by their cause's [`InstabilityCause::kind`].
    pub failures: BTreeMap<&'static str, u64>,
}

impl Cost {
    /// The cost of `totals` (Newton iterations and sweeps) with `splitting`'s parts.
    pub fn new(totals: &StepReport, splitting: &Splitting) -> Self {
        Self {
            newton: u64::from(totals.newton),
            sweeps: u64::from(totals.sweeps),
            failed: splitting.substeps,
            parts: splitting.parts,
            failures: splitting.failures.clone(),
        }
    }
}

/// Why a step failed (the method turns it into an [`crate::EngineError::Unstable`]).
#[derive(Debug, Clone, PartialEq)]
pub struct StepFailure {
    /// What happened.
    pub cause: InstabilityCause,
}

/// A [`StepFailure`] of `cause`.
pub fn fail(cause: InstabilityCause) -> StepFailure {
    StepFailure { cause }
}

/// A method whose step can be done in parts.
pub trait StepParts {
    /// Advances by `dt` (s) without splitting; `last_chance`: the part cannot be split further.
    /// A part that fails must leave the grains where they were (apart from what
    /// [`StepParts::undo_part`] puts back).
    fn try_part(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure>;

    /// Puts back what a failed part changed, before its halves are tried.
    fn undo_part(&mut self) {}
}

/// Whether a shorter part can mend a failure for `cause`.
fn recoverable(cause: &InstabilityCause) -> bool {
    matches!(
        cause,
        InstabilityCause::NewtonBudget { .. }
            | InstabilityCause::NotPositiveDefinite { .. }
            | InstabilityCause::SolverBudget { .. }
            | InstabilityCause::Inverted { .. }
            | InstabilityCause::InvertedElement { .. }
            | InstabilityCause::ContactDrift { .. }
    )
}

/// The level the steps are done at, and what splitting them cost (module documentation).
#[derive(Debug, Clone, Default)]
pub struct Splitting {
    /// The level the next step starts at: `2^depth` parts.
    depth: u32,
    /// Steps since the last failure at `depth`.
    calm: u32,
    /// Step parts that failed and were done again as two halves, since the start.
    pub substeps: u64,
    /// Step parts done since the start (a step is one part unless it was split).
    pub parts: u64,
    /// The failed parts of [`Splitting::substeps`] by their cause's [`InstabilityCause::kind`].
    pub failures: BTreeMap<&'static str, u64>,
}

impl Splitting {
    /// The level the next step starts at (`2^depth` parts) and the steps since the last failure
    /// there: what a saved state keeps so that a run started from it splits its steps alike.
    pub fn level(&self) -> (u32, u32) {
        (self.depth, self.calm)
    }

    /// Starts the next step at `depth` (at most [`MAX_DEPTH`]), `calm` steps after the last
    /// failure there ([`Splitting::level`]).
    pub fn resume(&mut self, depth: u32, calm: u32) {
        self.depth = depth.min(MAX_DEPTH);
        self.calm = calm.min(CALM_STEPS);
    }

    /// Advances `sys` by one step of `dt` (s) as `2^depth` equal parts (module documentation).
    pub fn step<S: StepParts>(&mut self, sys: &mut S, dt: Real) -> Result<StepReport, StepFailure> {
        let start = self.depth;
        let parts = 1u32 << start;
        let mut report = StepReport::default();
        let mut deepest = start;
        for _ in 0..parts {
            let (part, depth) = self.advance(sys, dt / Real::from(parts), start)?;
            report.add(&part);
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
        Ok(report)
    }

    /// Advances by `dt`, splitting it on a recoverable failure (`depth` halvings of the step so
    /// far); returns the cost and the deepest level a part needed.
    fn advance<S: StepParts>(&mut self, sys: &mut S, dt: Real, depth: u32) -> Result<(StepReport, u32), StepFailure> {
        match sys.try_part(dt, depth >= MAX_DEPTH) {
            Err(f) if depth < MAX_DEPTH && recoverable(&f.cause) => {
                sys.undo_part();
                self.substeps += 1;
                *self.failures.entry(f.cause.kind()).or_default() += 1;
                let (mut a, da) = self.advance(sys, 0.5 * dt, depth + 1)?;
                let (b, db) = self.advance(sys, 0.5 * dt, depth + 1)?;
                a.add(&b);
                Ok((a, da.max(db)))
            }
            Err(f) => Err(f),
            Ok(r) => {
                self.parts += 1;
                Ok((r, depth))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step that fails whenever its part is longer than `longest`.
    struct Picky {
        longest: Real,
        done: Real,
        undone: u32,
    }

    impl StepParts for Picky {
        fn try_part(&mut self, dt: Real, _last_chance: bool) -> Result<StepReport, StepFailure> {
            if dt > self.longest {
                return Err(fail(InstabilityCause::NotPositiveDefinite { grain: 0 }));
            }
            self.done += dt;
            Ok(StepReport { newton: 1, sweeps: 2, contacts: 3 })
        }

        fn undo_part(&mut self) {
            self.undone += 1;
        }
    }

    #[test]
    fn a_step_is_split_as_deep_as_needed_and_the_next_ones_start_there() {
        let mut sys = Picky { longest: 0.25, done: 0.0, undone: 0 };
        let mut s = Splitting::default();
        let r = s.step(&mut sys, 1.0).expect("splits");
        // 1 → 2 halves → each fails and splits again: 4 quarters done, 3 failures undone.
        assert_eq!((r.newton, r.sweeps, r.contacts), (4, 8, 3));
        assert_eq!((s.substeps, s.parts, sys.undone), (3, 4, 3));
        assert_eq!(s.failures.get("not_positive_definite"), Some(&3));
        assert!((sys.done - 1.0).abs() < 1e-15);
        // The next step starts in quarters: no failure.
        s.step(&mut sys, 1.0).expect("quarters");
        assert_eq!((s.substeps, s.parts), (3, 8));
        // After CALM_STEPS calm steps the parts double, and the next attempt fails again.
        for _ in 1..CALM_STEPS {
            s.step(&mut sys, 1.0).expect("quarters");
        }
        assert_eq!(s.depth, 1);
        s.step(&mut sys, 1.0).expect("halves fail, quarters pass");
        assert_eq!(s.depth, 2);
        assert!((sys.done - Real::from(CALM_STEPS + 2)).abs() < 1e-12);
    }

    #[test]
    fn past_the_deepest_level_the_failure_is_the_steps() {
        let mut sys = Picky { longest: 0.5f64.powi(MAX_DEPTH as i32 + 1), done: 0.0, undone: 0 };
        let err = Splitting::default().step(&mut sys, 1.0).expect_err("too short a part needed");
        assert_eq!(err.cause, InstabilityCause::NotPositiveDefinite { grain: 0 });
        assert_eq!(sys.done, 0.0);
    }
}
