//! `GET /metrics`: Prometheus text exposition, computed from the job store at scrape time (so
//! the numbers survive restarts and agree with the database).

use std::fmt::Write;
use std::sync::atomic::Ordering;

use sable_worker::PoolStats;

use crate::api::ApiError;
use crate::store::{JobState, JobStore};

/// Upper bounds (s) of the job duration histogram.
const BUCKETS: [f64; 10] = [0.1, 0.5, 1.0, 5.0, 10.0, 30.0, 60.0, 300.0, 1800.0, 7200.0];

/// Renders every metric.
pub async fn render(store: &JobStore, pool: Option<&PoolStats>) -> Result<String, ApiError> {
    let mut out = String::new();
    let by_state = store.count_by_state().await?;
    let count = |s: JobState| by_state.iter().find(|(n, _)| n == s.as_str()).map_or(0, |x| x.1);
    let _ = writeln!(out, "# HELP sable_jobs Jobs in the store, by state.\n# TYPE sable_jobs gauge");
    for s in JobState::ALL {
        let _ = writeln!(out, "sable_jobs{{state=\"{}\"}} {}", s.as_str(), count(s));
    }
    let _ = writeln!(out, "# HELP sable_queue_depth Jobs waiting for a worker.\n# TYPE sable_queue_depth gauge");
    let _ = writeln!(out, "sable_queue_depth {}", count(JobState::Queued));
    let durations = store.durations().await?;
    let _ = writeln!(out, "# HELP sable_job_duration_seconds Wall time from first start to end of finished jobs.");
    let _ = writeln!(out, "# TYPE sable_job_duration_seconds histogram");
    for le in BUCKETS {
        let n = durations.iter().filter(|(_, d)| *d <= le).count();
        let _ = writeln!(out, "sable_job_duration_seconds_bucket{{le=\"{le}\"}} {n}");
    }
    let _ = writeln!(out, "sable_job_duration_seconds_bucket{{le=\"+Inf\"}} {}", durations.len());
    let _ = writeln!(out, "sable_job_duration_seconds_sum {}", durations.iter().map(|x| x.1).sum::<f64>());
    let _ = writeln!(out, "sable_job_duration_seconds_count {}", durations.len());
    if let Some(p) = pool {
        let _ = writeln!(out, "# HELP sable_workers Workers of the local pool.\n# TYPE sable_workers gauge");
        let _ = writeln!(out, "sable_workers {}", p.workers.load(Ordering::Relaxed));
        let _ = writeln!(out, "# HELP sable_workers_busy Workers of the local pool running a job.\n# TYPE sable_workers_busy gauge");
        let _ = writeln!(out, "sable_workers_busy {}", p.busy.load(Ordering::Relaxed));
    }
    Ok(out)
}
