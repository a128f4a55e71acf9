//! `sable bench service`: submission latency and throughput with many concurrent clients, and
//! WatchJob fan-out to many watchers, against a running server or one started in-process on a
//! temporary database. Never a pass/fail test.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use sable_client::{Client, SubmitOptions};
use sable_proto::v1::job_event::Kind;
use sable_server::{ServeConfig, Server};
use serde::Serialize;
use tokio_stream::StreamExt;

/// Arguments of `sable bench service`.
#[derive(Debug, Args)]
pub struct ServiceBenchArgs {
    /// gRPC address of a running server (default: start one in-process, with no workers for the
    /// submission test, on a temporary database).
    #[arg(long)]
    pub server: Option<String>,
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
    clients: usize,
    submissions: usize,
    submit_seconds: f64,
    submissions_per_second: f64,
    submit_latency_ms_p50: f64,
    submit_latency_ms_p99: f64,
    watchers: usize,
    watch_events_per_watcher: usize,
    watch_lag_ms_p50: f64,
    watch_lag_ms_p99: f64,
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
            clients: a.clients,
            submissions: lat.len(),
            submit_seconds,
            submissions_per_second: lat.len() as f64 / submit_seconds,
            submit_latency_ms_p50: percentile(&lat, 50.0),
            submit_latency_ms_p99: percentile(&lat, 99.0),
            watchers: a.watchers,
            watch_events_per_watcher: per,
            watch_lag_ms_p50: percentile(&lags, 50.0),
            watch_lag_ms_p99: percentile(&lags, 99.0),
        };
        if a.json {
            println!("{}", serde_json::to_string(&r)?);
        } else {
            println!(
                "submit: {} clients, {} jobs in {:.2} s = {:.0} jobs/s, latency p50 {:.1} ms, p99 {:.1} ms\n\
                 watch: {} watchers x {} events, lag from commit p50 {:.1} ms, p99 {:.1} ms (includes replay for late joiners)",
                r.clients,
                r.submissions,
                r.submit_seconds,
                r.submissions_per_second,
                r.submit_latency_ms_p50,
                r.submit_latency_ms_p99,
                r.watchers,
                r.watch_events_per_watcher,
                r.watch_lag_ms_p50,
                r.watch_lag_ms_p99
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
        db: sable_server::store::DbLocation::Sqlite(db.to_path_buf()),
        http: "127.0.0.1:0".parse()?,
        grpc: "127.0.0.1:0".parse()?,
        workers,
        limits: sable_server::api::Limits { max_watchers: a.watchers + 8, ..Default::default() },
        ..Default::default()
    };
    let s = Server::start(cfg).await.context("cannot start the in-process server")?;
    Ok((format!("http://{}", s.grpc_addr), Some(s)))
}

fn tempfile_dir() -> anyhow::Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("sable-bench-{}-{}", std::process::id(), rand::random::<u32>()));
    std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
    Ok(d)
}
