//! Studies as a service (issue 6; the engine's side is `sable_engine::study`): a study file is
//! checked and expanded into jobs that run through the normal queue; the study driver measures
//! each job when it ends, adds a search's next probe, and keeps the report (cost and error of
//! every run, the Pareto front, a search's limit against its theory) in the store.
//!
//! Everything the driver knows is in the database: after a crash or a restart it picks up
//! every running study where it was (a probe's position in the study is unique, so a repeated
//! step adds nothing twice), and the jobs themselves are recovered by the queue.

use std::time::Duration;

use sable_engine::study::report::{Cost, PointReport, StudyReport, Theory};
use sable_engine::study::search::{FailureMode, Next, Probe};
use sable_engine::study::{parse_checked_study, parse_study, probe_scene, theory, ReferenceSpec, Study, StudySpec};
use serde::Serialize;

use crate::api::{self, rfc3339, ApiError, Limits};
use crate::store::{JobStore, NewRun, RunRow, StudyRow};

/// A study as both APIs show it.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct StudyView {
    /// Id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// `sweep` or `search`.
    pub kind: String,
    /// `running`, `succeeded` (every run ended; some may have failed, which is data) or `failed`.
    pub state: String,
    /// Runs ended so far, and runs in all (a search adds its probes one at a time).
    pub runs_done: usize,
    /// Runs so far.
    pub runs: usize,
    /// RFC 3339.
    pub created_at: String,
    /// RFC 3339, empty while running.
    pub finished_at: String,
    /// Why the study failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The report (each run's cost and error, the Pareto front; a search's limit and theory).
    #[schema(value_type = Object)]
    pub report: Option<serde_json::Value>,
}

impl StudyView {
    fn of(row: StudyRow, runs: &[RunRow]) -> Self {
        Self {
            id: row.id,
            name: row.name,
            kind: row.kind,
            state: row.state,
            runs_done: runs.iter().filter(|r| ended(&r.state)).count(),
            runs: runs.len(),
            created_at: rfc3339(row.created_at),
            finished_at: row.finished_at.map(rfc3339).unwrap_or_default(),
            error: row.error,
            report: row.report.and_then(|r| serde_json::from_str(&r).ok()),
        }
    }
}

fn ended(state: &str) -> bool {
    matches!(state, "succeeded" | "failed" | "cancelled")
}

/// Checks a study file and queues its first jobs (every run of a sweep; the two ends of a
/// search). Nothing is written when a rule is broken.
pub async fn create(store: &JobStore, limits: &Limits, body: &serde_json::Value) -> Result<StudyView, ApiError> {
    let text = serde_json::to_string(body).map_err(|e| ApiError::Internal(e.to_string()))?;
    if text.len() > limits.max_body_bytes {
        return Err(ApiError::TooLarge(limits.max_body_bytes));
    }
    // A base scene that starts from a job's final state is checked with that state in place; its
    // runs keep the reference, which each job resolves when it is submitted and leased (as a
    // submitted scene does), so the state is not copied into every run.
    if let Some(job) = body.get("scene").and_then(crate::start_from::referenced_job) {
        let gz = store.final_state(job).await.map_err(|_| {
            ApiError::invalid("scene.start_from.job", format!("job {job} has no final state: name a job of this server that succeeded"))
        })?;
        let mut resolved = body.clone();
        resolved["scene"] = crate::start_from::with_state(&body["scene"], &gz)
            .map_err(|e| ApiError::Internal(format!("the final state of job {job} {e}")))?;
        let resolved = serde_json::to_string(&resolved).map_err(|e| ApiError::Internal(e.to_string()))?;
        parse_study(&resolved).map_err(ApiError::InvalidArgument)?;
    }
    let (spec, study) = match crate::start_from::referenced_job(&body["scene"]) {
        Some(_) => parse_checked_study(&text),
        None => parse_study(&text),
    }
    .map_err(ApiError::InvalidArgument)?;
    let name = spec.name.clone().unwrap_or_else(|| {
        let scene = spec.scene.get("name").and_then(|n| n.as_str()).unwrap_or("scene");
        format!("study of {scene}")
    });
    if let Some(job) = spec.reference.as_ref().and_then(|r| r.job) {
        let ok = store.get(job).await.map(|j| j.state == "succeeded").unwrap_or(false);
        if !ok {
            return Err(ApiError::invalid("reference.job", format!("job {job} has not succeeded: name a succeeded job of this server")));
        }
    }
    let (kind, runs) = match &study {
        Study::Sweep { points, .. } => {
            let mut runs = Vec::with_capacity(points.len());
            for p in points {
                let job_name = format!("{name} · {} {}", p.series, p.label()).trim().to_string();
                let job = api::new_job(store, limits, &p.scene, "scene.", job_name).await?;
                runs.push(NewRun { idx: p.index as i64, series: p.series.clone(), label: p.label(), value: None, job });
            }
            ("sweep", runs)
        }
        Study::Search { search, scene } => {
            let mut runs = Vec::new();
            for (k, value) in [search.low, search.high].into_iter().enumerate() {
                runs.push(probe_run(store, limits, &name, scene, search, k as i64, value).await?);
            }
            ("search", runs)
        }
    };
    let row = store.create_study(&name, kind, &text, &runs).await?;
    let id = row.id;
    let runs = store.study_runs(id).await?;
    Ok(StudyView::of(row, &runs))
}

/// The run of a search's probe at `value`.
async fn probe_run(
    store: &JobStore,
    limits: &Limits,
    name: &str,
    scene: &serde_json::Value,
    search: &sable_engine::study::SearchSpec,
    idx: i64,
    value: f64,
) -> Result<NewRun, ApiError> {
    let s = probe_scene(scene, search, value).map_err(|e| ApiError::invalid("search.parameter", e))?;
    let label = format!("{value:.4e}");
    let job = api::new_job(store, limits, &s, "scene.", format!("{name} · {} = {label}", search.parameter)).await?;
    Ok(NewRun { idx, series: "probe".into(), label, value: Some(value), job })
}

/// The chart of a study's report, as SVG or PNG.
pub fn chart(view: &StudyView, format: crate::charts::Format) -> Result<Vec<u8>, ApiError> {
    let report = view
        .report
        .clone()
        .and_then(|r| serde_json::from_value::<StudyReport>(r).ok())
        .ok_or_else(|| ApiError::Conflict(format!("study {} has no report yet: ask again in a moment", view.id)))?;
    crate::charts::study(&view.name, &report, format).map_err(ApiError::Internal)
}

/// One study as the APIs show it.
pub async fn get(store: &JobStore, id: i64) -> Result<StudyView, ApiError> {
    let row = store.study(id).await?;
    let runs = store.study_runs(id).await?;
    Ok(StudyView::of(row, &runs))
}

/// The newest studies.
pub async fn list(store: &JobStore, limit: i64) -> Result<Vec<StudyView>, ApiError> {
    let mut out = Vec::new();
    for row in store.studies(None, limit).await? {
        let runs = store.study_runs(row.id).await?;
        out.push(StudyView::of(row, &runs));
    }
    Ok(out)
}

/// Runs the study driver until `stop` is cancelled: every `every`, advances each running
/// study (errors are logged and retried at the next round).
pub async fn drive(store: JobStore, limits: Limits, every: Duration, stop: tokio_util::sync::CancellationToken) {
    let mut tick = tokio::time::interval(every);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = stop.cancelled() => return,
            _ = tick.tick() => {}
        }
        // Servers sharing a PostgreSQL database drive the studies one at a time.
        if !store.is_study_driver().await {
            continue;
        }
        let running = match store.studies(Some("running"), 1000).await {
            Ok(r) => r,
            Err(e) => {
                eprintln!("sable serve: study driver: {e}");
                continue;
            }
        };
        for row in running {
            if let Err(e) = advance(&store, &limits, &row).await {
                eprintln!("sable serve: study {}: {e}", row.id);
            }
        }
    }
}

/// One round of the driver for one study: measure the runs that ended, add a search's next
/// probe, recompute and store the report, and end the study when its runs are all done.
pub async fn advance(store: &JobStore, limits: &Limits, row: &StudyRow) -> Result<(), ApiError> {
    let mut runs = store.study_runs(row.id).await?;
    // Nothing to do when no run changed since the last report (the study file is not parsed
    // again, which for large scenes is the expensive part of a round).
    if let Some(last) = row.report.as_deref().and_then(|r| serde_json::from_str::<StudyReport>(r).ok()) {
        let same =
            last.points.len() == runs.len() && last.points.iter().zip(&runs).all(|(p, r)| p.state == r.state && p.job_id == r.job_id);
        if same && runs.iter().any(|r| !ended(&r.state)) {
            return Ok(());
        }
    }
    let (spec, study) = match parse_checked_study(&row.spec) {
        Ok(x) => x,
        Err(v) => {
            let why = sable_engine::scene::format_violations(&v);
            store.set_study_report(row.id, "null", "failed", Some(&format!("the stored study cannot be read any more: {why}"))).await?;
            return Ok(());
        }
    };
    // Measure what ended.
    if let Study::Sweep { measure, points, .. } = &study {
        for r in runs.iter_mut().filter(|r| ended(&r.state) && r.measured_done == 0) {
            let (value, note) = if r.state == "succeeded" {
                let measure = points.get(r.idx as usize).and_then(|p| p.measure.as_ref()).unwrap_or(measure);
                match measure_job(store, measure, r.job_id, r.result.as_deref()).await? {
                    Ok(v) => (Some(v), None),
                    Err(e) => (None, Some(e)),
                }
            } else {
                (None, Some(r.error_message.clone().unwrap_or_else(|| format!("the job was {}", r.state))))
            };
            store.set_run_measure(row.id, r.idx, value, note.as_deref()).await?;
            r.measured = value;
            r.measure_note = note;
            r.measured_done = 1;
        }
    }
    let mut done = runs.iter().all(|r| ended(&r.state));
    let mut report = StudyReport {
        measure: String::new(),
        reference: None,
        reference_source: String::new(),
        swept: spec.series.iter().map(|s| (s.label.clone(), s.sweep.iter().map(|w| w.parameter.clone()).collect())).collect(),
        points: runs.iter().map(point_of).collect(),
        limit: None,
        theory: None,
        fit: None,
        fit_note: None,
    };
    match &study {
        Study::Sweep { measure, reference, points } => {
            report.measure = describe_measures(&spec, measure);
            match reference.formula.as_deref().map(sable_engine::study::formula::Formula::parse) {
                Some(Ok(f)) => {
                    report.reference_source = format!("formula {}", reference.formula.as_deref().unwrap_or_default());
                    report.score_each(|p| points.get(p.index).and_then(|pt| f.eval(&pt.vars).ok()));
                }
                Some(Err(e)) => return Err(ApiError::Internal(format!("the stored formula no longer parses: {e}"))),
                None => {
                    let (value, source) = reference_value(store, &spec, reference, measure, &report).await?;
                    report.reference_source = source;
                    report.score(value);
                }
            }
            if let Some(f) = &spec.fit {
                fit_runs(&mut report, f, &runs);
            }
        }
        Study::Search { search, scene } => {
            report.measure = format!("stability of {}", search.parameter);
            report.reference_source = "bisection".into();
            let probes: Vec<Probe> = runs
                .iter()
                .filter(|r| ended(&r.state))
                .filter_map(|r| r.value.map(|value| Probe { value, failure: failure_of(r) }))
                .collect();
            let pending = runs.iter().filter(|r| !ended(&r.state)).count();
            match search.next(&probes, pending) {
                Next::Probe(values) => {
                    let mut fresh = Vec::new();
                    for (k, value) in values.into_iter().enumerate() {
                        let idx = runs.len() as i64 + k as i64;
                        fresh.push(probe_run(store, limits, &row.name, scene, search, idx, value).await?);
                    }
                    store.add_study_runs(row.id, &fresh).await?;
                    done = false;
                }
                Next::Wait => done = false,
                Next::Done(limit) => {
                    report.theory = theory::dem_limit(scene, search).map(|t| Theory { ratio: limit.stable.map(|s| s / t.value), ..t });
                    report.limit = Some(limit);
                }
            }
        }
    }
    let json = serde_json::to_string(&report).map_err(|e| ApiError::Internal(e.to_string()))?;
    store.set_study_report(row.id, &json, if done { "succeeded" } else { "running" }, None).await?;
    Ok(())
}

/// Fits the study's law over the succeeded runs of the series it names (recomputed at every
/// change: a fit takes milliseconds), or says why there is no fit.
fn fit_runs(report: &mut StudyReport, spec: &sable_engine::study::fit::FitSpec, runs: &[RunRow]) {
    let Some(law) = sable_engine::study::fit::law(&spec.law) else {
        report.fit_note = Some(format!("unknown law '{}'", spec.law));
        return;
    };
    let results: Vec<(usize, serde_json::Value)> = runs
        .iter()
        .filter(|r| r.state == "succeeded" && spec.fits(&r.series))
        .filter_map(|r| Some((r.idx as usize, serde_json::from_str(r.result.as_deref()?).ok()?)))
        .collect();
    let runs: Vec<sable_engine::study::fit::RunResult<'_>> =
        results.iter().map(|(index, result)| sable_engine::study::fit::RunResult { index: *index, result }).collect();
    match law.fit(&runs) {
        Ok(f) => report.fit = Some(f),
        Err(e) => report.fit_note = Some(e),
    }
}

/// A failed run's failure mode (a cancelled run counts as another failure).
fn failure_of(r: &RunRow) -> Option<FailureMode> {
    match r.state.as_str() {
        "succeeded" => None,
        "failed" => Some(FailureMode::of(r.error_code.as_deref().unwrap_or_default(), r.error_message.as_deref().unwrap_or_default())),
        _ => Some(FailureMode::Other),
    }
}

fn point_of(r: &RunRow) -> PointReport {
    PointReport {
        index: r.idx as usize,
        series: r.series.clone(),
        label: r.label.clone(),
        value: r.value,
        job_id: r.job_id,
        state: r.state.clone(),
        cost: Cost {
            wall_seconds: r.wall_seconds,
            cpu_seconds: r.cpu_seconds,
            steps: r.steps.max(0) as u64,
            solver_iterations: r.solver_iterations.max(0) as u64,
        },
        measured: r.measured,
        reference: None,
        error: None,
        relative_error: None,
        failure: failure_of(r),
        note: r.measure_note.clone(),
        pareto: false,
    }
}

/// What the study measures: its measure, and each series' own (`BPM: grains.phi where ...`).
fn describe_measures(spec: &StudySpec, measure: &sable_engine::study::MeasureSpec) -> String {
    let own: Vec<String> =
        spec.series.iter().filter_map(|s| s.measure.as_ref().map(|m| format!("{}: {}", s.label, m.describe()))).collect();
    match (own.len(), spec.measure.is_some()) {
        (0, _) => measure.describe(),
        (_, true) => format!("{}; {}", measure.describe(), own.join("; ")),
        (_, false) => own.join("; "),
    }
}

/// The measure of a succeeded job, from its samples and its results (`result`, JSON), or why
/// there is none.
async fn measure_job(
    store: &JobStore,
    measure: &sable_engine::study::MeasureSpec,
    job: i64,
    result: Option<&str>,
) -> Result<Result<f64, String>, ApiError> {
    let samples = store.samples(job, 0, None).await?;
    let result = result.and_then(|t| serde_json::from_str::<serde_json::Value>(t).ok());
    Ok(match measure.evaluate(&samples, result.as_ref()) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("the measure is not finite ({v})")),
        Err(e) => Err(e),
    })
}

/// The reference value (once it can be known) and where it comes from.
async fn reference_value(
    store: &JobStore,
    spec: &StudySpec,
    reference: &ReferenceSpec,
    measure: &sable_engine::study::MeasureSpec,
    report: &StudyReport,
) -> Result<(Option<f64>, String), ApiError> {
    if let Some(v) = reference.value {
        return Ok((Some(v), "value".into()));
    }
    if let (Some(f), true) = (&spec.fit, reference == &ReferenceSpec::default()) {
        return Ok((None, format!("none: the study fits the law {}", f.law)));
    }
    if reference.analytic.is_some() {
        // The restitution coefficient of the scene's first material.
        let e = spec
            .scene
            .get("materials")
            .and_then(|m| m.as_object())
            .and_then(|m| m.values().next())
            .and_then(|m| m.get("restitution"))
            .and_then(|e| e.as_f64());
        return Ok((e, "analytic: the restitution coefficient of the scene's material".into()));
    }
    if let Some(job) = reference.job {
        let row = store.get(job).await?;
        return Ok((measure_job(store, measure, job, row.result.as_deref()).await?.ok(), format!("job {job}")));
    }
    let label = reference.finest.clone().unwrap_or_default();
    Ok(match report.finest(&label) {
        Some(p) if p.label.is_empty() => (p.measured, format!("the finest run of series '{label}' (job {})", p.job_id)),
        Some(p) => (p.measured, format!("the finest run of series '{label}' ({}, job {})", p.label, p.job_id)),
        None => (None, format!("the finest run of series '{label}' (none has succeeded yet)")),
    })
}
