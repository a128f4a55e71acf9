//! Stability maps: the bisection that finds where a method stops being stable as one knob
//! moves (the time step, the contact stiffness at a fixed step, the NLGS budget), the failure
//! mode each unstable run showed, and the theory it is compared with (docs/physics.md §10.2).

use serde::{Deserialize, Serialize};

/// A stability search as a study file writes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchSpec {
    /// The knob, a path into the scene (`method.time_step`, `materials.glass.contact.k_n`,
    /// `method.max_iterations`).
    pub parameter: String,
    /// Lower end of the range (> 0).
    pub low: f64,
    /// Upper end of the range (> low).
    pub high: f64,
    /// On which side of the limit runs fail: `above` (time step, stiffness; default) or
    /// `below` (an iteration budget).
    #[serde(default)]
    pub unstable: Side,
    /// Bisection steps after the two ends. Default 8, at most 30.
    #[serde(default)]
    pub iterations: Option<u32>,
    /// Bisect the logarithm (default) or the value.
    #[serde(default)]
    pub scale: Scale,
    /// The knob takes whole values (an iteration budget).
    #[serde(default)]
    pub integer: bool,
}

/// Which side of the limit fails.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Values above the limit fail.
    #[default]
    Above,
    /// Values below the limit fail.
    Below,
}

/// How the range is halved.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// Geometric mean.
    #[default]
    Log,
    /// Arithmetic mean.
    Linear,
}

/// How a run failed, in the terms of a stability map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureMode {
    /// Non-finite values or energy growing beyond the work put in.
    BlowUp,
    /// Bodies overlapping beyond the allowed fraction.
    ExcessiveOverlap,
    /// The contact solver or an equilibrium stage did not converge.
    NonConvergence,
    /// Another failure (the scene could not be built, ...).
    Other,
}

impl FailureMode {
    /// Classifies a failed job by its error code and message (the engine's
    /// [`crate::error::EngineError`] as text).
    pub fn of(code: &str, message: &str) -> Self {
        match code {
            "not_converged" => Self::NonConvergence,
            "unstable" if message.contains("non-finite") || message.contains("energy grew") => Self::BlowUp,
            "unstable" if message.contains("overlap reached") => Self::ExcessiveOverlap,
            "unstable" if message.contains("did not converge") => Self::NonConvergence,
            _ => Self::Other,
        }
    }

    /// The name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::BlowUp => "blow-up",
            Self::ExcessiveOverlap => "excessive overlap",
            Self::NonConvergence => "non-convergence",
            Self::Other => "other failure",
        }
    }
}

/// One probe of the search and how it ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Probe {
    /// The knob's value.
    pub value: f64,
    /// None: the run succeeded; else how it failed.
    pub failure: Option<FailureMode>,
}

/// What the search found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Limit {
    /// The stable value closest to the limit (none if every probe failed).
    pub stable: Option<f64>,
    /// The failing value closest to the limit (none if every probe succeeded).
    pub unstable: Option<f64>,
    /// The failure seen at `unstable`.
    pub mode: Option<FailureMode>,
    /// Every failure mode seen, in order of the probes.
    pub modes_seen: Vec<FailureMode>,
    /// What the result means when the limit is not inside the range.
    pub note: Option<String>,
}

/// The next step of a search.
#[derive(Debug, Clone, PartialEq)]
pub enum Next {
    /// Run these values (the two ends at first, then one midpoint at a time).
    Probe(Vec<f64>),
    /// Wait for probes still running.
    Wait,
    /// The search is over.
    Done(Limit),
}

impl SearchSpec {
    /// Bisection steps after the two ends.
    pub fn iteration_budget(&self) -> u32 {
        self.iterations.unwrap_or(8)
    }

    /// The rules the search breaks, as (field below `search`, rule).
    pub fn check(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        if !(self.low.is_finite() && self.low > 0.0) {
            out.push(("low".into(), format!("must be > 0, got {}", self.low)));
        }
        if !(self.high.is_finite() && self.high > self.low) {
            out.push(("high".into(), format!("must be above low ({}), got {}", self.low, self.high)));
        }
        if self.iteration_budget() == 0 || self.iteration_budget() > 30 {
            out.push(("iterations".into(), format!("must be between 1 and 30, got {}", self.iteration_budget())));
        }
        out
    }

    fn fails_above(&self) -> bool {
        self.unstable == Side::Above
    }

    /// The value to probe between a stable `a` and a failing `b`.
    fn midpoint(&self, a: f64, b: f64) -> f64 {
        let m = match self.scale {
            Scale::Log => (a * b).sqrt(),
            Scale::Linear => 0.5 * (a + b),
        };
        if self.integer {
            m.round()
        } else {
            m
        }
    }

    /// The next step given the probes so far (`pending`: values still running).
    pub fn next(&self, probes: &[Probe], pending: usize) -> Next {
        let ends = [self.low, self.high];
        let missing: Vec<f64> = ends.iter().copied().filter(|e| !probes.iter().any(|p| p.value == *e)).collect();
        if !missing.is_empty() {
            return if pending > 0 { Next::Wait } else { Next::Probe(missing) };
        }
        if pending > 0 {
            return Next::Wait;
        }
        let modes_seen: Vec<FailureMode> = probes.iter().filter_map(|p| p.failure).collect();
        // The bracket: the stable value nearest the failing side, the failing value nearest the
        // stable side.
        let up = self.fails_above();
        let stable = probes.iter().filter(|p| p.failure.is_none()).map(|p| p.value).reduce(|a, b| if up { a.max(b) } else { a.min(b) });
        let failing = probes.iter().filter(|p| p.failure.is_some()).map(|p| p.value).reduce(|a, b| if up { a.min(b) } else { a.max(b) });
        let mode = failing.and_then(|v| probes.iter().find(|p| p.value == v).and_then(|p| p.failure));
        let done = |note: Option<String>| Next::Done(Limit { stable, unstable: failing, mode, modes_seen: modes_seen.clone(), note });
        let (Some(a), Some(b)) = (stable, failing) else {
            return done(Some(match stable {
                Some(_) => "every probe was stable: the limit is beyond the range".into(),
                None => "every probe failed: the limit is below the range".into(),
            }));
        };
        if (a < b) != up {
            return done(Some("a stable value lies beyond a failing one: the failures are not a stability limit".into()));
        }
        let bisections = probes.len().saturating_sub(2) as u32;
        let m = self.midpoint(a, b);
        if bisections >= self.iteration_budget() || m == a || m == b {
            return done(None);
        }
        Next::Probe(vec![m])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn search(unstable: Side, integer: bool) -> SearchSpec {
        SearchSpec { parameter: "x".into(), low: 1.0, high: 100.0, unstable, iterations: Some(12), scale: Scale::Log, integer }
    }

    /// Runs a search against a known limit.
    fn run(s: &SearchSpec, limit: f64) -> (Limit, usize) {
        let mut probes = Vec::new();
        loop {
            match s.next(&probes, 0) {
                Next::Probe(values) => {
                    for v in values {
                        let fails = if s.unstable == Side::Above { v > limit } else { v < limit };
                        probes.push(Probe { value: v, failure: fails.then_some(FailureMode::BlowUp) });
                    }
                }
                Next::Wait => panic!("nothing is pending"),
                Next::Done(l) => return (l, probes.len()),
            }
        }
    }

    #[test]
    fn the_bisection_brackets_the_limit_from_either_side() {
        let (l, n) = run(&search(Side::Above, false), 17.0);
        assert_eq!(n, 14);
        let (a, b) = (l.stable.expect("stable"), l.unstable.expect("unstable"));
        assert!(a <= 17.0 && b > 17.0 && b / a < 100f64.powf(1.0 / 4096.0) * 1.0001, "{a} {b}");
        assert_eq!(l.mode, Some(FailureMode::BlowUp));
        let (l, _) = run(&search(Side::Below, true), 42.0);
        assert_eq!((l.stable, l.unstable), (Some(42.0), Some(41.0)));
        let (l, n) = run(&search(Side::Above, false), 1000.0);
        assert_eq!(n, 2);
        assert!(l.note.is_some_and(|n| n.contains("beyond the range")) && l.unstable.is_none());
        // Waiting for the ends, then for a midpoint.
        let s = search(Side::Above, false);
        assert_eq!(s.next(&[], 2), Next::Wait);
        assert_eq!(s.next(&[Probe { value: 1.0, failure: None }], 0), Next::Probe(vec![100.0]));
    }

    #[test]
    fn failure_modes_follow_the_engines_messages() {
        use crate::error::{EngineError, InstabilityCause};
        let err = |cause| EngineError::Unstable { step: 1, time: 0.0, cause, suggestion: String::new() }.to_string();
        assert_eq!(FailureMode::of("unstable", &err(InstabilityCause::NonFinite { particle: 0 })), FailureMode::BlowUp);
        assert_eq!(
            FailureMode::of("unstable", &err(InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part: "kinetic", part_gain: 1.0 })),
            FailureMode::BlowUp
        );
        assert_eq!(
            FailureMode::of("unstable", &err(InstabilityCause::Overlap { fraction: 0.2, limit: 0.1 })),
            FailureMode::ExcessiveOverlap
        );
        let budget = InstabilityCause::SolverBudget {
            iterations: 10,
            change: 1.0,
            violation: 1.0,
            tolerance: 1.0,
            violation_tolerance: 1.0,
            worst: 1.0,
            worst_tolerance: 1.0,
        };
        assert_eq!(FailureMode::of("unstable", &err(budget)), FailureMode::NonConvergence);
        assert_eq!(FailureMode::of("not_converged", "stage did not reach equilibrium"), FailureMode::NonConvergence);
        assert_eq!(FailureMode::of("build_failed", "x"), FailureMode::Other);
    }
}
