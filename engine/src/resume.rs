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
//! cover the whole run. What the rigid-grain methods carry from step to step beside the state
//! goes with it ([`Carried`]): the grains glued to the walls (rough walls), the wet grains'
//! followed cluster with its accretion and erosion so far, and the contacts'
//! history — DEM's tangential and rolling springs and capillary bridges, contact dynamics'
//! impulses of the last step (the solver's warm start) and bridges. The simulation that goes on
//! is built keeping the state's particle order ([`crate::scene::Scene::continue_saved_run`]),
//! to which the history refers, without relaxing aggregates again, and with the original
//! scene's loading program; its clock sets back what its build would derive anew from the
//! state ([`Clock::totals`]: the step, the walls' gains, the plates' masses). What is still not carried:
//! the contact impulses of soft grains (MPM, FEM: their next solve starts cold) and the window
//! over which contact dynamics averages its equilibrium checks (the first check after the
//! checkpoint averages over a shorter one).

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::observe::cluster::ClusterTrack;
use crate::scene::StateFile;

/// Value of [`Checkpoint::format`].
pub const CHECKPOINT_FORMAT: &str = "sable-checkpoint";
/// Version of the checkpoint format written by this engine; a checkpoint of a version outside
/// [`CHECKPOINT_OLDEST`]..=[`CHECKPOINT_VERSION`] is not resumed from (the run starts over).
pub const CHECKPOINT_VERSION: u32 = 3;
/// Oldest version of the checkpoint format this engine goes on from (version 1 carried no
/// [`Carried`]: its contacts start afresh; version 2 no followed wet cluster: its accretion
/// and erosion count again from the checkpoint).
pub const CHECKPOINT_OLDEST: u32 = 1;

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
    /// The method's own running values, which a build from the saved state would not find
    /// again: soft grains, the work of the walls and gravity, J/m, and the energy at the
    /// start, J/m; DEM, the time step (s), then each wall's default servo gain (m/(s·Pa)),
    /// then, with a deforming periodic cell, its strain rate along x, y and z (1/s); contact
    /// dynamics, the nominal time step (s), the mass of a stress-controlled wall (kg), then,
    /// with a deforming periodic cell, the velocity of its lengths (m/s, x, y, z) and of its
    /// stress-controlled degree of freedom (m/s).
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
    /// What the run carries beside the state (glued grains, contact history).
    #[serde(default, skip_serializing_if = "Carried::is_empty")]
    pub carried: Carried,
}

/// What a run carries from step to step that a saved state does not hold, with particles
/// numbered in the state's order ([`crate::run::Simulation::carried`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Carried {
    /// Grains glued to a wall (rough walls): (particle, index of the wall in the container's
    /// order).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub glued: Vec<(u32, u16)>,
    /// The contacts' history.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contacts: Option<ContactHistory>,
    /// The wet grains' followed cluster and its accretion and erosion so far (version 3).
    #[serde(default, skip_serializing_if = "ClusterTrack::is_empty")]
    pub cluster: ClusterTrack,
}

impl Carried {
    /// Nothing carried.
    pub fn is_empty(&self) -> bool {
        self.glued.is_empty() && self.contacts.is_none() && self.cluster.is_empty()
    }
}

/// The other side of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Other {
    /// Another particle (index in the state's order).
    Particle(u32),
    /// A boundary: the plane walls in the container's order, then the drum.
    Boundary(u16),
}

/// The contacts' history of a method, by what the method carries.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactHistory {
    /// Soft contacts (DEM): the springs of each interacting pair, and the loads of the last
    /// force evaluation, which the first steps after the checkpoint read before they evaluate
    /// their own (velocity Verlet's first half kick; the walls' servos).
    Springs {
        /// One per pair touching, or held by a capillary bridge, at the last force evaluation.
        contacts: Vec<SpringContact>,
        /// Force (N, x y z) then torque (N·m, x y z) on each particle at the last evaluation,
        /// in the state's order (empty: evaluated anew from the springs).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        loads: Vec<[Real; 6]>,
        /// Force of the grains on each plane wall at the last evaluation, N (x y z).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        walls: Vec<[Real; 3]>,
    },
    /// Rigid contacts (contact dynamics): the impulses of the last step.
    Impulses {
        /// One per contact of the last step.
        contacts: Vec<ImpulseContact>,
    },
}

/// What a DEM contact carries ([`crate::contact`]'s laws; the tangential spring of Cundall &
/// Strack, "A discrete numerical model for granular assemblies", 1979).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringContact {
    /// The particle (for a pair, the first: the one whose spring it is).
    pub i: u32,
    /// The other side.
    pub with: Other,
    /// Tangential spring, m (three components; z is 0 in 2D).
    pub spring: [Real; 3],
    /// Rolling spring, rad (zero without rolling resistance).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub roll: [Real; 3],
    /// A capillary bridge joins the pair.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub bridge: bool,
}

/// What a contact of contact dynamics carries to the next step (its warm start; Jean, "The
/// non-smooth contact dynamics method", 1999).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImpulseContact {
    /// The particle (for a pair, the first: the impulse is the one on it).
    pub i: u32,
    /// The other side.
    pub with: Other,
    /// Impulse on `i`, N·s (three components).
    pub impulse: [Real; 3],
    /// Rolling moment impulse on `i`, N·m·s (zero without rolling resistance).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub moment: [Real; 3],
    /// The contact pressed at the last step (a lasting contact: no restitution).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub pressed: bool,
    /// A capillary bridge joins the pair.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub bridge: bool,
}

fn is_zero(v: &[Real; 3]) -> bool {
    v.iter().all(|&x| x == 0.0)
}

impl Checkpoint {
    /// Reads a checkpoint from its JSON, refusing another format or version.
    pub fn from_json(text: &str) -> Result<Self, String> {
        let c: Self = serde_json::from_str(text).map_err(|e| format!("not a checkpoint: {e}"))?;
        if c.format != CHECKPOINT_FORMAT {
            return Err(format!("format is '{}', not '{CHECKPOINT_FORMAT}'", c.format));
        }
        if !(CHECKPOINT_OLDEST..=CHECKPOINT_VERSION).contains(&c.version) {
            return Err(format!(
                "version {} cannot be read by this engine (it reads versions {CHECKPOINT_OLDEST} to {CHECKPOINT_VERSION})",
                c.version
            ));
        }
        Ok(c)
    }

    /// The scene JSON `scene` made to start from this checkpoint's state, as
    /// `start_from.state` (docs/scene-format.md §14: its particle sets and box corners give
    /// way to the state's); the run built from it, once planned, marked with
    /// [`crate::scene::Scene::continue_saved_run`], goes on from the checkpoint once its clock
    /// and what it carried are set back ([`crate::run::Runner::run_resumable`]).
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

#[cfg(test)]
mod tests {
    use super::*;

    fn checkpoint_json(version: u32, carried: serde_json::Value) -> String {
        serde_json::json!({
            "format": CHECKPOINT_FORMAT, "version": version,
            "clock": {"steps": 10, "time": 1e-3, "len0": [1.0, 1.0, 0.0]},
            "stage": {"index": 0, "step": 0, "time": 0.0, "lengths": [1.0, 1.0, 0.0], "strain": 0.0},
            "phi0": 0.5, "samples": 1, "snapshots": 0,
            "state": {"format": "sable-state", "version": 1, "dimension": 2, "min": [0.0, 0.0], "max": [1.0, 1.0],
                      "materials": ["m"],
                      "particles": {"material": [0], "radius": [0.1], "position": [[0.5, 0.5]], "velocity": [[0.0, 0.0]],
                                    "angular_velocity": [[0.0]]}},
            "carried": carried
        })
        .to_string()
    }

    #[test]
    fn what_a_run_carries_goes_through_json_and_older_versions_carry_nothing() {
        let carried = serde_json::json!({
            "glued": [[3, 1]],
            "cluster": {"members": [0, 2, 5], "accreted": 4, "eroded": 1},
            "contacts": {"kind": "springs", "contacts": [{"i": 0, "with": {"particle": 2}, "spring": [1e-6, 0.0, 0.0], "bridge": true},
                                                         {"i": 1, "with": {"boundary": 0}, "spring": [0.0, 2e-6, 0.0]}],
                         "loads": [[1.0, 2.0, 0.0, 0.0, 0.0, 0.5]], "walls": [[0.0, -3.0, 0.0]]}
        });
        let c = Checkpoint::from_json(&checkpoint_json(CHECKPOINT_VERSION, carried)).expect("a checkpoint");
        assert_eq!(c.carried.glued, vec![(3, 1)]);
        assert_eq!((c.carried.cluster.members.as_slice(), c.carried.cluster.accreted, c.carried.cluster.eroded), (&[0, 2, 5][..], 4, 1));
        let Some(ContactHistory::Springs { contacts, loads, walls }) = &c.carried.contacts else { panic!("springs: {:?}", c.carried) };
        assert_eq!(contacts[0].with, Other::Particle(2));
        assert!(contacts[0].bridge && !contacts[1].bridge);
        assert_eq!(contacts[1].with, Other::Boundary(0));
        assert_eq!((loads.len(), walls.len()), (1, 1));
        let again = Checkpoint::from_json(&serde_json::to_string(&c).expect("JSON")).expect("read back");
        assert_eq!(again, c);

        let impulses = serde_json::json!({"contacts": {"kind": "impulses", "contacts": [
            {"i": 0, "with": {"boundary": 2}, "impulse": [0.0, 1e-9, 0.0], "pressed": true}]}});
        let c = Checkpoint::from_json(&checkpoint_json(CHECKPOINT_VERSION, impulses)).expect("a checkpoint");
        assert!(
            matches!(&c.carried.contacts, Some(ContactHistory::Impulses { contacts }) if contacts[0].pressed && contacts[0].moment == [0.0; 3])
        );

        let old = Checkpoint::from_json(&checkpoint_json(1, serde_json::json!({}))).expect("version 1 is read");
        assert!(old.carried.is_empty());
        let err = Checkpoint::from_json(&checkpoint_json(CHECKPOINT_VERSION + 1, serde_json::json!({}))).expect_err("a newer version");
        assert!(err.contains("versions 1 to 3"), "{err}");
        let err = Checkpoint::from_json(&checkpoint_json(
            CHECKPOINT_VERSION,
            serde_json::json!({"contacts": {"kind": "springs", "contacts": [], "extra": 1}}),
        ))
        .expect_err("an unknown field");
        assert!(err.contains("extra"), "{err}");
    }
}
