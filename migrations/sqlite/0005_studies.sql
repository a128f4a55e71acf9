-- Studies (speed against accuracy; engine/src/study, server/src/studies.rs): the study file as
-- submitted, its state, and its report (JSON: each run's cost and error, the Pareto front, a
-- search's limit), recomputed by the study driver whenever one of its jobs ends.
CREATE TABLE studies (
    id          INTEGER PRIMARY KEY AUTOINCREMENT,
    name        TEXT    NOT NULL,
    kind        TEXT    NOT NULL CHECK (kind IN ('sweep', 'search')),
    state       TEXT    NOT NULL CHECK (state IN ('running', 'succeeded', 'failed', 'cancelled')),
    spec        TEXT    NOT NULL,              -- the study file (JSON)
    report      TEXT,                          -- JSON
    error       TEXT,
    created_at  INTEGER NOT NULL,
    finished_at INTEGER
);
CREATE INDEX studies_state ON studies (state, id);

-- The jobs a study spawned, one per run (a sweep's point, a search's probe), with the value
-- measured on it once it ended.
CREATE TABLE study_jobs (
    study_id      INTEGER NOT NULL REFERENCES studies (id) ON DELETE CASCADE,
    idx           INTEGER NOT NULL,            -- position in the study, from 0
    job_id        INTEGER NOT NULL UNIQUE REFERENCES jobs (id),
    series        TEXT    NOT NULL,
    label         TEXT    NOT NULL,            -- the swept values
    value         REAL,                        -- the knob of a search's probe
    measured      REAL,
    measure_note  TEXT,                        -- why nothing was measured
    measured_done INTEGER NOT NULL DEFAULT 0,
    PRIMARY KEY (study_id, idx)
) WITHOUT ROWID;

-- What each job cost beyond its wall time: CPU seconds of its threads, contact-solver sweeps.
ALTER TABLE jobs ADD COLUMN cpu_seconds REAL NOT NULL DEFAULT 0;
ALTER TABLE jobs ADD COLUMN solver_iterations INTEGER NOT NULL DEFAULT 0;
