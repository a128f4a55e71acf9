//! The REST routes of studies and charts: `POST /v1/studies`, `GET /v1/studies[/{id}]`,
//! `GET /v1/studies/{id}/chart.svg` (and `.png`), `GET /v1/jobs/{id}/chart.svg` (and `.png`).

use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;

use crate::api::{self, ApiError};
use crate::charts::Format;
use crate::rest::{json_body, parse_id, positive_id, query, AppState};
use crate::studies::{self, StudyView};

fn study_id(s: &str) -> Result<i64, ApiError> {
    positive_id(s, "study")
}

fn image(format: Format, bytes: Vec<u8>) -> Response {
    ([(header::CONTENT_TYPE, format.content_type()), (header::CACHE_CONTROL, "no-cache")], bytes).into_response()
}

/// `POST /v1/studies`.
#[utoipa::path(
    post,
    path = "/v1/studies",
    tag = "studies",
    summary = "Check a study (docs/studies.md) and queue its runs",
    request_body(content = Object, description = "A study file: {scene, series | search, measure, reference}"),
    responses(
        (status = 201, description = "Accepted; its runs are queued", body = StudyView),
        (status = 400, description = "The body is not JSON", body = api::ErrorBody),
        (status = 413, description = "The body is larger than the server's limit", body = api::ErrorBody),
        (status = 422, description = "The study or one of its runs breaks a rule; every violation is in details", body = api::ErrorBody),
    )
)]
pub(crate) async fn create(State(st): State<AppState>, body: Result<Bytes, BytesRejection>) -> Result<Response, ApiError> {
    let value = json_body(&st, body)?;
    if !value.is_object() {
        return Err(ApiError::malformed("", "the body must be a study (a JSON object)"));
    }
    let view = studies::create(&st.store, &st.limits, &value).await?;
    Ok((StatusCode::CREATED, [(header::LOCATION, format!("/v1/studies/{}", view.id))], Json(view)).into_response())
}

/// `GET /v1/studies`.
#[utoipa::path(get, path = "/v1/studies", tag = "studies", summary = "The newest studies (at most 100)",
    responses((status = 200, description = "Newest first", body = [StudyView])))]
pub(crate) async fn list(State(st): State<AppState>) -> Result<Json<Vec<StudyView>>, ApiError> {
    Ok(Json(studies::list(&st.store, 100).await?))
}

/// `GET /v1/studies/{id}`.
#[utoipa::path(get, path = "/v1/studies/{id}", tag = "studies", summary = "A study: its state and report",
    params(("id" = i64, Path, description = "Study id")),
    responses(
        (status = 200, description = "The study", body = StudyView),
        (status = 400, description = "The id cannot be read", body = api::ErrorBody),
        (status = 404, description = "No such study", body = api::ErrorBody),
    ))]
pub(crate) async fn get(State(st): State<AppState>, Path(id): Path<String>) -> Result<Json<StudyView>, ApiError> {
    Ok(Json(studies::get(&st.store, study_id(&id)?).await?))
}

/// `GET /v1/studies/{id}/chart.svg`.
#[utoipa::path(get, path = "/v1/studies/{id}/chart.svg", tag = "studies",
    summary = "Error against cost (log-log, one series per label, Pareto front, failed runs), or a search's probes against its theory",
    params(("id" = i64, Path, description = "Study id")),
    responses(
        (status = 200, description = "SVG", content_type = "image/svg+xml"),
        (status = 404, description = "No such study", body = api::ErrorBody),
        (status = 409, description = "No report yet", body = api::ErrorBody),
    ))]
pub(crate) async fn chart(State(st): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    study_chart(&st, &id, Format::Svg).await
}

/// `GET /v1/studies/{id}/chart.png`.
#[utoipa::path(get, path = "/v1/studies/{id}/chart.png", tag = "studies", summary = "The study's chart as PNG",
    params(("id" = i64, Path, description = "Study id")),
    responses(
        (status = 200, description = "PNG", content_type = "image/png"),
        (status = 404, description = "No such study", body = api::ErrorBody),
        (status = 409, description = "No report yet", body = api::ErrorBody),
    ))]
pub(crate) async fn chart_png(State(st): State<AppState>, Path(id): Path<String>) -> Result<Response, ApiError> {
    study_chart(&st, &id, Format::Png).await
}

async fn study_chart(st: &AppState, id: &str, format: Format) -> Result<Response, ApiError> {
    let view = studies::get(&st.store, study_id(id)?).await?;
    let bytes = studies::chart(&view, format)?;
    Ok(image(format, bytes))
}

/// Query of `GET /v1/jobs/{id}/chart.svg`.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub(crate) struct ChartParams {
    /// Sample field on the vertical axis, by path (`zeta`, `mu`, `p`, `phi`, `stress.xy`). Default `zeta`.
    /// Or one path per job, comma-separated, in the jobs' order (this one, then `with`): models
    /// whose samples name a quantity differently (`grains.phi,phi`).
    y: Option<String>,
    /// `time` (default), `step`, `strain` (the deviatoric strain of the stage) or a sample path.
    x: Option<String>,
    /// Units of the horizontal axis, one positive number per job in the jobs' order: each job's
    /// x is divided by its own (the wall stress over each model's characteristic stress).
    x_unit: Option<String>,
    /// Other jobs drawn on the same axes, comma-separated ids.
    with: Option<String>,
    /// Only the samples of this stage of the experiment. Default: every sample, or the last
    /// stage's when `x` is `strain` (strains restart at each stage).
    stage: Option<String>,
}

/// `GET /v1/jobs/{id}/chart.svg`.
#[utoipa::path(get, path = "/v1/jobs/{id}/chart.svg", tag = "jobs", summary = "A sample field against time or strain, for one or several jobs",
    params(("id" = i64, Path, description = "Job id"), ChartParams),
    responses(
        (status = 200, description = "SVG", content_type = "image/svg+xml"),
        (status = 404, description = "No such job", body = api::ErrorBody),
        (status = 422, description = "A field is not in the samples", body = api::ErrorBody),
    ))]
pub(crate) async fn job_chart(
    State(st): State<AppState>,
    Path(id): Path<String>,
    q: Result<Query<ChartParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    samples_chart(&st, &id, q, Format::Svg).await
}

/// `GET /v1/jobs/{id}/chart.png`.
#[utoipa::path(get, path = "/v1/jobs/{id}/chart.png", tag = "jobs", summary = "The same chart as PNG",
    params(("id" = i64, Path, description = "Job id"), ChartParams),
    responses(
        (status = 200, description = "PNG", content_type = "image/png"),
        (status = 404, description = "No such job", body = api::ErrorBody),
        (status = 422, description = "A field is not in the samples", body = api::ErrorBody),
    ))]
pub(crate) async fn job_chart_png(
    State(st): State<AppState>,
    Path(id): Path<String>,
    q: Result<Query<ChartParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    samples_chart(&st, &id, q, Format::Png).await
}

/// A job's name as a legend: a study's run by its series and values (what follows the study's
/// name), any other name cut to 60 characters.
fn legend_name(name: &str) -> String {
    let short = name.rsplit_once(" · ").map_or(name, |(_, run)| run);
    match short.char_indices().nth(60) {
        Some((cut, _)) => format!("{}…", &short[..cut]),
        None => short.to_string(),
    }
}

async fn samples_chart(
    st: &AppState,
    id: &str,
    q: Result<Query<ChartParams>, QueryRejection>,
    format: Format,
) -> Result<Response, ApiError> {
    let first = parse_id(id)?;
    let p = query(q)?;
    let y = p.y.unwrap_or_else(|| "zeta".into());
    let x = p.x.unwrap_or_else(|| "time".into());
    let mut ids = vec![first];
    for part in p.with.iter().flat_map(|w| w.split(',')).filter(|s| !s.trim().is_empty()) {
        let id = part
            .trim()
            .parse::<i64>()
            .ok()
            .filter(|&i| i > 0)
            .ok_or_else(|| ApiError::invalid("with", format!("must list job ids, got '{part}'")))?;
        ids.push(id);
    }
    if ids.len() > 12 {
        return Err(ApiError::invalid("with", "at most 11 other jobs"));
    }
    let x_path = if x == "strain" { "strain.deviatoric".to_string() } else { x.clone() };
    let ys: Vec<String> = y.split(',').map(|s| s.trim().to_string()).collect();
    if ys.len() != 1 && ys.len() != ids.len() {
        return Err(ApiError::invalid("y", format!("give one path, or one per job ({}), got {}", ids.len(), ys.len())));
    }
    let units: Vec<f64> = match &p.x_unit {
        None => vec![1.0; ids.len()],
        Some(text) => {
            let units: Vec<f64> = text
                .split(',')
                .map(|part| part.trim().parse::<f64>().ok().filter(|u| u.is_finite() && *u > 0.0))
                .collect::<Option<_>>()
                .ok_or_else(|| ApiError::invalid("x_unit", format!("must list positive numbers, got '{text}'")))?;
            if units.len() != ids.len() {
                return Err(ApiError::invalid("x_unit", format!("give one unit per job ({}), got {}", ids.len(), units.len())));
            }
            units
        }
    };
    let mut series = Vec::new();
    for (k, id) in ids.into_iter().enumerate() {
        let y = &ys[if ys.len() == 1 { 0 } else { k }];
        let job = st.store.get(id).await?;
        let samples = api::samples(&st.store, id, 0, None, Some(2000), None).await?.samples;
        // Strains restart at every stage: by default a strain axis shows the last stage.
        let stage = p.stage.clone().or_else(|| if x == "strain" { samples.iter().rev().find_map(|s| s.stage.clone()) } else { None });
        let samples: Vec<_> = samples.into_iter().filter(|s| stage.is_none() || s.stage == stage).collect();
        if let (Some(st), true) = (&p.stage, samples.is_empty()) {
            return Err(ApiError::invalid("stage", format!("job {id} has no sample of stage '{st}'")));
        }
        let (mut pts, mut has_y) = (Vec::with_capacity(samples.len()), false);
        for s in &samples {
            let doc = serde_json::to_value(s).map_err(|e| ApiError::Internal(e.to_string()))?;
            let get = |path: &str| sable_engine::study::paths::get(&doc, path).and_then(|v| v.as_f64());
            let (a, b) = (get(&x_path), get(y));
            has_y |= b.is_some();
            if let (Some(a), Some(b)) = (a, b) {
                pts.push((a / units[k], b));
            }
        }
        if pts.is_empty() && !samples.is_empty() {
            let field = if has_y { "x" } else { "y" };
            return Err(ApiError::invalid(field, format!("job {id}'s samples have no number at '{y}' against '{x}'")));
        }
        let scaled = if p.x_unit.is_some() { format!(", x over {:e}", units[k]) } else { String::new() };
        let field = if ys.len() > 1 { format!(", {y}") } else { String::new() };
        series.push((format!("job {id}{field}{scaled}: {}", legend_name(&job.name)), pts));
    }
    let title = format!("{} against {x}{}", ys.join(" | "), if p.x_unit.is_some() { " over each job's unit" } else { "" });
    let unit = |f: &str| match f {
        "time" => "time, s".to_string(),
        "strain" => "deviatoric strain of the stage".to_string(),
        "p" | "q" => format!("{f}, Pa"),
        f if f.starts_with("stress.") => format!("{f}, Pa"),
        "kinetic_energy" | "elastic_energy" => format!("{f}, J"),
        other => other.to_string(),
    };
    let x_desc = if p.x_unit.is_some() { format!("{x} / unit of the job") } else { unit(&x) };
    let y_desc = if ys.len() > 1 { ys.join(" | ") } else { unit(&y) };
    Ok(image(format, crate::charts::lines(&title, &x_desc, &y_desc, &series, format).map_err(ApiError::Internal)?))
}
