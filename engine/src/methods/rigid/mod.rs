//! The rigid-grain methods' shared layer, the counterpart of [`super::soft::sim::SoftSim`]:
//! the world they move ([`RigidWorld`]: particles, box, walls, drum, glued grains, fields,
//! clock), the relaxation of aggregates ([`settle`]), and the [`Simulation`] both are, written
//! once over what each method adds ([`RigidMethod`]: its step, its contacts, its samples, its
//! stage controls and its equilibrium). DEM ([`super::dem`]) and contact dynamics
//! ([`super::cd`]) keep only their contact laws and their steps.

pub mod settle;
mod world;

pub use world::{RigidWorld, NOT_GLUED};

use crate::error::EngineError;
use crate::math::{Real, Vec3};
use crate::methods::world::in_own_pool;
use crate::observe::{ContactRecord, Sample, Snapshot};
use crate::resume::{Carried, Clock, ContactHistory};
use crate::run::{Balance, GrainModel, Simulation};
use crate::scene::{Controls, Stage, StateFile};

/// What a rigid-grain method adds to its [`RigidWorld`] to make a [`Simulation`]. The names
/// differ from [`Simulation`]'s so that both traits can be in scope.
pub trait RigidMethod: Send {
    /// Method name (`"dem"`, `"cd"`).
    const NAME: &'static str;
    /// How the method models the grains.
    const GRAIN_MODEL: GrainModel;
    /// The world.
    fn world(&self) -> &RigidWorld;
    /// The world, to change.
    fn world_mut(&mut self) -> &mut RigidWorld;
    /// The nominal time step, s.
    fn nominal_step(&self) -> Real;
    /// One step, in the method's own pool or not (the caller sees to it).
    fn advance(&mut self) -> Result<(), EngineError>;
    /// The contacts now as the metrics and snapshots see them.
    fn contact_records(&self) -> Vec<ContactRecord>;
    /// The (position, force) of each grain on the drum, for its shell in snapshots.
    fn drum_loads(&self) -> Vec<(Vec3, Vec3)>;
    /// Measures the state ([`Simulation::sample`]).
    fn measure(&mut self) -> Result<Sample, EngineError>;
    /// Heap bytes held.
    fn heap_size(&self) -> usize;
    /// Applies a stage's controls ([`Simulation::apply_controls`]); the method applies the
    /// world's part with [`RigidWorld::apply_controls`].
    fn controls(&mut self, controls: &Controls) -> Result<(), EngineError>;
    /// Starts a stage ([`Simulation::begin_stage`]).
    fn stage(&mut self, stage: &Stage) -> Result<(), EngineError> {
        self.controls(&stage.controls)
    }
    /// Distance from static equilibrium ([`Simulation::balance`]).
    fn equilibrium(&mut self) -> Balance;
    /// Checks in a row a stage's equilibrium needs ([`Simulation::equilibrium_checks`]).
    fn checks_in_a_row(&self) -> u32 {
        3
    }
    /// Contact-solver sweeps since the start.
    fn sweeps_done(&self) -> u64 {
        0
    }
    /// The method's own running values ([`Clock::totals`]).
    fn running_values(&self) -> Vec<Real>;
    /// Sets back what [`RigidMethod::running_values`] returned (a shorter list, from an older
    /// checkpoint, sets what it holds).
    fn set_running_values(&mut self, values: &[Real]);
    /// The contacts' history now, particles numbered as in the world ([`crate::resume`]).
    fn history(&self) -> ContactHistory;
    /// Sets back the contacts' history of a checkpoint (the glued grains are set already) and
    /// evaluates the forces again, so that the next step goes on as the run that saved it.
    fn restore_history(&mut self, history: Option<&ContactHistory>) -> Result<(), EngineError>;
}

/// The items of [`RigidMethod`] every rigid-grain method writes alike, for a method that keeps
/// its world in its field `w` and its nominal time step (s) in `dt`, steps with its
/// `step_stages` and gives its contacts with its `contacts`.
macro_rules! rigid_method_common {
    () => {
        fn world(&self) -> &$crate::methods::rigid::RigidWorld {
            &self.w
        }

        fn world_mut(&mut self) -> &mut $crate::methods::rigid::RigidWorld {
            &mut self.w
        }

        fn nominal_step(&self) -> $crate::math::Real {
            self.dt
        }

        fn advance(&mut self) -> Result<(), $crate::error::EngineError> {
            self.step_stages()
        }

        fn contact_records(&self) -> Vec<$crate::observe::ContactRecord> {
            self.contacts()
        }
    };
}
pub(crate) use rigid_method_common;

impl<M: RigidMethod> Simulation for M {
    fn method(&self) -> &'static str {
        M::NAME
    }

    fn grain_model(&self) -> GrainModel {
        M::GRAIN_MODEL
    }

    fn step(&mut self) -> Result<(), EngineError> {
        in_own_pool(self, |s| &mut s.world_mut().pool, M::advance)
    }

    fn steps_done(&self) -> u64 {
        self.world().step
    }

    fn solver_iterations(&self) -> u64 {
        self.sweeps_done()
    }

    fn time(&self) -> Real {
        self.world().time
    }

    fn dt(&self) -> Real {
        self.nominal_step()
    }

    fn particle_count(&self) -> usize {
        self.world().p.len()
    }

    fn packing_fraction(&self) -> Real {
        self.world().packing_fraction()
    }

    fn strain(&self) -> Real {
        self.world().strain()
    }

    fn box_lengths(&self) -> Vec3 {
        self.world().box_lengths()
    }

    fn sample(&mut self) -> Result<Sample, EngineError> {
        self.measure()
    }

    fn snapshot(&self) -> Snapshot {
        self.world().snapshot(self.contact_records(), self.drum_loads())
    }

    fn memory_bytes(&self) -> usize {
        self.heap_size()
    }

    fn apply_controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        self.controls(controls)
    }

    fn begin_stage(&mut self, stage: &Stage) -> Result<(), EngineError> {
        self.stage(stage)
    }

    fn balance(&mut self) -> Balance {
        self.equilibrium()
    }

    fn equilibrium_checks(&self) -> u32 {
        self.checks_in_a_row()
    }

    fn grain_scales(&self) -> (Real, Real) {
        self.world().grain_scales()
    }

    fn saved_state(&self) -> StateFile {
        self.world().saved_state()
    }

    fn clock(&self) -> Clock {
        let w = self.world();
        Clock {
            steps: w.step,
            time: w.time,
            len0: [w.len0[0], w.len0[1], w.len0[2]],
            totals: self.running_values(),
            shear_rate: w.domain.shear_rate,
            walls: w.walls.iter().map(|wall| wall.servo_state()).collect(),
        }
    }

    fn set_clock(&mut self, clock: &Clock) {
        // The step and the gains first: the walls' servo states below are set on top.
        self.set_running_values(&clock.totals);
        let w = self.world_mut();
        w.step = clock.steps;
        w.time = clock.time;
        w.len0 = Vec3::from(clock.len0);
        for (wall, s) in w.walls.iter_mut().zip(&clock.walls) {
            wall.set_servo_state(*s);
        }
        // The grains' velocities are the state's: only the cell's rate is set back.
        w.domain.shear_rate = clock.shear_rate;
    }

    fn carried(&self) -> Carried {
        Carried { glued: self.world().glued.clone(), contacts: Some(self.history()), cluster: self.world().cluster.clone() }
    }

    fn carry_on(&mut self, carried: &Carried) -> Result<(), EngineError> {
        let refuse = |reason: String| EngineError::Build { field: "checkpoint".into(), reason };
        if carried.is_empty() {
            return Ok(());
        }
        if !self.world().continued {
            return Err(refuse("the simulation was not built to continue its state (Scene::continue_saved_run)".into()));
        }
        self.world_mut().glue(&carried.glued).map_err(refuse)?;
        let n = self.world().p.len();
        if carried.cluster.members.iter().any(|&m| m as usize >= n) {
            return Err(refuse(format!("the followed cluster names a particle beyond the state's {n}")));
        }
        let mut track = carried.cluster.clone();
        track.members.sort_unstable();
        track.members.dedup();
        self.world_mut().cluster = track;
        in_own_pool(self, |s| &mut s.world_mut().pool, |s| s.restore_history(carried.contacts.as_ref()))
    }
}
