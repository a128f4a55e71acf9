//! End-to-end tests of the service on PostgreSQL: the suite of service_e2e.rs, each server on a
//! fresh database of the throw-away test cluster (server/tests/common/postgres.rs). Without
//! PostgreSQL binaries on the machine every test skips with a message (and fails under
//! `SABLE_REQUIRE_POSTGRES=1`, as in CI).

/// The back-end this copy of the suite runs on.
const BACKEND: sable_server::store::Backend = sable_server::store::Backend::Postgres;

mod common;

include!("e2e/suite.rs");
