//! The browser dashboard, served at `/` (issue 28): static files embedded in the binary
//! (`server/assets/dashboard/`: plain ES modules, no build step; uPlot 1.6.32, MIT, vendored
//! for the charts), which call the REST API like any client. Nothing is fetched from elsewhere.

use axum::extract::Path;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;

/// Every file of the dashboard: path under `/assets/`, content type, bytes.
const FILES: &[(&str, &str, &[u8])] = &[
    ("app.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/app.js")),
    ("api.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/api.js")),
    ("ui.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/ui.js")),
    ("jobs.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/jobs.js")),
    ("job.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/job.js")),
    ("particles.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/particles.js")),
    ("studies.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/studies.js")),
    ("submit.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/submit.js")),
    ("style.css", "text/css; charset=utf-8", include_bytes!("../assets/dashboard/style.css")),
    ("favicon.svg", "image/svg+xml", include_bytes!("../assets/dashboard/favicon.svg")),
    ("vendor/uPlot.iife.min.js", "text/javascript; charset=utf-8", include_bytes!("../assets/dashboard/vendor/uPlot.iife.min.js")),
    ("vendor/uPlot.min.css", "text/css; charset=utf-8", include_bytes!("../assets/dashboard/vendor/uPlot.min.css")),
    ("vendor/uPlot.LICENSE", "text/plain; charset=utf-8", include_bytes!("../assets/dashboard/vendor/uPlot.LICENSE")),
];

const INDEX: &[u8] = include_bytes!("../assets/dashboard/index.html");

/// The dashboard's routes: `/` and `/assets/{path}`.
pub fn router<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new().route("/", get(index)).route("/assets/{*path}", get(asset))
}

fn file(content_type: &'static str, bytes: &'static [u8]) -> Response {
    // Revalidated on every load: a new binary's files replace the old ones at once.
    ([(header::CONTENT_TYPE, content_type), (header::CACHE_CONTROL, "no-cache")], bytes).into_response()
}

async fn index() -> Response {
    file("text/html; charset=utf-8", INDEX)
}

async fn asset(Path(path): Path<String>) -> Response {
    match FILES.iter().find(|(p, _, _)| *p == path) {
        Some((_, content_type, bytes)) => file(content_type, bytes),
        None => (StatusCode::NOT_FOUND, "no such file of the dashboard").into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_module_the_pages_import_is_served() {
        let served: Vec<&str> = FILES.iter().map(|(p, _, _)| *p).collect();
        let index = std::str::from_utf8(INDEX).expect("utf-8");
        let mut wanted: Vec<String> = Vec::new();
        for (_, _, bytes) in FILES.iter().filter(|(p, _, _)| p.ends_with(".js") && !p.starts_with("vendor/")) {
            let text = std::str::from_utf8(bytes).expect("utf-8");
            for part in text.split("from \"./").skip(1) {
                wanted.push(part.split('"').next().unwrap_or_default().to_string());
            }
        }
        for part in index.split("/assets/").skip(1) {
            wanted.push(part.split('"').next().unwrap_or_default().to_string());
        }
        assert!(wanted.len() > 10, "{wanted:?}");
        for w in wanted {
            assert!(served.contains(&w.as_str()), "{w} is imported but not served");
        }
    }
}
