//! `sable serve`: the job store, the local worker pool, the lease reaper, and the REST and gRPC
//! listeners, started together and stopped together.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use sable_proto::v1::simulations_server::SimulationsServer;
use sable_proto::v1::workers_server::WorkersServer;
use sable_worker::{Pool, PoolConfig};
use tokio::net::TcpListener;
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;
use tonic::service::interceptor::InterceptedService;

use crate::auth::{GrpcGuard, Role, Tokens};
use crate::grpc::{SimulationsService, WorkersService};
use crate::rest::AppState;
use crate::routes::router;
use crate::store::{Backend, DbLocation, JobStore, LeaseConfig, StoreError};

/// Settings of a server.
#[derive(Debug, Clone)]
pub struct ServeConfig {
    /// The job store: an SQLite file (created if missing) or a PostgreSQL database.
    pub db: DbLocation,
    /// REST address (port 0: any free port).
    pub http: SocketAddr,
    /// gRPC address (port 0: any free port).
    pub grpc: SocketAddr,
    /// Local workers (0: none; jobs then wait for `sable worker` processes).
    pub workers: usize,
    /// Threads per job (0: cores / workers).
    pub threads_per_job: usize,
    /// Lease duration without a report.
    pub lease_ttl: Duration,
    /// Interval of worker reports (samples, lease renewal, cancellation check).
    pub report_interval: Duration,
    /// Interval of the local workers' checkpoints (None: only when the server stops).
    pub checkpoint_interval: Option<Duration>,
    /// Where the local workers run each job's engine.
    pub job_process: sable_worker::JobProcess,
    /// Heartbeat interval of idle event streams.
    pub heartbeat: Duration,
    /// Request limits.
    pub limits: crate::api::Limits,
    /// The bearer tokens of users and workers (none: open; `crate::auth`).
    pub tokens: Arc<Tokens>,
    /// How often the token files are read again (`crate::auth::Tokens::reload`).
    pub token_reload: Duration,
    /// Serve without tokens on addresses other machines can reach (`--no-auth`).
    pub no_auth: bool,
    /// The certificate and key to serve REST and gRPC over TLS with (None: plain; `crate::tls`).
    pub tls: Option<crate::tls::TlsIdentity>,
    /// A connection with no byte either way for this long is closed (`crate::idle`).
    pub idle_timeout: Duration,
}

impl Default for ServeConfig {
    fn default() -> Self {
        Self {
            db: DbLocation::Sqlite(PathBuf::from("sable.db")),
            http: SocketAddr::from(([127, 0, 0, 1], 8080)),
            grpc: SocketAddr::from(([127, 0, 0, 1], 50051)),
            workers: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads_per_job: 0,
            lease_ttl: Duration::from_secs(30),
            report_interval: Duration::from_millis(250),
            checkpoint_interval: Some(sable_worker::DEFAULT_CHECKPOINT_INTERVAL),
            job_process: sable_worker::JobProcess::InWorker,
            heartbeat: Duration::from_secs(15),
            limits: crate::api::Limits::default(),
            tokens: Arc::default(),
            token_reload: Duration::from_secs(5),
            no_auth: false,
            tls: None,
            idle_timeout: crate::idle::DEFAULT_IDLE_TIMEOUT,
        }
    }
}

/// Why a server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The database could not be opened or migrated.
    #[error("cannot open the database: {0}")]
    Store(#[from] StoreError),
    /// A listener could not bind.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// Tokens are needed on an address other machines can reach.
    #[error("{0}")]
    Exposed(String),
    /// TLS could not be set up on a listener.
    #[error("TLS: {0}")]
    Tls(String),
    /// gRPC reflection could not be set up.
    #[error("gRPC reflection: {0}")]
    Reflection(#[from] tonic_reflection::server::Error),
}

/// The REST listener: plain, or over TLS.
enum Rest {
    Plain(crate::idle::IdleListener),
    Tls(crate::tls::TlsListener),
}

/// A running server.
#[derive(Debug)]
pub struct Server {
    /// Bound REST address.
    pub http_addr: SocketAddr,
    /// Bound gRPC address.
    pub grpc_addr: SocketAddr,
    /// The job store.
    pub store: JobStore,
    stop: CancellationToken,
    tasks: JoinSet<()>,
    pool: Option<Pool>,
}

impl Server {
    /// Opens the store, puts back in the queue the jobs that a previous run of the local pool
    /// left running, starts the workers, the reaper and both listeners.
    pub async fn start(cfg: ServeConfig) -> Result<Self, ServeError> {
        crate::auth::check_exposure(&cfg.tokens, &[cfg.http, cfg.grpc], cfg.no_auth).map_err(ServeError::Exposed)?;
        let store = JobStore::open(&cfg.db, LeaseConfig { ttl: cfg.lease_ttl }).await?.with_job_limits(cfg.limits.job());
        // A local worker of an earlier run of this server cannot be alive any more. (On
        // PostgreSQL other servers' local workers may be: their jobs go back to the queue
        // when their leases expire.)
        if store.backend() == Backend::Sqlite {
            let requeued = store.requeue_expired(Some("local:")).await?;
            if requeued > 0 {
                eprintln!("sable serve: {requeued} job(s) left running by a previous run put back in the queue");
            }
        }
        let stop = CancellationToken::new();
        let mut tasks = JoinSet::new();

        let reaper_store = store.clone();
        let reaper_stop = stop.clone();
        let every = (cfg.lease_ttl / 4).max(Duration::from_millis(50));
        tasks.spawn(async move {
            // Set while the database is away: when it is back, the leases that ran out
            // meanwhile are renewed rather than their jobs run again (JobStore::renew_running_leases).
            let mut outage = false;
            loop {
                tokio::select! {
                    _ = tokio::time::sleep(every) => {}
                    _ = reaper_stop.cancelled() => return,
                }
                if outage {
                    match reaper_store.renew_running_leases().await {
                        Ok(n) => {
                            eprintln!("sable serve: the database is back; the leases of {n} running job(s) renewed");
                            outage = false;
                        }
                        Err(e) => eprintln!("sable serve: lease reaper: {e}"),
                    }
                    continue;
                }
                if let Err(e) = reaper_store.requeue_expired(None).await {
                    outage = e.outage().is_some();
                    eprintln!("sable serve: lease reaper: {e}");
                }
            }
        });

        // Token files edited while the server runs: granted and revoked within `token_reload`.
        let (tokens, every, reload_stop) = (cfg.tokens.clone(), cfg.token_reload, stop.clone());
        tasks.spawn(async move {
            let mut last_error = String::new();
            loop {
                tokio::select! {
                    _ = reload_stop.cancelled() => return,
                    _ = tokio::time::sleep(every) => {}
                }
                match tokens.reload() {
                    Ok(changed) => {
                        if changed {
                            let (users, workers) = tokens.counts();
                            eprintln!("sable serve: token files read again: {users} user token(s), {workers} worker token(s)");
                        }
                        last_error.clear();
                    }
                    Err(e) => {
                        let e = e.to_string();
                        if e != last_error {
                            eprintln!("sable serve: token files not read again, the tokens stay as they were: {e}");
                            last_error = e;
                        }
                    }
                }
            }
        });

        // The study driver: measures the runs of studies as they end and adds a search's probes.
        tasks.spawn(crate::studies::drive(store.clone(), cfg.limits, Duration::from_millis(200), stop.clone()));

        let pool = (cfg.workers > 0).then(|| {
            let mut pc = PoolConfig::new(format!("local:{:08x}", rand::random::<u32>()), cfg.workers);
            if cfg.threads_per_job > 0 {
                pc.threads_per_job = cfg.threads_per_job;
            }
            pc.report_interval = cfg.report_interval;
            pc.checkpoint_interval = cfg.checkpoint_interval;
            pc.job_process = cfg.job_process.clone();
            Pool::start(Arc::new(store.clone()), pc, store.queued.clone())
        });

        let http = TcpListener::bind(cfg.http).await.map_err(|source| ServeError::Bind { addr: cfg.http, source })?;
        let http_addr = http.local_addr().map_err(|source| ServeError::Bind { addr: cfg.http, source })?;
        let grpc = TcpListener::bind(cfg.grpc).await.map_err(|source| ServeError::Bind { addr: cfg.grpc, source })?;
        let grpc_addr = grpc.local_addr().map_err(|source| ServeError::Bind { addr: cfg.grpc, source })?;

        let watchers = Arc::new(tokio::sync::Semaphore::new(cfg.limits.max_watchers));
        let state = AppState {
            store: store.clone(),
            pool: pool.as_ref().map(|p| p.stats.clone()),
            heartbeat: cfg.heartbeat,
            limits: cfg.limits,
            watchers: watchers.clone(),
        };
        let app = router(state).layer(axum::middleware::from_fn_with_state(cfg.tokens.clone(), crate::auth::http_layer));
        let http_stop = stop.clone();
        let http = match &cfg.tls {
            Some(id) => {
                Rest::Tls(id.listener(http, cfg.idle_timeout, stop.clone()).map_err(|source| ServeError::Bind { addr: cfg.http, source })?)
            }
            None => Rest::Plain(crate::idle::IdleListener::new(http, cfg.idle_timeout)),
        };
        tasks.spawn(async move {
            let shutdown = async move { http_stop.cancelled().await };
            let served = match http {
                Rest::Tls(tls) => axum::serve(tls, app).with_graceful_shutdown(shutdown).await,
                Rest::Plain(http) => axum::serve(http, app).with_graceful_shutdown(shutdown).await,
            };
            if let Err(e) = served {
                eprintln!("sable serve: HTTP server: {e}");
            }
        });

        let (health, health_service) = tonic_health::server::health_reporter();
        health.set_serving::<SimulationsServer<SimulationsService>>().await;
        health.set_serving::<WorkersServer<WorkersService>>().await;
        health.set_serving::<sable_proto::v1::studies_server::StudiesServer<crate::grpc::StudiesService>>().await;
        let reflection = tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(sable_proto::FILE_DESCRIPTOR_SET)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
            .build_v1()?;
        let sims = SimulationsService { store: store.clone(), heartbeat: cfg.heartbeat, limits: cfg.limits, watchers };
        let studies = crate::grpc::StudiesService { store: store.clone(), limits: cfg.limits };
        let workers = WorkersService { store: store.clone(), lease_seconds: cfg.lease_ttl.as_secs_f64() };
        let grpc_stop = stop.clone();
        // Users' tokens guard Simulations and Studies, workers' tokens Workers (crate::auth).
        let (user, worker) = (GrpcGuard::new(cfg.tokens.clone(), Role::User), GrpcGuard::new(cfg.tokens.clone(), Role::Worker));
        // Room for the largest scene accepted plus the rest of the request.
        let max_message = cfg.limits.max_body_bytes + 64 * 1024;
        let idle_timeout = cfg.idle_timeout;
        let mut grpc_server = tonic::transport::Server::builder();
        if let Some(id) = &cfg.tls {
            grpc_server = grpc_server.tls_config(id.grpc()).map_err(|e| ServeError::Tls(e.to_string()))?;
        }
        let grpc_server =
            grpc_server.layer(tower::util::MapResponseLayer::new(crate::grpc::unparsed_request_is_invalid_argument::<tonic::body::Body>));
        tasks.spawn(async move {
            // tonic ignores its tcp_nodelay setting for incoming streams given to it: without
            // this each small gRPC answer waited for the peer's delayed ACK, about 40 ms (a
            // remote worker ran at most 23 tiny jobs a second, whatever their number).
            // Each connection is closed once quiet for the idle timeout (crate::idle).
            let incoming = tokio_stream::StreamExt::map(tokio_stream::wrappers::TcpListenerStream::new(grpc), move |s| {
                s.map(|tcp| {
                    let _ = tcp.set_nodelay(true);
                    crate::idle::Idle::new(tcp, idle_timeout)
                })
            });
            let r = grpc_server
                .http2_keepalive_interval(Some(Duration::from_secs(30)))
                .add_service(health_service)
                .add_service(reflection)
                .add_service(InterceptedService::new(SimulationsServer::new(sims).max_decoding_message_size(max_message), user.clone()))
                .add_service(InterceptedService::new(
                    sable_proto::v1::studies_server::StudiesServer::new(studies).max_decoding_message_size(max_message),
                    user,
                ))
                .add_service(InterceptedService::new(
                    WorkersServer::new(workers).max_decoding_message_size(sable_worker::remote::MAX_REPORT_BYTES),
                    worker,
                ))
                .serve_with_incoming_shutdown(incoming, async move { grpc_stop.cancelled().await })
                .await;
            if let Err(e) = r {
                eprintln!("sable serve: gRPC server: {e}");
            }
        });
        Ok(Self { http_addr, grpc_addr, store, stop, tasks, pool })
    }

    /// Stops: ends event streams, hands running jobs back to the queue (they are not counted as
    /// attempts), stops the listeners and closes the database; waits at most about `grace`.
    pub async fn shutdown(mut self, grace: Duration) {
        self.store.closing.cancel();
        if let Some(pool) = self.pool.take() {
            pool.shutdown(grace).await;
        }
        self.stop.cancel();
        let all = async { while self.tasks.join_next().await.is_some() {} };
        if tokio::time::timeout(grace, all).await.is_err() {
            self.tasks.abort_all();
        }
        self.store.close().await;
    }

    /// Simulates a crash for tests: stops everything at once without handing jobs back or
    /// writing anything (the database is left as a killed process would leave it).
    pub async fn abort(mut self) {
        self.store.closing.cancel();
        if let Some(pool) = self.pool.take() {
            pool.abort();
        }
        self.stop.cancel();
        self.tasks.abort_all();
        while self.tasks.join_next().await.is_some() {}
        self.store.close().await;
    }
}
