//! Recovery after a real crash: `sable serve` killed with SIGKILL while a job runs, then started
//! again on the same database, finishes the job — once, going on from its last checkpoint; and a
//! job's own process killed with SIGKILL fails that job only.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

fn start(db: &std::path::Path, http: u16, grpc: u16) -> Child {
    start_with(db, http, grpc, &[])
}

/// As [`start`], with `more` arguments.
fn start_with(db: &std::path::Path, http: u16, grpc: u16, more: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["serve", "--workers", "1", "--threads-per-job", "1", "--lease-seconds", "2", "--checkpoint-every", "0.3"])
        .args(more)
        .arg("--db")
        .arg(db)
        .args(["--http", &format!("127.0.0.1:{http}"), "--grpc", &format!("127.0.0.1:{grpc}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("sable serve starts")
}

/// 40 disks settling under gravity for `steps` steps, a sample every `every`.
fn settle(steps: u64, every: u64) -> Value {
    json!({
        "name": "settle", "dimension": 2, "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 40, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "gravity": [0, -9.81],
        "stop": {"steps": steps},
        "sampling": {"every_steps": every},
        "seed": 3
    })
}

/// Submits `scene` to the server at `base` as soon as it listens (within 20 s); the job.
async fn submit_once_up(client: &reqwest::Client, base: &str, scene: &Value) -> Value {
    let start = Instant::now();
    loop {
        if let Ok(r) = client.post(format!("{base}/v1/jobs")).json(scene).send().await {
            return r.json::<Value>().await.expect("job");
        }
        assert!(start.elapsed() < Duration::from_secs(20), "sable serve did not start");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

async fn get(client: &reqwest::Client, url: &str) -> Option<Value> {
    client.get(url).send().await.ok()?.json().await.ok()
}

async fn wait_state(client: &reqwest::Client, url: &str, state: &str, timeout: Duration) -> Value {
    let start = Instant::now();
    loop {
        if let Some(job) = get(client, url).await {
            if job["state"] == state {
                return job;
            }
        }
        assert!(start.elapsed() < timeout, "{url} did not reach {state} in {timeout:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[tokio::test]
async fn a_server_killed_with_sigkill_finishes_its_job_after_restart() {
    let dir = tempfile::tempdir().expect("temp dir");
    let db = dir.path().join("sable.db");
    let (http, grpc) = (free_port(), free_port());
    let base = format!("http://127.0.0.1:{http}");
    let client = reqwest::Client::new();
    let mut server = start(&db, http, grpc);
    let scene = settle(2_000_000, 200_000);
    let job = submit_once_up(&client, &base, &scene).await;
    let url = format!("{base}/v1/jobs/{}", job["id"]);
    wait_state(&client, &url, "running", Duration::from_secs(20)).await;
    // A fifth of the way: checkpoints have been taken.
    let running = Instant::now();
    while get(&client, &url).await.and_then(|j| j["progress"].as_f64()).unwrap_or(0.0) < 0.2 {
        assert!(running.elapsed() < Duration::from_secs(30), "the job does not progress");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    server.kill().expect("SIGKILL");
    server.wait().expect("reaped");

    let mut server = start(&db, http, grpc);
    let done = wait_state(&client, &url, "succeeded", Duration::from_secs(120)).await;
    assert_eq!(done["attempts"], 2, "{done}");
    assert_eq!(done["steps"], 2000000);
    assert_eq!(done["sample_count"], 11, "samples of the killed attempt are replaced, not duplicated: {done}");
    // The second attempt went on from a checkpoint of the first (one every 0.3 s).
    let store = sable_server::store::JobStore::open(
        &sable_server::store::DbLocation::Sqlite(db.clone()),
        sable_server::store::LeaseConfig { ttl: Duration::from_secs(2) },
    )
    .await
    .expect("the database");
    let events = store.events_after(job["id"].as_i64().expect("id"), 0, 1000).await.expect("events");
    let resumed: Vec<i64> = events
        .iter()
        .filter_map(|e| serde_json::from_str::<Value>(&e.payload).ok())
        .filter(|p| p["state"] == "running")
        .map(|p| p["resumed_from_step"].as_i64().unwrap_or(0))
        .collect();
    assert!(resumed.len() == 2 && resumed[1] > 0, "the attempts went on from steps {resumed:?}");
    server.kill().expect("stop");
    let _ = server.wait();
}

/// The `job-run` processes `pid` started.
fn job_processes(pid: u32) -> Vec<i32> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let Ok(child) = entry.file_name().to_string_lossy().parse::<i32>() else { continue };
        let stat = std::fs::read_to_string(format!("/proc/{child}/stat")).unwrap_or_default();
        // pid (comm) state ppid ...: the fields after the command's closing parenthesis.
        let ppid = stat.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().nth(1)).and_then(|p| p.parse::<u32>().ok());
        let cmdline = std::fs::read_to_string(format!("/proc/{child}/cmdline")).unwrap_or_default();
        if ppid == Some(pid) && cmdline.contains("job-run") {
            found.push(child);
        }
    }
    found
}

/// Issue 71, finding 1: a job that aborts its process (an allocation the machine cannot make
/// aborts, as SIGKILL does here) fails with code `crashed`, saying how its process ended, and
/// the server and its workers go on with the next job. Before, jobs ran on a thread of the
/// server's process: such a job killed the server, and every restart ran it again.
#[tokio::test]
async fn a_job_whose_process_is_killed_fails_alone() {
    let dir = tempfile::tempdir().expect("temp dir");
    let db = dir.path().join("sable.db");
    let (http, grpc) = (free_port(), free_port());
    let base = format!("http://127.0.0.1:{http}");
    let client = reqwest::Client::new();
    let mut server = start(&db, http, grpc);
    let job = submit_once_up(&client, &base, &settle(1_000_000_000, 100_000)).await;
    let url = format!("{base}/v1/jobs/{}", job["id"]);
    wait_state(&client, &url, "running", Duration::from_secs(20)).await;
    let started = Instant::now();
    let victims = loop {
        let found = job_processes(server.id());
        if !found.is_empty() || started.elapsed() > Duration::from_secs(10) {
            break found;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert_eq!(victims.len(), 1, "one job, one process");
    let killed = Command::new("kill").args(["-9", &victims[0].to_string()]).status().expect("kill runs");
    assert!(killed.success(), "kill -9 {}", victims[0]);
    let failed = wait_state(&client, &url, "failed", Duration::from_secs(20)).await;
    assert_eq!(failed["error"]["code"], "crashed", "{failed}");
    assert!(failed["error"]["message"].as_str().unwrap_or_default().contains("killed by SIGKILL"), "{failed}");
    assert_eq!(failed["attempts"], 1, "not run again: {failed}");

    // The server and its worker go on.
    let next = client
        .post(format!("{base}/v1/jobs"))
        .json(&settle(20_000, 1_000))
        .send()
        .await
        .expect("submit")
        .json::<Value>()
        .await
        .expect("job");
    let done = wait_state(&client, &format!("{base}/v1/jobs/{}", next["id"]), "succeeded", Duration::from_secs(60)).await;
    assert_eq!(done["sample_count"], 21, "{done}");
    server.kill().expect("stop");
    let _ = server.wait();
}

/// With `--job-memory`, a job that needs more than its bound fails with
/// code `crashed`, saying it ran out of memory (the allocator's own words quoted), rather than
/// being killed by the kernel with no word; the next job runs.
#[tokio::test]
async fn a_job_past_its_memory_bound_fails_saying_so() {
    let dir = tempfile::tempdir().expect("temp dir");
    let db = dir.path().join("sable.db");
    let (http, grpc) = (free_port(), free_port());
    let base = format!("http://127.0.0.1:{http}");
    let client = reqwest::Client::new();
    let mut server = start_with(&db, http, grpc, &["--job-memory", "0.25"]);
    // A million disks: several hundred megabytes of arrays, more than a quarter of a GiB.
    let mut big = settle(10, 10);
    big["particles"][0]["count"] = 1_000_000.into();
    big["container"]["max"] = serde_json::json!([2.0, 2.0]);
    let job = submit_once_up(&client, &base, &big).await;
    assert!(job["id"].is_i64(), "{job}");
    let failed = wait_state(&client, &format!("{base}/v1/jobs/{}", job["id"]), "failed", Duration::from_secs(60)).await;
    assert_eq!(failed["error"]["code"], "crashed", "{failed}");
    let message = failed["error"]["message"].as_str().unwrap_or_default();
    assert!(message.contains("ran out of memory") && message.contains("memory allocation of"), "{failed}");
    let next = client.post(format!("{base}/v1/jobs")).json(&settle(2_000, 1_000)).send().await.expect("submit");
    let next = next.json::<Value>().await.expect("job");
    wait_state(&client, &format!("{base}/v1/jobs/{}", next["id"]), "succeeded", Duration::from_secs(60)).await;
    server.kill().expect("stop");
    let _ = server.wait();
}
