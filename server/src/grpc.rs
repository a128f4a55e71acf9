//! The gRPC API (tonic): `sable.v1.Simulations` for users and `sable.v1.Workers` for remote
//! worker pools. The operations are those of [`crate::api`], as REST serves them.

use std::pin::Pin;
use std::time::Duration;

use sable_engine::observe::Sample;
use sable_proto::v1 as pb;
use sable_proto::v1::finish_job_request::Outcome as PbOutcome;
use sable_worker::{CheckpointFile, Lease, Outcome, Report, SnapshotFiles};
use tokio_stream::Stream;
use tonic::{Request, Response, Status};

use crate::api::{self, ApiError, JobView, ListQuery, Submission};
use crate::store::{EventRow, JobState, JobStore, StoreError};
use crate::watch::{take_slot, watch_stream, WatchItem};

impl From<ApiError> for Status {
    fn from(e: ApiError) -> Self {
        match e {
            ApiError::InvalidArgument(_) | ApiError::Malformed(_) | ApiError::TooLarge(_) => {
                Status::invalid_argument(bounded(e.to_string()))
            }
            ApiError::Exhausted(m) => Status::resource_exhausted(bounded(m)),
            ApiError::NotFound(m) => Status::not_found(bounded(m)),
            ApiError::Conflict(m) => Status::failed_precondition(bounded(m)),
            ApiError::Unavailable(_) => Status::unavailable(bounded(e.to_string())),
            ApiError::StorageFull(_) => Status::resource_exhausted(bounded(e.to_string())),
            ApiError::Unauthenticated(m) => Status::unauthenticated(bounded(m)),
            ApiError::Internal(_) => Status::internal("internal error"),
        }
    }
}

fn pb_state(s: &str) -> pb::JobState {
    match JobState::parse(s) {
        Some(JobState::Queued) => pb::JobState::Queued,
        Some(JobState::Running) => pb::JobState::Running,
        Some(JobState::Succeeded) => pb::JobState::Succeeded,
        Some(JobState::Failed) => pb::JobState::Failed,
        Some(JobState::Cancelled) => pb::JobState::Cancelled,
        None => pb::JobState::Unspecified,
    }
}

/// The proto form of a job.
pub fn pb_job(j: JobView) -> pb::Job {
    let mut out = pb::Job {
        id: j.id,
        name: j.name,
        state: 0,
        method: j.method,
        method_reason: j.method_reason,
        priority: j.priority as i32,
        created_at: j.created_at,
        started_at: j.started_at.unwrap_or_default(),
        finished_at: j.finished_at.unwrap_or_default(),
        attempts: j.attempts as u32,
        max_attempts: j.max_attempts as u32,
        progress: j.progress,
        error_code: j.error.as_ref().map(|e| e.code.clone()).unwrap_or_default(),
        error_message: j.error.map(|e| e.message).unwrap_or_default(),
        // Empty in lists (summaries): GetJob has the scene.
        scene_json: if j.scene.is_null() { String::new() } else { j.scene.to_string() },
        scene_hash: j.scene_hash,
        engine_version: j.engine_version,
        seed: j.seed,
        steps: j.steps as u64,
        wall_seconds: j.wall_seconds,
        sample_count: j.sample_count as u64,
        result_json: j.result.as_ref().map(|r| r.to_string()).unwrap_or_default(),
    };
    out.set_state(pb_state(&j.state));
    out
}

/// The summary of a sample carried by watch events.
pub fn pb_sample(s: &Sample) -> pb::SampleSummary {
    let st = &s.stress;
    pb::SampleSummary {
        step: s.step,
        time: s.time,
        phi: s.phi,
        z: s.z,
        zeta: s.zeta,
        mu: s.mu,
        p: s.p,
        q: s.q,
        stress: Some(pb::Stress {
            xx: st.xx,
            yy: st.yy,
            zz: st.zz.unwrap_or(0.0),
            xy: st.xy,
            xz: st.xz.unwrap_or(0.0),
            yz: st.yz.unwrap_or(0.0),
        }),
    }
}

/// The proto form of a stored event.
pub fn pb_event(e: &EventRow) -> pb::JobEvent {
    let v: serde_json::Value = serde_json::from_str(&e.payload).unwrap_or_default();
    let kind = if e.kind == "sample" {
        let sample: Option<Sample> = v.get("sample").and_then(|s| serde_json::from_value(s.clone()).ok());
        pb::job_event::Kind::Sample(pb::SampleEvent {
            fraction: v.get("fraction").and_then(|x| x.as_f64()).unwrap_or(0.0),
            remaining_seconds: v.get("remaining_seconds").and_then(|x| x.as_f64()).unwrap_or(-1.0),
            sample: sample.as_ref().map(pb_sample),
        })
    } else {
        let mut sc = pb::StateChange {
            state: 0,
            error_code: v.get("error_code").and_then(|x| x.as_str()).unwrap_or_default().to_string(),
            error_message: v.get("error_message").and_then(|x| x.as_str()).unwrap_or_default().to_string(),
            attempt: v.get("attempt").and_then(|x| x.as_u64()).unwrap_or(0) as u32,
        };
        sc.set_state(pb_state(v.get("state").and_then(|x| x.as_str()).unwrap_or_default()));
        pb::job_event::Kind::State(sc)
    };
    pb::JobEvent { seq: e.seq as u64, job_id: e.job_id, at: api::rfc3339(e.at), kind: Some(kind) }
}

/// `sable.v1.Simulations`.
#[derive(Debug, Clone)]
pub struct SimulationsService {
    /// The job store.
    pub store: JobStore,
    /// Idle interval between heartbeats of WatchJob.
    pub heartbeat: Duration,
    /// Request limits.
    pub limits: api::Limits,
    /// Open event streams (REST and gRPC share it).
    pub watchers: std::sync::Arc<tokio::sync::Semaphore>,
}

type EventStream = Pin<Box<dyn Stream<Item = Result<pb::JobEvent, Status>> + Send + 'static>>;

#[tonic::async_trait]
impl pb::simulations_server::Simulations for SimulationsService {
    async fn submit_job(&self, req: Request<pb::SubmitJobRequest>) -> Result<Response<pb::Job>, Status> {
        let r = req.into_inner();
        let scene: serde_json::Value = serde_json::from_str(&r.scene_json)
            .map_err(|e| Status::from(ApiError::invalid("scene_json", format!("must be a JSON object: {e}"))))?;
        if !scene.is_object() {
            return Err(ApiError::invalid("scene_json", "must be a JSON object (a scene)").into());
        }
        let sub = Submission {
            scene,
            scene_path: "scene_json.",
            name: (!r.name.is_empty()).then_some(r.name),
            priority: Some(r.priority as i64),
            max_attempts: (r.max_attempts > 0).then_some(r.max_attempts),
            idempotency_key: (!r.request_id.is_empty()).then_some(r.request_id),
        };
        let (job, _) = api::submit(&self.store, &self.limits, sub).await?;
        Ok(Response::new(pb_job(job)))
    }

    async fn advise(&self, req: Request<pb::AdviseRequest>) -> Result<Response<pb::Advice>, Status> {
        let r = req.into_inner();
        let scene: serde_json::Value = serde_json::from_str(&r.scene_json)
            .map_err(|e| Status::from(ApiError::invalid("scene_json", format!("must be a JSON object: {e}"))))?;
        if !scene.is_object() {
            return Err(ApiError::invalid("scene_json", "must be a JSON object (a scene)").into());
        }
        let a = api::advise(&self.store, &self.limits, &scene, "scene_json.").await?;
        let n = a.numbers;
        Ok(Response::new(pb::Advice {
            method: a.method,
            requested: a.requested,
            regime: a.regime.name().to_string(),
            numbers: Some(pb::AdviceNumbers {
                mean_diameter: n.mean_diameter,
                density: n.density,
                pressure: n.pressure,
                pressure_source: n.pressure_source.unwrap_or_default(),
                strain_rate: n.strain_rate,
                strain_rate_source: n.strain_rate_source.unwrap_or_default(),
                initial_solid_fraction: n.initial_solid_fraction,
                inertial_number: n.inertial_number,
                stiffness_number: n.stiffness_number,
                deflection: n.deflection,
                cohesion_index: n.cohesion_index,
                stokes_number: n.stokes_number,
            }),
            reasons: a.reasons,
            dropped: a.dropped,
            needs: a.needs.unwrap_or_default(),
            suggestions: a.suggestions,
            expected_cost: a
                .expected_cost
                .into_iter()
                .map(|c| pb::ExpectedCost {
                    study_id: c.study_id,
                    job_id: c.job_id,
                    series: c.series,
                    label: c.label,
                    method: c.method,
                    cpu_seconds: c.cpu_seconds,
                    wall_seconds: c.wall_seconds,
                    error: c.error,
                    pareto: c.pareto,
                })
                .collect(),
        }))
    }

    async fn get_job(&self, req: Request<pb::GetJobRequest>) -> Result<Response<pb::Job>, Status> {
        let row = self.store.get(req.into_inner().id).await.map_err(ApiError::from)?;
        Ok(Response::new(pb_job(row.into())))
    }

    async fn list_jobs(&self, req: Request<pb::ListJobsRequest>) -> Result<Response<pb::ListJobsResponse>, Status> {
        let r = req.into_inner();
        // `r.state()` reads an unknown number as unspecified, which listed every state.
        let state = match pb::JobState::try_from(r.state) {
            Ok(pb::JobState::Unspecified) => None,
            Ok(s) => Some(s.as_str_name().trim_start_matches("JOB_STATE_").to_lowercase()),
            Err(_) => return Err(Status::invalid_argument(format!("state: {} is not a JobState", r.state))),
        };
        let (jobs, next) = api::list(
            &self.store,
            ListQuery {
                state,
                name: Some(r.name),
                method: Some(r.method),
                created_after: Some(r.created_after),
                created_before: Some(r.created_before),
                page_size: Some(r.page_size),
                page_token: Some(r.page_token),
            },
        )
        .await?;
        Ok(Response::new(pb::ListJobsResponse { jobs: jobs.into_iter().map(pb_job).collect(), next_page_token: next.unwrap_or_default() }))
    }

    async fn cancel_job(&self, req: Request<pb::CancelJobRequest>) -> Result<Response<pb::Job>, Status> {
        let row = self.store.cancel(req.into_inner().id).await.map_err(ApiError::from)?;
        Ok(Response::new(pb_job(row.into())))
    }

    type WatchJobStream = EventStream;

    async fn watch_job(&self, req: Request<pb::WatchJobRequest>) -> Result<Response<Self::WatchJobStream>, Status> {
        let still = req.extensions().get::<crate::auth::Admitted>().map(|a| a.checker());
        let r = req.into_inner();
        let after = i64::try_from(r.after_seq).map_err(|_| Status::from(ApiError::invalid("after_seq", "is too large")))?;
        let slot = take_slot(&self.watchers, self.limits.max_watchers)?;
        let id = r.id;
        let stream = watch_stream(&self.store, id, after, self.heartbeat, slot, still, move |item| match item {
            Ok(WatchItem::Event(e)) => Ok(pb_event(&e)),
            Ok(WatchItem::Heartbeat) => Ok(pb::JobEvent {
                seq: 0,
                job_id: id,
                at: api::rfc3339(crate::store::now_ms()),
                kind: Some(pb::job_event::Kind::Heartbeat(pb::Heartbeat {})),
            }),
            Err(e) => Err(Status::from(e)),
        })
        .await?;
        Ok(Response::new(Box::pin(stream)))
    }

    async fn get_samples(&self, req: Request<pb::GetSamplesRequest>) -> Result<Response<pb::GetSamplesResponse>, Status> {
        let r = req.into_inner();
        let to = (r.to_step > 0).then_some(r.to_step);
        let read = api::samples(&self.store, r.id, r.from_step, to, Some(r.max_points), Some(r.limit)).await?;
        let samples_json = read.samples.iter().map(|s| serde_json::to_string(s).unwrap_or_default()).collect();
        Ok(Response::new(pb::GetSamplesResponse {
            samples_json,
            events_seq: read.events_seq.max(0) as u64,
            next_from_step: read.next_from_step.unwrap_or(0),
        }))
    }

    async fn get_final_state(&self, req: Request<pb::GetFinalStateRequest>) -> Result<Response<pb::FinalState>, Status> {
        let id = req.into_inner().id;
        let state_gz = self.store.final_state(id).await.map_err(api::ApiError::from)?;
        Ok(Response::new(pb::FinalState { job_id: id, state_gz }))
    }
}

/// `sable.v1.Workers`: leases for remote worker pools.
#[derive(Debug, Clone)]
pub struct WorkersService {
    /// The job store.
    pub store: JobStore,
    /// Lease duration, for the reply.
    pub lease_seconds: f64,
}

/// The lease a worker names. Its id must be one the store could have issued (32 hexadecimal
/// digits; at most 64 letters and digits are let through to the store): a 20 kB one came back
/// in the error's message, which then no longer fit in an HTTP/2 header.
fn lease_of(job_id: i64, lease_id: String) -> Result<Lease, Status> {
    if lease_id.is_empty() || lease_id.len() > 64 || !lease_id.bytes().all(|b| b.is_ascii_alphanumeric()) {
        return Err(Status::invalid_argument("lease_id: must be the id of a lease this server issued (at most 64 letters and digits)"));
    }
    Ok(Lease { job_id, lease_id, scene_json: String::new(), attempt: 0, resume: None })
}

/// Longest message a status carries, bytes: messages that quote a request must still fit in
/// the HTTP/2 header they travel in.
const MAX_STATUS_MESSAGE: usize = 4096;

/// `m`, cut to [`MAX_STATUS_MESSAGE`] bytes (at a character boundary) with an ellipsis.
fn bounded(mut m: String) -> String {
    if m.len() > MAX_STATUS_MESSAGE {
        let mut end = MAX_STATUS_MESSAGE - 3;
        while !m.is_char_boundary(end) {
            end -= 1;
        }
        m.truncate(end);
        m.push('…');
    }
    m
}

/// The start of tonic's message for a request whose bytes are not the protobuf message the
/// method takes, as it travels in `grpc-message` (percent-encoded).
const UNPARSED_REQUEST: &[u8] = b"failed%20to%20decode%20Protobuf%20message";

/// A response whose status says the request could not be parsed, with its code made
/// INVALID_ARGUMENT: tonic answers INTERNAL, after gRPC's table of status codes, but such a
/// request is the client's error, one it must correct, not the server's, and Sable answers
/// every other malformed input with INVALID_ARGUMENT. The message is kept. Only
/// trailers-only responses carry it in their headers; those are the answers to requests
/// refused before their method ran, which parse errors are while no method streams its
/// requests (none does: each takes one message).
pub fn unparsed_request_is_invalid_argument<B>(mut response: axum::http::Response<B>) -> axum::http::Response<B> {
    let headers = response.headers_mut();
    let internal = headers.get("grpc-status").is_some_and(|c| c.as_bytes() == b"13");
    if internal && headers.get("grpc-message").is_some_and(|m| m.as_bytes().starts_with(UNPARSED_REQUEST)) {
        headers.insert("grpc-status", axum::http::HeaderValue::from_static("3"));
    }
    response
}

fn worker_status(e: StoreError) -> Status {
    match e {
        StoreError::Conflict(m) => Status::failed_precondition(bounded(m)),
        StoreError::NotFound(id) => Status::not_found(format!("job {id} not found")),
        StoreError::Missing(m) => Status::not_found(bounded(m)),
        e => {
            eprintln!("store error: {e}");
            Status::unavailable("job store unavailable")
        }
    }
}

#[tonic::async_trait]
impl pb::workers_server::Workers for WorkersService {
    async fn lease_job(&self, req: Request<pb::LeaseJobRequest>) -> Result<Response<pb::LeaseJobResponse>, Status> {
        let worker = req.into_inner().worker;
        if worker.is_empty() || worker.len() > 200 || worker.starts_with("local:") || worker.chars().any(char::is_control) {
            return Err(Status::invalid_argument(
                "worker: must be 1 to 200 characters, none a control character, and not start with 'local:' (reserved)",
            ));
        }
        let lease = self.store.lease_next(&format!("remote:{worker}")).await.map_err(worker_status)?;
        let lease = match lease {
            Some(l) => {
                let resume = match l.resume {
                    Some(r) => {
                        let mut samples_json = Vec::with_capacity(r.samples.len());
                        for s in &r.samples {
                            samples_json.push(serde_json::to_string(s).map_err(|e| Status::internal(format!("a stored sample: {e}")))?);
                        }
                        Some(pb::ResumeFrom { step: r.step, checkpoint_gz: r.checkpoint, samples_json })
                    }
                    None => None,
                };
                Some(pb::Lease {
                    job_id: l.job_id,
                    lease_id: l.lease_id,
                    scene_json: l.scene_json,
                    attempt: l.attempt,
                    lease_seconds: self.lease_seconds,
                    resume,
                })
            }
            None => None,
        };
        Ok(Response::new(pb::LeaseJobResponse { lease }))
    }

    async fn report_progress(&self, req: Request<pb::ReportProgressRequest>) -> Result<Response<pb::ReportProgressResponse>, Status> {
        let r = req.into_inner();
        // Worker-supplied figures are checked like a user's: a NaN fraction once broke a NOT
        // NULL constraint and was answered UNAVAILABLE, so the worker retried it for good.
        if !(0.0..=1.0).contains(&r.fraction) {
            return Err(Status::invalid_argument(format!("fraction: must be between 0 and 1, got {}", r.fraction)));
        }
        if r.remaining_seconds.is_nan() {
            return Err(Status::invalid_argument("remaining_seconds: must be a number (negative: unknown)"));
        }
        let mut samples = Vec::with_capacity(r.samples_json.len());
        for (i, s) in r.samples_json.iter().enumerate() {
            let s: Sample =
                serde_json::from_str(s).map_err(|e| Status::invalid_argument(format!("samples_json[{i}]: not a sample: {e}")))?;
            if !s.is_finite() {
                return Err(Status::invalid_argument(format!("samples_json[{i}]: non-finite values are never stored")));
            }
            samples.push(s);
        }
        let mut snapshots = Vec::with_capacity(r.snapshots.len());
        for (i, f) in r.snapshots.into_iter().enumerate() {
            for (name, gz) in [("particles_gz", &f.particles_gz), ("contacts_gz", &f.contacts_gz), ("walls_gz", &f.walls_gz)] {
                // The header only: the files are decompressed, with a bound, when downloaded.
                if !gz.starts_with(&[0x1f, 0x8b]) {
                    return Err(Status::invalid_argument(format!("snapshots[{i}].{name}: not a gzip stream")));
                }
            }
            snapshots.push(SnapshotFiles {
                index: f.index,
                step: f.step,
                time: f.time,
                particles: f.particles_gz,
                contacts: f.contacts_gz,
                walls: f.walls_gz,
            });
        }
        let checkpoint = match r.checkpoint {
            // The header only, as for snapshots: it is decompressed, with a bound, when a
            // worker goes on from it.
            Some(c) if !c.data_gz.starts_with(&[0x1f, 0x8b]) => {
                return Err(Status::invalid_argument("checkpoint.data_gz: not a gzip stream"))
            }
            Some(c) => Some(CheckpointFile { step: c.step, samples: c.samples, snapshots: c.snapshots, data: c.data_gz }),
            None => None,
        };
        let report = Report {
            fraction: r.fraction,
            remaining_seconds: (r.remaining_seconds >= 0.0).then_some(r.remaining_seconds),
            samples,
            snapshots,
            first_sample: r.first_sample,
            checkpoint,
            from_start: r.from_start,
        };
        let cancel = self.store.report(&lease_of(r.job_id, r.lease_id)?, &report).await.map_err(worker_status)?;
        Ok(Response::new(pb::ReportProgressResponse { cancel_requested: cancel }))
    }

    async fn finish_job(&self, req: Request<pb::FinishJobRequest>) -> Result<Response<pb::FinishJobResponse>, Status> {
        let r = req.into_inner();
        let outcome = match r.outcome() {
            PbOutcome::Succeeded => {
                // The result is stored as sent; it must be a JSON object (or absent).
                let result = if r.result_json.is_empty() {
                    None
                } else {
                    match serde_json::from_str::<serde_json::Value>(&r.result_json) {
                        Ok(v) if v.is_object() => Some(r.result_json.clone()),
                        _ => return Err(Status::invalid_argument("result_json: must be a JSON object or empty")),
                    }
                };
                // Checked to be gzip (the header): it is decompressed, with a bound, when read.
                let state = if r.final_state_gz.is_empty() {
                    None
                } else if r.final_state_gz.starts_with(&[0x1f, 0x8b]) {
                    Some(r.final_state_gz)
                } else {
                    return Err(Status::invalid_argument("final_state_gz: not a gzip stream"));
                };
                Outcome::Succeeded {
                    steps: r.steps,
                    wall_seconds: r.wall_seconds,
                    cpu_seconds: r.cpu_seconds,
                    solver_iterations: r.solver_iterations,
                    result,
                    state,
                }
            }
            // Stored as text: the NUL character, which PostgreSQL refuses, becomes �.
            PbOutcome::Failed => Outcome::Failed {
                code: r.error_code.replace('\0', "\u{FFFD}"),
                message: r.error_message.replace('\0', "\u{FFFD}"),
                steps: r.steps,
                wall_seconds: r.wall_seconds,
                cpu_seconds: r.cpu_seconds,
            },
            PbOutcome::Cancelled => Outcome::Cancelled { steps: r.steps, wall_seconds: r.wall_seconds, cpu_seconds: r.cpu_seconds },
            PbOutcome::Released => Outcome::Released,
            PbOutcome::Unspecified => return Err(Status::invalid_argument("outcome: must be set")),
        };
        self.store.finish(&lease_of(r.job_id, r.lease_id)?, &outcome).await.map_err(worker_status)?;
        Ok(Response::new(pb::FinishJobResponse {}))
    }
}

/// `sable.v1.Studies`: the same operations as `/v1/studies` (crate::studies).
#[derive(Debug, Clone)]
pub struct StudiesService {
    /// The job store.
    pub store: JobStore,
    /// Request limits (a study's runs are checked as submitted scenes).
    pub limits: api::Limits,
}

fn pb_study(v: crate::studies::StudyView) -> pb::Study {
    pb::Study {
        id: v.id,
        name: v.name,
        kind: v.kind,
        state: v.state,
        runs_done: v.runs_done as u32,
        runs: v.runs as u32,
        created_at: v.created_at,
        finished_at: v.finished_at,
        error: v.error.unwrap_or_default(),
        report_json: v.report.map(|r| r.to_string()).unwrap_or_default(),
    }
}

#[tonic::async_trait]
impl pb::studies_server::Studies for StudiesService {
    async fn create_study(&self, req: Request<pb::CreateStudyRequest>) -> Result<Response<pb::Study>, Status> {
        let r = req.into_inner();
        let body: serde_json::Value = serde_json::from_str(&r.study_json)
            .map_err(|e| Status::from(ApiError::invalid("study_json", format!("must be a JSON object: {e}"))))?;
        if !body.is_object() {
            return Err(ApiError::invalid("study_json", "must be a JSON object (a study)").into());
        }
        Ok(Response::new(pb_study(crate::studies::create(&self.store, &self.limits, &body).await?)))
    }

    async fn get_study(&self, req: Request<pb::GetStudyRequest>) -> Result<Response<pb::Study>, Status> {
        Ok(Response::new(pb_study(crate::studies::get(&self.store, req.into_inner().id).await?)))
    }

    async fn list_studies(&self, req: Request<pb::ListStudiesRequest>) -> Result<Response<pb::ListStudiesResponse>, Status> {
        let n = match req.into_inner().page_size {
            0 => 100,
            n => n.min(100),
        };
        let studies = crate::studies::list(&self.store, i64::from(n)).await?.into_iter().map(pb_study).collect();
        Ok(Response::new(pb::ListStudiesResponse { studies }))
    }

    async fn get_study_chart(&self, req: Request<pb::GetStudyChartRequest>) -> Result<Response<pb::Chart>, Status> {
        let r = req.into_inner();
        let format = match r.format.as_str() {
            "" | "svg" => crate::charts::Format::Svg,
            "png" => crate::charts::Format::Png,
            f => return Err(ApiError::invalid("format", format!("must be svg or png, got '{f}'")).into()),
        };
        let view = crate::studies::get(&self.store, r.id).await?;
        let data = crate::studies::chart(&view, format)?;
        Ok(Response::new(pb::Chart { content_type: format.content_type().into(), data }))
    }
}
