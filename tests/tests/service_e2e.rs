//! End-to-end tests of the service: a server started in-process on free ports with a temporary
//! database, driven over HTTP and gRPC as users and remote workers would. The suite
//! (e2e/suite.rs) runs on each back-end: `sqlite::` on a temporary file (the default back-end),
//! `postgres::` each server on a fresh database of the throw-away test cluster
//! (server/tests/common/postgres.rs; without PostgreSQL binaries on the machine those tests skip
//! with a message, and fail under `SABLE_REQUIRE_POSTGRES=1`, as in CI). One binary and one
//! copy of the suite for both: as two binaries, each with its own copy, they took 118 s of
//! build and 48 s of tests, as one 109 s and 43 s (2026-12-03, `cargo test --no-run --timings`,
//! units' times beside others on two cores).

mod common;

include!("e2e/suite.rs");
