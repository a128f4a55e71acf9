//! TLS for `sable serve` (`--tls-cert`, `--tls-key`): the REST API, the dashboard and gRPC
//! answer over HTTPS with one certificate, so that bearer tokens (`crate::auth`) do not cross
//! the network in clear when no TLS-terminating proxy stands in front of the server.
//!
//! rustls with the ring provider; the certificate chain and the private key are PEM files,
//! read and checked against each other at start-up. gRPC uses tonic's own TLS with the same
//! files; the REST listener hands axum connections whose handshake is done, each handshake in
//! its own task (a client that never finishes its handshake delays nobody, and is dropped
//! after [`HANDSHAKE_TIMEOUT`]).

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use rustls_pki_types::pem::PemObject;
use rustls_pki_types::{CertificateDer, PrivateKeyDer};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio_rustls::rustls;
use tokio_rustls::server::TlsStream;
use tokio_rustls::TlsAcceptor;
use tokio_util::sync::CancellationToken;

use crate::idle::Idle;

/// How long a client has to finish its TLS handshake.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(10);

/// Connections whose handshake is done and not yet taken by the HTTP server.
const READY_BACKLOG: usize = 64;

/// A server's certificate chain and private key (PEM), checked to belong together.
#[derive(Clone)]
pub struct TlsIdentity {
    cert_pem: Vec<u8>,
    key_pem: Vec<u8>,
    config: Arc<rustls::ServerConfig>,
}

impl std::fmt::Debug for TlsIdentity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never the key.
        f.debug_struct("TlsIdentity").field("cert_pem_bytes", &self.cert_pem.len()).finish_non_exhaustive()
    }
}

impl TlsIdentity {
    /// From the PEM text of a certificate chain (the server's first) and of its private key
    /// (PKCS#8, PKCS#1 or SEC1). Fails naming what is wrong: no certificate, no key, or a key
    /// that does not match the certificate.
    pub fn from_pem(cert_pem: Vec<u8>, key_pem: Vec<u8>) -> Result<Self, String> {
        let certs = CertificateDer::pem_slice_iter(&cert_pem)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("--tls-cert: not valid PEM: {e}"))?;
        if certs.is_empty() {
            return Err("--tls-cert: holds no PEM certificate (-----BEGIN CERTIFICATE-----)".into());
        }
        let key = PrivateKeyDer::from_pem_slice(&key_pem).map_err(|e| format!("--tls-key: no PEM private key in it ({e})"))?;
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let mut config = rustls::ServerConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .map_err(|e| format!("TLS: {e}"))?
            .with_no_client_auth()
            .with_single_cert(certs, key)
            .map_err(|e| format!("--tls-key: does not go with --tls-cert, or is not a key rustls can use: {e}"))?;
        config.alpn_protocols = vec![b"h2".to_vec(), b"http/1.1".to_vec()];
        Ok(Self { cert_pem, key_pem, config: Arc::new(config) })
    }

    /// From the PEM files `cert` and `key` ([`TlsIdentity::from_pem`]).
    pub fn from_files(cert: &Path, key: &Path) -> Result<Self, String> {
        let read = |p: &Path, flag: &str| std::fs::read(p).map_err(|e| format!("{flag}: cannot read {}: {e}", p.display()));
        Self::from_pem(read(cert, "--tls-cert")?, read(key, "--tls-key")?)
    }

    /// The gRPC listener's TLS settings (the same certificate and key).
    pub fn grpc(&self) -> tonic::transport::ServerTlsConfig {
        tonic::transport::ServerTlsConfig::new().identity(tonic::transport::Identity::from_pem(&self.cert_pem, &self.key_pem))
    }

    /// The REST listener over TLS: accepts on `tcp` until `stop`, without Nagle's delay
    /// (small answers), each handshake in its own task, each connection closed once quiet for
    /// `idle` (`crate::idle`).
    pub fn listener(&self, tcp: TcpListener, idle: Duration, stop: CancellationToken) -> std::io::Result<TlsListener> {
        let local = tcp.local_addr()?;
        let (tx, rx) = mpsc::channel(READY_BACKLOG);
        let acceptor = TlsAcceptor::from(self.config.clone());
        tokio::spawn(async move {
            loop {
                let (stream, peer) = tokio::select! {
                    _ = stop.cancelled() => return,
                    accepted = tcp.accept() => match accepted {
                        Ok(a) => a,
                        // Out of file descriptors and the like: wait a little, as hyper does.
                        Err(_) => {
                            tokio::time::sleep(Duration::from_millis(50)).await;
                            continue;
                        }
                    },
                };
                let _ = stream.set_nodelay(true);
                let (acceptor, tx) = (acceptor.clone(), tx.clone());
                tokio::spawn(async move {
                    // A failed or slow handshake only loses its own connection.
                    let stream = Idle::new(stream, idle);
                    if let Ok(Ok(tls)) = tokio::time::timeout(HANDSHAKE_TIMEOUT, acceptor.accept(stream)).await {
                        let _ = tx.send((tls, peer)).await;
                    }
                });
            }
        });
        Ok(TlsListener { ready: rx, local })
    }
}

/// The REST listener over TLS ([`TlsIdentity::listener`]): connections whose handshake is done.
#[derive(Debug)]
pub struct TlsListener {
    ready: mpsc::Receiver<(TlsStream<Idle<TcpStream>>, SocketAddr)>,
    local: SocketAddr,
}

impl axum::serve::Listener for TlsListener {
    type Io = TlsStream<Idle<TcpStream>>;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Self::Io, Self::Addr) {
        match self.ready.recv().await {
            Some(c) => c,
            // The accepting task stopped: the server is shutting down, and axum's graceful
            // shutdown ends this future's caller.
            None => std::future::pending().await,
        }
    }

    fn local_addr(&self) -> std::io::Result<Self::Addr> {
        Ok(self.local)
    }
}
