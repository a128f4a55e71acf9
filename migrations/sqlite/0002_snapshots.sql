-- VTK snapshots of a job (particles, contact network, walls), each file gzip-compressed as the
-- worker rendered it; served decompressed by GET /v1/jobs/{id}/snapshots/{index}/{part}.
CREATE TABLE snapshots (
    job_id    INTEGER NOT NULL REFERENCES jobs (id) ON DELETE CASCADE,
    idx       INTEGER NOT NULL,               -- from 0, in the order taken
    step      INTEGER NOT NULL,
    time      REAL    NOT NULL,
    particles BLOB    NOT NULL,               -- particles.vtp, gzip
    contacts  BLOB    NOT NULL,               -- contacts.vtp, gzip
    walls     BLOB    NOT NULL,               -- walls.vtp, gzip
    PRIMARY KEY (job_id, idx)
) WITHOUT ROWID;
