//! The operations of the service, shared by REST and gRPC: input checks, the job view, and
//! one error type mapped to HTTP statuses and gRPC codes.

use sable_engine::methods::{plan_scene, Plan};
use sable_engine::observe::Sample;
use sable_engine::scene::Violation;
use serde::Serialize;
use sha2::{Digest, Sha256};

use crate::start_from;
pub use crate::store::downsample;
use crate::store::{JobLimits, JobRow, JobState, JobStore, ListFilter, NewJob, Outage, StoreError};

/// Every error the APIs return. Messages name the field and the rule, never internals.
#[derive(Debug, thiserror::Error)]
pub enum ApiError {
    /// The request cannot be read at all (not JSON, unparseable query or id).
    #[error("{}", sable_engine::scene::format_violations(.0))]
    Malformed(Vec<Violation>),
    /// The request (or its scene) breaks one or more rules; every violation is listed.
    #[error("invalid request: {}", sable_engine::scene::format_violations(.0))]
    InvalidArgument(Vec<Violation>),
    /// The body is larger than the server accepts.
    #[error("the request body is larger than the limit of {0} bytes")]
    TooLarge(usize),
    /// A server limit is reached (for example concurrent watchers); try again later.
    #[error("{0}")]
    Exhausted(String),
    /// No such job.
    #[error("{0}")]
    NotFound(String),
    /// Conflicts with the job's state or with an earlier request.
    #[error("{0}")]
    Conflict(String),
    /// The job store cannot be reached for now (a database outage); the request may be sent
    /// again. HTTP 503, gRPC UNAVAILABLE.
    #[error("the job store is unavailable: {0}; nothing was changed, try again later")]
    Unavailable(String),
    /// The job store's disk is full; the request may be sent again once space is freed. HTTP
    /// 507, gRPC RESOURCE_EXHAUSTED.
    #[error("the job store's disk is full: nothing was written; free space on the database's disk, then try again ({0})")]
    StorageFull(String),
    /// The token the request came with is no longer valid (revoked while an event stream was
    /// open). HTTP 401, gRPC UNAUTHENTICATED.
    #[error("{0}")]
    Unauthenticated(String),
    /// The server failed; the message is logged, the client gets a generic one.
    #[error("internal error")]
    Internal(String),
}

impl ApiError {
    /// One violation.
    pub fn invalid(field: impl Into<String>, rule: impl Into<String>) -> Self {
        Self::InvalidArgument(vec![Violation { field: field.into(), rule: rule.into() }])
    }

    /// A request that cannot be read, naming the part.
    pub fn malformed(field: impl Into<String>, rule: impl Into<String>) -> Self {
        Self::Malformed(vec![Violation { field: field.into(), rule: rule.into() }])
    }

    /// The violations, if any.
    pub fn details(&self) -> &[Violation] {
        match self {
            Self::Malformed(v) | Self::InvalidArgument(v) => v,
            _ => &[],
        }
    }

    /// Stable code of the error kind.
    pub fn code(&self) -> &'static str {
        match self {
            Self::Malformed(_) => "malformed",
            Self::InvalidArgument(_) => "invalid_argument",
            Self::TooLarge(_) => "too_large",
            Self::Exhausted(_) => "resource_exhausted",
            Self::NotFound(_) => "not_found",
            Self::Conflict(_) => "conflict",
            Self::Unavailable(_) => "unavailable",
            Self::StorageFull(_) => "insufficient_storage",
            Self::Unauthenticated(_) => "unauthenticated",
            Self::Internal(_) => "internal",
        }
    }
}

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::NotFound(id) => Self::NotFound(format!("job {id} not found")),
            StoreError::Missing(m) => Self::NotFound(m),
            StoreError::Conflict(m) => Self::Conflict(m),
            e => {
                eprintln!("store error: {e}");
                match e.outage() {
                    Some(Outage::DiskFull) => return Self::StorageFull(e.to_string()),
                    Some(Outage::Unreachable) => return Self::Unavailable(e.to_string()),
                    None => {}
                }
                Self::Internal(e.to_string())
            }
        }
    }
}

/// The one error body of the REST API.
#[derive(Debug, Clone, Serialize, PartialEq, utoipa::ToSchema)]
pub struct ErrorBody {
    /// `malformed`, `invalid_argument`, `too_large`, `resource_exhausted`, `not_found`,
    /// `conflict`, `unavailable`, `insufficient_storage` or `internal`.
    pub code: String,
    /// What is wrong, in one line.
    pub message: String,
    /// Every broken rule, with the path of its field.
    pub details: Vec<Violation>,
}

impl From<&ApiError> for ErrorBody {
    fn from(e: &ApiError) -> Self {
        Self { code: e.code().to_string(), message: e.to_string(), details: e.details().to_vec() }
    }
}

/// Limits of the submission fields.
pub const MAX_NAME: usize = 200;
/// Largest |priority|.
pub const MAX_PRIORITY: i64 = 1000;
/// Largest max_attempts.
pub const MAX_ATTEMPTS: u32 = 20;
/// Default max_attempts.
pub const DEFAULT_ATTEMPTS: u32 = 3;
/// Default and largest page sizes of lists.
pub const PAGE_SIZE: (u32, u32) = (50, 500);
/// Largest scene document accepted, bytes.
pub const MAX_SCENE_BYTES: usize = 16 << 20;

/// Limits on what one request may ask for (`sable serve` flags).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Particles in one scene.
    pub max_particles: usize,
    /// `stop.steps` of one scene.
    pub max_steps: u64,
    /// Request body, bytes.
    pub max_body_bytes: usize,
    /// Event streams open at once (WatchJob and SSE together).
    pub max_watchers: usize,
    /// Samples one job may store.
    pub max_samples: u64,
    /// Bytes one job may store (samples, their events, snapshots).
    pub max_job_bytes: u64,
}

impl Limits {
    /// What the store holds each job to as its reports arrive.
    pub fn job(&self) -> JobLimits {
        JobLimits { max_samples: self.max_samples, max_bytes: self.max_job_bytes, max_steps: self.max_steps }
    }
}

impl Default for Limits {
    fn default() -> Self {
        let job = JobLimits::default();
        Self {
            max_particles: 2_000_000,
            max_steps: job.max_steps,
            max_body_bytes: MAX_SCENE_BYTES,
            max_watchers: 1024,
            max_samples: job.max_samples,
            max_job_bytes: job.max_bytes,
        }
    }
}

/// A submission, from either API.
#[derive(Debug, Clone, Default)]
pub struct Submission {
    /// The scene (JSON).
    pub scene: serde_json::Value,
    /// Prefix of the scene's field paths in violations (`"scene."` when it was wrapped).
    pub scene_path: &'static str,
    /// Name (default: the scene's name).
    pub name: Option<String>,
    /// Priority (default 0).
    pub priority: Option<i64>,
    /// Attempts allowed (default 3).
    pub max_attempts: Option<u32>,
    /// Idempotency key.
    pub idempotency_key: Option<String>,
}

/// A job as the APIs show it.
#[derive(Debug, Clone, Serialize, PartialEq, utoipa::ToSchema)]
pub struct JobView {
    /// Id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// `queued`, `running`, `succeeded`, `failed` or `cancelled`.
    #[schema(example = "running")]
    pub state: String,
    /// Method used.
    pub method: String,
    /// Why that method.
    pub method_reason: String,
    /// Priority.
    pub priority: i64,
    /// RFC 3339 times.
    pub created_at: String,
    /// Start of the first attempt.
    pub started_at: Option<String>,
    /// End.
    pub finished_at: Option<String>,
    /// Leases taken.
    pub attempts: i64,
    /// Leases allowed.
    pub max_attempts: i64,
    /// Fraction done, 0..1.
    pub progress: f64,
    /// Why it failed.
    pub error: Option<ErrorView>,
    /// The scene as stored (canonical JSON: keys sorted; docs/scene-format.md). Absent in
    /// lists of jobs, which are summaries: `GET /v1/jobs/{id}` has it.
    #[schema(value_type = Object)]
    #[serde(skip_serializing_if = "serde_json::Value::is_null")]
    pub scene: serde_json::Value,
    /// SHA-256 of the stored scene, hex.
    pub scene_hash: String,
    /// Engine version that ran (or will run) it.
    pub engine_version: String,
    /// Random seed.
    pub seed: u64,
    /// Steps done.
    pub steps: i64,
    /// Wall-clock seconds of the run.
    pub wall_seconds: f64,
    /// CPU seconds of the job's threads (the cost studies chart).
    pub cpu_seconds: f64,
    /// Contact-solver sweeps (contact dynamics; 0 for DEM).
    pub solver_iterations: i64,
    /// Samples stored.
    pub sample_count: i64,
    /// A cancellation was asked and has not reached the worker yet.
    pub cancel_requested: bool,
    /// Derived results of the scene's experiment (docs/scene-format.md §13); absent for a scene
    /// without an experiment or a job that has not succeeded.
    #[serde(skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Object>)]
    pub result: Option<serde_json::Value>,
}

/// Error of a failed job.
#[derive(Debug, Clone, Serialize, PartialEq, utoipa::ToSchema)]
pub struct ErrorView {
    /// Stable code.
    pub code: String,
    /// Message.
    pub message: String,
}

/// RFC 3339 form of a time in ms.
pub fn rfc3339(ms: i64) -> String {
    let t = std::time::UNIX_EPOCH + std::time::Duration::from_millis(ms.max(0) as u64);
    humantime::format_rfc3339_millis(t).to_string()
}

/// Parses an RFC 3339 time into ms, naming `field` on error.
pub fn parse_time(field: &str, s: &str) -> Result<i64, ApiError> {
    let t = humantime::parse_rfc3339_weak(s)
        .map_err(|e| ApiError::invalid(field, format!("must be an RFC 3339 time such as 2026-01-31T12:00:00Z ({e})")))?;
    Ok(t.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis() as i64))
}

impl From<JobRow> for JobView {
    fn from(r: JobRow) -> Self {
        let error = r.error_code.clone().map(|code| ErrorView { code, message: r.error_message.clone().unwrap_or_default() });
        Self {
            id: r.id,
            name: r.name,
            state: r.state,
            method: r.method,
            method_reason: r.method_reason,
            priority: r.priority,
            created_at: rfc3339(r.created_at),
            started_at: r.started_at.map(rfc3339),
            finished_at: r.finished_at.map(rfc3339),
            attempts: r.attempts,
            max_attempts: r.max_attempts,
            progress: r.progress,
            error,
            scene: serde_json::from_str(&r.scene).unwrap_or(serde_json::Value::Null),
            scene_hash: r.scene_hash,
            engine_version: r.engine_version,
            seed: r.seed as u64,
            steps: r.steps,
            wall_seconds: r.wall_seconds,
            cpu_seconds: r.cpu_seconds,
            solver_iterations: r.solver_iterations,
            sample_count: r.sample_count,
            cancel_requested: r.cancel_requested != 0,
            result: r.result.as_deref().and_then(|t| serde_json::from_str(t).ok()),
        }
    }
}

/// Checks a submission and queues it. Returns the job and whether it was created now (false:
/// an earlier request with the same idempotency key created it). Nothing is written when a
/// rule is broken.
pub async fn submit(store: &JobStore, limits: &Limits, s: Submission) -> Result<(JobView, bool), ApiError> {
    let mut violations = Vec::new();
    if let Some(n) = &s.name {
        if n.trim().is_empty() || n.chars().count() > MAX_NAME || n.chars().any(char::is_control) {
            violations.push(Violation { field: "name".into(), rule: format!("must be 1 to {MAX_NAME} printable characters") });
        }
    }
    if let Some(p) = s.priority {
        if p.abs() > MAX_PRIORITY {
            violations
                .push(Violation { field: "priority".into(), rule: format!("must be between -{MAX_PRIORITY} and {MAX_PRIORITY}, got {p}") });
        }
    }
    if let Some(m) = s.max_attempts {
        if !(1..=MAX_ATTEMPTS).contains(&m) {
            violations.push(Violation { field: "max_attempts".into(), rule: format!("must be between 1 and {MAX_ATTEMPTS}, got {m}") });
        }
    }
    if let Some(k) = &s.idempotency_key {
        if k.is_empty() || k.len() > 200 || !k.chars().all(|c| c.is_ascii_graphic()) {
            violations.push(Violation { field: "idempotency_key".into(), rule: "must be 1 to 200 visible ASCII characters".into() });
        }
    }
    let text = serde_json::to_string(&s.scene).map_err(|e| ApiError::Internal(e.to_string()))?;
    let scene = check_scene(store, limits, &s.scene, &text, s.scene_path, violations).await?;
    let (scene, text) = learned(store, limits, &s.scene, scene, text, s.scene_path).await?;
    let new = NewJob {
        priority: s.priority.unwrap_or(0),
        max_attempts: s.max_attempts.unwrap_or(DEFAULT_ATTEMPTS),
        idempotency_key: s.idempotency_key,
        ..job_for(&scene, text, s.name)
    };
    let (row, created) = store.submit(new).await?;
    Ok((row.into(), created))
}

/// A scene whose method is `auto`, with what the stored studies of the same scene taught
/// ([`sable_engine::advise::Advice::learn`]): when one of their runs came within
/// [`sable_engine::advise::LEARNED_ACCURACY`] of its reference, the cheapest such run's method
/// and parameters replace `auto` in the scene that is stored (`text`), and the job's method
/// reason says which study and run. Otherwise the scene and its text are returned unchanged.
async fn learned(
    store: &JobStore,
    limits: &Limits,
    value: &serde_json::Value,
    scene: Plan,
    text: String,
    scene_path: &str,
) -> Result<(Plan, String), ApiError> {
    let Some(mut advice) = scene.advice.clone() else { return Ok((scene, text)) };
    advice.expected_cost = store.expected_cost(value).await?;
    let Some(run) = advice.learn() else { return Ok((scene, text)) };
    let method =
        store.get(run.job_id).await.ok().and_then(|j| serde_json::from_str::<serde_json::Value>(&j.scene).ok()?.get("method").cloned());
    let (Some(method), Some(fields)) = (method, value.as_object()) else { return Ok((scene, text)) };
    let mut fields = fields.clone();
    fields.insert("method".into(), method);
    let value = serde_json::Value::Object(fields);
    let text = serde_json::to_string(&value).map_err(|e| ApiError::Internal(e.to_string()))?;
    let mut chosen = check_scene(store, limits, &value, &text, scene_path, Vec::new()).await?;
    chosen.reason = advice.summary();
    chosen.advice = Some(advice);
    Ok((chosen, text))
}

/// A job's name from its scene's: the first [`MAX_NAME`] characters (the scene's own rule
/// allows longer descriptions), cut with an ellipsis.
fn job_name_of(scene_name: &str) -> String {
    // Control characters (the NUL character, which PostgreSQL's text refuses) are shown as �.
    let printable = |c: char| if c.is_control() { char::REPLACEMENT_CHARACTER } else { c };
    if scene_name.chars().count() <= MAX_NAME {
        return scene_name.chars().map(printable).collect();
    }
    let mut name: String = scene_name.chars().take(MAX_NAME - 1).map(printable).collect();
    name.push('…');
    name
}

/// The job of a checked scene (`text` its JSON), named `name` or after the scene, with the
/// default priority and attempts.
fn job_for(scene: &Plan, text: String, name: Option<String>) -> NewJob {
    let hash = Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect::<String>();
    NewJob {
        name: name.unwrap_or_else(|| job_name_of(&scene.name)),
        scene: text,
        scene_hash: hash,
        method: scene.method_name().to_string(),
        method_reason: scene.reason.clone(),
        seed: scene.seed,
        priority: 0,
        max_attempts: DEFAULT_ATTEMPTS,
        idempotency_key: None,
    }
}

/// A job for a scene, checked as a submission is (`scene_path` prefixes its fields in errors).
pub(crate) async fn new_job(
    store: &JobStore,
    limits: &Limits,
    scene: &serde_json::Value,
    scene_path: &str,
    name: String,
) -> Result<NewJob, ApiError> {
    let text = serde_json::to_string(scene).map_err(|e| ApiError::Internal(e.to_string()))?;
    let checked = check_scene(store, limits, scene, &text, scene_path, Vec::new()).await?;
    Ok(job_for(&checked, text, Some(name)))
}

/// Validates a scene as submitted (`text` its JSON; `scene_path` the prefix of its fields in
/// the request), with the server's limits and `start_from.job` resolved; every broken rule,
/// with the `violations` found before, comes back in one error.
async fn check_scene(
    store: &JobStore,
    limits: &Limits,
    scene_value: &serde_json::Value,
    text: &str,
    scene_path: &str,
    mut violations: Vec<Violation>,
) -> Result<Plan, ApiError> {
    if text.len() > limits.max_body_bytes {
        return Err(ApiError::TooLarge(limits.max_body_bytes));
    }
    // A scene that starts from a job's final state is checked with that state in place; the
    // job keeps the scene as submitted (the state goes in again when a worker leases it). The
    // state is parsed on a blocking thread, one submission at a time (`JobStore::inlining`).
    let from = start_from::referenced_job(scene_value);
    let planned = match from {
        None => Some(plan_scene(text)),
        Some(job) => {
            let permit = store.inlining().await?;
            match store.final_state(job).await {
                Ok(gz) => {
                    let scene = scene_value.clone();
                    let planned = tokio::task::spawn_blocking(move || {
                        let _permit = permit;
                        start_from::with_state(&scene, &gz).map(|resolved| plan_scene(&resolved.to_string()))
                    })
                    .await
                    .map_err(|e| ApiError::Internal(format!("checking a scene that starts from job {job}: {e}")))?
                    .map_err(|e| ApiError::Internal(format!("the final state of job {job} {e}")))?;
                    Some(planned)
                }
                Err(StoreError::NotFound(_)) | Err(StoreError::Missing(_)) => {
                    // (Nothing to parse when the referenced state is missing.)
                    violations.push(Violation {
                        field: format!("{}start_from.job", scene_path),
                        rule: format!("job {job} has no final state: name a job of this server that succeeded"),
                    });
                    None
                }
                Err(e) => return Err(e.into()),
            }
        }
    };
    let scene = match planned {
        None => None,
        Some(Ok(scene)) => {
            let n = scene.particle_count();
            if n > limits.max_particles {
                violations.push(Violation {
                    field: format!("{}particles", scene_path),
                    rule: format!("at most {} particles in all on this server, got {n}", limits.max_particles),
                });
            }
            let mut step_limits: Vec<(&str, u64)> = scene.stop.steps.map(|k| ("stop.steps", k)).into_iter().collect();
            step_limits.extend(scene.experiment.iter().flat_map(|e| e.step_limits()));
            for (field, steps) in step_limits.into_iter().filter(|&(_, k)| k > limits.max_steps) {
                violations.push(Violation {
                    field: format!("{}{field}", scene_path),
                    rule: format!("must be at most {} on this server, got {steps}", limits.max_steps),
                });
            }
            // The samples a run to `stop.steps` stores (an experiment ends on its own
            // criteria, held to the limit as it runs).
            if scene.experiment.is_none() {
                if let Some(v) = sample_bound(&scene, limits.max_samples) {
                    violations.push(Violation { field: format!("{}{}", scene_path, v.field), rule: v.rule });
                }
            }
            Some(scene)
        }
        Some(Err(v)) => {
            violations.extend(v.into_iter().map(|v| {
                // A rule the referenced state breaks is reported on the reference the user wrote.
                let (field, rule) = match from.and_then(|job| start_from::on_reference(&v.field, "start_from.job").map(|f| (job, f))) {
                    Some((job, field)) => (field, format!("the final state of job {job}: {}", v.rule)),
                    None => (v.field, v.rule),
                };
                Violation {
                    field: if field.is_empty() { scene_path.trim_end_matches('.').to_string() } else { format!("{}{field}", scene_path) },
                    rule,
                }
            }));
            None
        }
    };
    match (scene, violations.is_empty()) {
        (Some(scene), true) => Ok(scene),
        _ => Err(ApiError::InvalidArgument(violations)),
    }
}

/// The violation of a scene whose stop and sampling figures store more than `max` samples
/// (`stop.steps / sampling.every_steps`, `stop.time / sampling.every_time`), if they do.
fn sample_bound(scene: &sable_engine::scene::Scene, max: u64) -> Option<Violation> {
    use sable_engine::scene::Sampling;
    let (field, samples, every) = match scene.sampling {
        Sampling::Steps(n) => {
            let steps = scene.stop.steps?;
            ("sampling.every_steps", steps / n.max(1) + 1, format!("{} steps", steps.div_ceil(max.saturating_sub(1).max(1))))
        }
        Sampling::Time(t) => {
            let time = scene.stop.time?;
            let samples = time / t + 1.0;
            let samples = if samples.is_finite() && samples < u64::MAX as f64 { samples as u64 } else { u64::MAX };
            ("sampling.every_time", samples, format!("{:e} s", time / max.saturating_sub(1).max(1) as f64))
        }
    };
    (samples > max).then(|| Violation {
        field: field.into(),
        rule: format!(
            "the run stores {samples} samples before its stop, at most {max} per job on this server: sample every {every} or more"
        ),
    })
}

/// The method advisor's answer for a scene, checked as a submission is (nothing is written).
pub async fn advise(
    store: &JobStore,
    limits: &Limits,
    scene: &serde_json::Value,
    scene_path: &str,
) -> Result<sable_engine::advise::Advice, ApiError> {
    let text = serde_json::to_string(scene).map_err(|e| ApiError::Internal(e.to_string()))?;
    let checked = check_scene(store, limits, scene, &text, scene_path, Vec::new()).await?;
    let mut advice = checked.advice();
    advice.expected_cost = store.expected_cost(scene).await?;
    advice.learn();
    Ok(advice)
}

/// Query of a job list, as both APIs receive it.
#[derive(Debug, Clone, Default)]
pub struct ListQuery {
    /// State name.
    pub state: Option<String>,
    /// Exact name.
    pub name: Option<String>,
    /// Method name.
    pub method: Option<String>,
    /// RFC 3339 lower bound of created_at.
    pub created_after: Option<String>,
    /// RFC 3339 upper bound of created_at.
    pub created_before: Option<String>,
    /// Page size.
    pub page_size: Option<u32>,
    /// Token of the next page.
    pub page_token: Option<String>,
}

/// Lists jobs, newest first; returns the page and the token of the next one (None at the end).
pub async fn list(store: &JobStore, q: ListQuery) -> Result<(Vec<JobView>, Option<String>), ApiError> {
    let mut f = ListFilter::default();
    let mut violations = Vec::new();
    if let Some(s) = q.state.filter(|s| !s.is_empty()) {
        match JobState::parse(&s) {
            Some(st) => f.state = Some(st),
            None => violations.push(Violation {
                field: "state".into(),
                rule: format!("must be one of queued, running, succeeded, failed, cancelled; got '{s}'"),
            }),
        }
    }
    f.name = q.name.filter(|s| !s.is_empty());
    f.method = q.method.filter(|s| !s.is_empty());
    // PostgreSQL's text refuses the NUL character (the query failed as an internal error).
    for (field, v) in [("name", &f.name), ("method", &f.method)] {
        if v.as_deref().is_some_and(|v| v.chars().any(char::is_control)) {
            violations.push(Violation { field: field.into(), rule: "must not contain control characters".into() });
        }
    }
    for (field, v, slot) in
        [("created_after", q.created_after, &mut f.created_after), ("created_before", q.created_before, &mut f.created_before)]
    {
        if let Some(v) = v.filter(|s| !s.is_empty()) {
            match parse_time(field, &v) {
                Ok(t) => *slot = Some(t),
                Err(ApiError::InvalidArgument(v)) => violations.extend(v),
                Err(e) => return Err(e),
            }
        }
    }
    let size = q.page_size.filter(|&s| s > 0).unwrap_or(PAGE_SIZE.0);
    if size > PAGE_SIZE.1 {
        violations.push(Violation { field: "page_size".into(), rule: format!("must be at most {}, got {size}", PAGE_SIZE.1) });
    }
    f.limit = size.min(PAGE_SIZE.1) + 1;
    if let Some(t) = q.page_token.filter(|s| !s.is_empty()) {
        match t.strip_prefix("before-").and_then(|n| n.parse::<i64>().ok()) {
            Some(id) => f.before_id = Some(id),
            None => violations
                .push(Violation { field: "page_token".into(), rule: "must be a next_page_token returned by an earlier list".into() }),
        }
    }
    if !violations.is_empty() {
        return Err(ApiError::InvalidArgument(violations));
    }
    let mut rows = store.list(&f).await?;
    let more = rows.len() > size as usize;
    rows.truncate(size as usize);
    let next = if more { rows.last().map(|r| format!("before-{}", r.id)) } else { None };
    Ok((rows.into_iter().map(JobView::from).collect(), next))
}

/// Samples one read returns at most (and by default), whatever `max_points`: a longer run is
/// read in pages, each ending with the `from_step` of the next.
pub const SAMPLE_PAGE: u32 = 10_000;

/// A job's samples as read: the scene's dimension, the samples, and the job's last event
/// sequence number at the read ([`JobStore::samples_and_seq`]).
#[derive(Debug)]
pub struct SampleRead {
    /// The scene's dimension.
    pub dim: usize,
    /// In step order.
    pub samples: Vec<Sample>,
    /// Resume the job's event stream after it for the samples stored since.
    pub events_seq: i64,
    /// The `from_step` of the next page, when there are more samples in the range.
    pub next_from_step: Option<u64>,
}

/// A job's samples in a step range: at most `max_points` evenly spread over it (the last one
/// always kept), or else the first `limit` (at most and by default [`SAMPLE_PAGE`]) with where
/// the next page starts.
pub async fn samples(
    store: &JobStore,
    id: i64,
    from_step: u64,
    to_step: Option<u64>,
    max_points: Option<u32>,
    limit: Option<u32>,
) -> Result<SampleRead, ApiError> {
    if let Some(to) = to_step {
        if to < from_step {
            return Err(ApiError::invalid("to_step", format!("must be >= from_step ({from_step}), got {to}")));
        }
    }
    let limit = match limit {
        None | Some(0) => SAMPLE_PAGE,
        Some(n) if n <= SAMPLE_PAGE => n,
        Some(n) => return Err(ApiError::invalid("limit", format!("must be at most {SAMPLE_PAGE} samples a page, got {n}"))),
    };
    let read = store.samples_and_seq(id, from_step, to_step, max_points.unwrap_or(0) as usize, limit as usize).await?;
    Ok(SampleRead { dim: read.dim, samples: read.samples, events_seq: read.events_seq, next_from_step: read.next_from_step })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsample_keeps_ends_and_count() {
        let v: Vec<usize> = (0..101).collect();
        let d = downsample(v.clone(), 11);
        assert_eq!(d.len(), 11);
        assert_eq!(d[0], 0);
        assert_eq!(d[10], 100);
        assert_eq!(d[5], 50);
        assert_eq!(downsample(v.clone(), 0).len(), 101);
        assert_eq!(downsample(v, 1), vec![100]);
    }
}
