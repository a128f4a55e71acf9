//! Where the job store lives: an SQLite file (the default, for one machine) or a PostgreSQL
//! database shared by several servers and their workers. Both are reached through sqlx's `Any`
//! driver, so every query of the store is written once; the few places where the two dialects
//! differ (how a write transaction starts, row locks) are the methods of [`Backend`].
//!
//! SQL is written in the form both accept: `$1`-style parameters, `RETURNING`, `ON CONFLICT`,
//! `CASE` in place of SQLite's two-argument `MAX`, and `CAST(.. AS DOUBLE PRECISION)` where a
//! division must give a float on PostgreSQL.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::Duration;

use sqlx::any::{AnyConnectOptions, AnyPoolOptions};
use sqlx::sqlite::SqliteConnectOptions;
use sqlx::{AnyPool, ConnectOptions, Executor};

use super::StoreError;

/// The migrations of migrations/sqlite, embedded at build time.
pub static SQLITE_MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../migrations/sqlite");

/// The migrations of migrations/postgres (the same versions, in PostgreSQL's types).
pub static POSTGRES_MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("../migrations/postgres");

/// The database kind a store runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// One SQLite file in WAL mode: one writer, one server.
    Sqlite,
    /// A PostgreSQL database: any number of servers and workers.
    Postgres,
}

impl Backend {
    /// The statement that opens a write transaction. SQLite's `BEGIN IMMEDIATE` takes the
    /// write lock at once, so a read-then-write never fails with SQLITE_BUSY; PostgreSQL
    /// serialises writers on the rows they lock ([`Backend::lock`]).
    pub(super) fn begin_write(self) -> &'static str {
        match self {
            Self::Sqlite => "BEGIN IMMEDIATE",
            Self::Postgres => "BEGIN",
        }
    }

    /// The statement that opens a read transaction seeing one snapshot for all its reads
    /// (SQLite's read transactions always do; PostgreSQL's default, READ COMMITTED, does not).
    pub(super) fn begin_read(self) -> &'static str {
        match self {
            Self::Sqlite => "BEGIN",
            Self::Postgres => "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY",
        }
    }

    /// The clause a `SELECT` of rows that the transaction goes on to change ends with:
    /// PostgreSQL locks them against a concurrent writer (another server) until the commit;
    /// SQLite has locked the whole database already.
    pub(super) fn lock(self) -> &'static str {
        match self {
            Self::Sqlite => "",
            Self::Postgres => " FOR UPDATE",
        }
    }

    /// As [`Backend::lock`], passing over rows another transaction holds (the queue: two
    /// servers leasing at once take two different jobs instead of waiting for each other).
    pub(super) fn lock_skip(self) -> &'static str {
        match self {
            Self::Sqlite => "",
            Self::Postgres => " FOR UPDATE SKIP LOCKED",
        }
    }

    /// Name as in `--db`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sqlite => "sqlite",
            Self::Postgres => "postgres",
        }
    }
}

/// Where a store is (`sable serve --db`): `sqlite:PATH` or a bare path for an SQLite file,
/// `postgres://user:password@host:port/database` for PostgreSQL.
#[derive(Clone, PartialEq, Eq)]
pub enum DbLocation {
    /// An SQLite file, created if missing.
    Sqlite(PathBuf),
    /// A PostgreSQL connection URL (`postgres://` or `postgresql://`).
    Postgres(String),
}

impl DbLocation {
    /// The back-end this location is on.
    pub fn backend(&self) -> Backend {
        match self {
            Self::Sqlite(_) => Backend::Sqlite,
            Self::Postgres(_) => Backend::Postgres,
        }
    }
}

/// Why a `--db` value is not a location.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--db: {0}")]
pub struct BadLocation(String);

impl FromStr for DbLocation {
    type Err = BadLocation;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s.is_empty() {
            return Err(BadLocation("must not be empty: give sqlite:PATH or postgres://HOST/DATABASE".into()));
        }
        if s.starts_with("postgres://") || s.starts_with("postgresql://") {
            let url = url::Url::parse(s).map_err(|e| BadLocation(format!("not a valid PostgreSQL URL ({e})")))?;
            if url.host_str().is_none_or(str::is_empty) && !url.query_pairs().any(|(k, _)| k == "host") {
                return Err(BadLocation("a PostgreSQL URL needs a host (postgres://HOST:PORT/DATABASE)".into()));
            }
            return Ok(Self::Postgres(s.to_string()));
        }
        if let Some((scheme, _)) = s.split_once("://") {
            if scheme != "sqlite" {
                return Err(BadLocation(format!("unknown database kind '{scheme}': give sqlite:PATH or postgres://HOST/DATABASE")));
            }
        }
        let path = s.strip_prefix("sqlite://").or_else(|| s.strip_prefix("sqlite:")).unwrap_or(s);
        if path.is_empty() || path.contains('?') {
            return Err(BadLocation(format!("'{s}': an SQLite location is a file path (sqlite:PATH), without options")));
        }
        Ok(Self::Sqlite(PathBuf::from(path)))
    }
}

impl fmt::Display for DbLocation {
    /// The location with any password replaced by `***` (for logs and error messages).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sqlite(p) => write!(f, "sqlite:{}", p.display()),
            Self::Postgres(u) => match url::Url::parse(u) {
                Ok(mut url) if url.password().is_some() => {
                    let _ = url.set_password(Some("***"));
                    write!(f, "{url}")
                }
                _ => write!(f, "{u}"),
            },
        }
    }
}

impl fmt::Debug for DbLocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DbLocation({self})")
    }
}

/// The pools of an open store: one that writes and one that reads (for PostgreSQL the same).
pub(super) struct Pools {
    pub writer: AnyPool,
    pub reader: AnyPool,
}

/// Whether a pooled connection may serve another request: not if it is still inside a
/// transaction. That happens when a write fails in a way the database answers by rolling back
/// on its own (SQLite on a full disk, SQLITE_FULL): sqlx's rollback on drop then fails too, its
/// count of open transactions never returns to zero, and every later `BEGIN` on that connection
/// would be refused ("begin_with at non-zero transaction depth") until the process restarts.
/// The pool runs this after the connection's release has flushed the rollback, so a connection
/// whose rollback went through is kept; a poisoned one is closed and a fresh one opened.
fn usable(conn: &mut sqlx::AnyConnection) -> bool {
    use sqlx::Connection;
    let clean = !conn.is_in_transaction();
    if !clean {
        eprintln!("sable store: a connection was left inside a failed transaction; it is closed and a new one opened");
    }
    clean
}

/// Connects to `at`, applies the migrations, and returns the pools.
pub(super) async fn connect(at: &DbLocation) -> Result<Pools, StoreError> {
    sqlx::any::install_default_drivers();
    match at {
        DbLocation::Sqlite(path) => {
            let url = SqliteConnectOptions::new().filename(path).create_if_missing(true).to_url_lossy();
            let options = AnyConnectOptions::from_url(&url)?;
            // All writes go through one connection (SQLite has one writer).
            let writer = AnyPoolOptions::new()
                .max_connections(1)
                .before_acquire(|conn, _| Box::pin(async move { Ok(usable(conn)) }))
                .after_connect(|conn, _| {
                    Box::pin(async move {
                        conn.execute(
                            "PRAGMA journal_mode = WAL; PRAGMA synchronous = NORMAL; PRAGMA busy_timeout = 30000; \
                             PRAGMA foreign_keys = ON;",
                        )
                        .await?;
                        Ok(())
                    })
                })
                .connect_with(options)
                .await?;
            SQLITE_MIGRATOR.run(&writer).await?;
            let url = SqliteConnectOptions::new().filename(path).read_only(true).to_url_lossy();
            let reader = AnyPoolOptions::new()
                .max_connections(8)
                .after_connect(|conn, _| {
                    Box::pin(async move {
                        conn.execute("PRAGMA busy_timeout = 30000;").await?;
                        Ok(())
                    })
                })
                .connect_with(AnyConnectOptions::from_url(&url)?)
                .await?;
            Ok(Pools { writer, reader })
        }
        DbLocation::Postgres(url) => {
            let options = AnyConnectOptions::from_str(url)?;
            // While PostgreSQL is unreachable a request fails after the acquire timeout (a
            // submission is refused with 503 rather than left hanging: it was 10 s); the pool
            // reconnects when it is back.
            let pool = AnyPoolOptions::new()
                .max_connections(16)
                .acquire_timeout(Duration::from_secs(3))
                .before_acquire(|conn, _| Box::pin(async move { Ok(usable(conn)) }))
                .connect_with(options)
                .await?;
            // sqlx's PostgreSQL migrator holds an advisory lock: servers starting together
            // apply each migration once.
            POSTGRES_MIGRATOR.run(&pool).await?;
            Ok(Pools { writer: pool.clone(), reader: pool })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations_parse_and_hide_passwords() {
        assert_eq!("sable.db".parse::<DbLocation>(), Ok(DbLocation::Sqlite("sable.db".into())));
        assert_eq!("sqlite:./a b.db".parse::<DbLocation>(), Ok(DbLocation::Sqlite("./a b.db".into())));
        assert_eq!("sqlite:///tmp/x.db".parse::<DbLocation>(), Ok(DbLocation::Sqlite("/tmp/x.db".into())));
        let pg: DbLocation = "postgres://sable:secret@db.lab:5433/sable".parse().expect("postgres");
        assert_eq!(pg.backend(), Backend::Postgres);
        assert_eq!(pg.to_string(), "postgres://sable:***@db.lab:5433/sable");
        assert!(!format!("{pg:?}").contains("secret"));
        for bad in ["", "mysql://x/y", "sqlite:", "sqlite:x.db?mode=ro", "postgres://", "postgres://:5432/x"] {
            assert!(bad.parse::<DbLocation>().is_err(), "{bad}");
        }
    }
}
