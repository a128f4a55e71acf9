//! Faults across servers on one PostgreSQL, with real processes: `sable serve` and
//! `sable worker` killed with SIGKILL mid-run, and PostgreSQL itself restarted under load.
//! Every accepted job must finish exactly once (one final state event, its samples stored once)
//! and a study must finish although the server driving it may be the one killed.
//!
//! PostgreSQL comes from `common/postgres.rs`; without it the tests skip with a message (and
//! fail under `SABLE_REQUIRE_POSTGRES=1`, as in CI).

use crate::common;

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use sqlx::postgres::PgPool;

use common::postgres;

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

/// Processes killed when the test ends, whichever way it ends.
#[derive(Default)]
struct Procs(Vec<Child>);

impl Drop for Procs {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A `sable serve` on `db` with one local worker; returns (REST base URL, gRPC URL, process).
fn serve(db: &str, workers: usize) -> (String, String, Child) {
    let (http, grpc) = (free_port(), free_port());
    let child = Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["serve", "--threads-per-job", "1", "--lease-seconds", "2"])
        .args(["--workers", &workers.to_string(), "--db", db])
        .args(["--http", &format!("127.0.0.1:{http}"), "--grpc", &format!("127.0.0.1:{grpc}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("sable serve starts");
    (format!("http://127.0.0.1:{http}"), format!("http://127.0.0.1:{grpc}"), child)
}

/// A `sable worker` process with one worker leasing from `grpc`.
fn worker(grpc: &str, name: &str) -> Child {
    Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["worker", "--workers", "1", "--threads-per-job", "1", "--server", grpc, "--name", name])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("sable worker starts")
}

/// A tiny job: 30 disks settling for `steps` steps, a sample every `steps / 4` (5 samples).
fn tiny(seed: u64, steps: u64) -> Value {
    json!({
        "name": "tiny", "dimension": 2, "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 30, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "gravity": [0, -9.81],
        "stop": {"steps": steps},
        "sampling": {"every_steps": steps / 4},
        "seed": seed
    })
}

/// Waits until `base` answers.
async fn ready(http: &reqwest::Client, base: &str) {
    let start = Instant::now();
    while !http.get(format!("{base}/healthz")).send().await.map(|r| r.status().is_success()).unwrap_or(false) {
        assert!(start.elapsed() < Duration::from_secs(30), "{base} did not start");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Posts `body` to `url`; the job or study id if it was accepted (201), else the answer.
async fn post(http: &reqwest::Client, url: &str, body: &Value) -> Result<i64, String> {
    let r = http.post(url).json(body).send().await.map_err(|e| e.to_string())?;
    let status = r.status().as_u16();
    let answer: Value = r.json().await.unwrap_or(Value::Null);
    match (status, answer["id"].as_i64()) {
        (201, Some(id)) => Ok(id),
        _ => Err(format!("{status}: {answer}")),
    }
}

/// [`post`]'s id, if accepted.
async fn accepted(http: &reqwest::Client, url: &str, body: &Value) -> Option<i64> {
    post(http, url, body).await.ok()
}

async fn count(pool: &PgPool, sql: &str) -> i64 {
    sqlx::query_scalar(sql).fetch_one(pool).await.unwrap_or_else(|e| panic!("{sql}: {e}"))
}

async fn wait_ended(pool: &PgPool, want: i64, timeout: Duration) {
    let start = Instant::now();
    loop {
        let ended = sqlx::query_scalar::<_, i64>("SELECT COUNT(*) FROM jobs WHERE state IN ('succeeded', 'failed', 'cancelled')")
            .fetch_one(pool)
            .await
            .unwrap_or(0);
        if ended >= want {
            return;
        }
        assert!(start.elapsed() < timeout, "{ended} of {want} jobs ended in {timeout:?}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Every job of `pool` succeeded once: one final state event each, `samples` samples each,
/// none stored twice.
async fn each_job_finished_once(pool: &PgPool, jobs: i64, samples: i64) {
    assert_eq!(count(pool, "SELECT COUNT(*) FROM jobs").await, jobs);
    let not_ok: Vec<(i64, String, Option<String>)> =
        sqlx::query_as("SELECT id, state, error_message FROM jobs WHERE state <> 'succeeded'").fetch_all(pool).await.expect("query");
    assert!(not_ok.is_empty(), "jobs that did not succeed: {not_ok:?}");
    let finals = count(
        pool,
        "SELECT COUNT(*) FROM (SELECT job_id FROM job_events WHERE kind = 'state' AND payload LIKE '%\"state\":\"succeeded\"%' \
         GROUP BY job_id HAVING COUNT(*) = 1) t",
    )
    .await;
    assert_eq!(finals, jobs, "each job has exactly one final state event");
    let wrong =
        count(pool, &format!("SELECT COUNT(*) FROM jobs j WHERE (SELECT COUNT(*) FROM samples s WHERE s.job_id = j.id) <> {samples}"))
            .await;
    assert_eq!(wrong, 0, "every job has its {samples} samples");
    let twice = count(pool, "SELECT COUNT(*) FROM (SELECT job_id, step FROM samples GROUP BY job_id, step HAVING COUNT(*) > 1) t").await;
    assert_eq!(twice, 0, "no sample is stored twice");
    let sample_events = count(pool, "SELECT COUNT(*) FROM job_events WHERE kind = 'sample'").await;
    assert!(sample_events >= jobs * samples, "{sample_events} sample events");
}

/// Two servers and three worker processes on one PostgreSQL; 500 jobs submitted to both and a
/// study to the first; the first server and one worker are killed with SIGKILL mid-run. Every
/// job finishes exactly once and the study finishes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_servers_three_workers_and_sigkill_lose_and_repeat_nothing() {
    let Some(pg) = postgres::server() else { return };
    let db = postgres::fresh_database(pg).await;
    let mut procs = Procs::default();
    let http = reqwest::Client::new();
    let (a, a_grpc, server_a) = serve(&db, 1);
    procs.0.push(server_a);
    ready(&http, &a).await;
    // A starts first and takes the study driver's role at its first round.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let (b, b_grpc, server_b) = serve(&db, 1);
    procs.0.push(server_b);
    ready(&http, &b).await;
    procs.0.push(worker(&b_grpc, "w1"));
    procs.0.push(worker(&b_grpc, "w2"));
    procs.0.push(worker(&a_grpc, "w3"));

    let study = json!({
        "scene": tiny(1, 2000),
        "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.05, 0.1, 0.2]}]}],
        "measure": {"sample": "phi"},
        "reference": {"finest": "DEM"}
    });
    let study_id = post(&http, &format!("{a}/v1/studies"), &study).await.expect("the study is accepted");
    let mut submitted = 0;
    for chunk in 0..50u64 {
        let mut set = tokio::task::JoinSet::new();
        for k in 0..10u64 {
            let base = if k % 2 == 0 { a.clone() } else { b.clone() };
            let http = http.clone();
            set.spawn(async move { accepted(&http, &format!("{base}/v1/jobs"), &tiny(chunk * 10 + k, 2000)).await });
        }
        while let Some(r) = set.join_next().await {
            assert!(r.expect("task").is_some(), "a submission was refused");
            submitted += 1;
        }
    }
    assert_eq!(submitted, 500);

    let pool = PgPool::connect(&db).await.expect("connect");
    wait_ended(&pool, 150, Duration::from_secs(120)).await;
    // SIGKILL server A (and with it its local worker) and worker w1 mid-run.
    for victim in [0, 2] {
        procs.0[victim].kill().expect("SIGKILL");
        procs.0[victim].wait().expect("reaped");
    }
    let killed_at = count(&pool, "SELECT COUNT(*) FROM jobs WHERE state = 'succeeded'").await;
    wait_ended(&pool, 503, Duration::from_secs(300)).await;
    each_job_finished_once(&pool, 503, 5).await;
    let again = count(&pool, "SELECT COUNT(*) FROM jobs WHERE attempts > 1").await;
    eprintln!("killed after {killed_at} of 503 jobs had succeeded; {again} job(s) ran again after losing their worker");

    // The study finished although its driver may have been the server killed.
    let start = Instant::now();
    loop {
        let s: Value = http.get(format!("{b}/v1/studies/{study_id}")).send().await.expect("GET").json().await.expect("JSON");
        if s["state"] == "succeeded" {
            assert_eq!(s["report"]["points"].as_array().map(Vec::len), Some(3), "{s}");
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "the study did not finish: {s}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    pool.close().await;
}

/// PostgreSQL restarted while a server runs jobs and takes submissions: the server reconnects,
/// and every job it accepted, before, during or after the restart, finishes exactly once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn postgres_restarted_under_load_loses_no_accepted_job() {
    let Some(cluster) = postgres::Cluster::private("postgres-test-restart") else { return };
    let db = postgres::fresh_database(&cluster.server()).await;
    let mut procs = Procs::default();
    let http = reqwest::Client::new();
    let (base, grpc, server) = serve(&db, 2);
    procs.0.push(server);
    ready(&http, &base).await;

    let mut ids = Vec::new();
    for k in 0..40 {
        ids.push(accepted(&http, &format!("{base}/v1/jobs"), &tiny(k, 20_000)).await.expect("accepted"));
    }
    let pool = PgPool::connect(&db).await.expect("connect");
    wait_ended(&pool, 5, Duration::from_secs(120)).await;
    // A client following the last job (queued) through the outage: its event stream must wait
    // for the database and go on, not end with an error while the job goes on.
    let last = *ids.last().expect("a job");
    let follow = {
        let http = http.clone();
        let url = format!("{base}/v1/jobs/{last}/events");
        tokio::spawn(async move {
            let mut r = http.get(url).send().await.expect("events");
            let mut text = String::new();
            while let Ok(Some(chunk)) = r.chunk().await {
                text.push_str(&String::from_utf8_lossy(&chunk));
                if text.contains("\"succeeded\"") || text.contains("event: error") {
                    break;
                }
            }
            text
        })
    };
    // Jobs under way when the database stops: polled until there is one, since the two workers
    // may both be between jobs at any one instant (each job starts a process of its own).
    let start = Instant::now();
    let running: Vec<i64> = loop {
        let running: Vec<i64> = sqlx::query_scalar("SELECT id FROM jobs WHERE state = 'running'").fetch_all(&pool).await.expect("running");
        if !running.is_empty() || start.elapsed() > Duration::from_secs(30) {
            break running;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    pool.close().await;
    cluster.stop();
    // Submissions while PostgreSQL is down are refused, not half-written: 503 within the pool's
    // 3 s (they took 10 s and were answered 500).
    let t0 = Instant::now();
    let mut refused = 0;
    let mut down = tokio::task::JoinSet::new();
    for k in 40..45 {
        let (http, url) = (http.clone(), format!("{base}/v1/jobs"));
        down.spawn(async move {
            let t = Instant::now();
            (post(&http, &url, &tiny(k, 20_000)).await, t.elapsed())
        });
    }
    while let Some(r) = down.join_next().await {
        match r.expect("task") {
            (Ok(id), _) => ids.push(id),
            (Err(answer), took) => {
                assert!(answer.starts_with("503") && took < Duration::from_secs(6), "while down, after {took:?}: {answer}");
                refused += 1;
            }
        }
    }
    let health = http.get(format!("{base}/healthz")).send().await.expect("healthz").status().as_u16();
    assert_eq!(health, 503, "/healthz while the database is down");
    // A gRPC client (as `sable submit --watch`) that starts following the last job while the
    // database is down: its stream is refused (UNAVAILABLE) until the database is back, and it
    // keeps asking (it gave up after five tries, about 12 s, before).
    let grpc_follow = {
        let client = sable_client::Client::connect(&grpc).await.expect("gRPC client");
        tokio::spawn(async move {
            use tokio_stream::StreamExt;
            let events = client.watch(last, 0);
            tokio::pin!(events);
            let mut ended = None;
            while let Some(e) = events.next().await {
                match e {
                    Ok(ev) => {
                        if let Some(sable_proto::v1::job_event::Kind::State(st)) = ev.kind {
                            if st.state == sable_client::JobState::Succeeded as i32 {
                                ended = Some(Ok(()));
                            }
                        }
                    }
                    Err(err) => {
                        ended = Some(Err(err.to_string()));
                        break;
                    }
                }
            }
            ended
        })
    };
    eprintln!("down: {refused} refused in {:?}", t0.elapsed());
    // Down for longer than the lease (2 s) and an event stream's heartbeat (15 s).
    tokio::time::sleep(Duration::from_secs(16).saturating_sub(t0.elapsed())).await;
    cluster.start().expect("PostgreSQL starts again");
    // And accepted again once it is back (the pool reconnects).
    let start = Instant::now();
    let mut k = 45;
    while ids.len() < 50 {
        if let Some(id) = accepted(&http, &format!("{base}/v1/jobs"), &tiny(k, 20_000)).await {
            ids.push(id);
        }
        k += 1;
        assert!(start.elapsed() < Duration::from_secs(60), "submissions are still refused after the restart");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    eprintln!("back: accepting again {:?} after the stop", t0.elapsed());
    let pool = PgPool::connect(&db).await.expect("connect");
    wait_ended(&pool, ids.len() as i64, Duration::from_secs(300)).await;
    eprintln!("all {} accepted jobs ended {:?} after the stop", ids.len(), t0.elapsed());
    each_job_finished_once(&pool, ids.len() as i64, 5).await;
    // The jobs running when the database went away kept their leases (renewed when it came
    // back): none was run again from its start for the database's fault.
    let attempts: Vec<(i64, i64)> = sqlx::query_as("SELECT id, attempts FROM jobs WHERE id = ANY($1) ORDER BY id")
        .bind(&running)
        .fetch_all(&pool)
        .await
        .expect("attempts");
    assert!(!attempts.is_empty() && attempts.iter().all(|&(_, n)| n == 1), "attempts of the jobs running at the stop: {attempts:?}");
    let through = grpc_follow.await.expect("the gRPC follower");
    assert_eq!(through, Some(Ok(())), "the gRPC watch begun during the outage");
    let seen = follow.await.expect("the follower");
    assert!(seen.contains("\"succeeded\"") && !seen.contains("event: error"), "the event stream through the outage: {seen}");
    let stored: Vec<i64> = sqlx::query_scalar("SELECT id FROM jobs ORDER BY id").fetch_all(&pool).await.expect("ids");
    ids.sort();
    assert_eq!(stored, ids, "the stored jobs are exactly those accepted");
    eprintln!("{refused} submission(s) refused while PostgreSQL was down");
    pool.close().await;
}
