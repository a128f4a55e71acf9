//! Every engine-level validation test of Sable in one test binary: the physics of each method
//! and law, the standard experiments, saved states, snapshots and the shipped studies. One
//! binary, not one per file, because each test binary links (and monomorphises) the whole
//! engine again at opt-level 3: merged, the 22 files build in 76 s (2026-12-02, `--timings`, on
//! a shared core); the old layout's cost was not measured side by side. Each file
//! stays a module of its own name: `cargo test -p sable-tests --test physics physics_bpm::`
//! runs one.

mod common;

#[path = "checkpoints.rs"]
mod checkpoints;
#[path = "experiments.rs"]
mod experiments;
#[path = "golden_samples.rs"]
mod golden_samples;
#[path = "physics_agglomerate.rs"]
mod physics_agglomerate;
#[path = "physics_bpm.rs"]
mod physics_bpm;
#[path = "physics_cd.rs"]
mod physics_cd;
#[path = "physics_cd_cell.rs"]
mod physics_cd_cell;
#[path = "physics_cd_cohesion.rs"]
mod physics_cd_cohesion;
#[path = "physics_cd_drum.rs"]
mod physics_cd_drum;
#[path = "physics_collision.rs"]
mod physics_collision;
#[path = "physics_energy.rs"]
mod physics_energy;
#[path = "physics_fem.rs"]
mod physics_fem;
#[path = "physics_incline.rs"]
mod physics_incline;
#[path = "physics_invariants.rs"]
mod physics_invariants;
#[path = "physics_jamming.rs"]
mod physics_jamming;
#[path = "physics_mpm.rs"]
mod physics_mpm;
#[path = "physics_neighbors.rs"]
mod physics_neighbors;
#[path = "physics_settling.rs"]
mod physics_settling;
#[path = "physics_shear.rs"]
mod physics_shear;
#[path = "physics_stability.rs"]
mod physics_stability;
#[path = "physics_two_plates.rs"]
mod physics_two_plates;
#[path = "physics_walls.rs"]
mod physics_walls;
#[path = "physics_wet.rs"]
mod physics_wet;
#[path = "saved_state.rs"]
mod saved_state;
#[path = "shipped_studies.rs"]
mod shipped_studies;
#[path = "snapshots.rs"]
mod snapshots;
