//! Following a job's events: the stored events after a sequence number, then live ones as they
//! are committed, with heartbeats while idle, until the job's final state. Shared by gRPC
//! `WatchJob` and the REST Server-Sent Events mirror.
//!
//! Only stored events go on the wire, so a watcher that falls behind, or reconnects with the
//! last sequence number it saw, misses nothing: it subscribes to notifications first, then reads
//! the table. Each notification carries the events just committed; a watcher that is up to date
//! sends them as they are (no database read), and one that is not (a gap, a lagged channel)
//! reads the table again.

use std::time::Duration;

use std::sync::Arc;
use tokio::sync::broadcast::error::RecvError;

use tokio::sync::{mpsc, OwnedSemaphorePermit, Semaphore};
use tokio_stream::wrappers::ReceiverStream;

use crate::api::ApiError;
use crate::store::{EventRow, JobState, JobStore};

/// What a watcher receives.
#[derive(Debug, Clone, PartialEq)]
pub enum WatchItem {
    /// A stored event.
    Event(EventRow),
    /// Nothing happened for a while (not stored, no sequence number).
    Heartbeat,
}

/// True if the event is a change to a final state (the last event a job has).
pub fn is_final(e: &EventRow) -> bool {
    e.kind == "state"
        && serde_json::from_str::<serde_json::Value>(&e.payload)
            .ok()
            .and_then(|v| v.get("state").and_then(|s| s.as_str()).and_then(JobState::parse))
            .is_some_and(JobState::is_terminal)
}

/// Starts following job `id` from events after `after`. Fails at once if the job does not exist.
pub async fn watch(
    store: &JobStore,
    id: i64,
    after: i64,
    heartbeat: Duration,
) -> Result<mpsc::Receiver<Result<WatchItem, ApiError>>, ApiError> {
    let mut notices = store.subscribe();
    let job = store.get(id).await?;
    let (tx, rx) = mpsc::channel(32);
    let store = store.clone();
    tokio::spawn(async move {
        let mut last = after;
        let mut first = true;
        // Events handed over by a notification, in order, not yet sent.
        let mut pending: Vec<EventRow> = Vec::new();
        loop {
            let (events, full) = if pending.is_empty() {
                match store.events_after(id, last, 256).await {
                    Ok(e) => {
                        let full = e.len() == 256;
                        (e, full)
                    }
                    // The database is away: the stream waits for it, heartbeats keeping the
                    // client, and goes on from where it stood (it was ended with an error, and
                    // a client waiting for the job gave up while the job went on).
                    Err(e) if e.outage().is_some() => {
                        if tx.send(Ok(WatchItem::Heartbeat)).await.is_err() {
                            return;
                        }
                        tokio::select! {
                            _ = tokio::time::sleep(heartbeat.min(Duration::from_secs(1))) => continue,
                            _ = tx.closed() => return,
                            _ = store.closing.cancelled() => return,
                        }
                    }
                    Err(e) => {
                        let _ = tx.send(Err(e.into())).await;
                        return;
                    }
                }
            } else {
                (std::mem::take(&mut pending), false)
            };
            for e in events {
                last = e.seq;
                let done = is_final(&e);
                if tx.send(Ok(WatchItem::Event(e))).await.is_err() || done {
                    return;
                }
            }
            if full {
                continue;
            }
            if first && job.job_state().is_terminal() && last >= after {
                // Watching a finished job from past its last event: nothing will come.
                let max = store.events_after(id, last, 1).await.map(|v| v.is_empty()).unwrap_or(true);
                if max {
                    return;
                }
            }
            first = false;
            // Wait for news of this job, a heartbeat, or the watcher leaving. A notification that
            // continues exactly where this watcher stands is sent as it is; anything else (a gap,
            // a lagged channel, another server's word that the job changed) means reading the
            // table again, and so does each heartbeat (a notification lost on the way from
            // another server delays the events by one heartbeat at most).
            let beat = tokio::time::Instant::now() + heartbeat;
            loop {
                tokio::select! {
                    n = notices.recv() => match n {
                        Ok(notice) if notice.job_id == id => {
                            let fresh: Vec<EventRow> = notice.events.iter().filter(|e| e.seq > last).cloned().collect();
                            if fresh.first().is_some_and(|e| e.seq == last + 1) {
                                pending = fresh;
                            }
                            break;
                        }
                        Ok(_) => {}
                        Err(RecvError::Lagged(_)) => break,
                        Err(RecvError::Closed) => return,
                    },
                    _ = tokio::time::sleep_until(beat) => {
                        if tx.send(Ok(WatchItem::Heartbeat)).await.is_err() {
                            return;
                        }
                        break;
                    }
                    _ = tx.closed() => return,
                    _ = store.closing.cancelled() => return,
                }
            }
        }
    });
    Ok(rx)
}

/// Takes one of the `limit` event-stream slots of `slots`, or says the limit is reached.
pub fn take_slot(slots: &Arc<Semaphore>, limit: usize) -> Result<OwnedSemaphorePermit, ApiError> {
    slots
        .clone()
        .try_acquire_owned()
        .map_err(|_| ApiError::Exhausted(format!("too many open event streams (limit {limit}); try again later")))
}

/// Whether the token a stream was opened with is still valid (checked before each item).
pub type StillAdmitted = Arc<dyn Fn() -> bool + Send + Sync>;

/// [`watch`] as a stream of `convert`ed items, holding the watcher slot `slot` while it lives.
/// The stream ends after the job's final state, at server shutdown, as soon as its consumer
/// drops it (even while the job is quiet), or with an `Unauthenticated` error once `still`
/// says its token was revoked (within a heartbeat of the token files' reload).
#[allow(clippy::too_many_arguments)]
pub async fn watch_stream<T: Send + 'static>(
    store: &JobStore,
    id: i64,
    after: i64,
    heartbeat: Duration,
    slot: OwnedSemaphorePermit,
    still: Option<StillAdmitted>,
    convert: impl Fn(Result<WatchItem, ApiError>) -> T + Send + 'static,
) -> Result<ReceiverStream<T>, ApiError> {
    let mut rx = watch(store, id, after, heartbeat).await?;
    let (tx, out) = mpsc::channel(16);
    tokio::spawn(async move {
        let _slot = slot;
        loop {
            let item = tokio::select! {
                item = rx.recv() => item,
                _ = tx.closed() => return,
            };
            let Some(item) = item else { return };
            if still.as_ref().is_some_and(|still| !still()) {
                let revoked = ApiError::Unauthenticated("the token this stream was opened with has been revoked".into());
                let _ = tx.send(convert(Err(revoked))).await;
                return;
            }
            if tx.send(convert(item)).await.is_err() {
                return;
            }
        }
    });
    Ok(ReceiverStream::new(out))
}
