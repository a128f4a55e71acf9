//! The job store: jobs, their samples and their events, with the queue operations workers use
//! (lease, report, finish) fenced by lease ids. Two back-ends, one set of queries
//! ([`backend`]): an SQLite file (WAL mode; the default, for one machine) and PostgreSQL (for
//! several servers and their workers sharing one queue). Schema: migrations/sqlite and
//! migrations/postgres, the same versions in each.
//!
//! Writes run in write transactions: on SQLite through one connection in `BEGIN IMMEDIATE`
//! transactions (one writer, so a read-then-write never fails with SQLITE_BUSY); on PostgreSQL
//! each transaction first locks the job rows it changes (`FOR UPDATE`; the queue with
//! `SKIP LOCKED`), so that two servers never interleave their changes to one job. Reads use a
//! pool of their own on SQLite. Every committed change that adds events notifies
//! [`JobStore::subscribe`]rs with the job id; on PostgreSQL the other servers hear of it too
//! ([`listen`]).

mod backend;
#[cfg(test)]
mod fault_tests;
mod listen;
mod rows;
mod studies;

use std::sync::Arc;
use std::time::Duration;

use sable_engine::observe::Sample;
use sable_worker::{JobSource, Lease, Outcome, Report, ResumeFrom, SourceError};
use sqlx::{Any, AnyPool, Row, Transaction};
use tokio::sync::{broadcast, Notify};

pub use backend::{Backend, BadLocation, DbLocation, POSTGRES_MIGRATOR, SQLITE_MIGRATOR};
pub use rows::{EventRow, JobRow, JobState, SnapshotPart, SnapshotRow};
pub use studies::{NewRun, RunRow, StudyRow};

/// A write transaction of the store.
type Tx = Transaction<'static, Any>;

/// What watchers hear after each commit: the job that changed and the events it appended, in
/// order (empty when nothing was appended, e.g. a cancellation request for a running job).
#[derive(Debug, Clone, PartialEq)]
pub struct Notice {
    /// The job.
    pub job_id: i64,
    /// Its new events.
    pub events: Vec<EventRow>,
}

/// Failures of the store.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// No job with that id.
    #[error("job {0} not found")]
    NotFound(i64),
    /// The job exists but not the thing asked for (a snapshot index).
    #[error("{0}")]
    Missing(String),
    /// The request conflicts with the job's state or an earlier request.
    #[error("{0}")]
    Conflict(String),
    /// The database failed.
    #[error("database error: {0}")]
    Db(#[from] sqlx::Error),
    /// A migration failed.
    #[error("migration failed: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
}

/// Why the store cannot serve a request for now, read from a database error
/// ([`StoreError::outage`]): the request is not wrong and may be sent again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outage {
    /// The database's disk (or its quota) is full: SQLite's SQLITE_FULL, PostgreSQL's class 53
    /// (insufficient resources, 53100 `disk_full`).
    DiskFull,
    /// The database cannot be reached or is shutting down: no connection within the pool's
    /// timeout, a broken connection, PostgreSQL's classes 08 (connection exception) and 57P
    /// (operator intervention: shutdown, starting up), SQLite's I/O errors.
    Unreachable,
}

impl StoreError {
    /// The outage this error is a sign of, if any; `None` for errors of the request itself
    /// (a conflict, a missing job, a constraint) and for bugs.
    pub fn outage(&self) -> Option<Outage> {
        let Self::Db(e) = self else { return None };
        match e {
            sqlx::Error::PoolTimedOut | sqlx::Error::PoolClosed | sqlx::Error::Io(_) | sqlx::Error::Tls(_) | sqlx::Error::WorkerCrashed => {
                Some(Outage::Unreachable)
            }
            sqlx::Error::Database(d) => {
                let code = d.code().unwrap_or_default();
                // SQLite reports its extended result code: the primary code is its low byte.
                let sqlite = code.parse::<i64>().ok().map(|c| c & 0xff);
                match (sqlite, code.as_ref()) {
                    (Some(13), _) => Some(Outage::DiskFull),
                    (Some(10), _) => Some(Outage::Unreachable),
                    (None, c) if c.starts_with("53") => Some(Outage::DiskFull),
                    (None, c) if c.starts_with("08") || c.starts_with("57P") => Some(Outage::Unreachable),
                    _ => None,
                }
            }
            _ => None,
        }
    }
}

/// A read of a job's samples ([`JobStore::samples_and_seq`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SampleSlice {
    /// The dimension of the job's scene (3 if it cannot be read).
    pub dim: usize,
    /// The samples, in order.
    pub samples: Vec<Sample>,
    /// The job's last event sequence number when they were read.
    pub events_seq: i64,
    /// Where the next page starts (`from_step`) when the read stopped at its limit.
    pub next_from_step: Option<u64>,
}

/// The `dimension` of a scene's JSON text, read without building the rest (3 if it cannot be
/// read: a stored scene always has one).
fn scene_dimension(scene: &str) -> usize {
    #[derive(serde::Deserialize)]
    struct Dimension {
        dimension: Option<usize>,
    }
    serde_json::from_str::<Dimension>(scene).ok().and_then(|d| d.dimension).unwrap_or(3)
}

/// A job to insert.
#[derive(Debug, Clone)]
pub struct NewJob {
    /// Display name.
    pub name: String,
    /// Canonical scene JSON.
    pub scene: String,
    /// SHA-256 of `scene`, hex.
    pub scene_hash: String,
    /// Method actually used, and why.
    pub method: String,
    /// Why that method.
    pub method_reason: String,
    /// Seed of the scene.
    pub seed: u64,
    /// Higher first.
    pub priority: i64,
    /// Leases allowed before the job fails.
    pub max_attempts: u32,
    /// Idempotency key, if given.
    pub idempotency_key: Option<String>,
}

/// Filters of [`JobStore::list`].
#[derive(Debug, Clone, Default)]
pub struct ListFilter {
    /// Only jobs in this state.
    pub state: Option<JobState>,
    /// Only jobs with this exact name.
    pub name: Option<String>,
    /// Only jobs of this method.
    pub method: Option<String>,
    /// Created at or after (ms).
    pub created_after: Option<i64>,
    /// Created before (ms).
    pub created_before: Option<i64>,
    /// Jobs with an id below this (the page token).
    pub before_id: Option<i64>,
    /// Page size.
    pub limit: u32,
}

/// Lease settings.
#[derive(Debug, Clone, Copy)]
pub struct LeaseConfig {
    /// How long a lease lasts without a report.
    pub ttl: Duration,
}

/// What one job may store and run to (`sable serve --max-samples`, `--max-job-bytes`,
/// `--max-steps`), held as its reports arrive: the report that would pass a limit fails the
/// job with a message that names the limit and what to change, and the samples before it are
/// kept. A scene's own figures are checked against the same limits at submission where they
/// bound the run (`stop.steps / sampling.every_steps`); these catch the rest (`stop.time`, an
/// experiment's own end).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JobLimits {
    /// Samples one job may store.
    pub max_samples: u64,
    /// Bytes one job may store: its samples (each twice, as a row and as an event) and its
    /// snapshots.
    pub max_bytes: u64,
    /// Steps one job may run to (the step of its last sample).
    pub max_steps: u64,
}

impl Default for JobLimits {
    fn default() -> Self {
        Self { max_samples: 100_000, max_bytes: 1 << 30, max_steps: 10_000_000_000 }
    }
}

impl JobLimits {
    /// Why a job with `samples` samples, `bytes` stored and its last sample at `step` is past
    /// a limit, if it is.
    pub fn breach(&self, samples: u64, bytes: u64, step: u64) -> Option<String> {
        if samples > self.max_samples {
            Some(format!(
                "the job reached this server's limit of {} samples per job (--max-samples); sample less often (raise \
                 sampling.every_steps) or end the run sooner",
                self.max_samples
            ))
        } else if bytes > self.max_bytes {
            Some(format!(
                "the job's samples and snapshots reached this server's limit of {} bytes per job (--max-job-bytes); raise \
                 sampling.every_steps or snapshots.every_steps, or end the run sooner",
                self.max_bytes
            ))
        } else if step > self.max_steps {
            Some(format!(
                "the job ran past this server's limit of {} steps (--max-steps, step {step}); end it by stop.steps or a \
                 shorter stop.time",
                self.max_steps
            ))
        } else {
            None
        }
    }
}

/// The job store (module documentation).
#[derive(Debug, Clone)]
pub struct JobStore {
    backend: Backend,
    writer: AnyPool,
    reader: AnyPool,
    /// This server's name in the notifications it sends to the others (PostgreSQL), so that
    /// it does not hear its own.
    origin: Arc<str>,
    /// Holds the study driver's role among the servers of one database, while it has it.
    driver: Arc<tokio::sync::Mutex<listen::DriverRole>>,
    events: broadcast::Sender<Arc<Notice>>,
    /// Notified when a job is queued (wakes idle local workers).
    pub queued: std::sync::Arc<Notify>,
    /// Cancelled when the server shuts down: ends every event stream.
    pub closing: tokio_util::sync::CancellationToken,
    lease: LeaseConfig,
    limits: JobLimits,
    /// The last failure to store a worker's report for lack of space, until a report is stored
    /// again: a nearly full disk may still take the health probe's one row but not a batch of
    /// samples.
    report_failure: Arc<std::sync::Mutex<Option<String>>>,
    /// Held while a final state is inlined into a scene that starts from it by a
    /// submission's check: one at a time on this server, since a state of two million
    /// particles takes gigabytes while it is parsed.
    inlining_submissions: Arc<tokio::sync::Semaphore>,
    /// The same for leases, apart, so that a queue of submissions does not hold up the
    /// workers.
    inlining_leases: Arc<tokio::sync::Semaphore>,
}

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis() as i64)
}

fn new_lease_id() -> String {
    format!("{:032x}", rand::random::<u128>())
}

impl JobStore {
    /// The store with `limits` on what each job may store ([`JobLimits`]).
    pub fn with_job_limits(mut self, limits: JobLimits) -> Self {
        self.limits = limits;
        self
    }

    /// Opens the store at `at` (creating an SQLite file if needed) and applies the migrations.
    /// On PostgreSQL it also starts listening to the other servers' notifications.
    pub async fn open(at: &DbLocation, lease: LeaseConfig) -> Result<Self, StoreError> {
        let pools = backend::connect(at).await?;
        let (events, _) = broadcast::channel(1024);
        let store = Self {
            backend: at.backend(),
            writer: pools.writer,
            reader: pools.reader,
            origin: format!("{:016x}", rand::random::<u64>()).into(),
            driver: Default::default(),
            events,
            queued: Default::default(),
            closing: Default::default(),
            lease,
            limits: JobLimits::default(),
            report_failure: Default::default(),
            inlining_submissions: Arc::new(tokio::sync::Semaphore::new(1)),
            inlining_leases: Arc::new(tokio::sync::Semaphore::new(1)),
        };
        if let DbLocation::Postgres(url) = at {
            listen::start(&store, url).await?;
        }
        Ok(store)
    }

    /// The back-end the store runs on.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Closes the pools.
    pub async fn close(&self) {
        self.closing.cancel();
        self.driver.lock().await.release().await;
        self.writer.close().await;
        self.reader.close().await;
    }

    /// Receives, after each commit, the job that changed and the events it appended.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<Notice>> {
        self.events.subscribe()
    }

    async fn begin(&self) -> Result<Tx, StoreError> {
        Ok(self.writer.begin_with(self.backend.begin_write()).await?)
    }

    /// Locks job `id`'s row until the commit (PostgreSQL; SQLite's write transaction holds the
    /// whole database) and returns its state, or None if there is no such job. Every write
    /// transaction that appends events to a job takes this lock first, so that event
    /// numbers never collide between servers.
    async fn lock_job(&self, tx: &mut Tx, id: i64) -> Result<Option<String>, StoreError> {
        let sql = format!("SELECT state FROM jobs WHERE id = $1{}", self.backend.lock());
        Ok(sqlx::query_scalar(&sql).bind(id).fetch_optional(&mut **tx).await?)
    }

    /// Sequence number the next event of `job` will take.
    async fn next_seq(tx: &mut Tx, job: i64) -> Result<i64, StoreError> {
        Ok(sqlx::query_scalar("SELECT COALESCE(MAX(seq), 0) + 1 FROM job_events WHERE job_id = $1").bind(job).fetch_one(&mut **tx).await?)
    }

    /// Stores one event with sequence number `seq` and returns it; on PostgreSQL the other
    /// servers hear of it when the transaction commits ([`listen`]).
    async fn insert_event(&self, tx: &mut Tx, job: i64, seq: i64, kind: &str, payload: &serde_json::Value) -> Result<EventRow, StoreError> {
        let row = EventRow { job_id: job, seq, at: now_ms(), kind: kind.to_string(), payload: payload.to_string() };
        sqlx::query("INSERT INTO job_events (job_id, seq, at, kind, payload) VALUES ($1, $2, $3, $4, $5)")
            .bind(row.job_id)
            .bind(row.seq)
            .bind(row.at)
            .bind(&row.kind)
            .bind(&row.payload)
            .execute(&mut **tx)
            .await?;
        let queued = kind == "state" && payload.get("state").and_then(|s| s.as_str()) == Some("queued");
        listen::announce(self, tx, job, queued).await?;
        Ok(row)
    }

    /// Appends a state event carrying the job's current state, attempt and error.
    async fn state_event(&self, tx: &mut Tx, job: i64) -> Result<EventRow, StoreError> {
        let r = sqlx::query("SELECT state, attempts, error_code, error_message, resumed_from_step FROM jobs WHERE id = $1")
            .bind(job)
            .fetch_one(&mut **tx)
            .await?;
        let mut payload = serde_json::json!({
            "state": r.get::<String, _>("state"),
            "attempt": r.get::<i64, _>("attempts"),
            "error_code": r.get::<Option<String>, _>("error_code"),
            "error_message": r.get::<Option<String>, _>("error_message"),
        });
        // A running attempt that goes on from a checkpoint says from which step.
        if let Some(step) = r.get::<Option<i64>, _>("resumed_from_step") {
            payload["resumed_from_step"] = step.into();
        }
        let seq = Self::next_seq(tx, job).await?;
        self.insert_event(tx, job, seq, "state", &payload).await
    }

    /// Tells watchers (after the commit) that `job` changed, with the events it appended.
    fn notify(&self, job: i64, events: Vec<EventRow>) {
        let _ = self.events.send(Arc::new(Notice { job_id: job, events }));
    }

    /// Inserts a queued job and its first state event, in the caller's transaction.
    async fn insert_job(&self, tx: &mut Tx, new: &NewJob) -> Result<(i64, EventRow), StoreError> {
        let id: i64 = sqlx::query_scalar(
            "INSERT INTO jobs (name, state, priority, method, method_reason, scene, scene_hash, engine_version, seed, \
             idempotency_key, max_attempts, created_at) VALUES ($1, 'queued', $2, $3, $4, $5, $6, $7, $8, $9, $10, $11) RETURNING id",
        )
        .bind(&new.name)
        .bind(new.priority)
        .bind(&new.method)
        .bind(&new.method_reason)
        .bind(&new.scene)
        .bind(&new.scene_hash)
        .bind(sable_engine::VERSION)
        .bind(new.seed as i64)
        .bind(&new.idempotency_key)
        .bind(new.max_attempts as i64)
        .bind(now_ms())
        .fetch_one(&mut **tx)
        .await?;
        let event = self.state_event(tx, id).await?;
        Ok((id, event))
    }

    /// Inserts a job, or returns the job that an earlier request with the same idempotency key
    /// created (`false` as second value). The same key with another scene is a conflict.
    pub async fn submit(&self, new: NewJob) -> Result<(JobRow, bool), StoreError> {
        match self.try_submit(&new).await {
            // Another server inserted a job with this key between the lookup and the insert
            // (PostgreSQL; SQLite's write lock rules it out): that job is the answer.
            Err(StoreError::Db(sqlx::Error::Database(e))) if e.is_unique_violation() && new.idempotency_key.is_some() => {
                self.try_submit(&new).await
            }
            r => r,
        }
    }

    async fn try_submit(&self, new: &NewJob) -> Result<(JobRow, bool), StoreError> {
        let mut tx = self.begin().await?;
        if let Some(key) = &new.idempotency_key {
            let existing: Option<(i64, String)> =
                sqlx::query_as("SELECT id, scene_hash FROM jobs WHERE idempotency_key = $1").bind(key).fetch_optional(&mut *tx).await?;
            if let Some((id, hash)) = existing {
                tx.rollback().await?;
                if hash != new.scene_hash {
                    return Err(StoreError::Conflict(format!(
                        "Idempotency-Key '{key}' was used for job {id} with a different scene; use a new key for a new job"
                    )));
                }
                return Ok((self.get(id).await?, false));
            }
        }
        let (id, event) = self.insert_job(&mut tx, new).await?;
        // The job as created (a worker may lease it the moment the transaction commits).
        let row = sqlx::query_as::<_, JobRow>(&format!("{} WHERE j.id = $1", rows::JOB_SELECT)).bind(id).fetch_one(&mut *tx).await?;
        tx.commit().await?;
        self.notify(id, vec![event]);
        self.queued.notify_one();
        Ok((row, true))
    }

    /// One job.
    pub async fn get(&self, id: i64) -> Result<JobRow, StoreError> {
        let sql = format!("{} WHERE j.id = $1", rows::JOB_SELECT);
        sqlx::query_as::<_, JobRow>(&sql).bind(id).fetch_optional(&self.reader).await?.ok_or(StoreError::NotFound(id))
    }

    /// Jobs matching the filter, newest first, without their scenes (`scene` empty: read one
    /// with [`JobStore::get`]).
    pub async fn list(&self, f: &ListFilter) -> Result<Vec<JobRow>, StoreError> {
        // The filters as `$n` parameters (both back-ends read that form), each bound in turn.
        enum Arg {
            Text(String),
            Int(i64),
        }
        let mut sql = format!("{} WHERE 1 = 1", rows::JOB_SUMMARY_SELECT);
        let mut args = Vec::new();
        let mut push = |clause: &str, arg: Arg| {
            args.push(arg);
            sql.push_str(&format!(" AND {clause} ${}", args.len()));
        };
        if let Some(s) = f.state {
            push("j.state =", Arg::Text(s.as_str().to_string()));
        }
        if let Some(n) = &f.name {
            push("j.name =", Arg::Text(n.clone()));
        }
        if let Some(m) = &f.method {
            push("j.method =", Arg::Text(m.clone()));
        }
        if let Some(t) = f.created_after {
            push("j.created_at >=", Arg::Int(t));
        }
        if let Some(t) = f.created_before {
            push("j.created_at <", Arg::Int(t));
        }
        if let Some(id) = f.before_id {
            push("j.id <", Arg::Int(id));
        }
        sql.push_str(&format!(" ORDER BY j.id DESC LIMIT ${}", args.len() + 1));
        let mut q = sqlx::query_as::<_, JobRow>(&sql);
        for a in args {
            q = match a {
                Arg::Text(t) => q.bind(t),
                Arg::Int(i) => q.bind(i),
            };
        }
        Ok(q.bind(i64::from(f.limit)).fetch_all(&self.reader).await?)
    }

    /// Cancels a job: a queued one at once, a running one at its worker's next report.
    pub async fn cancel(&self, id: i64) -> Result<JobRow, StoreError> {
        let mut tx = self.begin().await?;
        let state = self.lock_job(&mut tx, id).await?.ok_or(StoreError::NotFound(id))?;
        let mut events = Vec::new();
        match JobState::parse(&state) {
            Some(JobState::Queued) => {
                sqlx::query("UPDATE jobs SET state = 'cancelled', finished_at = $1, cancel_requested = 1 WHERE id = $2")
                    .bind(now_ms())
                    .bind(id)
                    .execute(&mut *tx)
                    .await?;
                Self::drop_checkpoint(&mut tx, id).await?;
                events.push(self.state_event(&mut tx, id).await?);
            }
            Some(JobState::Running) => {
                sqlx::query("UPDATE jobs SET cancel_requested = 1 WHERE id = $1").bind(id).execute(&mut *tx).await?;
            }
            _ => {
                tx.rollback().await?;
                return Err(StoreError::Conflict(format!(
                    "job {id} has already ended ({state}); only queued or running jobs can be cancelled"
                )));
            }
        }
        tx.commit().await?;
        self.notify(id, events);
        self.get(id).await
    }

    /// Samples of a job in a step range, in order.
    pub async fn samples(&self, id: i64, from_step: u64, to_step: Option<u64>) -> Result<Vec<Sample>, StoreError> {
        Ok(self.samples_and_seq(id, from_step, to_step, 0, 0).await?.samples)
    }

    /// Samples of a job in a step range, in order ([`SampleSlice`]): at most `max_points` of
    /// them evenly spread over the range ([`downsample`]; 0 = not downsampled), and at most
    /// `limit` in all (0 = no limit): past it the slice ends with the step the next page starts
    /// from. With the sequence number of the job's last event when they were read (one read
    /// transaction; a worker stores its samples and their events in one write): the job's event
    /// stream resumed after it brings exactly the samples stored since. Only the kept samples
    /// are read and decoded (a 2,000-point view of 100,000 samples).
    pub async fn samples_and_seq(
        &self,
        id: i64,
        from_step: u64,
        to_step: Option<u64>,
        max_points: usize,
        limit: usize,
    ) -> Result<SampleSlice, StoreError> {
        let from = i64::try_from(from_step).unwrap_or(i64::MAX);
        let to = to_step.map_or(i64::MAX, |s| i64::try_from(s).unwrap_or(i64::MAX));
        let mut tx = self.reader.begin_with(self.backend.begin_read()).await?;
        let scene: String = sqlx::query_scalar("SELECT scene FROM jobs WHERE id = $1")
            .bind(id)
            .fetch_optional(&mut *tx)
            .await?
            .ok_or(StoreError::NotFound(id))?;
        let dim = scene_dimension(&scene);
        drop(scene);
        let marks: Vec<(i64, i64)> =
            sqlx::query_as("SELECT seq, step FROM samples WHERE job_id = $1 AND step >= $2 AND step <= $3 ORDER BY seq")
                .bind(id)
                .bind(from)
                .bind(to)
                .fetch_all(&mut *tx)
                .await?;
        let all = marks.len();
        let limit = if limit == 0 { usize::MAX } else { limit };
        let (keep, next_from_step) = if max_points > 0 {
            (downsample(marks, max_points.min(limit)), None)
        } else if all > limit {
            let next = u64::try_from(marks[limit].1).ok();
            (marks.into_iter().take(limit).collect(), next)
        } else {
            (marks, None)
        };
        let rows: Vec<String> = if keep.len() == all {
            sqlx::query_scalar("SELECT data FROM samples WHERE job_id = $1 AND step >= $2 AND step <= $3 ORDER BY seq")
                .bind(id)
                .bind(from)
                .bind(to)
                .fetch_all(&mut *tx)
                .await?
        } else {
            let mut rows = Vec::with_capacity(keep.len());
            for chunk in keep.chunks(500) {
                let marks = (2..chunk.len() + 2).map(|k| format!("${k}")).collect::<Vec<_>>().join(",");
                let sql = format!("SELECT data FROM samples WHERE job_id = $1 AND seq IN ({marks}) ORDER BY seq");
                let mut q = sqlx::query_scalar::<_, String>(&sql).bind(id);
                for (seq, _) in chunk {
                    q = q.bind(*seq);
                }
                rows.extend(q.fetch_all(&mut *tx).await?);
            }
            rows
        };
        let events_seq: i64 =
            sqlx::query_scalar("SELECT COALESCE(MAX(seq), 0) FROM job_events WHERE job_id = $1").bind(id).fetch_one(&mut *tx).await?;
        tx.commit().await?;
        let mut samples = Vec::with_capacity(rows.len());
        for r in rows {
            samples.push(serde_json::from_str(&r).map_err(|e| sqlx::Error::Decode(Box::new(e)))?);
        }
        Ok(SampleSlice { dim, samples, events_seq, next_from_step })
    }

    /// The snapshots of a job, in order, without their files.
    pub async fn snapshots(&self, id: i64) -> Result<Vec<SnapshotRow>, StoreError> {
        self.get(id).await?;
        Ok(sqlx::query_as::<_, SnapshotRow>("SELECT idx, step, time FROM snapshots WHERE job_id = $1 ORDER BY idx")
            .bind(id)
            .fetch_all(&self.reader)
            .await?)
    }

    /// One file of a snapshot, gzip-compressed as stored.
    pub async fn snapshot_file(&self, id: i64, index: u32, part: SnapshotPart) -> Result<Vec<u8>, StoreError> {
        self.get(id).await?;
        let sql = format!("SELECT {} FROM snapshots WHERE job_id = $1 AND idx = $2", part.column());
        sqlx::query_scalar::<_, Vec<u8>>(&sql)
            .bind(id)
            .bind(index as i64)
            .fetch_optional(&self.reader)
            .await?
            .ok_or_else(|| StoreError::Missing(format!("job {id} has no snapshot {index}")))
    }

    /// The final state of a succeeded job, gzip-compressed JSON as stored.
    pub async fn final_state(&self, id: i64) -> Result<Vec<u8>, StoreError> {
        let job = self.get(id).await?;
        sqlx::query_scalar::<_, Vec<u8>>("SELECT state FROM job_states WHERE job_id = $1")
            .bind(id)
            .fetch_optional(&self.reader)
            .await?
            .ok_or_else(|| StoreError::Missing(format!("job {id} has no final state (it is {}: only a succeeded job has one)", job.state)))
    }

    /// The right of a submission to inline a final state into its scene, waited for while
    /// another holds it, held until the permit is dropped (move it into the task that parses:
    /// a request dropped meanwhile must not free it while the parse goes on).
    pub async fn inlining(&self) -> Result<tokio::sync::OwnedSemaphorePermit, StoreError> {
        Self::permit(&self.inlining_submissions).await
    }

    async fn permit(s: &Arc<tokio::sync::Semaphore>) -> Result<tokio::sync::OwnedSemaphorePermit, StoreError> {
        // The semaphores are never closed; if one were, the store would be shutting down.
        s.clone().acquire_owned().await.map_err(|_| StoreError::Db(sqlx::Error::PoolClosed))
    }

    /// The scene of a leased job with `start_from.job` replaced by that job's final state (the
    /// scene as stored if it names none, or if the state cannot be read: the engine then
    /// reports the reference it cannot resolve). Reads through the reader pool: states never
    /// change once written, so this needs no write transaction. One state at a time is
    /// inlined ([`JobStore::inlining`]).
    async fn resolve_start(&self, scene: String) -> Result<String, StoreError> {
        let Ok(value) = serde_json::from_str::<serde_json::Value>(&scene) else { return Ok(scene) };
        let Some(from) = crate::start_from::referenced_job(&value) else { return Ok(scene) };
        let permit = Self::permit(&self.inlining_leases).await?;
        let gz: Option<Vec<u8>> =
            sqlx::query_scalar("SELECT state FROM job_states WHERE job_id = $1").bind(from).fetch_optional(&self.reader).await?;
        let Some(gz) = gz else { return Ok(scene) };
        // Parsed on a blocking thread, one state at a time, the permit held to the end.
        let inlined = tokio::task::spawn_blocking(move || {
            let _permit = permit;
            crate::start_from::with_state(&value, &gz).ok().map(|v| v.to_string())
        })
        .await;
        Ok(inlined.ok().flatten().unwrap_or(scene))
    }

    /// Events of a job with seq > `after`, in order (at most `limit`).
    pub async fn events_after(&self, id: i64, after: i64, limit: i64) -> Result<Vec<EventRow>, StoreError> {
        Ok(sqlx::query_as::<_, EventRow>(
            "SELECT job_id, seq, at, kind, payload FROM job_events WHERE job_id = $1 AND seq > $2 ORDER BY seq LIMIT $3",
        )
        .bind(id)
        .bind(after)
        .bind(limit)
        .fetch_all(&self.reader)
        .await?)
    }

    /// Writes the health row in a write transaction: `Ok` when the store can write now.
    /// `GET /healthz` calls it, so that a store which still reads but cannot write (a full
    /// disk) is not reported healthy.
    pub async fn probe_write(&self) -> Result<(), StoreError> {
        let mut tx = self.begin().await?;
        sqlx::query("INSERT INTO health (id, checked_at) VALUES (1, $1) ON CONFLICT (id) DO UPDATE SET checked_at = excluded.checked_at")
            .bind(now_ms())
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(())
    }

    /// Why the last worker report could not be stored for lack of space, if the reports since
    /// have not been stored either.
    pub fn report_failure(&self) -> Option<String> {
        self.report_failure.lock().ok().and_then(|f| f.clone())
    }

    /// Jobs by state, for metrics.
    pub async fn count_by_state(&self) -> Result<Vec<(String, i64)>, StoreError> {
        Ok(sqlx::query_as("SELECT state, COUNT(*) FROM jobs GROUP BY state").fetch_all(&self.reader).await?)
    }

    /// Run durations (s) of finished jobs, for metrics.
    pub async fn durations(&self) -> Result<Vec<(String, f64)>, StoreError> {
        Ok(sqlx::query_as(
            "SELECT state, CAST(finished_at - started_at AS DOUBLE PRECISION) / 1000.0 FROM jobs WHERE finished_at IS NOT NULL AND started_at IS NOT NULL",
        )
        .fetch_all(&self.reader)
        .await?)
    }

    /// Renews the lease of every running job for one lease duration from now plus twice the
    /// longest pause between a worker's tries ([`sable_worker::execute::MAX_RETRY_PAUSE`]: a
    /// worker backing off when the database came back reports within it), and returns how
    /// many. The reaper calls it when the database comes back after an outage, in place of
    /// putting back the jobs whose leases ran out meanwhile: their workers could not report
    /// while the database was away, and a job run again from its start (spending an attempt)
    /// for the database's fault loses hours on a long run. A worker that really died meanwhile
    /// loses its job that much later.
    pub async fn renew_running_leases(&self) -> Result<u64, StoreError> {
        let grace = self.lease.ttl + 2 * sable_worker::execute::MAX_RETRY_PAUSE;
        let mut tx = self.begin().await?;
        let n = sqlx::query("UPDATE jobs SET lease_expires_at = $1 WHERE state = 'running' AND lease_id IS NOT NULL")
            .bind(now_ms() + grace.as_millis() as i64)
            .execute(&mut *tx)
            .await?
            .rows_affected();
        tx.commit().await?;
        Ok(n)
    }

    /// Puts back in the queue every running job whose lease has expired (or, with
    /// `owner_prefix`, that is held by a worker of that name: the local pool of a server that
    /// stopped without handing its jobs back). A job out of attempts fails with `worker_lost`.
    pub async fn requeue_expired(&self, owner_prefix: Option<&str>) -> Result<usize, StoreError> {
        let mut tx = self.begin().await?;
        let ids: Vec<(i64, i64, i64)> = match owner_prefix {
            None => {
                let sql = format!(
                    "SELECT id, attempts, max_attempts FROM jobs WHERE state = 'running' AND lease_expires_at < $1{}",
                    self.backend.lock_skip()
                );
                sqlx::query_as(&sql).bind(now_ms()).fetch_all(&mut *tx).await?
            }
            Some(p) => {
                let sql = format!(
                    "SELECT id, attempts, max_attempts FROM jobs WHERE state = 'running' AND substr(lease_owner, 1, length($1)) = $2{}",
                    self.backend.lock_skip()
                );
                sqlx::query_as(&sql).bind(p).bind(p).fetch_all(&mut *tx).await?
            }
        };
        let mut events = Vec::with_capacity(ids.len());
        for &(id, attempts, max) in &ids {
            if attempts < max {
                sqlx::query("UPDATE jobs SET state = 'queued', lease_id = NULL, lease_owner = NULL, lease_expires_at = NULL WHERE id = $1")
                    .bind(id)
                    .execute(&mut *tx)
                    .await?;
            } else {
                sqlx::query(
                    "UPDATE jobs SET state = 'failed', lease_id = NULL, lease_owner = NULL, lease_expires_at = NULL, finished_at = $1, \
                     error_code = 'worker_lost', error_message = $2 WHERE id = $3",
                )
                .bind(now_ms())
                .bind(format!("the worker running the job stopped answering, {attempts} time(s) out of {max} allowed attempts"))
                .bind(id)
                .execute(&mut *tx)
                .await?;
                Self::drop_checkpoint(&mut tx, id).await?;
            }
            events.push((id, self.state_event(&mut tx, id).await?));
        }
        tx.commit().await?;
        for (id, event) in events {
            self.notify(id, vec![event]);
        }
        if !ids.is_empty() {
            self.queued.notify_waiters();
        }
        Ok(ids.len())
    }

    /// Leases the next queued job (highest priority, then oldest) to `owner`.
    pub async fn lease_next(&self, owner: &str) -> Result<Option<Lease>, StoreError> {
        let mut tx = self.begin().await?;
        let lease_id = new_lease_id();
        let now = now_ms();
        let sql = format!(
            "UPDATE jobs SET state = 'running', lease_id = $1, lease_owner = $2, lease_expires_at = $3, attempts = attempts + 1, \
             started_at = COALESCE(started_at, $4), progress = 0 \
             WHERE id = (SELECT id FROM jobs WHERE state = 'queued' ORDER BY priority DESC, id LIMIT 1{}) \
             RETURNING id, scene, attempts",
            self.backend.lock_skip()
        );
        let row: Option<(i64, String, i64)> = sqlx::query_as(&sql)
            .bind(&lease_id)
            .bind(owner)
            .bind(now + self.lease.ttl.as_millis() as i64)
            .bind(now)
            .fetch_optional(&mut *tx)
            .await?;
        let Some((id, scene, attempts)) = row else {
            tx.rollback().await?;
            return Ok(None);
        };
        let resume_step = Self::resume_point(&mut tx, id).await?;
        sqlx::query("UPDATE jobs SET resumed_from_step = $1 WHERE id = $2")
            .bind(resume_step.map(|step| i64::try_from(step).unwrap_or(i64::MAX)))
            .bind(id)
            .execute(&mut *tx)
            .await?;
        self.commit_state(tx, id).await?;
        // The checkpoint and the samples before it are read once the write is committed (a
        // long run's samples are tens of megabytes; nothing else writes them while the job
        // is leased). If that or the scene's state cannot be read, the job is handed back at
        // once rather than left to a lease nobody holds (and an attempt spent).
        let lease = Lease { job_id: id, lease_id, scene_json: String::new(), attempt: attempts as u32, resume: None };
        let prepared = async {
            let resume = match resume_step {
                None => None,
                Some(step) => self.read_resume(id, &lease.lease_id, step).await?,
            };
            Ok::<_, StoreError>((resume, self.resolve_start(scene).await?))
        };
        match prepared.await {
            Ok((resume, scene_json)) => Ok(Some(Lease { scene_json, resume, ..lease })),
            Err(e) => {
                let _ = self.finish(&lease, &Outcome::Released).await;
                Err(e)
            }
        }
    }

    /// Drops job `id`'s checkpoint in `tx`: an ended job is not run again.
    async fn drop_checkpoint(tx: &mut Tx, id: i64) -> Result<(), StoreError> {
        sqlx::query("DELETE FROM checkpoints WHERE job_id = $1").bind(id).execute(&mut **tx).await?;
        Ok(())
    }

    /// The step from which a new attempt of job `id` starts, in `tx`: that of the last
    /// checkpoint an earlier attempt stored, with what was stored after it dropped; else
    /// (none, or one whose samples are not all there) `None`, everything earlier attempts
    /// stored dropped.
    async fn resume_point(tx: &mut Tx, id: i64) -> Result<Option<u64>, StoreError> {
        let checkpoint: Option<(i64, i64, i64)> =
            sqlx::query_as("SELECT step, samples, snapshots FROM checkpoints WHERE job_id = $1").bind(id).fetch_optional(&mut **tx).await?;
        if let Some((step, samples, snapshots)) = checkpoint {
            sqlx::query("DELETE FROM samples WHERE job_id = $1 AND seq > $2").bind(id).bind(samples).execute(&mut **tx).await?;
            sqlx::query("DELETE FROM snapshots WHERE job_id = $1 AND idx >= $2").bind(id).bind(snapshots).execute(&mut **tx).await?;
            let kept: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM samples WHERE job_id = $1").bind(id).fetch_one(&mut **tx).await?;
            if kept == samples && samples > 0 {
                return Ok(Some(step.max(0) as u64));
            }
        }
        Self::forget_attempts(tx, id).await?;
        Ok(None)
    }

    /// Drops what earlier attempts of job `id` stored (checkpoint, samples, snapshots), in
    /// `tx`: the next attempt starts from scratch.
    async fn forget_attempts(tx: &mut Tx, id: i64) -> Result<(), StoreError> {
        for table in ["checkpoints", "samples", "snapshots"] {
            sqlx::query(&format!("DELETE FROM {table} WHERE job_id = $1")).bind(id).execute(&mut **tx).await?;
        }
        sqlx::query("UPDATE jobs SET resumed_from_step = NULL WHERE id = $1").bind(id).execute(&mut **tx).await?;
        Ok(())
    }

    /// The checkpoint of job `id` at `step` and the samples before it, read through the
    /// reader pool for the attempt leased as `lease_id`. If they cannot be read back whole (a
    /// sample that does not parse, the checkpoint gone), the attempt starts from scratch
    /// instead: what earlier attempts stored is dropped, as long as the lease still holds.
    async fn read_resume(&self, id: i64, lease_id: &str, step: u64) -> Result<Option<ResumeFrom>, StoreError> {
        let data: Option<Vec<u8>> =
            sqlx::query_scalar("SELECT data FROM checkpoints WHERE job_id = $1").bind(id).fetch_optional(&self.reader).await?;
        let rows: Vec<String> =
            sqlx::query_scalar("SELECT data FROM samples WHERE job_id = $1 ORDER BY seq").bind(id).fetch_all(&self.reader).await?;
        let samples: Option<Vec<Sample>> = rows.iter().map(|r| serde_json::from_str(r).ok()).collect();
        if let (Some(checkpoint), Some(samples)) = (data, samples) {
            return Ok(Some(ResumeFrom { step, checkpoint, samples }));
        }
        let mut tx = self.begin().await?;
        self.lock_job(&mut tx, id).await?;
        let held: Option<i64> = sqlx::query_scalar("SELECT id FROM jobs WHERE id = $1 AND lease_id = $2")
            .bind(id)
            .bind(lease_id)
            .fetch_optional(&mut *tx)
            .await?;
        if held.is_some() {
            Self::forget_attempts(&mut tx, id).await?;
        }
        tx.commit().await?;
        Ok(None)
    }

    /// Checks the lease inside a transaction; renews it.
    async fn hold(&self, tx: &mut Tx, lease: &Lease) -> Result<bool, StoreError> {
        let r: Option<i64> = sqlx::query_scalar(
            "UPDATE jobs SET lease_expires_at = $1 WHERE id = $2 AND lease_id = $3 AND state = 'running' RETURNING cancel_requested",
        )
        .bind(now_ms() + self.lease.ttl.as_millis() as i64)
        .bind(lease.job_id)
        .bind(&lease.lease_id)
        .fetch_optional(&mut **tx)
        .await?;
        r.map(|c| c != 0).ok_or_else(|| StoreError::Conflict(format!("lease {} of job {} is no longer held", lease.lease_id, lease.job_id)))
    }

    /// Appends job `id`'s state event to `tx`, commits, and tells the watchers: how every
    /// change of a job's state ends.
    async fn commit_state(&self, mut tx: Tx, id: i64) -> Result<(), StoreError> {
        let event = self.state_event(&mut tx, id).await?;
        tx.commit().await?;
        self.notify(id, vec![event]);
        Ok(())
    }

    /// Fails the leased job in `tx` for passing a limit ([`JobLimits`]), with `why`; the
    /// worker hears a conflict (its lease is gone) and stops the run.
    async fn stop_at_limit(&self, mut tx: Tx, lease: &Lease, why: &str) -> Result<bool, StoreError> {
        sqlx::query(
            "UPDATE jobs SET state = 'failed', error_code = 'limit', error_message = $1, finished_at = $2, \
             lease_id = NULL, lease_owner = NULL, lease_expires_at = NULL WHERE id = $3",
        )
        .bind(why)
        .bind(now_ms())
        .bind(lease.job_id)
        .execute(&mut *tx)
        .await?;
        Self::drop_checkpoint(&mut tx, lease.job_id).await?;
        self.commit_state(tx, lease.job_id).await?;
        Err(StoreError::Conflict(format!("job {} stopped: {why}", lease.job_id)))
    }

    /// Stores a worker's report (fenced by its lease). Returns true if the job was cancelled.
    pub async fn report(&self, lease: &Lease, report: &Report) -> Result<bool, StoreError> {
        let mut tx = self.begin().await?;
        let cancel = self.hold(&mut tx, lease).await?;
        if report.from_start {
            // The worker could not go on from the checkpoint it was given: what earlier
            // attempts stored goes, as for an attempt without one.
            Self::forget_attempts(&mut tx, lease.job_id).await?;
        }
        // The samples of an attempt are numbered 1, 2, ... without gaps. A report sent again
        // because its answer was lost starts at or before the last one stored: those are
        // skipped, so every sample is stored once.
        let mut seq: i64 = sqlx::query_scalar("SELECT COALESCE(MAX(seq), 0) FROM samples WHERE job_id = $1")
            .bind(lease.job_id)
            .fetch_one(&mut *tx)
            .await?;
        let skip = report.first_sample.map_or(0, |first| (seq - first.min(i64::MAX as u64) as i64).clamp(0, report.samples.len() as i64));
        let fresh = &report.samples[skip as usize..];
        let rows =
            fresh.iter().map(serde_json::to_string).collect::<Result<Vec<String>, _>>().map_err(|e| sqlx::Error::Encode(Box::new(e)))?;
        let snapshot_bytes: usize = report.snapshots.iter().map(|f| f.particles.len() + f.contacts.len() + f.walls.len()).sum();
        // Each sample is stored twice: as a row and in its event.
        let adding = (2 * rows.iter().map(String::len).sum::<usize>() + snapshot_bytes) as u64;
        let stored: i64 = sqlx::query_scalar("SELECT stored_bytes FROM jobs WHERE id = $1").bind(lease.job_id).fetch_one(&mut *tx).await?;
        let last_step = report.samples.last().map_or(0, |s| s.step);
        // A checkpoint replaces the last one: it counts against the bytes a job may store
        // while it is held, not added to them.
        let checkpoint_bytes = report.checkpoint.as_ref().map_or(0, |c| c.data.len() as u64);
        if let Some(why) =
            self.limits.breach(seq.max(0) as u64 + rows.len() as u64, stored.max(0) as u64 + adding + checkpoint_bytes, last_step)
        {
            return self.stop_at_limit(tx, lease, &why).await;
        }
        for (s, data) in fresh.iter().zip(rows) {
            seq += 1;
            sqlx::query(
                "INSERT INTO samples (job_id, seq, step, time, phi, z, z_no_rattlers, zeta, mu, p, q, inertial_number, \
                 kinetic_energy, elastic_energy, data) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15)",
            )
            .bind(lease.job_id)
            .bind(seq)
            .bind(s.step as i64)
            .bind(s.time)
            .bind(s.phi)
            .bind(s.z)
            .bind(s.z_no_rattlers)
            .bind(s.zeta)
            .bind(s.mu)
            .bind(s.p)
            .bind(s.q)
            .bind(s.inertial_number)
            .bind(s.kinetic_energy)
            .bind(s.elastic_energy)
            .bind(data)
            .execute(&mut *tx)
            .await?;
        }
        for f in &report.snapshots {
            // A snapshot is numbered by the worker: one sent again is stored once.
            sqlx::query(
                "INSERT INTO snapshots (job_id, idx, step, time, particles, contacts, walls) VALUES ($1, $2, $3, $4, $5, $6, $7) \
                 ON CONFLICT (job_id, idx) DO NOTHING",
            )
            .bind(lease.job_id)
            .bind(f.index as i64)
            .bind(f.step as i64)
            .bind(f.time)
            .bind(&f.particles)
            .bind(&f.contacts)
            .bind(&f.walls)
            .execute(&mut *tx)
            .await?;
        }
        if let Some(c) = &report.checkpoint {
            // Stored only once every sample before it is (the report that carries it stores
            // them): a resumed attempt numbers its samples from there.
            if c.samples > 0 && seq >= i64::try_from(c.samples).unwrap_or(i64::MAX) {
                sqlx::query(
                    "INSERT INTO checkpoints (job_id, step, samples, snapshots, data, saved_at) VALUES ($1, $2, $3, $4, $5, $6) \
                     ON CONFLICT (job_id) DO UPDATE SET step = excluded.step, samples = excluded.samples, \
                     snapshots = excluded.snapshots, data = excluded.data, saved_at = excluded.saved_at",
                )
                .bind(lease.job_id)
                .bind(i64::try_from(c.step).unwrap_or(i64::MAX))
                .bind(c.samples as i64)
                .bind(i64::try_from(c.snapshots).unwrap_or(i64::MAX))
                .bind(&c.data)
                .bind(now_ms())
                .execute(&mut *tx)
                .await?;
            }
        }
        // One sample event per sample, carrying the progress of the batch.
        let mut events = Vec::with_capacity(fresh.len());
        let first = Self::next_seq(&mut tx, lease.job_id).await?;
        for (k, s) in fresh.iter().enumerate() {
            let payload = serde_json::json!({"fraction": report.fraction, "remaining_seconds": report.remaining_seconds, "sample": s});
            events.push(self.insert_event(&mut tx, lease.job_id, first + k as i64, "sample", &payload).await?);
        }
        sqlx::query(
            "UPDATE jobs SET progress = $1, steps = CASE WHEN steps > $2 THEN steps ELSE $2 END, stored_bytes = stored_bytes + $4 WHERE id = $3",
        )
        .bind(report.fraction.clamp(0.0, 1.0))
        .bind(i64::try_from(last_step).unwrap_or(i64::MAX))
        .bind(lease.job_id)
        .bind(i64::try_from(adding).unwrap_or(i64::MAX))
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        if !events.is_empty() {
            self.notify(lease.job_id, events);
        }
        Ok(cancel)
    }

    /// Ends a lease with its outcome (fenced by the lease).
    pub async fn finish(&self, lease: &Lease, outcome: &Outcome) -> Result<(), StoreError> {
        let mut tx = self.begin().await?;
        self.hold(&mut tx, lease).await?;
        // How the job ends (None: a released job is handed back instead).
        struct End<'a> {
            state: &'a str,
            code: Option<&'a str>,
            message: Option<&'a str>,
            steps: Option<u64>,
            wall_seconds: Option<f64>,
            cpu_seconds: Option<f64>,
            solver_iterations: Option<u64>,
            result: Option<&'a str>,
        }
        let end = match outcome {
            Outcome::Succeeded { steps, wall_seconds, cpu_seconds, solver_iterations, result, .. } => Some(End {
                state: "succeeded",
                code: None,
                message: None,
                steps: Some(*steps),
                wall_seconds: Some(*wall_seconds),
                cpu_seconds: Some(*cpu_seconds),
                solver_iterations: Some(*solver_iterations),
                result: result.as_deref(),
            }),
            Outcome::Failed { code, message, steps, wall_seconds, cpu_seconds } => Some(End {
                state: "failed",
                code: Some(code),
                message: Some(message),
                steps: Some(*steps),
                wall_seconds: Some(*wall_seconds),
                cpu_seconds: Some(*cpu_seconds),
                solver_iterations: None,
                result: None,
            }),
            Outcome::Cancelled { steps, wall_seconds, cpu_seconds } => Some(End {
                state: "cancelled",
                code: Some("cancelled"),
                message: Some("cancelled by the user"),
                steps: Some(*steps),
                wall_seconds: Some(*wall_seconds),
                cpu_seconds: Some(*cpu_seconds),
                solver_iterations: None,
                result: None,
            }),
            Outcome::Released => None,
        };
        let clear = "lease_id = NULL, lease_owner = NULL, lease_expires_at = NULL";
        match end {
            Some(End { state, code, message, steps, wall_seconds, cpu_seconds, solver_iterations, result }) => {
                sqlx::query(&format!(
                    "UPDATE jobs SET state = $1, progress = CASE WHEN $1 = 'succeeded' THEN 1 ELSE progress END, error_code = $2, \
                     error_message = $3, steps = COALESCE($4, steps), wall_seconds = COALESCE($5, wall_seconds), finished_at = $6, \
                     result = $8, cpu_seconds = COALESCE($9, cpu_seconds), solver_iterations = COALESCE($10, solver_iterations), \
                     {clear} WHERE id = $7"
                ))
                .bind(state)
                .bind(code)
                .bind(message)
                .bind(steps.map(|s| i64::try_from(s).unwrap_or(i64::MAX)))
                .bind(wall_seconds)
                .bind(now_ms())
                .bind(lease.job_id)
                .bind(result)
                .bind(cpu_seconds)
                .bind(solver_iterations.map(|n| n as i64))
                .execute(&mut *tx)
                .await?;
                Self::drop_checkpoint(&mut tx, lease.job_id).await?;
                if let Outcome::Succeeded { state: Some(gz), .. } = outcome {
                    sqlx::query(
                        "INSERT INTO job_states (job_id, state) VALUES ($1, $2) ON CONFLICT (job_id) DO UPDATE SET state = excluded.state",
                    )
                    .bind(lease.job_id)
                    .bind(gz)
                    .execute(&mut *tx)
                    .await?;
                }
            }
            None => {
                // Handed back by a worker that is shutting down: not the job's fault.
                sqlx::query(&format!(
                    "UPDATE jobs SET state = 'queued', attempts = CASE WHEN attempts > 0 THEN attempts - 1 ELSE 0 END, progress = 0, {clear} WHERE id = $1"
                ))
                .bind(lease.job_id)
                .execute(&mut *tx)
                .await?;
            }
        }
        self.commit_state(tx, lease.job_id).await?;
        if matches!(outcome, Outcome::Released) {
            self.queued.notify_one();
        }
        Ok(())
    }
}

fn source_error(e: StoreError, lease: Option<&Lease>) -> SourceError {
    match (e, lease) {
        (StoreError::Conflict(_), Some(l)) => SourceError::LeaseLost { job_id: l.job_id, lease_id: l.lease_id.clone() },
        (e, _) => SourceError::Unavailable(e.to_string()),
    }
}

impl JobSource for JobStore {
    async fn lease(&self, worker: &str) -> Result<Option<Lease>, SourceError> {
        self.lease_next(worker).await.map_err(|e| source_error(e, None))
    }

    async fn report(&self, lease: &Lease, report: &Report) -> Result<bool, SourceError> {
        let stored = JobStore::report(self, lease, report).await;
        let failure = match &stored {
            Err(e) if e.outage() == Some(Outage::DiskFull) => Some(format!("job {}'s last report: {e}", lease.job_id)),
            Err(_) => return stored.map_err(|e| source_error(e, Some(lease))),
            Ok(_) => None,
        };
        if let Ok(mut last) = self.report_failure.lock() {
            *last = failure;
        }
        stored.map_err(|e| source_error(e, Some(lease)))
    }

    async fn finish(&self, lease: &Lease, outcome: Outcome) -> Result<(), SourceError> {
        JobStore::finish(self, lease, &outcome).await.map_err(|e| source_error(e, Some(lease)))
    }
}

/// Keeps at most `max` of `v` (0 = all), evenly spread, first and last included.
pub fn downsample<T>(v: Vec<T>, max: usize) -> Vec<T> {
    if max == 0 || v.len() <= max {
        return v;
    }
    if max == 1 {
        return v.into_iter().last().into_iter().collect();
    }
    let n = v.len();
    let keep: Vec<usize> = (0..max).map(|k| (k * (n - 1) + (max - 1) / 2) / (max - 1)).collect();
    v.into_iter().enumerate().filter(|(i, _)| keep.binary_search(i).is_ok()).map(|(_, x)| x).collect()
}
