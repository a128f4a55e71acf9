//! Turns a [`SceneSpec`] into a [`Scene`], reporting every broken rule at once.

use super::container::{check_box, check_experiment_limits, check_sampling, check_stop};
use super::experiments::check_experiment;
use super::materials::check_materials;
use super::model::*;
use super::sets::{check_aggregate_periods, check_set, check_total, fill_drum, grain_scales};
use super::spec::*;
use super::state::{check_state, StateFile};
use super::violation::{Checker, Violation};
use crate::math::{vec_from_slice, Real, Vec3};

/// Parses scene JSON text and validates the scene (not its method: a scene knows no method;
/// `methods::plan_scene` reads both).
///
/// Structural errors (bad JSON, wrong type, unknown field) are reported with their path, one at a
/// time since the document cannot be read past them; rule violations are all reported together.
pub fn parse_scene(json: &str) -> Result<Scene, Vec<Violation>> {
    validate(&read_spec(json)?)
}

/// Reads scene JSON text into its spec, a structural error reported with its path.
pub fn read_spec(json: &str) -> Result<SceneSpec, Vec<Violation>> {
    let de = &mut serde_json::Deserializer::from_str(json);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." || path == "?" { String::new() } else { path };
        vec![Violation { field, rule: e.into_inner().to_string() }]
    })
}

/// Validates a parsed scene (not its method).
pub fn validate(spec: &SceneSpec) -> Result<Scene, Vec<Violation>> {
    let mut c = Checker::default();
    let scene = check(spec, &mut c);
    if c.violations.is_empty() {
        Ok(scene)
    } else {
        Err(c.violations)
    }
}

/// Longest scene `name`, characters: a description of a few sentences, not a document (a job
/// named after its scene keeps the first 200 of them).
pub const MAX_SCENE_NAME: usize = 1000;

/// Checks a parsed scene, every broken rule reported to `c`; the scene is returned whole even
/// then (with placeholders where a value was refused), so that a method can add its own rules
/// on it and every violation is reported at once.
pub(crate) fn check(spec: &SceneSpec, c: &mut Checker) -> Scene {
    let dim = match spec.dimension {
        2 | 3 => spec.dimension as usize,
        d => {
            c.fail("dimension", format!("must be 2 or 3, got {d}"));
            // Keep checking the rest as if 3D so that more violations are reported.
            3
        }
    };

    if let Some(name) = &spec.name {
        if name.trim().is_empty() || name.chars().count() > MAX_SCENE_NAME || name.chars().any(char::is_control) {
            c.fail("name", format!("must be 1 to {MAX_SCENE_NAME} printable characters (got {} bytes)", name.len()));
        }
    }

    let names: Vec<String> = spec.materials.keys().cloned().collect();
    let materials = check_materials(c, spec);
    let material_index = |c: &mut Checker, field: &str, name: &str| -> usize {
        match names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                c.fail(field, format!("unknown material '{name}'; defined: {}", names.join(", ")));
                0
            }
        }
    };

    // A saved state to start from gives the particles and the box.
    let state = check_start_from(c, spec.start_from.as_ref(), spec.particles.is_empty());
    let mut container = check_box(c, &spec.container, state, dim, &material_index);
    let initial = state.map(|st| std::sync::Arc::new(check_state(c, "start_from.state", st, dim, &material_index)));

    let gravity = check_gravity(c, spec.gravity.as_deref(), dim);

    // Particle sets.
    if spec.particles.is_empty() && initial.is_none() {
        c.fail("particles", "must contain at least one particle set (or give start_from)");
    }
    let mut sets = check_sets(c, spec, dim, &materials, &container, &material_index);

    check_aggregate_periods(c, &sets, &container, dim);

    let (experiment, stop, stages) = match (&spec.experiment, &spec.stop) {
        (None, None) => {
            c.fail("stop", "required: give at least one of time, steps, packing_fraction, strain (or an experiment)");
            (None, Stop::default(), Vec::new())
        }
        (None, Some(s)) => {
            let stop = check_stop(c, s, &container);
            let stage = Stage { name: String::new(), controls: Controls::default(), until: stop, strain_axis: None, equilibrium: None };
            (None, stop, vec![stage])
        }
        (Some(e), limits) => {
            let grains = grain_scales(dim, initial.as_deref(), &sets, &materials);
            let (experiment, stages) = check_experiment(c, e, dim, &container, &grains, &gravity);
            place_experiment(c, spec, &experiment, &mut container, &mut sets, dim);
            let stop = check_experiment_limits(c, limits.as_ref());
            (Some(experiment), stop, stages)
        }
    };
    let sampling = check_sampling(c, spec.sampling.as_ref(), &stop);
    let snapshots = spec.snapshots.as_ref().map(|s| check_snapshot_interval(c, s.every_steps));

    check_total(c, initial.as_ref().map_or(0, |st| st.radius.len()), &sets);
    Scene {
        name: spec.name.clone().unwrap_or_else(|| "scene".to_string()),
        dim,
        materials,
        sets,
        initial,
        container,
        gravity,
        stop,
        stages,
        experiment,
        sampling,
        snapshots,
        seed: spec.seed.unwrap_or(0),
    }
}

/// The fill of a drum experiment, which sets the count of its one particle set.
fn drum_fill(spec: &SceneSpec) -> Option<Real> {
    match &spec.experiment {
        Some(ExperimentSpec::Drum(d)) => d.fill,
        _ => None,
    }
}

/// The gravity vector (zero when none is given or it is refused).
fn check_gravity(c: &mut Checker, g: Option<&[f64]>, dim: usize) -> Vec3 {
    match g {
        Some(g) if c.vector("gravity", g, dim) => vec_from_slice(g),
        _ => Vec3::zeros(),
    }
}

/// Checks every particle set, each with its material found by `material_index`.
fn check_sets(
    c: &mut Checker,
    spec: &SceneSpec,
    dim: usize,
    materials: &[Material],
    container: &Container,
    material_index: &dyn Fn(&mut Checker, &str, &str) -> usize,
) -> Vec<ParticleSet> {
    let count_from_fill = drum_fill(spec).is_some();
    spec.particles
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let path = format!("particles[{i}]");
            let material = material_index(c, &format!("{path}.material"), &p.material);
            check_set(c, &path, p, dim, material, materials, container, count_from_fill)
        })
        .collect()
}

/// Puts the experiment's drum or granule into the container, and sets a drum's grain count
/// from its fill.
fn place_experiment(
    c: &mut Checker,
    spec: &SceneSpec,
    experiment: &Experiment,
    container: &mut Container,
    sets: &mut [ParticleSet],
    dim: usize,
) {
    match experiment {
        Experiment::Drum { drum, .. } => {
            container.drum = Some(*drum);
            if let Some(fill) = drum_fill(spec) {
                fill_drum(c, sets, &spec.particles, fill, drum, container, dim);
            }
        }
        Experiment::GranuleCompression { ball, .. } => container.granule = Some(*ball),
        _ => {}
    }
}

/// The snapshot interval in steps (0: with every sample; an explicit 0 is refused).
fn check_snapshot_interval(c: &mut Checker, every_steps: Option<u64>) -> u64 {
    match every_steps {
        Some(0) => {
            c.fail("snapshots.every_steps", "must be >= 1 (leave it out to take a snapshot with every sample)");
            0
        }
        Some(n) => n,
        None => 0,
    }
}

/// Checks `start_from` and returns the state to start from, if any. Only the inline `state` is
/// read here: `job` and `file` must have been replaced by their content before validation.
fn check_start_from<'a>(c: &mut Checker, s: Option<&'a StartFromSpec>, no_sets: bool) -> Option<&'a StateFile> {
    let s = s?;
    let given = [s.job.is_some(), s.file.is_some(), s.state.is_some()].iter().filter(|&&g| g).count();
    if given != 1 {
        c.fail("start_from", format!("give exactly one of job, file, state; got {given}"));
    }
    if !no_sets {
        c.fail("particles", "must be empty with start_from: the particles are the state's");
    }
    if s.job.is_some() {
        c.fail(
            "start_from.job",
            "names a job of the service: submit the scene to a Sable server (sable submit), which starts it from that job's final state; \
             to run it locally, download the state (sable state ID --out FILE) and give start_from.file",
        );
    }
    if s.file.is_some() {
        c.fail(
            "start_from.file",
            "is read by the sable CLI (sable run, sable submit) relative to the scene file; elsewhere give the state itself as start_from.state",
        );
    }
    s.state.as_deref()
}
