-- The stress ratio ζ = q/p and the effective friction μ = τ/σ_n on the shear plane were one
-- column, `mu`, whose meaning depended on the scene (τ/σ_n where a shear is defined, q/p
-- otherwise). Now `zeta` is always q/p, and `mu` is τ/σ_n where a shear is defined (the
-- samples with an inertial number), NULL otherwise. The stored samples (`data`, and the
-- sample events replayed by WatchJob and SSE) are rewritten to the same shape.
ALTER TABLE samples RENAME COLUMN mu TO zeta;
ALTER TABLE samples ADD COLUMN mu DOUBLE PRECISION;
UPDATE samples SET
    mu = CASE WHEN inertial_number IS NOT NULL THEN zeta END,
    zeta = CASE WHEN p > 0 THEN q / p ELSE 0.0 END;
UPDATE samples SET data = (
    CASE WHEN mu IS NULL THEN data::jsonb - 'mu' ELSE data::jsonb END || jsonb_build_object('zeta', zeta)
)::text;
UPDATE job_events SET payload = jsonb_set(
    CASE
        WHEN payload::jsonb #>> '{sample,inertial_number}' IS NULL THEN payload::jsonb #- '{sample,mu}'
        ELSE payload::jsonb
    END,
    '{sample,zeta}',
    to_jsonb(CASE
        WHEN (payload::jsonb #>> '{sample,p}')::double precision > 0
            THEN (payload::jsonb #>> '{sample,q}')::double precision / (payload::jsonb #>> '{sample,p}')::double precision
        ELSE 0.0
    END)
)::text WHERE kind = 'sample';
