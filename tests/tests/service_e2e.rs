//! End-to-end tests of the service on SQLite (the default back-end): a server started
//! in-process on free ports with a temporary database file, driven over HTTP and gRPC as users
//! and remote workers would. The same suite runs on PostgreSQL in service_e2e_postgres.rs.

/// The back-end this copy of the suite runs on.
const BACKEND: sable_server::store::Backend = sable_server::store::Backend::Sqlite;

mod common;

include!("e2e/suite.rs");
