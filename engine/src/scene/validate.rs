//! Turns a [`SceneSpec`] into a [`Scene`], reporting every broken rule at once.

use super::container::{check_container, check_sampling, check_stop};
use super::experiments::{check_experiment, GrainScales};
use super::materials::check_material;
use super::model::*;
use super::sets::{check_set, fill_drum};
use super::spec::*;
use super::state::{check_state, StateFile};
use super::violation::{Checker, Violation};
use crate::math::{vec_from_slice, Real, Vec3, AXES};

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

    // Materials.
    let names: Vec<String> = spec.materials.keys().cloned().collect();
    if names.is_empty() {
        c.fail("materials", "must define at least one material");
    }
    let materials: Vec<Material> = spec.materials.iter().map(|(name, m)| check_material(c, name, m)).collect();
    let hertz = |m: &Material| matches!(m.law, ElasticLaw::HertzMindlin { .. });
    let contact_materials: Vec<&Material> = materials.iter().filter(|m| m.deformable.is_none()).collect();
    if let Some(first) = contact_materials.first() {
        for m in &contact_materials[1..] {
            if hertz(m) != hertz(first) {
                c.fail(
                    format!("materials.{}.contact.law", m.name),
                    format!("all materials must use the same contact law ('{}' uses another one)", first.name),
                );
            }
        }
    }
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
    let mut container = match state {
        Some(st) => {
            if !spec.container.min.is_empty() || !spec.container.max.is_empty() {
                c.fail("container.min", "leave container.min and container.max out with start_from: the box is the state's");
            }
            let mut periodic: Vec<&str> = spec.container.periodic.iter().map(String::as_str).collect();
            let mut theirs: Vec<&str> = st.periodic.iter().map(String::as_str).collect();
            periodic.sort_unstable();
            theirs.sort_unstable();
            if periodic != theirs {
                c.fail(
                    "container.periodic",
                    format!(
                        "must match the periodic axes of the state it starts from ([{}]), got [{}]",
                        theirs.join(", "),
                        periodic.join(", ")
                    ),
                );
            }
            let spec_box = ContainerSpec { min: st.min.clone(), max: st.max.clone(), ..spec.container.clone() };
            check_container(c, &spec_box, dim, &material_index)
        }
        None => check_container(c, &spec.container, dim, &material_index),
    };
    let initial = state.map(|st| std::sync::Arc::new(check_state(c, "start_from.state", st, dim, &material_index)));

    let gravity = match &spec.gravity {
        Some(g) if c.vector("gravity", g, dim) => vec_from_slice(g),
        _ => Vec3::zeros(),
    };

    // Particle sets.
    if spec.particles.is_empty() && initial.is_none() {
        c.fail("particles", "must contain at least one particle set (or give start_from)");
    }
    let drum_fill = match &spec.experiment {
        Some(ExperimentSpec::Drum(d)) => d.fill,
        _ => None,
    };
    let mut sets: Vec<ParticleSet> = spec
        .particles
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let path = format!("particles[{i}]");
            let material = material_index(c, &format!("{path}.material"), &p.material);
            check_set(c, &path, p, dim, material, &materials, &container, drum_fill.is_some())
        })
        .collect();

    // A grain is measured whole across a periodic boundary from its primaries' nearest images
    // (observe::grains): it must be less than half the period across.
    for (k, set) in sets.iter().enumerate().filter(|(_, s)| s.aggregate.is_some()) {
        let grain = set.size.max_diameter();
        for a in (0..dim).filter(|&a| container.periodic[a]) {
            let period = container.hi[a] - container.lo[a];
            if grain.is_finite() && period > 0.0 && 2.0 * grain >= period {
                c.fail(
                    format!("container.max[{a}]"),
                    format!("the period along {} ({period} m) must exceed twice the largest grain of particles[{k}] ({grain} m), whose primaries are measured as one grain by their nearest images", AXES[a]),
                );
            }
        }
    }

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
            let volume_of = |d: Real| crate::particles::Particles::volume_of(dim, 0.5 * d);
            let (diameter, first_material, any_wet, solid_volume) = match (&initial, sets.first()) {
                (Some(st), _) => (
                    st.mean_diameter(),
                    st.material.first().copied(),
                    st.wet.iter().any(|&w| w),
                    st.radius.iter().map(|&r| volume_of(2.0 * r)).sum(),
                ),
                (None, Some(set)) => (
                    set.size.mean_diameter(),
                    Some(set.material),
                    sets.iter().any(|s| s.wet_fraction > 0.0),
                    sets.iter().map(|s| s.count as Real * volume_of(1.0) * s.size.mean_power(dim as Real)).sum(),
                ),
                (None, None) => (1.0, None, false, 0.0),
            };
            let material = first_material.and_then(|m| materials.get(m));
            let capillary_force = material
                .and_then(|m| m.liquid)
                .filter(|_| any_wet)
                .map(|l| 2.0 * std::f64::consts::PI * l.surface_tension * l.contact_angle.cos() * 0.5 * diameter);
            let grains = GrainScales { diameter, density: material.map_or(1.0, |m| m.density), solid_volume, capillary_force };
            let (experiment, stages) = check_experiment(c, e, dim, &container, &grains, &gravity);
            match &experiment {
                Experiment::Drum { drum, .. } => {
                    container.drum = Some(*drum);
                    if let Some(fill) = drum_fill {
                        fill_drum(c, &mut sets, &spec.particles, fill, drum, &container, dim);
                    }
                }
                Experiment::GranuleCompression { ball, .. } => container.granule = Some(*ball),
                _ => {}
            }
            let stop = match limits {
                None => Stop::default(),
                Some(s) => {
                    for (field, set) in [("packing_fraction", s.packing_fraction.is_some()), ("strain", s.strain.is_some())] {
                        if set {
                            c.fail(
                                format!("stop.{field}"),
                                "not with an experiment, whose stages end by their own criteria (stop may limit time and steps)",
                            );
                        }
                    }
                    if let Some(t) = s.time {
                        c.positive("stop.time", t);
                    }
                    if s.steps == Some(0) {
                        c.fail("stop.steps", "must be >= 1");
                    }
                    Stop { time: s.time, steps: s.steps, ..Stop::default() }
                }
            };
            (Some(experiment), stop, stages)
        }
    };
    let sampling = check_sampling(c, spec.sampling.as_ref(), &stop);
    let snapshots = spec.snapshots.as_ref().map(|s| match s.every_steps {
        Some(0) => {
            c.fail("snapshots.every_steps", "must be >= 1 (leave it out to take a snapshot with every sample)");
            0
        }
        Some(n) => n,
        None => 0,
    });

    // Sets of valid counts may still add up (or multiply, by an aggregate's primaries) past what
    // any machine holds; the sum saturates rather than wraps.
    let from_state = initial.as_ref().map_or(0, |st| st.radius.len());
    let total = sets.iter().map(ParticleSet::particle_count).fold(from_state, usize::saturating_add);
    if total > MAX_PARTICLES {
        let shown = if total == usize::MAX { "more than that".to_string() } else { format!("{total}") };
        c.fail(
            "particles",
            format!("the scene places at most {MAX_PARTICLES} particles in all (primaries of aggregates included), got {shown}"),
        );
    }
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
