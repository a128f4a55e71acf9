-- Sable's job store on PostgreSQL: the same tables, columns and meanings as migrations/sqlite
-- (one migration per SQLite one, same version), in PostgreSQL's types. Times are milliseconds
-- since the Unix epoch (UTC): to_timestamp(created_at / 1000.0) reads them in SQL.

-- One row per accepted job; the scene is kept whole so that a job can be re-run exactly.
CREATE TABLE jobs (
    id               BIGSERIAL PRIMARY KEY,
    name             TEXT             NOT NULL,
    state            TEXT             NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    priority         BIGINT           NOT NULL DEFAULT 0,
    method           TEXT             NOT NULL,
    method_reason    TEXT             NOT NULL,
    scene            TEXT             NOT NULL,            -- the scene JSON as submitted
    scene_hash       TEXT             NOT NULL,            -- SHA-256 of the scene JSON, hex
    engine_version   TEXT             NOT NULL,
    seed             BIGINT           NOT NULL,
    idempotency_key  TEXT             UNIQUE,
    attempts         BIGINT           NOT NULL DEFAULT 0,  -- leases taken so far
    max_attempts     BIGINT           NOT NULL,
    lease_id         TEXT,                                 -- fences every write of the worker holding it
    lease_owner      TEXT,
    lease_expires_at BIGINT,
    cancel_requested BIGINT           NOT NULL DEFAULT 0,
    progress         DOUBLE PRECISION NOT NULL DEFAULT 0,  -- fraction done, 0..1
    created_at       BIGINT           NOT NULL,
    started_at       BIGINT,
    finished_at      BIGINT,
    error_code       TEXT,
    error_message    TEXT,
    steps            BIGINT           NOT NULL DEFAULT 0,
    wall_seconds     DOUBLE PRECISION NOT NULL DEFAULT 0
);
CREATE INDEX jobs_queue ON jobs (state, priority DESC, id);
CREATE INDEX jobs_created ON jobs (created_at);

-- The measured time series, one row per sample, with the engine's field names. `data` holds the
-- whole sample as JSON (stress tensor, walls); the scalar columns are there to query directly.
CREATE TABLE samples (
    job_id          BIGINT           NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq             BIGINT           NOT NULL,
    step            BIGINT           NOT NULL,
    time            DOUBLE PRECISION NOT NULL,
    phi             DOUBLE PRECISION NOT NULL,
    z               DOUBLE PRECISION NOT NULL,
    z_no_rattlers   DOUBLE PRECISION NOT NULL,
    mu              DOUBLE PRECISION NOT NULL,
    p               DOUBLE PRECISION NOT NULL,
    q               DOUBLE PRECISION NOT NULL,
    inertial_number DOUBLE PRECISION,
    kinetic_energy  DOUBLE PRECISION NOT NULL,
    elastic_energy  DOUBLE PRECISION NOT NULL,
    data            TEXT             NOT NULL,
    PRIMARY KEY (job_id, seq)
);

-- Numbered events of each job (state changes and samples), replayed by WatchJob and SSE.
CREATE TABLE job_events (
    job_id  BIGINT NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    seq     BIGINT NOT NULL,
    at      BIGINT NOT NULL,
    kind    TEXT   NOT NULL CHECK (kind IN ('state', 'sample')),
    payload TEXT   NOT NULL,                     -- JSON
    PRIMARY KEY (job_id, seq)
);
