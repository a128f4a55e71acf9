//! # sable-client
//!
//! Typed async client of the Sable gRPC service (`sable.v1.Simulations`, `sable.v1.Studies`):
//! submit a scene, get, list and cancel jobs, follow a job's events as a
//! [`Stream`](tokio_stream::Stream) that resumes by itself after a dropped connection, read its
//! samples, and create studies and read their reports and charts.
//!
//! ```no_run
//! # async fn demo() -> Result<(), sable_client::ClientError> {
//! use tokio_stream::StreamExt;
//! let mut client = sable_client::Client::connect("http://127.0.0.1:50051").await?;
//! let scene = std::fs::read_to_string("scenes/quickstart.json").expect("scene file");
//! let job = client.submit(&scene, sable_client::SubmitOptions::default()).await?;
//! let mut events = client.watch(job.id, 0);
//! while let Some(event) = events.next().await {
//!     println!("{:?}", event?);
//! }
//! let samples = client.samples(job.id, 0, None, None).await?;
//! println!("{} samples, final phi = {}", samples.len(), samples.last().map_or(0.0, |s| s.phi));
//! # Ok(()) }
//! ```

use std::time::Duration;

pub use sable_engine::observe::Sample;
use sable_proto::v1 as pb;
use sable_proto::v1::simulations_client::SimulationsClient;
use sable_proto::v1::studies_client::StudiesClient;
pub use sable_proto::v1::{Job, JobEvent, JobState, Study};
use tokio_stream::Stream;
use tonic::transport::Channel;

/// Default server address of the client commands.
pub const DEFAULT_SERVER: &str = "http://127.0.0.1:50051";

/// Errors of the client.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The server address is malformed, or its TLS settings are (a CA for an `http://`
    /// address, a CA file without a certificate).
    #[error("cannot use the server address '{url}': {reason}")]
    Address {
        /// The address given.
        url: String,
        /// Why it is wrong.
        reason: String,
    },
    /// The bearer token cannot be sent.
    #[error("bad token: {0}")]
    Token(String),
    /// The server could not be reached.
    #[error("cannot reach the server at {url}: {reason}")]
    Connect {
        /// The address.
        url: String,
        /// Why.
        reason: String,
    },
    /// The server answered with an error (invalid scene, unknown job, ...).
    #[error("{}", .0.message())]
    Status(#[from] tonic::Status),
    /// The server sent something that is not a sample.
    #[error("malformed sample from the server: {0}")]
    Decode(String),
}

impl ClientError {
    /// The gRPC code, for errors the server returned.
    pub fn code(&self) -> Option<tonic::Code> {
        match self {
            Self::Status(s) => Some(s.code()),
            _ => None,
        }
    }
}

/// Options of [`Client::submit`].
#[derive(Debug, Clone, Default)]
pub struct SubmitOptions {
    /// Job name (default: the scene's).
    pub name: Option<String>,
    /// Higher runs first.
    pub priority: i32,
    /// Idempotency key: submitting again with it returns the same job.
    pub request_id: Option<String>,
    /// Attempts allowed (default: the server's).
    pub max_attempts: Option<u32>,
}

/// Filters of [`Client::list`].
#[derive(Debug, Clone, Default)]
pub struct ListOptions {
    /// Only this state.
    pub state: Option<JobState>,
    /// Only this exact name.
    pub name: Option<String>,
    /// Only this method.
    pub method: Option<String>,
    /// Page size (server default 50).
    pub page_size: u32,
    /// Token from the previous page.
    pub page_token: Option<String>,
}

/// Largest reply accepted, bytes (a final state of millions of particles).
const MAX_STATE_MESSAGE: usize = 1 << 30;

/// A connected client. Cheap to clone.
#[derive(Debug, Clone)]
pub struct Client {
    inner: SimulationsClient<Authed>,
    studies: StudiesClient<Authed>,
}

/// The channel of the client, with its bearer token.
type Authed = tonic::service::interceptor::InterceptedService<Channel, sable_proto::Bearer>;

impl Client {
    /// Connects to the server at `url` (e.g. `http://127.0.0.1:50051`).
    pub async fn connect(url: &str) -> Result<Self, ClientError> {
        Self::connect_with_token(url, None).await
    }

    /// Connects to the server at `url` sending a user's bearer token with every call (for a
    /// server started with `--user-tokens`; None: no token).
    pub async fn connect_with_token(url: &str, token: Option<&str>) -> Result<Self, ClientError> {
        Self::connect_with_access(url, token, None).await
    }

    /// Connects to the server at `url` with a user's bearer token (None: no token) and, for an
    /// `https://` address, trusting the certificate authorities in `ca_pem` (PEM) besides the
    /// system's: a lab's own CA, or the server's self-signed certificate
    /// ([`sable_proto::endpoint`]).
    pub async fn connect_with_access(url: &str, token: Option<&str>, ca_pem: Option<&[u8]>) -> Result<Self, ClientError> {
        let bearer = sable_proto::Bearer::new(token).map_err(ClientError::Token)?;
        let endpoint = sable_proto::endpoint(url, ca_pem)
            .map_err(|reason| ClientError::Address { url: url.into(), reason })?
            .connect_timeout(Duration::from_secs(5))
            .http2_keep_alive_interval(Duration::from_secs(30))
            .keep_alive_while_idle(true);
        let channel = endpoint.connect().await.map_err(|e| ClientError::Connect { url: url.into(), reason: e.to_string() })?;
        // Final states are large (about 1 MB per 10,000 particles, compressed).
        Ok(Self {
            inner: SimulationsClient::with_interceptor(channel.clone(), bearer.clone()).max_decoding_message_size(MAX_STATE_MESSAGE),
            studies: StudiesClient::with_interceptor(channel, bearer),
        })
    }

    /// Validates and queues a scene given as JSON text.
    pub async fn submit(&mut self, scene_json: &str, opts: SubmitOptions) -> Result<Job, ClientError> {
        let req = pb::SubmitJobRequest {
            scene_json: scene_json.to_string(),
            name: opts.name.unwrap_or_default(),
            priority: opts.priority,
            request_id: opts.request_id.unwrap_or_default(),
            max_attempts: opts.max_attempts.unwrap_or(0),
        };
        Ok(self.inner.submit_job(req).await?.into_inner())
    }

    /// Checks a study file (JSON text, docs/studies.md) and queues its runs.
    pub async fn create_study(&mut self, study_json: &str) -> Result<Study, ClientError> {
        Ok(self.studies.create_study(pb::CreateStudyRequest { study_json: study_json.to_string() }).await?.into_inner())
    }

    /// One study with its report so far (`report_json`).
    pub async fn study(&mut self, id: i64) -> Result<Study, ClientError> {
        Ok(self.studies.get_study(pb::GetStudyRequest { id }).await?.into_inner())
    }

    /// A study's chart, `format` `svg` or `png`.
    pub async fn study_chart(&mut self, id: i64, format: &str) -> Result<Vec<u8>, ClientError> {
        Ok(self.studies.get_study_chart(pb::GetStudyChartRequest { id, format: format.to_string() }).await?.into_inner().data)
    }

    /// One job.
    pub async fn get(&mut self, id: i64) -> Result<Job, ClientError> {
        Ok(self.inner.get_job(pb::GetJobRequest { id }).await?.into_inner())
    }

    /// One page of jobs, newest first, and the token of the next page (None at the end).
    pub async fn list(&mut self, opts: ListOptions) -> Result<(Vec<Job>, Option<String>), ClientError> {
        let mut req = pb::ListJobsRequest {
            name: opts.name.unwrap_or_default(),
            method: opts.method.unwrap_or_default(),
            page_size: opts.page_size,
            page_token: opts.page_token.unwrap_or_default(),
            ..Default::default()
        };
        if let Some(s) = opts.state {
            req.set_state(s);
        }
        let r = self.inner.list_jobs(req).await?.into_inner();
        Ok((r.jobs, (!r.next_page_token.is_empty()).then_some(r.next_page_token)))
    }

    /// Cancels a queued or running job.
    pub async fn cancel(&mut self, id: i64) -> Result<Job, ClientError> {
        Ok(self.inner.cancel_job(pb::CancelJobRequest { id }).await?.into_inner())
    }

    /// The final state of a succeeded job (particles and box; docs/scene-format.md §14),
    /// gzip-compressed JSON as the server keeps it.
    pub async fn final_state_gz(&mut self, id: i64) -> Result<Vec<u8>, ClientError> {
        Ok(self.inner.get_final_state(pb::GetFinalStateRequest { id }).await?.into_inner().state_gz)
    }

    /// The job's samples in a step range, at most `max_points` of them evenly spread, or all of
    /// them (read page by page).
    pub async fn samples(
        &mut self,
        id: i64,
        from_step: u64,
        to_step: Option<u64>,
        max_points: Option<u32>,
    ) -> Result<Vec<Sample>, ClientError> {
        let mut out = Vec::new();
        let mut from = from_step;
        loop {
            let req =
                pb::GetSamplesRequest { id, from_step: from, to_step: to_step.unwrap_or(0), max_points: max_points.unwrap_or(0), limit: 0 };
            let r = self.inner.get_samples(req).await?.into_inner();
            for s in &r.samples_json {
                out.push(serde_json::from_str(s).map_err(|e| ClientError::Decode(e.to_string()))?);
            }
            // A page ends where the next starts (the server reads at most 10,000 a call).
            if r.next_from_step == 0 || r.next_from_step <= from {
                return Ok(out);
            }
            from = r.next_from_step;
        }
    }

    /// The job's events after `after_seq`, live, until its final state. Heartbeats are passed
    /// on. A dropped connection, or a server that cannot serve it for now (restarting, its
    /// database away), is tried again from the last event seen for up to
    /// [`WATCH_RECONNECT_FOR`] without an event.
    pub fn watch(&self, id: i64, after_seq: u64) -> impl Stream<Item = Result<JobEvent, ClientError>> + Send + 'static {
        let mut inner = self.inner.clone();
        let (tx, rx) = tokio::sync::mpsc::channel(32);
        tokio::spawn(async move {
            let mut last = after_seq;
            // Since when the stream cannot be had (None: it can).
            let mut down: Option<tokio::time::Instant> = None;
            let mut failures = 0u32;
            loop {
                let mut stream = match inner.watch_job(pb::WatchJobRequest { id, after_seq: last }).await {
                    Ok(s) => s.into_inner(),
                    Err(s) if retryable(&s) && down.get_or_insert_with(tokio::time::Instant::now).elapsed() < WATCH_RECONNECT_FOR => {
                        failures += 1;
                        tokio::time::sleep(Duration::from_millis(200 << failures.min(4))).await;
                        continue;
                    }
                    Err(s) => {
                        let _ = tx.send(Err(s.into())).await;
                        return;
                    }
                };
                loop {
                    match stream.message().await {
                        Ok(Some(ev)) => {
                            failures = 0;
                            down = None;
                            if ev.seq > 0 {
                                last = ev.seq;
                            }
                            if tx.send(Ok(ev)).await.is_err() {
                                return;
                            }
                        }
                        // The server ends the stream after the final state.
                        Ok(None) => return,
                        Err(s) if retryable(&s) && down.get_or_insert_with(tokio::time::Instant::now).elapsed() < WATCH_RECONNECT_FOR => {
                            failures += 1;
                            tokio::time::sleep(Duration::from_millis(200 << failures.min(4))).await;
                            break;
                        }
                        Err(s) => {
                            let _ = tx.send(Err(s.into())).await;
                            return;
                        }
                    }
                }
            }
        });
        tokio_stream::wrappers::ReceiverStream::new(rx)
    }
}

/// How long [`Client::watch`] tries to get its stream back (a server restarting, its database
/// away: UNAVAILABLE) before it gives up with the last error.
pub const WATCH_RECONNECT_FOR: Duration = Duration::from_secs(120);

fn retryable(s: &tonic::Status) -> bool {
    matches!(s.code(), tonic::Code::Unavailable | tonic::Code::Unknown | tonic::Code::Internal | tonic::Code::Cancelled)
}
