//! TLS (server/src/tls.rs): a server started with a certificate answers REST, gRPC and remote
//! workers over TLS only; clients that trust the certificate (`--ca-cert`) reach it with
//! https:// addresses, the others are refused by their own TLS; bad certificate or key files
//! are refused at start-up naming the flag.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use sable_server::auth::Tokens;
use sable_server::tls::TlsIdentity;
use sable_server::{ServeConfig, Server};

use crate::common::scenes::tiny as scene;

const USER: &str = "user-token-0123456789abcdef";
const WORKER: &str = "worker-token-0123456789abcdef";

/// A self-signed certificate for localhost and 127.0.0.1: (certificate PEM, key PEM).
fn self_signed() -> (String, String) {
    let names = vec!["localhost".to_string(), "127.0.0.1".to_string()];
    let rcgen::CertifiedKey { cert, key_pair } = rcgen::generate_simple_self_signed(names).expect("certificate");
    (cert.pem(), key_pair.serialize_pem())
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rest_grpc_and_workers_go_over_tls_with_a_trusted_certificate_only() {
    let dir = tempfile::tempdir().expect("dir");
    let (cert, key) = self_signed();
    let cert_file = write(dir.path(), "cert.pem", &cert);
    let key_file = write(dir.path(), "key.pem", &key);
    let cfg = ServeConfig {
        db: sable_server::store::DbLocation::Sqlite(dir.path().join("sable.db")),
        http: "127.0.0.1:0".parse().expect("addr"),
        grpc: "127.0.0.1:0".parse().expect("addr"),
        workers: 0,
        tokens: Arc::new(Tokens::new(vec![USER.into()], vec![WORKER.into()])),
        tls: Some(TlsIdentity::from_files(&cert_file, &key_file).expect("a certificate and its key")),
        ..Default::default()
    };
    let server = Server::start(cfg).await.expect("starts");
    let rest = format!("https://127.0.0.1:{}", server.http_addr.port());
    let grpc = format!("https://127.0.0.1:{}", server.grpc_addr.port());

    // REST over HTTPS with the certificate trusted; the token still needed.
    let trusting = reqwest::Client::builder()
        .add_root_certificate(reqwest::Certificate::from_pem(cert.as_bytes()).expect("pem"))
        .https_only(true)
        .build()
        .expect("client");
    assert_eq!(trusting.get(format!("{rest}/healthz")).send().await.expect("answer").status(), 200);
    assert_eq!(trusting.get(format!("{rest}/v1/jobs")).send().await.expect("answer").status(), 401);
    let r = trusting.post(format!("{rest}/v1/jobs")).bearer_auth(USER).body(scene()).send().await.expect("answer");
    assert_eq!(r.status(), 201, "{:?}", r.text().await);
    let created: serde_json::Value = r.json().await.expect("json");
    let id = created["id"].as_i64().expect("job id");
    // The dashboard comes over the same listener.
    assert_eq!(trusting.get(format!("{rest}/")).send().await.expect("answer").status(), 200);
    // A client that does not trust the certificate, and plain HTTP, get nothing.
    let e = reqwest::Client::new().get(format!("{rest}/healthz")).send().await.expect_err("untrusted");
    assert!(format!("{e:?}").to_lowercase().contains("certificate"), "{e:?}");
    assert!(reqwest::Client::new().get(format!("http://{}/healthz", server.http_addr)).send().await.is_err(), "plain HTTP answered");

    // gRPC with the certificate trusted.
    let mut user = sable_client::Client::connect_with_access(&grpc, Some(USER), Some(cert.as_bytes())).await.expect("connects over TLS");
    assert_eq!(user.get(id).await.expect("the job over gRPC").id, id);
    // Without it, the client's own TLS refuses the server; plain gRPC gets no answer.
    match sable_client::Client::connect_with_token(&grpc, Some(USER)).await {
        Err(e) => assert!(matches!(e, sable_client::ClientError::Connect { .. }), "{e}"),
        Ok(mut c) => assert!(c.get(id).await.is_err(), "a client that does not trust the certificate was answered"),
    }
    let plain = format!("http://{}", server.grpc_addr);
    if let Ok(mut c) = sable_client::Client::connect_with_token(&plain, Some(USER)).await {
        assert!(c.get(id).await.is_err(), "plain gRPC was answered");
    }

    // A remote `sable worker` over TLS runs the job; the CLI client reads it.
    let mut worker = std::process::Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["worker", "--workers", "1", "--server", &grpc, "--token", WORKER, "--ca-cert"])
        .arg(&cert_file)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("sable worker runs");
    let started = Instant::now();
    let state = loop {
        let job = user.get(id).await.expect("job");
        if matches!(job.state(), sable_client::JobState::Succeeded | sable_client::JobState::Failed)
            || started.elapsed() > Duration::from_secs(60)
        {
            break job.state();
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let _ = worker.kill();
    let _ = worker.wait();
    assert_eq!(state, sable_client::JobState::Succeeded);
    let shown = std::process::Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["show", &id.to_string(), "--json", "--server", &grpc, "--token", USER, "--ca-cert"])
        .arg(&cert_file)
        .output()
        .expect("sable show runs");
    let out = String::from_utf8_lossy(&shown.stdout);
    assert!(shown.status.success() && out.contains("\"succeeded\""), "{out}\n{}", String::from_utf8_lossy(&shown.stderr));
    server.shutdown(Duration::from_secs(2)).await;
}

#[test]
fn bad_certificates_keys_and_ca_files_are_refused_naming_what_is_wrong() {
    let (cert, key) = self_signed();
    let (_, other_key) = self_signed();
    let no_cert = TlsIdentity::from_pem(b"not a certificate".to_vec(), key.clone().into_bytes()).expect_err("no certificate");
    assert!(no_cert.starts_with("--tls-cert: holds no PEM certificate"), "{no_cert}");
    let no_key = TlsIdentity::from_pem(cert.clone().into_bytes(), b"nothing".to_vec()).expect_err("no key");
    assert!(no_key.starts_with("--tls-key: no PEM private key"), "{no_key}");
    let mismatch = TlsIdentity::from_pem(cert.clone().into_bytes(), other_key.into_bytes()).expect_err("another key");
    assert!(mismatch.starts_with("--tls-key: does not go with --tls-cert"), "{mismatch}");
    let missing = TlsIdentity::from_files(Path::new("/nonexistent/cert.pem"), Path::new("/nonexistent/key.pem")).expect_err("no file");
    assert!(missing.starts_with("--tls-cert: cannot read /nonexistent/cert.pem"), "{missing}");

    // Clients: a CA is for https:// only, and must hold a certificate.
    let plain = sable_proto::endpoint("http://127.0.0.1:50051", Some(cert.as_bytes())).expect_err("CA with http://");
    assert!(plain.contains("not an https:// address"), "{plain}");
    let junk = sable_proto::endpoint("https://127.0.0.1:50051", Some(b"junk")).expect_err("junk CA");
    assert!(junk.contains("holds no PEM certificate"), "{junk}");
    assert!(sable_proto::endpoint("https://127.0.0.1:50051", Some(cert.as_bytes())).is_ok());

    // The CLI: a certificate needs its key, and an unreadable CA file is named.
    let serve = std::process::Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["serve", "--tls-cert", "cert.pem"])
        .output()
        .expect("sable serve runs");
    let err = String::from_utf8_lossy(&serve.stderr);
    assert!(!serve.status.success() && err.contains("--tls-key"), "{err}");
    let show = std::process::Command::new(env!("CARGO_BIN_EXE_sable"))
        .args(["show", "1", "--server", "https://127.0.0.1:1", "--ca-cert", "/nonexistent/ca.pem"])
        .output()
        .expect("sable show runs");
    let err = String::from_utf8_lossy(&show.stderr);
    assert!(!show.status.success() && err.contains("--ca-cert: cannot read /nonexistent/ca.pem"), "{err}");
}
