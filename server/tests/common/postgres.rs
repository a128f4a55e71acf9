//! A throw-away PostgreSQL for the tests that run against both back-ends.
//!
//! `SABLE_TEST_POSTGRES_URL` (a URL of a server and a database the tests may create databases
//! from) is used when set. Otherwise the first test that needs one starts a cluster from the
//! PostgreSQL binaries on the machine (Debian's `/usr/lib/postgresql/*/bin`, or `initdb` on the
//! PATH) in `target/postgres-test/`: `initdb` with trust authentication, then `pg_ctl start` on a
//! free port of 127.0.0.1, as the `postgres` user (or `nobody`) when the tests run as root,
//! since PostgreSQL refuses to run as root. The cluster is left running for the next test
//! binaries and runs; `.ci/run` stops it at the end (`pg_ctl stop -D target/postgres-test/data`).
//! Each test takes a database of its own ([`fresh_database`]).
//!
//! Without any PostgreSQL binaries the tests that need one skip with a message, unless
//! `SABLE_REQUIRE_POSTGRES=1` (set by `.ci/run`): then they fail.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The server the tests use: its URL without a database name.
#[derive(Debug, Clone)]
pub struct Postgres {
    /// `postgres://USER@HOST:PORT` (or what `SABLE_TEST_POSTGRES_URL` gives, database removed).
    pub base: String,
    /// The database to connect to for creating others.
    pub admin_db: String,
}

impl Postgres {
    /// The URL of database `db` on this server.
    pub fn url(&self, db: &str) -> String {
        format!("{}/{db}", self.base)
    }
}

/// The test server, started on first use; None (after saying why) when the machine has no
/// PostgreSQL and `SABLE_REQUIRE_POSTGRES` is not set.
pub fn server() -> Option<&'static Postgres> {
    static PG: OnceLock<Result<Postgres, String>> = OnceLock::new();
    match PG.get_or_init(start) {
        Ok(pg) => Some(pg),
        Err(why) => {
            if std::env::var("SABLE_REQUIRE_POSTGRES").is_ok_and(|v| v == "1") {
                panic!("PostgreSQL is required (SABLE_REQUIRE_POSTGRES=1) but not available: {why}");
            }
            eprintln!("SKIPPED: this test needs PostgreSQL: {why}");
            None
        }
    }
}

/// Creates an empty database with a fresh name and returns its URL.
pub async fn fresh_database(pg: &Postgres) -> String {
    use sqlx::Connection;
    let name = format!("sable_test_{:016x}", rand::random::<u64>());
    let mut admin = sqlx::PgConnection::connect(&pg.url(&pg.admin_db)).await.expect("connect to the test PostgreSQL");
    sqlx::query(&format!("CREATE DATABASE {name}")).execute(&mut admin).await.expect("create a test database");
    admin.close().await.ok();
    pg.url(&name)
}

fn start() -> Result<Postgres, String> {
    if let Ok(url) = std::env::var("SABLE_TEST_POSTGRES_URL") {
        let mut u = url::Url::parse(&url).map_err(|e| format!("SABLE_TEST_POSTGRES_URL: {e}"))?;
        let db = u.path().trim_start_matches('/').to_string();
        u.set_path("");
        let base = u.to_string().trim_end_matches('/').to_string();
        return Ok(Postgres { base, admin_db: if db.is_empty() { "postgres".into() } else { db } });
    }
    // Shared by the test binaries and runs: never stopped by the tests.
    let mut cluster = Cluster::new(target_dir().join("postgres-test"))?;
    cluster.keep = true;
    // A cluster left running by an earlier test binary or run.
    if let Ok(port) = std::fs::read_to_string(cluster.root.join("port")) {
        if let (Ok(port), true) = (port.trim().parse(), cluster.running()) {
            cluster.port = port;
            return Ok(cluster.server());
        }
    }
    Ok(cluster.create()?.server())
}

/// A PostgreSQL cluster of the tests' own, in a directory of `target/`.
pub struct Cluster {
    bin: PathBuf,
    root: PathBuf,
    run_as: Option<User>,
    /// The port it listens on (127.0.0.1).
    pub port: u16,
    /// Left running when dropped (the shared cluster).
    keep: bool,
}

impl Cluster {
    fn new(root: PathBuf) -> Result<Self, String> {
        let bin = binaries().ok_or("no PostgreSQL binaries (initdb, pg_ctl) on this machine: apt-get install postgresql")?;
        Ok(Self { bin, root, run_as: run_as()?, port: 0, keep: false })
    }

    /// A cluster of its own in `target/<name>` (for tests that stop or restart PostgreSQL);
    /// None when the machine has no PostgreSQL (and `SABLE_REQUIRE_POSTGRES` is not set).
    /// Stopped when dropped.
    pub fn private(name: &str) -> Option<Self> {
        match Cluster::new(target_dir().join(name)).and_then(Cluster::create) {
            Ok(c) => Some(c),
            Err(why) => {
                if std::env::var("SABLE_REQUIRE_POSTGRES").is_ok_and(|v| v == "1") {
                    panic!("PostgreSQL is required (SABLE_REQUIRE_POSTGRES=1) but not available: {why}");
                }
                eprintln!("SKIPPED: this test needs PostgreSQL: {why}");
                None
            }
        }
    }

    /// The cluster as a [`Postgres`] server.
    pub fn server(&self) -> Postgres {
        Postgres { base: format!("postgres://sable@127.0.0.1:{}", self.port), admin_db: "postgres".into() }
    }

    fn data(&self) -> String {
        self.root.join("data").to_string_lossy().into_owned()
    }

    fn pg_ctl(&self, args: &[&str]) -> Command {
        as_user(&self.run_as, &self.bin.join("pg_ctl"), args)
    }

    /// Whether its postmaster runs.
    fn running(&self) -> bool {
        self.pg_ctl(&["status", "-D", &self.data()])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    }

    /// Makes a new cluster in `root` (removing what was there) and starts it on a free port.
    fn create(mut self) -> Result<Self, String> {
        let root = &self.root;
        if self.running() {
            let _ = self.pg_ctl(&["stop", "-m", "immediate", "-D", &self.data()]).output();
        }
        let _ = std::fs::remove_dir_all(root);
        std::fs::create_dir_all(root).map_err(|e| format!("cannot create {}: {e}", root.display()))?;
        if let Some((uid, gid)) = self.run_as.as_ref().map(|u| (u.uid, u.gid)) {
            std::os::unix::fs::chown(root, Some(uid), Some(gid)).map_err(|e| format!("cannot hand {} over: {e}", root.display()))?;
        }
        let out = as_user(
            &self.run_as,
            &self.bin.join("initdb"),
            &["-D", &self.data(), "-U", "sable", "--auth=trust", "--no-sync", "-E", "UTF8", "--locale=C"],
        )
        .output()
        .map_err(|e| format!("cannot run initdb: {e}"))?;
        if !out.status.success() {
            return Err(format!("initdb failed: {}", String::from_utf8_lossy(&out.stderr)));
        }
        self.port =
            std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map_err(|e| format!("no free port: {e}"))?.port();
        self.start()?;
        let port_file = self.root.join("port");
        std::fs::write(&port_file, self.port.to_string()).map_err(|e| format!("cannot write {}: {e}", port_file.display()))?;
        Ok(self)
    }

    /// Starts the postmaster (fsync off: the data is thrown away).
    pub fn start(&self) -> Result<(), String> {
        let options = format!(
            "-p {} -k {} -c listen_addresses=127.0.0.1 -c fsync=off -c synchronous_commit=off -c full_page_writes=off \
             -c max_connections=300",
            self.port,
            self.root.display()
        );
        let log = self.root.join("log").to_string_lossy().into_owned();
        let out = self
            .pg_ctl(&["start", "-w", "-t", "60", "-D", &self.data(), "-l", &log, "-o", &options])
            .output()
            .map_err(|e| format!("cannot run pg_ctl: {e}"))?;
        if !out.status.success() {
            let log = std::fs::read_to_string(&log).unwrap_or_default();
            return Err(format!("pg_ctl start failed: {}{log}", String::from_utf8_lossy(&out.stderr)));
        }
        Ok(())
    }

    /// Stops the postmaster at once (`-m fast`: open sessions are ended).
    pub fn stop(&self) {
        let _ = self.pg_ctl(&["stop", "-m", "fast", "-D", &self.data()]).output();
    }
}

impl Drop for Cluster {
    /// Private clusters are stopped and removed; the shared one is left running.
    fn drop(&mut self) {
        if self.keep {
            return;
        }
        self.stop();
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// The directory of `initdb` and `pg_ctl`: the newest Debian cluster version, else the PATH.
fn binaries() -> Option<PathBuf> {
    let mut versions: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| Some((e.file_name().to_str()?.parse().ok()?, e.path().join("bin"))))
        .filter(|(_, b): &(u32, PathBuf)| b.join("initdb").exists() && b.join("pg_ctl").exists())
        .collect();
    versions.sort();
    if let Some((_, b)) = versions.pop() {
        return Some(b);
    }
    std::env::var_os("PATH")
        .into_iter()
        .flat_map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .find(|d| d.join("initdb").exists() && d.join("pg_ctl").exists())
}

/// The workspace's target directory.
fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("target"))
}

/// A user to run PostgreSQL as.
struct User {
    name: String,
    uid: u32,
    gid: u32,
}

/// None when the tests do not run as root; else `postgres` or `nobody`.
fn run_as() -> Result<Option<User>, String> {
    let me = Command::new("id").arg("-u").output().map_err(|e| format!("cannot run id: {e}"))?;
    if String::from_utf8_lossy(&me.stdout).trim() != "0" {
        return Ok(None);
    }
    for name in ["postgres", "nobody"] {
        let id = |flag: &str| -> Option<u32> {
            let o = Command::new("id").arg(flag).arg(name).output().ok()?;
            String::from_utf8_lossy(&o.stdout).trim().parse().ok().filter(|_| o.status.success())
        };
        if let (Some(uid), Some(gid)) = (id("-u"), id("-g")) {
            return Ok(Some(User { name: name.into(), uid, gid }));
        }
    }
    Err("the tests run as root and there is neither a postgres nor a nobody user to run PostgreSQL as".into())
}

fn as_user(user: &Option<User>, program: &Path, args: &[&str]) -> Command {
    match user {
        None => {
            let mut c = Command::new(program);
            c.args(args);
            c
        }
        Some(u) => {
            let mut c = Command::new("runuser");
            c.arg("-u").arg(&u.name).arg("--").arg(program).args(args);
            c
        }
    }
}
