//! Physics validation tests of Sable live in `tests/physics_*.rs`; end-to-end service tests
//! arrive with the service.
