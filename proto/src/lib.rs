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

/// A client-side interceptor that sends a bearer token (`authorization: Bearer TOKEN`) with
/// every call, or nothing when there is none: how the Rust client and remote workers
/// authenticate to a server that requires tokens (server/src/auth.rs).
#[derive(Debug, Clone, Default)]
pub struct Bearer(Option<tonic::metadata::MetadataValue<tonic::metadata::Ascii>>);

impl Bearer {
    /// The interceptor for `token` (None or empty: no header). Fails if the token is not
    /// printable ASCII.
    pub fn new(token: Option<&str>) -> Result<Self, String> {
        match token.map(str::trim).filter(|t| !t.is_empty()) {
            None => Ok(Self(None)),
            Some(t) => format!("Bearer {t}")
                .parse()
                .map(|v| Self(Some(v)))
                .map_err(|_| "the token must be printable ASCII without spaces".to_string()),
        }
    }
}

impl tonic::service::Interceptor for Bearer {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(v) = &self.0 {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}
