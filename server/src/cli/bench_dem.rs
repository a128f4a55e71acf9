//! `sable bench dem`: the throughput of soft-contact DEM in particle-steps per second, with
//! memory per particle, on a scene of the suite (`engine/src/methods/dem/bench_suite.rs`: the periodic
//! gas, depositions into walled boxes in 2D and 3D, dense shear, a biaxial test, a polydisperse
//! compression) or a scene file. A scene with a preparation runs it first, untimed (its final
//! state is kept in a cache directory for the next run); then the timed scene runs as a job
//! does, with its sampling. Never a pass/fail test.
//!
//! `--scaling N1,N2,...` runs a suite scene at several counts instead (`super::bench_scaling`).
//!
//! `--lammps-data FILE` writes the timed scene's initial state as a LAMMPS data file, and
//! `FILE.vars`, the LAMMPS variables of the scene (written after the run: a servo wall's mean
//! speed is only known then), for the twin inputs of `benches/peers/`.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use sable_engine::contact::{NormalLaw, PairLaw, TangentialLaw};
use sable_engine::methods::dem::bench_suite::{bench_scene, BenchScene, SUITE};
use sable_engine::methods::dem::Dem;
use sable_engine::methods::dem::DemParams;
use sable_engine::methods::{plan_scene, Plan};
use sable_engine::run::{Runner, Simulation};
use sable_engine::scene::{ElasticLaw, Scene, StateFile};
use serde::Serialize;
use sha2::Digest;

/// Arguments of `sable bench dem`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// The scene: a name of the suite (gas, deposition_3d, shear_3d, deposition_2d, biaxial_2d,
    /// polydisperse_3d) or the path of a scene file (method dem).
    #[arg(long, default_value = "gas")]
    pub scene: String,
    /// Number of particles of a suite scene (default: the scene's; the box scales with it).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Number of timed steps (default: the scene's).
    #[arg(long)]
    pub steps: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Also report the time spent in each stage of the step.
    #[arg(long)]
    pub profile: bool,
    /// Also write the timed scene's initial state as a LAMMPS data file (atom_style sphere), and
    /// its parameters as LAMMPS variables in FILE.vars, for benches/peers/run_lammps.sh.
    #[arg(long)]
    pub lammps_data: Option<PathBuf>,
    /// Where prepared states are kept between runs (default: $TMPDIR/sable-bench).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Also write the final state (a scene may start from it: `start_from.file`).
    #[arg(long)]
    pub save_state: Option<PathBuf>,
    /// Instead of one run, the cost per particle-step against the number of particles: the
    /// suite scene at each of these counts (comma-separated), in `--rounds` alternated rounds.
    #[arg(long, value_delimiter = ',')]
    pub scaling: Vec<usize>,
    /// Rounds of a `--scaling` sweep (each runs every count once, in turn).
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// Chart of a `--scaling` sweep (SVG, or PNG by the extension).
    #[arg(long)]
    pub chart: Option<PathBuf>,
}

/// The state at the end of the timed run, to compare with the LAMMPS twin's.
#[derive(Debug, Serialize)]
pub(super) struct FinalState {
    /// Translational kinetic energy, J (J/m in 2D).
    kinetic_energy: f64,
    /// Rotational kinetic energy, J.
    rotational_energy: f64,
    /// Interacting (touching) particle pairs.
    pair_contacts: usize,
    /// Particle-wall contacts.
    wall_contacts: usize,
    /// Mean coordination (pairs and walls), from the sample.
    z: f64,
    /// Packing fraction of the box.
    phi: f64,
    /// Highest point of a grain along the last axis, m (a deposit's height).
    top: f64,
    /// Mean pressure, Pa.
    p: f64,
}

/// One timed run.
#[derive(Debug, Serialize)]
pub(super) struct BenchResult {
    method: &'static str,
    scene: String,
    pub(super) particles: usize,
    pub(super) steps: u64,
    pub(super) threads: usize,
    /// Parsing the scene, placing the grains, the first neighbour list and forces, s.
    setup_seconds: f64,
    /// The untimed preparation, s (0 when read from the cache or there is none).
    preparation_seconds: f64,
    /// The timed run (steps and samples), s.
    pub(super) wall_seconds: f64,
    pub(super) particle_steps_per_second: f64,
    pub(super) bytes_per_particle: f64,
    samples: usize,
    /// Time spent taking samples, s (with `--profile`).
    sampling_seconds: Option<f64>,
    time_step: f64,
    pub(super) neighbor_pairs: usize,
    pub(super) interacting_pairs: usize,
    neighbor_builds: u64,
    near_pairs: usize,
    near_filters: u64,
    kinetic_energy_start: f64,
    kinetic_energy_end: f64,
    end: FinalState,
}

/// The scene to run: a suite scene, or a scene file (timed as it is).
fn resolve(a: &BenchArgs, particles: Option<usize>, threads: usize) -> anyhow::Result<BenchScene> {
    if let Some(s) = bench_scene(&a.scene, particles, a.steps, threads) {
        return Ok(s);
    }
    let path = Path::new(&a.scene);
    if !path.exists() {
        anyhow::bail!("--scene: {:?} is neither a scene of the suite ({}) nor a file", a.scene, SUITE.join(", "));
    }
    let (text, _) = super::run::read_scene_text(path)?;
    let mut timed: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    if particles.is_some() {
        anyhow::bail!("--particles, --scaling: only for the scenes of the suite; a scene file sets its own counts");
    }
    if let Some(steps) = a.steps {
        timed["stop"] = serde_json::json!({"steps": steps});
    }
    Ok(BenchScene { name: "file", description: path.display().to_string(), preparation: None, timed, skip_stages: 0 })
}

fn parse(v: &serde_json::Value, what: &str) -> anyhow::Result<Plan> {
    plan_scene(&v.to_string()).map_err(|e| anyhow::anyhow!("{what}: {}", sable_engine::scene::format_violations(&e)))
}

/// The final state of the scene's preparation: from the cache if it was run before (the key is
/// a hash of the preparation scene, whose threads do not change the result), else run now and
/// stored. Returns the state and the seconds it took (0 from the cache).
fn prepared_state(prep: &serde_json::Value, name: &str, cache: &Path, pool: &rayon::ThreadPool) -> anyhow::Result<(StateFile, f64)> {
    let mut key = prep.clone();
    key["method"]["threads"] = serde_json::json!(0);
    let digest = sha2::Sha256::digest(key.to_string().as_bytes());
    let hex: String = digest.iter().take(8).map(|b| format!("{b:02x}")).collect();
    let path = cache.join(format!("{name}-{hex}.state.json"));
    if let Ok(text) = std::fs::read_to_string(&path) {
        if let Ok(state) = serde_json::from_str::<StateFile>(&text) {
            eprintln!("bench: preparation of {name} read from {}", path.display());
            return Ok((state, 0.0));
        }
    }
    let scene = parse(prep, "the preparation scene")?;
    let mut runner = Runner::for_scene(&scene);
    // Only the preparation stage: it ends at equilibrium.
    runner.stages.truncate(1);
    eprintln!("bench: preparing {name} ({} particles; the preparation is not timed)", scene.particle_count());
    let start = std::time::Instant::now();
    let state = pool.install(|| {
        let mut sim = scene.build()?;
        runner.run(sim.as_mut(), &mut |_, _| {})?;
        Ok::<_, sable_engine::EngineError>(sim.saved_state())
    })?;
    let seconds = start.elapsed().as_secs_f64();
    std::fs::create_dir_all(cache).with_context(|| format!("cannot create {}", cache.display()))?;
    std::fs::write(&path, serde_json::to_string(&state)?).with_context(|| format!("cannot write {}", path.display()))?;
    eprintln!("bench: prepared in {seconds:.1} s, kept in {}", path.display());
    Ok((state, seconds))
}

/// `sable bench dem` at one count (a `--scaling` sweep is `bench_scaling`'s).
pub fn bench(a: BenchArgs) -> anyhow::Result<()> {
    let r = measure(&a, a.particles)?;
    if a.json {
        println!("{}", serde_json::to_string(&r)?);
    } else {
        println!(
            "dem {}: {} particles x {} steps on {} thread(s): {:.3} s ({:.3} s setup), {:.3e} particle-steps/s, {:.0} bytes/particle \
             ({} samples; {} pairs listed, {} near, {} interacting, {} wall contacts, {} neighbour builds, {} near filterings; \
             kinetic energy {:.4e} -> {:.4e} J)",
            r.scene,
            r.particles,
            r.steps,
            r.threads,
            r.wall_seconds,
            r.setup_seconds,
            r.particle_steps_per_second,
            r.bytes_per_particle,
            r.samples,
            r.neighbor_pairs,
            r.near_pairs,
            r.interacting_pairs,
            r.end.wall_contacts,
            r.neighbor_builds,
            r.near_filters,
            r.kinetic_energy_start,
            r.kinetic_energy_end
        );
    }
    Ok(())
}

/// One timed run of the scene of `a` with `particles` (a suite scene's count), with the files
/// `a` asks for written.
pub(super) fn measure(a: &BenchArgs, particles: Option<usize>) -> anyhow::Result<BenchResult> {
    let budget = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let mut bench_scene = resolve(a, particles, budget)?;
    let pool = sable_worker::execute::job_pool(budget).map_err(anyhow::Error::msg)?;
    let cache = a.cache.clone().unwrap_or_else(|| std::env::temp_dir().join("sable-bench"));
    let mut preparation_seconds = 0.0;
    if let Some(prep) = &bench_scene.preparation {
        let (state, seconds) = prepared_state(prep, bench_scene.name, &cache, &pool)?;
        preparation_seconds = seconds;
        bench_scene.timed["start_from"] = serde_json::json!({"state": state});
    }
    // Setup: what `sable run` does before the first step.
    let setup = std::time::Instant::now();
    let mut scene = parse(&bench_scene.timed, "the benchmark scene")?;
    let threads = sable_worker::execute::apply_thread_budget(&mut scene, budget);
    let Some(params) = scene.params::<DemParams>() else { anyhow::bail!("sable bench dem runs method dem; the scene asks for another") };
    let mut sim = pool.install(|| Dem::new(&scene, params))?;
    let setup_seconds = setup.elapsed().as_secs_f64();
    let mut runner = Runner::for_scene(&scene);
    // An experiment's stages that the preparation already ran.
    runner.stages.drain(..bench_scene.skip_stages.min(runner.stages.len().saturating_sub(1)));
    if let Some(path) = &a.lammps_data {
        // The state the steps start from: with the first stage's controls applied (a shear
        // stage gives the grains their velocity profile); the runner applies them again at the
        // stage's start, which changes nothing more.
        if let Some(stage) = runner.stages.first() {
            pool.install(|| sim.apply_controls(&stage.controls))?;
        }
        write_lammps_data(&sim, path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let walls_before: Vec<(String, f64)> = sim.walls().iter().map(|w| (w.face.name(), w.position)).collect();
    let ke0 = kinetic_energy(&sim).0;
    sim.set_profiling(a.profile);
    let mut samples = 0usize;
    let start = std::time::Instant::now();
    pool.install(|| runner.run(&mut sim, &mut |_, _| samples += 1))?;
    let wall = start.elapsed().as_secs_f64();
    let last = sim.sample()?;
    let (ke1, rotational) = kinetic_energy(&sim);
    let p = sim.particles();
    let axis = scene.dim - 1;
    let top = (0..p.len()).map(|i| p.pos[i][axis] + p.radius[i]).fold(f64::NEG_INFINITY, f64::max);
    let steps = sim.steps_done();
    let r = BenchResult {
        method: "dem",
        scene: bench_scene.name.to_string(),
        particles: sim.particle_count(),
        steps,
        threads,
        setup_seconds,
        preparation_seconds,
        wall_seconds: wall,
        particle_steps_per_second: sim.particle_count() as f64 * steps as f64 / wall,
        bytes_per_particle: sim.memory_bytes() as f64 / sim.particle_count() as f64,
        samples,
        sampling_seconds: sim.stage_times().map(|t| t.sampling),
        time_step: sim.time_step(),
        neighbor_pairs: sim.neighbor_pairs(),
        interacting_pairs: sim.interacting_pairs(),
        neighbor_builds: sim.neighbor_builds(),
        near_pairs: sim.near_pairs(),
        near_filters: sim.near_filters(),
        kinetic_energy_start: ke0,
        kinetic_energy_end: ke1,
        end: FinalState {
            kinetic_energy: ke1,
            rotational_energy: rotational,
            pair_contacts: sim.interacting_pairs(),
            wall_contacts: sim.wall_contact_count(),
            z: last.z,
            phi: last.phi,
            top,
            p: last.p,
        },
    };
    if let Some(path) = &a.save_state {
        std::fs::write(path, serde_json::to_string(&sim.saved_state())?).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(path) = &a.lammps_data {
        let vars = PathBuf::from(format!("{}.vars", path.display()));
        write_lammps_vars(&sim, &scene, &walls_before, steps, &vars).with_context(|| format!("cannot write {}", vars.display()))?;
    }
    if let Some(t) = sim.stage_times() {
        eprintln!(
            "stages (s): integrate {:.3}, boundaries {:.3}, neighbours {:.3}, pair forces {:.3}, walls and gather {:.3}, check {:.3}, sampling {:.3}",
            t.integrate, t.boundaries, t.neighbors, t.pairs, t.forces, t.check, t.sampling
        );
    }
    Ok(r)
}

/// Translational and rotational kinetic energy, J.
fn kinetic_energy(sim: &Dem) -> (f64, f64) {
    let p = sim.particles();
    let translational = (0..p.len()).map(|i| 0.5 * p.mass[i] * p.vel[i].norm_squared()).sum::<f64>();
    let total = (0..p.len()).map(|i| p.kinetic_energy_at(i, &p.vel[i])).sum::<f64>();
    (translational, total - translational)
}

/// Writes the current state as a LAMMPS data file (atom_style sphere: id type diameter density
/// x y z; velocities with angular velocities). The density is the one that gives Sable's mass
/// with LAMMPS's sphere volume (4/3 π r³) in 2D too, where Sable's masses are per metre of
/// thickness. The atom type is the size class: 1 for grains within 1.5 times the smallest
/// diameter, 2 up to 2.25 times, ... (for LAMMPS's `neighbor multi` on polydisperse scenes).
fn write_lammps_data(sim: &Dem, path: &Path) -> anyhow::Result<()> {
    let p = sim.particles();
    let d = sim.domain();
    let rmin = p.radius.iter().copied().fold(f64::INFINITY, f64::min);
    let class = |r: f64| 1 + ((r / rmin).ln() / 1.5f64.ln() + 1e-9).floor().max(0.0) as usize;
    let types = (0..p.len()).map(|i| class(p.radius[i])).max().unwrap_or(1);
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "LAMMPS data file written by sable bench dem\n")?;
    writeln!(f, "{} atoms\n{types} atom types\n", p.len())?;
    for (a, name) in ["x", "y", "z"].iter().enumerate() {
        let (lo, hi) = if a < d.dim { (d.lo[a], d.hi[a]) } else { (-0.5e-3, 0.5e-3) };
        writeln!(f, "{lo:.16e} {hi:.16e} {name}lo {name}hi")?;
    }
    if d.sheared() {
        // A sheared cell is triclinic in LAMMPS, with no tilt at the start.
        writeln!(f, "0 0 0 xy xz yz")?;
    }
    writeln!(f, "\nAtoms # sphere\n")?;
    for i in 0..p.len() {
        let r = p.radius[i];
        let vol = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        writeln!(
            f,
            "{} {} {:.16e} {:.16e} {:.16e} {:.16e} {:.16e}",
            i + 1,
            class(r),
            2.0 * r,
            p.mass[i] / vol,
            p.pos[i].x,
            p.pos[i].y,
            p.pos[i].z
        )?;
    }
    writeln!(f, "\nVelocities\n")?;
    for i in 0..p.len() {
        let (v, w) = (p.vel[i], p.omega[i]);
        writeln!(f, "{} {:.16e} {:.16e} {:.16e} {:.16e} {:.16e} {:.16e}", i + 1, v.x, v.y, v.z, w.x, w.y, w.z)?;
    }
    f.flush()?;
    Ok(())
}

/// LAMMPS's coefficients for a linear law between bodies of effective mass `m_eff`: k_n, k_t,
/// and the dashpots per unit of effective mass (gran/hooke/history multiplies by it):
/// gamma_n = 2 zeta sqrt(k_n / m_eff), gamma_t its tangential share.
fn lammps_law(law: &PairLaw, m_eff: f64) -> anyhow::Result<(f64, f64, f64, f64)> {
    let (NormalLaw::Linear(n), TangentialLaw::Linear { k_t, damping_ratio }) = (law.normal, law.tangential) else {
        anyhow::bail!("the LAMMPS twin needs the linear law (gran/hooke/history)");
    };
    let gamma_n = 2.0 * n.zeta * (n.k_n / m_eff).sqrt();
    Ok((n.k_n, k_t, gamma_n, damping_ratio * gamma_n))
}

/// Writes the scene's parameters as LAMMPS variables for the twin inputs: steps, dt, the
/// contact laws (pairs at the mean particle mass, walls at it too), gravity, the box, each
/// wall's position at the start and mean velocity over the run (`wall_x_max_v`, ...), the cell's
/// strain rates and Lees-Edwards shear rate, and how often Sable sampled.
fn write_lammps_vars(sim: &Dem, scene: &Scene, walls_before: &[(String, f64)], steps: u64, path: &Path) -> anyhow::Result<()> {
    let p = sim.particles();
    let m_mean = p.mass.iter().sum::<f64>() / p.len().max(1) as f64;
    let grain = &scene.materials[p.material.first().copied().unwrap_or(0) as usize];
    let wall_material = scene.container.wall_material.map(|w| &scene.materials[w]).unwrap_or(grain);
    let pair = PairLaw::between(grain, grain);
    let wall = PairLaw::between(grain, wall_material);
    let (kn, kt, gn, gt) = lammps_law(&pair, 0.5 * m_mean)?;
    let (knw, ktw, gnw, gtw) = lammps_law(&wall, m_mean)?;
    if !matches!(grain.law, ElasticLaw::Linear { .. }) {
        anyhow::bail!("the LAMMPS twin needs the linear law");
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "# LAMMPS variables of the Sable scene {:?}, written by sable bench dem", scene.name)?;
    let mut var = |name: &str, value: f64| writeln!(f, "variable {name} equal {value:.16e}");
    var("dim", scene.dim as f64)?;
    var("nsteps", steps as f64)?;
    var("dt", sim.time_step())?;
    var("skin", sim.skin())?;
    var("kn", kn)?;
    var("kt", kt)?;
    var("gamma_n", gn)?;
    var("gamma_t", gt)?;
    var("mu", pair.friction)?;
    var("kn_wall", knw)?;
    var("kt_wall", ktw)?;
    var("gamma_n_wall", gnw)?;
    var("gamma_t_wall", gtw)?;
    var("mu_wall", wall.friction)?;
    var("limit_damping", if pair.limit_damping { 1.0 } else { 0.0 })?;
    let g = scene.gravity;
    var("gravity", g.norm())?;
    for (a, axis) in ["x", "y", "z"].iter().enumerate() {
        var(&format!("gravity_{axis}"), if g.norm() > 0.0 { g[a] / g.norm() } else { 0.0 })?;
    }
    let d = sim.domain();
    let duration = steps as f64 * sim.time_step();
    for (name, x0) in walls_before {
        var(&format!("wall_{name}"), *x0)?;
        let now = sim.walls().iter().find(|w| &w.face.name() == name).map_or(*x0, |w| w.position);
        var(&format!("wall_{name}_v"), if duration > 0.0 { (now - x0) / duration } else { 0.0 })?;
    }
    for a in 0..scene.dim {
        let (lo, hi) = (d.lo[a], d.hi[a]);
        var(&format!("{}lo", ["x", "y", "z"][a]), lo)?;
        var(&format!("{}hi", ["x", "y", "z"][a]), hi)?;
    }
    if let Some(sable_engine::scene::Deformation::StrainRate(rates)) = &scene.container.deformation {
        for (a, axis) in ["x", "y", "z"].iter().enumerate().take(scene.dim) {
            var(&format!("strain_rate_{axis}"), rates[a])?;
        }
    }
    var("shear_rate", d.shear_rate)?;
    if let Some(sable_engine::scene::Deformation::NormalStress { axis, target, .. }) = sim.cell_deformation() {
        var(&format!("normal_stress_{}", ["x", "y", "z"][axis]), target)?;
    }
    let every = match scene.sampling {
        sable_engine::scene::Sampling::Steps(n) => n as f64,
        sable_engine::scene::Sampling::Time(t) => (t / sim.time_step()).round().max(1.0),
    };
    var("thermo_every", every)?;
    f.flush()?;
    Ok(())
}
