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

/// The endpoint of a server at `url`, for the Rust client and remote workers. An `https://`
/// address is reached over TLS, trusting the system's certificate authorities and, when
/// `ca_pem` is given, the ones in it (PEM: a lab's own CA, or a server's self-signed
/// certificate); an `http://` address is plain, and refuses a CA, which would not be used.
/// Fails with the rule broken (the caller names the address): a bad address, a CA without
/// `https://`, or a CA file without a PEM certificate.
pub fn endpoint(url: &str, ca_pem: Option<&[u8]>) -> Result<tonic::transport::Endpoint, String> {
    use rustls_pki_types::pem::PemObject;
    let endpoint = tonic::transport::Endpoint::from_shared(url.to_string()).map_err(|e| format!("not a valid address: {e}"))?;
    let https = endpoint.uri().scheme_str() == Some("https");
    match (https, ca_pem) {
        (false, Some(_)) => Err("a CA certificate is given, but this is not an https:// address".into()),
        (false, None) => Ok(endpoint),
        (true, ca) => {
            let mut tls = tonic::transport::ClientTlsConfig::new().with_native_roots();
            if let Some(pem) = ca {
                let certs = rustls_pki_types::CertificateDer::pem_slice_iter(pem)
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| format!("the CA certificate is not valid PEM: {e}"))?;
                if certs.is_empty() {
                    return Err("the CA certificate file holds no PEM certificate (-----BEGIN CERTIFICATE-----)".into());
                }
                tls = tls.ca_certificate(tonic::transport::Certificate::from_pem(pem));
            }
            endpoint.tls_config(tls).map_err(|e| format!("cannot set up TLS: {e}"))
        }
    }
}
