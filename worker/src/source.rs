//! Where workers get jobs from, and what they tell it: the one extension point between the
//! worker pool and the job store.

use std::future::Future;

use sable_engine::observe::{Sample, Snapshot};

/// A job leased by one worker. Every report and the final outcome carry the lease id, and the
/// store ignores them once the lease is gone (fencing).
#[derive(Debug, Clone, PartialEq)]
pub struct Lease {
    /// Job id.
    pub job_id: i64,
    /// Lease id, unique to this attempt.
    pub lease_id: String,
    /// The scene JSON as submitted.
    pub scene_json: String,
    /// Attempt number, from 1.
    pub attempt: u32,
    /// The checkpoint an earlier attempt left, to go on from (None: run from step 0).
    pub resume: Option<ResumeFrom>,
}

/// What a leased job goes on from ([`Lease::resume`]): the last checkpoint an earlier attempt
/// stored, and the samples stored before it (the store has dropped the later ones).
#[derive(Debug, Clone, PartialEq)]
pub struct ResumeFrom {
    /// Step of the checkpoint.
    pub step: u64,
    /// The checkpoint ([`sable_engine::resume::Checkpoint`]), gzip-compressed JSON.
    pub checkpoint: Vec<u8>,
    /// Every sample stored before it, in order.
    pub samples: Vec<Sample>,
}

/// A checkpoint of the running attempt, stored with the report that carries it
/// ([`Report::checkpoint`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CheckpointFile {
    /// Step it was taken at.
    pub step: u64,
    /// Samples the run had taken before it (all stored by the report that carries it).
    pub samples: u64,
    /// Snapshots the run had taken before it.
    pub snapshots: u64,
    /// The checkpoint ([`sable_engine::resume::Checkpoint`]), gzip-compressed JSON.
    pub data: Vec<u8>,
}

/// A batch of progress: the samples taken since the last report and where the run stands.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Report {
    /// Fraction of the run done, 0..1.
    pub fraction: f64,
    /// Estimated wall-clock seconds left.
    pub remaining_seconds: Option<f64>,
    /// New samples, in order.
    pub samples: Vec<Sample>,
    /// New snapshots, in order.
    pub snapshots: Vec<SnapshotFiles>,
    /// How many samples of this attempt came before `samples[0]` (the workers of this version
    /// always say; None from older remote workers). With it a report sent again, because its
    /// answer was lost, stores its samples once: the store numbers them from it and skips
    /// those it has.
    pub first_sample: Option<u64>,
    /// A checkpoint taken after this report's samples, stored in their place as the job's
    /// last (None: none new).
    pub checkpoint: Option<CheckpointFile>,
    /// The attempt could not go on from its lease's checkpoint and runs from step 0: the store
    /// drops what earlier attempts stored (samples, snapshots, checkpoint) before this report's
    /// samples (sent with the first report only).
    pub from_start: bool,
}

/// One snapshot as its three VTK files, each gzip-compressed
/// ([`sable_engine::observe::vtk`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SnapshotFiles {
    /// Number of the snapshot in the job, from 0.
    pub index: u32,
    /// Step it was taken at.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// `particles.vtp`, gzip.
    pub particles: Vec<u8>,
    /// `contacts.vtp`, gzip.
    pub contacts: Vec<u8>,
    /// `walls.vtp`, gzip.
    pub walls: Vec<u8>,
}

impl SnapshotFiles {
    /// Renders and compresses snapshot number `index`.
    pub fn encode(index: u32, s: &Snapshot) -> Self {
        use sable_engine::observe::vtk::{contacts_vtp, particles_vtp, walls_vtp};
        Self {
            index,
            step: s.step,
            time: s.time,
            particles: gzip(&particles_vtp(s)),
            contacts: gzip(&contacts_vtp(s)),
            walls: gzip(&walls_vtp(s)),
        }
    }
}

/// Gzip of a text (fast level: snapshots are written while the run goes on).
pub fn gzip(text: &str) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::with_capacity(text.len() / 4), flate2::Compression::fast());
    // Writing into a Vec cannot fail.
    let _ = e.write_all(text.as_bytes());
    e.finish().unwrap_or_default()
}

/// The text of a gzip stream made by [`gzip`], refused past `limit` bytes.
pub fn gunzip(bytes: &[u8], limit: u64) -> std::io::Result<String> {
    use std::io::Read;
    let mut text = String::new();
    flate2::read::GzDecoder::new(bytes).take(limit + 1).read_to_string(&mut text)?;
    if text.len() as u64 > limit {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, format!("more than {limit} bytes once decompressed")));
    }
    Ok(text)
}

/// How a leased job ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Ran to its stop criteria.
    Succeeded {
        /// Steps done.
        steps: u64,
        /// Wall-clock seconds of the run.
        wall_seconds: f64,
        /// CPU seconds of the job's threads.
        cpu_seconds: f64,
        /// Contact-solver sweeps (contact dynamics).
        solver_iterations: u64,
        /// Derived results of the scene's experiment, JSON (`ExperimentResult`).
        result: Option<String>,
        /// The final state (`StateFile`), gzip-compressed JSON.
        state: Option<Vec<u8>>,
    },
    /// Stopped with an error (unstable integration, scene that cannot be built, crash).
    Failed {
        /// Stable code: `unstable`, `build_failed`, `invalid_scene`, `internal`.
        code: String,
        /// What happened and what to change.
        message: String,
        /// Steps done before the failure.
        steps: u64,
        /// Wall-clock seconds of the run.
        wall_seconds: f64,
        /// CPU seconds of the job's threads.
        cpu_seconds: f64,
    },
    /// Stopped because the user cancelled it.
    Cancelled {
        /// Steps done before it stopped.
        steps: u64,
        /// Wall-clock seconds of the run.
        wall_seconds: f64,
        /// CPU seconds of the job's threads.
        cpu_seconds: f64,
    },
    /// Handed back to the queue unfinished (the worker is shutting down); does not count as an
    /// attempt.
    Released,
}

/// Why a call to the source failed.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The lease expired and the job was given back to the queue or to another worker.
    #[error("lease {lease_id} of job {job_id} is no longer held")]
    LeaseLost {
        /// Job id.
        job_id: i64,
        /// The lost lease.
        lease_id: String,
    },
    /// The store or the server could not be reached; the call may be retried.
    #[error("job source unavailable: {0}")]
    Unavailable(String),
    /// The server refuses this worker (no worker's token, or a wrong one): retrying will not
    /// help, so the pool stops.
    #[error("the server refuses this worker: {0}")]
    Refused(String),
}

/// A queue of jobs that workers lease from. Implemented by the server's SQLite store and by the
/// gRPC client of a remote server.
pub trait JobSource: Send + Sync + 'static {
    /// Leases the next queued job for `worker`, if there is one.
    fn lease(&self, worker: &str) -> impl Future<Output = Result<Option<Lease>, SourceError>> + Send;
    /// Stores the samples, updates progress and renews the lease. Returns true if the job was
    /// cancelled and the run must stop.
    fn report(&self, lease: &Lease, report: &Report) -> impl Future<Output = Result<bool, SourceError>> + Send;
    /// Ends the lease with its outcome.
    fn finish(&self, lease: &Lease, outcome: Outcome) -> impl Future<Output = Result<(), SourceError>> + Send;
}
