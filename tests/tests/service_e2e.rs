//! End-to-end tests of the service: a server started in-process on free ports with a temporary
//! database, driven over HTTP and gRPC as users and remote workers would. The suite runs on each
//! back-end: `sqlite::` on a temporary file (the default back-end), `postgres::` each server on
//! a fresh database of the throw-away test cluster (server/tests/common/postgres.rs; without
//! PostgreSQL binaries on the machine those tests skip with a message, and fail under
//! `SABLE_REQUIRE_POSTGRES=1`, as in CI). Each test takes the back-end it runs on;
//! `on_both_backends!` at the end makes it a test on each (one left out of that list is dead
//! code, which the lint refuses). One binary and one copy of the suite for both: as two
//! binaries, each with its own copy, they took 118 s of build and 48 s of tests, as one 109 s
//! and 43 s (2026-12-03, `cargo test --no-run --timings`, units' times beside others on two
//! cores).

mod common;

use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::{Duration, Instant};

use sable_proto::v1 as pb;
use sable_proto::v1::simulations_client::SimulationsClient;
use sable_server::store::{Backend, DbLocation};
use sable_server::{ServeConfig, Server};
use serde_json::{json, Value};
use tonic::transport::Channel;

/// A small 2D scene: `steps` steps of a few disks settling, a sample every 100 steps.
fn scene(steps: u64, seed: u64) -> Value {
    json!({
        "name": "settle",
        "dimension": 2,
        "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 30, "size": {"kind": "monodisperse", "diameter": 1e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "gravity": [0, -9.81],
        "stop": {"steps": steps},
        "sampling": {"every_steps": 100},
        "seed": seed
    })
}

struct Harness {
    backend: Backend,
    server: Option<Server>,
    dir: tempfile::TempDir,
    db: DbLocation,
    http: reqwest::Client,
    base: String,
}

/// The database of the server started in `dir`: for SQLite a file in it; for PostgreSQL a
/// fresh database, whose URL is kept in `dir` so that a server started again there finds it.
/// None when this suite needs PostgreSQL and the machine has none (the tests skip).
async fn location(backend: Backend, dir: &tempfile::TempDir) -> Option<DbLocation> {
    match backend {
        Backend::Sqlite => Some(DbLocation::Sqlite(dir.path().join("sable.db"))),
        Backend::Postgres => {
            let kept = dir.path().join("postgres-url");
            if let Ok(url) = std::fs::read_to_string(&kept) {
                return Some(DbLocation::Postgres(url));
            }
            let url = common::postgres::fresh_database(common::postgres::server()?).await;
            std::fs::write(&kept, &url).expect("keep the database URL");
            Some(DbLocation::Postgres(url))
        }
    }
}

fn config(db: DbLocation, workers: usize) -> ServeConfig {
    ServeConfig {
        db,
        http: "127.0.0.1:0".parse().expect("addr"),
        grpc: "127.0.0.1:0".parse().expect("addr"),
        workers,
        threads_per_job: 1,
        lease_ttl: Duration::from_secs(2),
        report_interval: Duration::from_millis(100),
        heartbeat: Duration::from_millis(500),
        limits: sable_server::api::Limits {
            max_particles: 10_000,
            max_steps: 2_000_000_000,
            max_body_bytes: 64 * 1024,
            max_watchers: 2,
            max_samples: 20_000_000,
            max_job_bytes: 1 << 30,
        },
        ..Default::default()
    }
}

impl Harness {
    /// A server with `workers` local workers on a fresh database; None when the suite's
    /// back-end is not available (the test then skips).
    async fn start(backend: Backend, workers: usize) -> Option<Self> {
        let dir = tempfile::tempdir().expect("temp dir");
        Self::start_in(backend, dir, workers).await
    }

    /// A server on the database of `dir` (a restart when a server ran there before).
    async fn start_in(backend: Backend, dir: tempfile::TempDir, workers: usize) -> Option<Self> {
        let db = location(backend, &dir).await?;
        let server = Server::start(config(db.clone(), workers)).await.expect("server starts");
        let base = format!("http://{}", server.http_addr);
        Some(Self { backend, server: Some(server), dir, db, http: reqwest::Client::new(), base })
    }

    /// A connection pool on the server's database, as any SQL tool would open it.
    async fn db_pool(&self) -> sqlx::AnyPool {
        sqlx::any::install_default_drivers();
        let url = match &self.db {
            DbLocation::Sqlite(path) => format!("sqlite://{}?mode=ro", path.display()),
            DbLocation::Postgres(url) => url.clone(),
        };
        sqlx::AnyPool::connect(&url).await.expect("open the database")
    }

    /// An SQL expression reading the number at `path` (e.g. `grains.phi`) of a sample's JSON.
    fn sample_field(&self, path: &str) -> String {
        match self.backend {
            Backend::Sqlite => format!("json_extract(data, '$.{path}')"),
            Backend::Postgres => format!("CAST(CAST(data AS JSON) #>> '{{{}}}' AS DOUBLE PRECISION)", path.replace('.', ",")),
        }
    }

    fn server(&self) -> &Server {
        self.server.as_ref().expect("running")
    }

    async fn grpc(&self) -> SimulationsClient<Channel> {
        SimulationsClient::connect(format!("http://{}", self.server().grpc_addr)).await.expect("gRPC connects")
    }

    async fn post(&self, path: &str, body: &Value, key: Option<&str>) -> (u16, Value) {
        let mut r = self.http.post(format!("{}{path}", self.base)).json(body);
        if let Some(k) = key {
            r = r.header("Idempotency-Key", k);
        }
        let resp = r.send().await.expect("HTTP answers");
        let status = resp.status().as_u16();
        (status, resp.json().await.unwrap_or(Value::Null))
    }

    async fn get(&self, path: &str) -> (u16, Value) {
        let resp = self.http.get(format!("{}{path}", self.base)).send().await.expect("HTTP answers");
        let status = resp.status().as_u16();
        (status, resp.json().await.unwrap_or(Value::Null))
    }

    async fn wait_state(&self, id: i64, states: &[&str], timeout: Duration) -> Value {
        let start = Instant::now();
        loop {
            let (_, job) = self.get(&format!("/v1/jobs/{id}")).await;
            if states.contains(&job["state"].as_str().unwrap_or_default()) {
                return job;
            }
            assert!(start.elapsed() < timeout, "job {id} did not reach {states:?} in {timeout:?}: {job}");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    async fn jobs_in_db(&self) -> i64 {
        let pool = self.db_pool().await;
        let n: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM jobs").fetch_one(&pool).await.expect("count");
        pool.close().await;
        n
    }
}

async fn watch_all(client: &mut SimulationsClient<Channel>, id: i64, after: u64) -> Vec<pb::JobEvent> {
    let mut stream = client.watch_job(pb::WatchJobRequest { id, after_seq: after }).await.expect("watch starts").into_inner();
    let mut out = Vec::new();
    while let Some(ev) =
        tokio::time::timeout(Duration::from_secs(60), stream.message()).await.expect("events keep coming").expect("stream ok")
    {
        out.push(ev);
    }
    out
}

async fn submit_over_http_watch_over_grpc_and_read_samples(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (status, job) = h.post("/v1/jobs", &json!({"scene": scene(1000, 1), "name": "first", "priority": 2}), None).await;
    assert_eq!(status, 201, "{job}");
    assert_eq!(job["state"], "queued");
    assert_eq!(job["name"], "first");
    assert_eq!(job["method"], "dem");
    let id = job["id"].as_i64().expect("id");

    let mut client = h.grpc().await;
    let events = watch_all(&mut client, id, 0).await;
    let seqs: Vec<u64> = events.iter().map(|e| e.seq).collect();
    assert_eq!(seqs, (1..=seqs.len() as u64).collect::<Vec<_>>(), "numbered without gaps");
    let states: Vec<i32> = events
        .iter()
        .filter_map(|e| match &e.kind {
            Some(pb::job_event::Kind::State(s)) => Some(s.state),
            _ => None,
        })
        .collect();
    assert_eq!(states, vec![pb::JobState::Queued as i32, pb::JobState::Running as i32, pb::JobState::Succeeded as i32]);
    let sample_events: Vec<&pb::SampleEvent> = events
        .iter()
        .filter_map(|e| match &e.kind {
            Some(pb::job_event::Kind::Sample(s)) => Some(s),
            _ => None,
        })
        .collect();
    // Samples at steps 0, 100, ..., 1000.
    assert_eq!(sample_events.len(), 11);
    assert_eq!(sample_events.last().and_then(|s| s.sample.as_ref()).map(|s| s.step), Some(1000));
    assert!((sample_events.last().map_or(0.0, |s| s.fraction) - 1.0).abs() < 1e-12);

    let (status, body) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    assert_eq!(status, 200);
    let samples = body["samples"].as_array().expect("samples");
    assert_eq!(samples.len(), 11);
    for key in ["step", "time", "phi", "z", "z_no_rattlers", "zeta", "p", "q", "stress", "kinetic_energy", "elastic_energy", "walls"] {
        assert!(samples[0].get(key).is_some(), "sample has {key}");
    }
    let (_, down) = h.get(&format!("/v1/jobs/{id}/samples?max_points=3&from_step=100")).await;
    let steps: Vec<u64> = down["samples"].as_array().expect("samples").iter().map(|s| s["step"].as_u64().unwrap_or(0)).collect();
    // 10 samples from step 100 kept at indices round(k 9 / 2), halves rounded up: 0, 5, 9.
    assert_eq!(steps, vec![100, 600, 1000]);
    let csv = h.http.get(format!("{}/v1/jobs/{id}/samples?format=csv", h.base)).send().await.expect("csv").text().await.expect("text");
    let mut lines = csv.lines();
    assert!(lines.next().unwrap_or_default().starts_with("step,time,phi,z,z_no_rattlers,zeta,mu,p,q,stress_xx"));
    assert_eq!(lines.count(), 11);

    // The same numbers are in the database, readable with any SQL tool.
    let pool = h.db_pool().await;
    let (n, last_step): (i64, i64) =
        sqlx::query_as("SELECT COUNT(*), MAX(step) FROM samples WHERE job_id = $1").bind(id).fetch_one(&pool).await.expect("query");
    assert_eq!((n, last_step), (11, 1000));
    pool.close().await;

    let (_, job) = h.get(&format!("/v1/jobs/{id}")).await;
    assert_eq!(job["state"], "succeeded");
    assert_eq!(job["steps"], 1000);
    assert_eq!(job["attempts"], 1);
    assert_eq!(job["sample_count"], 11);
    assert!(job["finished_at"].is_string());
    let grpc_job = client.get_job(pb::GetJobRequest { id }).await.expect("get").into_inner();
    assert_eq!(grpc_job.state(), pb::JobState::Succeeded);
    assert_eq!(grpc_job.sample_count, 11);
}

async fn an_unstable_run_fails_with_the_engines_reason_and_stores_no_nan(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    // A time step far above the collision time: the grains blow up on their first contacts.
    let mut bad = scene(200_000, 1);
    bad["method"] = json!({"kind": "dem", "time_step": 2e-4});
    bad["particles"][0]["velocity"] = json!({"kind": "gaussian", "std": 0.5});
    let (status, job) = h.post("/v1/jobs", &bad, None).await;
    assert_eq!(status, 201, "{job}");
    let id = job["id"].as_i64().expect("id");
    let job = h.wait_state(id, &["failed", "succeeded"], Duration::from_secs(60)).await;
    assert_eq!(job["state"], "failed", "{job}");
    assert_eq!(job["error"]["code"], "unstable", "{job}");
    let message = job["error"]["message"].as_str().unwrap_or_default();
    assert!(message.contains("dt ="), "the message names the time step and the fix: {message}");
    assert!(job["attempts"] == 1, "an unstable run is not retried: {job}");
    let (_, body) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    for s in body["samples"].as_array().expect("samples") {
        for key in ["time", "phi", "z", "zeta", "p", "q", "kinetic_energy", "elastic_energy"] {
            assert!(s[key].as_f64().is_some_and(f64::is_finite), "sample {key} = {}", s[key]);
        }
    }
}

async fn the_same_idempotency_key_returns_the_same_job(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (s1, j1) = h.post("/v1/jobs", &scene(100, 1), Some("key-1")).await;
    let (s2, j2) = h.post("/v1/jobs", &scene(100, 1), Some("key-1")).await;
    assert_eq!((s1, s2), (201, 200));
    assert_eq!(j1["id"], j2["id"]);
    let (s3, err) = h.post("/v1/jobs", &scene(100, 2), Some("key-1")).await;
    assert_eq!(s3, 409, "{err}");
    assert_eq!(err["code"], "conflict");
    // gRPC request_id is the same key space.
    let mut client = h.grpc().await;
    let j = client
        .submit_job(pb::SubmitJobRequest { scene_json: scene(100, 1).to_string(), request_id: "key-1".into(), ..Default::default() })
        .await
        .expect("submit")
        .into_inner();
    assert_eq!(Some(j.id), j1["id"].as_i64());
    assert_eq!(h.jobs_in_db().await, 1);
    // A job named after a long scene description keeps its first 200 characters.
    let mut described = scene(100, 3);
    described["name"] = json!("é".repeat(300));
    let (status, job) = h.post("/v1/jobs", &described, None).await;
    assert_eq!(status, 201, "{job}");
    let name = job["name"].as_str().expect("a name");
    assert_eq!((name.chars().count(), name.ends_with('…')), (200, true), "{name}");
}

async fn cancelling_a_running_job_stops_it_within_a_second(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (_, job) = h.post("/v1/jobs", &scene(1_000_000_000, 1), None).await;
    let id = job["id"].as_i64().expect("id");
    h.wait_state(id, &["running"], Duration::from_secs(10)).await;
    let asked = Instant::now();
    let (status, job) = h.post(&format!("/v1/jobs/{id}:cancel"), &json!({}), None).await;
    assert_eq!(status, 200, "{job}");
    let job = h.wait_state(id, &["cancelled"], Duration::from_secs(5)).await;
    let took = asked.elapsed();
    assert!(took < Duration::from_secs(1), "cancellation took {took:?}");
    assert_eq!(job["error"]["code"], "cancelled");
    // The time it ran is kept, as for a job that ends by itself.
    let (wall, cpu) = (job["wall_seconds"].as_f64().unwrap_or(0.0), job["cpu_seconds"].as_f64().unwrap_or(0.0));
    assert!(wall > 0.0 && cpu > 0.0 && wall < 30.0, "a cancelled job's times: wall {wall} s, CPU {cpu} s");
    // A finished job cannot be cancelled again.
    let (status, err) = h.post(&format!("/v1/jobs/{id}:cancel"), &json!({}), None).await;
    assert_eq!(status, 409, "{err}");
    // A queued job is cancelled at once.
    let Some(h0) = Harness::start(backend, 0).await else { return };
    let (_, q) = h0.post("/v1/jobs", &scene(100, 1), None).await;
    let (_, c) = h0.post(&format!("/v1/jobs/{}:cancel", q["id"]), &json!({}), None).await;
    assert_eq!(c["state"], "cancelled");
}

async fn a_worker_that_stops_reporting_loses_its_job_to_another(backend: Backend) {
    // No local workers: a "remote" worker leases the job and goes silent.
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (_, job) = h.post("/v1/jobs", &scene(500, 1), None).await;
    let id = job["id"].as_i64().expect("id");
    let store = h.server().store.clone();
    let dead = store.lease_next("remote:dead").await.expect("lease").expect("a job");
    assert_eq!(dead.job_id, id);
    // The lease (2 s) expires; the reaper puts the job back in the queue.
    h.wait_state(id, &["queued"], Duration::from_secs(6)).await;
    // A live remote worker pool, over gRPC, takes it and finishes it.
    let remote = sable_worker::remote::RemoteSource::new(&format!("http://{}", h.server().grpc_addr)).expect("client");
    let mut pc = sable_worker::PoolConfig::new("alive", 1);
    pc.report_interval = Duration::from_millis(100);
    let pool = sable_worker::Pool::start(Arc::new(remote), pc, Arc::new(tokio::sync::Notify::new()));
    let job = h.wait_state(id, &["succeeded"], Duration::from_secs(20)).await;
    assert_eq!(job["attempts"], 2);
    assert_eq!(job["sample_count"], 6);
    // The silent worker's late writes are refused (fenced by its lease).
    let late = store.report(&dead, &sable_worker::Report { fraction: 1.0, ..Default::default() }).await;
    assert!(late.is_err(), "a lost lease must not write");
    pool.shutdown(Duration::from_secs(2)).await;
}

/// A remote worker pool over gRPC with checkpoints every `checkpoint` (None: only when it stops).
fn remote_pool(h: &Harness, name: &str, checkpoint: Option<Duration>) -> sable_worker::Pool {
    let remote = sable_worker::remote::RemoteSource::new(&format!("http://{}", h.server().grpc_addr)).expect("client");
    let mut pc = sable_worker::PoolConfig::new(name, 1);
    pc.report_interval = Duration::from_millis(100);
    pc.threads_per_job = 1;
    pc.checkpoint_interval = checkpoint;
    sable_worker::Pool::start(Arc::new(remote), pc, Arc::new(tokio::sync::Notify::new()))
}

/// The step each attempt of job `id` went on from, from its `running` state events (0: from
/// the start).
async fn resumed_steps(h: &Harness, id: i64) -> Vec<i64> {
    let events = h.server().store.events_after(id, 0, 10_000).await.expect("events");
    events
        .iter()
        .filter(|e| e.kind == "state")
        .filter_map(|e| serde_json::from_str::<Value>(&e.payload).ok())
        .filter(|p| p["state"] == "running")
        .map(|p| p["resumed_from_step"].as_i64().unwrap_or(0))
        .collect()
}

/// Waits until job `id` has done at least `fraction` of its run.
async fn wait_progress(h: &Harness, id: i64, fraction: f64) {
    let start = Instant::now();
    loop {
        let (_, job) = h.get(&format!("/v1/jobs/{id}")).await;
        if job["progress"].as_f64().unwrap_or(0.0) >= fraction {
            return;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "job {id} stayed at {}", job["progress"]);
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Issue 71, finding 8: a job whose worker dies (a crash: nothing more is written) goes on from
/// its last checkpoint when another worker leases it, and a worker that stops (the Slurm
/// example's hand-back, SIGTERM before the allocation ends) saves one as it hands the job back.
/// The samples before each checkpoint are kept, none is stored twice, and the run ends at its
/// steps with every sample. Before, each new attempt ran from step 0.
async fn a_job_goes_on_from_its_checkpoint_after_a_crash_and_a_hand_back(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    // About 3 s of DEM on one thread; a sample every 10,000 steps.
    let mut long = scene(900_000, 3);
    long["sampling"] = json!({"every_steps": 10_000});
    let (_, job) = h.post("/v1/jobs", &long, None).await;
    let id = job["id"].as_i64().expect("id");

    // A worker with checkpoints every 0.2 s dies a third of the way.
    let first = remote_pool(&h, "crashes", Some(Duration::from_millis(200)));
    wait_progress(&h, id, 0.33).await;
    first.abort();
    h.wait_state(id, &["queued"], Duration::from_secs(8)).await;

    // The next one saves no checkpoint on its own but one as it is stopped, two thirds of the way.
    let second = remote_pool(&h, "handed-back", None);
    wait_progress(&h, id, 0.66).await;
    second.shutdown(Duration::from_secs(10)).await;
    let (_, queued) = h.get(&format!("/v1/jobs/{id}")).await;
    assert_eq!(
        (queued["state"].as_str(), queued["attempts"].as_i64()),
        (Some("queued"), Some(1)),
        "a hand-back is not an attempt: {queued}"
    );

    let third = remote_pool(&h, "finishes", None);
    let done = h.wait_state(id, &["succeeded"], Duration::from_secs(30)).await;
    third.shutdown(Duration::from_secs(2)).await;
    assert_eq!((done["steps"].as_i64(), done["sample_count"].as_i64()), (Some(900_000), Some(91)), "{done}");
    let from = resumed_steps(&h, id).await;
    assert_eq!(from.len(), 3, "three attempts ran: {from:?}");
    assert_eq!(from[0], 0);
    assert!(from[1] >= 200_000 && from[1] < from[2] && from[2] >= 500_000, "attempts went on from steps {from:?}");
    let (_, samples) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    let steps: Vec<i64> = samples["samples"].as_array().expect("samples").iter().map(|s| s["step"].as_i64().expect("step")).collect();
    assert_eq!(steps, (0..=90).map(|k| k * 10_000).collect::<Vec<_>>(), "each sample once, in order");
    eprintln!("attempts went on from steps {from:?} of 900,000");
}

/// A checkpoint the next worker cannot go on from (here not a checkpoint at all: another
/// engine's format would be the same) does not cost the job: the worker says so with its first
/// report, the store drops what the earlier attempt stored, and the run goes from step 0 to its
/// end with every sample once.
async fn a_checkpoint_a_worker_cannot_use_makes_the_job_start_over(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (_, job) = h.post("/v1/jobs", &scene(500, 1), None).await;
    let id = job["id"].as_i64().expect("id");
    let store = h.server().store.clone();
    let dead = store.lease_next("remote:dead").await.expect("lease").expect("a job");
    let samples: Vec<sable_engine::observe::Sample> =
        (0..3).map(|k| sable_engine::observe::Sample { step: k * 100, ..Default::default() }).collect();
    let report = sable_worker::Report {
        fraction: 0.4,
        samples,
        first_sample: Some(0),
        checkpoint: Some(sable_worker::CheckpointFile {
            step: 200,
            samples: 3,
            snapshots: 0,
            data: sable_worker::source::gzip("{\"format\": \"something else\"}"),
        }),
        ..Default::default()
    };
    store.report(&dead, &report).await.expect("a report with a checkpoint");
    h.wait_state(id, &["queued"], Duration::from_secs(6)).await;
    let pool = remote_pool(&h, "fresh", None);
    let done = h.wait_state(id, &["succeeded"], Duration::from_secs(20)).await;
    pool.shutdown(Duration::from_secs(2)).await;
    assert_eq!((done["steps"].as_i64(), done["sample_count"].as_i64()), (Some(500), Some(6)), "{done}");
    let (_, samples) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    let phis: Vec<f64> = samples["samples"].as_array().expect("samples").iter().map(|s| s["phi"].as_f64().unwrap_or(0.0)).collect();
    assert!(phis.iter().all(|&phi| phi > 0.0), "a sample of the dead attempt was kept: {phis:?}");
}

async fn a_restarted_server_finishes_the_job_that_was_running(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    // Long enough (about 2 s) to be caught running; a sample every 20,000 steps.
    let mut long = scene(600_000, 1);
    long["sampling"] = json!({"every_steps": 20_000});
    let (_, job) = h.post("/v1/jobs", &long, None).await;
    let id = job["id"].as_i64().expect("id");
    h.wait_state(id, &["running"], Duration::from_secs(10)).await;
    // Crash: nothing is handed back.
    let Harness { server, dir, .. } = h;
    server.expect("running").abort().await;
    let Some(h) = Harness::start_in(backend, dir, 1).await else { return };
    let job = h.wait_state(id, &["succeeded"], Duration::from_secs(30)).await;
    assert_eq!(job["attempts"], 2);
    assert_eq!(job["steps"], 600_000);
    // Samples of the interrupted attempt were replaced, not duplicated.
    assert_eq!(job["sample_count"], 31);
}

async fn a_stopped_server_hands_back_its_running_job_without_counting_an_attempt(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (_, job) = h.post("/v1/jobs", &scene(1_000_000_000, 1), None).await;
    let id = job["id"].as_i64().expect("id");
    h.wait_state(id, &["running"], Duration::from_secs(10)).await;
    let mut client = h.grpc().await;
    let mut watch = client.watch_job(pb::WatchJobRequest { id, after_seq: 0 }).await.expect("watch").into_inner();
    let Harness { server, dir, .. } = h;
    let stopping = Instant::now();
    server.expect("running").shutdown(Duration::from_secs(5)).await;
    assert!(stopping.elapsed() < Duration::from_secs(5), "shutdown took {:?}", stopping.elapsed());
    // Open streams are closed by the shutdown.
    let ended = tokio::time::timeout(Duration::from_secs(5), async { while let Ok(Some(_)) = watch.message().await {} }).await;
    assert!(ended.is_ok(), "the watch stream stayed open after shutdown");
    let Some(h) = Harness::start_in(backend, dir, 0).await else { return };
    let (_, job) = h.get(&format!("/v1/jobs/{id}")).await;
    assert_eq!(job["state"], "queued", "{job}");
    assert_eq!(job["attempts"], 0, "a hand-back is not an attempt: {job}");
}

async fn fifty_concurrent_submissions_all_finish_once(backend: Backend) {
    let Some(h) = Harness::start(backend, 2).await else { return };
    let h = Arc::new(h);
    let mut tasks = Vec::new();
    for k in 0..50u64 {
        let h = h.clone();
        tasks.push(tokio::spawn(async move {
            let (s, j) = h.post("/v1/jobs", &scene(200, k), Some(&format!("batch-{k}"))).await;
            assert_eq!(s, 201, "{j}");
            j["id"].as_i64().expect("id")
        }));
    }
    let mut ids = BTreeSet::new();
    for t in tasks {
        ids.insert(t.await.expect("task"));
    }
    assert_eq!(ids.len(), 50);
    for &id in &ids {
        let job = h.wait_state(id, &["succeeded", "failed", "cancelled"], Duration::from_secs(120)).await;
        assert_eq!(job["state"], "succeeded", "{job}");
        assert_eq!(job["attempts"], 1);
        assert_eq!(job["sample_count"], 3);
    }
    assert_eq!(h.jobs_in_db().await, 50);
    let (_, page) = h.get("/v1/jobs?state=succeeded&page_size=20").await;
    assert_eq!(page["jobs"].as_array().map(Vec::len), Some(20));
    let mut seen = 0;
    let mut token = String::new();
    loop {
        let (_, page) = h.get(&format!("/v1/jobs?page_size=20&page_token={token}")).await;
        seen += page["jobs"].as_array().map_or(0, Vec::len);
        token = page["next_page_token"].as_str().unwrap_or_default().to_string();
        if token.is_empty() {
            break;
        }
    }
    assert_eq!(seen, 50);
}

async fn a_watch_resumed_from_a_sequence_number_misses_nothing(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (_, job) = h.post("/v1/jobs", &scene(1000, 3), None).await;
    let id = job["id"].as_i64().expect("id");
    let mut client = h.grpc().await;
    // Resume from 4 while the job runs; then read it all once it is done.
    let tail = watch_all(&mut client, id, 4).await;
    let all = watch_all(&mut client, id, 0).await;
    assert_eq!(tail.first().map(|e| e.seq), Some(5));
    // A samples read says where its events end (here the ended job's last event), so that a
    // watch resumed there misses nothing and repeats nothing; gRPC and REST alike.
    let read = client
        .get_samples(pb::GetSamplesRequest { id, from_step: 0, to_step: 0, max_points: 3, limit: 0 })
        .await
        .expect("samples")
        .into_inner();
    assert_eq!(read.samples_json.len(), 3);
    assert_eq!(Some(read.events_seq), all.last().map(|e| e.seq));
    let (_, page) = h.get(&format!("/v1/jobs/{id}/samples?max_points=3")).await;
    assert_eq!(page["events_seq"].as_u64(), all.last().map(|e| e.seq));
    assert_eq!(page["samples"].as_array().map(Vec::len), Some(3));
    assert_eq!(all[4..].iter().map(|e| e.seq).collect::<Vec<_>>(), tail.iter().map(|e| e.seq).collect::<Vec<_>>());
    assert_eq!(all[4..], tail[..]);
    // SSE mirrors it.
    let text = h.http.get(format!("{}/v1/jobs/{id}/events?after_seq=4", h.base)).send().await.expect("sse").text().await.expect("body");
    let ids: Vec<u64> = text.lines().filter_map(|l| l.strip_prefix("id:")).filter_map(|s| s.trim().parse().ok()).collect();
    assert_eq!(ids, tail.iter().map(|e| e.seq).collect::<Vec<_>>());
    // A browser reconnects with its first URL and the last id it got: the header wins.
    let text = h
        .http
        .get(format!("{}/v1/jobs/{id}/events?after_seq=2", h.base))
        .header("Last-Event-ID", "4")
        .send()
        .await
        .expect("sse")
        .text()
        .await
        .expect("body");
    let ids: Vec<u64> = text.lines().filter_map(|l| l.strip_prefix("id:")).filter_map(|s| s.trim().parse().ok()).collect();
    assert_eq!(ids, tail.iter().map(|e| e.seq).collect::<Vec<_>>());
}

/// A long run is read in pages, and a list of jobs is a list of summaries: before, one call
/// returned every sample (312 MB for 394,510 of them) and every listed job's whole scene
/// (492 MB for a page of 50 jobs of 12 MB), on both APIs.
async fn long_runs_are_read_in_pages_and_lists_are_summaries(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let mut long = scene(12_000, 1);
    long["sampling"] = json!({"every_steps": 1});
    long["gravity"] = json!([0, 0]);
    let (status, job) = h.post("/v1/jobs", &long, None).await;
    assert_eq!(status, 201, "{job}");
    let id = job["id"].as_i64().expect("id");
    h.wait_state(id, &["succeeded"], Duration::from_secs(120)).await;

    let (status, first) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    assert_eq!(status, 200, "{first}");
    let page = first["samples"].as_array().expect("samples");
    assert_eq!((page.len(), first["next_from_step"].as_u64()), (10_000, Some(10_000)));
    let (_, second) = h.get(&format!("/v1/jobs/{id}/samples?from_step=10000")).await;
    let rest = second["samples"].as_array().expect("samples");
    assert_eq!((rest.len(), rest[0]["step"].as_u64(), second.get("next_from_step")), (2_001, Some(10_000), None));
    let (status, err) = h.get(&format!("/v1/jobs/{id}/samples?limit=10001")).await;
    assert_eq!((status, err["details"][0]["field"].as_str()), (422, Some("limit")), "{err}");
    let (_, few) = h.get(&format!("/v1/jobs/{id}/samples?max_points=50000")).await;
    assert_eq!(few["samples"].as_array().map(Vec::len), Some(10_000), "max_points is held to a page");
    // The Rust client reads every page.
    let mut client = sable_client::Client::connect(&format!("http://{}", h.server().grpc_addr)).await.expect("client");
    assert_eq!(client.samples(id, 0, None, None).await.expect("samples").len(), 12_001);

    // Lists leave the scenes out, on both APIs; the job itself has its scene.
    let (_, list) = h.get("/v1/jobs").await;
    let listed = &list["jobs"][0];
    assert_eq!((listed["id"].as_i64(), listed.get("scene")), (Some(id), None), "{listed}");
    let (_, one) = h.get(&format!("/v1/jobs/{id}")).await;
    assert_eq!(one["scene"]["sampling"]["every_steps"], 1);
    let mut grpc = h.grpc().await;
    let jobs = grpc.list_jobs(pb::ListJobsRequest::default()).await.expect("list").into_inner().jobs;
    assert_eq!((jobs[0].id, jobs[0].scene_json.as_str()), (id, ""));
    let got = grpc.get_job(pb::GetJobRequest { id }).await.expect("get").into_inner();
    assert!(got.scene_json.contains("every_steps"), "{}", got.scene_json);
}

/// Whether the server closes `tcp` within `within` (a read ends or fails).
async fn closed_within(tcp: &mut tokio::net::TcpStream, within: Duration) -> bool {
    use tokio::io::AsyncReadExt;
    let mut buf = [0u8; 256];
    let start = Instant::now();
    while start.elapsed() < within {
        match tokio::time::timeout(within.saturating_sub(start.elapsed()), tcp.read(&mut buf)).await {
            Ok(Ok(0)) | Ok(Err(_)) => return true,
            Ok(Ok(_)) => continue,
            Err(_) => return false,
        }
    }
    false
}

/// A connection quiet for the idle timeout is closed, before any request is complete, on the
/// REST and the gRPC port: 19,990 half-open requests once held the server at its descriptor
/// limit for as long as the client pleased. An event stream, with its heartbeats, stays open.
async fn quiet_connections_are_closed_and_live_streams_are_not(backend: Backend) {
    use tokio::io::AsyncWriteExt;
    let dir = tempfile::tempdir().expect("temp dir");
    let Some(db) = location(backend, &dir).await else { return };
    let idle = Duration::from_millis(1500);
    let server = Server::start(ServeConfig { idle_timeout: idle, ..config(db, 0) }).await.expect("server starts");
    let mut half = tokio::net::TcpStream::connect(server.http_addr).await.expect("connect");
    half.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n").await.expect("half a request");
    let mut silent = tokio::net::TcpStream::connect(server.grpc_addr).await.expect("connect");
    let (rest_closed, grpc_closed) =
        tokio::join!(closed_within(&mut half, idle + Duration::from_secs(3)), closed_within(&mut silent, idle + Duration::from_secs(3)));
    assert!(rest_closed && grpc_closed, "REST closed: {rest_closed}, gRPC closed: {grpc_closed}");

    // A job's event stream outlives the timeout on its heartbeats (every 0.5 s here).
    let base = format!("http://{}", server.http_addr);
    let http = reqwest::Client::new();
    let job: Value = http.post(format!("{base}/v1/jobs")).json(&scene(10, 1)).send().await.expect("submit").json().await.expect("job");
    let id = job["id"].as_i64().expect("id");
    let mut stream = http.get(format!("{base}/v1/jobs/{id}/events")).send().await.expect("events");
    let start = Instant::now();
    let mut chunks = 0;
    while start.elapsed() < idle * 2 {
        let chunk =
            tokio::time::timeout(idle, stream.chunk()).await.expect("a heartbeat within the timeout").expect("the stream stays open");
        assert!(chunk.is_some(), "the stream ended after {:?}", start.elapsed());
        chunks += 1;
    }
    assert!(chunks >= 3, "{chunks} chunks");
    server.shutdown(Duration::from_secs(5)).await;
}

/// What a worker sends is checked like a user's request: a NaN fraction once broke a NOT NULL
/// constraint and was answered UNAVAILABLE (the worker retried it for good), and ListJobs with
/// a state number it does not know listed every state.
async fn worker_figures_and_unknown_enums_are_refused_by_name(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (status, job) = h.post("/v1/jobs", &scene(100, 1), None).await;
    assert_eq!(status, 201, "{job}");
    let channel = Channel::from_shared(format!("http://{}", h.server().grpc_addr)).expect("url").connect().await.expect("connect");
    let mut workers = sable_proto::v1::workers_client::WorkersClient::new(channel);
    let lease = workers
        .lease_job(pb::LeaseJobRequest { worker: "fuzz".into() })
        .await
        .expect("lease")
        .into_inner()
        .lease
        .expect("the job is leased");
    let report = |fraction: f64, remaining_seconds: f64| pb::ReportProgressRequest {
        job_id: lease.job_id,
        lease_id: lease.lease_id.clone(),
        fraction,
        remaining_seconds,
        ..Default::default()
    };
    for (bad, field) in [(report(f64::NAN, 1.0), "fraction"), (report(1.5, 1.0), "fraction"), (report(0.5, f64::NAN), "remaining_seconds")]
    {
        let e = workers.report_progress(bad).await.expect_err("refused");
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
        assert!(e.message().starts_with(field), "{e}");
    }
    // A "snapshot" that decompresses to 64 MB of one byte (65 kB of gzip) is served as a
    // stream, never built in memory first (a 1.5 MB one once became a 1.5 GiB allocation on a
    // user's download): no Content-Length, and every byte arrives.
    let bomb = sable_worker::source::gzip(&"0".repeat(64 << 20));
    let small = sable_worker::source::gzip("<VTKFile/>");
    let snapshot = pb::SnapshotFiles { index: 0, step: 1, time: 0.0, particles_gz: bomb, contacts_gz: small.clone(), walls_gz: small };
    workers
        .report_progress(pb::ReportProgressRequest { snapshots: vec![snapshot], ..report(0.5, 1.0) })
        .await
        .expect("a good report is taken");
    let response = h.http.get(format!("{}/v1/jobs/{}/snapshots/0/particles", h.base, lease.job_id)).send().await.expect("download");
    assert_eq!(response.status(), 200);
    assert!(response.headers().get("content-length").is_none(), "{:?}", response.headers());
    assert_eq!(response.bytes().await.expect("the file").len(), 64 << 20);
    let mut client = h.grpc().await;
    let e = client.list_jobs(pb::ListJobsRequest { state: 99, ..Default::default() }).await.expect_err("refused");
    assert_eq!((e.code(), e.message()), (tonic::Code::InvalidArgument, "state: 99 is not a JobState"));
    // Bytes that are no protobuf message (field number 0 is none) are the client's error, on
    // every method: INVALID_ARGUMENT, not INTERNAL, and nothing moves.
    let channel = Channel::from_shared(format!("http://{}", h.server().grpc_addr)).expect("url").connect().await.expect("connect");
    let mut raw = tonic::client::Grpc::new(channel);
    let methods = [
        "Simulations/SubmitJob",
        "Simulations/GetJob",
        "Simulations/ListJobs",
        "Simulations/CancelJob",
        "Simulations/WatchJob",
        "Simulations/GetSamples",
        "Simulations/GetFinalState",
        "Simulations/Advise",
        "Studies/CreateStudy",
        "Studies/GetStudy",
        "Studies/ListStudies",
        "Studies/GetStudyChart",
        "Workers/LeaseJob",
        "Workers/ReportProgress",
        "Workers/FinishJob",
    ];
    for (k, method) in methods.into_iter().enumerate() {
        let bytes: Vec<u8> = [0u8, k as u8, 0xff, 0x07].to_vec();
        raw.ready().await.expect("ready");
        let path = format!("/sable.v1.{method}").parse::<http::uri::PathAndQuery>().expect("path");
        let e = raw.unary(tonic::Request::new(bytes), path, RawBytes).await.expect_err("refused");
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{method}: {}", e.message());
        assert!(e.message().starts_with("failed to decode Protobuf message"), "{method}: {}", e.message());
    }
    let (_, page) = h.get("/v1/jobs").await;
    assert_eq!(page["jobs"].as_array().map(Vec::len), Some(1), "{page}");
}

/// A gRPC codec of raw bytes, to send what no generated client would.
#[derive(Clone, Copy, Default)]
struct RawBytes;

impl tonic::codec::Codec for RawBytes {
    type Encode = Vec<u8>;
    type Decode = Vec<u8>;
    type Encoder = RawBytes;
    type Decoder = RawBytes;
    fn encoder(&mut self) -> RawBytes {
        RawBytes
    }
    fn decoder(&mut self) -> RawBytes {
        RawBytes
    }
}

impl tonic::codec::Encoder for RawBytes {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn encode(&mut self, item: Vec<u8>, dst: &mut tonic::codec::EncodeBuf<'_>) -> Result<(), tonic::Status> {
        bytes::BufMut::put_slice(dst, &item);
        Ok(())
    }
}

impl tonic::codec::Decoder for RawBytes {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn decode(&mut self, src: &mut tonic::codec::DecodeBuf<'_>) -> Result<Option<Vec<u8>>, tonic::Status> {
        let n = bytes::Buf::remaining(src);
        Ok(Some(bytes::Buf::copy_to_bytes(src, n).to_vec()))
    }
}

/// A scene JSON text mutated by `rng`: a byte changed, a number replaced by one of the values
/// that broke servers (huge, negative, NaN, 1e999), a part cut, or nested deep.
fn mutated(rng: &mut impl rand::Rng, text: &str) -> String {
    let mut bytes = text.as_bytes().to_vec();
    match rng.gen_range(0..5) {
        0 => {
            let i = rng.gen_range(0..bytes.len());
            bytes[i] = rng.gen();
        }
        1 => {
            let odd = ["1e999", "-1", "18446744073709551615", "NaN", "-0", "1e-320", "\"x\"", "null", "[]", "{}"];
            let text = String::from_utf8_lossy(&bytes).into_owned();
            let numbers: Vec<usize> = text.match_indices(|c: char| c.is_ascii_digit()).map(|(i, _)| i).collect();
            if let Some(&at) = numbers.get(rng.gen_range(0..numbers.len().max(1))) {
                let end = text[at..].find(|c: char| !c.is_ascii_digit() && c != '.' && c != 'e' && c != '-').map_or(text.len(), |k| at + k);
                return format!("{}{}{}", &text[..at], odd[rng.gen_range(0..odd.len())], &text[end..]);
            }
        }
        2 => bytes.truncate(rng.gen_range(0..bytes.len())),
        3 => return format!("{}{}{}", "[".repeat(rng.gen_range(1..20_000)), text, "]".repeat(rng.gen_range(0..3))),
        _ => {
            let i = rng.gen_range(0..bytes.len());
            let j = rng.gen_range(0..bytes.len());
            bytes.swap(i, j);
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Issue 71: random and mutated requests to every RPC of the user's and the workers' services
/// (the REST entry has its own cases below). Each is answered with a status that says what was
/// wrong (never INTERNAL or UNKNOWN, which would be a bug of the server), the server stays
/// healthy, runs a good job afterwards, and stores no job, sample or outcome from a refused
/// request.
async fn random_grpc_requests_are_answered_and_change_nothing(backend: Backend) {
    use rand::{Rng, SeedableRng};
    let Some(h) = Harness::start(backend, 0).await else { return };
    let mut rng = rand::rngs::StdRng::seed_from_u64(71);
    let mut client = h.grpc().await;
    let channel = Channel::from_shared(format!("http://{}", h.server().grpc_addr)).expect("url").connect().await.expect("connect");
    let mut workers = sable_proto::v1::workers_client::WorkersClient::new(channel);
    let good = scene(200, 1).to_string();
    let bad_codes = [tonic::Code::Internal, tonic::Code::Unknown, tonic::Code::DataLoss];
    let check = |what: &str, r: Result<(), tonic::Status>| {
        if let Err(e) = r {
            assert!(!bad_codes.contains(&e.code()), "{what}: {:?} {}", e.code(), e.message());
        }
    };
    let odd_i64 = |rng: &mut rand::rngs::StdRng| [i64::MIN, -1, 0, 1, 2, i64::MAX, rng.gen()][rng.gen_range(0..7)];
    let odd_u64 = |rng: &mut rand::rngs::StdRng| [0, 1, u64::MAX, u64::MAX / 2, rng.gen()][rng.gen_range(0..5)];
    let odd_f64 = |rng: &mut rand::rngs::StdRng| [f64::NAN, f64::INFINITY, -1.0, 0.0, 1e308, rng.gen()][rng.gen_range(0..6)];
    let mut accepted = 0;
    for k in 0..300 {
        let scene_json = mutated(&mut rng, &good);
        let submitted = client
            .submit_job(pb::SubmitJobRequest {
                scene_json,
                name: if rng.gen_bool(0.1) { "n".repeat(rng.gen_range(0..5000)) } else { String::new() },
                priority: [i32::MIN, -1, 0, 5, i32::MAX][rng.gen_range(0..5)],
                request_id: if rng.gen_bool(0.2) { format!("key-{k}") } else { String::new() },
                max_attempts: [0, 1, 3, u32::MAX][rng.gen_range(0..4)],
            })
            .await;
        if submitted.is_ok() {
            accepted += 1;
        }
        check("SubmitJob", submitted.map(|_| ()));
        check("GetJob", client.get_job(pb::GetJobRequest { id: odd_i64(&mut rng) }).await.map(|_| ()));
        check("CancelJob", client.cancel_job(pb::CancelJobRequest { id: odd_i64(&mut rng) }).await.map(|_| ()));
        let list = pb::ListJobsRequest {
            state: rng.gen_range(-2..9),
            name: mutated(&mut rng, "settle"),
            method: ["", "dem", "nope", "\u{0}"][rng.gen_range(0..4)].into(),
            created_after: ["", "2026-01-01T00:00:00Z", "yesterday", "9999-99-99"][rng.gen_range(0..4)].into(),
            created_before: String::new(),
            page_size: [0, 1, 50, u32::MAX][rng.gen_range(0..4)],
            page_token: ["", "abc", "-1", "99999999999999999999"][rng.gen_range(0..4)].into(),
        };
        check("ListJobs", client.list_jobs(list).await.map(|_| ()));
        let samples = pb::GetSamplesRequest {
            id: odd_i64(&mut rng),
            from_step: odd_u64(&mut rng),
            to_step: odd_u64(&mut rng),
            max_points: [0, 1, 10_001, u32::MAX][rng.gen_range(0..4)],
            limit: [0, 1, 10_001, u32::MAX][rng.gen_range(0..4)],
        };
        check("GetSamples", client.get_samples(samples).await.map(|_| ()));
        check("GetFinalState", client.get_final_state(pb::GetFinalStateRequest { id: odd_i64(&mut rng) }).await.map(|_| ()));
        let garbage: Vec<u8> = (0..rng.gen_range(0..64)).map(|_| rng.gen()).collect();
        let report = pb::ReportProgressRequest {
            job_id: odd_i64(&mut rng),
            lease_id: mutated(&mut rng, "lease-0123"),
            fraction: odd_f64(&mut rng),
            remaining_seconds: odd_f64(&mut rng),
            samples_json: vec![mutated(&mut rng, r#"{"step": 1, "time": 0.0, "phi": 0.5}"#)],
            snapshots: vec![pb::SnapshotFiles {
                index: rng.gen(),
                step: odd_u64(&mut rng),
                time: odd_f64(&mut rng),
                particles_gz: garbage.clone(),
                ..Default::default()
            }],
            first_sample: rng.gen_bool(0.5).then(|| odd_u64(&mut rng)),
            checkpoint: rng.gen_bool(0.5).then(|| pb::Checkpoint {
                step: odd_u64(&mut rng),
                samples: odd_u64(&mut rng),
                snapshots: odd_u64(&mut rng),
                data_gz: garbage.clone(),
            }),
            from_start: rng.gen(),
        };
        check("ReportProgress", workers.report_progress(report).await.map(|_| ()));
        let finish = pb::FinishJobRequest {
            job_id: odd_i64(&mut rng),
            lease_id: mutated(&mut rng, "lease-0123"),
            outcome: rng.gen_range(-1..7),
            error_code: mutated(&mut rng, "unstable"),
            error_message: String::new(),
            steps: odd_u64(&mut rng),
            wall_seconds: odd_f64(&mut rng),
            result_json: mutated(&mut rng, r#"{"peak": 1}"#),
            final_state_gz: garbage,
            ..Default::default()
        };
        check("FinishJob", workers.finish_job(finish).await.map(|_| ()));
        let worker = if rng.gen_bool(0.5) { mutated(&mut rng, "fuzz-worker") } else { "local:x".into() };
        // Leases are what workers are for: a job it takes is handed back at once.
        match workers.lease_job(pb::LeaseJobRequest { worker }).await {
            Ok(r) => {
                if let Some(l) = r.into_inner().lease {
                    let back = pb::FinishJobRequest { job_id: l.job_id, lease_id: l.lease_id, outcome: 4, ..Default::default() };
                    workers.finish_job(back).await.expect("hand back");
                }
            }
            Err(e) => check("LeaseJob", Err(e)),
        }
    }
    // No refused request ran, finished or failed a job: each is queued (or cancelled by a
    // CancelJob that named it).
    let (status, _) = h.get("/healthz").await;
    assert_eq!(status, 200);
    let (_, page) = h.get("/v1/jobs?page_size=500").await;
    let jobs = page["jobs"].as_array().expect("jobs").clone();
    let moved: Vec<&Value> = jobs.iter().filter(|j| j["state"] != "queued" && j["state"] != "cancelled").collect();
    assert!(moved.is_empty(), "a refused request moved a job: {moved:?}");
    eprintln!("{accepted} of 300 mutated scenes were valid and queued");
    // The queue cleared, a good job runs to its end on a worker pool started now.
    for j in jobs.iter().filter(|j| j["state"] == "queued") {
        h.post(&format!("/v1/jobs/{}:cancel", j["id"]), &json!({}), None).await;
    }
    let (_, job) = h.post("/v1/jobs", &scene(200, 2), None).await;
    let pool = remote_pool(&h, "after-fuzz", None);
    let done = h.wait_state(job["id"].as_i64().expect("id"), &["succeeded"], Duration::from_secs(60)).await;
    pool.shutdown(Duration::from_secs(2)).await;
    assert_eq!(done["sample_count"], 3, "{done}");
}

async fn bad_input_gets_a_clear_error_and_writes_nothing(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    // Rule violations: 422 with every violation in `details`, one error body everywhere.
    let mut no_snapshot_interval = scene(10, 1);
    no_snapshot_interval["snapshots"] = json!({"every_steps": 0});
    let mut long_preparation = compaction_scene();
    long_preparation["experiment"] = json!({"kind": "isotropic", "preparation": {"pressure": 10.0, "max_steps": 3_000_000_000u64}});
    // A scene name that is a document (a 15 MB one was once accepted and listed with every
    // page of jobs), and a run that would store more samples than a job may.
    let mut long_name = scene(10, 1);
    long_name["name"] = json!("x".repeat(1001));
    let mut many_samples = scene(1_900_000_000, 1);
    many_samples["sampling"] = json!({"every_steps": 10});
    let cases: Vec<(Value, &str)> = vec![
        (json!({"scene": long_name}), "scene.name"),
        (json!({"scene": many_samples}), "scene.sampling.every_steps"),
        (json!({"scene": scene(10, 1), "colour": "red"}), "colour"),
        (json!({"scene": scene(10, 1), "priority": 5000}), "priority"),
        (json!({"scene": scene(10, 1), "max_attempts": 0}), "max_attempts"),
        (json!({"scene": scene(10, 1), "name": ""}), "name"),
        (json!({"scene": scene(3_000_000_000, 1)}), "scene.stop.steps"),
        (json!({"scene": no_snapshot_interval}), "scene.snapshots.every_steps"),
        (json!({"scene": long_preparation}), "scene.experiment.preparation.max_steps"),
    ];
    for (body, field) in cases {
        let (status, err) = h.post("/v1/jobs", &body, None).await;
        assert_eq!(status, 422, "{body}: {err}");
        assert_eq!(err["code"], "invalid_argument");
        let fields: Vec<&str> = err["details"].as_array().expect("details").iter().filter_map(|v| v["field"].as_str()).collect();
        assert!(fields.contains(&field), "{body}: expected a violation on '{field}', got {err}");
    }
    let mut many = scene(10, 1);
    many["particles"][0]["count"] = json!(20_000);
    let (status, err) = h.post("/v1/jobs", &many, None).await;
    assert_eq!(status, 422, "{err}");
    assert_eq!(err["details"][0]["field"], "particles");
    // Counts that wrap when added (u64::MAX + 2 = 1) are refused by name, not run: such a
    // scene once passed as "1 particle" and aborted the process that allocated for it.
    let mut wraps = scene(10, 1);
    let set = wraps["particles"][0].clone();
    wraps["particles"] = json!([set.clone(), set]);
    wraps["particles"][0]["count"] = json!(u64::MAX);
    wraps["particles"][1]["count"] = json!(2);
    let (status, err) = h.post("/v1/jobs", &wraps, None).await;
    assert_eq!(status, 422, "{err}");
    assert!(err["details"].as_array().expect("details").iter().any(|d| d["field"] == "particles[0].count"), "{err}");
    // A scene with several broken rules: every one is reported, with its path.
    let mut bad = scene(10, 1);
    bad["materials"]["glass"]["friction"] = json!(-0.2);
    bad["materials"]["glass"]["density"] = json!(0);
    let (status, err) = h.post("/v1/jobs", &json!({"scene": bad}), None).await;
    assert_eq!(status, 422);
    let details = err["details"].as_array().expect("details");
    assert!(details.iter().any(|d| d["field"] == "scene.materials.glass.friction" && d["rule"] == "must be >= 0, got -0.2"), "{err}");
    assert!(details.iter().any(|d| d["field"] == "scene.materials.glass.density"), "{err}");
    // Not JSON, not an object, too large.
    let resp = h.http.post(format!("{}/v1/jobs", h.base)).body("{not json").send().await.expect("answers");
    assert_eq!(resp.status().as_u16(), 400);
    let (status, err) = h.post("/v1/jobs", &json!([1, 2]), None).await;
    assert_eq!((status, err["code"].as_str()), (400, Some("malformed")));
    let mut huge = scene(10, 1);
    huge["name"] = json!("x".repeat(100_000));
    let (status, err) = h.post("/v1/jobs", &huge, None).await;
    assert_eq!(status, 413, "{err}");
    // Queries and ids.
    for (path, status) in [
        ("/v1/jobs?state=sleeping", 422),
        ("/v1/jobs?page_token=xyz", 422),
        ("/v1/jobs?page_size=100000", 422),
        ("/v1/jobs?created_after=yesterday", 422),
        ("/v1/jobs?colour=red", 400),
        ("/v1/jobs?page_size=-1", 400),
        ("/v1/jobs/abc", 400),
        ("/v1/jobs/999", 404),
        ("/v1/jobs/999/samples", 404),
        ("/v1/jobs/999/events", 404),
        ("/v1/jobs/1/samples?format=xml", 422),
        ("/nowhere", 404),
    ] {
        let (s, body) = h.get(path).await;
        assert_eq!(s, status, "{path}: {body}");
        assert!(body["code"].is_string() && body["message"].is_string() && body["details"].is_array(), "{path}: {body}");
    }
    let (s, _) = h.post("/v1/jobs/999:cancel", &json!({}), None).await;
    assert_eq!(s, 404);
    let (s, _) = h.post("/v1/jobs/1:launch", &json!({}), None).await;
    assert_eq!(s, 404);
    // gRPC maps the same errors to status codes.
    let mut client = h.grpc().await;
    let e = client.submit_job(pb::SubmitJobRequest { scene_json: "{".into(), ..Default::default() }).await.expect_err("invalid");
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    let mut four_d = scene(10, 1);
    four_d["dimension"] = json!(4);
    let e = client.submit_job(pb::SubmitJobRequest { scene_json: four_d.to_string(), ..Default::default() }).await.expect_err("invalid");
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    assert!(e.message().contains("scene_json.dimension"), "{}", e.message());
    let e = client.get_job(pb::GetJobRequest { id: 999 }).await.expect_err("missing");
    assert_eq!(e.code(), tonic::Code::NotFound);
    let e = client.watch_job(pb::WatchJobRequest { id: 999, after_seq: 0 }).await.expect_err("missing");
    assert_eq!(e.code(), tonic::Code::NotFound);
    assert_eq!(h.jobs_in_db().await, 0, "nothing is written for a rejected request");

    // Event streams are limited (2 in this harness); a third is refused until one closes.
    let (_, job) = h.post("/v1/jobs", &scene(10, 1), None).await;
    let id = job["id"].as_i64().expect("id");
    let s1 = client.watch_job(pb::WatchJobRequest { id, after_seq: 0 }).await.expect("first watcher");
    let s2 = h.http.get(format!("{}/v1/jobs/{id}/events", h.base)).send().await.expect("second watcher");
    assert_eq!(s2.status().as_u16(), 200);
    let (s, err) = h.get(&format!("/v1/jobs/{id}/events")).await;
    assert_eq!((s, err["code"].as_str()), (429, Some("resource_exhausted")), "{err}");
    let e = client.watch_job(pb::WatchJobRequest { id, after_seq: 0 }).await.expect_err("over the limit");
    assert_eq!(e.code(), tonic::Code::ResourceExhausted);
    drop(s1);
    drop(s2);
    let start = Instant::now();
    loop {
        match client.watch_job(pb::WatchJobRequest { id, after_seq: 0 }).await {
            Ok(_) => break,
            Err(e) => {
                assert_eq!(e.code(), tonic::Code::ResourceExhausted);
                assert!(start.elapsed() < Duration::from_secs(5), "closed streams must free their slots");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    }
}

async fn health_metrics_and_openapi_describe_the_service(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (s, _) = h.get("/healthz").await;
    assert_eq!(s, 200);
    let (_, job) = h.post("/v1/jobs", &scene(200, 1), None).await;
    h.wait_state(job["id"].as_i64().expect("id"), &["succeeded"], Duration::from_secs(20)).await;
    let text = h.http.get(format!("{}/metrics", h.base)).send().await.expect("metrics").text().await.expect("text");
    assert!(text.contains("sable_jobs{state=\"succeeded\"} 1"), "{text}");
    assert!(text.contains("sable_queue_depth 0"), "{text}");
    assert!(text.contains("sable_job_duration_seconds_count 1"), "{text}");
    assert!(text.contains("sable_workers 1"), "{text}");
    let (_, doc) = h.get("/v1/openapi.json").await;
    for path in [
        "/v1/jobs",
        "/v1/jobs/{id}",
        "/v1/jobs/{id}:cancel",
        "/v1/jobs/{id}/samples",
        "/v1/jobs/{id}/events",
        "/healthz",
        "/metrics",
        "/v1/openapi.json",
    ] {
        assert!(doc["paths"].get(path).is_some(), "OpenAPI lacks {path}");
    }
    // The schemas are generated from the types the handlers exchange.
    for schema in ["JobView", "ErrorBody", "Sample", "Violation", "SubmitBody"] {
        assert!(doc["components"]["schemas"].get(schema).is_some(), "OpenAPI lacks the {schema} schema");
    }
    let sample_fields = doc["components"]["schemas"]["Sample"]["properties"].as_object().map(|m| m.len());
    assert_eq!(sample_fields, Some(22), "every Sample field is documented");
    assert!(doc["components"]["schemas"].get("ClusterSample").is_some(), "the wet grains' cluster in a sample has its schema");
    assert!(doc["components"]["schemas"].get("DrumSample").is_some(), "the drum's part of a sample has its schema");
    assert!(doc["components"]["schemas"].get("SolverSample").is_some(), "the contact solver's part of a sample has its schema");
    assert!(doc["components"]["schemas"].get("DeformableSample").is_some(), "the deformable grains' part of a sample has its schema");
    assert!(doc["components"]["schemas"].get("GrainSample").is_some(), "the aggregates' grain-level part of a sample has its schema");
    assert!(doc["paths"]["/v1/jobs"]["post"]["responses"].get("422").is_some());
    // gRPC health answers SERVING for both services.
    let channel = Channel::from_shared(format!("http://{}", h.server().grpc_addr)).expect("url").connect().await.expect("connect");
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel);
    for service in ["sable.v1.Simulations", "sable.v1.Workers"] {
        let r = health.check(tonic_health::pb::HealthCheckRequest { service: service.into() }).await.expect("health").into_inner();
        assert_eq!(r.status(), tonic_health::pb::health_check_response::ServingStatus::Serving, "{service}");
    }
}

/// Checks the snapshots of a finished job: taken at steps 0, 400, 800 and 1000, listed with
/// their files, each file a VTK document of the job's 30 particles; bad indices and parts are
/// refused.
async fn check_snapshots(h: &Harness, id: i64) {
    let (status, list) = h.get(&format!("/v1/jobs/{id}/snapshots")).await;
    assert_eq!(status, 200, "{list}");
    let steps: Vec<i64> = list["snapshots"].as_array().expect("list").iter().map(|s| s["step"].as_i64().expect("step")).collect();
    assert_eq!(steps, vec![0, 400, 800, 1000]);
    let files = list["snapshots"][3]["files"].as_array().expect("files").clone();
    assert_eq!(files.len(), 3);
    for (file, root) in files.iter().zip(["particles", "contacts", "walls"]) {
        let path = file.as_str().expect("path");
        assert!(path.ends_with(&format!("/3/{root}.vtp")), "{path}");
        let resp = h.http.get(format!("{}{path}", h.base)).send().await.expect("HTTP answers");
        assert_eq!(resp.status().as_u16(), 200, "{path}");
        let text = resp.text().await.expect("body");
        let doc = roxmltree::Document::parse(&text).expect("well-formed VTK XML");
        let piece = doc.descendants().find(|n| n.has_tag_name("Piece")).expect("a piece");
        match root {
            "particles" => assert_eq!(piece.attribute("NumberOfPoints"), Some("30")),
            // The four walls of the 2D box, as segments.
            "walls" => assert_eq!(piece.attribute("NumberOfLines"), Some("4")),
            _ => assert!(piece.attribute("NumberOfLines").is_some()),
        }
    }
    let (status, body) = h.get(&format!("/v1/jobs/{id}/snapshots/4/particles")).await;
    assert_eq!(status, 404, "{body}");
    let (status, body) = h.get(&format!("/v1/jobs/{id}/snapshots/0/grains")).await;
    assert_eq!(status, 400, "{body}");
    assert_eq!(body["details"][0]["field"], "part", "{body}");
}

async fn snapshots_are_stored_and_served_from_local_and_remote_workers(backend: Backend) {
    let mut s = scene(1000, 4);
    s["snapshots"] = json!({"every_steps": 400});
    // A local worker.
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (status, job) = h.post("/v1/jobs", &s, None).await;
    assert_eq!(status, 201, "{job}");
    let id = job["id"].as_i64().expect("id");
    h.wait_state(id, &["succeeded"], Duration::from_secs(20)).await;
    check_snapshots(&h, id).await;
    // A job without snapshots has none.
    let (_, plain) = h.post("/v1/jobs", &scene(200, 4), None).await;
    let plain = plain["id"].as_i64().expect("id");
    h.wait_state(plain, &["succeeded"], Duration::from_secs(20)).await;
    let (_, list) = h.get(&format!("/v1/jobs/{plain}/snapshots")).await;
    assert_eq!(list["snapshots"], json!([]));

    // A remote worker: the files travel in its gRPC reports.
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (_, job) = h.post("/v1/jobs", &s, None).await;
    let id = job["id"].as_i64().expect("id");
    let remote = sable_worker::remote::RemoteSource::new(&format!("http://{}", h.server().grpc_addr)).expect("client");
    let mut pc = sable_worker::PoolConfig::new("remote", 1);
    pc.report_interval = Duration::from_millis(100);
    let pool = sable_worker::Pool::start(Arc::new(remote), pc, Arc::new(tokio::sync::Notify::new()));
    h.wait_state(id, &["succeeded"], Duration::from_secs(20)).await;
    check_snapshots(&h, id).await;
    pool.shutdown(Duration::from_secs(2)).await;
}

/// A compaction experiment of 60 disks (Φ ≈ 0.5): the top wall moves down until the strain 0.45 (Φ ≈ 0.78, jammed).
fn compaction_scene() -> Value {
    json!({
        "name": "compaction",
        "dimension": 2,
        "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 60, "size": {"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.008, 0.012], "wall_material": "glass"},
        "experiment": {"kind": "compaction", "velocity": 0.01, "strain": 0.45},
        "sampling": {"every_steps": 500},
        "seed": 2
    })
}

/// Checks a compaction result against the packing fraction `phi0` of the first sample.
fn check_compaction(result: &Value, phi0: f64) {
    assert_eq!(result["experiment"], "compaction", "{result}");
    let c = &result["compaction"];
    let (onset, last) = (c["phi_onset"].as_f64().expect("onset"), c["phi_final"].as_f64().expect("final"));
    // Only the height changes: the strain ε (0.45 reached within a step) multiplies Φ by e^ε;
    // the wall takes load on the
    // way (onset) and ends loaded.
    let strain = c["strain"].as_f64().expect("strain");
    assert!(onset < last && (last - strain.exp() * phi0).abs() < 1e-9, "{c} (phi0 {phi0})");
    assert!((strain - 0.45).abs() < 0.01, "{c}");
    assert!(c["wall_stress"].as_f64().expect("stress") > 0.0, "{c}");
}

async fn an_experiments_results_are_stored_with_its_job(backend: Backend) {
    // A local worker; the result over REST and gRPC, the samples labelled with the stage.
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (status, job) = h.post("/v1/jobs", &compaction_scene(), None).await;
    assert_eq!(status, 201, "{job}");
    let id = job["id"].as_i64().expect("id");
    assert!(job.get("result").is_none(), "no result before the run: {job}");
    let done = h.wait_state(id, &["succeeded", "failed"], Duration::from_secs(60)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    let (_, samples) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    let rows = samples["samples"].as_array().expect("samples");
    assert!(rows.iter().all(|s| s["stage"] == "compaction" && s["strain"]["axes"].is_array()), "{}", rows[0]);
    let phi0 = rows[0]["phi"].as_f64().expect("phi");
    check_compaction(&done["result"], phi0);
    let mut grpc = h.grpc().await;
    let pb_job = grpc.get_job(pb::GetJobRequest { id }).await.expect("get").into_inner();
    let result: Value = serde_json::from_str(&pb_job.result_json).expect("result JSON");
    assert_eq!(result, done["result"]);
    // A plain job has no result.
    let (_, plain) = h.post("/v1/jobs", &scene(200, 4), None).await;
    let plain = plain["id"].as_i64().expect("id");
    let plain = h.wait_state(plain, &["succeeded"], Duration::from_secs(20)).await;
    assert!(plain.get("result").is_none(), "{plain}");

    // A remote worker sends the result with its FinishJob call.
    let Some(h) = Harness::start(backend, 0).await else { return };
    let (_, job) = h.post("/v1/jobs", &compaction_scene(), None).await;
    let id = job["id"].as_i64().expect("id");
    let remote = sable_worker::remote::RemoteSource::new(&format!("http://{}", h.server().grpc_addr)).expect("client");
    let mut pc = sable_worker::PoolConfig::new("remote", 1);
    pc.report_interval = Duration::from_millis(100);
    let pool = sable_worker::Pool::start(Arc::new(remote), pc, Arc::new(tokio::sync::Notify::new()));
    let done = h.wait_state(id, &["succeeded", "failed"], Duration::from_secs(60)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    check_compaction(&done["result"], phi0);
    // And the final state.
    let (status, state) = h.get(&format!("/v1/jobs/{id}/state")).await;
    assert_eq!(status, 200, "{state}");
    assert_eq!(state["particles"]["radius"].as_array().map(Vec::len), Some(60));
    pool.shutdown(Duration::from_secs(2)).await;
}

async fn a_job_starts_from_the_final_state_of_another(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (_, job) = h.post("/v1/jobs", &compaction_scene(), None).await;
    let first = job["id"].as_i64().expect("id");
    // No state before the job has succeeded.
    let (status, err) = h.get(&format!("/v1/jobs/{first}/state")).await;
    assert_eq!(status, 404, "{err}");
    let done = h.wait_state(first, &["succeeded", "failed"], Duration::from_secs(60)).await;
    assert_eq!(done["state"], "succeeded", "{done}");

    // The final state over REST and gRPC: the compacted box (strain 0.45 from 12 mm).
    let (status, state) = h.get(&format!("/v1/jobs/{first}/state")).await;
    assert_eq!(status, 200, "{state}");
    assert_eq!(state["format"], "sable-state");
    assert_eq!(state["particles"]["radius"].as_array().map(Vec::len), Some(60));
    let height = state["max"][1].as_f64().expect("max") - state["min"][1].as_f64().expect("min");
    assert!((height - 0.012 * (-0.45f64).exp()).abs() < 1e-4, "height {height}");
    let mut grpc = h.grpc().await;
    let gz = grpc.get_final_state(pb::GetFinalStateRequest { id: first }).await.expect("state").into_inner().state_gz;
    let text = sable_worker::source::gunzip(&gz, 1 << 30).expect("gzip");
    assert_eq!(serde_json::from_str::<Value>(&text).expect("JSON"), state);

    // A scene that starts from it: same grains, same box, the job keeps the reference.
    let next = json!({
        "name": "after compaction",
        "dimension": 2,
        "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "start_from": {"job": first},
        "container": {"wall_material": "glass"},
        "stop": {"steps": 200},
        "sampling": {"every_steps": 100}
    });
    let (status, job) = h.post("/v1/jobs", &next, None).await;
    assert_eq!(status, 201, "{job}");
    assert_eq!(job["scene"]["start_from"], json!({"job": first}));
    let second = job["id"].as_i64().expect("id");
    let done = h.wait_state(second, &["succeeded", "failed"], Duration::from_secs(60)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    let phi = |id: i64, last: bool| {
        let h = &h;
        async move {
            let (_, s) = h.get(&format!("/v1/jobs/{id}/samples")).await;
            let rows = s["samples"].as_array().expect("samples").clone();
            let row = if last { rows.last() } else { rows.first() };
            row.and_then(|r| r["phi"].as_f64()).expect("phi")
        }
    };
    let (before, after) = (phi(first, true).await, phi(second, false).await);
    assert!((before - after).abs() < 1e-9, "phi {before} then {after}");

    // A reference to no state, or to a state that does not fit, is refused; nothing is written.
    let jobs = h.jobs_in_db().await;
    let mut three_d = next.clone();
    three_d["dimension"] = json!(3);
    let mut queued = next.clone();
    queued["start_from"] = json!({"job": second + 100});
    for (scene, field) in [(queued, "scene.start_from.job"), (three_d, "scene.start_from.job.dimension")] {
        let (status, err) = h.post("/v1/jobs", &json!({"scene": scene}), None).await;
        assert_eq!(status, 422, "{err}");
        let fields: Vec<&str> = err["details"].as_array().expect("details").iter().filter_map(|v| v["field"].as_str()).collect();
        assert!(fields.contains(&field), "expected a violation on '{field}', got {err}");
    }
    assert_eq!(h.jobs_in_db().await, jobs);

    // A study of the scene that starts from it: checked with the state in place, its runs keep
    // the reference and start from the same particles; a missing state is refused.
    let study = json!({
        "scene": next,
        "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.01, 0.02]}]}],
        "measure": {"sample": "phi", "at": "min"},
        "reference": {"value": before}
    });
    let (status, created) = h.post("/v1/studies", &study, None).await;
    assert_eq!(status, 201, "{created}");
    let done = wait_study(&h, created["id"].as_i64().expect("id")).await;
    for p in done["report"]["points"].as_array().expect("points") {
        let job = h.get(&format!("/v1/jobs/{}", p["job_id"])).await.1;
        assert_eq!(job["scene"]["start_from"], json!({"job": first}));
        // Φ (the grains' volume over the box's) is the state's: same grains, same box.
        assert!(p["error"].as_f64().expect("error") < 1e-9, "{p}");
    }
    let mut missing = study.clone();
    missing["scene"]["start_from"] = json!({"job": second + 100});
    let (status, err) = h.post("/v1/studies", &missing, None).await;
    assert_eq!(status, 422, "{err}");
    assert_eq!(err["details"][0]["field"], "scene.start_from.job");
}

/// A rigid, slowly loaded biaxial test: the advisor takes contact dynamics for it.
fn rigid_biaxial(method: &str) -> Value {
    json!({
        "name": "rigid biaxial",
        "dimension": 2,
        "method": method,
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e8}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 30, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.01}
    })
}

async fn the_advisor_answers_without_running_and_auto_jobs_record_its_choice(backend: Backend) {
    let Some(h) = Harness::start(backend, 0).await else { return };
    // REST: the advice for a scene that names its method, and for a bad one.
    let (status, a) = h.post("/v1/advice", &json!({"scene": rigid_biaxial("dem")}), None).await;
    assert_eq!(status, 200, "{a}");
    assert_eq!((a["method"].as_str(), a["requested"].as_str(), a["regime"].as_str()), (Some("cd"), Some("dem"), Some("quasi_static")));
    assert!(a["reasons"].to_string().contains("rigid grains: κ = 1.0e5"), "{a}");
    assert!((a["numbers"]["stiffness_number"].as_f64().unwrap_or(0.0) - 1e5).abs() < 1e-6, "{a}");
    let mut bad = rigid_biaxial("auto");
    bad["materials"]["glass"]["density"] = json!(-1.0);
    let (status, err) = h.post("/v1/advice", &bad, None).await;
    assert_eq!(status, 422, "{err}");
    assert_eq!(err["details"][0]["field"], "materials.glass.density", "{err}");
    // gRPC: the same answer.
    let mut client = h.grpc().await;
    let g =
        client.advise(pb::AdviseRequest { scene_json: rigid_biaxial("auto").to_string() }).await.expect("advice over gRPC").into_inner();
    assert_eq!((g.method.as_str(), g.requested.as_str(), g.regime.as_str()), ("cd", "auto", "quasi_static"));
    assert_eq!(g.numbers.and_then(|n| n.stiffness_number), Some(1e5));
    // Nothing was stored by asking.
    assert_eq!(h.jobs_in_db().await, 0);
    // A job submitted with auto records the choice and its reasons.
    let (status, job) = h.post("/v1/jobs", &rigid_biaxial("auto"), None).await;
    assert_eq!(status, 201, "{job}");
    assert_eq!(job["method"], "cd");
    let reason = job["method_reason"].as_str().unwrap_or_default();
    assert!(reason.starts_with("auto chose cd: quasi-static loading: I = 1.6e-5"), "{reason}");
    assert!(reason.contains("rigid grains") && reason.contains("left out: capillary bridges"), "{reason}");
}

/// Two disks meeting head-on at 0.2 m/s (no gravity, no friction): a binary collision with
/// restitution 0.7, run with the DEM step at `fraction` of the collision time.
fn collision(fraction: f64) -> Value {
    json!({
        "name": "collision",
        "dimension": 2,
        "method": {"kind": "dem", "time_step_fraction": fraction, "threads": 1},
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.7, "friction": 0.0}},
        "particles": [{"material": "glass", "count": 2, "size": {"kind": "monodisperse", "diameter": 1e-3},
                       "placement": {"kind": "list", "positions": [[0.004, 0.005], [0.006, 0.005]], "velocities": [[0.1, 0.0], [-0.1, 0.0]]}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "stop": {"time": 0.008},
        "sampling": {"every_time": 0.002}
    })
}

async fn wait_study(h: &Harness, id: i64) -> Value {
    let start = Instant::now();
    loop {
        let (status, s) = h.get(&format!("/v1/studies/{id}")).await;
        assert_eq!(status, 200, "{s}");
        if s["state"] != "running" {
            return s;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "study {id} still running: {s}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

async fn a_study_runs_its_jobs_and_reports_errors_costs_and_a_chart(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let fractions = [0.005, 0.05, 0.3];
    let study = json!({
        "name": "restitution against the step",
        "scene": collision(0.02),
        "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": fractions}]}],
        "measure": {"derived": "restitution"},
        "reference": {"analytic": "restitution"}
    });
    let (status, created) = h.post("/v1/studies", &study, None).await;
    assert_eq!(status, 201, "{created}");
    assert_eq!((created["kind"].as_str(), created["runs"].as_u64()), (Some("sweep"), Some(3)));
    let done = wait_study(&h, created["id"].as_i64().expect("id")).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    let report = &done["report"];
    assert_eq!(report["reference"], 0.7);
    let points = report["points"].as_array().expect("points");
    assert_eq!(points.len(), 3);
    // The same scenes submitted by hand give the same measures, errors and costs.
    let mut scored = Vec::new();
    for ((p, f), label) in points.iter().zip(fractions).zip(["5e-3", "0.05", "0.3"]) {
        assert_eq!((p["series"].as_str(), p["label"].as_str(), p["state"].as_str()), (Some("DEM"), Some(label), Some("succeeded")));
        let job = h.get(&format!("/v1/jobs/{}", p["job_id"])).await.1;
        assert_eq!(job["scene"], collision_with(f), "the study's job runs the expanded scene");
        assert_eq!(p["cost"]["steps"], job["steps"]);
        assert_eq!(p["cost"]["wall_seconds"], job["wall_seconds"]);
        let cpu = job["cpu_seconds"].as_f64().expect("cpu seconds");
        assert!(cpu > 0.0 && p["cost"]["cpu_seconds"].as_f64() == Some(cpu), "{job}");
        let (_, mine) = h.post("/v1/jobs", &collision_with(f), None).await;
        let mine = h.wait_state(mine["id"].as_i64().expect("id"), &["succeeded"], Duration::from_secs(60)).await;
        let samples = h.get(&format!("/v1/jobs/{}/samples", mine["id"])).await.1;
        let s = samples["samples"].as_array().expect("samples");
        let ke = |k: usize| s[k]["kinetic_energy"].as_f64().expect("energy");
        let e = (ke(s.len() - 1) / ke(0)).sqrt();
        assert_eq!(p["measured"].as_f64(), Some(e), "run {f}");
        assert!((p["error"].as_f64().unwrap_or(-1.0) - (e - 0.7).abs()).abs() < 1e-15);
        assert!((p["relative_error"].as_f64().unwrap_or(-1.0) - (e - 0.7).abs() / 0.7).abs() < 1e-15);
        scored.push((cpu, (e - 0.7).abs(), p["pareto"].as_bool().expect("pareto flag")));
    }
    // The finest step is within 1% of the analytic restitution, the coarsest is not as close.
    assert!(scored[0].1 < 0.01 * 0.7 && scored[2].1 > scored[0].1, "{scored:?}");
    for (i, &(c, e, front)) in scored.iter().enumerate() {
        let beaten = scored.iter().enumerate().any(|(j, &(c2, e2, _))| j != i && c2 <= c && e2 <= e && (c2 < c || e2 < e));
        assert_eq!(front, !beaten, "Pareto flag of run {i}: {scored:?}");
    }
    let chart = h.http.get(format!("{}/v1/studies/{}/chart.svg", h.base, done["id"])).send().await.expect("chart");
    assert_eq!(chart.headers()["content-type"], "image/svg+xml");
    let svg = chart.text().await.expect("svg");
    for needle in ["<svg", "error against cost", "CPU time", "Pareto front", "DEM", "5e-3", "restitution"] {
        assert!(svg.contains(needle), "the chart lacks '{needle}'");
    }
    // The same chart as PNG: a 960 x 640 image.
    let png = h.http.get(format!("{}/v1/studies/{}/chart.png", h.base, done["id"])).send().await.expect("png");
    assert_eq!(png.headers()["content-type"], "image/png");
    let png = png.bytes().await.expect("bytes");
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 10_000, "{} bytes", png.len());
    let size = |k: usize| u32::from_be_bytes([png[k], png[k + 1], png[k + 2], png[k + 3]]);
    assert_eq!((size(16), size(20)), (960, 640));
    // A job's samples against time.
    let c =
        h.http.get(format!("{}/v1/jobs/{}/chart.svg?y=kinetic_energy&x=time", h.base, points[0]["job_id"])).send().await.expect("chart");
    assert_eq!(c.status(), 200);
    assert!(c.text().await.expect("svg").contains("kinetic_energy against time"));
    // Two jobs on one chart, each with its own field and its own unit of x.
    let (a, b) = (&points[0]["job_id"], &points[1]["job_id"]);
    let both = format!("{}/v1/jobs/{a}/chart.svg?y=kinetic_energy,phi&x=time&with={b}&x_unit=1e-3,2e-3", h.base);
    let c = h.http.get(both).send().await.expect("chart");
    assert_eq!(c.status(), 200);
    let svg = c.text().await.expect("svg");
    // A study's run is named in the legend by its series and values.
    for needle in [
        format!("job {a}, kinetic_energy, x over 1e-3: DEM 5e-3"),
        format!("job {b}, phi, x over 2e-3: DEM 0.05"),
        "kinetic_energy | phi against time over each job&apos;s unit".into(),
        "time / unit of the job".into(),
    ] {
        assert!(svg.contains(&needle), "the chart lacks '{needle}'");
    }
    assert!(!svg.contains("restitution against the step"), "the legend repeats the study's name");
    for (query, field) in [("x_unit=1", "x_unit"), ("x_unit=0,1", "x_unit"), ("y=p,q,phi", "y")] {
        let (status, err) = h.get(&format!("/v1/jobs/{a}/chart.svg?x=time&with={b}&{query}")).await;
        assert_eq!((status, err["details"][0]["field"].as_str()), (422, Some(field)), "{query}: {err}");
    }
    // The advice for the same scene quotes what the study measured: every run that succeeded,
    // those on its Pareto front marked.
    let (_, advice) = h.post("/v1/advice", &collision(0.02), None).await;
    let quoted = advice["expected_cost"].as_array().expect("expected cost");
    let ran: Vec<&Value> = points.iter().filter(|p| p["state"] == "succeeded").collect();
    assert_eq!(quoted.len(), ran.len(), "{advice}");
    for (q, p) in quoted.iter().zip(&ran) {
        assert_eq!((&q["study_id"], &q["label"], q["method"].as_str()), (&done["id"], &p["label"], Some("dem")));
        assert_eq!((&q["cpu_seconds"], &q["error"]), (&p["cost"]["cpu_seconds"], &p["relative_error"]));
        assert_eq!((&q["job_id"], &q["pareto"]), (&p["job_id"], &p["pareto"]));
    }
    // `auto` takes the method and parameters of the cheapest run within a percent of the
    // reference (every run is on the front or beaten by one that is), and says so.
    let within = points
        .iter()
        .filter(|p| p["relative_error"].as_f64().is_some_and(|e| e <= 0.01))
        .min_by(|a, b| a["cost"]["cpu_seconds"].as_f64().unwrap_or(0.0).total_cmp(&b["cost"]["cpu_seconds"].as_f64().unwrap_or(0.0)))
        .expect("the finest run is within a percent");
    let mut auto = collision(0.02);
    auto["method"] = json!("auto");
    let (status, job) = h.post("/v1/jobs", &auto, None).await;
    assert_eq!(status, 201, "{job}");
    let learned = h.get(&format!("/v1/jobs/{}", within["job_id"])).await.1;
    assert_eq!(job["scene"]["method"], learned["scene"]["method"], "{job}");
    let reason = job["method_reason"].as_str().unwrap_or_default();
    assert!(
        reason.starts_with(&format!("auto chose dem: study {} measured dem (DEM {})", done["id"], within["label"].as_str().unwrap_or("?"))),
        "{reason}"
    );
    // A bad study writes nothing.
    let before = h.jobs_in_db().await;
    let mut bad = study.clone();
    bad["series"][0]["sweep"][0]["values"] = json!([0.01, 0.9]);
    let (status, err) = h.post("/v1/studies", &bad, None).await;
    assert_eq!(status, 422, "{err}");
    assert_eq!(err["details"][0]["field"], "scene.method.time_step_fraction");
    assert!(
        err["details"][0]["rule"].as_str().unwrap_or_default().starts_with("in series 'DEM' with method.time_step_fraction = 0.9"),
        "{err}"
    );
    assert_eq!(h.jobs_in_db().await, before);
}

fn collision_with(fraction: f64) -> Value {
    let mut s = collision(0.02);
    s["method"]["time_step_fraction"] = json!(fraction);
    s
}

async fn a_stability_search_over_grpc_reports_the_limit_against_two_over_omega_zero(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let scene = common::bound_pair();
    let limit = 2.0 / (1e3 / (0.5 * 2500.0 * std::f64::consts::PI * 25e-8)).sqrt();
    let study = json!({
        "name": "bound pair",
        "scene": scene,
        "search": {"parameter": "method.time_step", "low": 0.8 * limit, "high": 1.25 * limit, "iterations": 4}
    });
    let mut client = sable_client::Client::connect(&format!("http://{}", h.server().grpc_addr)).await.expect("client");
    let s = client.create_study(&study.to_string()).await.expect("study accepted");
    assert_eq!((s.kind.as_str(), s.runs), ("search", 2));
    let start = Instant::now();
    let s = loop {
        let s = client.study(s.id).await.expect("study");
        if s.state != "running" {
            break s;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "search still running: {s:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    assert_eq!((s.state.as_str(), s.runs_done, s.runs), ("succeeded", 6, 6), "{s:?}");
    let r: Value = serde_json::from_str(&s.report_json).expect("report");
    let (stable, unstable) = (r["limit"]["stable"].as_f64().expect("stable"), r["limit"]["unstable"].as_f64().expect("unstable"));
    // Four halvings of a factor 1.5625 in log: the bracket is 1.5625^(1/16) = 2.8% wide.
    assert!(stable <= limit * (1.0 + 1e-9) && unstable > limit && unstable / stable < 1.03, "{r}");
    let ratio = r["theory"]["ratio"].as_f64().expect("ratio");
    assert!((0.95..=1.0 + 1e-9).contains(&ratio), "{r}");
    assert!(r["limit"]["mode"].is_string() && r["theory"]["what"].as_str().unwrap_or_default().starts_with("2/ω0"), "{r}");
    let svg = String::from_utf8(client.study_chart(s.id, "svg").await.expect("chart")).expect("utf-8");
    assert!(client.study_chart(s.id, "png").await.expect("png chart").starts_with(b"\x89PNG"));
    let e = client.study_chart(s.id, "gif").await.expect_err("no gif");
    assert!(e.to_string().contains("format: must be svg or png, got 'gif'"), "{e}");
    assert!(svg.contains("theory") && svg.contains("ran through (stable)") && svg.contains("failed: "), "chart");
    // A study with an unknown reference series is refused over gRPC too.
    let bad =
        json!({"scene": common::bound_pair(), "series": [{"label": "A"}], "measure": {"sample": "phi"}, "reference": {"finest": "B"}});
    let e = client.create_study(&bad.to_string()).await.expect_err("rejected");
    assert_eq!(e.code(), Some(tonic::Code::InvalidArgument));
    assert!(e.to_string().contains("reference.finest: no series is labelled 'B'"), "{e}");
}

async fn a_formula_reference_is_evaluated_for_each_run(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    // A disk settling on the floor stores (m g)^2 / (2 k_n) in its contact at rest.
    let grain = json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e4}, "restitution": 0.5, "friction": 0.0}},
        "particles": [{"material": "glass", "count": 1, "size": {"kind": "monodisperse", "diameter": 1e-3},
                       "placement": {"kind": "list", "positions": [[0.005, 0.000501]]}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "gravity": [0, -9.81],
        "stop": {"time": 0.2},
        "sampling": {"every_time": 0.05}
    });
    let m = 2500.0 * std::f64::consts::PI * 0.25e-6;
    let study = json!({
        "scene": grain,
        "series": [{"label": "DEM", "sweep": [{"parameter": "materials.glass.contact.k_n", "values": [1e3, 1e4, 1e5]}]}],
        "measure": {"sample": "elastic_energy"},
        "reference": {"formula": format!("({m} * 9.81)^2 / (2 * k_n)")}
    });
    let (status, created) = h.post("/v1/studies", &study, None).await;
    assert_eq!(status, 201, "{created}");
    let done = wait_study(&h, created["id"].as_i64().expect("id")).await;
    let points = done["report"]["points"].as_array().expect("points");
    for (p, k) in points.iter().zip([1e3, 1e4, 1e5]) {
        let expected = (m * 9.81f64).powi(2) / (2.0 * k);
        let reference = p["reference"].as_f64().expect("a reference per run");
        assert!((reference / expected - 1.0).abs() < 1e-12, "{p}");
        // At rest the contact holds the weight: the stored energy is the analytic one.
        assert!(p["relative_error"].as_f64().expect("error") < 1e-3, "{p}");
    }
    assert!(done["report"]["reference_source"].as_str().unwrap_or_default().starts_with("formula ("), "{done}");
    // A variable that no series sweeps is named in the error.
    let mut bad = study.clone();
    bad["reference"] = json!({"formula": "2 / k_t"});
    let (status, err) = h.post("/v1/studies", &bad, None).await;
    assert_eq!(status, 422, "{err}");
    assert_eq!(err["details"][0]["field"], "reference.formula");
    assert!(
        err["details"][0]["rule"]
            .as_str()
            .unwrap_or_default()
            .starts_with("'k_t' is not a numeric parameter of series 'DEM' (its variables: k_n)"),
        "{err}"
    );
}

/// Submits `scenes/{file}`, changed by `edit`, by HTTP; checks that it runs by `method` and
/// succeeds; returns its id and samples.
async fn run_shipped_scene(h: &Harness, file: &str, method: &str, edit: impl FnOnce(&mut Value)) -> (i64, Vec<Value>) {
    let path = format!("{}/../scenes/{file}", env!("CARGO_MANIFEST_DIR"));
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(&path).expect("scene")).expect("json");
    edit(&mut scene);
    let (status, job) = h.post("/v1/jobs", &json!({"scene": scene}), None).await;
    assert_eq!(status, 201, "{job}");
    assert_eq!(job["method"], method);
    let id = job["id"].as_i64().expect("id");
    let job = h.wait_state(id, &["succeeded", "failed"], Duration::from_secs(300)).await;
    assert_eq!(job["state"], "succeeded", "{job}");
    let (_, body) = h.get(&format!("/v1/jobs/{id}/samples")).await;
    (id, body["samples"].as_array().expect("samples").clone())
}

/// Deformable grains through the service: the CI compaction of soft disks
/// (`scenes/mpm_compaction_2d.json`, its wall twice as fast and cut at 400 steps, Φ 0.73, where
/// the grains press on each other: before Φ ≈ 0.67 the first ones the wall meets bounce, and Z
/// at one instant may be 0) submitted by HTTP, its samples queried back — Φ of the grains'
/// current area, Z, the stress and the `deformable` part — and the same rows in the database.
async fn a_soft_grain_compaction_runs_as_a_job(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (id, samples) = run_shipped_scene(&h, "mpm_compaction_2d.json", "mpm", |scene| {
        scene["container"]["walls"]["y_max"]["velocity"] = json!([0.0, -0.2]);
        scene["stop"] = json!({"steps": 400});
        scene["sampling"] = json!({"every_steps": 50});
    })
    .await;
    assert_eq!(samples.len(), 9);
    let phi: Vec<f64> = samples.iter().map(|s| s["phi"].as_f64().unwrap_or(0.0)).collect();
    assert!(phi.windows(2).all(|w| w[1] > w[0]), "Φ must grow as the wall comes down: {phi:?}");
    let last = samples.last().expect("last");
    assert!(last["z"].as_f64().unwrap_or(0.0) > 0.0, "no contact carries force: {last}");
    assert!(last["stress"]["yy"].as_f64().unwrap_or(0.0) > 0.0, "{last}");
    let d = &last["deformable"];
    assert!(d["min_jacobian"].as_f64().is_some_and(|j| j > 0.0 && j < 1.0), "{d}");
    let g = &last["grains"];
    assert!(g["mean_aspect_ratio"].as_f64().is_some_and(|a| a > 1.0), "{g}");
    assert_eq!(g["phi"], last["phi"], "a deformable grain is a particle: the grains' Φ is the sample's");
    let pool = h.db_pool().await;
    let (n, phi_last): (i64, f64) =
        sqlx::query_as("SELECT COUNT(*), MAX(phi) FROM samples WHERE job_id = $1").bind(id).fetch_one(&pool).await.expect("query");
    pool.close().await;
    assert_eq!(n, 9);
    assert!(phi.last().is_some_and(|&p| (phi_last - p).abs() < 1e-12), "{phi_last} against {phi:?}");
}

/// Aggregates through the service (issue 27): the DEM compaction of four aggregates
/// (`scenes/bpm_compaction_dem_2d.json`, cut at 3e4 steps, where the top wall has met the grains)
/// submitted by HTTP; its samples carry the grains' own Φ, Z and pressure beside the primaries',
/// and the same values are in the database (the sample's `grains` part, read by SQL).
async fn an_aggregate_compaction_runs_as_a_job_with_its_grain_measures_stored(backend: Backend) {
    let Some(h) = Harness::start(backend, 1).await else { return };
    let (id, samples) = run_shipped_scene(&h, "bpm_compaction_dem_2d.json", "dem", |scene| {
        scene["stop"] = json!({"steps": 30000});
        scene["sampling"] = json!({"every_steps": 5000});
    })
    .await;
    assert_eq!(samples.len(), 7);
    let grains: Vec<&Value> = samples.iter().map(|s| &s["grains"]).collect();
    assert!(grains.iter().all(|g| g["count"] == 4), "four aggregates: {grains:?}");
    let phi: Vec<f64> = grains.iter().map(|g| g["phi"].as_f64().unwrap_or(0.0)).collect();
    assert!(phi.windows(2).all(|w| w[1] > w[0]), "the grains' Φ must grow as the wall comes down: {phi:?}");
    // The sample's Φ is the grains' (issue 69); the grains' Φ counts the pores inside each grain:
    // above the primaries' own Φ, kept under `primaries`.
    for s in &samples {
        assert_eq!(s["phi"], s["grains"]["phi"], "a sample's Φ is its grains'");
        let (g, p) = (s["grains"]["phi"].as_f64().unwrap_or(0.0), s["primaries"]["phi"].as_f64().unwrap_or(1.0));
        assert!(g > p && g < 1.0, "grains' Φ {g} against the primaries' {p}");
    }
    // The wall meets the top grains within these steps: some sample has a loaded grain.
    assert!(grains.iter().any(|g| g["pressure"].as_f64().unwrap_or(0.0) > 0.0), "{grains:?}");
    assert!(grains.iter().all(|g| g["mean_aspect_ratio"].as_f64().is_some_and(|a| (1.0..1.5).contains(&a))), "{grains:?}");
    let pool = h.db_pool().await;
    let sql = format!(
        "SELECT {}, {}, {} FROM samples WHERE job_id = $1 ORDER BY seq",
        h.sample_field("grains.phi"),
        h.sample_field("grains.z"),
        h.sample_field("grains.pressure")
    );
    let stored: Vec<(f64, f64, f64)> = sqlx::query_as(&sql).bind(id).fetch_all(&pool).await.expect("query");
    pool.close().await;
    assert_eq!(stored.len(), samples.len());
    // A database's JSON parser may round the last digit of a double.
    let same = |db: f64, api: &Value| api.as_f64().is_some_and(|v| (db - v).abs() <= 1e-12 * v.abs().max(1.0));
    for (&(phi_db, z_db, p_db), g) in stored.iter().zip(&grains) {
        assert!(same(phi_db, &g["phi"]) && same(z_db, &g["z"]) && same(p_db, &g["pressure"]), "{:?} against {g}", (phi_db, z_db, p_db));
    }
}

/// Each test of the suite as a test on each back-end: `sqlite::NAME` and `postgres::NAME`.
macro_rules! on_both_backends {
    ($($name:ident),* $(,)?) => {
        /// The suite on SQLite, the default back-end.
        mod sqlite {
            $(
                #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
                async fn $name() {
                    super::$name(super::Backend::Sqlite).await
                }
            )*
        }

        /// The suite on PostgreSQL, each server on a fresh database of the throw-away test cluster.
        mod postgres {
            $(
                #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
                async fn $name() {
                    super::$name(super::Backend::Postgres).await
                }
            )*
        }
    };
}

on_both_backends!(
    submit_over_http_watch_over_grpc_and_read_samples,
    an_unstable_run_fails_with_the_engines_reason_and_stores_no_nan,
    the_same_idempotency_key_returns_the_same_job,
    cancelling_a_running_job_stops_it_within_a_second,
    a_worker_that_stops_reporting_loses_its_job_to_another,
    a_job_goes_on_from_its_checkpoint_after_a_crash_and_a_hand_back,
    a_checkpoint_a_worker_cannot_use_makes_the_job_start_over,
    random_grpc_requests_are_answered_and_change_nothing,
    a_restarted_server_finishes_the_job_that_was_running,
    a_stopped_server_hands_back_its_running_job_without_counting_an_attempt,
    fifty_concurrent_submissions_all_finish_once,
    a_watch_resumed_from_a_sequence_number_misses_nothing,
    bad_input_gets_a_clear_error_and_writes_nothing,
    long_runs_are_read_in_pages_and_lists_are_summaries,
    quiet_connections_are_closed_and_live_streams_are_not,
    worker_figures_and_unknown_enums_are_refused_by_name,
    health_metrics_and_openapi_describe_the_service,
    snapshots_are_stored_and_served_from_local_and_remote_workers,
    an_experiments_results_are_stored_with_its_job,
    a_job_starts_from_the_final_state_of_another,
    the_advisor_answers_without_running_and_auto_jobs_record_its_choice,
    a_study_runs_its_jobs_and_reports_errors_costs_and_a_chart,
    a_stability_search_over_grpc_reports_the_limit_against_two_over_omega_zero,
    a_formula_reference_is_evaluated_for_each_run,
    a_soft_grain_compaction_runs_as_a_job,
    an_aggregate_compaction_runs_as_a_job_with_its_grain_measures_stored,
);
