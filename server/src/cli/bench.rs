//! `sable bench dem` ([`super::bench_dem`]): throughput of soft-contact DEM on the scenes of the
//! suite, in particle-steps per second, with memory per particle; `sable bench cd`: contact
//! dynamics in contact-iterations per second; `sable bench mpm`: the material point method on
//! the soft-grain compaction in material-point-steps per second; `sable bench fem`: meshed
//! grains on the sources' FEM compaction in element-steps per second; `sable bench bpm`
//! ([`super::bench_bpm`]): aggregates of primaries in primary-steps per second; `sable bench biaxial`: the cost of one quasi-static biaxial test by CD and by DEM
//! at two stiffness numbers, with the ζ each finds. Never a pass/fail test.

use super::bench_prepare::prepare;
use super::trace::TraceFile;
use clap::{Args, Subcommand};
use sable_engine::methods::cd::Cd;
use sable_engine::methods::cd::{CdParams, Sweep};
use sable_engine::methods::fem::FemParams;
use sable_engine::methods::mpm::MpmParams;
use sable_engine::methods::soft::parts::Cost;
use sable_engine::run::Simulation;
use sable_engine::scene::{presets::biaxial_benchmark, presets::cd_benchmark};
use serde::Serialize;

/// What `sable bench` measures.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Soft-contact DEM on a scene of the suite or a scene file (particle-steps per second).
    Dem(super::bench_dem::BenchArgs),
    /// Contact dynamics on a dense pile of rigid spheres (contact-iterations per second).
    Cd(CdBenchArgs),
    /// One quasi-static biaxial test by CD and by DEM (stiffness numbers 1e3 and 1e4): wall time,
    /// steps and the ζ each finds.
    Biaxial(BiaxialBenchArgs),
    /// The service: submission latency and throughput, WatchJob fan-out.
    Service(super::bench_service::ServiceBenchArgs),
    /// The material point method on the sources' soft-grain compaction (material-point-steps
    /// per second, Newton iterations and contact sweeps per step, memory per point).
    Mpm(MpmBenchArgs),
    /// Meshed grains (FEM) on the sources' FEM compaction, Nezamabadi 2020, §2.1.2
    /// (element-steps per second, Newton iterations and contact sweeps per step, memory per node).
    Fem(FemBenchArgs),
    /// The bonded particle method's compaction by DEM or CD, Nezamabadi 2020, §2.1.3
    /// (primary-steps per second, grain-seconds simulated per second, memory per primary).
    Bpm(super::bench_bpm::BpmBenchArgs),
}

/// Runs the chosen benchmark.
pub fn run(c: BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Dem(a) if !a.scaling.is_empty() => super::bench_scaling::sweep(&a),
        BenchCommand::Dem(a) => super::bench_dem::bench(a),
        BenchCommand::Cd(a) => bench_cd(a),
        BenchCommand::Biaxial(a) => bench_biaxial(a),
        BenchCommand::Service(a) => super::bench_service::bench(a),
        BenchCommand::Mpm(a) => bench_mpm(a),
        BenchCommand::Fem(a) => bench_fem(a),
        BenchCommand::Bpm(a) => super::bench_bpm::bench_bpm(a),
    }
}

/// Arguments of `sable bench mpm`.
#[derive(Debug, Args)]
pub struct MpmBenchArgs {
    /// Number of grains (300: the sources' compaction).
    #[arg(long, default_value_t = 300)]
    pub grains: usize,
    /// Packing fraction at which the run stops.
    #[arg(long, default_value_t = 0.95)]
    pub phi: f64,
    /// Largest number of steps (the run stops earlier at `phi`).
    #[arg(long, default_value_t = 1_000_000)]
    pub steps: u64,
    /// Grain friction.
    #[arg(long, default_value_t = 0.0)]
    pub friction: f64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Every this many steps, print the progress to stderr (step, Φ, seconds, the cost of the
    /// steps since the last line): where the time goes as the packing densifies.
    #[arg(long)]
    pub progress: Option<u64>,
    /// Write a record of every Newton iteration to this file, one JSON object per line (as
    /// `sable run --trace`).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<std::path::PathBuf>,
}

#[derive(Debug, Serialize)]
struct MpmBenchResult {
    method: &'static str,
    grains: usize,
    points: usize,
    #[serde(flatten)]
    run: SoftRun,
    /// Material-point-steps per second: the method's natural unit.
    point_steps_per_second: f64,
    bytes_per_point: f64,
}

/// What a soft-grain benchmark run cost, whatever the method.
#[derive(Debug, Serialize)]
struct SoftRun {
    threads: usize,
    steps: u64,
    /// Step parts that failed and were done again as two halves.
    split_steps: u64,
    /// Parts a step was done as, on average (a step is split where the grains are pressed
    /// hard; `System::step` in the engine).
    parts_per_step: f64,
    phi: f64,
    wall_seconds: f64,
    newton_per_step: f64,
    sweeps_per_step: f64,
    /// The failed step parts by their cause (`contact_drift`, `newton_budget`, ...).
    failures: std::collections::BTreeMap<&'static str, u64>,
}

impl std::fmt::Display for SoftRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} thread(s): {} steps ({:.2} parts each, {} failed{}) to Φ = {:.4} in {:.1} s, {:.2} Newton iterations and {:.1} sweeps per step",
            self.threads,
            self.steps,
            self.parts_per_step,
            self.split_steps,
            self.failures.iter().map(|(kind, n)| format!(", {n} {kind}")).collect::<String>(),
            self.phi,
            self.wall_seconds,
            self.newton_per_step,
            self.sweeps_per_step
        )
    }
}

/// `sable bench mpm`: the compaction of [`sable_engine::scene::presets::mpm_compaction`] from
/// its start until `phi` (or `steps`), timed as a whole (building the grains excluded).
pub fn bench_mpm(a: MpmBenchArgs) -> anyhow::Result<()> {
    let (scene, threads, pool) =
        prepare(a.threads, |t| sable_engine::scene::presets::mpm_compaction(a.grains, a.friction, a.phi, a.steps, t))?;
    let Some(params) = scene.params::<MpmParams>() else { anyhow::bail!("the MPM benchmark scene must use method mpm") };
    let mut sim = pool.install(|| sable_engine::methods::mpm::sim::mpm(&scene, params))?;
    let trace = traced(&mut sim, a.trace.as_deref(), scene.method_name())?;
    let run = drive_soft(&mut sim, &pool, threads, a.steps, a.phi, a.progress, |s| s.cost());
    if let Some(t) = trace {
        t.finish()?;
    }
    let run = run?;
    let r = MpmBenchResult {
        method: "mpm",
        grains: sim.particle_count(),
        points: sim.point_count(),
        point_steps_per_second: sim.point_count() as f64 * run.steps as f64 / run.wall_seconds,
        bytes_per_point: sim.memory_bytes() as f64 / sim.point_count().max(1) as f64,
        run,
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "mpm: {} grains ({} points) on {}, {:.3e} point-steps/s, {:.0} bytes/point",
            r.grains, r.points, r.run, r.point_steps_per_second, r.bytes_per_point
        );
    }
    Ok(())
}

/// The trace file of `--trace`, if given, its sink set on `sim`.
fn traced(sim: &mut impl Simulation, path: Option<&std::path::Path>, method: &str) -> anyhow::Result<Option<TraceFile>> {
    let Some(path) = path else { return Ok(None) };
    let t = TraceFile::create(path, method)?;
    sim.trace_newton(t.sink());
    Ok(Some(t))
}

/// Steps a soft-grain simulation until `phi` or `steps` inside `pool` (of `threads`), printing
/// every `progress` steps to stderr where the time goes (`cost`: what the steps cost since the
/// start); returns what the run cost.
fn drive_soft<S: Simulation>(
    sim: &mut S,
    pool: &rayon::ThreadPool,
    threads: usize,
    max_steps: u64,
    phi: f64,
    progress: Option<u64>,
    cost: impl Fn(&S) -> Cost + Sync,
) -> anyhow::Result<SoftRun> {
    let start = std::time::Instant::now();
    let mut steps = 0u64;
    pool.install(|| {
        let mut last = (0.0, Cost::default(), 0);
        while steps < max_steps && sim.packing_fraction() < phi {
            sim.step()?;
            steps += 1;
            if progress.is_some_and(|every| every > 0 && steps.is_multiple_of(every)) {
                let t = start.elapsed().as_secs_f64();
                let c = cost(sim);
                let k = (steps - last.2).max(1) as f64;
                let causes: Vec<String> = c
                    .failures
                    .iter()
                    .filter_map(|(kind, n)| {
                        let new = n - last.1.failures.get(kind).copied().unwrap_or(0);
                        (new > 0).then(|| format!("{new} {kind}"))
                    })
                    .collect();
                eprintln!(
                    "step {steps}: Φ {:.4}, {t:.1} s ({:.1} ms/step), {:.2} parts, {:.2} Newton and {:.0} sweeps per step, {} failed parts{}",
                    sim.packing_fraction(),
                    1e3 * (t - last.0) / k,
                    (c.parts - last.1.parts) as f64 / k,
                    (c.newton - last.1.newton) as f64 / k,
                    (c.sweeps - last.1.sweeps) as f64 / k,
                    c.failed - last.1.failed,
                    if causes.is_empty() { String::new() } else { format!(" ({})", causes.join(", ")) }
                );
                last = (t, c, steps);
            }
        }
        Ok::<(), sable_engine::EngineError>(())
    })?;
    let wall_seconds = start.elapsed().as_secs_f64();
    let c = cost(sim);
    let n = steps.max(1) as f64;
    Ok(SoftRun {
        threads,
        steps,
        split_steps: c.failed,
        parts_per_step: c.parts as f64 / n,
        phi: sim.packing_fraction(),
        wall_seconds,
        newton_per_step: c.newton as f64 / n,
        sweeps_per_step: c.sweeps as f64 / n,
        failures: c.failures,
    })
}

/// Arguments of `sable bench fem`.
#[derive(Debug, Args)]
pub struct FemBenchArgs {
    /// Number of grains (400: the sources' FEM compaction).
    #[arg(long, default_value_t = 400)]
    pub grains: usize,
    /// Packing fraction at which the run stops (0.93: the sources' largest).
    #[arg(long, default_value_t = 0.93)]
    pub phi: f64,
    /// Largest number of steps (the run stops earlier at `phi`).
    #[arg(long, default_value_t = 1_000_000)]
    pub steps: u64,
    /// Grain friction (the sources: 0 to 0.8).
    #[arg(long, default_value_t = 0.0)]
    pub friction: f64,
    /// Boundary elements across the smallest grain (the method's `elements_per_diameter`).
    #[arg(long, default_value_t = 8.0)]
    pub elements_per_diameter: f64,
    /// Time step, s (the method's `time_step`).
    #[arg(long, default_value_t = sable_engine::scene::presets::FEM_COMPACTION_STEP)]
    pub time_step: f64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Every this many steps, print the progress to stderr (as `sable bench mpm --progress`).
    #[arg(long)]
    pub progress: Option<u64>,
    /// Write a record of every Newton iteration to this file (as `sable bench mpm --trace`).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<std::path::PathBuf>,
}

#[derive(Debug, Serialize)]
struct FemBenchResult {
    method: &'static str,
    grains: usize,
    elements: usize,
    nodes: usize,
    #[serde(flatten)]
    run: SoftRun,
    /// Element-steps per second: the method's natural unit.
    element_steps_per_second: f64,
    bytes_per_node: f64,
}

/// `sable bench fem`: the compaction of [`sable_engine::scene::presets::fem_compaction`] from its
/// start until `phi` (or `steps`), timed as a whole (meshing the grains excluded).
pub fn bench_fem(a: FemBenchArgs) -> anyhow::Result<()> {
    let (scene, threads, pool) = prepare(a.threads, |t| {
        sable_engine::scene::presets::fem_compaction(a.grains, a.friction, a.phi, a.steps, a.elements_per_diameter, a.time_step, t)
    })?;
    let Some(params) = scene.params::<FemParams>() else { anyhow::bail!("the FEM benchmark scene must use method fem") };
    let mut sim = pool.install(|| sable_engine::methods::fem::sim::fem(&scene, params))?;
    let trace = traced(&mut sim, a.trace.as_deref(), scene.method_name())?;
    let run = drive_soft(&mut sim, &pool, threads, a.steps, a.phi, a.progress, |s| s.cost());
    if let Some(t) = trace {
        t.finish()?;
    }
    let run = run?;
    let r = FemBenchResult {
        method: "fem",
        grains: sim.particle_count(),
        elements: sim.element_count(),
        nodes: sim.node_count(),
        element_steps_per_second: sim.element_count() as f64 * run.steps as f64 / run.wall_seconds,
        bytes_per_node: sim.memory_bytes() as f64 / sim.node_count().max(1) as f64,
        run,
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "fem: {} grains ({} elements, {} nodes) on {}, {:.3e} element-steps/s, {:.0} bytes/node",
            r.grains, r.elements, r.nodes, r.run, r.element_steps_per_second, r.bytes_per_node
        );
    }
    Ok(())
}

/// Arguments of `sable bench cd`.
#[derive(Debug, Args)]
pub struct CdBenchArgs {
    /// Number of spheres.
    #[arg(long, default_value_t = 20_000)]
    pub particles: usize,
    /// Steps timed (after `warmup` steps that let the pile form).
    #[arg(long, default_value_t = 50)]
    pub steps: u64,
    /// Steps run before timing.
    #[arg(long, default_value_t = 20)]
    pub warmup: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Order of the NLGS sweep: `auto`, `serial` or `coloured` (the scene's `method.sweep`).
    #[arg(long, default_value = "auto")]
    pub sweep: String,
    /// Largest momentum factor of the accelerated sweep (the scene's `method.acceleration`; 0:
    /// plain Gauss-Seidel). Default: the method's.
    #[arg(long)]
    pub acceleration: Option<f64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct CdBenchResult {
    method: &'static str,
    sweep: Sweep,
    acceleration: f64,
    particles: usize,
    steps: u64,
    threads: usize,
    wall_seconds: f64,
    /// Contacts solved per step, mean over the timed steps.
    contacts_per_step: f64,
    /// NLGS sweeps per step, mean over the timed steps.
    iterations_per_step: f64,
    /// Local solves (contacts × sweeps) per second: the method's natural unit.
    contact_iterations_per_second: f64,
    particle_steps_per_second: f64,
    bytes_per_particle: f64,
}

/// `sable bench cd`: the dense pile of [`cd_benchmark`], `warmup` steps untimed, then `steps`
/// timed; the solver's sweeps and contacts are summed step by step.
pub fn bench_cd(a: CdBenchArgs) -> anyhow::Result<()> {
    let sweep: Sweep = serde_json::from_value(serde_json::Value::String(a.sweep.clone()))
        .map_err(|_| anyhow::anyhow!("--sweep: must be auto, serial or coloured, got {:?}", a.sweep))?;
    // `--acceleration` goes into the scene, whose validation states its rule.
    let (mut scene, threads, pool) = prepare(a.threads, |t| {
        let mut scene = cd_benchmark(a.particles, a.steps, t);
        if let Some(beta) = a.acceleration {
            scene["method"]["acceleration"] = serde_json::json!(beta);
        }
        scene
    })?;
    let Some(params) = scene.params_mut::<CdParams>() else { anyhow::bail!("the CD benchmark scene must use method cd") };
    params.sweep = sweep;
    let acceleration = params.acceleration;
    let Some(params) = scene.params::<CdParams>() else { anyhow::bail!("the CD benchmark scene must use method cd") };
    let mut sim = pool.install(|| Cd::new(&scene, params))?;
    pool.install(|| (0..a.warmup).try_for_each(|_| sim.step()))?;
    let (mut contacts, mut iterations, mut work) = (0u64, 0u64, 0u64);
    let start = std::time::Instant::now();
    pool.install(|| {
        (0..a.steps).try_for_each(|_| {
            sim.step()?;
            let r = sim.solver_report();
            contacts += r.contacts as u64;
            iterations += u64::from(r.iterations);
            work += r.contacts as u64 * u64::from(r.iterations);
            Ok::<(), sable_engine::EngineError>(())
        })
    })?;
    let wall = start.elapsed().as_secs_f64();
    let steps = a.steps.max(1) as f64;
    let r = CdBenchResult {
        method: "cd",
        sweep,
        acceleration,
        particles: sim.particle_count(),
        steps: a.steps,
        threads,
        wall_seconds: wall,
        contacts_per_step: contacts as f64 / steps,
        iterations_per_step: iterations as f64 / steps,
        contact_iterations_per_second: work as f64 / wall,
        particle_steps_per_second: sim.particle_count() as f64 * a.steps as f64 / wall,
        bytes_per_particle: sim.memory_bytes() as f64 / sim.particle_count() as f64,
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "cd (acceleration {}): {} spheres x {} steps on {} thread(s): {:.3} s, {:.3e} contact-iterations/s ({:.0} contacts and {:.1} sweeps per step), \
             {:.3e} particle-steps/s, {:.0} bytes/particle",
            r.acceleration,
            r.particles,
            r.steps,
            r.threads,
            r.wall_seconds,
            r.contact_iterations_per_second,
            r.contacts_per_step,
            r.iterations_per_step,
            r.particle_steps_per_second,
            r.bytes_per_particle
        );
    }
    Ok(())
}

/// Arguments of `sable bench biaxial`.
#[derive(Debug, Args)]
pub struct BiaxialBenchArgs {
    /// Number of disks.
    #[arg(long, default_value_t = 400)]
    pub particles: usize,
    /// Axial strain of the loading.
    #[arg(long, default_value_t = 0.10)]
    pub strain: f64,
    /// Slop of contact dynamics (`method.slop`).
    #[arg(long, default_value_t = 0.02)]
    pub slop: f64,
    /// Packings to run each case from (the preset's seed and the next ones). One packing of 400
    /// disks moves the peak ζ by up to 0.07 from seed to seed, with either method: compare
    /// methods on the mean over three or more.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..=100))]
    pub packings: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// One case of `sable bench biaxial`: wall time and steps summed over the packings, the rest
/// their means.
#[derive(Debug, Default, Serialize)]
struct BiaxialCase {
    method: &'static str,
    /// Stiffness number k_n / p (DEM only).
    stiffness_number: Option<f64>,
    wall_seconds: f64,
    steps: u64,
    /// Steps of the preparation (the rest is the loading).
    preparation_steps: u64,
    peak_zeta: f64,
    steady_zeta: f64,
    steady_zeta_std: f64,
    steady_phi: f64,
    steady_z_no_rattlers: f64,
}

#[derive(Debug, Serialize)]
struct BiaxialBenchResult {
    particles: usize,
    axial_strain: f64,
    packings: u64,
    cases: Vec<BiaxialCase>,
    /// Wall time of DEM at stiffness number 1e4 (the rigid limit: CD's accuracy) over CD's.
    speedup_over_dem_1e4: f64,
    /// Relative differences of CD's peak and steady ζ from DEM's at 1e4.
    peak_zeta_difference: f64,
    steady_zeta_difference: f64,
}

/// `sable bench biaxial`: the biaxial test of [`biaxial_benchmark`] by CD (at `slop`) and by DEM
/// at stiffness numbers 1e3 and 1e4, each on one thread (in its own pool, as a job runs), one
/// after the other, each from `packings` packings.
pub fn bench_biaxial(a: BiaxialBenchArgs) -> anyhow::Result<()> {
    let cases: [(&'static str, serde_json::Value, f64, Option<f64>); 3] = [
        ("cd", serde_json::json!({"kind": "cd", "threads": 1, "slop": a.slop}), 1e5, None),
        ("dem", serde_json::json!({"kind": "dem", "threads": 1}), 1e5, Some(1e3)),
        ("dem", serde_json::json!({"kind": "dem", "threads": 1}), 1e6, Some(1e4)),
    ];
    let mut out = Vec::new();
    for (method, section, k_n, kappa) in cases {
        let mut case = BiaxialCase { method, stiffness_number: kappa, ..BiaxialCase::default() };
        let share = 1.0 / a.packings as f64;
        for packing in 0..a.packings {
            // As a job runs: the whole run inside a pool of the scene's one thread.
            let (scene, _, pool) = prepare(Some(1), |_| {
                let mut s = biaxial_benchmark(section.clone(), k_n, a.particles, a.strain);
                s["seed"] = serde_json::json!(s["seed"].as_u64().unwrap_or(0) + packing);
                s
            })?;
            let runner = sable_engine::run::Runner::for_scene(&scene);
            let summary = pool.install(|| {
                let mut sim = scene.build()?;
                runner.run(sim.as_mut(), &mut |_, _| {})
            })?;
            let r = summary.result.ok_or_else(|| anyhow::anyhow!("{method}: the biaxial test gave no result"))?;
            let (peak, steady, prepared) = match (r.peak, r.steady, r.prepared) {
                (Some(p), Some(s), Some(q)) => (p, s, q),
                _ => anyhow::bail!("{method}: the biaxial test gave no peak, steady state or prepared state"),
            };
            case.wall_seconds += summary.wall_seconds;
            case.steps += summary.steps;
            case.preparation_steps += prepared.step;
            case.peak_zeta += share * peak.zeta;
            case.steady_zeta += share * steady.zeta;
            case.steady_zeta_std += share * steady.zeta_std;
            case.steady_phi += share * steady.phi;
            case.steady_z_no_rattlers += share * steady.z_no_rattlers;
        }
        out.push(case);
    }
    let rel = |a: f64, b: f64| (a - b) / b;
    let (cd, rigid) = (&out[0], &out[2]);
    let r = BiaxialBenchResult {
        particles: a.particles,
        axial_strain: a.strain,
        packings: a.packings,
        speedup_over_dem_1e4: rigid.wall_seconds / cd.wall_seconds,
        peak_zeta_difference: rel(cd.peak_zeta, rigid.peak_zeta),
        steady_zeta_difference: rel(cd.steady_zeta, rigid.steady_zeta),
        cases: out,
    };
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        if a.packings > 1 {
            println!("{} packings each: wall time and steps summed, the rest averaged", a.packings);
        }
        for c in &r.cases {
            let kappa = c.stiffness_number.map_or(String::new(), |k| format!(" (kappa {k:.0e})"));
            println!(
                "{}{kappa}: {:.1} s, {} steps ({} preparing); peak zeta {:.3}, steady zeta {:.3} +- {:.3}, phi {:.4}, Z {:.2}",
                c.method,
                c.wall_seconds,
                c.steps,
                c.preparation_steps,
                c.peak_zeta,
                c.steady_zeta,
                c.steady_zeta_std,
                c.steady_phi,
                c.steady_z_no_rattlers
            );
        }
        println!(
            "cd is {:.1}x faster than dem at kappa 1e4; peak zeta {:+.1}%, steady zeta {:+.1}%",
            r.speedup_over_dem_1e4,
            100.0 * r.peak_zeta_difference,
            100.0 * r.steady_zeta_difference
        );
    }
    Ok(())
}
