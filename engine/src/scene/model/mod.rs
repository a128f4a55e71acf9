//! The checked scene: typed values that the methods build from. Produced only by
//! [`validate`](super::validate), so every invariant stated here holds. A scene knows no
//! method: `methods::Plan` pairs it with the one that runs it.
//!
//! This module holds the scene, its stop, sampling and stages; `materials.rs`, `sets.rs`,
//! `container.rs` and `experiments.rs` hold the checked forms of those sections.

mod container;
mod experiments;
mod materials;
mod sets;

pub use container::{Ball, Container, Deformation, DrumDef, Face, WallDef, WallMotion};
pub use experiments::{CompactionDrive, Experiment, Preparation};
pub use materials::{Cohesion, ElasticLaw, Liquid, Material, Rolling};
pub use sets::{Aabb, AggregateModel, InitialVelocity, LatticeKind, ParticleSet, Placement, SizeDist, AGGREGATE_FILL};

use crate::math::{Real, Vec3};

/// A validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name (the file's `name`, or `"scene"`).
    pub name: String,
    /// 2 or 3.
    pub dim: usize,
    /// Materials; particle sets and walls refer to them by index.
    pub materials: Vec<Material>,
    /// Particle sets in placement order (empty when the scene starts from a state).
    pub sets: Vec<ParticleSet>,
    /// The saved state the scene starts from (`start_from`), whose particles replace the sets.
    pub initial: Option<std::sync::Arc<super::state::InitialState>>,
    /// Box, walls, periodicity and imposed deformation.
    pub container: Container,
    /// Gravity, m/s² (z = 0 in 2D).
    pub gravity: Vec3,
    /// Stop criteria of the whole run (for a scene with an `experiment`, the limits it gives,
    /// possibly none: each stage then ends by its own criteria).
    pub stop: Stop,
    /// The loading program, in order: one stage built from `stop` for a plain scene, or the
    /// stages of the scene's experiment ([`Experiment::stages`]). Never empty.
    pub stages: Vec<Stage>,
    /// The standard experiment the scene runs, if any (its derived results are computed by
    /// [`crate::observe::results`]).
    pub experiment: Option<Experiment>,
    /// Sampling interval.
    pub sampling: Sampling,
    /// Snapshot interval in steps (0: with every sample); `None`: no snapshots.
    pub snapshots: Option<u64>,
    /// Seed of all random draws.
    pub seed: u64,
}

/// The most particles a scene may place (primaries of aggregates included), whatever the
/// machine: beyond it the engine's per-particle arrays alone would take hundreds of gigabytes.
/// A server bounds scenes further by its own limit.
pub const MAX_PARTICLES: usize = 1_000_000_000;

impl Scene {
    /// Makes this scene, planned from a checkpoint's state ([`crate::resume`]), go on as the
    /// run of `original` that saved it: the simulation built from it keeps the state's particle
    /// order (to which the carried contact history refers) and does not relax aggregates again,
    /// and the loading program is `original`'s — its rates derive from the scene's nominal
    /// grains (an inertial number's shear rate from the sets' mean diameter), which a plan
    /// from the state would derive from the grains it holds (0.5% apart for disks of
    /// 0.8–1.2 mm). Nothing happens for a scene without a state.
    pub fn continue_saved_run(&mut self, original: &Scene) {
        let Some(initial) = self.initial.as_mut() else { return };
        std::sync::Arc::make_mut(initial).continued = true;
        self.stages = original.stages.clone();
        self.experiment = original.experiment.clone();
        self.stop = original.stop;
        self.sampling = original.sampling;
    }

    /// Whether the simulation goes on from a checkpoint's state
    /// ([`Scene::continue_saved_run`]).
    pub fn continues_saved_run(&self) -> bool {
        self.initial.as_ref().is_some_and(|st| st.continued)
    }

    /// Number of particles: those of the sets (an aggregate set's estimated primaries), or of
    /// the state the scene starts from. Saturates at `usize::MAX` rather than wrapping, so a
    /// scene whose counts overflow compares above every limit.
    pub fn particle_count(&self) -> usize {
        let from_state = self.initial.as_ref().map_or(0, |st| st.radius.len());
        self.sets.iter().map(ParticleSet::particle_count).fold(from_state, usize::saturating_add)
    }

    /// Fastest motion the scene sets, m/s (0 if none): the grains' fastest initial speed
    /// (`initial`, m/s), free fall across the box, the walls' speeds (imposed velocity, strain
    /// rate times length) in the container, the shear velocity across the box, the drum's rim;
    /// with `stages`, also the walls of every stage of the loading program and the finite
    /// `max_speed` of stress-controlled walls (left out without, which keeps DEM's
    /// impact-velocity estimate as it was).
    pub fn imposed_speed(&self, initial: Real, stages: bool) -> Real {
        let c = &self.container;
        let span = (0..self.dim).map(|a| c.hi[a] - c.lo[a]).fold(0.0, f64::max);
        let mut v: Real = initial;
        v = v.max((2.0 * self.gravity.norm() * span).sqrt());
        let mut walls: Vec<(usize, WallMotion)> = c.walls.iter().map(|w| (w.face.axis, w.motion)).collect();
        if stages {
            walls.extend(self.stages.iter().flat_map(|s| s.controls.walls.iter().map(|w| (w.face.axis, w.motion))));
        }
        for (axis, motion) in walls {
            match motion {
                WallMotion::Velocity(u) => v = v.max(u.norm()),
                WallMotion::StrainRate(r) => v = v.max((r * (c.hi[axis] - c.lo[axis])).abs()),
                WallMotion::Stress { max_speed, .. } if stages && max_speed.is_finite() => v = v.max(max_speed),
                WallMotion::Shearing { shear_rate, .. } if stages => v = v.max((shear_rate * (c.hi[axis] - c.lo[axis])).abs()),
                _ => {}
            }
        }
        if let Some((rate, _)) = c.lees_edwards {
            v = v.max(rate.abs() * (c.hi.y - c.lo.y));
        }
        if stages {
            // The stages' Lees-Edwards shear, and the cell's deformation (a length's rate).
            let length = |a: usize| c.hi[a] - c.lo[a];
            for s in &self.stages {
                if let Some(rate) = s.controls.shear_rate {
                    v = v.max(rate.abs() * length(1));
                }
            }
            let staged = self.stages.iter().filter_map(|s| s.controls.deformation.flatten());
            for d in c.deformation.into_iter().chain(staged) {
                let rate = match d {
                    Deformation::StrainRate(r) => r.abs().max(),
                    Deformation::Pressure { max_strain_rate, .. } | Deformation::NormalStress { max_strain_rate, .. } => max_strain_rate,
                };
                v = v.max(rate * span);
            }
        }
        if let Some(crate::scene::Experiment::Drum { drum, angular_velocity, .. }) = &self.experiment {
            v = v.max(angular_velocity.abs() * drum.radius);
        }
        v
    }
}

/// Stop criteria.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stop {
    /// Simulated time, s.
    pub time: Option<Real>,
    /// Steps.
    pub steps: Option<u64>,
    /// Packing fraction reached.
    pub packing_fraction: Option<Real>,
    /// Strain reached.
    pub strain: Option<Real>,
}

/// Sampling interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// Every n steps.
    Steps(u64),
    /// Every t seconds of simulated time.
    Time(Real),
}

/// One stage of a loading program: the boundary controls set at its start and the criteria
/// that end it.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// Name reported with every sample of the stage (`preparation`, `loading`, ...).
    pub name: String,
    /// Boundary and material controls applied when the stage starts.
    pub controls: Controls,
    /// Ends the stage (first criterion reached). `strain` counts from the stage's start.
    pub until: Stop,
    /// Axis whose true strain `|ln(L/L_start)|` the `until.strain` criterion reads; `None`: the
    /// largest over the axes (the Lees-Edwards strain under shear).
    pub strain_axis: Option<usize>,
    /// When set, the stage ends once the system is at equilibrium; reaching `until`'s time or
    /// steps first is then an error ([`crate::EngineError::NotConverged`]).
    pub equilibrium: Option<Equilibrium>,
}

/// Controls that a stage changes when it starts. Fields left empty keep what the stage before
/// set (or the container's initial settings).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Controls {
    /// New motion of these walls (the others keep theirs).
    pub walls: Vec<WallDef>,
    /// `Some(d)`: the cell deformation becomes `d` (`None` inside: the cell stops).
    pub deformation: Option<Option<Deformation>>,
    /// Coulomb friction of every particle-particle contact during the stage (wall contacts keep
    /// their material's); `None`: the materials' own.
    pub friction: Option<Real>,
    /// Cundall's local damping during the stage; `None`: the method's own setting.
    pub local_damping: Option<Real>,
    /// `Some(rate)`: the Lees-Edwards shear rate becomes `rate` (1/s; x and y periodic), and the
    /// grains' x-velocities get the change of the linear profile `Δrate (y - y_centre)`.
    pub shear_rate: Option<Real>,
    /// `Some(ω)`: the drum turns at ω, rad/s (right-handed about its axis).
    pub drum_angular_velocity: Option<Real>,
    /// `Some(gap)`: the grains whose surface lies within `gap` mean diameters of a wall are
    /// glued to it (rough walls): from then on they move with the wall, do not turn, and the
    /// load the other grains put on them is the wall's.
    pub glue: Option<Real>,
    /// `Some(a)`: every grain is pulled towards the centre of the container's granule ball
    /// with the acceleration `a`, m/s² (0 switches the field off).
    pub centripetal: Option<Real>,
    /// `Some(axis)`: the two walls of this axis jump to the grains' extent along it (they
    /// touch the outermost grains) when the stage starts.
    pub close_walls: Option<usize>,
}

/// The equilibrium criterion of a stage: all must hold at `consecutive` checks in a row,
/// `check_every` steps apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equilibrium {
    /// Translational kinetic energy / elastic energy stored in the contacts.
    pub kinetic_ratio: Real,
    /// Mean norm of the net force on a particle / mean norm of a contact force (Yade's
    /// "unbalanced force").
    pub unbalanced_force: Real,
    /// Relative error of every stress-controlled boundary against its target.
    pub stress_tolerance: Real,
    /// Steps between checks.
    pub check_every: u64,
    /// Checks in a row that must pass; `None`: the method's own number
    /// ([`crate::run::Simulation::equilibrium_checks`]).
    pub consecutive: Option<u32>,
}

impl Default for Equilibrium {
    fn default() -> Self {
        Self { kinetic_ratio: 1e-4, unbalanced_force: 1e-2, stress_tolerance: 0.01, check_every: 500, consecutive: None }
    }
}
