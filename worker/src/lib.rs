//! # sable-worker
//!
//! The worker pool that leases queued jobs and drives the engine. This crate is filled by the
//! service issue; today it holds the one piece the service and the CLI share: running a scene
//! to completion with a sample callback.

use sable_engine::run::{Progress, RunSummary, Runner};
use sable_engine::scene::Scene;
use sable_engine::{observe::Sample, EngineError};

/// Builds the scene's method and runs it to its stop criteria with `runner`.
pub fn run_scene(scene: &Scene, runner: &Runner, on_sample: &mut dyn FnMut(&Sample, &Progress)) -> Result<RunSummary, EngineError> {
    let mut sim = sable_engine::methods::build(scene)?;
    runner.run(sim.as_mut(), on_sample)
}
