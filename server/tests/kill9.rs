//! Recovery after a real crash: `sable serve` killed with SIGKILL while a job runs, then started
//! again on the same database, finishes the job — once.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

fn start(db: &std::path::Path, http: u16, grpc: u16) -> Child {
    Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["serve", "--workers", "1", "--threads-per-job", "1", "--lease-seconds", "2"])
        .arg("--db")
        .arg(db)
        .args(["--http", &format!("127.0.0.1:{http}"), "--grpc", &format!("127.0.0.1:{grpc}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("sable serve starts")
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
    let scene = json!({
        "name": "settle", "dimension": 2, "method": "dem",
        "materials": {"glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 40, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "gravity": [0, -9.81],
        "stop": {"steps": 2000000},
        "sampling": {"every_steps": 200000},
        "seed": 3
    });
    // The server needs a moment to listen.
    let start_wait = Instant::now();
    let job = loop {
        if let Ok(r) = client.post(format!("{base}/v1/jobs")).json(&scene).send().await {
            break r.json::<Value>().await.expect("job");
        }
        assert!(start_wait.elapsed() < Duration::from_secs(20), "sable serve did not start");
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let url = format!("{base}/v1/jobs/{}", job["id"]);
    wait_state(&client, &url, "running", Duration::from_secs(20)).await;
    server.kill().expect("SIGKILL");
    server.wait().expect("reaped");

    let mut server = start(&db, http, grpc);
    let done = wait_state(&client, &url, "succeeded", Duration::from_secs(120)).await;
    assert_eq!(done["attempts"], 2, "{done}");
    assert_eq!(done["steps"], 2000000);
    assert_eq!(done["sample_count"], 11, "samples of the killed attempt are replaced, not duplicated: {done}");
    server.kill().expect("stop");
    let _ = server.wait();
}
