//! # sable-proto
//!
//! The gRPC API of Sable (`sable.v1`). The `.proto` files and generated code arrive with the
//! service issue; this crate exists so that the workspace layout is fixed from the start.

/// Protocol package name.
pub const PACKAGE: &str = "sable.v1";
