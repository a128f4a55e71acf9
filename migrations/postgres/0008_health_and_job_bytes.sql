-- One row that `GET /healthz` writes on each call: a store that can read but no longer write
-- (a full disk, a read-only file system) is reported unhealthy.
CREATE TABLE health (
    id BIGINT PRIMARY KEY,
    checked_at BIGINT NOT NULL
);

-- The bytes a job has stored (its samples, their events and its snapshots), counted as its
-- reports arrive and held to the server's --max-job-bytes.
ALTER TABLE jobs ADD COLUMN stored_bytes BIGINT NOT NULL DEFAULT 0;
