//! `sable run SCENE.json` and `sable validate SCENE.json`.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use sable_engine::methods::{plan_scene, Plan};
use sable_engine::observe::vtk::SnapshotSeries;
use sable_engine::observe::{Sample, Snapshot};
use sable_engine::run::{Progress, Runner};

/// Output format of the samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Comma-separated values with a header row (walls omitted).
    Csv,
    /// One JSON object per line (every field, walls included).
    Jsonl,
}

/// Arguments of `sable run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    /// Sample format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: Format,
    /// Write samples to this file (default: standard output, unless --final-json or --result-json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the last sample as one JSON object on standard output.
    #[arg(long)]
    pub final_json: bool,
    /// Print the experiment's derived results (peak, steady state, prepared state, warnings) as
    /// one JSON object on standard output (scenes with an `experiment`).
    #[arg(long)]
    pub result_json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Write VTK snapshots for ParaView into this directory (`snapshots.pvd` indexes them):
    /// particles, contact network and walls, at the start, the end and every interval.
    #[arg(long, value_name = "DIR")]
    pub snapshots: Option<PathBuf>,
    /// Snapshot interval in steps (default: the scene's `snapshots.every_steps`, else with every
    /// sample).
    #[arg(long, value_name = "STEPS", requires = "snapshots", value_parser = clap::value_parser!(u64).range(1..))]
    pub snapshot_every: Option<u64>,
    /// Write the final state (particles and box, JSON) to this file: another scene starts from
    /// it with `"start_from": {"file": FILE}`.
    #[arg(long, value_name = "FILE")]
    pub save_state: Option<PathBuf>,
    /// Write a record of every Newton iteration of a soft-grain method (`mpm`, `fem`) to this
    /// file, one JSON object per line: the step, the part's time and duration, the iteration's
    /// correction (relative, as compared with `newton_tolerance`), its contact sweeps and
    /// contacts, and how each part ended (converged, or the failure that split it).
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
}

/// Arguments of `sable validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
}

/// Reads a scene file and replaces `start_from.file` by the state it names (read relative to
/// the scene file); returns the text and the state file read, if any. A document that is not
/// JSON is returned as read, for the scene parser to report.
pub fn read_scene_text(path: &Path) -> anyhow::Result<(String, Option<PathBuf>)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let Ok(mut scene) = serde_json::from_str::<serde_json::Value>(&text) else { return Ok((text, None)) };
    let Some(file) = scene.pointer("/start_from/file").and_then(|f| f.as_str()).map(PathBuf::from) else { return Ok((text, None)) };
    let file = if file.is_relative() { path.parent().unwrap_or(Path::new(".")).join(file) } else { file };
    let state_text = std::fs::read_to_string(&file).with_context(|| format!("start_from.file: cannot read {}", file.display()))?;
    let state: serde_json::Value =
        serde_json::from_str(&state_text).with_context(|| format!("start_from.file: {} is not JSON", file.display()))?;
    if let Some(start) = scene.get_mut("start_from").and_then(|s| s.as_object_mut()) {
        start.remove("file");
        start.insert("state".into(), state);
    }
    Ok((scene.to_string(), Some(file)))
}

/// Reads and validates a scene file; the error lists every violation, one per line.
pub fn load_scene(path: &Path) -> anyhow::Result<Plan> {
    let (text, state_file) = read_scene_text(path)?;
    plan_scene(&text).map_err(|v| {
        // Rules a state file breaks are reported on the field the user wrote.
        let lines: Vec<String> = v
            .iter()
            .map(|x| match (&state_file, sable_server::start_from::on_reference(&x.field, "start_from.file")) {
                (Some(file), Some(field)) => format!("  {field}: {} (in {})", x.rule, file.display()),
                _ => format!("  {x}"),
            })
            .collect();
        anyhow::anyhow!("{} is not a valid scene ({} violation(s)):\n{}", path.display(), v.len(), lines.join("\n"))
    })
}

/// `sable validate`.
pub fn validate(a: ValidateArgs) -> anyhow::Result<()> {
    let s = load_scene(&a.scene)?;
    let n = s.particle_count();
    println!("{}: valid {}D scene '{}', method {} ({}), {n} particles", a.scene.display(), s.dim, s.name, s.method_name(), s.reason);
    Ok(())
}

/// Where samples go.
struct SampleWriter {
    out: Option<Box<dyn Write + Send>>,
    format: Format,
    dim: usize,
    wrote_header: bool,
}

impl SampleWriter {
    fn write(&mut self, s: &Sample) -> anyhow::Result<()> {
        let Some(out) = self.out.as_mut() else { return Ok(()) };
        match self.format {
            Format::Jsonl => {
                serde_json::to_writer(&mut *out, s)?;
                writeln!(out)?;
            }
            Format::Csv => {
                if !self.wrote_header {
                    writeln!(out, "{}", Sample::csv_header(self.dim).join(","))?;
                    self.wrote_header = true;
                }
                writeln!(out, "{}", s.csv_row(self.dim).join(","))?;
            }
        }
        Ok(())
    }
}

/// `sable run`.
pub fn run(a: RunArgs) -> anyhow::Result<()> {
    let scene = load_scene(&a.scene)?;
    let trace = a.trace.as_deref().map(|path| super::trace::TraceFile::create(path, scene.method_name())).transpose()?;
    let out: Option<Box<dyn Write + Send>> = match (&a.out, a.final_json || a.result_json) {
        (Some(p), _) => {
            Some(Box::new(std::io::BufWriter::new(std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?)))
        }
        (None, true) => None,
        (None, false) => Some(Box::new(std::io::BufWriter::new(std::io::stdout()))),
    };
    let mut writer = SampleWriter { out, format: a.format, dim: scene.dim, wrote_header: false };
    let show_bar = !a.quiet && std::io::stderr().is_terminal();
    let bar = show_bar.then(|| {
        let b = indicatif::ProgressBar::new(1000);
        b.set_style(
            indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {percent:>3}% eta {eta} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    // Same threading as a service job: the whole run inside one pool of the scene's threads
    // (all cores by default).
    let mut scene = scene;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = sable_worker::execute::apply_thread_budget(&mut scene, cores);
    let pool = sable_worker::execute::job_pool(threads).map_err(anyhow::Error::msg)?;
    let mut runner = Runner::for_scene(&scene);
    let mut series = match &a.snapshots {
        None => {
            // Without a directory, a scene's snapshots have nowhere to go locally.
            runner.snapshot_every = None;
            None
        }
        Some(dir) => {
            // The flag, else the scene's interval, else with every sample.
            runner.snapshot_every = Some(a.snapshot_every.or(scene.snapshots).unwrap_or(0));
            Some(SnapshotSeries::create(dir)?)
        }
    };
    let mut snapshot_error: Option<anyhow::Error> = None;
    let cancel = runner.cancel.clone();
    let mut on_snapshot = |s: &Snapshot| {
        if let (Some(series), None) = (series.as_mut(), &snapshot_error) {
            if let Err(e) = series.push(s) {
                snapshot_error = Some(e.into());
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
    };
    let mut write_error: Option<anyhow::Error> = None;
    let mut on_sample = |s: &Sample, p: &Progress| {
        if write_error.is_none() {
            if let Err(e) = writer.write(s) {
                write_error = Some(e);
            }
        }
        if let Some(b) = &bar {
            b.set_position((p.fraction * 1000.0) as u64);
            let stage = s.stage.as_deref().map(|n| format!("{n}  ")).unwrap_or_default();
            let ratio = s.mu.map_or_else(|| format!("ζ={:.3}", s.zeta), |mu| format!("μ={mu:.3}"));
            b.set_message(format!("{stage}t={:.3e}s  Φ={:.4}  Z={:.2}  {ratio}", s.time, s.phi, s.z));
        }
    };
    let sink = trace.as_ref().map(|t| t.sink());
    let result = pool.install(|| sable_worker::execute::run_scene_traced(&scene, &runner, &mut on_sample, &mut on_snapshot, sink));
    if let Some(t) = trace {
        t.finish()?;
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if let Some(e) = snapshot_error {
        return Err(e.context("cannot write snapshots"));
    }
    if let Some(e) = write_error {
        return Err(e.context("cannot write samples"));
    }
    if let Some(out) = writer.out.as_mut() {
        out.flush()?;
    }
    let summary = match result {
        Ok((summary, state)) => {
            if let Some(path) = &a.save_state {
                let file = std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
                let mut w = std::io::BufWriter::new(file);
                serde_json::to_writer(&mut w, &state)?;
                w.flush().with_context(|| format!("cannot write {}", path.display()))?;
            }
            summary
        }
        Err(e) => bail!("{e}"),
    };
    if a.final_json {
        println!("{}", serde_json::to_string(&summary.last)?);
    }
    if a.result_json {
        println!("{}", serde_json::to_string(&summary.result)?);
    }
    if !a.quiet {
        eprintln!(
            "finished: {:?} after {} steps, t = {:.6e} s, {:.2} s wall clock",
            summary.reason, summary.steps, summary.time, summary.wall_seconds
        );
        if let Some(r) = &summary.result {
            eprintln!("result: {}", serde_json::to_string_pretty(r)?);
        }
        if let (Some(series), Some(dir)) = (&series, &a.snapshots) {
            eprintln!("{} snapshots in {} (open snapshots.pvd in ParaView)", series.len(), dir.display());
        }
    }
    Ok(())
}
