//! The REST API (axum): the same operations as gRPC, as JSON over HTTP, plus Server-Sent Events,
//! health and Prometheus metrics. Routes:
//!
//! | method | path | what |
//! |---|---|---|
//! | POST | `/v1/jobs` | submit (body: a scene, or `{"scene", "name", "priority", "max_attempts"}`; `Idempotency-Key` header) |
//! | GET | `/v1/jobs` | list, summaries without scenes (`state, name, method, created_after, created_before, page_size, page_token`) |
//! | GET | `/v1/jobs/{id}` | one job |
//! | POST | `/v1/jobs/{id}:cancel` | cancel |
//! | GET | `/v1/jobs/{id}/samples` | samples, 10,000 a page (`from_step, to_step, max_points, limit, format=json|csv`; `next_from_step`) |
//! | GET | `/v1/jobs/{id}/events` | Server-Sent Events (`after_seq` or `Last-Event-ID` to resume) |
//! | GET | `/v1/jobs/{id}/snapshots` | the job's VTK snapshots (index, step, time, file URLs) |
//! | GET | `/v1/jobs/{id}/snapshots/{index}/{part}` | one file: `particles`, `contacts` or `walls` (`.vtp`) |
//! | GET | `/v1/jobs/{id}/state` | the final state of a succeeded job (JSON; a scene's `start_from`) |
//! | GET | `/v1/openapi.json` | the OpenAPI document |
//! | GET | `/healthz`, `/metrics` | liveness, Prometheus text |
//! | GET | `/`, `/assets/...` | the browser dashboard ([`crate::dashboard`]) |

use std::convert::Infallible;
use std::sync::Arc;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::Json;
use sable_engine::observe::Sample;
use serde::Deserialize;
use serde_json::json;

use crate::api::{self, ApiError, ListQuery, Submission};
use crate::store::{JobStore, Outage, SnapshotPart};
use crate::watch::{take_slot, watch_stream, WatchItem};

/// What the handlers share.
#[derive(Debug, Clone)]
pub struct AppState {
    /// The job store.
    pub store: JobStore,
    /// Busy/total worker counters of the local pool, if any.
    pub pool: Option<Arc<sable_worker::PoolStats>>,
    /// Idle interval between heartbeats of event streams.
    pub heartbeat: Duration,
    /// Request limits.
    pub limits: api::Limits,
    /// Open event streams (REST and gRPC share it).
    pub watchers: Arc<tokio::sync::Semaphore>,
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let status = match &self {
            ApiError::Malformed(_) => StatusCode::BAD_REQUEST,
            ApiError::InvalidArgument(_) => StatusCode::UNPROCESSABLE_ENTITY,
            ApiError::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            ApiError::Exhausted(_) => StatusCode::TOO_MANY_REQUESTS,
            ApiError::NotFound(_) => StatusCode::NOT_FOUND,
            ApiError::Conflict(_) => StatusCode::CONFLICT,
            ApiError::Unavailable(_) => StatusCode::SERVICE_UNAVAILABLE,
            ApiError::StorageFull(_) => StatusCode::INSUFFICIENT_STORAGE,
            ApiError::Unauthenticated(_) => StatusCode::UNAUTHORIZED,
            ApiError::Internal(_) => StatusCode::INTERNAL_SERVER_ERROR,
        };
        (status, Json(api::ErrorBody::from(&self))).into_response()
    }
}

/// The body of `POST /v1/jobs` in its wrapped form (a bare scene is accepted too).
#[derive(Debug, serde::Deserialize, utoipa::ToSchema)]
#[allow(dead_code)] // documents the wrapper that rest::submit reads field by field
pub struct SubmitBody {
    /// The scene (docs/scene-format.md).
    #[schema(value_type = Object)]
    scene: serde_json::Value,
    /// Job name (default: the scene's).
    #[schema(max_length = 200)]
    name: Option<String>,
    /// Higher runs first; FIFO within a priority.
    #[schema(minimum = -1000, maximum = 1000)]
    priority: Option<i64>,
    /// Leases allowed before the job fails (default 3).
    #[schema(minimum = 1, maximum = 20)]
    max_attempts: Option<u32>,
}

/// A request body read as JSON (413 over the server's limit, 400 when it is not JSON).
pub(crate) fn json_body(st: &AppState, body: Result<Bytes, BytesRejection>) -> Result<serde_json::Value, ApiError> {
    let body = body.map_err(|e| match e.status() {
        StatusCode::PAYLOAD_TOO_LARGE => ApiError::TooLarge(st.limits.max_body_bytes),
        _ => ApiError::malformed("", e.body_text()),
    })?;
    serde_json::from_slice(&body).map_err(|e| ApiError::malformed("", format!("the body must be a JSON object: {e}")))
}

pub(crate) fn parse_id(s: &str) -> Result<i64, ApiError> {
    positive_id(s, "job")
}

/// A path id of a `what` (job, study): a positive integer.
pub(crate) fn positive_id(s: &str, what: &str) -> Result<i64, ApiError> {
    s.parse::<i64>()
        .ok()
        .filter(|&i| i > 0)
        .ok_or_else(|| ApiError::malformed("id", format!("must be a positive integer {what} id, got '{s}'")))
}

pub(crate) fn query<T>(q: Result<Query<T>, QueryRejection>) -> Result<T, ApiError> {
    q.map(|Query(t)| t).map_err(|e| ApiError::malformed("query", e.body_text()))
}

/// `POST /v1/jobs`.
#[utoipa::path(
    post,
    path = "/v1/jobs",
    tag = "jobs",
    summary = "Validate and queue a scene",
    request_body(content = SubmitBody, description = "A scene (docs/scene-format.md), or {\"scene\", \"name\", \"priority\", \"max_attempts\"}"),
    params(("Idempotency-Key" = Option<String>, Header, description = "The same key returns the first job (200); with another scene it is a 409")),
    responses(
        (status = 201, description = "Queued", body = api::JobView),
        (status = 200, description = "Already submitted with this Idempotency-Key", body = api::JobView),
        (status = 400, description = "The body is not a JSON object", body = api::ErrorBody),
        (status = 409, description = "Idempotency-Key reused with another scene", body = api::ErrorBody),
        (status = 413, description = "The body is larger than the server's limit", body = api::ErrorBody),
        (status = 422, description = "The scene or a field breaks a rule; every violation is in details", body = api::ErrorBody),
    )
)]
pub(crate) async fn submit(
    State(st): State<AppState>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let value = json_body(&st, body)?;
    let mut sub = Submission::default();
    match value {
        serde_json::Value::Object(mut m) if m.contains_key("scene") => {
            sub.scene = m.remove("scene").unwrap_or_default();
            sub.scene_path = "scene.";
            let mut violations = Vec::new();
            for (k, v) in m {
                match k.as_str() {
                    "name" => match v.as_str() {
                        Some(s) => sub.name = Some(s.to_string()),
                        None => violations.push(("name", "must be a string")),
                    },
                    "priority" => match v.as_i64() {
                        Some(p) => sub.priority = Some(p),
                        None => violations.push(("priority", "must be an integer")),
                    },
                    "max_attempts" => match v.as_u64().and_then(|x| u32::try_from(x).ok()) {
                        Some(p) => sub.max_attempts = Some(p),
                        None => violations.push(("max_attempts", "must be a positive integer")),
                    },
                    _ => {
                        return Err(ApiError::invalid(k.clone(), "unknown field: expected scene, name, priority or max_attempts"));
                    }
                }
            }
            if !violations.is_empty() {
                return Err(ApiError::InvalidArgument(
                    violations.into_iter().map(|(f, r)| sable_engine::scene::Violation { field: f.into(), rule: r.into() }).collect(),
                ));
            }
        }
        v @ serde_json::Value::Object(_) => sub.scene = v,
        _ => return Err(ApiError::malformed("", "the body must be a JSON object: a scene, or {\"scene\": ..., \"name\": ...}")),
    }
    if let Some(k) = headers.get("idempotency-key") {
        sub.idempotency_key = Some(k.to_str().map_err(|_| ApiError::invalid("Idempotency-Key", "must be visible ASCII"))?.to_string());
    }
    let (job, created) = api::submit(&st.store, &st.limits, sub).await?;
    let status = if created { StatusCode::CREATED } else { StatusCode::OK };
    Ok((status, [(header::LOCATION, format!("/v1/jobs/{}", job.id))], Json(job)).into_response())
}

/// `POST /v1/advice`.
#[utoipa::path(
    post,
    path = "/v1/advice",
    tag = "jobs",
    summary = "The method advisor's choice for a scene, without running it",
    request_body(content = SubmitBody, description = "A scene (docs/scene-format.md) whose method may be auto or a name, or {\"scene\": ...}"),
    responses(
        (status = 200, description = "The choice, its reasons, the scene's dimensionless numbers, what it does not need", body = sable_engine::advise::Advice),
        (status = 400, description = "The body is not a JSON object", body = api::ErrorBody),
        (status = 413, description = "The body is larger than the server's limit", body = api::ErrorBody),
        (status = 422, description = "The scene breaks a rule; every violation is in details", body = api::ErrorBody),
    )
)]
pub(crate) async fn advice(State(st): State<AppState>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let value = json_body(&st, body)?;
    let (scene, path) = match value {
        serde_json::Value::Object(mut m) if m.contains_key("scene") => {
            if let Some(k) = m.keys().find(|k| *k != "scene") {
                return Err(ApiError::invalid(k.clone(), "unknown field: expected scene"));
            }
            (m.remove("scene").unwrap_or_default(), "scene.")
        }
        v @ serde_json::Value::Object(_) => (v, ""),
        _ => return Err(ApiError::malformed("", "the body must be a JSON object: a scene, or {\"scene\": ...}")),
    };
    Ok(Json(api::advise(&st.store, &st.limits, &scene, path).await?).into_response())
}

/// Query of `GET /v1/jobs`.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub(crate) struct ListParams {
    /// queued, running, succeeded, failed or cancelled.
    state: Option<String>,
    /// Exact name.
    name: Option<String>,
    /// Method name, e.g. dem.
    method: Option<String>,
    /// RFC 3339 time (inclusive).
    created_after: Option<String>,
    /// RFC 3339 time (exclusive).
    created_before: Option<String>,
    /// 1 to 500, default 50.
    page_size: Option<u32>,
    /// next_page_token of the previous page.
    page_token: Option<String>,
}

/// A page of jobs.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub(crate) struct JobPage {
    /// Newest first.
    jobs: Vec<api::JobView>,
    /// Token of the next page; empty on the last.
    next_page_token: String,
}

/// `GET /v1/jobs`.
#[utoipa::path(
    get,
    path = "/v1/jobs",
    tag = "jobs",
    summary = "Jobs, newest first",
    params(ListParams),
    responses(
        (status = 200, description = "A page", body = JobPage),
        (status = 400, description = "A query parameter cannot be read", body = api::ErrorBody),
        (status = 422, description = "A filter breaks a rule", body = api::ErrorBody),
    )
)]
pub(crate) async fn list(State(st): State<AppState>, q: Result<Query<ListParams>, QueryRejection>) -> Result<Response, ApiError> {
    let p = query(q)?;
    let (jobs, next) = api::list(
        &st.store,
        ListQuery {
            state: p.state,
            name: p.name,
            method: p.method,
            created_after: p.created_after,
            created_before: p.created_before,
            page_size: p.page_size,
            page_token: p.page_token,
        },
    )
    .await?;
    Ok(Json(JobPage { jobs, next_page_token: next.unwrap_or_default() }).into_response())
}

/// `GET /v1/jobs/{id}`.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}",
    tag = "jobs",
    summary = "One job",
    params(("id" = i64, Path, description = "Job id")),
    responses(
        (status = 200, description = "The job", body = api::JobView),
        (status = 400, description = "The id is not a positive integer", body = api::ErrorBody),
        (status = 404, description = "No such job", body = api::ErrorBody),
    )
)]
pub(crate) async fn get_job(State(st): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let id = parse_id(&id)?;
    Ok(Json(api::JobView::from(st.store.get(id).await?)).into_response())
}

/// `POST /v1/jobs/{id}:cancel` (the one action so far).
#[utoipa::path(
    post,
    path = "/v1/jobs/{id}:cancel",
    tag = "jobs",
    summary = "Cancel a queued or running job (a running one stops within a second)",
    params(("id" = i64, Path, description = "Job id")),
    responses(
        (status = 200, description = "The job after the request", body = api::JobView),
        (status = 404, description = "No such job or action", body = api::ErrorBody),
        (status = 409, description = "The job has already ended", body = api::ErrorBody),
    )
)]
pub(crate) async fn job_action(State(st): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let Some(id) = id.strip_suffix(":cancel") else {
        return Err(ApiError::NotFound(format!("no action in '/v1/jobs/{id}': use POST /v1/jobs/{{id}}:cancel")));
    };
    let id = parse_id(id)?;
    Ok(Json(api::JobView::from(st.store.cancel(id).await?)).into_response())
}

/// Query of `GET /v1/jobs/{id}/samples`.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub(crate) struct SampleParams {
    /// First step (inclusive).
    from_step: Option<u64>,
    /// Last step (inclusive).
    to_step: Option<u64>,
    /// Keep at most this many samples, evenly spread (first and last kept; at most 10,000).
    max_points: Option<u32>,
    /// Without `max_points`: at most this many samples (default and largest 10,000); a longer
    /// range is read in pages, each giving the `from_step` of the next (`next_from_step`, and
    /// the `Sable-Next-From-Step` header in CSV).
    limit: Option<u32>,
    /// json (default) or csv.
    format: Option<String>,
}

/// A job's samples.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub(crate) struct SamplePage {
    /// The job.
    job_id: i64,
    /// In step order, with the engine's field names.
    samples: Vec<Sample>,
    /// The job's last event sequence number when the samples were read: the event stream
    /// resumed after it (`after_seq`) brings exactly the samples stored since.
    events_seq: i64,
    /// The `from_step` of the next page, when the range holds more samples than this one.
    #[serde(skip_serializing_if = "Option::is_none")]
    next_from_step: Option<u64>,
}

/// `GET /v1/jobs/{id}/samples`.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}/samples",
    tag = "jobs",
    summary = "The job's measured time series (JSON, or CSV with format=csv)",
    params(("id" = i64, Path, description = "Job id"), SampleParams),
    responses(
        (status = 200, description = "Samples", body = SamplePage, content_type = "application/json"),
        (status = 400, description = "A parameter cannot be read", body = api::ErrorBody),
        (status = 404, description = "No such job", body = api::ErrorBody),
        (status = 422, description = "A parameter breaks a rule", body = api::ErrorBody),
    )
)]
pub(crate) async fn samples(
    State(st): State<AppState>,
    Path(id): Path<String>,
    q: Result<Query<SampleParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    let id = parse_id(&id)?;
    let p = query(q)?;
    let csv = match p.format.as_deref() {
        None | Some("json") => false,
        Some("csv") => true,
        Some(f) => return Err(ApiError::invalid("format", format!("must be json or csv, got '{f}'"))),
    };
    let read = api::samples(&st.store, id, p.from_step.unwrap_or(0), p.to_step, p.max_points, p.limit).await?;
    let mut response = if csv {
        ([(header::CONTENT_TYPE, "text/csv; charset=utf-8")], samples_csv(read.dim, &read.samples)).into_response()
    } else {
        Json(SamplePage { job_id: id, samples: read.samples, events_seq: read.events_seq, next_from_step: read.next_from_step })
            .into_response()
    };
    if let Some(next) = read.next_from_step {
        response.headers_mut().insert("sable-next-from-step", header::HeaderValue::from(next));
    }
    Ok(response)
}

/// One stored snapshot.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub(crate) struct SnapshotView {
    /// Number of the snapshot in the job, from 0.
    index: i64,
    /// Step it was taken at.
    step: i64,
    /// Simulated time, s.
    time: f64,
    /// Paths of its files: particles, contacts, walls (VTK XML PolyData).
    files: Vec<String>,
}

/// Body of `GET /v1/jobs/{id}/snapshots`.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub(crate) struct SnapshotList {
    /// Job.
    job_id: i64,
    /// In the order taken.
    snapshots: Vec<SnapshotView>,
}

/// `GET /v1/jobs/{id}/snapshots`.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}/snapshots",
    tag = "jobs",
    summary = "The job's VTK snapshots for ParaView (scene field `snapshots`)",
    params(("id" = i64, Path, description = "Job id")),
    responses(
        (status = 200, description = "Snapshots, possibly none", body = SnapshotList),
        (status = 400, description = "The id cannot be read", body = api::ErrorBody),
        (status = 404, description = "No such job", body = api::ErrorBody),
    )
)]
pub(crate) async fn snapshots(State(st): State<AppState>, Path(id): Path<String>) -> Result<Json<SnapshotList>, ApiError> {
    let id = parse_id(&id)?;
    let rows = st.store.snapshots(id).await?;
    let snapshots = rows
        .into_iter()
        .map(|r| SnapshotView {
            index: r.idx,
            step: r.step,
            time: r.time,
            files: SnapshotPart::ALL.iter().map(|p| format!("/v1/jobs/{id}/snapshots/{}/{}.vtp", r.idx, p.name())).collect(),
        })
        .collect();
    Ok(Json(SnapshotList { job_id: id, snapshots }))
}

/// Largest file served once decompressed, bytes (a snapshot of a million particles is ~0.6 GB).
const MAX_SNAPSHOT_FILE: u64 = 4 << 30;

/// Size of the pieces a stored gzip file is served in once decompressed, bytes.
const UNZIP_CHUNK: usize = 64 << 10;

/// The decompressed text of a stored gzip file (a worker's snapshot, a final state) as a
/// streamed body: decompressed on a blocking thread a piece at a time while the client reads,
/// so a request holds a few pieces however large the file, and ended with an error past
/// `limit` bytes. A file that does not start as gzip is an error before anything is sent.
/// Before, the whole text was built in memory first: a 1.5 MB "snapshot" from a worker's
/// token became a 1.5 GiB allocation on a user's download.
fn unzipped_body(gz: Vec<u8>, limit: u64, what: String) -> Result<axum::body::Body, ApiError> {
    use std::io::Read;
    let mut decoder = flate2::read::GzDecoder::new(std::io::Cursor::new(gz));
    let mut first = vec![0u8; UNZIP_CHUNK];
    let n = decoder.read(&mut first).map_err(|e| ApiError::Internal(format!("{what} cannot be read: {e}")))?;
    first.truncate(n);
    let (tx, rx) = tokio::sync::mpsc::channel::<std::io::Result<Vec<u8>>>(4);
    tokio::task::spawn_blocking(move || {
        let mut sent = first.len() as u64;
        if tx.blocking_send(Ok(first)).is_err() {
            return;
        }
        loop {
            let mut piece = vec![0u8; UNZIP_CHUNK];
            let piece = match decoder.read(&mut piece) {
                Ok(0) => return,
                Ok(n) => {
                    sent += n as u64;
                    piece.truncate(n);
                    if sent > limit {
                        Err(std::io::Error::new(
                            std::io::ErrorKind::InvalidData,
                            format!("{what}: more than {limit} bytes once decompressed"),
                        ))
                    } else {
                        Ok(piece)
                    }
                }
                Err(e) => Err(e),
            };
            let failed = piece.is_err();
            // The client went away: stop decompressing.
            if tx.blocking_send(piece).is_err() || failed {
                return;
            }
        }
    });
    Ok(axum::body::Body::from_stream(tokio_stream::wrappers::ReceiverStream::new(rx)))
}

/// `GET /v1/jobs/{id}/snapshots/{index}/{part}`.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}/snapshots/{index}/{part}",
    tag = "jobs",
    summary = "One file of a snapshot: particles, contacts or walls (VTK XML PolyData; `.vtp` suffix optional)",
    params(
        ("id" = i64, Path, description = "Job id"),
        ("index" = u32, Path, description = "Snapshot number, from 0"),
        ("part" = String, Path, description = "particles, contacts or walls (optionally with .vtp)"),
    ),
    responses(
        (status = 200, description = "The file", body = String, content_type = "application/xml"),
        (status = 400, description = "The id, index or part cannot be read", body = api::ErrorBody),
        (status = 404, description = "No such job or snapshot", body = api::ErrorBody),
    )
)]
pub(crate) async fn snapshot_file(
    State(st): State<AppState>,
    Path((id, index, part)): Path<(String, String, String)>,
) -> Result<Response, ApiError> {
    let id = parse_id(&id)?;
    let index: u32 = index.parse().map_err(|_| ApiError::malformed("index", format!("must be a snapshot number >= 0, got '{index}'")))?;
    let part = SnapshotPart::parse(&part)
        .ok_or_else(|| ApiError::malformed("part", format!("must be particles, contacts or walls (optionally .vtp), got '{part}'")))?;
    let gz = st.store.snapshot_file(id, index, part).await?;
    let body = unzipped_body(gz, MAX_SNAPSHOT_FILE, format!("snapshot {index} of job {id}"))?;
    let disposition = format!("attachment; filename=\"job{id}_{}_{index:06}.vtp\"", part.name());
    Ok(([(header::CONTENT_TYPE, "application/xml".to_string()), (header::CONTENT_DISPOSITION, disposition)], body).into_response())
}

/// `GET /v1/jobs/{id}/state`.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}/state",
    tag = "jobs",
    summary = "The final state of a succeeded job: particles and box (docs/scene-format.md §14), to start another scene from",
    params(("id" = i64, Path, description = "Job id")),
    responses(
        (status = 200, description = "The state (JSON)", body = Object, content_type = "application/json"),
        (status = 400, description = "The id cannot be read", body = api::ErrorBody),
        (status = 404, description = "No such job, or the job has no final state (it has not succeeded)", body = api::ErrorBody),
    )
)]
pub(crate) async fn final_state(State(st): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    let id = parse_id(&id)?;
    let gz = st.store.final_state(id).await?;
    let body = unzipped_body(gz, crate::start_from::MAX_STATE_BYTES, format!("the final state of job {id}"))?;
    let disposition = format!("attachment; filename=\"job{id}_state.json\"");
    Ok(([(header::CONTENT_TYPE, "application/json".to_string()), (header::CONTENT_DISPOSITION, disposition)], body).into_response())
}

/// Samples as CSV with the engine's column names.
pub fn samples_csv(dim: usize, samples: &[Sample]) -> String {
    let mut out = Sample::csv_header(dim).join(",");
    out.push('\n');
    for s in samples {
        out.push_str(&s.csv_row(dim).join(","));
        out.push('\n');
    }
    out
}

/// Query of `GET /v1/jobs/{id}/events`.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub(crate) struct EventParams {
    /// Send the events after this sequence number (a Last-Event-ID header, as a reconnecting
    /// browser sends, takes precedence).
    after_seq: Option<i64>,
}

/// `GET /v1/jobs/{id}/events`: Server-Sent Events, `id:` = sequence number, `event:` = kind.
#[utoipa::path(
    get,
    path = "/v1/jobs/{id}/events",
    tag = "jobs",
    summary = "Server-Sent Events: state changes and samples, ending after the final state",
    description = "Each event has id = sequence number, event = state | sample | heartbeat, and JSON data. Resume with after_seq or Last-Event-ID (the header wins when both are given: a reconnecting browser sends its original URL with it).",
    params(("id" = i64, Path, description = "Job id"), EventParams),
    responses(
        (status = 200, description = "The event stream", body = String, content_type = "text/event-stream"),
        (status = 404, description = "No such job", body = api::ErrorBody),
        (status = 429, description = "Too many open event streams", body = api::ErrorBody),
    )
)]
pub(crate) async fn events(
    State(st): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    admitted: Option<axum::Extension<crate::auth::Admitted>>,
    q: Result<Query<EventParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    let id = parse_id(&id)?;
    let p = query(q)?;
    // A browser's EventSource reconnects with the URL it opened (its after_seq) and the last
    // event it received in Last-Event-ID: the header is the newer of the two.
    let resume = headers.get("last-event-id").and_then(|v| v.to_str().ok()).and_then(|s| s.parse::<i64>().ok());
    let after = resume.or(p.after_seq).unwrap_or(0);
    if after < 0 {
        return Err(ApiError::invalid("after_seq", "must be >= 0"));
    }
    let slot = take_slot(&st.watchers, st.limits.max_watchers)?;
    let still = admitted.map(|axum::Extension(a)| a.checker());
    let stream = watch_stream(&st.store, id, after, st.heartbeat, slot, still, |item| {
        Ok::<_, Infallible>(match item {
            Ok(WatchItem::Event(e)) => Event::default().id(e.seq.to_string()).event(e.kind.clone()).data(e.payload),
            Ok(WatchItem::Heartbeat) => Event::default().event("heartbeat").data("{}"),
            Err(e) => Event::default().event("error").data(json!({"code": e.code(), "message": e.to_string()}).to_string()),
        })
    })
    .await?;
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()).into_response())
}

/// `GET /healthz`: the database answers reads, takes a write and stored the last worker report
/// it was sent (503 otherwise, with the reason: a store whose disk is full reads but cannot
/// write).
#[utoipa::path(get, path = "/healthz", tag = "service", summary = "Health: the database answers and can write",
    responses((status = 200, description = "Healthy"), (status = 503, description = "The database does not answer, or cannot write")))]
pub(crate) async fn healthz(State(st): State<AppState>) -> Response {
    let checked = match st.store.count_by_state().await {
        Ok(_) => st.store.probe_write().await.map_err(|e| ("cannot write", e)),
        Err(e) => Err(("cannot read", e)),
    };
    match checked {
        Ok(()) => match st.store.report_failure() {
            None => (StatusCode::OK, Json(json!({"status": "ok"}))).into_response(),
            Some(why) => (
                StatusCode::SERVICE_UNAVAILABLE,
                Json(json!({"status": "unavailable", "reason": format!("the store cannot take a worker's samples: its disk is full ({why})")})),
            )
                .into_response(),
        },
        Err((what, e)) => {
            let reason = match e.outage() {
                Some(Outage::DiskFull) => format!("the store {what}: its disk is full ({e})"),
                _ => format!("the store {what}: {e}"),
            };
            (StatusCode::SERVICE_UNAVAILABLE, Json(json!({"status": "unavailable", "reason": reason}))).into_response()
        }
    }
}

/// `GET /metrics`: Prometheus text format.
#[utoipa::path(get, path = "/metrics", tag = "service",
    summary = "Prometheus metrics: jobs by state, queue depth, job durations, worker use",
    responses((status = 200, description = "Prometheus text format", body = String, content_type = "text/plain")))]
pub(crate) async fn metrics(State(st): State<AppState>) -> Result<Response, ApiError> {
    let body = crate::metrics::render(&st.store, st.pool.as_deref()).await?;
    Ok(([(header::CONTENT_TYPE, "text/plain; version=0.0.4")], body).into_response())
}
