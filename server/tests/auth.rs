//! Bearer tokens (server/src/auth.rs) through both APIs: a user's token for the REST API and
//! gRPC Simulations, a worker's token for gRPC Workers, neither usable for the other; health
//! and the dashboard's files open; no server without tokens on an address others can reach.

use std::sync::Arc;
use std::time::Duration;

use sable_server::auth::Tokens;
use sable_server::serve::ServeError;
use sable_server::{ServeConfig, Server};
use sable_worker::JobSource;

use crate::common::scenes::tiny as scene;

const USER: &str = "user-token-0123456789abcdef";
const WORKER: &str = "worker-token-0123456789abcdef";

fn config(dir: &tempfile::TempDir, tokens: Tokens) -> ServeConfig {
    ServeConfig {
        db: sable_server::store::DbLocation::Sqlite(dir.path().join("sable.db")),
        http: "127.0.0.1:0".parse().expect("addr"),
        grpc: "127.0.0.1:0".parse().expect("addr"),
        workers: 0,
        tokens: Arc::new(tokens),
        ..Default::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn users_and_workers_each_need_their_own_token() {
    let dir = tempfile::tempdir().expect("dir");
    let server = Server::start(config(&dir, Tokens::new(vec![USER.into()], vec![WORKER.into()]))).await.expect("starts");
    let base = format!("http://{}", server.http_addr);
    let grpc = format!("http://{}", server.grpc_addr);
    let http = reqwest::Client::new();

    // REST: no token 401 (with WWW-Authenticate), a worker's 403, a user's 200.
    let r = http.get(format!("{base}/v1/jobs")).send().await.expect("answer");
    assert_eq!(r.status(), 401);
    assert_eq!(r.headers().get("www-authenticate").and_then(|v| v.to_str().ok()), Some("Bearer"));
    let body: serde_json::Value = r.json().await.expect("json");
    assert_eq!(body["code"], "unauthenticated", "{body}");
    let r = http.get(format!("{base}/v1/jobs")).bearer_auth(WORKER).send().await.expect("answer");
    assert_eq!(r.status(), 403);
    let r = http.get(format!("{base}/v1/jobs")).bearer_auth("some-other-token-0123456789").send().await.expect("answer");
    assert_eq!(r.status(), 401);
    let r = http.post(format!("{base}/v1/jobs")).bearer_auth(USER).body(scene()).send().await.expect("answer");
    assert_eq!(r.status(), 201, "{:?}", r.text().await);
    // A browser's event stream or image gives the token in the query, on GET only.
    assert_eq!(http.get(format!("{base}/v1/jobs?access_token={USER}")).send().await.expect("answer").status(), 200);
    assert_eq!(http.post(format!("{base}/v1/jobs?access_token={USER}")).body(scene()).send().await.expect("answer").status(), 401);
    assert_eq!(http.get(format!("{base}/metrics")).send().await.expect("answer").status(), 401);
    // Open: health and the dashboard's files.
    assert_eq!(http.get(format!("{base}/healthz")).send().await.expect("answer").status(), 200);
    assert_eq!(http.get(format!("{base}/")).send().await.expect("answer").status(), 200);

    // gRPC Simulations: the same rule.
    let mut anonymous = sable_client::Client::connect(&grpc).await.expect("connects");
    let e = anonymous.get(1).await.expect_err("no token");
    assert_eq!(e.code(), Some(tonic::Code::Unauthenticated), "{e}");
    let mut as_worker = sable_client::Client::connect_with_token(&grpc, Some(WORKER)).await.expect("connects");
    assert_eq!(as_worker.get(1).await.expect_err("worker token").code(), Some(tonic::Code::PermissionDenied));
    let mut user = sable_client::Client::connect_with_token(&grpc, Some(USER)).await.expect("connects");
    let job = user.submit(&scene(), sable_client::SubmitOptions::default()).await.expect("a user submits");

    // gRPC Workers: only a worker's token leases.
    for token in [None, Some(USER)] {
        let source = sable_worker::remote::RemoteSource::with_token(&grpc, token).expect("source");
        let e = source.lease("intruder").await.expect_err("not a worker").to_string();
        assert!(e.contains("worker's token"), "{token:?}: {e}");
    }
    let source = sable_worker::remote::RemoteSource::with_token(&grpc, Some(WORKER)).expect("source");
    let lease = source.lease("w").await.expect("a worker leases").expect("a job");
    let done = sable_worker::Outcome::Succeeded {
        steps: 100,
        wall_seconds: 0.0,
        cpu_seconds: 0.0,
        solver_iterations: 0,
        result: None,
        state: None,
    };
    source.finish(&lease, done).await.expect("and finishes");
    assert!(lease.job_id >= job.id - 1);

    // A `sable worker` with a user's token stops at once with the reason, rather than asking
    // for jobs forever.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["worker", "--workers", "1", "--server", &grpc, "--token", USER])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("sable worker runs");
    let started = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if started.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            panic!("sable worker with a user's token did not stop by itself");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().expect("piped"), &mut stderr).expect("stderr");
    assert!(!status.success() && stderr.contains("refuses this worker") && stderr.contains("worker's token"), "{stderr}");
    server.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn no_server_without_tokens_on_an_address_others_can_reach() {
    let dir = tempfile::tempdir().expect("dir");
    let mut cfg = config(&dir, Tokens::default());
    cfg.http = "0.0.0.0:0".parse().expect("addr");
    match Server::start(cfg.clone()).await {
        Err(ServeError::Exposed(why)) => assert!(why.contains("--user-tokens") && why.contains("--no-auth"), "{why}"),
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("started without tokens on 0.0.0.0"),
    }
    cfg.no_auth = true;
    let server = Server::start(cfg).await.expect("--no-auth: the operator's choice");
    server.shutdown(Duration::from_secs(2)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn edited_token_files_grant_and_revoke_without_a_restart() {
    let dir = tempfile::tempdir().expect("dir");
    let (users, workers) = (dir.path().join("users"), dir.path().join("workers"));
    let (alice, bob, worker2) = ("alice-token-0123456789abcdef", "bob-token-0123456789abcdef", "worker2-token-0123456789abcdef");
    std::fs::write(&users, format!("{alice}\n")).expect("write");
    std::fs::write(&workers, format!("{WORKER}\n")).expect("write");
    let mut cfg = config(&dir, Tokens::from_files(Some(&users), Some(&workers)).expect("token files"));
    cfg.token_reload = Duration::from_millis(100);
    let server = Server::start(cfg).await.expect("starts");
    let base = format!("http://{}", server.http_addr);
    let grpc = format!("http://{}", server.grpc_addr);
    let http = reqwest::Client::new();
    let status = |token: &'static str| {
        let (http, url) = (http.clone(), format!("{base}/v1/jobs"));
        async move { http.get(url).bearer_auth(token).send().await.expect("answer").status().as_u16() }
    };
    let lease_refused = |token: &'static str| {
        let grpc = grpc.clone();
        async move {
            let source = sable_worker::remote::RemoteSource::with_token(&grpc, Some(token)).expect("source");
            matches!(source.lease("w").await, Err(sable_worker::SourceError::Refused(_)))
        }
    };
    assert_eq!((status(alice).await, status(bob).await), (200, 401));
    assert!(!lease_refused(WORKER).await);

    // Alice revoked and Bob granted; the worker's token replaced.
    std::fs::write(&users, format!("# alice left\n{bob}\n")).expect("write");
    std::fs::write(&workers, format!("{worker2}\n")).expect("write");
    let started = std::time::Instant::now();
    while (status(alice).await, status(bob).await) != (401, 200) {
        assert!(started.elapsed() < Duration::from_secs(5), "the edited users' file was not read again within 5 s");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    assert!(lease_refused(WORKER).await && !lease_refused(worker2).await, "the workers' file was not read again");

    // A file made unusable keeps the tokens as they were: the users' role does not open.
    std::fs::write(&users, "tooshort\n").expect("write");
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!((status(bob).await, status(alice).await), (200, 401));
    std::fs::remove_file(&users).expect("remove");
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(http.get(format!("{base}/v1/jobs")).send().await.expect("answer").status(), 401, "a removed file opened the API");
    server.shutdown(Duration::from_secs(2)).await;
}

/// Issue 71, finding 7: an event stream opened with a token that is then revoked ends with an
/// `unauthenticated` error, on REST and gRPC, within a heartbeat of the token files' reload.
/// Before, it went on streaming for as long as the job ran.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_event_stream_ends_when_its_token_is_revoked() {
    let dir = tempfile::tempdir().expect("dir");
    let users = dir.path().join("users");
    let (alice, bob) = ("alice-token-0123456789abcdef", "bob-token-0123456789abcdef");
    std::fs::write(&users, format!("{alice}\n{bob}\n")).expect("write");
    let mut cfg = config(&dir, Tokens::from_files(Some(&users), None).expect("token file"));
    cfg.token_reload = Duration::from_millis(100);
    cfg.heartbeat = Duration::from_millis(200);
    let server = Server::start(cfg).await.expect("starts");
    let base = format!("http://{}", server.http_addr);
    let http = reqwest::Client::new();
    // No workers: the job stays queued and its streams stay open, beating.
    let job: serde_json::Value = http
        .post(format!("{base}/v1/jobs"))
        .bearer_auth(alice)
        .header("content-type", "application/json")
        .body(scene())
        .send()
        .await
        .expect("submit")
        .json()
        .await
        .expect("job");
    let id = job["id"].as_i64().expect("id");
    let mut sse = http.get(format!("{base}/v1/jobs/{id}/events")).bearer_auth(alice).send().await.expect("events");
    assert_eq!(sse.status(), 200);
    let grpc = sable_client::Client::connect_with_token(&format!("http://{}", server.grpc_addr), Some(alice)).await.expect("gRPC");
    let mut watch = grpc.watch(id, 0);
    // Bob keeps his stream.
    let mut kept = http.get(format!("{base}/v1/jobs/{id}/events")).bearer_auth(bob).send().await.expect("events");

    std::fs::write(&users, format!("{bob}\n")).expect("revoke alice");
    let revoked = std::time::Instant::now();
    let mut text = String::new();
    while let Ok(Some(chunk)) = tokio::time::timeout(Duration::from_secs(5), sse.chunk()).await.expect("the stream went on for 5 s") {
        text.push_str(&String::from_utf8_lossy(&chunk));
    }
    assert!(text.contains("event: error") && text.contains("unauthenticated"), "{text}");
    let ended = tokio::time::timeout(Duration::from_secs(5), async {
        use tokio_stream::StreamExt;
        loop {
            match watch.next().await {
                Some(Ok(_)) => continue,
                Some(Err(e)) => return Some(e.to_string()),
                None => return None,
            }
        }
    })
    .await
    .expect("the gRPC stream went on for 5 s");
    assert!(ended.as_deref().is_some_and(|e| e.contains("revoked")), "{ended:?}");
    eprintln!("streams ended {:?} after the revocation", revoked.elapsed());
    // Bob's stream beats on.
    let beat = tokio::time::timeout(Duration::from_secs(2), kept.chunk()).await.expect("Bob's stream beats").expect("a chunk");
    assert!(beat.is_some(), "Bob's stream ended");
    server.shutdown(Duration::from_secs(2)).await;
}
