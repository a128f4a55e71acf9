//! The store under faults of its database: a full disk, a transaction the database ended by
//! itself.

use std::time::Duration;

use super::{DbLocation, JobStore, LeaseConfig, NewJob, Outage};

fn job(name: &str, scene_bytes: usize) -> NewJob {
    NewJob {
        name: name.into(),
        scene: format!("{{\"name\":\"{name}\",\"pad\":\"{}\"}}", "x".repeat(scene_bytes)),
        scene_hash: format!("hash-{name}"),
        method: "dem".into(),
        method_reason: "test".into(),
        seed: 7,
        priority: 0,
        max_attempts: 2,
        idempotency_key: None,
    }
}

/// A disk that fills up, simulated by SQLite's page limit on the one writer connection: the
/// failed write is reported as a full disk (HTTP 507), and the store writes again once space
/// returns.
#[tokio::test]
async fn a_full_disk_is_reported_as_such_and_the_store_writes_again_when_space_returns() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let at = DbLocation::Sqlite(dir.path().join("sable.db"));
    let store = JobStore::open(&at, LeaseConfig { ttl: Duration::from_secs(30) }).await.expect("the store opens");
    store.submit(job("first", 10)).await.expect("a first job");
    let pages: i64 = sqlx::query_scalar("PRAGMA page_count").fetch_one(&store.writer).await.expect("page count");
    sqlx::query(&format!("PRAGMA max_page_count = {}", pages + 2)).execute(&store.writer).await.expect("a page limit");

    let mut failure = None;
    for k in 0..50 {
        if let Err(e) = store.submit(job(&format!("filler {k}"), 20_000)).await {
            failure = Some(e);
            break;
        }
    }
    let e = failure.expect("a write fails once the pages run out");
    assert_eq!(e.outage(), Some(Outage::DiskFull), "{e}");

    // Space returns (on the connection the pool hands out next; a new one has no limit).
    sqlx::query("PRAGMA max_page_count = 1073741823").execute(&store.writer).await.expect("the limit lifted");
    store.submit(job("after", 10)).await.expect("the store writes again once space returns");
    store.probe_write().await.expect("the health probe writes");
    let states = store.count_by_state().await.expect("reads");
    assert!(states.iter().any(|(s, n)| s == "queued" && *n >= 2), "{states:?}");
}

/// On a full disk SQLite may end the failed transaction itself (an automatic rollback); sqlx's
/// rollback on drop then fails, and the connection went back to the pool still counted inside
/// a transaction: every later write was refused ("begin_with at non-zero transaction depth")
/// until the process restarted, while reads went on. The same state is made here by ending
/// the transaction behind sqlx's back; the pool must discard that connection.
#[tokio::test]
async fn a_transaction_the_database_ended_by_itself_does_not_wedge_the_writer() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let at = DbLocation::Sqlite(dir.path().join("sable.db"));
    let store = JobStore::open(&at, LeaseConfig { ttl: Duration::from_secs(30) }).await.expect("the store opens");
    for round in 0..3 {
        let mut tx = store.begin().await.expect("a write transaction");
        sqlx::query("ROLLBACK").execute(&mut *tx).await.expect("the database ends the transaction");
        drop(tx);
        store.submit(job(&format!("after {round}"), 10)).await.expect("the store writes after a transaction ended under it");
        store.probe_write().await.expect("the health probe writes");
    }
}
