-- Derived results of a job's experiment (engine/src/observe/results.rs: peak and steady-state
-- stress ratio, dilatancy, prepared state, inertial and stiffness numbers, warnings), as JSON;
-- NULL for a scene without an experiment or a job that did not succeed.
ALTER TABLE jobs ADD COLUMN result TEXT;
