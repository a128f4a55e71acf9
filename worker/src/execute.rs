//! Running one leased job: the engine on a blocking thread, the reports on the async side.

use std::panic::AssertUnwindSafe;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use sable_engine::methods::soft::trace::NewtonSink;
use sable_engine::methods::{plan_scene, Plan};
use sable_engine::observe::{Sample, Snapshot};
use sable_engine::resume::Checkpoint;
use sable_engine::run::{Progress, Resume, RunSummary, Runner};
use sable_engine::scene::{format_violations, StateFile};
use sable_engine::EngineError;
use tokio_util::sync::CancellationToken;

use crate::source::{gunzip, gzip, CheckpointFile, JobSource, Lease, Outcome, Report, ResumeFrom, SnapshotFiles, SourceError};

/// Largest checkpoint read back from a lease, bytes once decompressed (as a final state:
/// about two million particles in 3D).
pub const MAX_CHECKPOINT_BYTES: u64 = 1 << 30;

/// Builds the plan's method on its scene and runs it to its stop criteria with `runner`.
pub fn run_scene(scene: &Plan, runner: &Runner, on_sample: &mut dyn FnMut(&Sample, &Progress)) -> Result<RunSummary, EngineError> {
    run_scene_with_snapshots(scene, runner, on_sample, &mut |_| {}).map(|(summary, _)| summary)
}

/// As [`run_scene`], with the snapshots the runner asks for; also returns the final state.
pub fn run_scene_with_snapshots(
    scene: &Plan,
    runner: &Runner,
    on_sample: &mut dyn FnMut(&Sample, &Progress),
    on_snapshot: &mut dyn FnMut(&Snapshot),
) -> Result<(RunSummary, StateFile), EngineError> {
    run_scene_traced(scene, runner, on_sample, on_snapshot, None)
}

/// As [`run_scene_with_snapshots`], the method's Newton iterations sent to `trace` when given
/// (`sable run --trace`; methods without Newton iterations ignore it).
pub fn run_scene_traced(
    scene: &Plan,
    runner: &Runner,
    on_sample: &mut dyn FnMut(&Sample, &Progress),
    on_snapshot: &mut dyn FnMut(&Snapshot),
    trace: Option<NewtonSink>,
) -> Result<(RunSummary, StateFile), EngineError> {
    let mut sim = scene.build()?;
    if let Some(sink) = trace {
        sim.trace_newton(sink);
    }
    let summary = runner.run_with_snapshots(sim.as_mut(), on_sample, on_snapshot)?;
    Ok((summary, sim.saved_state()))
}

/// Runs a leased job: from `resume` when given (falling back to the scene's start, with
/// [`Msg::FromStart`] sent, if the checkpoint's state cannot be built), else from the start;
/// snapshots numbered from the checkpoint's count, checkpoints sent gzip-compressed.
fn run_job(
    job: i64,
    scene: &Plan,
    resume: Option<Resumable>,
    runner: &Runner,
    send: &(dyn Fn(Msg) + Sync),
) -> Result<(RunSummary, StateFile), EngineError> {
    let resumed = match resume {
        Some(r) => match r.plan.build() {
            Ok(sim) => Some((sim, r)),
            Err(e) => {
                send(Msg::FromStart(format!(
                    "job {job}: the state of the checkpoint at step {} cannot be built: {e}",
                    r.checkpoint.clock.steps
                )));
                None
            }
        },
        None => None,
    };
    let (mut sim, resume) = match resumed {
        Some((sim, r)) => (sim, Some(r)),
        None => (scene.build()?, None),
    };
    let mut index = resume.as_ref().map_or(0, |r| u32::try_from(r.checkpoint.snapshots).unwrap_or(u32::MAX));
    let summary = runner.run_resumable(
        sim.as_mut(),
        resume.as_ref().map(|r| Resume { checkpoint: &r.checkpoint, samples: &r.samples }),
        // Never blocks: the physics does not wait for the reports.
        &mut |s, p| send(Msg::Sample(Box::new(s.clone()), *p)),
        &mut |s| {
            send(Msg::Snapshot(SnapshotFiles::encode(index, s)));
            index = index.saturating_add(1);
        },
        &mut |c| {
            // Written here, off the async threads; a checkpoint that cannot be written is skipped.
            if let Ok(text) = serde_json::to_string(c) {
                send(Msg::Checkpoint(CheckpointFile {
                    step: c.clock.steps,
                    samples: c.samples,
                    snapshots: c.snapshots,
                    data: gzip(&text),
                }));
            }
        },
    )?;
    Ok((summary, sim.saved_state()))
}

/// Runs job `job` of `scene` (its JSON `scene_json`, the thread budget applied: `threads`)
/// on a pool of `threads` threads of its own, from the checkpoint `resume` when it can be gone
/// on from: how it ended and its final state (gzip-compressed JSON), every message sent to
/// `send`. A panic of the engine is caught and reported as a failure.
pub(crate) fn engine_run(
    job: i64,
    scene: Plan,
    scene_json: &str,
    threads: usize,
    resume: Option<ResumeFrom>,
    runner: Runner,
    send: &(dyn Fn(Msg) + Sync),
) -> (Ended, Option<Vec<u8>>) {
    let pool = match job_pool(threads) {
        Ok(p) => p,
        Err(message) => return (Ended::Failed { code: "internal".into(), message, step: Some(0), cpu_seconds: 0.0 }, None),
    };
    let resume = resume.and_then(|from| {
        let step = from.step;
        match resumable(from, &scene, scene_json, threads) {
            Ok(r) => Some(r),
            Err(why) => {
                send(Msg::FromStart(format!("job {job}: cannot go on from the checkpoint at step {step}: {why}")));
                None
            }
        }
    });
    let caught = std::panic::catch_unwind(AssertUnwindSafe(|| {
        pool.install(|| {
            // The CPU time of every thread of the job's pool, before and after the run.
            let cpu_start = pool_cpu_seconds();
            let run = run_job(job, &scene, resume, &runner, send)
                // Compressed here, off the async threads.
                .map(|(summary, state)| (summary, serde_json::to_string(&state).ok().map(|text| gzip(&text))));
            (run, pool_cpu_seconds() - cpu_start)
        })
    }));
    match caught {
        Ok((Ok((summary, state)), cpu_seconds)) => (
            Ended::Ran {
                steps: summary.steps,
                solver_iterations: summary.solver_iterations,
                result: summary.result.as_ref().and_then(|r| serde_json::to_string(r).ok()),
                cpu_seconds,
            },
            state,
        ),
        Ok((Err(EngineError::Cancelled { step }), cpu_seconds)) => (Ended::Cancelled { step, cpu_seconds }, None),
        Ok((Err(e), cpu_seconds)) => {
            // The step the engine stopped at, where it says.
            let step = match &e {
                EngineError::Unstable { step, .. } => Some(*step),
                _ => None,
            };
            (Ended::Failed { code: e.code().into(), message: e.to_string(), step, cpu_seconds }, None)
        }
        Err(panic) => (Ended::Failed { code: "internal".into(), message: panic_message(&panic), step: None, cpu_seconds: 0.0 }, None),
    }
}

/// The threads a scene's method will use under a budget of `budget` threads: the scene's own
/// smaller setting stays. The method's own setting is cleared: the caller runs the whole job
/// inside a pool of that size ([`job_pool`]), so the method's parallel loops use it without a
/// hand-off to another pool at every step.
pub fn apply_thread_budget(scene: &mut Plan, budget: usize) -> usize {
    let budget = budget.max(1);
    let threads = scene.method.threads();
    let n = if threads == 0 { budget } else { threads.min(budget) };
    scene.method.set_threads(0);
    n
}

/// CPU seconds used so far by the threads of the rayon pool this runs in (each thread's
/// `CLOCK_THREAD_CPUTIME_ID`, summed by a broadcast); 0 where the clock cannot be read.
fn pool_cpu_seconds() -> f64 {
    rayon::broadcast(|_| {
        nix::time::clock_gettime(nix::time::ClockId::CLOCK_THREAD_CPUTIME_ID).map_or(0.0, |t| t.tv_sec() as f64 + 1e-9 * t.tv_nsec() as f64)
    })
    .into_iter()
    .sum()
}

/// A pool of `threads` threads for one job.
pub fn job_pool(threads: usize) -> Result<rayon::ThreadPool, String> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .thread_name(|i| format!("sable-job-{i}"))
        .build()
        .map_err(|e| format!("cannot start {threads} threads: {e}"))
}

/// Sets the engine's cancel flag when dropped.
struct CancelOnDrop(std::sync::Arc<std::sync::atomic::AtomicBool>);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// What the engine thread sends to the async side.
pub(crate) enum Msg {
    Sample(Box<Sample>, Progress),
    Snapshot(SnapshotFiles),
    Checkpoint(CheckpointFile),
    /// The lease's checkpoint could not be gone on from (why): the run starts from step 0.
    FromStart(String),
}

/// Timing of the reports of one job.
#[derive(Debug, Clone, Copy)]
pub struct ReportTiming {
    /// Samples and progress are flushed (and the lease renewed) at this interval.
    pub interval: Duration,
    /// A checkpoint is saved at this interval of wall time (None: only when the worker stops).
    pub checkpoint: Option<Duration>,
}

/// Where a job's engine runs.
#[derive(Debug, Clone, Default)]
pub enum JobProcess {
    /// On a thread of the worker's process (a job that aborts its process takes the worker
    /// down with it).
    #[default]
    InWorker,
    /// In a process of its own: this executable (`exe`) run as `EXE job-run`
    /// ([`crate::child`]), its data (heap and written mappings) bounded to `memory` bytes
    /// when given (an allocation past it fails the job with code `crashed`, saying it ran out
    /// of memory, rather than leaving the kernel to kill a process of its choice).
    Own {
        /// The executable.
        exe: std::path::PathBuf,
        /// Largest data of a job process, bytes.
        memory: Option<u64>,
    },
}

/// How a job's engine ended (in the worker's process or in a job process of its own,
/// [`crate::child`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) enum Ended {
    /// Ran to its stop criteria.
    Ran { steps: u64, solver_iterations: u64, result: Option<String>, cpu_seconds: f64 },
    /// Stopped by its cancel flag.
    Cancelled { step: u64, cpu_seconds: f64 },
    /// Stopped with an error; `step`: where, when the error says.
    Failed { code: String, message: String, step: Option<u64>, cpu_seconds: f64 },
}

/// A lease's checkpoint, ready to go on from: the scene made to start from its state (with
/// the thread budget applied), the checkpoint, and the samples before it.
pub(crate) struct Resumable {
    plan: Plan,
    checkpoint: Checkpoint,
    samples: Vec<Sample>,
}

/// Reads the checkpoint of `from` and makes `scene_json` (planned as `original`) go on from it,
/// on `threads` threads; why not if this engine cannot (another version of the format, a state
/// the scene refuses).
pub(crate) fn resumable(from: ResumeFrom, original: &Plan, scene_json: &str, threads: usize) -> Result<Resumable, String> {
    let text = gunzip(&from.checkpoint, MAX_CHECKPOINT_BYTES).map_err(|e| format!("cannot be read: {e}"))?;
    let checkpoint = Checkpoint::from_json(&text)?;
    let json = checkpoint.scene_to_resume(scene_json)?;
    let mut plan = plan_scene(&json).map_err(|v| format!("the scene does not go on from its state: {}", format_violations(&v)))?;
    plan.continue_saved_run(original);
    apply_thread_budget(&mut plan, threads);
    Ok(Resumable { plan, checkpoint, samples: from.samples })
}

/// Waits for the next tick of `t`, or for ever without one.
async fn tick_of(t: &mut Option<tokio::time::Interval>) {
    match t {
        Some(t) => {
            t.tick().await;
        }
        None => std::future::pending().await,
    }
}

/// Runs a leased job to its end and reports its outcome. Returns the outcome reported (or
/// `None` if the lease was lost and nothing more could be written).
pub async fn execute<S: JobSource>(
    source: &S,
    lease: &Lease,
    threads: usize,
    timing: ReportTiming,
    process: &JobProcess,
    shutdown: &CancellationToken,
) -> Option<Outcome> {
    let mut scene = match plan_scene(&lease.scene_json) {
        Ok(s) => s,
        Err(v) => {
            // The server validated it at submission; only an engine upgrade can make it invalid.
            let outcome = Outcome::Failed {
                code: "invalid_scene".into(),
                message: format!("the stored scene is no longer valid: {}", format_violations(&v)),
                steps: 0,
                wall_seconds: 0.0,
                cpu_seconds: 0.0,
            };
            return finish(source, lease, outcome).await;
        }
    };
    let threads = apply_thread_budget(&mut scene, threads);
    let runner = Runner::for_scene(&scene);
    let cancel = runner.cancel.clone();
    let checkpoint = runner.checkpoint.clone();
    // If this future is dropped (the pool aborted), the engine stops too.
    let _guard = CancelOnDrop(cancel.clone());
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Msg>();
    // The first sample this attempt reports, and the step it starts from (both back to 0 if
    // the checkpoint cannot be gone on from: Msg::FromStart).
    let (first_sample, mut last_step) = lease.resume.as_ref().map_or((0, 0), |r| (r.samples.len() as u64, r.step));
    let started = Instant::now();
    let (job, scene_json, resume) = (lease.job_id, lease.scene_json.clone(), lease.resume.clone());
    let mut engine = match process {
        JobProcess::InWorker => tokio::task::spawn_blocking(move || {
            engine_run(job, scene, &scene_json, threads, resume, runner, &|m| {
                let _ = tx.send(m);
            })
        }),
        JobProcess::Own { exe, memory } => {
            let (exe, memory) = (exe.clone(), *memory);
            tokio::spawn(async move {
                crate::child::run_in_process(&exe, memory, job, &scene_json, threads, resume.as_ref(), &runner, &mut |m| {
                    let _ = tx.send(m);
                })
                .await
            })
        }
    };

    let mut pending = Report { first_sample: Some(first_sample), ..Report::default() };
    let mut tick = tokio::time::interval(timing.interval);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut checkpoints = timing.checkpoint.map(|every| {
        let mut t = tokio::time::interval_at(tokio::time::Instant::now() + every, every);
        t.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        t
    });
    let mut released = false;
    let mut lost = false;
    let result = loop {
        tokio::select! {
            r = &mut engine => break r,
            _ = tick_of(&mut checkpoints) => checkpoint.store(true, Ordering::SeqCst),
            Some(msg) = rx.recv() => receive(msg, &mut pending, &mut last_step),
            _ = tick.tick() => {
                if lost {
                    continue;
                }
                match flush(source, lease, &mut pending).await {
                    Ok(true) => cancel.store(true, Ordering::Relaxed),
                    Ok(false) => {}
                    Err(SourceError::LeaseLost { .. } | SourceError::Refused(_)) => {
                        lost = true;
                        cancel.store(true, Ordering::Relaxed);
                    }
                    // Transient: keep the samples and try again at the next tick; the lease
                    // outlives several ticks.
                    Err(SourceError::Unavailable(_)) => {}
                }
            }
            _ = shutdown.cancelled(), if !released => {
                // A checkpoint first, stored with the last report: the next attempt goes on
                // from it.
                released = true;
                checkpoint.store(true, Ordering::SeqCst);
                cancel.store(true, Ordering::SeqCst);
            }
        }
    };
    while let Ok(msg) = rx.try_recv() {
        receive(msg, &mut pending, &mut last_step);
    }
    if lost {
        return None;
    }
    let wall_seconds = started.elapsed().as_secs_f64();
    let outcome = match result {
        Ok((Ended::Ran { steps, solver_iterations, result, cpu_seconds }, state)) => {
            pending.fraction = 1.0;
            pending.remaining_seconds = Some(0.0);
            Outcome::Succeeded { steps, wall_seconds, cpu_seconds, solver_iterations, result, state }
        }
        Ok((Ended::Cancelled { .. }, _)) if released => Outcome::Released,
        Ok((Ended::Cancelled { step, cpu_seconds }, _)) => Outcome::Cancelled { steps: step, wall_seconds, cpu_seconds },
        // The step the engine stopped at, or the last one sampled.
        Ok((Ended::Failed { code, message, step, cpu_seconds }, _)) => {
            Outcome::Failed { code, message, steps: step.unwrap_or(last_step), wall_seconds, cpu_seconds }
        }
        Err(join) => Outcome::Failed {
            code: "internal".into(),
            message: format!("the engine thread failed: {join}"),
            steps: last_step,
            wall_seconds,
            cpu_seconds: 0.0,
        },
    };
    // The last samples (and a job handed back: its checkpoint) go in before the outcome;
    // retried while the store is unreachable.
    for attempt in 0..20 {
        match flush(source, lease, &mut pending).await {
            Ok(_) => break,
            Err(SourceError::LeaseLost { .. } | SourceError::Refused(_)) => return None,
            Err(SourceError::Unavailable(_)) => tokio::time::sleep(retry_pause(attempt)).await,
        }
    }
    finish(source, lease, outcome).await
}

/// The longest pause between two tries of a worker to store its last samples or its outcome
/// while the store is unreachable: the store gives running jobs at least this much beyond a
/// lease when it comes back, so that a worker between two tries does not lose its job.
pub const MAX_RETRY_PAUSE: Duration = Duration::from_millis(100 << 5);

/// The pause before try `attempt + 1`: 0.1 s, doubling up to [`MAX_RETRY_PAUSE`].
fn retry_pause(attempt: u32) -> Duration {
    Duration::from_millis(100 << attempt.min(5))
}

/// Sends the pending samples and progress (also when there is no sample: the report renews the
/// lease and brings back cancellation). Keeps the samples if the call fails.
async fn flush<S: JobSource>(source: &S, lease: &Lease, pending: &mut Report) -> Result<bool, SourceError> {
    let before = pending.first_sample.get_or_insert(0);
    let sent = *before + pending.samples.len() as u64;
    let cancelled = source.report(lease, pending).await?;
    pending.first_sample = Some(sent);
    pending.samples.clear();
    pending.snapshots.clear();
    pending.checkpoint = None;
    pending.from_start = false;
    Ok(cancelled)
}

/// Adds what the engine sent to the next report.
fn receive(msg: Msg, pending: &mut Report, last_step: &mut u64) {
    match msg {
        Msg::Sample(s, p) => {
            *last_step = s.step;
            pending.fraction = p.fraction;
            pending.remaining_seconds = p.remaining;
            pending.samples.push(*s);
        }
        Msg::Snapshot(f) => pending.snapshots.push(f),
        // A newer checkpoint replaces one not sent yet.
        Msg::Checkpoint(c) => pending.checkpoint = Some(c),
        Msg::FromStart(why) => {
            // Sent before any sample: this attempt numbers its samples from 1 again.
            eprintln!("{why}; the job runs from step 0");
            pending.from_start = true;
            pending.first_sample = Some(0);
            *last_step = 0;
        }
    }
}

async fn finish<S: JobSource>(source: &S, lease: &Lease, outcome: Outcome) -> Option<Outcome> {
    for attempt in 0..20 {
        match source.finish(lease, outcome.clone()).await {
            Ok(()) => return Some(outcome),
            Err(SourceError::LeaseLost { .. } | SourceError::Refused(_)) => return None,
            Err(SourceError::Unavailable(_)) => tokio::time::sleep(retry_pause(attempt)).await,
        }
    }
    None
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    let what = p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_default();
    format!("the engine panicked (a bug in Sable; please report it with the scene): {what}")
}
