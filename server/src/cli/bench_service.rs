//! `sable bench service`: submission latency and throughput with many concurrent clients,
//! lease round trips of many concurrent workers (the queue alone: no physics), the job
//! throughput of 1, 2 and 4 `sable worker` processes on tiny jobs, and WatchJob fan-out to many
//! watchers — against a running server (submissions and fan-out only), or servers started
//! in-process on a temporary SQLite file or on a PostgreSQL database (`--db`). Never a
//! pass/fail test.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use sable_client::{Client, JobState, SubmitOptions};
use sable_proto::v1::job_event::Kind;
use sable_server::{ServeConfig, Server};
use serde::Serialize;
use tokio_stream::StreamExt;

/// Arguments of `sable bench service`.
#[derive(Debug, Args)]
pub struct ServiceBenchArgs {
    /// gRPC address of a running server (default: start one in-process, with no workers for the
    /// submission test, on a temporary database). Only the submissions and the fan-out are
    /// measured on a running server (the lease test would take its users' jobs).
    #[arg(long)]
    pub server: Option<String>,
    /// The in-process servers' database: `sqlite` (a temporary file) or a PostgreSQL URL. Give
    /// a scratch database: the jobs of the bench stay in it.
    #[arg(long, default_value = "sqlite")]
    pub db: String,
    /// Worker-process counts whose job throughput is measured on tiny jobs (0: none).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4")]
    pub worker_processes: Vec<usize>,
    /// Tiny jobs run for each worker-process count.
    #[arg(long, default_value_t = 500)]
    pub worker_jobs: usize,
    /// Concurrent clients submitting.
    #[arg(long, default_value_t = 100)]
    pub clients: usize,
    /// Submissions per client.
    #[arg(long, default_value_t = 10)]
    pub per_client: usize,
    /// Watchers following one job.
    #[arg(long, default_value_t = 100)]
    pub watchers: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct ServiceBench {
    /// `sqlite`, `postgres` or `remote`.
    backend: String,
    clients: usize,
    submissions: usize,
    submit_seconds: f64,
    submissions_per_second: f64,
    submit_latency_ms_p50: f64,
    submit_latency_ms_p99: f64,
    /// Jobs leased, reported on once and finished by `clients` concurrent workers over gRPC.
    leased_jobs: usize,
    lease_seconds: f64,
    /// Lease + report + finish cycles per second (three round trips each).
    lease_cycles_per_second: f64,
    lease_cycle_ms_p50: f64,
    lease_cycle_ms_p99: f64,
    /// Tiny-job throughput by number of `sable worker` processes (one worker, one thread each).
    worker_processes: Vec<WorkerThroughput>,
    watchers: usize,
    watch_events_per_watcher: usize,
    watch_lag_ms_p50: f64,
    watch_lag_ms_p99: f64,
}

#[derive(Debug, Serialize)]
struct WorkerThroughput {
    processes: usize,
    jobs: usize,
    seconds: f64,
    jobs_per_second: f64,
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let k = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[k.min(sorted.len() - 1)]
}

/// A tiny scene: the job itself is not what is measured.
fn tiny_scene(seed: usize, steps: u64) -> String {
    serde_json::json!({
        "name": "bench-service",
        "dimension": 2,
        "method": "dem",
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "m", "count": 20, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "m"},
        "gravity": [0, -9.81],
        "stop": {"steps": steps},
        "sampling": {"every_steps": 10},
        "seed": seed
    })
    .to_string()
}

/// `sable bench service`.
pub fn bench(a: ServiceBenchArgs) -> anyhow::Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    rt.block_on(async move {
        let dir = tempfile_dir()?;
        let backend = match &a.server {
            Some(_) => "remote",
            None => location(&a, &dir.join("bench.db"))?.backend().name(),
        };
        // In-process: submissions against a server without workers, then a second server with
        // one worker for the fan-out.
        let (url, server) = target(&a, &dir.join("bench.db"), 0).await?;
        let client = Client::connect(&url).await?;
        let started = Instant::now();
        let mut tasks = Vec::new();
        for c in 0..a.clients {
            let mut client = client.clone();
            let n = a.per_client;
            tasks.push(tokio::spawn(async move {
                let mut lat = Vec::with_capacity(n);
                for k in 0..n {
                    let t = Instant::now();
                    client.submit(&tiny_scene(c * n + k, 100), SubmitOptions::default()).await?;
                    lat.push(t.elapsed().as_secs_f64() * 1e3);
                }
                Ok::<_, sable_client::ClientError>(lat)
            }));
        }
        let mut lat = Vec::new();
        for t in tasks {
            lat.extend(t.await??);
        }
        let submit_seconds = started.elapsed().as_secs_f64();
        lat.sort_by(f64::total_cmp);

        // The queue alone: as many workers as clients lease, report and finish the jobs just
        // submitted (not on a running server: they are its users' jobs).
        let (leased, lease_seconds, mut cycles) = match &server {
            Some(_) => lease_cycles(&url, a.clients).await?,
            None => (0, 0.0, Vec::new()),
        };
        cycles.sort_by(f64::total_cmp);
        let mut workers = Vec::new();
        if server.is_some() {
            for &n in a.worker_processes.iter().filter(|&&n| n > 0) {
                workers.push(worker_throughput(&url, n, a.worker_jobs).await?);
            }
        }
        if let Some(s) = server {
            s.shutdown(Duration::from_secs(2)).await;
        }

        // Fan-out: one job followed by many watchers; lag = receipt time - event time.
        let (url, server) = target(&a, &dir.join("fanout.db"), 1).await?;
        let mut client = Client::connect(&url).await?;
        let job = client.submit(&tiny_scene(7, 20_000), SubmitOptions::default()).await?;
        let barrier = Arc::new(tokio::sync::Barrier::new(a.watchers));
        let mut tasks = Vec::new();
        for _ in 0..a.watchers {
            let client = client.clone();
            let barrier = barrier.clone();
            tasks.push(tokio::spawn(async move {
                barrier.wait().await;
                let mut lags = Vec::new();
                let mut events = client.watch(job.id, 0);
                while let Some(ev) = events.next().await {
                    let ev = ev?;
                    if matches!(ev.kind, Some(Kind::Heartbeat(_))) {
                        continue;
                    }
                    if let Ok(at) = humantime::parse_rfc3339_weak(&ev.at) {
                        lags.push((std::time::SystemTime::now().duration_since(at).unwrap_or_default()).as_secs_f64() * 1e3);
                    }
                }
                Ok::<_, sable_client::ClientError>(lags)
            }));
        }
        let mut lags = Vec::new();
        let mut per = 0;
        for t in tasks {
            let l = t.await??;
            per = per.max(l.len());
            lags.extend(l);
        }
        lags.sort_by(f64::total_cmp);
        if let Some(s) = server {
            s.shutdown(Duration::from_secs(2)).await;
        }
        let r = ServiceBench {
            backend: backend.to_string(),
            clients: a.clients,
            submissions: lat.len(),
            submit_seconds,
            submissions_per_second: lat.len() as f64 / submit_seconds,
            submit_latency_ms_p50: percentile(&lat, 50.0),
            submit_latency_ms_p99: percentile(&lat, 99.0),
            leased_jobs: leased,
            lease_seconds,
            lease_cycles_per_second: leased as f64 / lease_seconds.max(1e-9),
            lease_cycle_ms_p50: percentile(&cycles, 50.0),
            lease_cycle_ms_p99: percentile(&cycles, 99.0),
            worker_processes: workers,
            watchers: a.watchers,
            watch_events_per_watcher: per,
            watch_lag_ms_p50: percentile(&lags, 50.0),
            watch_lag_ms_p99: percentile(&lags, 99.0),
        };
        if a.json {
            println!("{}", serde_json::to_string(&r)?);
        } else {
            println!(
                "{}\nsubmit: {} clients, {} jobs in {:.2} s = {:.0} jobs/s, latency p50 {:.1} ms, p99 {:.1} ms\n\
                 lease: {} workers, {} lease+report+finish cycles in {:.2} s = {:.0} /s, cycle p50 {:.1} ms, p99 {:.1} ms",
                r.backend,
                r.clients,
                r.submissions,
                r.submit_seconds,
                r.submissions_per_second,
                r.submit_latency_ms_p50,
                r.submit_latency_ms_p99,
                r.clients,
                r.leased_jobs,
                r.lease_seconds,
                r.lease_cycles_per_second,
                r.lease_cycle_ms_p50,
                r.lease_cycle_ms_p99,
            );
            for w in &r.worker_processes {
                println!(
                    "workers: {} process(es), {} tiny jobs in {:.2} s = {:.1} jobs/s",
                    w.processes, w.jobs, w.seconds, w.jobs_per_second
                );
            }
            println!(
                "watch: {} watchers x {} events, lag from commit p50 {:.1} ms, p99 {:.1} ms (includes replay for late joiners)",
                r.watchers, r.watch_events_per_watcher, r.watch_lag_ms_p50, r.watch_lag_ms_p99
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    })
}

/// The server to measure: the one given, or one started in-process on `db` with `workers`
/// local workers and room for every watcher.
async fn target(a: &ServiceBenchArgs, db: &std::path::Path, workers: usize) -> anyhow::Result<(String, Option<Server>)> {
    if let Some(u) = &a.server {
        return Ok((u.clone(), None));
    }
    let cfg = ServeConfig {
        db: location(a, db)?,
        http: "127.0.0.1:0".parse()?,
        grpc: "127.0.0.1:0".parse()?,
        workers,
        limits: sable_server::api::Limits { max_watchers: a.watchers + 8, ..Default::default() },
        ..Default::default()
    };
    let s = Server::start(cfg).await.context("cannot start the in-process server")?;
    Ok((format!("http://{}", s.grpc_addr), Some(s)))
}

/// The in-process servers' database: `--db sqlite` is a file at `sqlite_file`; anything else
/// is read as `sable serve --db` reads it (a PostgreSQL URL), with its error.
fn location(a: &ServiceBenchArgs, sqlite_file: &std::path::Path) -> anyhow::Result<sable_server::store::DbLocation> {
    Ok(match a.db.as_str() {
        "sqlite" => sable_server::store::DbLocation::Sqlite(sqlite_file.to_path_buf()),
        other => other.parse()?,
    })
}

/// `clients` workers leasing over gRPC at once, each job reported on once and finished at once,
/// until the queue is empty: the jobs cycled, the seconds, each cycle's milliseconds.
async fn lease_cycles(url: &str, clients: usize) -> anyhow::Result<(usize, f64, Vec<f64>)> {
    use sable_worker::{JobSource, Outcome, Report};
    let started = Instant::now();
    let mut tasks = tokio::task::JoinSet::new();
    for c in 0..clients {
        let source = sable_worker::remote::RemoteSource::new(url)?;
        tasks.spawn(async move {
            let name = format!("bench-{c}");
            let mut cycles = Vec::new();
            loop {
                let t = Instant::now();
                let Some(lease) = source.lease(&name).await? else { return Ok::<_, anyhow::Error>(cycles) };
                source.report(&lease, &Report { fraction: 0.5, first_sample: Some(0), ..Default::default() }).await?;
                let done =
                    Outcome::Succeeded { steps: 0, wall_seconds: 0.0, cpu_seconds: 0.0, solver_iterations: 0, result: None, state: None };
                source.finish(&lease, done).await?;
                cycles.push(t.elapsed().as_secs_f64() * 1e3);
            }
        });
    }
    let mut all = Vec::new();
    while let Some(r) = tasks.join_next().await {
        all.extend(r??);
    }
    Ok((all.len(), started.elapsed().as_secs_f64(), all))
}

/// Submits `jobs` tiny jobs (100 steps of 20 disks), starts `processes` `sable worker`
/// processes of one worker each, and times them until every job has ended.
async fn worker_throughput(url: &str, processes: usize, jobs: usize) -> anyhow::Result<WorkerThroughput> {
    let mut client = Client::connect(url).await?;
    let mut pending = std::collections::VecDeque::with_capacity(jobs);
    for k in 0..jobs {
        pending.push_back(client.submit(&tiny_scene(k, 100), SubmitOptions::default()).await?.id);
    }
    let exe = std::env::current_exe().context("cannot find the sable binary")?;
    let started = Instant::now();
    let mut children = Vec::new();
    for k in 0..processes {
        let child = std::process::Command::new(&exe)
            .args(["worker", "--workers", "1", "--threads-per-job", "1", "--server", url, "--name", &format!("bench-process-{k}")])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .context("cannot start sable worker");
        match child {
            Ok(c) => children.push(c),
            Err(e) => {
                stop(&mut children);
                return Err(e);
            }
        }
    }
    // Each job in turn (FIFO), until the last has ended.
    let waited = async {
        while let Some(&id) = pending.front() {
            if matches!(client.get(id).await?.state(), JobState::Succeeded | JobState::Failed | JobState::Cancelled) {
                pending.pop_front();
            } else {
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
        }
        Ok::<_, anyhow::Error>(())
    }
    .await;
    let seconds = started.elapsed().as_secs_f64();
    stop(&mut children);
    waited?;
    Ok(WorkerThroughput { processes, jobs, seconds, jobs_per_second: jobs as f64 / seconds })
}

fn stop(children: &mut [std::process::Child]) {
    for c in children {
        let _ = c.kill();
        let _ = c.wait();
    }
}

fn tempfile_dir() -> anyhow::Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("sable-bench-{}-{}", std::process::id(), rand::random::<u32>()));
    std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    Ok(d)
}
