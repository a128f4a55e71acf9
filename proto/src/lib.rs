//! # sable-proto
//!
//! The gRPC API of Sable, package `sable.v1` (proto/sable/v1/simulations.proto): the
//! `Simulations` service that users call and the `Workers` service that remote worker pools
//! lease jobs from. Generated with tonic and prost at build time; no protoc needed.

#![allow(missing_docs, clippy::all, clippy::unwrap_used)] // generated code

/// Protocol package name.
pub const PACKAGE: &str = "sable.v1";

/// Encoded file descriptor set of the API, for gRPC server reflection.
pub const FILE_DESCRIPTOR_SET: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sable_descriptor.bin"));

/// `sable.v1`: messages, clients and servers.
pub mod v1 {
    include!(concat!(env!("OUT_DIR"), "/sable.v1.rs"));
}
