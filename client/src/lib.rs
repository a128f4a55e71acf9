//! # sable-client
//!
//! Typed async client of the Sable gRPC service, added with the service issue.

/// Default server address of the client commands.
pub const DEFAULT_SERVER: &str = "http://127.0.0.1:50051";
