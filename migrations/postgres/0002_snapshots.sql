-- VTK snapshots of a job (particles, contact network, walls), each file gzip-compressed as the
-- worker rendered it; served decompressed by GET /v1/jobs/{id}/snapshots/{index}/{part}.
CREATE TABLE snapshots (
    job_id    BIGINT           NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    idx       BIGINT           NOT NULL,               -- from 0, in the order taken
    step      BIGINT           NOT NULL,
    time      DOUBLE PRECISION NOT NULL,
    particles BYTEA            NOT NULL,               -- particles.vtp, gzip
    contacts  BYTEA            NOT NULL,               -- contacts.vtp, gzip
    walls     BYTEA            NOT NULL,               -- walls.vtp, gzip
    PRIMARY KEY (job_id, idx)
);
