//! `sable bench bpm`: the bonded particle method's cost on the compaction of
//! [`sable_engine::scene::presets::bpm_compaction`] (≥ 100 aggregates of over 200 primaries), by
//! DEM or by contact dynamics: primary-steps per second (the method's natural unit), grain-seconds
//! simulated per second of wall time (what a study of grains needs), the step, the solver's
//! sweeps per step (CD), memory per primary, and the build (growth and relaxation of the
//! aggregates) timed apart. Never a pass/fail test.

use clap::Args;
use sable_engine::run::Simulation;
use serde::Serialize;

/// Arguments of `sable bench bpm`.
#[derive(Debug, Args)]
pub struct BpmBenchArgs {
    /// Number of aggregates (grains of 1.8–2.4 mm, about 300 primaries each).
    #[arg(long, default_value_t = 100)]
    pub grains: usize,
    /// `dem` or `cd`.
    #[arg(long, default_value = "dem")]
    pub method: String,
    /// Steps timed (after the build, which grows and relaxes the aggregates).
    #[arg(long, default_value_t = 2_000)]
    pub steps: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct BpmBenchResult {
    method: String,
    grains: u64,
    primaries: usize,
    threads: usize,
    steps: u64,
    /// Step, s.
    time_step: f64,
    /// Growth and relaxation of the aggregates, s.
    build_seconds: f64,
    wall_seconds: f64,
    /// Primary-steps per second: the method's natural unit.
    primary_steps_per_second: f64,
    /// Grains × simulated time per second of wall time.
    grain_seconds_per_second: f64,
    /// Contact-solver sweeps per step (0 for DEM).
    sweeps_per_step: f64,
    /// The grains' packing fraction at the end.
    grain_phi: f64,
    bytes_per_primary: f64,
}

/// `sable bench bpm`.
pub fn bench_bpm(a: BpmBenchArgs) -> anyhow::Result<()> {
    if !matches!(a.method.as_str(), "dem" | "cd") {
        anyhow::bail!("--method: must be dem or cd, got {:?}", a.method);
    }
    let (scene, threads, pool) =
        super::bench_prepare::prepare(a.threads, |t| sable_engine::scene::presets::bpm_compaction(a.grains, &a.method, a.steps, t))?;
    let start = std::time::Instant::now();
    let mut sim: Box<dyn Simulation> = pool.install(|| scene.build())?;
    let build_seconds = start.elapsed().as_secs_f64();
    let sweeps0 = sim.solver_iterations();
    let start = std::time::Instant::now();
    pool.install(|| {
        for _ in 0..a.steps {
            sim.step()?;
        }
        Ok::<(), sable_engine::EngineError>(())
    })?;
    let wall_seconds = start.elapsed().as_secs_f64();
    let sample = pool.install(|| sim.sample())?;
    let primaries = sim.particle_count();
    let grains = sample.grains.as_ref().map_or(0, |g| g.count);
    let r = BpmBenchResult {
        method: a.method.clone(),
        grains,
        primaries,
        threads,
        steps: a.steps,
        time_step: sim.dt(),
        build_seconds,
        wall_seconds,
        primary_steps_per_second: primaries as f64 * a.steps as f64 / wall_seconds,
        grain_seconds_per_second: grains as f64 * sim.dt() * a.steps as f64 / wall_seconds,
        sweeps_per_step: (sim.solver_iterations() - sweeps0) as f64 / a.steps.max(1) as f64,
        grain_phi: sample.grains.as_ref().map_or(0.0, |g| g.phi),
        bytes_per_primary: sim.memory_bytes() as f64 / primaries.max(1) as f64,
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "bpm by {}: {} grains ({} primaries) on {} thread(s): build {:.1} s, {} steps of {:.3e} s in {:.1} s, {:.3e} primary-steps/s, {:.3e} grain-s/s, {:.1} sweeps per step, grains' Φ {:.4}, {:.0} bytes/primary",
            r.method,
            r.grains,
            r.primaries,
            r.threads,
            r.build_seconds,
            r.steps,
            r.time_step,
            r.wall_seconds,
            r.primary_steps_per_second,
            r.grain_seconds_per_second,
            r.sweeps_per_step,
            r.grain_phi,
            r.bytes_per_primary
        );
    }
    Ok(())
}
