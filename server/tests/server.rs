//! Every integration test of the server in one test binary: the command line, bearer tokens,
//! TLS, the job store on both back-ends, crash recovery, PostgreSQL faults, the Python client
//! and the dashboard in a browser. One binary, not one per file, because each test binary links
//! and monomorphises the whole service (tokio, axum, tonic, sqlx) again at opt-level 3. As eight
//! binaries these files took 158 s of build and 83 s of tests, as one 134 s and 51 s (the tests
//! now overlap; 2026-12-03, `cargo test --no-run --timings`, units' times beside others on two
//! cores, so the build figures are a rough guide). The whole test build from an empty target
//! took 13 m 25 s before this merge and service_e2e's, 12 m 42 s after (24.7 and 23.4 CPU
//! minutes; one build each, back to back on the idle machine). Each file stays a module of its
//! own name: `cargo test -p sable-server --test server tls::` runs one.

mod common;

#[path = "auth.rs"]
mod auth;
#[path = "cli_run.rs"]
mod cli_run;
#[path = "dashboard_browser.rs"]
mod dashboard_browser;
#[path = "kill9.rs"]
mod kill9;
#[path = "postgres_faults.rs"]
mod postgres_faults;
#[path = "python_client.rs"]
mod python_client;
#[path = "store_backends.rs"]
mod store_backends;
#[path = "tls.rs"]
mod tls;
