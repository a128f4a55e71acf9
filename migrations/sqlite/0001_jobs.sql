-- Sable's job store. Times are milliseconds since the Unix epoch (UTC):
-- datetime(created_at / 1000, 'unixepoch') reads them in SQL.

-- One row per accepted job; the scene is kept whole so that a job can be re-run exactly.
CREATE TABLE jobs (
    id               INTEGER PRIMARY KEY AUTOINCREMENT,
    name             TEXT    NOT NULL,
    state            TEXT    NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    priority         INTEGER NOT NULL DEFAULT 0,
    method           TEXT    NOT NULL,
    method_reason    TEXT    NOT NULL,
    scene            TEXT    NOT NULL,            -- the scene JSON as submitted
    scene_hash       TEXT    NOT NULL,            -- SHA-256 of the scene JSON, hex
    engine_version   TEXT    NOT NULL,
    seed             INTEGER NOT NULL,
    idempotency_key  TEXT    UNIQUE,
    attempts         INTEGER NOT NULL DEFAULT 0,  -- leases taken so far
    max_attempts     INTEGER NOT NULL,
    lease_id         TEXT,                        -- fences every write of the worker holding it
    lease_owner      TEXT,
    lease_expires_at INTEGER,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    progress         REAL    NOT NULL DEFAULT 0,  -- fraction done, 0..1
    created_at       INTEGER NOT NULL,
    started_at       INTEGER,
    finished_at      INTEGER,
    error_code       TEXT,
    error_message    TEXT,
    steps            INTEGER NOT NULL DEFAULT 0,
    wall_seconds     REAL    NOT NULL DEFAULT 0
);
CREATE INDEX jobs_queue ON jobs (state, priority DESC, id);
CREATE INDEX jobs_created ON jobs (created_at);

-- The measured time series, one row per sample, with the engine's field names. `data` holds the
-- whole sample as JSON (stress tensor, walls); the scalar columns are there to query directly.
CREATE TABLE samples (
    job_id          INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq             INTEGER NOT NULL,
    step            INTEGER NOT NULL,
    time            REAL    NOT NULL,
    phi             REAL    NOT NULL,
    z               REAL    NOT NULL,
    z_no_rattlers   REAL    NOT NULL,
    mu              REAL    NOT NULL,
    p               REAL    NOT NULL,
    q               REAL    NOT NULL,
    inertial_number REAL,
    kinetic_energy  REAL    NOT NULL,
    elastic_energy  REAL    NOT NULL,
    data            TEXT    NOT NULL,
    PRIMARY KEY (job_id, seq)
) WITHOUT ROWID;

-- Numbered events of each job (state changes and samples), replayed by WatchJob and SSE.
CREATE TABLE job_events (
    job_id  INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq     INTEGER NOT NULL,
    at      INTEGER NOT NULL,
    kind    TEXT    NOT NULL CHECK (kind IN ('state', 'sample')),
    payload TEXT    NOT NULL,                     -- JSON
    PRIMARY KEY (job_id, seq)
) WITHOUT ROWID;
