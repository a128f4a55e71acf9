//! Studies in the store (migrations/0005_studies.sql): the study file, the jobs it spawned
//! (one per run: a sweep's point, a search's probe) with their measured value, and the report
//! the study driver recomputes as they finish (server/src/studies.rs).

use sable_engine::advise::ExpectedCost;
use sable_engine::study::report::StudyReport;
use sable_engine::study::StudySpec;

use super::{now_ms, EventRow, JobStore, NewJob, StoreError, Tx};

/// A run to add to a study, with the job that runs it.
#[derive(Debug, Clone)]
pub struct NewRun {
    /// Position in the study, from 0.
    pub idx: i64,
    /// Label of its series (for a search: `probe`).
    pub series: String,
    /// The swept values, as a label.
    pub label: String,
    /// The knob's value of a search's probe.
    pub value: Option<f64>,
    /// The job.
    pub job: NewJob,
}

/// One study.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct StudyRow {
    /// Id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// `sweep` or `search`.
    pub kind: String,
    /// `running`, `succeeded`, `failed` or `cancelled`.
    pub state: String,
    /// The study file as submitted.
    pub spec: String,
    /// The report (JSON, `sable_engine::study::report::StudyReport`), once computed.
    pub report: Option<String>,
    /// Why the study failed.
    pub error: Option<String>,
    /// Times, ms since the epoch.
    pub created_at: i64,
    /// When it ended.
    pub finished_at: Option<i64>,
}

/// One run of a study with its job's outcome and cost.
#[derive(Debug, Clone, PartialEq, sqlx::FromRow)]
pub struct RunRow {
    /// Position in the study.
    pub idx: i64,
    /// The job.
    pub job_id: i64,
    /// Series label.
    pub series: String,
    /// Swept values as a label.
    pub label: String,
    /// Knob of a probe.
    pub value: Option<f64>,
    /// Measured value, once the job ended and was measured.
    pub measured: Option<f64>,
    /// Why nothing was measured.
    pub measure_note: Option<String>,
    /// 1 once the run's measure has been taken (or found impossible).
    pub measured_done: i64,
    /// The job's state.
    pub state: String,
    /// The job's error code and message, if it failed.
    pub error_code: Option<String>,
    /// Message.
    pub error_message: Option<String>,
    /// Steps done.
    pub steps: i64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// CPU seconds of the job's threads.
    pub cpu_seconds: f64,
    /// Contact-solver sweeps.
    pub solver_iterations: i64,
    /// The job's experiment results (JSON).
    pub result: Option<String>,
    /// The method the job ran with (`dem`, `cd`, `mpm`, ...).
    pub method: String,
}

const STUDY_SELECT: &str = "SELECT id, name, kind, state, spec, report, error, created_at, finished_at FROM studies";

impl JobStore {
    /// Inserts the jobs of `runs` and their rows in `study_jobs`, in the caller's transaction;
    /// returns the events to announce after the commit.
    async fn insert_runs(&self, tx: &mut Tx, study: i64, runs: &[NewRun]) -> Result<Vec<(i64, EventRow)>, StoreError> {
        let mut events = Vec::with_capacity(runs.len());
        for run in runs {
            let (job, event) = self.insert_job(tx, &run.job).await?;
            sqlx::query("INSERT INTO study_jobs (study_id, idx, job_id, series, label, value) VALUES ($1, $2, $3, $4, $5, $6)")
                .bind(study)
                .bind(run.idx)
                .bind(job)
                .bind(&run.series)
                .bind(&run.label)
                .bind(run.value)
                .execute(&mut **tx)
                .await?;
            events.push((job, event));
        }
        Ok(events)
    }

    fn announce(&self, events: Vec<(i64, EventRow)>) {
        for (job, event) in events {
            self.notify(job, vec![event]);
            self.queued.notify_one();
        }
    }

    /// Creates a study with its first runs, all in one transaction: either the study and every
    /// job exist, or nothing was written.
    pub async fn create_study(&self, name: &str, kind: &str, spec: &str, runs: &[NewRun]) -> Result<StudyRow, StoreError> {
        let mut tx = self.begin().await?;
        let id: i64 =
            sqlx::query_scalar("INSERT INTO studies (name, kind, state, spec, created_at) VALUES ($1, $2, 'running', $3, $4) RETURNING id")
                .bind(name)
                .bind(kind)
                .bind(spec)
                .bind(now_ms())
                .fetch_one(&mut *tx)
                .await?;
        let events = self.insert_runs(&mut tx, id, runs).await?;
        tx.commit().await?;
        self.announce(events);
        self.study(id).await
    }

    /// Adds runs to a running study (a search's next probe). A run whose position is taken
    /// already is skipped, so that a driver that repeats itself after a crash adds nothing
    /// twice.
    pub async fn add_study_runs(&self, study: i64, runs: &[NewRun]) -> Result<(), StoreError> {
        let mut tx = self.begin().await?;
        let mut fresh = Vec::new();
        for run in runs {
            let taken: Option<i64> = sqlx::query_scalar("SELECT job_id FROM study_jobs WHERE study_id = $1 AND idx = $2")
                .bind(study)
                .bind(run.idx)
                .fetch_optional(&mut *tx)
                .await?;
            if taken.is_none() {
                fresh.push(run.clone());
            }
        }
        let events = self.insert_runs(&mut tx, study, &fresh).await?;
        tx.commit().await?;
        self.announce(events);
        Ok(())
    }

    /// One study.
    pub async fn study(&self, id: i64) -> Result<StudyRow, StoreError> {
        sqlx::query_as::<_, StudyRow>(&format!("{STUDY_SELECT} WHERE id = $1"))
            .bind(id)
            .fetch_optional(&self.reader)
            .await?
            .ok_or_else(|| StoreError::Missing(format!("study {id} not found")))
    }

    /// Studies in a state (`running` for the driver), oldest first, or the newest `limit` of all.
    pub async fn studies(&self, state: Option<&str>, limit: i64) -> Result<Vec<StudyRow>, StoreError> {
        Ok(match state {
            Some(s) => {
                sqlx::query_as::<_, StudyRow>(&format!("{STUDY_SELECT} WHERE state = $1 ORDER BY id LIMIT $2"))
                    .bind(s)
                    .bind(limit)
                    .fetch_all(&self.reader)
                    .await?
            }
            None => {
                sqlx::query_as::<_, StudyRow>(&format!("{STUDY_SELECT} ORDER BY id DESC LIMIT $1"))
                    .bind(limit)
                    .fetch_all(&self.reader)
                    .await?
            }
        })
    }

    /// The runs that succeeded in the stored studies of this scene (the same scene whatever its
    /// method, name, sampling and snapshots, which do not change what is simulated), those on
    /// their study's Pareto front marked: what the advice quotes as the expected cost. Every run,
    /// not the front alone: a method whose runs another beats on both cost and error is still
    /// quoted with what it needed.
    pub async fn expected_cost(&self, scene: &serde_json::Value) -> Result<Vec<ExpectedCost>, StoreError> {
        let strip = |s: &serde_json::Value| {
            let mut s = s.clone();
            if let Some(m) = s.as_object_mut() {
                for field in ["method", "name", "sampling", "snapshots"] {
                    m.remove(field);
                }
            }
            s
        };
        let wanted = strip(scene);
        let mut out = Vec::new();
        for row in self.studies(None, 1000).await? {
            let Ok(spec) = serde_json::from_str::<StudySpec>(&row.spec) else { continue };
            if strip(&spec.scene) != wanted {
                continue;
            }
            let Some(report) = row.report.as_deref().and_then(|r| serde_json::from_str::<StudyReport>(r).ok()) else { continue };
            // One query per matching study for the runs' methods, not one read per run.
            let methods: std::collections::HashMap<i64, String> =
                self.study_runs(row.id).await?.into_iter().map(|r| (r.job_id, r.method)).collect();
            for p in report.points.iter().filter(|p| p.state == "succeeded") {
                let method = methods.get(&p.job_id).cloned().unwrap_or_default();
                out.push(ExpectedCost {
                    study_id: row.id,
                    job_id: p.job_id,
                    series: p.series.clone(),
                    label: p.label.clone(),
                    method,
                    cpu_seconds: p.cost.cpu_seconds,
                    wall_seconds: p.cost.wall_seconds,
                    error: p.relative_error.or(p.error),
                    pareto: p.pareto,
                });
            }
        }
        Ok(out)
    }

    /// The runs of a study, in order, with their jobs' outcomes.
    pub async fn study_runs(&self, study: i64) -> Result<Vec<RunRow>, StoreError> {
        Ok(sqlx::query_as::<_, RunRow>(
            "SELECT r.idx, r.job_id, r.series, r.label, r.value, r.measured, r.measure_note, r.measured_done, j.state, j.error_code, \
             j.error_message, j.steps, j.wall_seconds, j.cpu_seconds, j.solver_iterations, j.result, j.method \
             FROM study_jobs r JOIN jobs j ON j.id = r.job_id WHERE r.study_id = $1 ORDER BY r.idx",
        )
        .bind(study)
        .fetch_all(&self.reader)
        .await?)
    }

    /// Records a run's measured value (or why there is none).
    pub async fn set_run_measure(&self, study: i64, idx: i64, measured: Option<f64>, note: Option<&str>) -> Result<(), StoreError> {
        let mut tx = self.begin().await?;
        sqlx::query("UPDATE study_jobs SET measured = $1, measure_note = $2, measured_done = 1 WHERE study_id = $3 AND idx = $4")
            .bind(measured)
            .bind(note)
            .bind(study)
            .bind(idx)
            .execute(&mut *tx)
            .await?;
        tx.commit().await?;
        Ok(())
    }

    /// Stores a study's report and state (`finished_at` is set when it leaves `running`).
    pub async fn set_study_report(&self, id: i64, report: &str, state: &str, error: Option<&str>) -> Result<(), StoreError> {
        let mut tx = self.begin().await?;
        sqlx::query(
            "UPDATE studies SET report = $1, state = $2, error = $3, \
             finished_at = CASE WHEN $2 = 'running' THEN NULL ELSE COALESCE(finished_at, $4) END WHERE id = $5",
        )
        .bind(report)
        .bind(state)
        .bind(error)
        .bind(now_ms())
        .bind(id)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(())
    }
}
