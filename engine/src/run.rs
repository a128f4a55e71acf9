//! The interface every method implements ([`Simulation`]) and the loop that drives it
//! ([`Runner`]): stop criteria, sampling, progress, cancellation.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::error::EngineError;
use crate::math::Real;
use crate::math::Vec3;
use crate::observe::Sample;
use crate::observe::Snapshot;
use crate::observe::{Analysis, ExperimentResult, StrainSample};
use crate::resume::{Carried, Checkpoint, Clock, StagePoint, CHECKPOINT_FORMAT, CHECKPOINT_VERSION};
use crate::scene::{Controls, Equilibrium, Sampling, Scene, Stage, StateFile, Stop};

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
    /// Current strain magnitude since the start (cheap; see `stop.strain` in the scene format).
    fn strain(&self) -> Real;
    /// Current box lengths, m (z = 0 in 2D).
    fn box_lengths(&self) -> Vec3;
    /// Measures the current state (runs the stability guard first; never returns NaN).
    fn sample(&mut self) -> Result<Sample, EngineError>;
    /// Particles, contacts and walls now, for visualisation ([`crate::observe::vtk`]).
    fn snapshot(&self) -> Snapshot;
    /// Heap memory held, bytes.
    fn memory_bytes(&self) -> usize;
    /// How the method models the grains (soft contacts by default).
    fn grain_model(&self) -> GrainModel {
        GrainModel::SoftContacts
    }
    /// Contact-solver sweeps done since the start (an implicit method's cost; 0 for DEM).
    fn solver_iterations(&self) -> u64 {
        0
    }
    /// Applies the controls of a new stage of the loading program (wall motions, cell
    /// deformation, friction, damping).
    fn apply_controls(&mut self, controls: &Controls) -> Result<(), EngineError>;
    /// Starts a stage of the loading program: applies its controls, and whatever else the method
    /// sets per stage (contact dynamics: the solver's violation bound, tighter in a stage that
    /// runs until equilibrium than in an experiment's loading).
    fn begin_stage(&mut self, stage: &Stage) -> Result<(), EngineError> {
        self.apply_controls(&stage.controls)
    }
    /// How far the system is from static equilibrium (for stages that run until it). A method
    /// may measure it over the interval since its previous call (contact dynamics does: its
    /// step-to-step velocities carry the solver's residual), so the runner calls it once per
    /// check.
    fn balance(&mut self) -> Balance;
    /// Checks in a row that a stage's equilibrium needs when the scene does not set
    /// `equilibrium.consecutive`: three for a balance that is a snapshot of the state (one
    /// snapshot may catch a packing at a quiet instant), fewer for one that is a mean over the
    /// interval since the previous check.
    fn equilibrium_checks(&self) -> u32 {
        3
    }
    /// Number-mean diameter (m) and solid density (kg/m³) of the grains.
    fn grain_scales(&self) -> (Real, Real);
    /// The current particles and box, to start another run from ([`crate::scene::state`]).
    fn saved_state(&self) -> StateFile;
    /// The run's clock: steps, time, the strain's origin, running totals (a checkpoint's,
    /// [`crate::resume`]).
    fn clock(&self) -> Clock;
    /// Sets the clock of a simulation built from a checkpoint's state, so that it counts on
    /// from the checkpoint's step.
    fn set_clock(&mut self, clock: &Clock);
    /// What the run carries beside its saved state, particles numbered in the state's order
    /// ([`crate::resume::Carried`]): nothing for a method without history.
    fn carried(&self) -> Carried {
        Carried::default()
    }
    /// Sets back what a run carried, in a simulation built from the checkpoint's state with
    /// [`crate::scene::Scene::continue_saved_run`]. A method without history refuses anything
    /// but nothing.
    fn carry_on(&mut self, carried: &Carried) -> Result<(), EngineError> {
        if carried.is_empty() {
            Ok(())
        } else {
            Err(EngineError::Build { field: "checkpoint".into(), reason: format!("method {} carries no contact history", self.method()) })
        }
    }
    /// Sends a record of every Newton iteration to `sink` from now on
    /// ([`crate::methods::soft::trace`]); false (and nothing sent) for a method without Newton
    /// iterations.
    fn trace_newton(&mut self, sink: crate::methods::soft::trace::NewtonSink) -> bool {
        drop(sink);
        false
    }
}

/// How a method models the grains ([`Simulation::grain_model`]): what the analysis of its
/// results may compare with the rigid limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GrainModel {
    /// Rigid grains touching through contacts of a finite stiffness (DEM): their stiffness
    /// number says how far they are from the rigid limit.
    SoftContacts,
    /// Rigid grains with no contact stiffness (contact dynamics): the rigid limit itself.
    Rigid,
    /// Grains that deform under a constitutive law (MPM, FEM).
    Deformable,
}

/// Distance from static equilibrium ([`Simulation::balance`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    /// Translational kinetic energy, J (free spins of rattlers do not count).
    pub kinetic_energy: Real,
    /// The energy the kinetic energy is compared with, J: the elastic energy stored in the
    /// contacts for soft contacts (DEM); for rigid grains (CD), which store none, what linear
    /// contacts at KAPPA_REF would store under the same forces ([`rigid_reference_energy`]).
    pub reference_energy: Real,
    /// Mean norm of the net force on a particle / mean norm of a contact force (infinite
    /// without contacts).
    pub unbalanced_force: Real,
    /// Largest relative error of a stress-controlled boundary against its target (0 if none).
    pub stress_error: Real,
}

impl Balance {
    /// Kinetic / reference energy (infinite without reference energy).
    pub fn kinetic_ratio(&self) -> Real {
        if self.reference_energy > 0.0 {
            self.kinetic_energy / self.reference_energy
        } else {
            Real::INFINITY
        }
    }

    /// True if the criterion holds.
    pub fn satisfies(&self, e: &Equilibrium) -> bool {
        self.kinetic_ratio() < e.kinetic_ratio && self.unbalanced_force < e.unbalanced_force && self.stress_error < e.stress_tolerance
    }
}

/// Stiffness number `kappa = k_n / (p d^(D-2))` that rigid grains are compared with for the
/// equilibrium criterion ([`rigid_reference_energy`]): 1e4, the usual bound above which soft
/// contacts behave as rigid ones in quasi-static tests (Roux & Combe 2002; docs/physics.md §9).
pub const KAPPA_REF: Real = 1e4;

/// The reference energy of rigid grains whose contacts carry the forces `forces` (N, the
/// non-zero ones), for grains of mean diameter `d` (m): the elastic energy linear contacts at
/// stiffness number KAPPA_REF would store under these forces, `sum f² / (2 k)` with
/// `k = KAPPA_REF p d^(D-2)` and the contact pressure `p d^(D-1) = <f>` — so
/// `k = KAPPA_REF <f> / d` in 2D and 3D alike. DEM's criterion compares the kinetic energy with
/// its elastic energy, `sum f² / (2 k)` with its own k: the same `kinetic_ratio` bound then
/// means the same quietness for both methods at KAPPA_REF. Per contact, the reference does not
/// depend on the box: a granule in a large box is judged as a packing that fills it would be.
pub fn rigid_reference_energy(forces: &[Real], d: Real) -> Real {
    if forces.is_empty() {
        return 0.0;
    }
    let mean = forces.iter().sum::<Real>() / forces.len() as Real;
    if mean <= 0.0 {
        return 0.0;
    }
    forces.iter().map(|f| f * f).sum::<Real>() * d / (2.0 * KAPPA_REF * mean)
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
    /// The last stage reached equilibrium.
    Equilibrium,
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
    /// Contact-solver sweeps ([`Simulation::solver_iterations`]).
    pub solver_iterations: u64,
    /// The last sample.
    pub last: Sample,
    /// Derived results of the scene's experiment.
    pub result: Option<ExperimentResult>,
}

/// A run to go on from ([`Runner::run_resumable`]): a checkpoint and the samples the run took
/// before it, in order.
#[derive(Debug, Clone, Copy)]
pub struct Resume<'a> {
    /// Where the run stood.
    pub checkpoint: &'a Checkpoint,
    /// Every sample taken before the checkpoint.
    pub samples: &'a [Sample],
}

/// Drives a simulation through the stages of its scene to its stop criteria.
#[derive(Debug, Clone)]
pub struct Runner {
    /// Limits of the whole run.
    pub stop: Stop,
    /// The loading program, run in order (at least one stage).
    pub stages: Vec<Stage>,
    /// Sampling interval.
    pub sampling: Sampling,
    /// Set to true from another thread to cancel; checked every step.
    pub cancel: Arc<AtomicBool>,
    /// Set to true from another thread to ask for a checkpoint ([`crate::resume`]) before the
    /// next step; cleared when it is taken. Asked for together with `cancel` (set first), the
    /// checkpoint is taken before the run stops.
    pub checkpoint: Arc<AtomicBool>,
    /// Take a snapshot every this many steps, or with every sample if 0, plus the initial and
    /// final states; `None`: no snapshots.
    pub snapshot_every: Option<u64>,
    /// Computes the experiment's results from the samples.
    pub analysis: Analysis,
    /// Dimension of the scene.
    pub dim: usize,
}

/// Where the current stage started.
struct StageStart {
    index: usize,
    step: u64,
    time: Real,
    lengths: Vec3,
    strain: Real,
}

impl Runner {
    /// A runner for the scene's stages, stop criteria and sampling.
    pub fn for_scene(scene: &Scene) -> Self {
        Self {
            stop: scene.stop,
            stages: scene.stages.clone(),
            sampling: scene.sampling,
            cancel: Arc::new(AtomicBool::new(false)),
            checkpoint: Arc::new(AtomicBool::new(false)),
            snapshot_every: scene.snapshots,
            analysis: Analysis::new(scene),
            dim: scene.dim,
        }
    }

    /// The whole run's limits (`stop`).
    fn reached_global(&self, sim: &dyn Simulation) -> Option<StopReason> {
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

    /// Strain of the stage so far: of its axis, else the largest over the axes (the
    /// Lees-Edwards strain under shear).
    fn stage_strain(&self, sim: &dyn Simulation, stage: &Stage, start: &StageStart) -> Real {
        let now = sim.box_lengths();
        match stage.strain_axis {
            Some(a) => (now[a] / start.lengths[a]).ln().abs(),
            None if start.index == 0 && self.stages.len() == 1 => sim.strain(),
            None => (0..self.dim).map(|a| (now[a] / start.lengths[a]).ln().abs()).fold((sim.strain() - start.strain).abs(), Real::max),
        }
    }

    /// The stage's own criteria (time and steps count from its start).
    fn reached_stage(&self, sim: &dyn Simulation, stage: &Stage, start: &StageStart) -> Option<StopReason> {
        let s = &stage.until;
        let half = 0.5 * sim.dt();
        if s.steps.is_some_and(|n| sim.steps_done() - start.step >= n) {
            return Some(StopReason::Steps);
        }
        if s.time.is_some_and(|t| sim.time() - start.time >= t - half) {
            return Some(StopReason::Time);
        }
        if s.packing_fraction.is_some_and(|phi| sim.packing_fraction() >= phi) {
            return Some(StopReason::PackingFraction);
        }
        if s.strain.is_some_and(|e| self.stage_strain(sim, stage, start) >= e) {
            return Some(StopReason::Strain);
        }
        None
    }

    fn fraction(&self, sim: &dyn Simulation, phi0: Real, start: &StageStart) -> Real {
        let mut global: Real = 0.0;
        let s = &self.stop;
        if let Some(n) = s.steps {
            global = global.max(sim.steps_done() as Real / n as Real);
        }
        if let Some(t) = s.time {
            global = global.max(sim.time() / t);
        }
        if let Some(phi) = s.packing_fraction {
            if phi > phi0 {
                global = global.max((sim.packing_fraction() - phi0) / (phi - phi0));
            }
        }
        if let Some(e) = s.strain {
            global = global.max(sim.strain() / e);
        }
        // Within the stage: the most advanced of its criteria (a stage that ends at equilibrium
        // cannot say how far it is; it counts as half done).
        let stage = &self.stages[start.index];
        let mut local: Real = if stage.equilibrium.is_some() { 0.5 } else { 0.0 };
        let u = &stage.until;
        if stage.equilibrium.is_none() {
            if let Some(n) = u.steps {
                local = local.max((sim.steps_done() - start.step) as Real / n as Real);
            }
            if let Some(t) = u.time {
                local = local.max((sim.time() - start.time) / t);
            }
        }
        if let Some(phi) = u.packing_fraction {
            if phi > phi0 {
                local = local.max((sim.packing_fraction() - phi0) / (phi - phi0));
            }
        }
        if let Some(e) = u.strain {
            local = local.max(self.stage_strain(sim, stage, start) / e);
        }
        let staged = (start.index as Real + local.clamp(0.0, 1.0)) / self.stages.len() as Real;
        global.max(staged).clamp(0.0, 1.0)
    }

    /// Runs to the end, calling `on_sample` with the initial sample, every sample at the
    /// interval and the final one.
    pub fn run(&self, sim: &mut dyn Simulation, on_sample: &mut dyn FnMut(&Sample, &Progress)) -> Result<RunSummary, EngineError> {
        self.run_with_snapshots(sim, on_sample, &mut |_| {})
    }

    /// As [`Runner::run`], also calling `on_snapshot` with the initial state, at the
    /// `snapshot_every` interval and with the final state (each step at most once). To stop the run from
    /// `on_snapshot` (a write failed), set `cancel`.
    ///
    /// The stages run in order: each applies its controls, starts with a sample (the first
    /// stage's is the initial sample), then steps until one of its criteria (or, for a stage with
    /// an equilibrium criterion, equilibrium) is reached, and ends with a sample. The run's own `stop` limits end everything at once.
    pub fn run_with_snapshots(
        &self,
        sim: &mut dyn Simulation,
        on_sample: &mut dyn FnMut(&Sample, &Progress),
        on_snapshot: &mut dyn FnMut(&Snapshot),
    ) -> Result<RunSummary, EngineError> {
        self.run_resumable(sim, None, on_sample, on_snapshot, &mut |_| {})
    }

    /// As [`Runner::run_with_snapshots`], calling `on_checkpoint` with a checkpoint whenever
    /// [`Runner::checkpoint`] is set, and, with `resume`, going on from a checkpoint instead of
    /// starting: `sim` must then have been built from the checkpoint's state
    /// ([`Checkpoint::scene_to_resume`]); its clock is set back, the samples taken before the
    /// checkpoint feed the analysis again, and the run takes no initial sample or snapshot (the
    /// first it reports are the first due after the checkpoint's step).
    pub fn run_resumable(
        &self,
        sim: &mut dyn Simulation,
        resume: Option<Resume>,
        on_sample: &mut dyn FnMut(&Sample, &Progress),
        on_snapshot: &mut dyn FnMut(&Snapshot),
        on_checkpoint: &mut dyn FnMut(&Checkpoint),
    ) -> Result<RunSummary, EngineError> {
        let mut analysis = self.analysis.clone();
        analysis.for_grains(sim.grain_model());
        let started = std::time::Instant::now();
        let mut run = RunState {
            runner: self,
            analysis,
            on_sample,
            on_snapshot,
            on_checkpoint,
            last_snapshot: None,
            samples: 0,
            snapshots: 0,
            settled: 0,
            started,
            phi0: sim.packing_fraction(),
            annotate: self.stages.len() > 1 || self.stages.iter().any(|s| !s.name.is_empty()),
            next_time: match self.sampling {
                Sampling::Time(t) => t,
                Sampling::Steps(_) => Real::INFINITY,
            },
        };
        let (mut start, mut last) = match resume {
            None => {
                let start = self.begin(sim, 0)?;
                let last = run.take(sim, &start)?;
                run.snapshot(sim);
                (start, last)
            }
            Some(r) => self.resume(&mut run, sim, r)?,
        };
        let reason = loop {
            let stage = &self.stages[start.index];
            let ended = match self.run_stage(&mut run, sim, &start, &mut last)? {
                ControlFlow::Break(r) => break r,
                ControlFlow::Continue(r) => r,
            };
            // Every stage ends with a sample of its final state.
            if last.step != sim.steps_done() || last.stage.as_deref() != Some(stage.name.as_str()) && run.annotate {
                last = run.take(sim, &start)?;
            }
            if start.index + 1 == self.stages.len() {
                break ended;
            }
            start = self.begin(sim, start.index + 1)?;
            run.settled = 0;
            // And every later stage starts with one (same step, zero strain), the origin of its curves.
            last = run.take(sim, &start)?;
        };
        if last.step != sim.steps_done() {
            last = run.take(sim, &start)?;
        }
        run.snapshot(sim);
        let mut analysis = run.analysis;
        if analysis.needs_final_state() {
            analysis.final_state(&sim.saved_state());
        }
        let (d, rho) = sim.grain_scales();
        let result = analysis.finish(d, rho);
        Ok(RunSummary {
            reason,
            steps: sim.steps_done(),
            time: sim.time(),
            wall_seconds: started.elapsed().as_secs_f64(),
            solver_iterations: sim.solver_iterations(),
            last,
            result,
        })
    }

    /// Sets `sim` and `run` where checkpoint `r` left them; returns where its stage started and
    /// the last sample before it.
    fn resume(&self, run: &mut RunState, sim: &mut dyn Simulation, r: Resume) -> Result<(StageStart, Sample), EngineError> {
        let cp = r.checkpoint;
        let refuse = |reason: String| EngineError::Build { field: "checkpoint".into(), reason };
        if cp.stage.index >= self.stages.len() {
            return Err(refuse(format!("stage {} does not exist: the scene has {}", cp.stage.index, self.stages.len())));
        }
        let Some(last) = r.samples.last() else {
            return Err(refuse("no sample before the checkpoint was given".into()));
        };
        if r.samples.len() as u64 != cp.samples {
            return Err(refuse(format!("{} samples came before it, {} were given", cp.samples, r.samples.len())));
        }
        // The controls of the stages up to the checkpoint's, in order (a stage keeps what the
        // ones before it set), without what acts once when a stage starts and is already in
        // the state (walls closed onto the grains, a shear profile imposed, grains glued); then
        // the clock, which sets back the walls' servos the controls reset, and what the run
        // carried (the grains it glued, its contacts' history).
        let quiet = |stage: &Stage| Stage {
            controls: Controls { close_walls: None, glue: None, shear_rate: None, ..stage.controls.clone() },
            ..stage.clone()
        };
        for stage in &self.stages[..cp.stage.index] {
            sim.apply_controls(&quiet(stage).controls)?;
        }
        sim.begin_stage(&quiet(&self.stages[cp.stage.index]))?;
        sim.set_clock(&cp.clock);
        sim.carry_on(&cp.carried)?;
        for s in r.samples {
            run.analysis.push(s);
        }
        run.samples = cp.samples;
        run.snapshots = cp.snapshots;
        run.settled = cp.settled;
        run.last_snapshot = cp.last_snapshot;
        run.phi0 = cp.phi0;
        if let Some(t) = cp.next_sample_time {
            run.next_time = t;
        }
        let p = &cp.stage;
        let start = StageStart { index: p.index, step: p.step, time: p.time, lengths: Vec3::from(p.lengths), strain: p.strain };
        Ok((start, last.clone()))
    }

    /// Applies stage `index`'s controls and notes where it starts.
    fn begin(&self, sim: &mut dyn Simulation, index: usize) -> Result<StageStart, EngineError> {
        sim.begin_stage(&self.stages[index])?;
        Ok(StageStart { index, step: sim.steps_done(), time: sim.time(), lengths: sim.box_lengths(), strain: sim.strain() })
    }

    /// Steps the stage that began at `start`, sampling and snapshotting as due, until it ends
    /// (`Continue` with why) or the whole run does (`Break` with why).
    fn run_stage(
        &self,
        run: &mut RunState,
        sim: &mut dyn Simulation,
        start: &StageStart,
        last: &mut Sample,
    ) -> Result<ControlFlow<StopReason, StopReason>, EngineError> {
        let stage = &self.stages[start.index];
        let mut balance = None;
        loop {
            // A checkpoint before this step's checks (a run resumed from it makes them again),
            // and before the cancellation: a worker that stops asks for both.
            if self.checkpoint.swap(false, Ordering::SeqCst) {
                run.checkpoint(sim, start);
            }
            if let Some(r) = self.reached_global(sim) {
                return Ok(ControlFlow::Break(r));
            }
            if let Some(eq) = &stage.equilibrium {
                if (sim.steps_done() - start.step).is_multiple_of(eq.check_every) {
                    let b = sim.balance();
                    run.settled = if b.satisfies(eq) { run.settled + 1 } else { 0 };
                    balance = Some(b);
                    if run.settled >= eq.consecutive.unwrap_or_else(|| sim.equilibrium_checks()) {
                        return Ok(ControlFlow::Continue(StopReason::Equilibrium));
                    }
                }
            }
            if let Some(r) = self.reached_stage(sim, stage, start) {
                if let Some(eq) = &stage.equilibrium {
                    return Err(not_converged(stage, sim.steps_done(), balance.unwrap_or_else(|| sim.balance()), eq));
                }
                return Ok(ControlFlow::Continue(r));
            }
            if self.cancel.load(Ordering::SeqCst) {
                return Err(EngineError::Cancelled { step: sim.steps_done() });
            }
            sim.step()?;
            let due = run.sample_due(sim);
            let going_on = self.reached_global(sim).is_none() && self.reached_stage(sim, stage, start).is_none();
            if due && going_on {
                *last = run.take(sim, start)?;
            }
            if run.snapshot_due(sim, due) && going_on {
                run.snapshot(sim);
            }
        }
    }
}

/// What one run carries from step to step: its analysis, its callbacks, and when the last
/// snapshot and the next timed sample are.
struct RunState<'a> {
    /// The runner whose stages run.
    runner: &'a Runner,
    /// The analysis the samples feed.
    analysis: Analysis,
    /// Called with every sample and the progress.
    on_sample: &'a mut dyn FnMut(&Sample, &Progress),
    /// Called with every snapshot.
    on_snapshot: &'a mut dyn FnMut(&Snapshot),
    /// Called with every checkpoint.
    on_checkpoint: &'a mut dyn FnMut(&Checkpoint),
    /// Step of the last snapshot taken.
    last_snapshot: Option<u64>,
    /// Samples taken since the run started (before a checkpoint it resumes from included).
    samples: u64,
    /// Snapshots taken, counted likewise.
    snapshots: u64,
    /// Equilibrium checks passed in a row in the current stage.
    settled: u32,
    /// When the run started.
    started: std::time::Instant,
    /// Packing fraction at the start.
    phi0: Real,
    /// Whether samples name their stage and carry its strain.
    annotate: bool,
    /// Time of the next sample when sampling by time.
    next_time: Real,
}

impl RunState<'_> {
    /// Takes a sample, annotated with its stage, feeds it to the analysis and reports it.
    fn take(&mut self, sim: &mut dyn Simulation, start: &StageStart) -> Result<Sample, EngineError> {
        let runner = self.runner;
        let mut s = sim.sample()?;
        if self.annotate {
            let stage = &runner.stages[start.index];
            s.stage = (!stage.name.is_empty()).then(|| stage.name.clone());
            let (a, b) = (start.lengths, sim.box_lengths());
            s.strain = Some(StrainSample::between(runner.dim, a.as_slice(), b.as_slice()));
        }
        self.analysis.push(&s);
        self.samples += 1;
        let fraction = runner.fraction(sim, self.phi0, start);
        let elapsed = self.started.elapsed().as_secs_f64();
        let remaining = (fraction > 1e-6).then(|| elapsed * (1.0 - fraction) / fraction);
        (self.on_sample)(&s, &Progress { fraction, elapsed, remaining });
        Ok(s)
    }

    /// Reports a snapshot, when snapshots are asked for and this step has none yet.
    fn snapshot(&mut self, sim: &dyn Simulation) {
        if self.runner.snapshot_every.is_some() && self.last_snapshot != Some(sim.steps_done()) {
            self.last_snapshot = Some(sim.steps_done());
            self.snapshots += 1;
            (self.on_snapshot)(&sim.snapshot());
        }
    }

    /// Reports a checkpoint of the run now, within the stage that began at `start`.
    fn checkpoint(&mut self, sim: &dyn Simulation, start: &StageStart) {
        let l = start.lengths;
        let cp = Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            version: CHECKPOINT_VERSION,
            clock: sim.clock(),
            stage: StagePoint { index: start.index, step: start.step, time: start.time, lengths: [l[0], l[1], l[2]], strain: start.strain },
            phi0: self.phi0,
            next_sample_time: self.next_time.is_finite().then_some(self.next_time),
            samples: self.samples,
            snapshots: self.snapshots,
            settled: self.settled,
            last_snapshot: self.last_snapshot,
            state: sim.saved_state(),
            carried: sim.carried(),
        };
        (self.on_checkpoint)(&cp);
    }

    /// Whether a sample is due after the step just taken (moving on the next sampling time).
    fn sample_due(&mut self, sim: &dyn Simulation) -> bool {
        match self.runner.sampling {
            Sampling::Steps(n) => sim.steps_done().is_multiple_of(n),
            Sampling::Time(t) => {
                if sim.time() >= self.next_time - 0.5 * sim.dt() {
                    self.next_time += t;
                    true
                } else {
                    false
                }
            }
        }
    }

    /// Whether a snapshot is due after the step just taken (`every 0`: with each sample).
    fn snapshot_due(&self, sim: &dyn Simulation, sample_due: bool) -> bool {
        match self.runner.snapshot_every {
            Some(0) => sample_due,
            Some(n) => sim.steps_done().is_multiple_of(n),
            None => false,
        }
    }
}

fn not_converged(stage: &Stage, step: u64, b: Balance, eq: &Equilibrium) -> EngineError {
    EngineError::NotConverged {
        stage: stage.name.clone(),
        step,
        kinetic_ratio: b.kinetic_ratio(),
        kinetic_limit: eq.kinetic_ratio,
        unbalanced_force: b.unbalanced_force,
        unbalanced_limit: eq.unbalanced_force,
        stress_error: b.stress_error,
        stress_limit: eq.stress_tolerance,
    }
}
