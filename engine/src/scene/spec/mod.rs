//! The scene file as written by users: plain serde types, SI units, unknown fields rejected.
//!
//! These types describe the physics of a scene, not the algorithm that simulates it. They are
//! turned into the checked [`Scene`](super::Scene) by [`validate`](super::validate), which
//! reports every broken rule at once. The full format is documented in `docs/scene-format.md`.
//!
//! This module holds the top level, its `start_from`, stop, sampling and snapshots;
//! `materials.rs`, `sets.rs`, `container.rs` and `experiments.rs` hold those sections.

mod container;
mod experiments;
mod materials;
mod sets;

pub use container::{ContainerSpec, DeformationSpec, LeesEdwardsSpec, WallSpec};
pub use experiments::{
    CompactionSpec, DepositionSpec, DrumSpec, EquilibriumSpec, ExperimentSpec, GranuleCompressionSpec, IsotropicSpec, PlaneShearSpec,
    PreparationSpec, TriaxialSpec,
};
pub use materials::{CohesionSpec, ContactLawSpec, DeformableSpec, LiquidSpec, MaterialSpec, RollingSpec};
pub use sets::{BallSpec, BondAttractionSpec, GrainModelSpec, ParticleSetSpec, PlacementSpec, RegionSpec, SizeSpec, VelocitySpec};

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Top level of a scene file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Optional human-readable name.
    #[serde(default)]
    pub name: Option<String>,
    /// 2 (disks, plane problems; quantities per metre of thickness) or 3 (spheres).
    pub dimension: u8,
    /// Method name (`"dem"`) or object `{"kind": "dem", ...parameters}`.
    pub method: serde_json::Value,
    /// Named materials.
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Particle sets, placed in order (none when the scene starts from a saved state).
    #[serde(default)]
    pub particles: Vec<ParticleSetSpec>,
    /// A saved state to start from instead of placing particle sets (its particles and box).
    #[serde(default)]
    pub start_from: Option<StartFromSpec>,
    /// The box, its walls, periodic directions and imposed deformation.
    pub container: ContainerSpec,
    /// Gravity vector, m/s² (length = dimension). Default: none.
    #[serde(default)]
    pub gravity: Option<Vec<f64>>,
    /// When to stop; the first criterion reached ends the run.
    #[serde(default)]
    pub stop: Option<StopSpec>,
    /// How often to take a sample. Default: 100 samples over the run.
    #[serde(default)]
    pub sampling: Option<SamplingSpec>,
    /// VTK snapshots for ParaView (particles, contact network, walls). Default: none.
    #[serde(default)]
    pub snapshots: Option<SnapshotSpec>,
    /// A standard experiment: its preparation and loading program replace `stop` (which then
    /// only limits the whole run, if given).
    #[serde(default)]
    pub experiment: Option<ExperimentSpec>,
    /// Seed of every random draw (placement, velocities). Default 0.
    #[serde(default)]
    pub seed: Option<u64>,
}

/// Where a scene's particles come from when it starts from a saved state: exactly one field.
/// The engine reads only `state`; the `sable` CLI replaces `file` by the file's content and the
/// service replaces `job` by that job's final state before validation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartFromSpec {
    /// Id of a succeeded job of the service, whose final state to start from.
    #[serde(default)]
    pub job: Option<i64>,
    /// Path of a state file (`sable run --save-state`, `sable state`), relative to the scene file.
    #[serde(default)]
    pub file: Option<String>,
    /// The state itself.
    #[serde(default)]
    pub state: Option<Box<super::state::StateFile>>,
}

/// Stop criteria; the first one reached ends the run.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopSpec {
    /// Simulated time, s.
    #[serde(default)]
    pub time: Option<f64>,
    /// Number of steps.
    #[serde(default)]
    pub steps: Option<u64>,
    /// Target packing fraction: stop when Φ >= this value.
    #[serde(default)]
    pub packing_fraction: Option<f64>,
    /// Target strain magnitude: shear strain with Lees-Edwards, else the largest |ln(L/L0)|.
    #[serde(default)]
    pub strain: Option<f64>,
}

/// Sampling interval: give exactly one.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingSpec {
    /// Sample every this many steps.
    #[serde(default)]
    pub every_steps: Option<u64>,
    /// Sample every this much simulated time, s.
    #[serde(default)]
    pub every_time: Option<f64>,
}

/// When to take snapshots.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SnapshotSpec {
    /// Every this many steps; absent: with every sample.
    #[serde(default)]
    pub every_steps: Option<u64>,
}
