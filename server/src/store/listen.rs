//! What the servers of one PostgreSQL database tell each other, and the one role they share.
//!
//! **Notifications.** Every write transaction that appends events to a job also sends
//! `pg_notify` on [`CHANNEL`] with the sending server's name, the job id and whether the job
//! became queued. PostgreSQL delivers it at the commit (never for a transaction rolled back).
//! Each server listens on its own connection. When another server's notification arrives, it
//! tells its local watchers that the job changed (a [`Notice`] without events; watchers then
//! read the stored events, `crate::watch`). If the job became queued, it also wakes an idle
//! local worker. A notification lost while the listening connection is down costs nothing
//! lasting: watchers read the table again at every heartbeat, and idle workers poll.
//!
//! **The study driver's role.** The study driver must run once per database, not once per
//! server. The server that holds a session-level advisory lock ([`DRIVER_LOCK`]) on a
//! connection of its own drives; the others try to take the lock at each round. When the
//! holder dies, PostgreSQL ends its session and releases the lock, and the next server to try
//! takes the role over. The driver repeats nothing when it changes hands
//! (`JobStore::add_study_runs` skips runs that exist already).

use std::sync::Arc;

use sqlx::postgres::PgListener;
use sqlx::{AnyConnection, Connection};

use super::{Backend, JobStore, Notice, StoreError, Tx};

/// The channel of the notifications.
pub const CHANNEL: &str = "sable_jobs";

/// The advisory-lock key of the study driver's role ("sable-sd" in ASCII).
pub const DRIVER_LOCK: i64 = 0x7361_626c_652d_7364;

/// Sends, when `tx` commits, word that `job` has new events (PostgreSQL; nothing on SQLite,
/// where the store's own broadcast reaches every watcher). Identical notifications of one
/// transaction are delivered once, so a report of many samples sends one.
pub(super) async fn announce(store: &JobStore, tx: &mut Tx, job: i64, queued: bool) -> Result<(), StoreError> {
    if store.backend != Backend::Postgres {
        return Ok(());
    }
    let payload = format!("{} {job} {}", store.origin, if queued { "queued" } else { "events" });
    sqlx::query("SELECT pg_notify($1, $2)").bind(CHANNEL).bind(payload).execute(&mut **tx).await?;
    Ok(())
}

/// Starts listening to the other servers' notifications until the store closes.
pub(super) async fn start(store: &JobStore, url: &str) -> Result<(), StoreError> {
    let mut listener = PgListener::connect(url).await?;
    listener.listen(CHANNEL).await?;
    let store = store.clone();
    tokio::spawn(async move {
        loop {
            tokio::select! {
                _ = store.closing.cancelled() => return,
                n = listener.try_recv() => match n {
                    Ok(Some(n)) => heard(&store, n.payload()),
                    // The connection dropped and is opened again at the next call: what was
                    // sent meanwhile is lost, so wake every idle worker to look at the queue.
                    Ok(None) => store.queued.notify_waiters(),
                    Err(e) => {
                        eprintln!("sable serve: listening to the other servers: {e}; trying again in 1 s");
                        tokio::select! {
                            _ = store.closing.cancelled() => return,
                            _ = tokio::time::sleep(std::time::Duration::from_secs(1)) => {}
                        }
                    }
                },
            }
        }
    });
    Ok(())
}

/// Handles one notification's payload (`origin job kind`).
fn heard(store: &JobStore, payload: &str) {
    let mut parts = payload.split(' ');
    let (Some(origin), Some(job), Some(kind)) = (parts.next(), parts.next().and_then(|j| j.parse::<i64>().ok()), parts.next()) else {
        return;
    };
    if origin == &*store.origin {
        return;
    }
    let _ = store.events.send(Arc::new(Notice { job_id: job, events: Vec::new() }));
    if kind == "queued" {
        store.queued.notify_one();
    }
}

/// The study driver's role as this server holds it (module documentation).
#[derive(Debug, Default)]
pub(super) struct DriverRole {
    /// The connection on which this server holds, or tries to take, the advisory lock.
    conn: Option<AnyConnection>,
    /// Whether the lock is held.
    held: bool,
}

impl DriverRole {
    /// Gives the role up (at shutdown), so that another server takes it at once.
    pub(super) async fn release(&mut self) {
        self.held = false;
        if let Some(conn) = self.conn.take() {
            let _ = conn.close().await;
        }
    }
}

impl JobStore {
    /// Whether this server is to run the study driver now: always on SQLite (one server per
    /// file); on PostgreSQL while it holds the driver's advisory lock, which it tries to take
    /// when nobody holds it (module documentation).
    pub async fn is_study_driver(&self) -> bool {
        if self.backend == Backend::Sqlite {
            return true;
        }
        let mut role = self.driver.lock().await;
        if role.conn.is_none() {
            let Ok(conn) = self.writer.acquire().await else { return false };
            *role = DriverRole { conn: Some(conn.detach()), held: false };
        }
        let held = role.held;
        let Some(conn) = role.conn.as_mut() else { return false };
        // A held lock lives as long as the session: check that the session does.
        let r = if held {
            conn.ping().await.map(|_| true)
        } else {
            sqlx::query_scalar::<_, bool>("SELECT pg_try_advisory_lock($1)").bind(DRIVER_LOCK).fetch_one(conn).await
        };
        match r {
            Ok(h) => {
                role.held = h;
                h
            }
            Err(_) => {
                role.release().await;
                false
            }
        }
    }
}
