//! The interface every method implements ([`Simulation`]) and the loop that drives it
//! ([`Runner`]): stop criteria, sampling, progress, cancellation.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::error::EngineError;
use crate::math::Real;
use crate::observe::Sample;
use crate::observe::Snapshot;
use crate::scene::{Sampling, Scene, Stop};

/// A running simulation of one method.
pub trait Simulation: Send {
    /// Method name (`"dem"`, ...).
    fn method(&self) -> &'static str;
    /// Advances one time step; fails if the integration became unstable.
    fn step(&mut self) -> Result<(), EngineError>;
    /// Steps done.
    fn steps_done(&self) -> u64;
    /// Simulated time, s.
    fn time(&self) -> Real;
    /// Time step, s.
    fn dt(&self) -> Real;
    /// Number of particles.
    fn particle_count(&self) -> usize;
    /// Current packing fraction (cheap).
    fn packing_fraction(&self) -> Real;
    /// Current strain magnitude (cheap; see `stop.strain` in the scene format).
    fn strain(&self) -> Real;
    /// Measures the current state (runs the stability guard first; never returns NaN).
    fn sample(&mut self) -> Result<Sample, EngineError>;
    /// Particles, contacts and walls now, for visualisation ([`crate::observe::vtk`]).
    fn snapshot(&self) -> Snapshot;
    /// Heap memory held, bytes.
    fn memory_bytes(&self) -> usize;
}

/// Progress of a run, passed with every sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Fraction of the run done, 0..1 (the most advanced stop criterion).
    pub fraction: Real,
    /// Wall-clock seconds since the run started.
    pub elapsed: Real,
    /// Estimated wall-clock seconds left.
    pub remaining: Option<Real>,
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// `stop.time` reached.
    Time,
    /// `stop.steps` reached.
    Steps,
    /// `stop.packing_fraction` reached.
    PackingFraction,
    /// `stop.strain` reached.
    Strain,
}

/// Outcome of a finished run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Why it stopped.
    pub reason: StopReason,
    /// Steps done.
    pub steps: u64,
    /// Simulated time, s.
    pub time: Real,
    /// Wall-clock seconds.
    pub wall_seconds: Real,
    /// The last sample.
    pub last: Sample,
}

/// Drives a simulation to its stop criteria.
#[derive(Debug, Clone)]
pub struct Runner {
    /// Stop criteria.
    pub stop: Stop,
    /// Sampling interval.
    pub sampling: Sampling,
    /// Set to true from another thread to cancel; checked every step.
    pub cancel: Arc<AtomicBool>,
    /// Take a snapshot every this many steps, or with every sample if 0, plus the initial and
    /// final states; `None`: no snapshots.
    pub snapshot_every: Option<u64>,
}

impl Runner {
    /// A runner for the scene's stop criteria and sampling.
    pub fn for_scene(scene: &Scene) -> Self {
        Self { stop: scene.stop, sampling: scene.sampling, cancel: Arc::new(AtomicBool::new(false)), snapshot_every: scene.snapshots }
    }

    fn reached(&self, sim: &dyn Simulation) -> Option<StopReason> {
        let s = &self.stop;
        let half = 0.5 * sim.dt();
        if s.steps.is_some_and(|n| sim.steps_done() >= n) {
            return Some(StopReason::Steps);
        }
        if s.time.is_some_and(|t| sim.time() >= t - half) {
            return Some(StopReason::Time);
        }
        if s.packing_fraction.is_some_and(|phi| sim.packing_fraction() >= phi) {
            return Some(StopReason::PackingFraction);
        }
        if s.strain.is_some_and(|e| sim.strain() >= e) {
            return Some(StopReason::Strain);
        }
        None
    }

    fn fraction(&self, sim: &dyn Simulation, phi0: Real) -> Real {
        let s = &self.stop;
        let mut f: Real = 0.0;
        if let Some(n) = s.steps {
            f = f.max(sim.steps_done() as Real / n as Real);
        }
        if let Some(t) = s.time {
            f = f.max(sim.time() / t);
        }
        if let Some(phi) = s.packing_fraction {
            if phi > phi0 {
                f = f.max((sim.packing_fraction() - phi0) / (phi - phi0));
            }
        }
        if let Some(e) = s.strain {
            f = f.max(sim.strain() / e);
        }
        f.clamp(0.0, 1.0)
    }

    /// Runs to the end, calling `on_sample` with the initial sample, every sample at the
    /// interval and the final one.
    pub fn run(&self, sim: &mut dyn Simulation, on_sample: &mut dyn FnMut(&Sample, &Progress)) -> Result<RunSummary, EngineError> {
        self.run_with_snapshots(sim, on_sample, &mut |_| {})
    }

    /// As [`Runner::run`], also calling `on_snapshot` with the initial state, at the
    /// `snapshot_every` interval and with the final state (each step at most once). To stop the run from
    /// `on_snapshot` (a write failed), set `cancel`.
    pub fn run_with_snapshots(
        &self,
        sim: &mut dyn Simulation,
        on_sample: &mut dyn FnMut(&Sample, &Progress),
        on_snapshot: &mut dyn FnMut(&Snapshot),
    ) -> Result<RunSummary, EngineError> {
        let mut last_snapshot = None;
        let mut snapshot = |sim: &dyn Simulation, last_snapshot: &mut Option<u64>| {
            if self.snapshot_every.is_some() && *last_snapshot != Some(sim.steps_done()) {
                *last_snapshot = Some(sim.steps_done());
                on_snapshot(&sim.snapshot());
            }
        };
        let started = std::time::Instant::now();
        let phi0 = sim.packing_fraction();
        let progress = |sim: &dyn Simulation| {
            let fraction = self.fraction(sim, phi0);
            let elapsed = started.elapsed().as_secs_f64();
            let remaining = (fraction > 1e-6).then(|| elapsed * (1.0 - fraction) / fraction);
            Progress { fraction, elapsed, remaining }
        };
        let mut last = sim.sample()?;
        on_sample(&last, &progress(sim));
        snapshot(sim, &mut last_snapshot);
        let mut next_time = match self.sampling {
            Sampling::Time(t) => t,
            Sampling::Steps(_) => Real::INFINITY,
        };
        let reason = loop {
            if let Some(r) = self.reached(sim) {
                break r;
            }
            if self.cancel.load(Ordering::Relaxed) {
                return Err(EngineError::Cancelled { step: sim.steps_done() });
            }
            sim.step()?;
            let due = match self.sampling {
                Sampling::Steps(n) => sim.steps_done().is_multiple_of(n),
                Sampling::Time(t) => {
                    if sim.time() >= next_time - 0.5 * sim.dt() {
                        next_time += t;
                        true
                    } else {
                        false
                    }
                }
            };
            if due && self.reached(sim).is_none() {
                last = sim.sample()?;
                on_sample(&last, &progress(sim));
            }
            let snapshot_due = match self.snapshot_every {
                Some(0) => due,
                Some(n) => sim.steps_done().is_multiple_of(n),
                None => false,
            };
            if snapshot_due && self.reached(sim).is_none() {
                snapshot(sim, &mut last_snapshot);
            }
        };
        if last.step != sim.steps_done() {
            last = sim.sample()?;
            on_sample(&last, &progress(sim));
        }
        snapshot(sim, &mut last_snapshot);
        Ok(RunSummary { reason, steps: sim.steps_done(), time: sim.time(), wall_seconds: started.elapsed().as_secs_f64(), last })
    }
}
