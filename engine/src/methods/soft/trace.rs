//! A trace of the soft-grain methods' Newton iterations: one record per iteration of every step
//! part and one where each part ends, converged or failed and why. Where a run's time goes and
//! why a step fails are in these records, not in the samples: a period-2 cycle of points
//! switching between elastic and plastic, a correction that stalls, contact solves that take
//! thousands of sweeps (`sable run --trace FILE`, `sable bench mpm|fem --trace FILE`).
//!
//! A method without a sink set pays one branch per iteration.

use serde::Serialize;

use crate::error::InstabilityCause;
use crate::math::Real;

/// One record of the trace.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NewtonRecord {
    /// The step being done (1 for the first).
    pub step: u64,
    /// Time at the part's start, s.
    pub time: Real,
    /// The part's duration, s (the step's, or a fraction of it when the step was split).
    pub dt: Real,
    /// The Newton iteration (from 1); on the record that ends a part, the iterations it took.
    pub iteration: u32,
    /// The iteration's velocity correction relative to Newton's velocity scale (the quantity
    /// compared with `newton_tolerance`); `None` where the part ends.
    pub correction: Option<Real>,
    /// The iteration's contact-solver sweeps (on the end record, the part's).
    pub sweeps: u32,
    /// Contacts in the part.
    pub contacts: usize,
    /// Material points that switched between elastic and plastic since the previous iterate
    /// (`mpm` with a plastic law; `None` elsewhere).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub switching: Option<usize>,
    /// The fraction of the correction taken (`mpm`: smaller while points switch and the
    /// correction does not shrink).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fraction: Option<Real>,
    /// Whether the iteration assembled and factorised the matrices anew (`mpm`: all grains';
    /// `fem`: the number that did is in `refreshed_grains`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refreshed: Option<bool>,
    /// `fem`: grains whose matrices the iteration assembled anew.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refreshed_grains: Option<usize>,
    /// Grains whose current matrix is not Newton's own, made definite (`mpm`: its diagonal
    /// scaled, or its points' tangents replaced by their positive parts; `fem`: its elements'
    /// stiffnesses replaced by their positive parts); while any is, the iterations converge
    /// linearly at best.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damped_grains: Option<usize>,
    /// Grains whose current matrix was made definite along their closed contacts
    /// ([`super::augment`]): Newton's own on the modes those contacts hold.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub penalised_grains: Option<usize>,
    /// `mpm`: the iteration's correction turned back on the previous one (their mass-weighted
    /// cosine below −½), the mark of a two-cycle that only a partial correction breaks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reversed: Option<bool>,
    /// On the record that ends a part: `"converged"`, or the failure's kind and message.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub end: Option<String>,
}

impl NewtonRecord {
    /// The record of Newton iteration `iteration` of the part of `dt` (s) started at `time` (s)
    /// in step `step`: its relative `correction`, `sweeps` and `contacts`; the method's own
    /// fields unset.
    pub fn iteration((step, time, dt): (u64, Real, Real), iteration: u32, correction: Real, sweeps: u32, contacts: usize) -> Self {
        Self {
            step,
            time,
            dt,
            iteration,
            correction: Some(correction),
            sweeps,
            contacts,
            switching: None,
            fraction: None,
            refreshed: None,
            refreshed_grains: None,
            damped_grains: None,
            penalised_grains: None,
            reversed: None,
            end: None,
        }
    }
}

/// Where a method sends its records.
pub type NewtonSink = Box<dyn FnMut(&NewtonRecord) + Send>;

/// A method's trace: off until a sink is set.
#[derive(Default)]
pub struct Tracer {
    sink: Option<NewtonSink>,
    /// The current part's Newton iterations, sweeps and contacts so far ([`Tracer::count`]).
    counts: (u32, u32, usize),
}

impl std::fmt::Debug for Tracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tracer").field("on", &self.sink.is_some()).finish()
    }
}

impl Tracer {
    /// Sends the records to `sink` from now on.
    pub fn set(&mut self, sink: NewtonSink) {
        self.sink = Some(sink);
    }

    /// Whether records are wanted.
    #[inline(always)]
    pub fn on(&self) -> bool {
        self.sink.is_some()
    }

    /// Sends the record `make` builds, if a sink is set.
    #[inline(always)]
    pub fn emit(&mut self, make: impl FnOnce() -> NewtonRecord) {
        if let Some(sink) = self.sink.as_mut() {
            sink(&make());
        }
    }

    /// Starts counting a part's Newton iterations, sweeps and contacts from zero.
    pub fn begin_part(&mut self) {
        self.counts = (0, 0, 0);
    }

    /// The current part has done `iterations` Newton iterations and `sweeps` sweeps so far,
    /// with `contacts` contacts.
    pub fn count(&mut self, iterations: u32, sweeps: u32, contacts: usize) {
        self.counts = (iterations, sweeps, contacts);
    }

    /// Sends the record that ends the current part ([`Tracer::end`]) with its counts so far:
    /// `part` its step, start time (s) and duration (s), `cause` why it failed.
    pub fn end_part(&mut self, part: (u64, Real, Real), cause: Option<&InstabilityCause>) {
        if self.on() {
            let counts = self.counts;
            self.end(part, counts, cause);
        }
    }

    /// Sends the record that ends a part of `dt` (s) started at `time` (s) in step `step`,
    /// after `iterations` Newton iterations and `sweeps` sweeps: converged, or failed for
    /// `cause`.
    pub fn end(
        &mut self,
        (step, time, dt): (u64, Real, Real),
        (iterations, sweeps, contacts): (u32, u32, usize),
        cause: Option<&InstabilityCause>,
    ) {
        self.emit(|| NewtonRecord {
            correction: None,
            end: Some(cause.map_or_else(|| "converged".to_string(), |c| format!("{}: {c}", c.kind()))),
            ..NewtonRecord::iteration((step, time, dt), iterations, 0.0, sweeps, contacts)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// Records reach the sink only once it is set, and the end record names the failure.
    #[test]
    fn records_reach_the_sink_once_set() {
        let mut t = Tracer::default();
        let mut built = 0;
        t.emit(|| {
            built += 1;
            NewtonRecord::iteration((1, 0.0, 1e-3), 1, 0.5, 3, 2)
        });
        assert_eq!(built, 0, "no record is built without a sink");
        let got = Arc::new(Mutex::new(Vec::new()));
        let into = got.clone();
        t.set(Box::new(move |r| into.lock().expect("lock").push(serde_json::to_value(r).expect("json"))));
        t.end((3, 0.1, 5e-5), (7, 40, 12), Some(&InstabilityCause::NotPositiveDefinite { grain: 4 }));
        t.end((4, 0.2, 5e-5), (2, 1, 12), None);
        let got = got.lock().expect("lock");
        assert_eq!(got.len(), 2);
        assert_eq!(got[0]["step"], 3);
        assert_eq!(got[0]["iteration"], 7);
        assert!(got[0]["end"].as_str().is_some_and(|e| e.starts_with("not_positive_definite: ")), "{}", got[0]);
        assert!(got[0].get("switching").is_none());
        assert_eq!(got[1]["end"], "converged");
    }
}

/// Test helpers: a tracer's records kept, cut into parts, and Newton's rate read off them.
#[cfg(test)]
pub mod recorded {
    use std::sync::{Arc, Mutex};

    use super::{NewtonRecord, Tracer};
    use crate::math::Real;

    /// The records a tracer emitted, shared with its sink.
    pub type Records = Arc<Mutex<Vec<NewtonRecord>>>;

    /// Keeps every record `tracer` emits from now on.
    pub fn record(tracer: &mut Tracer) -> Records {
        let records = Arc::new(Mutex::new(Vec::new()));
        let sink = records.clone();
        tracer.set(Box::new(move |r| sink.lock().expect("trace").push(r.clone())));
        records
    }

    /// The iteration records of each part, in order (the records that end parts left out).
    pub fn parts(records: &Mutex<Vec<NewtonRecord>>) -> Vec<Vec<NewtonRecord>> {
        let all = records.lock().expect("trace").clone();
        all.split(|r| r.end.is_some()).map(|p| p.to_vec()).filter(|p| !p.is_empty()).collect()
    }

    /// `c_(k+1) / c_k²` for every iteration `k` on a `fresh` matrix whose relative correction
    /// `c_k` is below 1e-2 (Newton's asymptotic range): bounded for a quadratic rate, `r / c_k`
    /// for a linear rate `r`.
    pub fn quadratic_ratios(parts: &[Vec<NewtonRecord>], fresh: impl Fn(&NewtonRecord) -> bool) -> Vec<Real> {
        parts
            .iter()
            .flat_map(|p| p.windows(2).filter(|w| fresh(&w[0])).filter_map(|w| Some((w[0].correction?, w[1].correction?))))
            .filter(|&(c0, _)| c0 < 1e-2)
            .map(|(c0, c1)| c1 / (c0 * c0))
            .collect()
    }
}
