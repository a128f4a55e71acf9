//! A job source on another machine: the `Workers` gRPC service of a Sable server.

use sable_proto::v1::finish_job_request::Outcome as ProtoOutcome;
use sable_proto::v1::workers_client::WorkersClient;
use sable_proto::v1::{FinishJobRequest, LeaseJobRequest, ReportProgressRequest};
use tonic::transport::Channel;

use crate::source::{JobSource, Lease, Outcome, Report, ResumeFrom, SourceError};

/// Largest progress report a worker sends and the server accepts, and largest lease the worker
/// reads, bytes (snapshots of large scenes make large reports; a scene that starts from a saved
/// state carries it in its lease).
pub const MAX_REPORT_BYTES: usize = 256 << 20;

/// Leases jobs from a Sable server over gRPC.
#[derive(Debug, Clone)]
pub struct RemoteSource {
    client: WorkersClient<tonic::service::interceptor::InterceptedService<Channel, sable_proto::Bearer>>,
}

impl RemoteSource {
    /// Connects lazily to the server at `url` (e.g. `http://host:50051`).
    pub fn new(url: &str) -> Result<Self, SourceError> {
        Self::with_token(url, None)
    }

    /// Connects lazily to the server at `url`, sending a worker's bearer token with every call
    /// (for a server started with `--worker-tokens`; None: no token).
    pub fn with_token(url: &str, token: Option<&str>) -> Result<Self, SourceError> {
        Self::with_access(url, token, None)
    }

    /// Connects lazily to the server at `url` with a worker's bearer token (None: no token)
    /// and, for an `https://` address, trusting the certificate authorities in `ca_pem` (PEM)
    /// besides the system's ([`sable_proto::endpoint`]).
    pub fn with_access(url: &str, token: Option<&str>, ca_pem: Option<&[u8]>) -> Result<Self, SourceError> {
        let bearer = sable_proto::Bearer::new(token).map_err(|e| SourceError::Unavailable(format!("bad worker token: {e}")))?;
        let endpoint = sable_proto::endpoint(url, ca_pem)
            .map_err(|e| SourceError::Unavailable(format!("cannot use the server address '{url}': {e}")))?
            .connect_timeout(std::time::Duration::from_secs(5))
            .timeout(std::time::Duration::from_secs(30));
        // Snapshots of large scenes make large reports; a scene that starts from a saved state
        // carries it in its lease.
        let client = WorkersClient::with_interceptor(endpoint.connect_lazy(), bearer)
            .max_encoding_message_size(MAX_REPORT_BYTES)
            .max_decoding_message_size(MAX_REPORT_BYTES);
        Ok(Self { client })
    }
}

fn status_error(s: tonic::Status, lease: Option<&Lease>) -> SourceError {
    match (s.code(), lease) {
        (tonic::Code::FailedPrecondition, Some(l)) => SourceError::LeaseLost { job_id: l.job_id, lease_id: l.lease_id.clone() },
        (tonic::Code::Unauthenticated | tonic::Code::PermissionDenied, _) => SourceError::Refused(s.message().to_string()),
        _ => SourceError::Unavailable(format!("{}: {}", s.code(), s.message())),
    }
}

impl JobSource for RemoteSource {
    async fn lease(&self, worker: &str) -> Result<Option<Lease>, SourceError> {
        let r = self.client.clone().lease_job(LeaseJobRequest { worker: worker.to_string() }).await.map_err(|s| status_error(s, None))?;
        let Some(l) = r.into_inner().lease else { return Ok(None) };
        let resume = match l.resume {
            Some(r) => {
                let mut samples = Vec::with_capacity(r.samples_json.len());
                for text in &r.samples_json {
                    samples.push(
                        serde_json::from_str(text)
                            .map_err(|e| SourceError::Unavailable(format!("a sample of the lease is not valid: {e}")))?,
                    );
                }
                Some(ResumeFrom { step: r.step, checkpoint: r.checkpoint_gz, samples })
            }
            None => None,
        };
        Ok(Some(Lease { job_id: l.job_id, lease_id: l.lease_id, scene_json: l.scene_json, attempt: l.attempt, resume }))
    }

    async fn report(&self, lease: &Lease, report: &Report) -> Result<bool, SourceError> {
        let mut samples_json = Vec::with_capacity(report.samples.len());
        for s in &report.samples {
            samples_json.push(serde_json::to_string(s).map_err(|e| SourceError::Unavailable(e.to_string()))?);
        }
        let req = ReportProgressRequest {
            job_id: lease.job_id,
            lease_id: lease.lease_id.clone(),
            fraction: report.fraction,
            remaining_seconds: report.remaining_seconds.unwrap_or(-1.0),
            samples_json,
            first_sample: report.first_sample,
            checkpoint: report.checkpoint.as_ref().map(|c| sable_proto::v1::Checkpoint {
                step: c.step,
                samples: c.samples,
                snapshots: c.snapshots,
                data_gz: c.data.clone(),
            }),
            from_start: report.from_start,
            snapshots: report
                .snapshots
                .iter()
                .map(|f| sable_proto::v1::SnapshotFiles {
                    index: f.index,
                    step: f.step,
                    time: f.time,
                    particles_gz: f.particles.clone(),
                    contacts_gz: f.contacts.clone(),
                    walls_gz: f.walls.clone(),
                })
                .collect(),
        };
        let r = self.client.clone().report_progress(req).await.map_err(|s| status_error(s, Some(lease)))?;
        Ok(r.into_inner().cancel_requested)
    }

    async fn finish(&self, lease: &Lease, outcome: Outcome) -> Result<(), SourceError> {
        let mut req = FinishJobRequest { job_id: lease.job_id, lease_id: lease.lease_id.clone(), ..Default::default() };
        match outcome {
            Outcome::Succeeded { steps, wall_seconds, cpu_seconds, solver_iterations, result, state } => {
                req.set_outcome(ProtoOutcome::Succeeded);
                req.steps = steps;
                req.wall_seconds = wall_seconds;
                req.cpu_seconds = cpu_seconds;
                req.solver_iterations = solver_iterations;
                req.result_json = result.unwrap_or_default();
                req.final_state_gz = state.unwrap_or_default();
            }
            Outcome::Failed { code, message, steps, wall_seconds, cpu_seconds } => {
                req.set_outcome(ProtoOutcome::Failed);
                req.error_code = code;
                req.error_message = message;
                req.steps = steps;
                req.wall_seconds = wall_seconds;
                req.cpu_seconds = cpu_seconds;
            }
            Outcome::Cancelled { steps, wall_seconds, cpu_seconds } => {
                req.set_outcome(ProtoOutcome::Cancelled);
                req.steps = steps;
                req.wall_seconds = wall_seconds;
                req.cpu_seconds = cpu_seconds;
            }
            Outcome::Released => req.set_outcome(ProtoOutcome::Released),
        }
        self.client.clone().finish_job(req).await.map_err(|s| status_error(s, Some(lease)))?;
        Ok(())
    }
}
