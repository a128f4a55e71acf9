//! The REST API's routes: each path to its handler ([`crate::rest`] for jobs and the service,
//! [`crate::rest_studies`] for studies and charts, [`crate::openapi`] for the document) and the
//! dashboard's pages.

use axum::routing::{get, post};
use axum::Router;

use crate::api::ApiError;
use crate::rest::{
    advice, events, final_state, get_job, healthz, job_action, list, metrics, samples, snapshot_file, snapshots, submit, AppState,
};

/// The router of the REST API.
pub fn router(state: AppState) -> Router {
    let limit = state.limits.max_body_bytes;
    Router::new()
        .route("/v1/jobs", post(submit).get(list))
        .route("/v1/jobs/{id}", get(get_job).post(job_action))
        .route("/v1/jobs/{id}/samples", get(samples))
        .route("/v1/jobs/{id}/events", get(events))
        .route("/v1/jobs/{id}/snapshots", get(snapshots))
        .route("/v1/jobs/{id}/snapshots/{index}/{part}", get(snapshot_file))
        .route("/v1/jobs/{id}/state", get(final_state))
        .route("/v1/jobs/{id}/chart.svg", get(crate::rest_studies::job_chart))
        .route("/v1/jobs/{id}/chart.png", get(crate::rest_studies::job_chart_png))
        .route("/v1/studies", post(crate::rest_studies::create).get(crate::rest_studies::list))
        .route("/v1/studies/{id}", get(crate::rest_studies::get))
        .route("/v1/studies/{id}/chart.svg", get(crate::rest_studies::chart))
        .route("/v1/studies/{id}/chart.png", get(crate::rest_studies::chart_png))
        .route("/v1/advice", post(advice))
        .route("/v1/openapi.json", get(crate::openapi::serve))
        .route("/healthz", get(healthz))
        .route("/metrics", get(metrics))
        .merge(crate::dashboard::router())
        .fallback(not_found)
        .layer(axum::extract::DefaultBodyLimit::max(limit))
        .with_state(state)
}

async fn not_found() -> ApiError {
    ApiError::NotFound("no such route; see GET /v1/openapi.json".into())
}
