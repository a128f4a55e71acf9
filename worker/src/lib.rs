//! # sable-worker
//!
//! The worker pool of the Sable service. Workers lease queued jobs from a [`JobSource`] — the
//! server's own job store when the pool runs inside `sable serve`, or a server reached over gRPC
//! ([`remote::RemoteSource`]) for `sable worker --server URL` — build the scene with the engine,
//! step it on a dedicated thread with its own thread budget, and report samples and progress in
//! batches, so the physics never waits on the database.
//!
//! Leases are renewed by every report; a report that finds the job cancelled stops the engine
//! (it checks its cancel flag every step), and a lost lease (the job was given to another
//! worker) stops it without writing anything more.

pub mod child;
pub mod execute;
pub mod pool;
pub mod remote;
pub mod source;

pub use execute::{run_scene, JobProcess};
pub use pool::{Pool, PoolConfig, PoolStats, DEFAULT_CHECKPOINT_INTERVAL};
pub use source::{CheckpointFile, JobSource, Lease, Outcome, Report, ResumeFrom, SnapshotFiles, SourceError};
