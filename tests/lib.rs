//! Sable's validation and end-to-end tests. The engine-level files (`tests/physics_*.rs`, the
//! experiments, saved states, snapshots, shipped studies) are modules of one test binary,
//! `tests/physics.rs`; the service's end-to-end suite is the binary `service_e2e`, once
//! per back-end (`sqlite::`, `postgres::`).
