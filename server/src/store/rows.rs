//! Rows of the job store as Rust values.

/// The state of a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JobState {
    /// Waiting for a worker.
    Queued,
    /// Leased by a worker.
    Running,
    /// Ran to its stop criteria.
    Succeeded,
    /// Stopped with an error, or ran out of attempts.
    Failed,
    /// Cancelled by the user.
    Cancelled,
}

impl JobState {
    /// All states.
    pub const ALL: [JobState; 5] = [Self::Queued, Self::Running, Self::Succeeded, Self::Failed, Self::Cancelled];

    /// Name as stored and as shown by the APIs.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Queued => "queued",
            Self::Running => "running",
            Self::Succeeded => "succeeded",
            Self::Failed => "failed",
            Self::Cancelled => "cancelled",
        }
    }

    /// Parses a state name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.as_str() == s)
    }

    /// True for succeeded, failed and cancelled.
    pub fn is_terminal(self) -> bool {
        matches!(self, Self::Succeeded | Self::Failed | Self::Cancelled)
    }
}

/// The columns of a job the APIs show.
pub(crate) const JOB_SELECT: &str = "SELECT j.id, j.name, j.state, j.priority, j.method, j.method_reason, j.scene, j.scene_hash, \
     j.engine_version, j.seed, j.attempts, j.max_attempts, j.progress, j.created_at, j.started_at, j.finished_at, j.error_code, \
     j.error_message, j.steps, j.wall_seconds, j.cpu_seconds, j.solver_iterations, j.cancel_requested, j.result, \
     (SELECT COUNT(*) FROM samples s WHERE s.job_id = j.id) AS sample_count FROM jobs j";

/// The columns of a job in a list: its scene left out (`''`), which may be megabytes and is
/// read by its own route; a page of jobs stays a page of summaries.
pub(crate) const JOB_SUMMARY_SELECT: &str = "SELECT j.id, j.name, j.state, j.priority, j.method, j.method_reason, '' AS scene, \
     j.scene_hash, j.engine_version, j.seed, j.attempts, j.max_attempts, j.progress, j.created_at, j.started_at, j.finished_at, \
     j.error_code, j.error_message, j.steps, j.wall_seconds, j.cpu_seconds, j.solver_iterations, j.cancel_requested, j.result, \
     (SELECT COUNT(*) FROM samples s WHERE s.job_id = j.id) AS sample_count FROM jobs j";

/// One job.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct JobRow {
    /// Id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// State name (see [`JobState`]).
    pub state: String,
    /// Priority (higher first).
    pub priority: i64,
    /// Method used.
    pub method: String,
    /// Why that method.
    pub method_reason: String,
    /// Canonical scene JSON.
    pub scene: String,
    /// SHA-256 of the scene, hex.
    pub scene_hash: String,
    /// Engine version.
    pub engine_version: String,
    /// Seed (stored as the bits of a u64).
    pub seed: i64,
    /// Leases taken.
    pub attempts: i64,
    /// Leases allowed.
    pub max_attempts: i64,
    /// Fraction done.
    pub progress: f64,
    /// Times, ms since the epoch.
    pub created_at: i64,
    /// Start of the first attempt.
    pub started_at: Option<i64>,
    /// End.
    pub finished_at: Option<i64>,
    /// Error code.
    pub error_code: Option<String>,
    /// Error message.
    pub error_message: Option<String>,
    /// Steps done.
    pub steps: i64,
    /// Wall-clock seconds of the run.
    pub wall_seconds: f64,
    /// CPU seconds of the job's threads.
    pub cpu_seconds: f64,
    /// Contact-solver sweeps.
    pub solver_iterations: i64,
    /// Cancellation asked.
    pub cancel_requested: i64,
    /// Derived results of the experiment, JSON.
    pub result: Option<String>,
    /// Samples stored.
    pub sample_count: i64,
}

impl JobRow {
    /// The state, typed.
    pub fn job_state(&self) -> JobState {
        JobState::parse(&self.state).unwrap_or(JobState::Failed)
    }
}

/// One stored event.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct EventRow {
    /// Job.
    pub job_id: i64,
    /// Sequence number within the job, from 1.
    pub seq: i64,
    /// When, ms since the epoch.
    pub at: i64,
    /// `state` or `sample`.
    pub kind: String,
    /// JSON payload.
    pub payload: String,
}

/// A stored snapshot, without its files.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct SnapshotRow {
    /// Number of the snapshot in the job, from 0.
    pub idx: i64,
    /// Step it was taken at.
    pub step: i64,
    /// Simulated time, s.
    pub time: f64,
}

/// The three files of a snapshot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SnapshotPart {
    /// `particles.vtp`.
    Particles,
    /// `contacts.vtp`.
    Contacts,
    /// `walls.vtp`.
    Walls,
}

impl SnapshotPart {
    /// Every part, in file order.
    pub const ALL: [SnapshotPart; 3] = [Self::Particles, Self::Contacts, Self::Walls];

    /// Name in URLs and file names.
    pub fn name(self) -> &'static str {
        match self {
            Self::Particles => "particles",
            Self::Contacts => "contacts",
            Self::Walls => "walls",
        }
    }

    /// The part named `name` (`particles`, `contacts`, `walls`, with or without `.vtp`).
    pub fn parse(name: &str) -> Option<Self> {
        let name = name.strip_suffix(".vtp").unwrap_or(name);
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    pub(crate) fn column(self) -> &'static str {
        self.name()
    }
}
