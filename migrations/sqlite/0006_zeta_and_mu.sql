-- The stress ratio ζ = q/p and the effective friction μ = τ/σ_n on the shear plane were one
-- column, `mu`, whose meaning depended on the scene (τ/σ_n where a shear is defined, q/p
-- otherwise). Now `zeta` is always q/p, and `mu` is τ/σ_n where a shear is defined (the
-- samples with an inertial number), NULL otherwise. The stored samples (`data`, and the
-- sample events replayed by WatchJob and SSE) are rewritten to the same shape.
ALTER TABLE samples RENAME COLUMN mu TO zeta;
ALTER TABLE samples ADD COLUMN mu REAL;
UPDATE samples SET
    mu = CASE WHEN inertial_number IS NOT NULL THEN zeta END,
    zeta = CASE WHEN p > 0 THEN q / p ELSE 0.0 END;
UPDATE samples SET data = CASE
    WHEN mu IS NULL THEN json_set(json_remove(data, '$.mu'), '$.zeta', zeta)
    ELSE json_set(data, '$.zeta', zeta)
END;
UPDATE job_events SET payload = json_set(
    CASE
        WHEN json_extract(payload, '$.sample.inertial_number') IS NULL THEN json_remove(payload, '$.sample.mu')
        ELSE payload
    END,
    '$.sample.zeta',
    CASE
        WHEN json_extract(payload, '$.sample.p') > 0
            THEN json_extract(payload, '$.sample.q') / json_extract(payload, '$.sample.p')
        ELSE 0.0
    END
) WHERE kind = 'sample';
