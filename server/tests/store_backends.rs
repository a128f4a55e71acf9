//! The job store's semantics, the same tests on both back-ends (SQLite and PostgreSQL), and
//! what only several servers on one PostgreSQL can show: one queue leased by all of them, each
//! job exactly once; a server hearing of the events another server stored; the study driver
//! running on one server at a time and moving when its holder goes.
//!
//! PostgreSQL comes from `common/postgres.rs` (a throw-away cluster; the tests skip with a
//! message when the machine has no PostgreSQL, and fail then under `SABLE_REQUIRE_POSTGRES=1`).

use crate::common;

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;

use sable_engine::observe::Sample;
use sable_server::store::{Backend, DbLocation, JobLimits, JobStore, LeaseConfig, ListFilter, NewJob, NewRun, StoreError};
use sable_worker::{CheckpointFile, Lease, Outcome, Report, SnapshotFiles};

use common::postgres;

/// The back-ends to run a test on: SQLite always, PostgreSQL when there is one.
async fn locations(dir: &tempfile::TempDir) -> Vec<DbLocation> {
    let mut v = vec![DbLocation::Sqlite(dir.path().join("sable.db"))];
    if let Some(pg) = postgres::server() {
        v.push(DbLocation::Postgres(postgres::fresh_database(pg).await));
    }
    v
}

async fn open(at: &DbLocation, ttl_ms: u64) -> JobStore {
    JobStore::open(at, LeaseConfig { ttl: Duration::from_millis(ttl_ms) }).await.unwrap_or_else(|e| panic!("open {at}: {e}"))
}

fn job(name: &str, priority: i64, key: Option<&str>) -> NewJob {
    NewJob {
        name: name.into(),
        scene: format!("{{\"name\":\"{name}\"}}"),
        scene_hash: format!("hash-{name}"),
        method: "dem".into(),
        method_reason: "test".into(),
        seed: 7,
        priority,
        max_attempts: 2,
        idempotency_key: key.map(str::to_string),
    }
}

fn sample(step: u64, phi: f64) -> Sample {
    serde_json::from_value(serde_json::json!({
        "step": step, "time": step as f64 * 1e-3, "phi": phi, "z": 4.0, "z_no_rattlers": 4.2, "zeta": 0.3, "p": 100.0, "q": 30.0,
        "stress": {"xx": 1.0, "yy": 2.0, "zz": 0.0, "xy": 0.5, "xz": 0.0, "yz": 0.0},
        "inertial_number": null, "kinetic_energy": 1e-6, "elastic_energy": 2e-6, "walls": []
    }))
    .expect("a sample")
}

fn report(samples: Vec<Sample>, fraction: f64) -> Report {
    Report { fraction, remaining_seconds: Some(1.0), samples, ..Report::default() }
}

fn succeeded(steps: u64) -> Outcome {
    Outcome::Succeeded {
        steps,
        wall_seconds: 0.5,
        cpu_seconds: 0.4,
        solver_iterations: 0,
        result: Some("{\"peak\":1}".into()),
        state: Some(vec![1, 2, 3]),
    }
}

/// Submission, idempotency, the queue's order, reports fenced by the lease, events numbered
/// without gaps, samples read back whole and downsampled with the events' sequence number,
/// the end of a job, listing, cancellation, lease expiry and hand-back: on both back-ends.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_queue_behaves_the_same_on_both_backends() {
    let dir = tempfile::tempdir().expect("tempdir");
    for at in locations(&dir).await {
        let s = open(&at, 60_000).await;
        let (a, fresh) = s.submit(job("a", 0, Some("key-a"))).await.expect("submit a");
        assert!(fresh);
        let (again, fresh) = s.submit(job("a", 0, Some("key-a"))).await.expect("submit a again");
        assert!(!fresh, "{at}: same key, same scene: the same job");
        assert_eq!(again.id, a.id);
        let mut other = job("a", 0, Some("key-a"));
        other.scene_hash = "another".into();
        assert!(matches!(s.submit(other).await, Err(StoreError::Conflict(_))), "{at}");
        let (b, _) = s.submit(job("b", 5, None)).await.expect("submit b");
        let (c, _) = s.submit(job("c", 0, None)).await.expect("submit c");

        // Highest priority first, then the oldest.
        let l1 = s.lease_next("w1").await.expect("lease").expect("a job");
        let l2 = s.lease_next("w1").await.expect("lease").expect("a job");
        assert_eq!((l1.job_id, l2.job_id), (b.id, a.id), "{at}");
        assert_eq!(l1.attempt, 1);

        // Reports fenced by the lease id.
        let cancelled = s.report(&l1, &report((1..=5).map(|k| sample(k * 100, 0.5 + 0.01 * k as f64)).collect(), 0.5)).await;
        assert!(!cancelled.expect("report"), "{at}");
        let forged = Lease { lease_id: "not-the-lease".into(), ..l1.clone() };
        assert!(matches!(s.report(&forged, &report(vec![sample(600, 0.6)], 0.6)).await, Err(StoreError::Conflict(_))), "{at}");
        // A report sent again (its answer lost) stores its samples once; one that overlaps
        // what is stored adds only what is new.
        let second = Report { first_sample: Some(5), ..report(vec![sample(600, 0.56)], 0.6) };
        s.report(&l1, &second).await.expect("second report");
        s.report(&l1, &second).await.expect("second report again");
        let overlapping = Report { first_sample: Some(4), ..report(vec![sample(500, 0.55), sample(600, 0.56)], 0.6) };
        s.report(&l1, &overlapping).await.expect("overlapping report");

        let all = s.samples(b.id, 0, None).await.expect("samples");
        assert_eq!(all.iter().map(|x| x.step).collect::<Vec<_>>(), vec![100, 200, 300, 400, 500, 600], "{at}");
        assert_eq!(all[2], sample(300, 0.53), "{at}: a sample reads back whole");
        let read = s.samples_and_seq(b.id, 200, Some(600), 3, 0).await.expect("downsampled");
        let (few, seq) = (read.samples, read.events_seq);
        assert_eq!((few.iter().map(|x| x.step).collect::<Vec<_>>(), read.next_from_step), (vec![200, 400, 600], None), "{at}");
        // A page of two, then the rest from where it says.
        let page = s.samples_and_seq(b.id, 0, None, 0, 2).await.expect("a page");
        assert_eq!((page.samples.iter().map(|x| x.step).collect::<Vec<_>>(), page.next_from_step), (vec![100, 200], Some(300)), "{at}");
        let rest = s.samples_and_seq(b.id, 300, None, 0, 4).await.expect("the rest");
        assert_eq!((rest.samples.len(), rest.next_from_step), (4, None), "{at}");
        // Events: queued, running, six samples, numbered 1.. without gaps.
        let events = s.events_after(b.id, 0, 100).await.expect("events");
        assert_eq!(events.iter().map(|e| e.seq).collect::<Vec<_>>(), (1..=8).collect::<Vec<_>>(), "{at}");
        assert_eq!(seq, 8, "{at}");
        assert_eq!(events.iter().filter(|e| e.kind == "sample").count(), 6);

        s.finish(&l1, &succeeded(600)).await.expect("finish");
        let done = s.get(b.id).await.expect("get");
        assert_eq!((done.state.as_str(), done.steps, done.sample_count, done.progress), ("succeeded", 600, 6, 1.0), "{at}");
        assert_eq!(done.result.as_deref(), Some("{\"peak\":1}"));
        assert_eq!(s.final_state(b.id).await.expect("state"), vec![1, 2, 3], "{at}");
        assert!(matches!(s.finish(&l1, &succeeded(600)).await, Err(StoreError::Conflict(_))), "{at}: a lease ends once");
        assert!(matches!(s.final_state(a.id).await, Err(StoreError::Missing(_))), "{at}");

        // Handed back: queued again, the attempt not counted; leased again it starts afresh.
        s.report(&l2, &report(vec![sample(10, 0.5)], 0.1)).await.expect("report a");
        s.finish(&l2, &Outcome::Released).await.expect("release");
        let a_now = s.get(a.id).await.expect("get a");
        assert_eq!((a_now.state.as_str(), a_now.attempts), ("queued", 0), "{at}");
        let l3 = s.lease_next("w2").await.expect("lease").expect("a again");
        assert_eq!((l3.job_id, l3.attempt), (a.id, 1), "{at}");
        assert_eq!(s.get(a.id).await.expect("get").sample_count, 0, "{at}: a new attempt drops the old samples");

        // Cancellation: a queued job at once; a running one at its next report; an ended one never.
        let cancelled_c = s.cancel(c.id).await.expect("cancel c");
        assert_eq!(cancelled_c.state, "cancelled", "{at}");
        s.cancel(a.id).await.expect("cancel a");
        assert!(s.report(&l3, &report(Vec::new(), 0.2)).await.expect("report"), "{at}: the worker hears of it");
        s.finish(&l3, &Outcome::Cancelled { steps: 700, wall_seconds: 1.5, cpu_seconds: 1.25 }).await.expect("finish cancelled");
        let ended = s.get(a.id).await.expect("get");
        assert_eq!(ended.state, "cancelled", "{at}");
        assert_eq!((ended.steps, ended.wall_seconds, ended.cpu_seconds), (700, 1.5, 1.25), "{at}: a cancelled run's time is kept");
        assert!(matches!(s.cancel(b.id).await, Err(StoreError::Conflict(_))), "{at}");
        assert!(matches!(s.cancel(9_999_999).await, Err(StoreError::NotFound(9_999_999))), "{at}");

        // Listing: filters and pages.
        for k in 0..5 {
            s.submit(job(&format!("page-{k}"), 0, None)).await.expect("submit");
        }
        let page1 = s.list(&ListFilter { limit: 3, ..Default::default() }).await.expect("list");
        assert_eq!(page1.len(), 3);
        let page2 = s.list(&ListFilter { limit: 3, before_id: page1.last().map(|j| j.id), ..Default::default() }).await.expect("list");
        assert!(page2.iter().all(|j| j.id < page1[2].id) && page2.len() == 3, "{at}");
        let named = s.list(&ListFilter { name: Some("page-3".into()), limit: 10, ..Default::default() }).await.expect("list");
        assert_eq!(named.len(), 1, "{at}");
        let by_state = s
            .list(&ListFilter {
                state: Some(sable_server::store::JobState::Cancelled),
                method: Some("dem".into()),
                limit: 10,
                ..Default::default()
            })
            .await
            .expect("list");
        assert_eq!(by_state.iter().map(|j| j.id).collect::<HashSet<_>>(), HashSet::from([a.id, c.id]), "{at}");
        let counts: std::collections::HashMap<String, i64> = s.count_by_state().await.expect("counts").into_iter().collect();
        assert_eq!((counts["queued"], counts["succeeded"], counts["cancelled"]), (5, 1, 2), "{at}");
        let durations = s.durations().await.expect("durations");
        assert!(durations.iter().all(|(_, d)| d.is_finite() && *d >= 0.0) && !durations.is_empty(), "{at}");
        s.close().await;

        // A lease that expires puts the job back (and out of attempts, fails it).
        let s = open(&at, 50).await;
        let l = s.lease_next("w3").await.expect("lease").expect("a job");
        tokio::time::sleep(Duration::from_millis(120)).await;
        assert!(s.requeue_expired(None).await.expect("requeue") >= 1, "{at}");
        assert_eq!(s.get(l.job_id).await.expect("get").state, "queued", "{at}");
        assert!(matches!(s.report(&l, &report(Vec::new(), 0.3)).await, Err(StoreError::Conflict(_))), "{at}: the old lease is fenced");
        let l = s.lease_next("w3").await.expect("lease").expect("the same job");
        assert_eq!(l.attempt, 2);
        tokio::time::sleep(Duration::from_millis(120)).await;
        s.requeue_expired(None).await.expect("requeue");
        let failed = s.get(l.job_id).await.expect("get");
        assert_eq!((failed.state.as_str(), failed.error_code.as_deref()), ("failed", Some("worker_lost")), "{at}");
        s.close().await;
    }
}

/// What a job may store is held as its reports arrive: the report that would pass a limit
/// fails the job (code `limit`, the message naming the limit and what to change), the samples
/// before it are kept, and the worker hears that its lease is gone. Before, a scene sampling
/// every step filled the disk at 23 MB/s and `stop.time` 1e308 was never bounded.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_stores_no_more_than_the_servers_limits() {
    let dir = tempfile::tempdir().expect("tempdir");
    for at in locations(&dir).await {
        let limits = JobLimits { max_samples: 5, max_bytes: 1 << 20, max_steps: 1_000 };
        let s = open(&at, 60_000).await.with_job_limits(limits);
        let ended = |why: &'static str| {
            move |s: &JobStore, id: i64| {
                let s = s.clone();
                async move {
                    let row = s.get(id).await.expect("get");
                    assert_eq!((row.state.as_str(), row.error_code.as_deref()), ("failed", Some("limit")), "{why}");
                    let message = row.error_message.unwrap_or_default();
                    assert!(message.contains(why), "{message}");
                    row.sample_count
                }
            }
        };
        // The count: 3 samples stored, the next 3 would make 6 > 5.
        s.submit(job("count", 0, None)).await.expect("submit");
        let l = s.lease_next("w").await.expect("lease").expect("a job");
        s.report(&l, &report((1..=3).map(|k| sample(k * 10, 0.5)).collect(), 0.3)).await.expect("within the limit");
        let refused = s.report(&l, &report((4..=6).map(|k| sample(k * 10, 0.5)).collect(), 0.6)).await;
        assert!(matches!(refused, Err(StoreError::Conflict(_))), "{at}: {refused:?}");
        assert_eq!(ended("--max-samples")(&s, l.job_id).await, 3, "{at}: the samples before the limit are kept");
        assert!(matches!(s.report(&l, &report(Vec::new(), 0.7)).await, Err(StoreError::Conflict(_))), "{at}: the lease is gone");

        // The steps: a sample past step 1,000 (a run bounded only by its simulated time).
        s.submit(job("steps", 0, None)).await.expect("submit");
        let l = s.lease_next("w").await.expect("lease").expect("a job");
        assert!(s.report(&l, &report(vec![sample(2_000, 0.5)], 0.1)).await.is_err(), "{at}");
        assert_eq!(ended("--max-steps")(&s, l.job_id).await, 0, "{at}");

        // The bytes: snapshots of 0.6 MB each against 1 MB.
        s.submit(job("bytes", 0, None)).await.expect("submit");
        let l = s.lease_next("w").await.expect("lease").expect("a job");
        let snapshot = |index: u32| SnapshotFiles {
            index,
            step: u64::from(index),
            time: 0.0,
            particles: vec![0; 600_000],
            contacts: Vec::new(),
            walls: Vec::new(),
        };
        let mut r = report(vec![sample(1, 0.5)], 0.1);
        r.snapshots = vec![snapshot(0)];
        s.report(&l, &r).await.expect("within the limit");
        let mut r = report(vec![sample(2, 0.5)], 0.2);
        r.snapshots = vec![snapshot(1)];
        assert!(s.report(&l, &r).await.is_err(), "{at}");
        assert_eq!(ended("--max-job-bytes")(&s, l.job_id).await, 1, "{at}");
        s.close().await;
    }
}

/// Checkpoints: stored with the report that carries them (once its samples are); a job leased
/// again after its worker died goes on from its last checkpoint, with the samples and snapshots
/// stored after it dropped, those before it handed to the worker, and the step it goes on from
/// in its state event; its new samples are numbered on from there. A worker that cannot use
/// the checkpoint says so and everything earlier goes; an ended job's checkpoint goes. Before,
/// every new attempt started from step 0.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_run_again_goes_on_from_its_last_checkpoint() {
    let dir = tempfile::tempdir().expect("tempdir");
    for at in locations(&dir).await {
        let s = open(&at, 200).await;
        let (j, _) = s.submit(job("long", 0, None)).await.expect("submit");
        let l1 = s.lease_next("w1").await.expect("lease").expect("a job");
        assert_eq!(l1.resume, None, "{at}: a first attempt starts from step 0");
        let snapshot = |index: u32| SnapshotFiles { index, step: u64::from(index) * 100, ..SnapshotFiles::default() };
        let checkpoint =
            |step: u64, samples: u64| CheckpointFile { step, samples, snapshots: 1, data: format!("state at {step}").into_bytes() };
        let mut r = report((1..=3).map(|k| sample(k * 100, 0.5)).collect(), 0.3);
        r.first_sample = Some(0);
        r.snapshots = vec![snapshot(0)];
        r.checkpoint = Some(checkpoint(300, 3));
        s.report(&l1, &r).await.expect("report with a checkpoint");
        // A checkpoint that claims samples not stored is not kept.
        let mut r = report(vec![sample(400, 0.5)], 0.4);
        r.first_sample = Some(3);
        r.snapshots = vec![snapshot(1)];
        r.checkpoint = Some(checkpoint(900, 9));
        s.report(&l1, &r).await.expect("report");

        // The worker dies; its lease runs out.
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert_eq!(s.requeue_expired(None).await.expect("reaper"), 1, "{at}");
        let l2 = s.lease_next("w2").await.expect("lease").expect("the job again");
        let resume = l2.resume.clone().expect("a checkpoint to go on from");
        assert_eq!((resume.step, resume.checkpoint.as_slice()), (300, b"state at 300".as_slice()), "{at}");
        assert_eq!(resume.samples.iter().map(|x| x.step).collect::<Vec<_>>(), vec![100, 200, 300], "{at}");
        assert_eq!(s.samples(j.id, 0, None).await.expect("samples").len(), 3, "{at}: the sample after the checkpoint is dropped");
        assert_eq!(s.snapshots(j.id).await.expect("snapshots").len(), 1, "{at}: so is the snapshot");
        let events = s.events_after(j.id, 0, 100).await.expect("events");
        let running = events.iter().rev().find(|e| e.kind == "state").expect("a state event");
        let payload: serde_json::Value = serde_json::from_str(&running.payload).expect("JSON");
        assert_eq!(payload["resumed_from_step"], 300, "{at}: {payload}");
        // The resumed attempt numbers its samples on from the checkpoint's.
        let mut r = report(vec![sample(400, 0.51), sample(500, 0.52)], 0.5);
        r.first_sample = Some(3);
        s.report(&l2, &r).await.expect("resumed report");
        s.report(&l2, &r).await.expect("the same report again");
        let all = s.samples(j.id, 0, None).await.expect("samples");
        assert_eq!(all.iter().map(|x| x.step).collect::<Vec<_>>(), vec![100, 200, 300, 400, 500], "{at}: each sample once");
        assert_eq!(all[3].phi, 0.51, "{at}: the resumed attempt's sample");
        s.finish(&l2, &succeeded(500)).await.expect("finish");
        // Ended: nothing to go on from any more (a new lease of another job does not see it).
        s.submit(job("next", 0, None)).await.expect("submit");
        let l3 = s.lease_next("w3").await.expect("lease").expect("the next job");
        assert_eq!(l3.resume, None, "{at}");

        // A worker that cannot go on from the checkpoint starts over: everything earlier goes.
        let mut r = report(vec![sample(100, 0.5), sample(200, 0.5)], 0.2);
        r.first_sample = Some(0);
        r.checkpoint = Some(checkpoint(200, 2));
        s.report(&l3, &r).await.expect("report");
        s.finish(&l3, &Outcome::Released).await.expect("hand back");
        let l4 = s.lease_next("w4").await.expect("lease").expect("the job again");
        assert_eq!(l4.resume.as_ref().map(|r| r.step), Some(200), "{at}: a job handed back goes on from its checkpoint");
        let mut r = report(vec![sample(0, 0.4)], 0.0);
        r.first_sample = Some(0);
        r.from_start = true;
        s.report(&l4, &r).await.expect("from the start");
        let all = s.samples(l4.job_id, 0, None).await.expect("samples");
        assert_eq!(all.iter().map(|x| x.step).collect::<Vec<_>>(), vec![0], "{at}");
        s.close().await;
    }
}

/// Studies: created with their jobs in one transaction, runs added once, measures and
/// reports stored.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn studies_behave_the_same_on_both_backends() {
    let dir = tempfile::tempdir().expect("tempdir");
    for at in locations(&dir).await {
        let s = open(&at, 60_000).await;
        let run = |idx: i64| NewRun {
            idx,
            series: "s".into(),
            label: format!("n={idx}"),
            value: Some(idx as f64),
            job: job(&format!("run-{idx}"), 0, None),
        };
        let study = s.create_study("sweep", "sweep", "{}", &[run(0), run(1)]).await.expect("create");
        assert_eq!(study.state, "running");
        s.add_study_runs(study.id, &[run(1), run(2)]).await.expect("add");
        let runs = s.study_runs(study.id).await.expect("runs");
        assert_eq!(runs.iter().map(|r| r.idx).collect::<Vec<_>>(), vec![0, 1, 2], "{at}: run 1 is not added twice");
        assert_eq!(runs[2].value, Some(2.0));
        assert!(runs.iter().all(|r| r.method == "dem"), "{at}: each run carries its job's method");
        s.set_run_measure(study.id, 1, Some(0.25), None).await.expect("measure");
        s.set_run_measure(study.id, 2, None, Some("failed")).await.expect("measure");
        let runs = s.study_runs(study.id).await.expect("runs");
        assert_eq!((runs[1].measured, runs[1].measured_done), (Some(0.25), 1), "{at}");
        assert_eq!((runs[2].measured, runs[2].measure_note.as_deref()), (None, Some("failed")), "{at}");
        s.set_study_report(study.id, "{\"points\":[]}", "succeeded", None).await.expect("report");
        let ended = s.study(study.id).await.expect("study");
        assert!(ended.finished_at.is_some() && ended.state == "succeeded", "{at}");
        assert_eq!(s.studies(None, 10).await.expect("list").len(), 1);
        assert!(s.studies(Some("running"), 10).await.expect("list").is_empty());
        assert!(s.is_study_driver().await, "{at}: a lone server drives");
        s.close().await;
    }
}

/// Three servers on one PostgreSQL, each with three workers leasing at once, drain one queue
/// of 60 jobs: every job is leased and finished exactly once.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn servers_on_one_postgres_share_the_queue() {
    let Some(pg) = postgres::server() else { return };
    let at = DbLocation::Postgres(postgres::fresh_database(pg).await);
    let stores: Vec<JobStore> = futures_join(&at, 3).await;
    let mut ids = HashSet::new();
    for k in 0..60 {
        let (j, _) = stores[k % 3].submit(job(&format!("j{k}"), 0, None)).await.expect("submit");
        ids.insert(j.id);
    }
    let taken = Arc::new(std::sync::Mutex::new(Vec::new()));
    let mut tasks = tokio::task::JoinSet::new();
    for (n, s) in stores.iter().enumerate() {
        for w in 0..3 {
            let s = s.clone();
            let taken = taken.clone();
            tasks.spawn(async move {
                while let Some(l) = s.lease_next(&format!("server{n}:w{w}")).await.expect("lease") {
                    s.report(&l, &report(vec![sample(1, 0.5)], 0.5)).await.expect("report");
                    s.finish(&l, &succeeded(1)).await.expect("finish");
                    taken.lock().expect("lock").push(l.job_id);
                }
            });
        }
    }
    while let Some(r) = tasks.join_next().await {
        r.expect("a worker");
    }
    let taken = taken.lock().expect("lock").clone();
    assert_eq!(taken.len(), 60, "each job leased once");
    assert_eq!(taken.iter().copied().collect::<HashSet<_>>(), ids);
    for id in ids {
        let j = stores[0].get(id).await.expect("get");
        assert_eq!((j.state.as_str(), j.attempts, j.sample_count), ("succeeded", 1, 1));
    }
    for s in &stores {
        s.close().await;
    }
}

/// A watcher on one server hears of the samples a worker of another server stores; the study
/// driver runs on one server and moves to another when that one closes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn servers_on_one_postgres_hear_each_other_and_share_the_driver() {
    let Some(pg) = postgres::server() else { return };
    let at = DbLocation::Postgres(postgres::fresh_database(pg).await);
    let stores = futures_join(&at, 2).await;
    let (a, b) = (&stores[0], &stores[1]);
    assert_eq!(a.backend(), Backend::Postgres);

    let mut heard = b.subscribe();
    let (j, _) = a.submit(job("watched", 0, None)).await.expect("submit");
    let l = a.lease_next("a:w").await.expect("lease").expect("job");
    a.report(&l, &report(vec![sample(1, 0.5), sample(2, 0.51)], 0.5)).await.expect("report");
    // B hears of the job (submitted, leased, sampled) without having written anything.
    let notice = tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            match heard.recv().await {
                Ok(n) if n.job_id == j.id => return n,
                Ok(_) => {}
                Err(e) => panic!("notices: {e}"),
            }
        }
    })
    .await
    .expect("server B hears of server A's job within 10 s");
    assert!(notice.events.is_empty(), "another server's notice says only which job changed");
    // B's watcher, reading the table, sees every event, the samples included, then the end.
    a.finish(&l, &succeeded(2)).await.expect("finish");
    let mut rx = sable_server::watch::watch(b, j.id, 0, Duration::from_millis(200)).await.expect("watch");
    let mut kinds = Vec::new();
    loop {
        let item =
            tokio::time::timeout(Duration::from_secs(10), rx.recv()).await.expect("events come").expect("stream open").expect("no error");
        if let sable_server::watch::WatchItem::Event(e) = item {
            kinds.push(e.kind.clone());
            if sable_server::watch::is_final(&e) {
                break;
            }
        }
    }
    assert_eq!(kinds, vec!["state", "state", "sample", "sample", "state"]);

    // One driver at a time; the role moves when its holder closes.
    let (da, db) = (a.is_study_driver().await, b.is_study_driver().await);
    assert!(da ^ db, "exactly one server drives the studies: {da} {db}");
    let (holder, other) = if da { (a, b) } else { (b, a) };
    assert!(holder.is_study_driver().await && !other.is_study_driver().await, "the role stays put");
    holder.close().await;
    let moved = async {
        while !other.is_study_driver().await {
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    };
    tokio::time::timeout(Duration::from_secs(10), moved).await.expect("the other server takes the role over");
    other.close().await;
}

/// Opens `n` stores on `at` at once (their migrations race; PostgreSQL's advisory lock orders them).
async fn futures_join(at: &DbLocation, n: usize) -> Vec<JobStore> {
    let mut set = tokio::task::JoinSet::new();
    for k in 0..n {
        let at = at.clone();
        set.spawn(async move { (k, open(&at, 60_000).await) });
    }
    let mut v = Vec::new();
    while let Some(r) = set.join_next().await {
        v.push(r.expect("open"));
    }
    v.sort_by_key(|(k, _)| *k);
    v.into_iter().map(|(_, s)| s).collect()
}

/// The same idempotency key sent to two servers at once makes one job: the one that loses the
/// race finds the winner's job instead of failing on the key's uniqueness.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn one_idempotency_key_sent_to_two_servers_at_once_makes_one_job() {
    let Some(pg) = postgres::server() else { return };
    let at = DbLocation::Postgres(postgres::fresh_database(pg).await);
    let stores = futures_join(&at, 2).await;
    for round in 0..20 {
        let key = format!("key-{round}");
        let mut set = tokio::task::JoinSet::new();
        for k in 0..4 {
            let (s, key) = (stores[k % 2].clone(), key.clone());
            set.spawn(async move { s.submit(job("same", 0, Some(&key))).await });
        }
        let mut ids = HashSet::new();
        let mut created = 0;
        while let Some(r) = set.join_next().await {
            let (row, fresh) = r.expect("task").expect("every submission answers with the key's job");
            ids.insert(row.id);
            created += usize::from(fresh);
        }
        assert_eq!((ids.len(), created), (1, 1), "round {round}");
    }
    for s in &stores {
        s.close().await;
    }
}

/// A database at `at` with the schema as it was before migration `version` (from a copy of
/// the earlier migrations' files), holding the rows `script` inserts.
async fn old_database(dir: &tempfile::TempDir, at: &DbLocation, version: i64, script: &str) {
    let (source, backend) = match at {
        DbLocation::Sqlite(_) => ("sqlite", &sable_server::store::SQLITE_MIGRATOR),
        DbLocation::Postgres(_) => ("postgres", &sable_server::store::POSTGRES_MIGRATOR),
    };
    let old = dir.path().join(format!("migrations-{source}-{version}"));
    std::fs::create_dir_all(&old).expect("dir");
    for m in backend.iter().filter(|m| m.version < version) {
        let from = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../migrations/{source}"));
        let file = std::fs::read_dir(&from)
            .expect("migrations")
            .filter_map(Result::ok)
            .find(|f| f.file_name().to_string_lossy().starts_with(&format!("{:04}_", m.version)))
            .expect("the migration's file");
        std::fs::copy(file.path(), old.join(file.file_name())).expect("copy");
    }
    let migrator = sqlx::migrate::Migrator::new(old.as_path()).await.expect("old migrations");
    match at {
        DbLocation::Sqlite(path) => {
            let options = sqlx::sqlite::SqliteConnectOptions::new().filename(path).create_if_missing(true);
            let pool = sqlx::SqlitePool::connect_with(options).await.expect("sqlite");
            migrator.run(&pool).await.expect("old schema");
            sqlx::raw_sql(script).execute(&pool).await.expect("old rows");
            pool.close().await;
        }
        DbLocation::Postgres(url) => {
            let pool = sqlx::PgPool::connect(url).await.expect("postgres");
            migrator.run(&pool).await.expect("old schema");
            sqlx::raw_sql(script).execute(&pool).await.expect("old rows");
            pool.close().await;
        }
    }
}

/// The samples and the replayed sample events of job 1 in `store`, which must agree.
async fn samples_and_events(store: &JobStore, at: &DbLocation) -> Vec<Sample> {
    let samples = store.samples(1, 0, None).await.unwrap_or_else(|e| panic!("{at}: samples: {e}"));
    let events = store.events_after(1, 0, 10).await.expect("events");
    let replayed: Vec<Sample> = events
        .iter()
        .map(|e| {
            let v: serde_json::Value = serde_json::from_str(&e.payload).expect("json");
            serde_json::from_value(v["sample"].clone()).unwrap_or_else(|err| panic!("{at}: event {}: {err}", e.seq))
        })
        .collect();
    assert_eq!(replayed, samples, "{at}: the events replay the same samples");
    samples
}

/// A database made before samples had `zeta` (one `mu` column: τ/σ_n under shear, q/p
/// otherwise) is converted when a server opens it: every stored sample and sample event
/// reads back with `zeta` = q/p, and `mu` = the stored τ/σ_n where a shear was defined, absent
/// otherwise. No sample is lost or left unreadable.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_database_from_before_zeta_is_converted_and_loses_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    for at in locations(&dir).await {
        let shear = r#"{"step":10,"time":0.01,"phi":0.8,"z":4.0,"z_no_rattlers":4.0,"mu":0.25,"p":100.0,"q":40.0,
            "stress":{"xx":100.0,"yy":100.0,"xy":25.0},"inertial_number":0.01,"kinetic_energy":0.0,"elastic_energy":0.0,"walls":[]}"#;
        let biaxial = r#"{"step":0,"time":0.0,"phi":0.8,"z":4.0,"z_no_rattlers":4.0,"mu":0.3,"p":100.0,"q":30.0,
            "stress":{"xx":70.0,"yy":130.0,"xy":0.0},"inertial_number":null,"kinetic_energy":0.0,"elastic_energy":0.0,"walls":[]}"#;
        let script = format!(
            "INSERT INTO jobs (name, state, method, method_reason, scene, scene_hash, engine_version, seed, max_attempts, created_at) \
             VALUES ('old', 'succeeded', 'dem', 'test', '{{}}', 'h', '0', 1, 1, 0);
             INSERT INTO samples (job_id, seq, step, time, phi, z, z_no_rattlers, mu, p, q, inertial_number, kinetic_energy, \
             elastic_energy, data) VALUES (1, 1, 0, 0.0, 0.8, 4.0, 4.0, 0.3, 100.0, 30.0, NULL, 0.0, 0.0, '{biaxial}'), \
             (1, 2, 10, 0.01, 0.8, 4.0, 4.0, 0.25, 100.0, 40.0, 0.01, 0.0, 0.0, '{shear}');
             INSERT INTO job_events (job_id, seq, at, kind, payload) VALUES \
             (1, 1, 0, 'sample', '{{\"fraction\":0.5,\"remaining_seconds\":null,\"sample\":{biaxial}}}'), \
             (1, 2, 0, 'sample', '{{\"fraction\":1.0,\"remaining_seconds\":null,\"sample\":{shear}}}');"
        );
        old_database(&dir, &at, 6, &script).await;
        let store = open(&at, 30_000).await;
        let samples = samples_and_events(&store, &at).await;
        assert_eq!(samples.len(), 2, "{at}");
        assert_eq!((samples[0].zeta, samples[0].mu), (0.3, None), "{at}: q/p without shear, no τ/σ_n");
        assert_eq!((samples[1].zeta, samples[1].mu), (0.4, Some(0.25)), "{at}: q/p and the stored τ/σ_n under shear");
    }
}

/// A database made while a sample of aggregates (bonded particle method) held the primaries'
/// Φ and Z in its own fields is converted when a server opens it: those move under
/// `primaries`, the grains' take their place (the grains' Z standing for their backbone's,
/// which was not measured), in the columns, the stored samples and the replayed events; a
/// sample of deformable grains only gains its backbone's Z in `grains`; a sample of rigid
/// grains is left as it was.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_database_from_before_grains_first_is_converted_and_loses_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grains =
        r#""grains":{"count":4,"phi":0.55,"z":2.5,"pressure":1e5,"mean_aspect_ratio":1.1,"max_aspect_ratio":1.2,"mean_area":2e-6}"#;
    let rest = r#""zeta":0.2,"p":100.0,"q":20.0,"stress":{"xx":100.0,"yy":100.0,"xy":0.0},"inertial_number":null,"kinetic_energy":0.0,"elastic_energy":0.0,"walls":[]"#;
    let aggregates = format!(r#"{{"step":0,"time":0.0,"phi":0.45,"z":5.5,"z_no_rattlers":5.75,{rest},{grains}}}"#);
    let soft = format!(
        r#"{{"step":10,"time":0.01,"phi":0.55,"z":2.5,"z_no_rattlers":3.0,{rest},"deformable":{{"min_jacobian":0.9,"dissipated_energy":0.0,"newton_iterations":1,"sweeps":0}},{grains}}}"#
    );
    let rigid = format!(r#"{{"step":20,"time":0.02,"phi":0.8,"z":4.0,"z_no_rattlers":4.0,{rest}}}"#);
    for at in locations(&dir).await {
        let row = |seq: u32, phi: f64, z: f64, znr: f64, data: &str| {
            format!("(1, {seq}, {seq}, 0.0, {phi}, {z}, {znr}, 0.2, NULL, 100.0, 20.0, NULL, 0.0, 0.0, '{data}')")
        };
        let event =
            |seq: u32, data: &str| format!("(1, {seq}, 0, 'sample', '{{\"fraction\":0.5,\"remaining_seconds\":null,\"sample\":{data}}}')");
        let script = format!(
            "INSERT INTO jobs (name, state, method, method_reason, scene, scene_hash, engine_version, seed, max_attempts, created_at) \
             VALUES ('old', 'succeeded', 'cd', 'test', '{{}}', 'h', '0', 1, 1, 0);
             INSERT INTO samples (job_id, seq, step, time, phi, z, z_no_rattlers, zeta, mu, p, q, inertial_number, kinetic_energy, \
             elastic_energy, data) VALUES {}, {}, {};
             INSERT INTO job_events (job_id, seq, at, kind, payload) VALUES {}, {}, {};",
            row(1, 0.45, 5.5, 5.75, &aggregates),
            row(2, 0.55, 2.5, 3.0, &soft),
            row(3, 0.8, 4.0, 4.0, &rigid),
            event(1, &aggregates),
            event(2, &soft),
            event(3, &rigid),
        );
        old_database(&dir, &at, 7, &script).await;
        let store = open(&at, 30_000).await;
        let samples = samples_and_events(&store, &at).await;
        assert_eq!(samples.len(), 3, "{at}");
        let (a, s, r) = (&samples[0], &samples[1], &samples[2]);
        let primaries = a.primaries.expect("the primaries' measures");
        assert_eq!((primaries.phi, primaries.z, primaries.z_no_rattlers), (0.45, 5.5, 5.75), "{at}");
        assert_eq!((a.phi, a.z, a.z_no_rattlers), (0.55, 2.5, 2.5), "{at}: the grains' Φ and Z");
        assert_eq!(a.grains.as_ref().map(|g| g.z_no_rattlers), Some(2.5), "{at}");
        assert_eq!((s.phi, s.z, s.z_no_rattlers, s.primaries), (0.55, 2.5, 3.0, None), "{at}");
        assert_eq!(s.grains.as_ref().map(|g| g.z_no_rattlers), Some(3.0), "{at}: deformable grains' backbone");
        assert_eq!((r.phi, r.z, r.primaries.is_none(), r.grains.is_none()), (0.8, 4.0, true, true), "{at}");
        // The columns a user's SQL reads agree with the samples.
        let query = "SELECT phi, z, z_no_rattlers FROM samples WHERE job_id = 1 ORDER BY seq";
        let columns: Vec<(f64, f64, f64)> = match &at {
            DbLocation::Sqlite(path) => {
                let pool = sqlx::SqlitePool::connect_with(sqlx::sqlite::SqliteConnectOptions::new().filename(path)).await.expect("sqlite");
                sqlx::query_as(query).fetch_all(&pool).await.expect("columns")
            }
            DbLocation::Postgres(url) => {
                let pool = sqlx::PgPool::connect(url).await.expect("postgres");
                sqlx::query_as(query).fetch_all(&pool).await.expect("columns")
            }
        };
        let of = |x: &Sample| (x.phi, x.z, x.z_no_rattlers);
        assert_eq!(columns, vec![of(a), of(s), of(r)], "{at}: the columns");
    }
}
