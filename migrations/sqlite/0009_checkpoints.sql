-- The last checkpoint of each unfinished job (engine/src/resume.rs), as gzip-compressed JSON:
-- a job run again (its worker died, or handed it back) goes on from it. `samples` and
-- `snapshots` count what the run had stored when it was taken: the later ones are dropped when
-- the job is leased again. Removed when the job ends.
CREATE TABLE checkpoints (
    job_id    INTEGER PRIMARY KEY REFERENCES jobs (id) ON DELETE CASCADE,
    step      BIGINT  NOT NULL,
    samples   BIGINT  NOT NULL,
    snapshots BIGINT  NOT NULL,
    data      BLOB    NOT NULL,
    saved_at  BIGINT  NOT NULL
);

-- The step the job's last attempt went on from (NULL: it started from step 0).
ALTER TABLE jobs ADD COLUMN resumed_from_step BIGINT;
