//! The pool: N workers, each leasing one job at a time.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use tokio::sync::Notify;
use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use crate::execute::{execute, JobProcess, ReportTiming};
use crate::source::{JobSource, SourceError};

/// How often a running job saves a checkpoint unless told otherwise: ten minutes, so that a
/// worker lost costs at most that much of a job's run.
pub const DEFAULT_CHECKPOINT_INTERVAL: Duration = Duration::from_secs(600);

/// Settings of a worker pool.
#[derive(Debug, Clone)]
pub struct PoolConfig {
    /// Name prefix of the workers (lease owners), e.g. `local:1a2b`.
    pub name: String,
    /// Number of jobs run at once.
    pub workers: usize,
    /// Threads each job may use (its thread budget).
    pub threads_per_job: usize,
    /// How often an idle worker asks for a job when nobody wakes it.
    pub poll_interval: Duration,
    /// How often a running job reports samples and renews its lease (also bounds how long a
    /// cancellation takes to reach the engine).
    pub report_interval: Duration,
    /// How often a running job saves a checkpoint (wall time; None: only when the pool stops),
    /// from which a later attempt goes on if this one does not finish ([`crate::execute`]).
    pub checkpoint_interval: Option<Duration>,
    /// Where each job's engine runs: in a process of its own for `sable serve` and
    /// `sable worker`, so that a job that aborts its process leaves the others running.
    pub job_process: JobProcess,
}

impl PoolConfig {
    /// `workers` workers sharing the machine's cores: each job gets `cores / workers` threads
    /// (at least one).
    pub fn new(name: impl Into<String>, workers: usize) -> Self {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let workers = workers.max(1);
        Self {
            name: name.into(),
            workers,
            threads_per_job: (cores / workers).max(1),
            poll_interval: Duration::from_millis(500),
            report_interval: Duration::from_millis(250),
            checkpoint_interval: Some(DEFAULT_CHECKPOINT_INTERVAL),
            job_process: JobProcess::InWorker,
        }
    }
}

/// Live counters of a pool.
#[derive(Debug, Default)]
pub struct PoolStats {
    /// Workers running a job now.
    pub busy: AtomicUsize,
    /// Workers in the pool.
    pub workers: AtomicUsize,
    /// Why the server refused the pool, if it did (the pool then stops).
    pub refused: std::sync::OnceLock<String>,
}

/// A running pool; dropping it does not stop it: call [`Pool::shutdown`].
#[derive(Debug)]
pub struct Pool {
    tasks: JoinSet<()>,
    shutdown: CancellationToken,
    /// Counters, for metrics.
    pub stats: Arc<PoolStats>,
}

impl Pool {
    /// Starts the workers on the current tokio runtime. `wake` is notified by whoever queues a
    /// job, so that an idle worker takes it at once.
    pub fn start<S: JobSource>(source: Arc<S>, config: PoolConfig, wake: Arc<Notify>) -> Self {
        let shutdown = CancellationToken::new();
        let stats = Arc::new(PoolStats::default());
        stats.workers.store(config.workers, Ordering::Relaxed);
        let mut tasks = JoinSet::new();
        for k in 0..config.workers {
            let (source, config, wake, shutdown, stats) = (source.clone(), config.clone(), wake.clone(), shutdown.clone(), stats.clone());
            tasks.spawn(async move {
                let me = format!("{}/{k}", config.name);
                let timing = ReportTiming { interval: config.report_interval, checkpoint: config.checkpoint_interval };
                while !shutdown.is_cancelled() {
                    match source.lease(&me).await {
                        Ok(Some(lease)) => {
                            stats.busy.fetch_add(1, Ordering::Relaxed);
                            execute(source.as_ref(), &lease, config.threads_per_job, timing, &config.job_process, &shutdown).await;
                            stats.busy.fetch_sub(1, Ordering::Relaxed);
                            // Another job may be waiting: ask again at once.
                            continue;
                        }
                        Ok(None) => {}
                        Err(SourceError::Refused(why)) => {
                            // A wrong token stays wrong: stop the pool rather than ask forever.
                            let _ = stats.refused.set(why);
                            shutdown.cancel();
                            return;
                        }
                        Err(e) => eprintln!("worker {me}: cannot lease: {e}"),
                    }
                    tokio::select! {
                        _ = wake.notified() => {}
                        _ = tokio::time::sleep(config.poll_interval) => {}
                        _ = shutdown.cancelled() => {}
                    }
                }
            });
        }
        Self { tasks, shutdown, stats }
    }

    /// Waits until the pool stops by itself (the server refused it: [`PoolStats::refused`]) or
    /// is shut down.
    pub async fn stopped(&self) {
        self.shutdown.cancelled().await;
    }

    /// Stops every worker at once, as a crash would: nothing more is written (the engines see
    /// their cancel flags and stop).
    pub fn abort(mut self) {
        self.tasks.abort_all();
    }

    /// Stops leasing, hands running jobs back to the queue and waits for the workers, at most
    /// `grace`.
    pub async fn shutdown(mut self, grace: Duration) {
        self.shutdown.cancel();
        let all = async { while self.tasks.join_next().await.is_some() {} };
        if tokio::time::timeout(grace, all).await.is_err() {
            self.tasks.abort_all();
        }
    }
}
