-- A sample's `phi`, `z` and `z_no_rattlers` are the grains' whatever the method. For grains
-- made of primaries (a `grains` block without a `deformable` one) they were the primaries':
-- these move to a `primaries` block, and the grains' Φ and Z take their place. The grains'
-- backbone coordination was not measured then: those samples keep the grains' Z, rattlers
-- counted, as `z_no_rattlers` (in the columns and in `grains`). Deformable grains (MPM, FEM)
-- were already measured as grains; their `grains` block gains the sample's `z_no_rattlers`.
-- The sample events replayed by WatchJob and SSE are rewritten the same way.
UPDATE samples SET
    data = json_set(data,
        '$.primaries', json_object('phi', phi, 'z', z, 'z_no_rattlers', z_no_rattlers),
        '$.phi', json_extract(data, '$.grains.phi'),
        '$.z', json_extract(data, '$.grains.z'),
        '$.z_no_rattlers', json_extract(data, '$.grains.z'),
        '$.grains.z_no_rattlers', json_extract(data, '$.grains.z')),
    phi = json_extract(data, '$.grains.phi'),
    z = json_extract(data, '$.grains.z'),
    z_no_rattlers = json_extract(data, '$.grains.z')
WHERE json_type(data, '$.grains') = 'object' AND json_type(data, '$.deformable') IS NULL;
UPDATE samples SET data = json_set(data, '$.grains.z_no_rattlers', z_no_rattlers)
WHERE json_type(data, '$.grains') = 'object' AND json_type(data, '$.deformable') = 'object';
UPDATE job_events SET payload = json_set(payload,
    '$.sample.primaries', json_object(
        'phi', json_extract(payload, '$.sample.phi'),
        'z', json_extract(payload, '$.sample.z'),
        'z_no_rattlers', json_extract(payload, '$.sample.z_no_rattlers')),
    '$.sample.phi', json_extract(payload, '$.sample.grains.phi'),
    '$.sample.z', json_extract(payload, '$.sample.grains.z'),
    '$.sample.z_no_rattlers', json_extract(payload, '$.sample.grains.z'),
    '$.sample.grains.z_no_rattlers', json_extract(payload, '$.sample.grains.z'))
WHERE kind = 'sample' AND json_type(payload, '$.sample.grains') = 'object'
    AND json_type(payload, '$.sample.deformable') IS NULL;
UPDATE job_events SET payload = json_set(payload,
    '$.sample.grains.z_no_rattlers', json_extract(payload, '$.sample.z_no_rattlers'))
WHERE kind = 'sample' AND json_type(payload, '$.sample.grains') = 'object'
    AND json_type(payload, '$.sample.deformable') = 'object';
