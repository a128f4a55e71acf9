-- The final state of each succeeded job (particles and box; engine/src/scene/state.rs), as
-- gzip-compressed JSON: a scene's `start_from: {"job": ID}` starts from it, and
-- GET /v1/jobs/{id}/state serves it decompressed.
CREATE TABLE job_states (
    job_id BIGINT PRIMARY KEY REFERENCES jobs (id) ON DELETE CASCADE,
    state  BYTEA  NOT NULL
);
