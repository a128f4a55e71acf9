//! Bearer tokens for a shared deployment: users' tokens for the user APIs (REST `/v1/...` and
//! `/metrics`, gRPC `Simulations` and `Studies`), workers' tokens for the gRPC `Workers` API
//! (lease, report, finish), so that only a worker can take and write jobs and a worker's token
//! cannot submit or read. Off by default, which `sable serve` allows only on loopback
//! addresses ([`check_exposure`]).
//!
//! Tokens are read from files, one per line (blank lines and `#` comments skipped; at least
//! [`MIN_TOKEN_CHARS`] printable characters, no spaces), and compared in constant time. A
//! request carries one as `Authorization: Bearer TOKEN` (gRPC: the `authorization` metadata);
//! the browser's event streams and chart images, which cannot set headers, may give it as the
//! `access_token` query parameter of a GET request (RFC 6750 §2.3).
//! `/healthz`, the dashboard's files, gRPC health and reflection stay open. The server reads
//! the files again every few seconds ([`Tokens::reload`]): editing them grants and revokes.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{header, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::Json;

/// The shortest token accepted.
pub const MIN_TOKEN_CHARS: usize = 16;

/// Who a token belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Submits, reads, cancels: the REST API, gRPC `Simulations` and `Studies`.
    User,
    /// Leases, reports and finishes jobs: gRPC `Workers`.
    Worker,
}

/// The tokens a server accepts; a role without tokens is open. Read from files, they are read
/// again by [`Tokens::reload`] (the server does so every few seconds): a line added grants, a
/// line removed revokes, without a restart. A file that has become unusable (unreadable,
/// empty, a bad line) leaves the tokens as they were, so a role that needs tokens never
/// becomes open by a reload.
#[derive(Debug, Default)]
pub struct Tokens {
    sets: std::sync::RwLock<Sets>,
    users_file: Option<PathBuf>,
    workers_file: Option<PathBuf>,
}

/// The tokens of each role.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct Sets {
    users: Vec<String>,
    workers: Vec<String>,
}

impl Sets {
    fn of(&self, role: Role) -> &[String] {
        match role {
            Role::User => &self.users,
            Role::Worker => &self.workers,
        }
    }
}

/// Why a token file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    /// The file cannot be read.
    #[error("{flag}: cannot read {path}: {source}")]
    Read {
        /// The flag that named it.
        flag: &'static str,
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// A line is not a token.
    #[error("{flag}: {path} line {line}: {rule}")]
    Bad {
        /// The flag that named it.
        flag: &'static str,
        /// The file.
        path: String,
        /// Line number, from 1.
        line: usize,
        /// The rule broken.
        rule: String,
    },
    /// The file holds no token.
    #[error("{flag}: {path} holds no token")]
    Empty {
        /// The flag that named it.
        flag: &'static str,
        /// The file.
        path: String,
    },
    /// The same token is given to users and workers.
    #[error("a token is both a user's and a worker's: give each role its own")]
    Shared,
}

impl Tokens {
    /// Tokens of both roles, as given (no check: tests and embedding).
    pub fn new(users: Vec<String>, workers: Vec<String>) -> Self {
        Self { sets: std::sync::RwLock::new(Sets { users, workers }), users_file: None, workers_file: None }
    }

    /// Reads the users' and workers' token files (either may be absent: that role is open).
    pub fn from_files(users: Option<&Path>, workers: Option<&Path>) -> Result<Self, TokenError> {
        let (users_file, workers_file) = (users.map(Path::to_path_buf), workers.map(Path::to_path_buf));
        let sets = read_both(users_file.as_deref(), workers_file.as_deref())?;
        Ok(Self { sets: std::sync::RwLock::new(sets), users_file, workers_file })
    }

    /// Reads the token files again, if the tokens came from files. `Ok(true)`: the tokens
    /// changed; `Err`: a file cannot be used, and the tokens stay as they were.
    pub fn reload(&self) -> Result<bool, TokenError> {
        if self.users_file.is_none() && self.workers_file.is_none() {
            return Ok(false);
        }
        let fresh = read_both(self.users_file.as_deref(), self.workers_file.as_deref())?;
        let mut sets = self.sets.write().unwrap_or_else(std::sync::PoisonError::into_inner);
        if *sets == fresh {
            return Ok(false);
        }
        *sets = fresh;
        Ok(true)
    }

    /// How many tokens each role has: (users, workers).
    pub fn counts(&self) -> (usize, usize) {
        let sets = self.sets();
        (sets.users.len(), sets.workers.len())
    }

    fn sets(&self) -> std::sync::RwLockReadGuard<'_, Sets> {
        // The lock guards plain data that a panic cannot leave half-written.
        self.sets.read().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether requests of `role` need a token.
    pub fn required(&self, role: Role) -> bool {
        !self.sets().of(role).is_empty()
    }

    /// Whether `given` (the bearer token of a request, if any) lets it act as `role`.
    /// `Err` says why not, for the answer.
    pub fn check(&self, role: Role, given: Option<&str>) -> Result<(), Refusal> {
        let sets = self.sets();
        let accepted = sets.of(role);
        if accepted.is_empty() {
            return Ok(());
        }
        let Some(token) = given else {
            return Err(Refusal::Missing(role));
        };
        if accepted.iter().any(|t| same(t.as_bytes(), token.as_bytes())) {
            return Ok(());
        }
        let other = match role {
            Role::User => Role::Worker,
            Role::Worker => Role::User,
        };
        if sets.of(other).iter().any(|t| same(t.as_bytes(), token.as_bytes())) {
            return Err(Refusal::WrongRole(role));
        }
        Err(Refusal::Unknown)
    }
}

/// Why a request was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// No token: 401 / UNAUTHENTICATED.
    Missing(Role),
    /// A token of no one: 401 / UNAUTHENTICATED.
    Unknown,
    /// A token of the other role: 403 / PERMISSION_DENIED.
    WrongRole(Role),
}

impl Refusal {
    /// The message of the answer.
    pub fn message(self) -> String {
        match self {
            Self::Missing(Role::User) => "this server needs a user's token: send Authorization: Bearer TOKEN".into(),
            Self::Missing(Role::Worker) => {
                "this server needs a worker's token to lease jobs: sable worker --token (or SABLE_WORKER_TOKEN)".into()
            }
            Self::Unknown => "the token is not one this server accepts".into(),
            Self::WrongRole(Role::User) => "a worker's token cannot use the user API: give a user's token".into(),
            Self::WrongRole(Role::Worker) => "a user's token cannot lease, report or finish jobs: give a worker's token".into(),
        }
    }

    /// As a gRPC status.
    pub fn status(self) -> tonic::Status {
        match self {
            Self::WrongRole(_) => tonic::Status::permission_denied(self.message()),
            _ => tonic::Status::unauthenticated(self.message()),
        }
    }
}

/// Equal in time independent of where they differ (the length is not secret).
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

/// Both roles' token files (an absent one: that role is open).
fn read_both(users: Option<&Path>, workers: Option<&Path>) -> Result<Sets, TokenError> {
    let users = users.map(|p| read("--user-tokens", p)).transpose()?.unwrap_or_default();
    let workers = workers.map(|p| read("--worker-tokens", p)).transpose()?.unwrap_or_default();
    if users.iter().any(|u| workers.contains(u)) {
        return Err(TokenError::Shared);
    }
    Ok(Sets { users, workers })
}

fn read(flag: &'static str, path: &Path) -> Result<Vec<String>, TokenError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| TokenError::Read { flag, path: shown.clone(), source })?;
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let bad = |rule: String| TokenError::Bad { flag, path: shown.clone(), line: k + 1, rule };
        if t.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(bad("a token is one word (no spaces)".into()));
        }
        if t.chars().count() < MIN_TOKEN_CHARS {
            return Err(bad(format!("a token has at least {MIN_TOKEN_CHARS} characters (e.g. openssl rand -hex 32)")));
        }
        out.push(t.to_string());
    }
    if out.is_empty() {
        return Err(TokenError::Empty { flag, path: shown });
    }
    Ok(out)
}

/// Refuses to serve without tokens on an address other machines can reach, unless `open` (the
/// operator's `--no-auth`): `Err` names the address and what to do.
pub fn check_exposure(tokens: &Tokens, addrs: &[SocketAddr], open: bool) -> Result<(), String> {
    if open {
        return Ok(());
    }
    for a in addrs {
        if a.ip().is_loopback() {
            continue;
        }
        for (role, flag) in [(Role::User, "--user-tokens"), (Role::Worker, "--worker-tokens")] {
            if !tokens.required(role) {
                return Err(format!(
                    "{a} is reachable from other machines and {flag} is not given: give both token files, or --no-auth to \
                     serve without authentication"
                ));
            }
        }
    }
    Ok(())
}

/// The bearer token of an HTTP request: the `Authorization` header, or on a GET request the
/// `access_token` query parameter.
fn http_token(req: &Request) -> Option<String> {
    if let Some(h) = req.headers().get(header::AUTHORIZATION) {
        return h.to_str().ok().and_then(|v| v.strip_prefix("Bearer ")).map(|t| t.trim().to_string());
    }
    if req.method() == Method::GET {
        let q = req.uri().query()?;
        return url::form_urlencoded::parse(q.as_bytes()).find(|(k, _)| k == "access_token").map(|(_, v)| v.into_owned());
    }
    None
}

/// The REST layer: routes under `/v1/` and `/metrics` need a user's token (when users have
/// tokens); the rest (health, the dashboard's files) is open.
pub async fn http_layer(State(tokens): State<Arc<Tokens>>, mut req: Request, next: Next) -> Response {
    let path = req.uri().path();
    let guarded = path.starts_with("/v1/") || path == "/metrics";
    if guarded {
        let given = http_token(&req);
        if let Err(r) = tokens.check(Role::User, given.as_deref()) {
            let status = match r {
                Refusal::WrongRole(_) => StatusCode::FORBIDDEN,
                _ => StatusCode::UNAUTHORIZED,
            };
            let code = match r {
                Refusal::WrongRole(_) => "permission_denied",
                _ => "unauthenticated",
            };
            let body = serde_json::json!({"code": code, "message": r.message(), "details": []});
            return (status, [(header::WWW_AUTHENTICATE, "Bearer")], Json(body)).into_response();
        }
        req.extensions_mut().insert(Admitted { tokens: tokens.clone(), role: Role::User, token: given });
    }
    without_access_token(&mut req);
    next.run(req).await
}

/// Removes the `access_token` query parameter (the routes' own parameters are checked
/// strictly, and the token has no business further in).
fn without_access_token(req: &mut Request) {
    let Some(q) = req.uri().query() else { return };
    if !url::form_urlencoded::parse(q.as_bytes()).any(|(k, _)| k == "access_token") {
        return;
    }
    let rest: String = url::form_urlencoded::Serializer::new(String::new())
        .extend_pairs(url::form_urlencoded::parse(q.as_bytes()).filter(|(k, _)| k != "access_token"))
        .finish();
    let path = req.uri().path();
    let pq = if rest.is_empty() { path.to_string() } else { format!("{path}?{rest}") };
    let mut parts = req.uri().clone().into_parts();
    if let Ok(pq) = pq.parse() {
        parts.path_and_query = Some(pq);
        if let Ok(uri) = axum::http::Uri::from_parts(parts) {
            *req.uri_mut() = uri;
        }
    }
}

/// The token a request was admitted with, kept with the request so that a long-lived answer
/// (an event stream) can check that it is still valid.
#[derive(Clone)]
pub struct Admitted {
    tokens: Arc<Tokens>,
    role: Role,
    token: Option<String>,
}

impl std::fmt::Debug for Admitted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never the token itself.
        f.debug_struct("Admitted").field("role", &self.role).finish_non_exhaustive()
    }
}

impl Admitted {
    /// Whether the token is still valid for its role, as a closure an event stream calls.
    pub fn checker(&self) -> crate::watch::StillAdmitted {
        let me = self.clone();
        Arc::new(move || me.tokens.check(me.role, me.token.as_deref()).is_ok())
    }
}

/// A gRPC interceptor admitting requests of `role`.
#[derive(Debug, Clone)]
pub struct GrpcGuard {
    tokens: Arc<Tokens>,
    role: Role,
}

impl GrpcGuard {
    /// Admits `role`'s requests with `tokens`.
    pub fn new(tokens: Arc<Tokens>, role: Role) -> Self {
        Self { tokens, role }
    }
}

impl tonic::service::Interceptor for GrpcGuard {
    fn call(&mut self, req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        let given =
            req.metadata().get("authorization").and_then(|v| v.to_str().ok()).and_then(|v| v.strip_prefix("Bearer ")).map(str::trim);
        self.tokens.check(self.role, given).map_err(Refusal::status)?;
        let admitted = Admitted { tokens: self.tokens.clone(), role: self.role, token: given.map(str::to_string) };
        let mut req = req;
        req.extensions_mut().insert(admitted);
        Ok(req)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_are_kept_apart() {
        let t = Tokens::new(vec!["u".repeat(20)], vec!["w".repeat(20)]);
        let (u, w) = ("u".repeat(20), "w".repeat(20));
        assert_eq!(t.check(Role::User, Some(&u)), Ok(()));
        assert_eq!(t.check(Role::Worker, Some(&w)), Ok(()));
        assert_eq!(t.check(Role::Worker, Some(&u)), Err(Refusal::WrongRole(Role::Worker)));
        assert_eq!(t.check(Role::User, Some(&w)), Err(Refusal::WrongRole(Role::User)));
        assert_eq!(t.check(Role::User, None), Err(Refusal::Missing(Role::User)));
        assert_eq!(t.check(Role::User, Some("x")), Err(Refusal::Unknown));
        let open = Tokens::default();
        assert_eq!(open.check(Role::Worker, None), Ok(()));
        assert!(same(b"abc", b"abc") && !same(b"abc", b"abd") && !same(b"abc", b"ab"));
    }

    #[test]
    fn token_files_are_checked_line_by_line() {
        let dir = tempfile::tempdir().expect("dir");
        let good = dir.path().join("good");
        std::fs::write(&good, "# users\n\n0123456789abcdef0123\n  fedcba9876543210fedc  \n").expect("write");
        let t = Tokens::from_files(Some(&good), None).expect("read");
        assert!(t.required(Role::User) && !t.required(Role::Worker));
        let short = dir.path().join("short");
        std::fs::write(&short, "0123456789abcdef0123\ntooshort\n").expect("write");
        let e = Tokens::from_files(None, Some(&short)).expect_err("short").to_string();
        assert!(e.contains("--worker-tokens") && e.contains("line 2") && e.contains("16 characters"), "{e}");
        let empty = dir.path().join("empty");
        std::fs::write(&empty, "# nothing\n").expect("write");
        assert!(Tokens::from_files(Some(&empty), None).expect_err("empty").to_string().contains("holds no token"));
        assert!(matches!(Tokens::from_files(Some(&good), Some(&good)), Err(TokenError::Shared)));
        assert!(Tokens::from_files(Some(&dir.path().join("missing")), None).expect_err("missing").to_string().contains("cannot read"));
    }

    #[test]
    fn serving_beyond_loopback_needs_both_token_files() {
        let lo: SocketAddr = "127.0.0.1:8080".parse().expect("addr");
        let any: SocketAddr = "0.0.0.0:8080".parse().expect("addr");
        let none = Tokens::default();
        assert!(check_exposure(&none, &[lo], false).is_ok());
        let e = check_exposure(&none, &[lo, any], false).expect_err("exposed");
        assert!(e.contains("0.0.0.0:8080") && e.contains("--user-tokens") && e.contains("--no-auth"), "{e}");
        assert!(check_exposure(&none, &[any], true).is_ok());
        let users_only = Tokens::new(vec!["u".repeat(20)], Vec::new());
        assert!(check_exposure(&users_only, &[any], false).expect_err("workers open").contains("--worker-tokens"));
        let both = Tokens::new(vec!["u".repeat(20)], vec!["w".repeat(20)]);
        assert!(check_exposure(&both, &[any], false).is_ok());
    }
}
