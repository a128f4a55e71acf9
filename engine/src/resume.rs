//! Checkpoints: where a run stands, saved while it goes on, so that a run stopped by its worker
//! (a crash, the end of an allocation) goes on from there instead of from step 0
//! (docs/validation.md, "Checkpoints", with how closely a resumed run follows one never
//! stopped).
//!
//! A checkpoint is the method's saved state ([`crate::scene::state`]: particles, box, and the
//! material points or meshes of soft grains) with what the [`crate::run::Runner`] needs to go on
//! from the same step: the simulation's clock ([`Clock`]), the stage running and where it
//! started ([`StagePoint`]), and how many samples and snapshots came before. The run that
//! resumes is built from the saved state as a scene's `start_from` is, its clock is set back,
//! and the samples taken before the checkpoint are fed to its analysis again, so its results
//! cover the whole run. What a saved state does not hold starts afresh, as after `start_from`:
//! the contacts' history (tangential and rolling springs, capillary bridges, contact
//! dynamics' impulses of the last step). A run whose grains are glued to its walls (rough
//! walls) takes no checkpoint: a saved state does not say which grains are.

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::scene::StateFile;

/// Value of [`Checkpoint::format`].
pub const CHECKPOINT_FORMAT: &str = "sable-checkpoint";
/// Version of the checkpoint format written by this engine; a checkpoint of another version is
/// not resumed from (the run starts over).
pub const CHECKPOINT_VERSION: u32 = 1;

/// A run's clock: what a simulation built from a saved state must be told to count on from the
/// step it was saved at ([`crate::run::Simulation::set_clock`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Clock {
    /// Steps done.
    pub steps: u64,
    /// Simulated time, s.
    pub time: Real,
    /// Box lengths at the start of the run, m (the origin of the strain).
    pub len0: [Real; 3],
    /// The method's running totals since the start (soft grains: the work of the walls and
    /// gravity, J/m, and the energy at the start, J/m); empty for methods without any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub totals: Vec<Real>,
    /// Shear rate of a Lees-Edwards cell, 1/s (0: not sheared).
    #[serde(default)]
    pub shear_rate: Real,
    /// Each plane wall's velocity (m/s, three components) and servo integral (m/s), in the
    /// container's order: a stress-controlled wall goes on at the speed it had.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub walls: Vec<[Real; 4]>,
}

/// Where the stage that was running at a checkpoint started.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StagePoint {
    /// Index of the stage in the scene's loading program.
    pub index: usize,
    /// Step it started at.
    pub step: u64,
    /// Time it started at, s.
    pub time: Real,
    /// Box lengths when it started, m.
    pub lengths: [Real; 3],
    /// The run's strain when it started.
    pub strain: Real,
}

/// Where a run stands, to go on from ([`crate::run::Runner::run_resumable`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checkpoint {
    /// Always [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// [`CHECKPOINT_VERSION`].
    pub version: u32,
    /// The simulation's clock.
    pub clock: Clock,
    /// The stage running.
    pub stage: StagePoint,
    /// Packing fraction at the start of the run (the origin of its progress).
    pub phi0: Real,
    /// Time of the next sample when the scene samples by time, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_sample_time: Option<Real>,
    /// Samples taken before the checkpoint (the run that resumes numbers its own from there).
    pub samples: u64,
    /// Snapshots taken before the checkpoint.
    pub snapshots: u64,
    /// Equilibrium checks the stage had passed in a row (a stage that runs until equilibrium).
    #[serde(default)]
    pub settled: u32,
    /// Step of the last snapshot taken.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_snapshot: Option<u64>,
    /// The method's saved state.
    pub state: StateFile,
}

impl Checkpoint {
    /// Reads a checkpoint from its JSON, refusing another format or version.
    pub fn from_json(text: &str) -> Result<Self, String> {
        let c: Self = serde_json::from_str(text).map_err(|e| format!("not a checkpoint: {e}"))?;
        if c.format != CHECKPOINT_FORMAT {
            return Err(format!("format is '{}', not '{CHECKPOINT_FORMAT}'", c.format));
        }
        if c.version != CHECKPOINT_VERSION {
            return Err(format!("version {} cannot be read by this engine (it reads version {CHECKPOINT_VERSION})", c.version));
        }
        Ok(c)
    }

    /// The scene JSON `scene` made to start from this checkpoint's state, as
    /// `start_from.state` (docs/scene-format.md §14: its particle sets and box corners give
    /// way to the state's); the run built from it goes on from the checkpoint once its clock is
    /// set.
    pub fn scene_to_resume(&self, scene: &str) -> Result<String, String> {
        let mut value: serde_json::Value = serde_json::from_str(scene).map_err(|e| format!("the scene is not JSON: {e}"))?;
        let obj = value.as_object_mut().ok_or("the scene is not a JSON object")?;
        obj.remove("particles");
        if let Some(container) = obj.get_mut("container").and_then(|c| c.as_object_mut()) {
            container.remove("min");
            container.remove("max");
        }
        let state = serde_json::to_value(&self.state).map_err(|e| format!("the state cannot be written: {e}"))?;
        obj.insert("start_from".into(), serde_json::json!({ "state": state }));
        Ok(value.to_string())
    }
}
