//! The service commands: `sable serve`, `sable worker`, and the client commands `submit`,
//! `show`, `jobs`, `cancel`, `samples` and `state` (over gRPC, through sable-client).

use std::io::{IsTerminal, Write};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use sable_client::{Client, JobState, ListOptions, SubmitOptions, DEFAULT_SERVER};
use sable_engine::observe::Sample;
use sable_proto::v1::job_event::Kind;
use sable_server::{ServeConfig, Server};
use tokio_stream::StreamExt;

pub(crate) fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread().enable_all().build().context("cannot start the async runtime")
}

/// Arguments of `sable serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The job store: an SQLite file (`sqlite:PATH` or a bare path, created if missing), or a
    /// PostgreSQL database shared with other servers (`postgres://USER:PASSWORD@HOST:PORT/DB`).
    #[arg(long, default_value = "sable.db", env = "SABLE_DB")]
    pub db: sable_server::store::DbLocation,
    /// REST address.
    #[arg(long, default_value = "127.0.0.1:8080", env = "SABLE_HTTP")]
    pub http: SocketAddr,
    /// gRPC address.
    #[arg(long, default_value = "127.0.0.1:50051", env = "SABLE_GRPC")]
    pub grpc: SocketAddr,
    /// Local workers (default: the number of cores; 0 = leave the jobs to `sable worker`).
    #[arg(long)]
    pub workers: Option<usize>,
    /// Threads per job (default: cores / workers).
    #[arg(long, default_value_t = 0)]
    pub threads_per_job: usize,
    /// Seconds a lease lasts without a report from its worker.
    #[arg(long, default_value_t = 30.0)]
    pub lease_seconds: f64,
    /// Largest number of particles in one scene.
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_particles)]
    pub max_particles: usize,
    /// Largest `stop.steps` of one scene.
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_steps)]
    pub max_steps: u64,
    /// Largest request body (scene), bytes.
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_body_bytes)]
    pub max_body_bytes: usize,
    /// Largest number of samples one job may store.
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_samples)]
    pub max_samples: u64,
    /// Largest number of bytes one job may store (samples, their events, snapshots).
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_job_bytes)]
    pub max_job_bytes: u64,
    /// Run each job's engine on a thread of this process instead of a process of its own (a
    /// job that aborts its process then takes the others down with it).
    #[arg(long)]
    pub jobs_in_worker: bool,
    /// GiB of memory each job's process may write to (heap and mappings; default:
    /// unbounded); a job that needs more fails with code `crashed`, saying it ran out of
    /// memory, and leaves the machine's memory to the other jobs.
    #[arg(long)]
    pub job_memory: Option<f64>,
    /// Seconds of wall time between two checkpoints of a running job, from which a later
    /// attempt goes on if this one does not finish (0: only when the workers stop).
    #[arg(long, default_value_t = sable_worker::DEFAULT_CHECKPOINT_INTERVAL.as_secs_f64())]
    pub checkpoint_every: f64,
    /// Seconds after which a connection with no byte either way is closed (REST and gRPC,
    /// TLS included; event streams and gRPC send heartbeats well within it).
    #[arg(long, default_value_t = sable_server::idle::DEFAULT_IDLE_TIMEOUT.as_secs_f64())]
    pub idle_timeout: f64,
    /// Largest number of event streams open at once.
    #[arg(long, default_value_t = sable_server::api::Limits::default().max_watchers)]
    pub max_watchers: usize,
    /// File of users' bearer tokens, one per line: the REST API and gRPC Simulations and
    /// Studies then need one (`Authorization: Bearer TOKEN`).
    #[arg(long, env = "SABLE_USER_TOKENS")]
    pub user_tokens: Option<PathBuf>,
    /// File of workers' bearer tokens, one per line: leasing, reporting and finishing jobs
    /// (gRPC Workers) then need one, and a user's token cannot.
    #[arg(long, env = "SABLE_WORKER_TOKENS")]
    pub worker_tokens: Option<PathBuf>,
    /// Serve without tokens on an address other machines can reach (refused otherwise).
    #[arg(long)]
    pub no_auth: bool,
    /// Certificate chain (PEM) to serve REST, the dashboard and gRPC over TLS with; needs
    /// --tls-key. Clients then use https:// addresses.
    #[arg(long, env = "SABLE_TLS_CERT", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// Private key (PEM) of --tls-cert.
    #[arg(long, env = "SABLE_TLS_KEY", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
}

/// Reads the CA certificate file a client or worker trusts besides the system's (`--ca-cert`).
fn read_ca(path: Option<&std::path::Path>) -> anyhow::Result<Option<Vec<u8>>> {
    path.map(|p| std::fs::read(p).with_context(|| format!("--ca-cert: cannot read {}", p.display()))).transpose()
}

/// Waits for SIGINT (Ctrl-C) or SIGTERM.
async fn stop_signal() {
    #[cfg(unix)]
    {
        let mut term = match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(s) => s,
            Err(_) => {
                let _ = tokio::signal::ctrl_c().await;
                return;
            }
        };
        tokio::select! {
            _ = tokio::signal::ctrl_c() => {}
            _ = term.recv() => {}
        }
    }
    #[cfg(not(unix))]
    {
        let _ = tokio::signal::ctrl_c().await;
    }
}

/// `sable serve`.
pub fn serve(a: ServeArgs) -> anyhow::Result<()> {
    if !(a.lease_seconds.is_finite() && a.lease_seconds >= 1.0) {
        bail!("--lease-seconds: must be at least 1, got {}", a.lease_seconds);
    }
    let tokens = sable_server::auth::Tokens::from_files(a.user_tokens.as_deref(), a.worker_tokens.as_deref())?;
    let tls = match (&a.tls_cert, &a.tls_key) {
        (Some(cert), Some(key)) => Some(sable_server::tls::TlsIdentity::from_files(cert, key).map_err(anyhow::Error::msg)?),
        _ => None,
    };
    let exposed = [a.http, a.grpc].iter().any(|addr| !addr.ip().is_loopback());
    if exposed && tls.is_none() && (a.user_tokens.is_some() || a.worker_tokens.is_some()) {
        eprintln!(
            "sable serve: warning: tokens cross the network in clear without TLS; give --tls-cert and --tls-key, \
             or keep a TLS-terminating proxy in front of the server"
        );
    }
    let mut cfg = ServeConfig {
        db: a.db.clone(),
        http: a.http,
        grpc: a.grpc,
        threads_per_job: a.threads_per_job,
        tokens: Arc::new(tokens),
        no_auth: a.no_auth,
        tls,
        ..Default::default()
    };
    if let Some(w) = a.workers {
        cfg.workers = w;
    }
    cfg.lease_ttl = Duration::from_secs_f64(a.lease_seconds);
    if !(a.idle_timeout.is_finite() && a.idle_timeout >= 1.0) {
        bail!("--idle-timeout: must be at least 1 second, got {}", a.idle_timeout);
    }
    cfg.idle_timeout = Duration::from_secs_f64(a.idle_timeout);
    cfg.checkpoint_interval = checkpoint_interval(a.checkpoint_every)?;
    cfg.job_process = job_process(a.jobs_in_worker, a.job_memory)?;
    cfg.limits = sable_server::api::Limits {
        max_particles: a.max_particles,
        max_steps: a.max_steps,
        max_body_bytes: a.max_body_bytes,
        max_watchers: a.max_watchers,
        max_samples: a.max_samples,
        max_job_bytes: a.max_job_bytes,
    };
    runtime()?.block_on(async move {
        let server = Server::start(cfg.clone()).await.with_context(|| format!("cannot start the server on {}", a.db))?;
        let scheme = if cfg.tls.is_some() { "https" } else { "http" };
        eprintln!(
            "sable serve: REST on {scheme}://{}, gRPC on {scheme}://{}, database {}, {} local worker(s); Ctrl-C to stop",
            server.http_addr, server.grpc_addr, a.db, cfg.workers
        );
        stop_signal().await;
        eprintln!("sable serve: stopping (running jobs go back to the queue)");
        server.shutdown(Duration::from_secs(5)).await;
        Ok(())
    })
}

/// Arguments of `sable worker`.
#[derive(Debug, Args)]
pub struct WorkerArgs {
    /// gRPC address of the server to lease jobs from.
    #[arg(long, env = "SABLE_SERVER")]
    pub server: String,
    /// Jobs run at once (default: the number of cores).
    #[arg(long)]
    pub workers: Option<usize>,
    /// Threads per job (default: cores / workers).
    #[arg(long, default_value_t = 0)]
    pub threads_per_job: usize,
    /// Run each job's engine on a thread of this process instead of a process of its own (a
    /// job that aborts its process then takes the others down with it).
    #[arg(long)]
    pub jobs_in_worker: bool,
    /// GiB of memory each job's process may write to (heap and mappings; default:
    /// unbounded); a job that needs more fails with code `crashed`, saying it ran out of
    /// memory, and leaves the machine's memory to the other jobs.
    #[arg(long)]
    pub job_memory: Option<f64>,
    /// Seconds of wall time between two checkpoints of a running job, from which a later
    /// attempt goes on if this one does not finish (0: only when the workers stop).
    #[arg(long, default_value_t = sable_worker::DEFAULT_CHECKPOINT_INTERVAL.as_secs_f64())]
    pub checkpoint_every: f64,
    /// Name of this worker pool, as shown in the job store (default: host name and process id).
    #[arg(long)]
    pub name: Option<String>,
    /// A worker's bearer token, for a server started with --worker-tokens.
    #[arg(long, env = "SABLE_WORKER_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// CA certificate (PEM) to trust besides the system's, for an https:// server with a
    /// certificate of a lab's own CA or a self-signed one.
    #[arg(long, env = "SABLE_CA_CERT")]
    pub ca_cert: Option<PathBuf>,
}

/// `sable worker --server URL`.
/// Where jobs run: in processes of this executable (`sable job-run`), each bounded to
/// `memory_gib` GiB of data if given, unless `in_worker`.
fn job_process(in_worker: bool, memory_gib: Option<f64>) -> anyhow::Result<sable_worker::JobProcess> {
    if let Some(g) = memory_gib {
        if !(g.is_finite() && g >= MIN_JOB_MEMORY_GIB) {
            bail!("--job-memory: must be at least {MIN_JOB_MEMORY_GIB} (GiB of memory per job process), got {g}");
        }
        if in_worker {
            bail!("--job-memory: bounds a job's own process; leave it out with --jobs-in-worker");
        }
    }
    if in_worker {
        return Ok(sable_worker::JobProcess::InWorker);
    }
    let exe =
        std::env::current_exe().context("cannot find this executable to run jobs in processes of their own (or give --jobs-in-worker)")?;
    Ok(sable_worker::JobProcess::Own { exe, memory: memory_gib.map(|g| (g * (1u64 << 30) as f64) as u64) })
}

/// Smallest `--job-memory`, GiB: below it a job's own set-up (its scene, thread stacks, the
/// engine's tables) leaves little room for its particles.
const MIN_JOB_MEMORY_GIB: f64 = 0.25;

/// The interval of `--checkpoint-every SECONDS` (0: none but at the stop).
fn checkpoint_interval(seconds: f64) -> anyhow::Result<Option<Duration>> {
    if !(seconds.is_finite() && seconds >= 0.0) {
        bail!("--checkpoint-every: must be 0 (only when the workers stop) or a number of seconds, got {seconds}");
    }
    Ok((seconds > 0.0).then(|| Duration::from_secs_f64(seconds.max(0.1))))
}

pub fn worker(a: WorkerArgs) -> anyhow::Result<()> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let name = a.name.clone().unwrap_or_else(|| {
        let host = std::fs::read_to_string("/etc/hostname").map(|s| s.trim().to_string()).unwrap_or_else(|_| "worker".into());
        format!("{host}-{}", std::process::id())
    });
    runtime()?.block_on(async move {
        let ca = read_ca(a.ca_cert.as_deref())?;
        let source = sable_worker::remote::RemoteSource::with_access(&a.server, a.token.as_deref(), ca.as_deref())?;
        let mut pc = sable_worker::PoolConfig::new(name.clone(), a.workers.unwrap_or(cores));
        if a.threads_per_job > 0 {
            pc.threads_per_job = a.threads_per_job;
        }
        pc.checkpoint_interval = checkpoint_interval(a.checkpoint_every)?;
        pc.job_process = job_process(a.jobs_in_worker, a.job_memory)?;
        let workers = pc.workers;
        let pool = sable_worker::Pool::start(Arc::new(source), pc, Arc::new(tokio::sync::Notify::new()));
        eprintln!("sable worker {name}: {workers} worker(s) leasing from {}; Ctrl-C to stop", a.server);
        tokio::select! {
            _ = stop_signal() => {}
            _ = pool.stopped() => {}
        }
        if let Some(why) = pool.stats.refused.get().cloned() {
            pool.shutdown(Duration::from_secs(5)).await;
            bail!("the server at {} refuses this worker: {why}", a.server);
        }
        eprintln!("sable worker: stopping (running jobs go back to the queue)");
        pool.shutdown(Duration::from_secs(5)).await;
        Ok(())
    })
}

/// Arguments shared by the client commands.
#[derive(Debug, Args)]
pub struct ServerArg {
    /// gRPC address of the server.
    #[arg(long, default_value = DEFAULT_SERVER, env = "SABLE_SERVER")]
    pub server: String,
    /// A user's bearer token, for a server started with --user-tokens.
    #[arg(long, env = "SABLE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// CA certificate (PEM) to trust besides the system's, for an https:// server with a
    /// certificate of a lab's own CA or a self-signed one.
    #[arg(long, env = "SABLE_CA_CERT")]
    pub ca_cert: Option<PathBuf>,
}

impl ServerArg {
    /// Connects to the server with the token and the CA certificate, if any.
    pub async fn connect(&self) -> anyhow::Result<Client> {
        let ca = read_ca(self.ca_cert.as_deref())?;
        Ok(Client::connect_with_access(&self.server, self.token.as_deref(), ca.as_deref()).await?)
    }
}

/// Arguments of `sable submit`.
#[derive(Debug, Args)]
pub struct SubmitArgs {
    /// Scene file (JSON).
    pub scene: PathBuf,
    #[command(flatten)]
    server: ServerArg,
    /// Job name (default: the scene's).
    #[arg(long)]
    pub name: Option<String>,
    /// Priority (higher runs first).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub priority: i32,
    /// Idempotency key: submitting again with it returns the same job.
    #[arg(long)]
    pub key: Option<String>,
    /// Follow the job to its end with a progress bar; exit non-zero if it does not succeed.
    #[arg(long)]
    pub watch: bool,
    /// Print the job as JSON.
    #[arg(long)]
    pub json: bool,
}

fn state_name(s: JobState) -> &'static str {
    match s {
        JobState::Queued => "queued",
        JobState::Running => "running",
        JobState::Succeeded => "succeeded",
        JobState::Failed => "failed",
        JobState::Cancelled => "cancelled",
        JobState::Unspecified => "unknown",
    }
}

fn job_json(j: &sable_client::Job) -> serde_json::Value {
    serde_json::json!({
        "id": j.id, "name": j.name, "state": state_name(j.state()), "method": j.method, "method_reason": j.method_reason,
        "priority": j.priority, "created_at": j.created_at, "started_at": j.started_at, "finished_at": j.finished_at,
        "attempts": j.attempts, "max_attempts": j.max_attempts, "progress": j.progress,
        "error": if j.error_code.is_empty() { serde_json::Value::Null } else { serde_json::json!({"code": j.error_code, "message": j.error_message}) },
        "scene_hash": j.scene_hash, "engine_version": j.engine_version, "seed": j.seed, "steps": j.steps,
        "wall_seconds": j.wall_seconds, "sample_count": j.sample_count,
        "result": serde_json::from_str::<serde_json::Value>(&j.result_json).unwrap_or(serde_json::Value::Null),
    })
}

fn job_line(j: &sable_client::Job) -> String {
    let err = if j.error_message.is_empty() { String::new() } else { format!("  ({}: {})", j.error_code, j.error_message) };
    format!("{:>6}  {:<9}  {:>5.1}%  {:<4}  {}{}", j.id, state_name(j.state()), 100.0 * j.progress, j.method, j.name, err)
}

/// `sable submit`.
pub fn submit(a: SubmitArgs) -> anyhow::Result<()> {
    // A state file the scene starts from goes with it: the server never reads client paths.
    let (text, _) = super::run::read_scene_text(&a.scene)?;
    runtime()?.block_on(async move {
        let mut client = a.server.connect().await?;
        let opts = SubmitOptions { name: a.name.clone(), priority: a.priority, request_id: a.key.clone(), max_attempts: None };
        let job = client.submit(&text, opts).await.with_context(|| format!("{} was not accepted", a.scene.display()))?;
        if !a.watch {
            if a.json {
                println!("{}", job_json(&job));
            } else {
                println!("job {} queued: {}", job.id, job.name);
            }
            return Ok(());
        }
        eprintln!("job {} queued: {}", job.id, job.name);
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(1000);
            b.set_style(
                indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {percent:>3}% {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
        let mut events = client.watch(job.id, 0);
        while let Some(ev) = events.next().await {
            match ev?.kind {
                Some(Kind::Sample(s)) => {
                    if let (Some(b), Some(x)) = (&bar, &s.sample) {
                        b.set_position((s.fraction * 1000.0) as u64);
                        let ratio = x.mu.map_or_else(|| format!("ζ={:.3}", x.zeta), |mu| format!("μ={mu:.3}"));
                        b.set_message(format!("step {}  Φ={:.4}  Z={:.2}  {ratio}", x.step, x.phi, x.z));
                    }
                }
                Some(Kind::State(s)) => {
                    let msg = format!(
                        "job {}: {}{}",
                        job.id,
                        state_name(s.state()),
                        if s.error_message.is_empty() { String::new() } else { format!(": {}", s.error_message) }
                    );
                    match &bar {
                        Some(b) => b.println(msg),
                        None => eprintln!("{msg}"),
                    }
                }
                _ => {}
            }
        }
        if let Some(b) = &bar {
            b.finish_and_clear();
        }
        let done = client.get(job.id).await?;
        if a.json {
            println!("{}", job_json(&done));
        } else {
            println!("{}", job_line(&done));
        }
        if done.state() != JobState::Succeeded {
            bail!("job {} ended {}", done.id, state_name(done.state()));
        }
        Ok(())
    })
}

/// Arguments of `sable state`.
#[derive(Debug, Args)]
pub struct StateArgs {
    /// Job id (a succeeded job).
    pub id: i64,
    #[command(flatten)]
    server: ServerArg,
    /// Write the state to this file (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `sable state ID`: the final state of a job, which a scene starts from with
/// `"start_from": {"file": FILE}` (or, on the same server, `{"job": ID}`).
pub fn state(a: StateArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        let gz = a.server.connect().await?.final_state_gz(a.id).await?;
        let text = sable_worker::source::gunzip(&gz, sable_server::start_from::MAX_STATE_BYTES)
            .with_context(|| format!("the final state of job {} cannot be read", a.id))?;
        match &a.out {
            Some(path) => std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))?,
            None => println!("{text}"),
        }
        Ok(())
    })
}

/// Arguments of `sable show`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// Job id.
    pub id: i64,
    #[command(flatten)]
    server: ServerArg,
    /// Print the job as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `sable show ID`.
pub fn status(a: StatusArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        let job = a.server.connect().await?.get(a.id).await?;
        if a.json {
            println!("{}", job_json(&job));
        } else {
            println!("{}", job_line(&job));
            // An experiment's derived results, readable.
            if let Ok(result) = serde_json::from_str::<serde_json::Value>(&job.result_json) {
                println!("result: {}", serde_json::to_string_pretty(&result)?);
            }
        }
        Ok(())
    })
}

/// Arguments of `sable cancel`.
#[derive(Debug, Args)]
pub struct CancelArgs {
    /// Job id.
    pub id: i64,
    #[command(flatten)]
    server: ServerArg,
}

/// `sable cancel ID`.
pub fn cancel(a: CancelArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        let job = a.server.connect().await?.cancel(a.id).await?;
        println!("{}", job_line(&job));
        Ok(())
    })
}

/// States accepted by `sable jobs --state`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StateArg {
    /// Waiting for a worker.
    Queued,
    /// Running.
    Running,
    /// Finished.
    Succeeded,
    /// Failed.
    Failed,
    /// Cancelled.
    Cancelled,
}

/// Arguments of `sable jobs`.
#[derive(Debug, Args)]
pub struct ListArgs {
    #[command(flatten)]
    server: ServerArg,
    /// Only jobs in this state.
    #[arg(long, value_enum)]
    pub state: Option<StateArg>,
    /// Only jobs with this name.
    #[arg(long)]
    pub name: Option<String>,
    /// At most this many jobs.
    #[arg(long, default_value_t = 50)]
    pub limit: u32,
    /// One JSON object per line.
    #[arg(long)]
    pub json: bool,
}

/// `sable jobs`.
pub fn list(a: ListArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        let mut client = a.server.connect().await?;
        let state = a.state.map(|s| match s {
            StateArg::Queued => JobState::Queued,
            StateArg::Running => JobState::Running,
            StateArg::Succeeded => JobState::Succeeded,
            StateArg::Failed => JobState::Failed,
            StateArg::Cancelled => JobState::Cancelled,
        });
        let mut left = a.limit;
        let mut token = None;
        while left > 0 {
            let opts = ListOptions { state, name: a.name.clone(), method: None, page_size: left.min(500), page_token: token.take() };
            let (jobs, next) = client.list(opts).await?;
            for j in &jobs {
                if a.json {
                    println!("{}", job_json(j));
                } else {
                    println!("{}", job_line(j));
                }
            }
            left = left.saturating_sub(jobs.len() as u32);
            match next {
                Some(t) => token = Some(t),
                None => break,
            }
        }
        Ok(())
    })
}

/// Arguments of `sable samples`.
#[derive(Debug, Args)]
pub struct SamplesArgs {
    /// Job id.
    pub id: i64,
    #[command(flatten)]
    server: ServerArg,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: super::run::Format,
    /// CSV (the default; same as --format csv).
    #[arg(long, conflicts_with = "format")]
    pub csv: bool,
    /// At most this many samples, evenly spread.
    #[arg(long)]
    pub max_points: Option<u32>,
    /// Write to this file instead of standard output.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `sable samples ID`.
pub fn samples(a: SamplesArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        let mut client = a.server.connect().await?;
        let job = client.get(a.id).await?;
        let dim =
            serde_json::from_str::<serde_json::Value>(&job.scene_json).ok().and_then(|v| v["dimension"].as_u64()).unwrap_or(3) as usize;
        let samples: Vec<Sample> = client.samples(a.id, 0, None, a.max_points).await?;
        let mut out: Box<dyn Write> = match &a.out {
            Some(p) => {
                Box::new(std::io::BufWriter::new(std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?))
            }
            None => Box::new(std::io::BufWriter::new(std::io::stdout())),
        };
        match a.format {
            super::run::Format::Csv => {
                writeln!(out, "{}", Sample::csv_header(dim).join(","))?;
                for s in &samples {
                    writeln!(out, "{}", s.csv_row(dim).join(","))?;
                }
            }
            super::run::Format::Jsonl => {
                for s in &samples {
                    writeln!(out, "{}", serde_json::to_string(s)?)?;
                }
            }
        }
        out.flush()?;
        Ok(())
    })
}
