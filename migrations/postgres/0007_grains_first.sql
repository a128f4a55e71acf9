-- A sample's `phi`, `z` and `z_no_rattlers` are the grains' whatever the method. For grains
-- made of primaries (a `grains` block without a `deformable` one) they were the primaries':
-- these move to a `primaries` block, and the grains' Φ and Z take their place. The grains'
-- backbone coordination was not measured then: those samples keep the grains' Z, rattlers
-- counted, as `z_no_rattlers` (in the columns and in `grains`). Deformable grains (MPM, FEM)
-- were already measured as grains; their `grains` block gains the sample's `z_no_rattlers`.
-- The sample events replayed by WatchJob and SSE are rewritten the same way.
UPDATE samples SET
    data = (data::jsonb
        || jsonb_build_object(
            'primaries', jsonb_build_object('phi', phi, 'z', z, 'z_no_rattlers', z_no_rattlers),
            'phi', data::jsonb -> 'grains' -> 'phi',
            'z', data::jsonb -> 'grains' -> 'z',
            'z_no_rattlers', data::jsonb -> 'grains' -> 'z',
            'grains', (data::jsonb -> 'grains') || jsonb_build_object('z_no_rattlers', data::jsonb -> 'grains' -> 'z')))::text,
    phi = (data::jsonb #>> '{grains,phi}')::double precision,
    z = (data::jsonb #>> '{grains,z}')::double precision,
    z_no_rattlers = (data::jsonb #>> '{grains,z}')::double precision
WHERE jsonb_typeof(data::jsonb -> 'grains') = 'object' AND data::jsonb -> 'deformable' IS NULL;
UPDATE samples SET data = jsonb_set(data::jsonb, '{grains,z_no_rattlers}', to_jsonb(z_no_rattlers))::text
WHERE jsonb_typeof(data::jsonb -> 'grains') = 'object' AND jsonb_typeof(data::jsonb -> 'deformable') = 'object';
UPDATE job_events SET payload = jsonb_set(payload::jsonb, '{sample}',
    (payload::jsonb -> 'sample')
        || jsonb_build_object(
            'primaries', jsonb_build_object(
                'phi', payload::jsonb -> 'sample' -> 'phi',
                'z', payload::jsonb -> 'sample' -> 'z',
                'z_no_rattlers', payload::jsonb -> 'sample' -> 'z_no_rattlers'),
            'phi', payload::jsonb -> 'sample' -> 'grains' -> 'phi',
            'z', payload::jsonb -> 'sample' -> 'grains' -> 'z',
            'z_no_rattlers', payload::jsonb -> 'sample' -> 'grains' -> 'z',
            'grains', (payload::jsonb -> 'sample' -> 'grains')
                || jsonb_build_object('z_no_rattlers', payload::jsonb -> 'sample' -> 'grains' -> 'z')))::text
WHERE kind = 'sample' AND jsonb_typeof(payload::jsonb -> 'sample' -> 'grains') = 'object'
    AND payload::jsonb -> 'sample' -> 'deformable' IS NULL;
UPDATE job_events SET payload = jsonb_set(payload::jsonb, '{sample,grains,z_no_rattlers}',
    payload::jsonb -> 'sample' -> 'z_no_rattlers')::text
WHERE kind = 'sample' AND jsonb_typeof(payload::jsonb -> 'sample' -> 'grains') = 'object'
    AND jsonb_typeof(payload::jsonb -> 'sample' -> 'deformable') = 'object';
