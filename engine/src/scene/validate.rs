//! Turns a [`SceneSpec`] into a [`Scene`], reporting every broken rule at once.

use super::experiments::{check_experiment, GrainScales};
use super::model::*;
use super::spec::*;
use super::state::{check_state, InitialState, StateFile};
use super::violation::{Checker, Violation};
use crate::constitutive::LawSpec;
use crate::contact::attraction_lj::AttractionLj;
use crate::math::{vec_from_slice, Real, Vec3, AXES};
use crate::particles::aggregate::Bonding;

/// Method names the format knows; only those in [`AVAILABLE_METHODS`] run in this version.
pub const KNOWN_METHODS: [&str; 6] = ["dem", "cd", "bpm", "mpm", "fem", "auto"];
/// Methods this version can run (`auto` picks among them).
pub const AVAILABLE_METHODS: [&str; 5] = ["dem", "cd", "mpm", "fem", "auto"];

/// Parses scene JSON text and validates it.
///
/// Structural errors (bad JSON, wrong type, unknown field) are reported with their path, one at a
/// time since the document cannot be read past them; rule violations are all reported together.
pub fn parse_scene(json: &str) -> Result<Scene, Vec<Violation>> {
    let de = &mut serde_json::Deserializer::from_str(json);
    let spec: SceneSpec = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." || path == "?" { String::new() } else { path };
        vec![Violation { field, rule: e.into_inner().to_string() }]
    })?;
    validate(&spec)
}

/// Validates a parsed scene.
pub fn validate(spec: &SceneSpec) -> Result<Scene, Vec<Violation>> {
    let mut c = Checker::default();
    let dim = match spec.dimension {
        2 | 3 => spec.dimension as usize,
        d => {
            c.fail("dimension", format!("must be 2 or 3, got {d}"));
            // Keep checking the rest as if 3D so that more violations are reported.
            3
        }
    };
    let (mut method, method_reason, auto) = check_method(&mut c, &spec.method);

    // Materials.
    let names: Vec<String> = spec.materials.keys().cloned().collect();
    if names.is_empty() {
        c.fail("materials", "must define at least one material");
    }
    // Rigid grains: contact dynamics, which `auto` takes for aggregates.
    let rigid = matches!(method, Method::Cd(_)) || (auto && spec.particles.iter().any(|p| p.model.is_some()));
    let materials: Vec<Material> = spec.materials.iter().map(|(name, m)| check_material(&mut c, name, m, rigid)).collect();
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
    let state = check_start_from(&mut c, spec.start_from.as_ref(), spec.particles.is_empty());
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
            check_container(&mut c, &spec_box, dim, &material_index)
        }
        None => check_container(&mut c, &spec.container, dim, &material_index),
    };
    let initial = state.map(|st| std::sync::Arc::new(check_state(&mut c, "start_from.state", st, dim, &material_index)));

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
            let material = material_index(&mut c, &format!("{path}.material"), &p.material);
            check_set(&mut c, &path, p, dim, material, &materials, &container, drum_fill.is_some())
        })
        .collect();

    let deformable = |m: usize| materials.get(m).is_some_and(|m| m.deformable.is_some());
    let any_deformable =
        sets.iter().any(|s| deformable(s.material)) || initial.as_ref().is_some_and(|st| st.material.iter().any(|&m| deformable(m)));
    // The soft-grain method the scene runs (or `auto` will pick), if any.
    let soft = match &method {
        Method::Mpm(_) | Method::Fem(_) => Some(method.name()),
        _ if auto && any_deformable => Some("mpm"),
        _ => None,
    };
    let time_step_given = match &method {
        Method::Mpm(p) => p.time_step.is_some(),
        Method::Fem(p) => p.time_step.is_some(),
        _ => false,
    };
    check_deformable_fit(&mut c, spec, (soft, time_step_given), method.name(), dim, &materials, (&sets, initial.as_deref()), &container);
    // Aggregates of bonded primaries, from a set or the state the scene starts from.
    let aggregates = match sets.iter().position(|s| s.aggregate.is_some()) {
        Some(k) => Some(format!("particles[{k}] are")),
        None => initial.as_ref().filter(|st| !st.bondings.is_empty()).map(|_| "start_from holds".to_string()),
    };
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
    let tolerance_given = spec.method.get("tolerance").is_some();
    if let (Some(_), Method::Cd(params), false) = (&aggregates, &mut method, tolerance_given) {
        params.tolerance = AGGREGATE_TOLERANCE;
    }
    if let Some(what) = aggregates.as_ref().filter(|_| !auto && !matches!(method, Method::Cd(_) | Method::Dem(_))) {
        c.fail(
            "method",
            format!(
                "{what} bonded_primaries aggregates, which run by contact dynamics as in the sources or by DEM: use method cd (or auto) or dem, not {}",
                method.name()
            ),
        );
    }
    if !auto && matches!(method, Method::Dem(_)) {
        for (k, set) in sets.iter().enumerate() {
            if let (Some(a), Some(m)) = (&set.aggregate, materials.get(set.material)) {
                check_dem_aggregate(&mut c, &format!("particles[{k}].model"), a.bonding, a.primaries.min_diameter(), m);
            }
        }
        // The aggregates a saved state holds: the same rules, with the primaries it holds.
        if let Some(st) = &initial {
            // One pass over the particles: each aggregate's smallest primary and its material.
            let mut of: Vec<(Real, Option<usize>)> = vec![(Real::INFINITY, None); st.bondings.len()];
            for (i, &a) in st.aggregate.iter().enumerate() {
                if let (Some(o), Some(&r)) = (of.get_mut(a as usize), st.radius.get(i)) {
                    o.0 = o.0.min(2.0 * r);
                    o.1 = o.1.or(st.material.get(i).copied());
                }
            }
            for (k, (b, (d_min, material))) in st.bondings.iter().zip(of).enumerate() {
                if let Some(m) = material.and_then(|m| materials.get(m)) {
                    check_dem_aggregate(&mut c, &format!("start_from.state.bondings[{k}]"), *b, d_min, m);
                }
            }
        }
    }

    let (experiment, stop, stages) = match (&spec.experiment, &spec.stop) {
        (None, None) => {
            c.fail("stop", "required: give at least one of time, steps, packing_fraction, strain (or an experiment)");
            (None, Stop::default(), Vec::new())
        }
        (None, Some(s)) => {
            let stop = check_stop(&mut c, s, &container);
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
            let (experiment, stages) = check_experiment(&mut c, e, dim, &container, &grains, &gravity);
            match &experiment {
                Experiment::Drum { drum, .. } => {
                    container.drum = Some(*drum);
                    if let Some(fill) = drum_fill {
                        fill_drum(&mut c, &mut sets, &spec.particles, fill, drum, &container, dim);
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
    let sampling = check_sampling(&mut c, spec.sampling.as_ref(), &stop);
    let snapshots = spec.snapshots.as_ref().map(|s| match s.every_steps {
        Some(0) => {
            c.fail("snapshots.every_steps", "must be >= 1 (leave it out to take a snapshot with every sample)");
            0
        }
        Some(n) => n,
        None => 0,
    });

    if c.violations.is_empty() {
        // Sets of valid counts may still add up (or multiply, by an aggregate's primaries) past
        // what any machine holds; the sum saturates rather than wraps.
        let from_state = initial.as_ref().map_or(0, |st| st.radius.len());
        let total = sets.iter().map(ParticleSet::particle_count).fold(from_state, usize::saturating_add);
        if total > MAX_PARTICLES {
            let shown = if total == usize::MAX { "more than that".to_string() } else { format!("{total}") };
            c.fail(
                "particles",
                format!("the scene places at most {MAX_PARTICLES} particles in all (primaries of aggregates included), got {shown}"),
            );
        }
    }
    if !c.violations.is_empty() {
        return Err(c.violations);
    }
    let mut scene = Scene {
        name: spec.name.clone().unwrap_or_else(|| "scene".to_string()),
        dim,
        method,
        method_reason,
        advice: None,
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
    };
    if auto && aggregates.is_some() {
        scene.method = Method::Cd(CdParams { tolerance: AGGREGATE_TOLERANCE, ..CdParams::default() });
        scene.method_reason = "aggregates of rigid primaries run by contact dynamics, as in the sources (N 1.2.1)".into();
    } else if auto {
        let mut advice = crate::advise::advise(&scene);
        advice.requested = "auto".into();
        scene.method = advice.method();
        scene.method_reason = advice.summary();
        scene.advice = Some(advice);
    }
    Ok(scene)
}

/// Packing fraction of a drum's bed used to turn `experiment.fill` into a grain count: that of
/// frictional grains poured and turned (measured: 0.815 with 300 disks, 0.558 with 5,000
/// spheres).
pub const DRUM_BED_PHI: [Real; 2] = [0.82, 0.58];

/// Sets the count of the one particle set of a drum from the fill asked for: the grains'
/// volume is `fill × Φ_bed × the drum's volume` ([`DRUM_BED_PHI`]).
fn fill_drum(
    c: &mut Checker,
    sets: &mut [ParticleSet],
    specs: &[ParticleSetSpec],
    fill: Real,
    drum: &DrumDef,
    container: &Container,
    dim: usize,
) {
    if !(fill > 0.0 && fill < 1.0) {
        c.fail("experiment.fill", format!("must be in (0, 1), got {fill}"));
        return;
    }
    let [set] = sets else {
        c.fail("experiment.fill", "needs exactly one particle set (placed at random, without count)");
        return;
    };
    if specs.first().is_some_and(|s| s.count.is_some()) || !matches!(set.placement, Placement::Random(_)) {
        c.fail("experiment.fill", "give particles[0].count or experiment.fill, not both (fill needs random placement)");
        return;
    }
    let length = if dim == 3 { container.hi[drum.axis] - container.lo[drum.axis] } else { 1.0 };
    let volume = std::f64::consts::PI * drum.radius * drum.radius * length;
    let grain = crate::particles::Particles::volume_of(dim, 1.0) * set.size.mean_power(dim as Real) / (2.0_f64).powi(dim as i32);
    let count = (fill * DRUM_BED_PHI[dim - 2] * volume / grain).round();
    if !(1.0..=1e8).contains(&count) {
        c.fail("experiment.fill", format!("gives {count} grains of this size; choose a fill or grain size that gives 1 to 1e8"));
        return;
    }
    set.count = count as usize;
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

/// The method and why, and whether the scene asked the advisor (`auto`, which takes no
/// parameters: the advisor sets them).
fn check_method(c: &mut Checker, v: &serde_json::Value) -> (Method, String, bool) {
    let fallback = (Method::Dem(DemParams::default()), String::new(), false);
    // A plain name is reported at `method`, an object's name at `method.kind`.
    let (kind, kind_path, object) = match v {
        serde_json::Value::String(s) => (s.clone(), "method", None),
        serde_json::Value::Object(map) => {
            let Some(kind) = map.get("kind").and_then(|k| k.as_str()) else {
                c.fail("method.kind", "must be a string naming the method (e.g. \"dem\")");
                return fallback;
            };
            (kind.to_string(), "method.kind", Some(v))
        }
        _ => {
            c.fail("method", "must be a method name or an object with a \"kind\"");
            return fallback;
        }
    };
    if !KNOWN_METHODS.contains(&kind.as_str()) {
        c.fail(kind_path, format!("unknown method '{kind}'; known: {}", KNOWN_METHODS.join(", ")));
        return fallback;
    }
    if kind == "bpm" {
        c.fail(
            kind_path,
            "the bonded particle method is a model of the grains, run by contact dynamics: give the particle set \"model\": {\"kind\": \"bonded_primaries\", ...} and \"method\": \"cd\"",
        );
        return fallback;
    }
    if !AVAILABLE_METHODS.contains(&kind.as_str()) {
        c.fail(kind_path, format!("method '{kind}' is not available in this version; available: {}", AVAILABLE_METHODS.join(", ")));
        return fallback;
    }
    /// The method object's parameters, with unknown ones rejected at their path.
    fn params<T: serde::de::DeserializeOwned + Default>(c: &mut Checker, object: Option<&serde_json::Value>) -> Option<T> {
        let Some(v) = object else { return Some(T::default()) };
        match serde_path_to_error::deserialize::<_, T>(v) {
            Ok(p) => Some(p),
            Err(e) => {
                c.fail(format!("method.{}", e.path()), e.into_inner().to_string());
                None
            }
        }
    }
    match kind.as_str() {
        "cd" => {
            let Some(s) = params::<CdParamsSpec>(c, object) else { return fallback };
            (Method::Cd(check_cd_params(c, &s)), "chosen by the scene".to_string(), false)
        }
        "mpm" => {
            let Some(s) = params::<MpmParamsSpec>(c, object) else { return fallback };
            (Method::Mpm(check_mpm_params(c, &s)), "chosen by the scene".to_string(), false)
        }
        "fem" => {
            let Some(s) = params::<FemParamsSpec>(c, object) else { return fallback };
            (Method::Fem(check_fem_params(c, &s)), "chosen by the scene".to_string(), false)
        }
        "auto" => {
            for key in object.and_then(|o| o.as_object()).into_iter().flat_map(|m| m.keys()).filter(|k| *k != "kind") {
                c.fail(
                    format!("method.{key}"),
                    "auto chooses the method and its parameters; name the method (dem, cd, mpm or fem) to set them",
                );
            }
            (Method::Dem(DemParams::default()), String::new(), true)
        }
        _ => {
            let Some(s) = params::<DemParamsSpec>(c, object) else { return fallback };
            (Method::Dem(check_dem_params(c, &s)), "chosen by the scene".to_string(), false)
        }
    }
}

/// The finite element method's parameters: the knobs it shares with the material point method
/// are checked by [`check_mpm_params`] under the same names.
fn check_fem_params(c: &mut Checker, s: &FemParamsSpec) -> FemParams {
    let shared = MpmParamsSpec {
        kind: s.kind.clone(),
        time_step: s.time_step,
        max_displacement: s.max_displacement,
        theta: s.theta,
        newton_tolerance: s.newton_tolerance,
        max_newton: s.max_newton,
        tolerance: s.tolerance,
        violation_tolerance: s.violation_tolerance,
        max_iterations: s.max_iterations,
        acceleration: s.acceleration,
        threads: s.threads,
        ..MpmParamsSpec::default()
    };
    let m = check_mpm_params(c, &shared);
    let mut p = FemParams {
        time_step: m.time_step,
        max_displacement: m.max_displacement,
        theta: m.theta,
        newton_tolerance: m.newton_tolerance,
        max_newton: m.max_newton,
        tolerance: m.tolerance,
        violation_tolerance: m.violation_tolerance,
        max_iterations: m.max_iterations,
        acceleration: m.acceleration,
        symmetric_contact: s.symmetric_contact.unwrap_or(FemParams::default().symmetric_contact),
        threads: m.threads,
        ..FemParams::default()
    };
    if let Some(n) = s.elements_per_diameter {
        if !(n.is_finite() && n >= 2.0) {
            c.fail(
                "method.elements_per_diameter",
                format!("must be >= 2 (an element larger than half the smallest grain cannot tell its shape), got {n}"),
            );
        } else {
            p.elements_per_diameter = n;
        }
    }
    p
}

fn check_mpm_params(c: &mut Checker, s: &MpmParamsSpec) -> MpmParams {
    let mut p = MpmParams { symmetric_contact: s.symmetric_contact, ..MpmParams::default() };
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.max_displacement {
        if s.time_step.is_some() {
            c.fail("method.max_displacement", "give time_step or max_displacement, not both");
        } else if c.positive("method.max_displacement", f) {
            p.max_displacement = f;
        }
    }
    if let Some(n) = s.cells_per_diameter {
        if !(n.is_finite() && n >= 1.0) {
            c.fail(
                "method.cells_per_diameter",
                format!("must be >= 1 (a grid cell larger than the smallest grain cannot tell its shape), got {n}"),
            );
        } else {
            p.cells_per_diameter = n;
        }
    }
    if let Some(n) = s.points_per_cell {
        if n == 0 || n > 8 {
            c.fail("method.points_per_cell", format!("must be 1 to 8, got {n}"));
        } else {
            p.points_per_cell = n;
        }
    }
    if p.cells_per_diameter * (p.points_per_cell as Real) < 2.0 {
        c.fail(
            "method.points_per_cell",
            format!(
                "gives {} point(s) across the smallest grain (cells_per_diameter × points_per_cell); a grain needs at least 2",
                p.cells_per_diameter * p.points_per_cell as Real
            ),
        );
    }
    if let Some(t) = s.theta {
        if c.within("method.theta", t, 0.5, 1.0) {
            p.theta = t;
        }
    }
    if let Some(f) = s.flip {
        if c.within("method.flip", f, 0.0, 1.0) {
            p.flip = f;
        }
    }
    if let Some(t) = s.newton_tolerance {
        if c.positive("method.newton_tolerance", t) {
            p.newton_tolerance = t;
        }
    }
    match s.max_newton {
        Some(0) => c.fail("method.max_newton", "must be >= 1"),
        Some(n) => p.max_newton = n,
        None => {}
    }
    if let Some(t) = s.tolerance {
        if c.positive("method.tolerance", t) {
            p.tolerance = t;
        }
    }
    if let Some(t) = s.violation_tolerance {
        if c.positive("method.violation_tolerance", t) {
            p.violation_tolerance = t;
        }
    }
    match s.max_iterations {
        Some(0) => c.fail("method.max_iterations", "must be >= 1"),
        Some(n) => p.max_iterations = n,
        None => {}
    }
    if let Some(a) = s.acceleration {
        if !(a.is_finite() && (0.0..1.0).contains(&a)) {
            c.fail("method.acceleration", format!("must be >= 0 and < 1, got {a}"));
        } else {
            p.acceleration = Some(a);
        }
    }
    p.threads = s.threads.unwrap_or(0);
    p
}

/// What the soft-grain methods cannot run, and deformable grains with a method for rigid ones:
/// every such field named. `soft`: the soft-grain method the scene runs (or `auto` will pick).
#[allow(clippy::too_many_arguments)]
fn check_deformable_fit(
    c: &mut Checker,
    spec: &SceneSpec,
    (soft, time_step_given): (Option<&str>, bool),
    method: &str,
    dim: usize,
    materials: &[Material],
    (sets, initial): (&[ParticleSet], Option<&InitialState>),
    container: &Container,
) {
    let name = soft.unwrap_or("mpm");
    // A soft method needs deformable grains and a rigid one rigid grains.
    let kind_rule = |c: &mut Checker, field: &str, m: &Material| match (soft.is_some(), m.deformable.is_some()) {
        (true, false) => c.fail(
            field,
            format!("method {name} needs deformable grains: give material '{}' a deformable law instead of a contact law", m.name),
        ),
        (false, true) => {
            c.fail(field, format!("'{}' is deformable: its grains need method mpm or fem (method {method} moves rigid grains)", m.name))
        }
        _ => {}
    };
    // The grains of a state the scene starts from, by material (the scene's numbering).
    if let Some(st) = initial {
        let mut used: Vec<usize> = st.material.clone();
        used.sort_unstable();
        used.dedup();
        for m in used.into_iter().filter_map(|m| materials.get(m)) {
            kind_rule(c, "start_from.state.materials", m);
        }
        if soft.is_some() && st.wet.iter().any(|&w| w) {
            c.fail("start_from.state.particles.wet", format!("not with method {name} (no capillary law between deformable grains)"));
        }
    }
    for (i, set) in sets.iter().enumerate() {
        let Some(m) = materials.get(set.material) else { continue };
        kind_rule(c, &format!("particles[{i}].material"), m);
        if soft.is_some() && set.wet_fraction > 0.0 {
            c.fail(format!("particles[{i}].wet_fraction"), format!("not with method {name} (no capillary law between deformable grains)"));
        }
    }
    if soft.is_none() {
        return;
    }
    if dim != 2 {
        c.fail("dimension", format!("method {name} is 2D (plane strain) in this version"));
    }
    if container.periodic.iter().any(|&p| p) {
        c.fail("container.periodic", format!("not with method {name}: its grains meet walls only"));
    }
    if spec.container.lees_edwards.is_some() {
        c.fail("container.lees_edwards", format!("not with method {name} (it needs walls all round)"));
    }
    if spec.container.deformation.is_some() {
        c.fail("container.deformation", format!("not with method {name} (it needs walls all round)"));
    }
    for w in &container.walls {
        match w.motion {
            WallMotion::Stress { max_speed, .. } if !max_speed.is_finite() && !time_step_given => c.fail(
                format!("container.walls.{}.max_speed", w.face.name()),
                format!("required with method {name} (unless method.time_step is given): the fastest wall sets the time step"),
            ),
            WallMotion::Shearing { .. } => {
                c.fail(format!("container.walls.{}", w.face.name()), format!("shearing walls are not available with method {name}"))
            }
            _ => {}
        }
    }
    if let Some(e) = &spec.experiment {
        if !matches!(e, ExperimentSpec::Isotropic(_) | ExperimentSpec::Biaxial(_) | ExperimentSpec::Compaction(_)) {
            c.fail(
                "experiment.kind",
                format!("the {} experiment is not available with method {name}: it runs isotropic, biaxial and compaction", e.kind()),
            );
        }
    }
}

fn check_dem_params(c: &mut Checker, s: &DemParamsSpec) -> DemParams {
    let mut p = DemParams::default();
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.time_step_fraction {
        if s.time_step.is_some() {
            c.fail("method.time_step_fraction", "give either time_step or time_step_fraction, not both");
        } else if c.within("method.time_step_fraction", f, 1e-6, 0.5) {
            p.time_step_fraction = f;
        }
    }
    if let Some(skin) = s.skin {
        if c.within("method.skin", skin, 1e-3, 2.0) {
            p.skin = skin;
        }
    }
    if let Some(v) = s.reference_velocity {
        if c.positive("method.reference_velocity", v) {
            p.reference_velocity = Some(v);
        }
    }
    if let Some(o) = s.max_overlap {
        if c.within("method.max_overlap", o, 1e-4, 1.0) {
            p.max_overlap = o;
        }
    }
    if let Some(a) = s.local_damping {
        if !(a.is_finite() && (0.0..1.0).contains(&a)) {
            c.fail("method.local_damping", format!("must be >= 0 and < 1, got {a}"));
        } else {
            p.local_damping = a;
        }
    }
    if let Some(t) = s.threads {
        p.threads = check_threads(c, t);
    }
    p
}

fn check_threads(c: &mut Checker, t: usize) -> usize {
    if t > 1024 {
        c.fail("method.threads", format!("must be <= 1024, got {t}"));
        return 0;
    }
    t
}

fn check_cd_params(c: &mut Checker, s: &CdParamsSpec) -> CdParams {
    let mut p = CdParams::default();
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.max_displacement {
        if s.time_step.is_some() {
            c.fail("method.max_displacement", "give either time_step or max_displacement, not both");
        } else if c.within("method.max_displacement", f, 1e-6, 0.5) {
            p.max_displacement = f;
        }
    }
    if let Some(v) = s.reference_velocity {
        if c.positive("method.reference_velocity", v) {
            p.reference_velocity = Some(v);
        }
    }
    if let Some(t) = s.theta {
        if c.within("method.theta", t, 0.5, 1.0) {
            p.theta = t;
        }
    }
    if let Some(t) = s.tolerance {
        if c.within("method.tolerance", t, 1e-14, 0.1) {
            p.tolerance = t;
        }
    }
    if let Some(t) = s.violation_tolerance {
        if c.within("method.violation_tolerance", t, 1e-14, 0.1) {
            p.violation_tolerance = Some(t);
        }
    }
    if let Some(n) = s.max_iterations {
        if !(1..=1_000_000).contains(&n) {
            c.fail("method.max_iterations", format!("must be between 1 and 1000000, got {n}"));
        } else {
            p.max_iterations = n;
        }
    }
    if let Some(t) = s.loading_violation_tolerance {
        if c.within("method.loading_violation_tolerance", t, 1e-14, 0.1) {
            p.loading_violation_tolerance = t;
        }
    }
    if let Some(w) = s.sweep {
        p.sweep = w;
    }
    if let Some(w) = s.relaxation {
        if !(w > 0.0 && w <= 1.0) {
            c.fail("method.relaxation", format!("must be in (0, 1], got {w}"));
        } else {
            p.relaxation = w;
        }
    }
    if let Some(a) = s.acceleration {
        if !(0.0..1.0).contains(&a) {
            c.fail("method.acceleration", format!("must be in [0, 1), got {a}"));
        } else {
            p.acceleration = a;
        }
    }
    if let Some(o) = s.max_interpenetration {
        if c.within("method.max_interpenetration", o, 1e-6, 1.0) {
            p.max_interpenetration = o;
        }
    }
    if let Some(slop) = s.slop {
        if c.within("method.slop", slop, 0.0, 1.0) {
            if slop < p.max_interpenetration {
                p.slop = slop;
            } else {
                c.fail("method.slop", format!("must be below method.max_interpenetration ({}), got {slop}", p.max_interpenetration));
            }
        }
    }
    if let Some(skin) = s.skin {
        if c.within("method.skin", skin, 1e-3, 2.0) {
            p.skin = skin;
        }
    }
    if let Some(t) = s.threads {
        p.threads = check_threads(c, t);
    }
    p
}

/// Checks a deformable material's constitutive law (every bad parameter named).
fn check_deformable(c: &mut Checker, p: &str, d: &DeformableSpec) -> LawSpec {
    let q = format!("{p}.deformable");
    let poisson = |c: &mut Checker, nu: f64| {
        if !(nu.is_finite() && nu > -1.0 && nu < 0.5) {
            c.fail(format!("{q}.poisson_ratio"), format!("must be > -1 and < 0.5, got {nu}"));
        }
    };
    match *d {
        DeformableSpec::LinearElastic { young_modulus, poisson_ratio } => {
            c.positive(&format!("{q}.young_modulus"), young_modulus);
            poisson(c, poisson_ratio);
            LawSpec::LinearElastic { young: young_modulus, poisson: poisson_ratio }
        }
        DeformableSpec::NeoHookean { shear_modulus, lambda } => {
            c.positive(&format!("{q}.shear_modulus"), shear_modulus);
            c.non_negative(&format!("{q}.lambda"), lambda);
            LawSpec::NeoHookean { shear_modulus, lambda }
        }
        DeformableSpec::Elastoplastic { young_modulus, poisson_ratio, yield_stress, hardening } => {
            c.positive(&format!("{q}.young_modulus"), young_modulus);
            poisson(c, poisson_ratio);
            c.positive(&format!("{q}.yield_stress"), yield_stress);
            c.non_negative(&format!("{q}.hardening"), hardening);
            LawSpec::Elastoplastic { young: young_modulus, poisson: poisson_ratio, yield_stress, hardening }
        }
    }
}

/// Checks a material; `rigid`: for contact dynamics, where the restitution is an impact law
/// (0 allowed: perfectly plastic impacts) and not a damping ratio.
fn check_material(c: &mut Checker, name: &str, m: &MaterialSpec, rigid: bool) -> Material {
    let p = format!("materials.{name}");
    c.positive(&format!("{p}.density"), m.density);
    if let Some(d) = &m.deformable {
        let deformable = check_deformable(c, &p, d);
        for (given, key) in [
            (m.contact.is_some(), "contact"),
            (m.restitution.is_some(), "restitution"),
            (m.rolling.is_some(), "rolling"),
            (m.liquid.is_some(), "liquid"),
            (m.cohesion.is_some(), "cohesion"),
            (m.tangential_damping_ratio.is_some(), "tangential_damping_ratio"),
            (m.limit_damping.is_some(), "limit_damping"),
        ] {
            if given {
                c.fail(
                    format!("{p}.{key}"),
                    "not for a deformable material: its grains touch through their constitutive law (leave it out)",
                );
            }
        }
        c.non_negative(&format!("{p}.friction"), m.friction);
        let (young, poisson) = deformable.young_poisson();
        return Material {
            name: name.to_string(),
            density: m.density,
            law: ElasticLaw::HertzMindlin { young, poisson },
            restitution: 0.0,
            friction: m.friction,
            tangential_damping_ratio: 0.0,
            limit_damping: true,
            rolling: None,
            liquid: None,
            cohesion: None,
            deformable: Some(deformable),
        };
    }
    let law = match m.contact {
        Some(ContactLawSpec::Linear { k_n, k_t }) => {
            c.positive(&format!("{p}.contact.k_n"), k_n);
            let k_t = k_t.unwrap_or(2.0 / 7.0 * k_n);
            c.non_negative(&format!("{p}.contact.k_t"), k_t);
            ElasticLaw::Linear { k_n, k_t }
        }
        Some(ContactLawSpec::HertzMindlin { young_modulus, poisson_ratio }) => {
            c.positive(&format!("{p}.contact.young_modulus"), young_modulus);
            if !(poisson_ratio.is_finite() && poisson_ratio > -1.0 && poisson_ratio < 0.5) {
                c.fail(format!("{p}.contact.poisson_ratio"), format!("must be > -1 and < 0.5, got {poisson_ratio}"));
            }
            ElasticLaw::HertzMindlin { young: young_modulus, poisson: poisson_ratio }
        }
        None => {
            c.fail(format!("{p}.contact"), "required (the elastic contact law), unless the material is deformable");
            ElasticLaw::Linear { k_n: 1.0, k_t: 0.0 }
        }
    };
    let restitution = m.restitution.unwrap_or_else(|| {
        c.fail(format!("{p}.restitution"), "required, unless the material is deformable");
        1.0
    });
    if rigid {
        if !(restitution.is_finite() && (0.0..=1.0).contains(&restitution)) {
            c.fail(format!("{p}.restitution"), format!("must be >= 0 and <= 1 with method cd, got {restitution}"));
        }
    } else if !(restitution.is_finite() && restitution > 0.0 && restitution <= 1.0) {
        c.fail(format!("{p}.restitution"), format!("must be > 0 and <= 1, got {restitution}"));
    }
    c.non_negative(&format!("{p}.friction"), m.friction);
    let ratio = m.tangential_damping_ratio.unwrap_or(0.5);
    c.non_negative(&format!("{p}.tangential_damping_ratio"), ratio);
    let limit_damping = m.limit_damping.unwrap_or(true);
    // A floored linear contact cannot lose more than critical damping takes; a Hertz contact's
    // damping grows as its overlap closes, so it reaches any restitution.
    let linear = matches!(law, ElasticLaw::Linear { .. });
    if !rigid && linear && limit_damping && restitution > 0.0 && restitution < crate::contact::damping::MIN_LIMITED_RESTITUTION {
        c.fail(
            format!("{p}.restitution"),
            format!(
                "must be >= {} with the linear law when limit_damping is true (an overdamped contact cannot reach lower); got {}",
                crate::contact::damping::MIN_LIMITED_RESTITUTION,
                restitution
            ),
        );
    }
    let rolling = m.rolling.as_ref().map(|r| {
        c.non_negative(&format!("{p}.rolling.stiffness"), r.stiffness);
        c.non_negative(&format!("{p}.rolling.friction"), r.friction);
        Rolling { stiffness: r.stiffness, friction: r.friction }
    });
    let liquid = m.liquid.as_ref().map(|l| {
        let q = format!("{p}.liquid");
        c.positive(&format!("{q}.surface_tension"), l.surface_tension);
        c.within(&format!("{q}.contact_angle"), l.contact_angle, 0.0, std::f64::consts::FRAC_PI_2 - 1e-9);
        c.positive(&format!("{q}.bridge_volume"), l.bridge_volume);
        c.non_negative(&format!("{q}.viscosity"), l.viscosity);
        let roughness = match l.roughness {
            Some(h) => {
                c.positive(&format!("{q}.roughness"), h);
                h
            }
            None if l.viscosity > 0.0 => {
                c.fail(format!("{q}.roughness"), "required when viscosity > 0 (it bounds the lubrication force)");
                0.0
            }
            None => 0.0,
        };
        Liquid {
            surface_tension: l.surface_tension,
            contact_angle: l.contact_angle,
            bridge_volume: l.bridge_volume,
            viscosity: l.viscosity,
            roughness,
        }
    });
    let cohesion = m.cohesion.as_ref().map(|k| {
        c.positive(&format!("{p}.cohesion.force"), k.force);
        c.non_negative(&format!("{p}.cohesion.distance"), k.distance);
        Cohesion { force: k.force, distance: k.distance }
    });
    Material {
        name: name.to_string(),
        density: m.density,
        law,
        restitution,
        friction: m.friction,
        tangential_damping_ratio: ratio,
        limit_damping,
        rolling,
        liquid,
        cohesion,
        deformable: None,
    }
}

fn check_region(c: &mut Checker, path: &str, r: Option<&RegionSpec>, dim: usize, container: &Container) -> Aabb {
    let Some(r) = r else {
        return Aabb { lo: container.lo, hi: container.hi };
    };
    let ok = c.vector(&format!("{path}.min"), &r.min, dim) & c.vector(&format!("{path}.max"), &r.max, dim);
    if !ok {
        return Aabb { lo: container.lo, hi: container.hi };
    }
    let lo = vec_from_slice(&r.min);
    let hi = vec_from_slice(&r.max);
    for a in 0..dim {
        if lo[a] >= hi[a] {
            c.fail(format!("{path}.max[{a}]"), format!("must be > min[{a}] = {}, got {}", lo[a], hi[a]));
        } else if lo[a] < container.lo[a] - 1e-12 || hi[a] > container.hi[a] + 1e-12 {
            c.fail(
                path.to_string(),
                format!(
                    "must lie inside the container along {} ([{}, {}]), got [{}, {}]",
                    AXES[a], container.lo[a], container.hi[a], lo[a], hi[a]
                ),
            );
        }
    }
    Aabb { lo, hi }
}

/// Checks one particle set; with `count_from_fill` a randomly placed set may leave its count
/// to the drum's `fill`.
#[allow(clippy::too_many_arguments)]
fn check_set(
    c: &mut Checker,
    path: &str,
    p: &ParticleSetSpec,
    dim: usize,
    material: usize,
    materials: &[Material],
    container: &Container,
    count_from_fill: bool,
) -> ParticleSet {
    let size = match &p.size {
        Some(size) => check_size(c, &format!("{path}.size"), size),
        None => {
            let has_diameters = matches!(&p.placement, PlacementSpec::List { diameters: Some(_), .. });
            if !has_diameters {
                c.fail(format!("{path}.size"), "required (unless a list placement gives diameters)");
            }
            SizeDist::Monodisperse(1.0)
        }
    };
    let placement = match &p.placement {
        PlacementSpec::Random { region } => {
            Placement::Random(check_region(c, &format!("{path}.placement.region"), region.as_ref(), dim, container))
        }
        PlacementSpec::Lattice { lattice, region, spacing, select } => {
            let kind = match (lattice.as_str(), dim) {
                ("square", 2) => LatticeKind::Square,
                ("hexagonal", 2) => LatticeKind::Hexagonal,
                ("cubic", 3) => LatticeKind::Cubic,
                ("fcc", 3) => LatticeKind::Fcc,
                (other, d) => {
                    c.fail(
                        format!("{path}.placement.lattice"),
                        format!("must be one of {} in {d}D, got '{other}'", if d == 2 { "square, hexagonal" } else { "cubic, fcc" }),
                    );
                    LatticeKind::Cubic
                }
            };
            if let Some(s) = spacing {
                c.positive(&format!("{path}.placement.spacing"), *s);
            }
            let random_select = match select.as_deref() {
                None | Some("first") => false,
                Some("random") => true,
                Some(o) => {
                    c.fail(format!("{path}.placement.select"), format!("must be 'first' or 'random', got '{o}'"));
                    false
                }
            };
            Placement::Lattice {
                kind,
                region: check_region(c, &format!("{path}.placement.region"), region.as_ref(), dim, container),
                spacing: *spacing,
                random_select,
            }
        }
        PlacementSpec::List { positions, diameters, velocities } => {
            let mut pos = Vec::with_capacity(positions.len());
            for (i, x) in positions.iter().enumerate() {
                if c.vector(&format!("{path}.placement.positions[{i}]"), x, dim) {
                    pos.push(vec_from_slice(x));
                }
            }
            if let Some(d) = diameters {
                if d.len() != positions.len() {
                    c.fail(
                        format!("{path}.placement.diameters"),
                        format!("must have one diameter per position ({}), got {}", positions.len(), d.len()),
                    );
                }
                for (i, di) in d.iter().enumerate() {
                    c.positive(&format!("{path}.placement.diameters[{i}]"), *di);
                }
            }
            let vel = velocities.as_ref().map(|vs| {
                if vs.len() != positions.len() {
                    c.fail(
                        format!("{path}.placement.velocities"),
                        format!("must have one velocity per position ({}), got {}", positions.len(), vs.len()),
                    );
                }
                vs.iter()
                    .enumerate()
                    .map(|(i, v)| {
                        c.vector(&format!("{path}.placement.velocities[{i}]"), v, dim);
                        vec_from_slice(v)
                    })
                    .collect()
            });
            Placement::List { positions: pos, diameters: diameters.clone(), velocities: vel }
        }
    };
    let count = match (&placement, p.count) {
        (Placement::List { positions, .. }, Some(n)) if n != positions.len() => {
            c.fail(format!("{path}.count"), format!("must equal the number of listed positions ({})", positions.len()));
            n
        }
        (Placement::List { positions, .. }, _) => positions.len(),
        (_, Some(n)) => n,
        // A drum's `fill` sets the count of a random set (after the experiment is checked).
        (Placement::Random(_), None) if count_from_fill => 0,
        (_, None) => {
            c.fail(format!("{path}.count"), "required for random and lattice placement");
            0
        }
    };
    if count == 0 && !matches!(placement, Placement::List { .. }) && p.count.is_some() {
        c.fail(format!("{path}.count"), "must be >= 1");
    }
    if count > MAX_PARTICLES {
        c.fail(format!("{path}.count"), format!("must be at most {MAX_PARTICLES}, got {count}"));
    }
    let velocity = match &p.velocity {
        None | Some(VelocitySpec::Zero) => InitialVelocity::Uniform(Vec3::zeros()),
        Some(VelocitySpec::Uniform { value }) => {
            c.vector(&format!("{path}.velocity.value"), value, dim);
            InitialVelocity::Uniform(vec_from_slice(value))
        }
        Some(VelocitySpec::Gaussian { std }) => {
            c.non_negative(&format!("{path}.velocity.std"), *std);
            InitialVelocity::Gaussian(*std)
        }
    };
    let has_liquid = materials.get(material).is_some_and(|m| m.liquid.is_some());
    let wet_fraction = match p.wet_fraction {
        Some(f) => {
            if c.within(&format!("{path}.wet_fraction"), f, 0.0, 1.0) && f > 0.0 && !has_liquid {
                c.fail(format!("{path}.wet_fraction"), "must be 0 when the material has no liquid");
            }
            f
        }
        None if has_liquid => 1.0,
        None => 0.0,
    };
    let aggregate = p.model.as_ref().map(|m| check_grain_model(c, &format!("{path}.model"), m, dim, &size, materials.get(material)));
    ParticleSet { material, count, size, placement, velocity, wet_fraction, aggregate }
}

/// A size distribution at `path` (`….size`).
fn check_size(c: &mut Checker, path: &str, s: &SizeSpec) -> SizeDist {
    match s {
        SizeSpec::Monodisperse { diameter } => {
            c.positive(&format!("{path}.diameter"), *diameter);
            SizeDist::Monodisperse(*diameter)
        }
        SizeSpec::Uniform { min, max } => {
            c.positive(&format!("{path}.min"), *min);
            if !(max.is_finite() && max >= min) {
                c.fail(format!("{path}.max"), format!("must be >= {path}.min = {min}, got {max}"));
            }
            SizeDist::Uniform { min: *min, max: *max }
        }
        SizeSpec::Bidisperse { diameter, ratio, fraction_small } => {
            c.positive(&format!("{path}.diameter"), *diameter);
            if !(ratio.is_finite() && *ratio >= 1.0) {
                c.fail(format!("{path}.ratio"), format!("must be >= 1, got {ratio}"));
            }
            let f = fraction_small.unwrap_or(0.5);
            c.within(&format!("{path}.fraction_small"), f, 0.0, 1.0);
            SizeDist::Bidisperse { small: *diameter, ratio: *ratio, fraction_small: f }
        }
    }
}

/// Fewest primaries of an aggregate that make a round grain rather than a cluster of a couple
/// of rings.
pub const MIN_ROUND_PRIMARIES: usize = 30;

/// A set's `model` at `path`, for grains of `size` made of `material`.
fn check_grain_model(
    c: &mut Checker,
    path: &str,
    m: &GrainModelSpec,
    dim: usize,
    size: &SizeDist,
    material: Option<&Material>,
) -> AggregateModel {
    let GrainModelSpec::BondedPrimaries { primaries, min_primaries, attraction, friction } = m;
    if material.is_some_and(|m| m.deformable.is_some()) {
        c.fail(format!("{path}.kind"), "bonded_primaries are rigid primaries: give the set a material without `deformable`");
    }
    let primaries = check_size(c, &format!("{path}.primaries"), primaries);
    let min_primaries = min_primaries.unwrap_or(200);
    if min_primaries < MIN_ROUND_PRIMARIES {
        c.fail(
            format!("{path}.min_primaries"),
            format!("must be >= {MIN_ROUND_PRIMARIES} (fewer make a cluster of a couple of rings, not a round grain), got {min_primaries}"),
        );
    }
    let f0 = attraction.force;
    c.positive(&format!("{path}.attraction.force"), f0);
    let gamma = attraction.exponent.unwrap_or(crate::contact::attraction_lj::GAMMA);
    if !(gamma.is_finite() && gamma > 1.0) {
        c.fail(
            format!("{path}.attraction.exponent"),
            format!("must be > 1 (the bond energy F_0 a_0/(γ − 1) is finite only then; the sources use 7), got {gamma}"),
        );
    }
    let (d_min, d_max) = (primaries.min_diameter(), primaries.max_diameter());
    let cutoff = attraction.cutoff.unwrap_or(d_max);
    if !(cutoff.is_finite() && cutoff >= d_min) {
        c.fail(
            format!("{path}.attraction.cutoff"),
            format!(
                "must be at least the smallest primary's diameter {d_min} m (a shorter reach binds only touching primaries), got {cutoff}"
            ),
        );
    }
    let friction = friction.unwrap_or(0.0);
    c.non_negative(&format!("{path}.friction"), friction);
    let model =
        AggregateModel { dim, primaries, min_primaries, bonding: Bonding { attraction: AttractionLj { f0, gamma, cutoff }, friction } };
    let grain = size.min_diameter();
    if d_max.is_finite() && d_max > 0.0 && grain > 0.0 {
        let holds = model.estimated_primaries(grain.powi(dim as i32));
        if holds < min_primaries {
            c.fail(
                format!("{path}.primaries"),
                format!(
                    "the smallest grain ({grain} m) holds about {holds} primaries of this size, fewer than min_primaries ({min_primaries}): make the grains larger or the primaries smaller"
                ),
            );
        }
    }
    model
}

/// Largest overlap of two touching primaries under the attraction `F_0`, as a fraction of the
/// smallest primary's diameter, that DEM accepts: the model's primaries are rigid.
const DEM_PRIMARY_OVERLAP: Real = 0.01;

/// The rules of aggregates bonded by `b` (a set's model, or a saved state's bonding, named by
/// `path`) whose primaries are of material `m`, the smallest `d_min` across, run by DEM: the
/// primaries touch by their material's contact law, which must therefore carry the bond's
/// friction, and hold `F_0` at an overlap of at most [`DEM_PRIMARY_OVERLAP`] of `d_min`.
fn check_dem_aggregate(c: &mut Checker, path: &str, b: crate::particles::aggregate::Bonding, d_min: Real, m: &Material) {
    if b.friction != m.friction {
        c.fail(
            format!("{path}.friction"),
            format!(
                "with method dem the primaries of one aggregate touch by their material's contact law: must equal materials.{}.friction ({}), got {} (method cd takes a friction of its own)",
                m.name, m.friction, b.friction
            ),
        );
    }
    if !(d_min.is_finite() && d_min > 0.0 && b.attraction.f0 > 0.0) {
        return;
    }
    let law = crate::contact::ContactTable::new(std::slice::from_ref(m));
    let overlap = DEM_PRIMARY_OVERLAP * d_min;
    let held = crate::contact::NormalForce::elastic(&law.get(0, 0).normal, overlap, 0.25 * d_min);
    if held < b.attraction.f0 {
        c.fail(
            format!("materials.{}.contact", m.name),
            format!(
                "with method dem the primaries are rigid: their contact must hold the attraction F_0 = {} at an overlap of {:.0}% of the smallest primary's diameter ({overlap:.3e} m), where this law gives {held:.3e} (the linear law needs k_n >= {:.3e})",
                b.attraction.f0,
                100.0 * DEM_PRIMARY_OVERLAP,
                b.attraction.f0 / overlap
            ),
        );
    }
}

fn check_container(
    c: &mut Checker,
    s: &ContainerSpec,
    dim: usize,
    material_index: &dyn Fn(&mut Checker, &str, &str) -> usize,
) -> Container {
    let ok = c.vector("container.min", &s.min, dim) & c.vector("container.max", &s.max, dim);
    let (lo, mut hi) = if ok { (vec_from_slice(&s.min), vec_from_slice(&s.max)) } else { (Vec3::zeros(), Vec3::repeat(1.0)) };
    if dim == 2 {
        hi.z = 0.0;
    }
    for a in 0..dim {
        if ok && lo[a] >= hi[a] {
            c.fail(format!("container.max[{a}]"), format!("must be > container.min[{a}] = {}, got {}", lo[a], hi[a]));
        }
    }
    let mut periodic = [false; 3];
    for (i, name) in s.periodic.iter().enumerate() {
        match AXES[..dim].iter().position(|a| a == name) {
            Some(a) => periodic[a] = true,
            None => {
                c.fail(format!("container.periodic[{i}]"), format!("must be one of {} in {dim}D, got '{name}'", AXES[..dim].join(", ")))
            }
        }
    }
    let mut walls = Vec::new();
    for axis in (0..dim).filter(|&a| !periodic[a]) {
        for upper in [false, true] {
            let face = Face { axis, upper };
            let motion = match s.walls.get(&face.name()) {
                None | Some(WallSpec::Fixed) => WallMotion::Fixed,
                Some(WallSpec::Velocity { velocity }) => {
                    let path = format!("container.walls.{}.velocity", face.name());
                    if c.vector(&path, velocity, dim) {
                        WallMotion::Velocity(vec_from_slice(velocity))
                    } else {
                        WallMotion::Fixed
                    }
                }
                Some(WallSpec::Stress { stress, gain, max_speed }) => {
                    let path = format!("container.walls.{}", face.name());
                    c.positive(&format!("{path}.stress"), *stress);
                    if let Some(g) = gain {
                        c.positive(&format!("{path}.gain"), *g);
                    }
                    if let Some(v) = max_speed {
                        c.positive(&format!("{path}.max_speed"), *v);
                    }
                    WallMotion::Stress { stress: *stress, gain: *gain, max_speed: max_speed.unwrap_or(f64::INFINITY), integral: false }
                }
            };
            walls.push(WallDef { face, motion });
        }
    }
    for key in s.walls.keys() {
        let known = (0..dim).any(|a| [false, true].iter().any(|&u| Face { axis: a, upper: u }.name() == *key));
        if !known {
            c.fail(format!("container.walls.{key}"), "unknown wall; names are x_min, x_max, y_min, y_max (and z_min, z_max in 3D)");
        } else if (0..dim).any(|a| periodic[a] && key.starts_with(AXES[a])) {
            c.fail(format!("container.walls.{key}"), "this axis is periodic: it has no walls");
        }
    }
    let wall_material = match (&s.wall_material, walls.is_empty()) {
        (Some(name), _) => Some(material_index(c, "container.wall_material", name)),
        (None, false) => {
            c.fail("container.wall_material", "required: the container has walls on its non-periodic faces");
            None
        }
        (None, true) => None,
    };
    let lees_edwards = s.lees_edwards.as_ref().map(|le| {
        if !(le.shear_rate.is_finite()) {
            c.fail("container.lees_edwards.shear_rate", "must be a finite number");
        }
        if !(periodic[0] && periodic[1]) {
            c.fail("container.lees_edwards", "requires x and y to be periodic (flow along x, gradient along y)");
        }
        (le.shear_rate, le.initial_profile)
    });
    let deformation = s.deformation.as_ref().map(|d| match d {
        DeformationSpec::StrainRate { rate } => {
            if c.vector("container.deformation.rate", rate, dim) {
                for (a, r) in rate.iter().enumerate() {
                    if *r != 0.0 && !periodic[a] {
                        c.fail(format!("container.deformation.rate[{a}]"), "must be 0 on a non-periodic axis (move its walls instead)");
                    }
                }
            }
            Deformation::StrainRate(vec_from_slice(rate))
        }
        DeformationSpec::Pressure { target, max_strain_rate, gain } => {
            c.positive("container.deformation.target", *target);
            c.positive("container.deformation.max_strain_rate", *max_strain_rate);
            if let Some(g) = gain {
                c.positive("container.deformation.gain", *g);
            }
            if !periodic[..dim].iter().all(|&p| p) {
                c.fail("container.deformation", "a pressure-controlled cell must be periodic on every axis");
            }
            Deformation::Pressure { target: *target, max_strain_rate: *max_strain_rate, gain: gain.unwrap_or(max_strain_rate / target) }
        }
    });
    if lees_edwards.is_some() && deformation.is_some() {
        c.fail("container.deformation", "cannot be combined with lees_edwards in this version");
    }
    Container { lo, hi, periodic, walls, wall_material, lees_edwards, deformation, drum: None, granule: None }
}

fn check_stop(c: &mut Checker, s: &StopSpec, container: &Container) -> Stop {
    if s.time.is_none() && s.steps.is_none() && s.packing_fraction.is_none() && s.strain.is_none() {
        c.fail("stop", "give at least one of time, steps, packing_fraction, strain");
    }
    if let Some(t) = s.time {
        c.positive("stop.time", t);
    }
    if s.steps == Some(0) {
        c.fail("stop.steps", "must be >= 1");
    }
    if let Some(phi) = s.packing_fraction {
        c.within("stop.packing_fraction", phi, 0.0, 1.0);
    }
    if let Some(e) = s.strain {
        c.positive("stop.strain", e);
        let wall_moves = |w: &WallDef| match w.motion {
            WallMotion::Fixed => false,
            WallMotion::Velocity(v) => v[w.face.axis] != 0.0,
            WallMotion::StrainRate(r) => r != 0.0,
            WallMotion::Stress { .. } | WallMotion::Shearing { .. } => true,
        };
        let deforms = container.lees_edwards.is_some_and(|(rate, _)| rate != 0.0)
            || container.deformation.is_some_and(|d| match d {
                Deformation::StrainRate(r) => r != Vec3::zeros(),
                Deformation::Pressure { .. } | Deformation::NormalStress { .. } => true,
            })
            || container.walls.iter().any(wall_moves);
        if !deforms {
            c.fail(
                "stop.strain",
                "the container never changes shape (no wall moving along its normal, no cell deformation, \
                 no Lees-Edwards shear rate): strain would stay 0",
            );
        }
    }
    if (s.packing_fraction.is_some() || s.strain.is_some()) && s.time.is_none() && s.steps.is_none() {
        c.fail("stop", "a packing_fraction or strain target also needs a time or steps limit, in case it is never reached");
    }
    Stop { time: s.time, steps: s.steps, packing_fraction: s.packing_fraction, strain: s.strain }
}

fn check_sampling(c: &mut Checker, s: Option<&SamplingSpec>, stop: &Stop) -> Sampling {
    match s {
        Some(SamplingSpec { every_steps: Some(n), every_time: None }) => {
            if *n == 0 {
                c.fail("sampling.every_steps", "must be >= 1");
            }
            Sampling::Steps((*n).max(1))
        }
        Some(SamplingSpec { every_steps: None, every_time: Some(t) }) => {
            c.positive("sampling.every_time", *t);
            Sampling::Time(*t)
        }
        Some(_) => {
            c.fail("sampling", "give exactly one of every_steps, every_time");
            Sampling::Steps(1000)
        }
        None => match (stop.steps, stop.time) {
            (Some(n), _) => Sampling::Steps((n / 100).max(1)),
            (None, Some(t)) => Sampling::Time(t / 100.0),
            _ => Sampling::Steps(1000),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_with(method: serde_json::Value, restitution: f64) -> String {
        serde_json::json!({
            "dimension": 2, "method": method,
            "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e5}, "restitution": restitution, "friction": 0.3}},
            "particles": [{"material": "glass", "count": 10, "size": {"kind": "monodisperse", "diameter": 0.001}, "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
            "stop": {"steps": 10}
        })
        .to_string()
    }

    fn rules(text: &str) -> Vec<String> {
        match parse_scene(text) {
            Ok(_) => Vec::new(),
            Err(v) => v.iter().map(|v| format!("{}: {}", v.field, v.rule)).collect(),
        }
    }

    /// A scene of 4 aggregate grains of 1.8 mm with the sources' primaries, `model` and
    /// `method` as given, in a box periodic along x if `periodic`.
    fn aggregate_scene(method: serde_json::Value, model: serde_json::Value, periodic: bool) -> String {
        serde_json::json!({
            "dimension": 2, "method": method,
            "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": 1e6}, "restitution": 0.0, "friction": 0.3}},
            "particles": [{"material": "primary", "count": 4, "size": {"kind": "monodisperse", "diameter": 1.8e-3}, "placement": {"kind": "random"}, "model": model}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "primary", "periodic": if periodic { vec!["x"] } else { vec![] }},
            "stop": {"steps": 10}
        })
        .to_string()
    }

    #[test]
    fn aggregates_take_their_defaults_and_run_with_contact_dynamics() {
        let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
        let scene = match parse_scene(&aggregate_scene(serde_json::json!("cd"), model.clone(), false)) {
            Ok(s) => s,
            Err(v) => panic!("{v:?}"),
        };
        let a = scene.sets[0].aggregate.expect("an aggregate set");
        assert_eq!((a.min_primaries, a.bonding.attraction.gamma, a.bonding.attraction.cutoff, a.bonding.friction), (200, 7.0, 1.3e-4, 0.0));
        assert!(matches!(scene.method, Method::Cd(ref p) if p.tolerance == AGGREGATE_TOLERANCE));
        // 4 grains of about 0.70 × (1.8 / 0.1)² primaries (⟨d²⟩ of 0.07–0.13 mm: 1.03e-8 m²).
        assert_eq!(scene.particle_count(), 4 * 220);
        let auto = parse_scene(&aggregate_scene(serde_json::json!("auto"), model.clone(), false)).map(|s| s.method.name());
        assert_eq!(auto, Ok("cd"));
        // A tolerance the scene gives is kept.
        let given = parse_scene(&aggregate_scene(serde_json::json!({"kind": "cd", "tolerance": 1e-4}), model, false));
        assert!(matches!(given.map(|s| s.method), Ok(Method::Cd(p)) if p.tolerance == 1e-4));
    }

    /// Counts that overflow a machine word once multiplied (by an aggregate's primaries) or
    /// added (over sets) are refused, not wrapped into a small count that passes every limit
    /// and then aborts the process that allocates for it.
    #[test]
    fn overflowing_particle_counts_are_refused() {
        let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
        let mut scene: serde_json::Value = serde_json::from_str(&aggregate_scene(serde_json::json!("cd"), model, false)).expect("json");
        // 83848836698679781 × 220 primaries wraps to 204 in 64 bits.
        scene["particles"][0]["count"] = serde_json::json!(83_848_836_698_679_781_u64);
        let r = rules(&scene.to_string());
        assert!(r.iter().any(|r| r.starts_with("particles[0].count: must be at most 1000000000")), "{r:?}");
        // Valid per set, too many once multiplied by the primaries of each grain.
        scene["particles"][0]["count"] = serde_json::json!(20_000_000);
        let r = rules(&scene.to_string());
        assert_eq!(
            r,
            vec!["particles: the scene places at most 1000000000 particles in all (primaries of aggregates included), got 4400000000"]
        );

        // Two sets whose counts add up past u64::MAX (to 1 when wrapped).
        let mut two: serde_json::Value = serde_json::from_str(&scene_with(serde_json::json!("dem"), 0.5)).expect("json");
        let set = two["particles"][0].clone();
        two["particles"] = serde_json::json!([set.clone(), set]);
        two["particles"][0]["count"] = serde_json::json!(u64::MAX);
        two["particles"][1]["count"] = serde_json::json!(2);
        let r = rules(&two.to_string());
        assert!(r.iter().any(|r| r.starts_with("particles[0].count: must be at most")), "{r:?}");
        // Each set valid, their sum not.
        two["particles"][0]["count"] = serde_json::json!(MAX_PARTICLES);
        let r = rules(&two.to_string());
        assert_eq!(
            r,
            vec![format!(
                "particles: the scene places at most {MAX_PARTICLES} particles in all (primaries of aggregates included), got {}",
                MAX_PARTICLES + 2
            )]
        );
        // The count itself saturates rather than wraps.
        let base = parse_scene(&scene_with(serde_json::json!("dem"), 0.5)).expect("valid");
        let set = ParticleSet { count: usize::MAX, ..base.sets[0].clone() };
        let big = Scene { sets: vec![set.clone(), ParticleSet { count: 2, ..set }], ..base };
        assert_eq!(big.particle_count(), usize::MAX);
    }

    #[test]
    fn bad_aggregates_are_named_field_by_field() {
        let bad = serde_json::json!({
            "kind": "bonded_primaries",
            "primaries": {"kind": "uniform", "min": 7e-5, "max": 5e-5},
            "min_primaries": 10,
            "attraction": {"force": -1.0, "exponent": 0.5, "cutoff": 1e-6},
            "friction": -0.1
        });
        let r = rules(&aggregate_scene(serde_json::json!("mpm"), bad, true));
        for want in [
            "particles[0].model.primaries.max: must be >=",
            "particles[0].model.min_primaries: must be >= 30",
            "particles[0].model.attraction.force: must be > 0",
            "particles[0].model.attraction.exponent: must be > 1",
            "particles[0].model.attraction.cutoff: must be at least the smallest primary's diameter",
            "particles[0].model.friction: must be >= 0",
            "method: particles[0] are bonded_primaries aggregates, which run by contact dynamics as in the sources or by DEM",
        ] {
            assert!(r.iter().any(|x| x.starts_with(want)), "missing '{want}' in {r:#?}");
        }
        // By DEM, the primaries touch by their material's law: its friction (0.3) must be the
        // bond's (0 by default), and its k_n (1e6 N/m) must hold F_0 = 100 N/m at 1% of the
        // smallest primary (7e-7 m): 1.43e8 N/m at least.
        let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
        let r = rules(&aggregate_scene(serde_json::json!("dem"), model, false));
        for want in [
            "particles[0].model.friction: with method dem the primaries of one aggregate touch by their material's contact law: must equal materials.primary.friction (0.3), got 0",
            "materials.primary.contact: with method dem the primaries are rigid",
        ] {
            assert!(r.iter().any(|x| x.starts_with(want)), "missing '{want}' in {r:#?}");
        }
        assert!(r.iter().any(|x| x.contains("k_n >= 1.429e8")), "{r:#?}");
        assert!(!r.iter().any(|x| x.starts_with("method:")), "{r:#?}");
        // The same rules for the aggregates a saved state holds: two primaries of 0.1 and
        // 0.12 mm bonded by F_0 = 100 N/m need k_n >= 100 / 1e-6 = 1e8 N/m.
        let state = serde_json::json!({
            "format": "sable-state", "version": 1, "dimension": 2, "min": [0.0, 0.0], "max": [1e-3, 1e-3],
            "materials": ["primary"],
            "particles": {
                "material": [0, 0], "radius": [5e-5, 6e-5], "position": [[4e-4, 5e-4], [5.1e-4, 5e-4]],
                "velocity": [[0.0, 0.0], [0.0, 0.0]], "angular_velocity": [[0.0], [0.0]], "aggregate": [0, 0]
            },
            "bondings": [{"force": 100.0, "exponent": 7.0, "cutoff": 1.3e-4, "friction": 0.0}]
        });
        let saved = |k_n: f64, friction: f64| {
            rules(
                &serde_json::json!({
                    "dimension": 2, "method": "dem",
                    "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.2, "friction": friction}},
                    "start_from": {"state": state}, "container": {"wall_material": "primary"}, "stop": {"steps": 10}
                })
                .to_string(),
            )
        };
        assert!(saved(1.1e8, 0.0).is_empty(), "{:#?}", saved(1.1e8, 0.0));
        let r = saved(1e6, 0.3);
        assert!(r.iter().any(|x| x.starts_with("start_from.state.bondings[0].friction: with method dem")), "{r:#?}");
        assert!(r.iter().any(|x| x.starts_with("materials.primary.contact: with method dem") && x.contains("k_n >= 1.000e8")), "{r:#?}");
        // Grains too small for their primaries.
        let small = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "monodisperse", "diameter": 2e-4}, "attraction": {"force": 100.0}});
        let r = rules(&aggregate_scene(serde_json::json!("cd"), small, false));
        assert!(
            r.iter().any(|x| x.starts_with("particles[0].model.primaries: the smallest grain (0.0018 m) holds about 56 primaries")),
            "{r:#?}"
        );
        // Periodic along x: the period (0.01 m) must exceed twice the largest grain.
        let wide = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
        assert!(!rules(&aggregate_scene(serde_json::json!("cd"), wide.clone(), true)).iter().any(|x| x.starts_with("container.max")));
        let big = aggregate_scene(serde_json::json!("cd"), wide, true).replace("0.0018", "0.0051");
        let r = rules(&big);
        assert!(
            r.iter().any(|x| x.starts_with("container.max[0]: the period along x (0.01 m) must exceed twice the largest grain")),
            "{r:#?}"
        );
        // In 3D the estimate is 0.39 × D³/⟨d³⟩: a grain of 0.9 mm holds about 260 of the
        // sources' primaries (⟨d³⟩ 1.09e-12 m³), one of 0.5 mm about 44, fewer than 200.
        let in_3d = |diameter: f64| {
            serde_json::json!({
                "dimension": 3, "method": "dem",
                "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": 3e4}, "restitution": 0.2, "friction": 0.0}},
                "particles": [{"material": "primary", "size": {"kind": "monodisperse", "diameter": diameter},
                    "placement": {"kind": "list", "positions": [[1e-3, 1e-3, 1e-3]]},
                    "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 0.01}}}],
                "container": {"min": [0.0, 0.0, 0.0], "max": [2e-3, 2e-3, 2e-3], "wall_material": "primary"},
                "stop": {"steps": 10}
            })
            .to_string()
        };
        assert_eq!(parse_scene(&in_3d(0.9e-3)).map(|s| s.particle_count()), Ok(260));
        let r = rules(&in_3d(0.5e-3));
        assert!(
            r.iter().any(|x| x.starts_with("particles[0].model.primaries: the smallest grain (0.0005 m) holds about 44 primaries")),
            "{r:#?}"
        );
        // The method name `bpm` points to the model.
        let r = rules(&scene_with(serde_json::json!("bpm"), 0.5));
        assert!(r.iter().any(|x| x.starts_with("method: the bonded particle method is a model of the grains")), "{r:#?}");
    }

    #[test]
    fn contact_dynamics_parameters_are_checked_by_path_and_rule() {
        let ok = parse_scene(&scene_with(serde_json::json!({"kind": "cd", "time_step": 1e-4, "theta": 0.6, "tolerance": 1e-6}), 0.5));
        match ok.map(|s| s.method) {
            Ok(Method::Cd(p)) => {
                assert_eq!(
                    (p.time_step, p.theta, p.tolerance, p.max_iterations),
                    (Some(1e-4), 0.6, 1e-6, CdParams::default().max_iterations)
                )
            }
            other => panic!("{other:?}"),
        }
        let bad = rules(&scene_with(
            serde_json::json!({"kind": "cd", "theta": 0.3, "max_iterations": 0, "loading_violation_tolerance": 0.5, "relaxation": 1.5, "acceleration": 1.0, "time_step": 1e-4, "max_displacement": 0.1}),
            0.5,
        ));
        assert_eq!(
            bad,
            vec![
                "method.max_displacement: give either time_step or max_displacement, not both",
                "method.theta: must be between 0.5 and 1, got 0.3",
                "method.max_iterations: must be between 1 and 1000000, got 0",
                "method.loading_violation_tolerance: must be between 0.00000000000001 and 0.1, got 0.5",
                "method.relaxation: must be in (0, 1], got 1.5",
                "method.acceleration: must be in [0, 1), got 1",
            ]
        );
        let slop = rules(&scene_with(serde_json::json!({"kind": "cd", "slop": 0.05}), 0.5));
        assert_eq!(slop, vec!["method.slop: must be below method.max_interpenetration (0.05), got 0.05"]);
        match parse_scene(&scene_with(serde_json::json!({"kind": "cd", "slop": 0.02}), 0.5)).map(|s| s.method) {
            Ok(Method::Cd(p)) => assert_eq!(p.slop, 0.02),
            other => panic!("{other:?}"),
        }
        let unknown = rules(&scene_with(serde_json::json!({"kind": "cd", "skn": 0.1}), 0.5));
        assert_eq!(unknown.len(), 1);
        assert!(unknown[0].starts_with("method.skn: unknown field"), "{unknown:?}");
        let sweep = rules(&scene_with(serde_json::json!({"kind": "cd", "sweep": "parallel"}), 0.5));
        assert_eq!(sweep.len(), 1);
        assert!(
            sweep[0].starts_with("method.sweep: unknown variant `parallel`, expected one of `auto`, `serial`, `coloured`"),
            "{sweep:?}"
        );
        match parse_scene(&scene_with(serde_json::json!({"kind": "cd", "sweep": "coloured"}), 0.5)).map(|s| s.method) {
            Ok(Method::Cd(p)) => assert_eq!(p.sweep, Sweep::Coloured),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn zero_restitution_is_an_impact_law_for_contact_dynamics_only() {
        assert!(rules(&scene_with(serde_json::json!("cd"), 0.0)).is_empty());
        assert_eq!(rules(&scene_with(serde_json::json!("dem"), 0.0)), vec!["materials.glass.restitution: must be > 0 and <= 1, got 0"]);
        assert_eq!(
            rules(&scene_with(serde_json::json!("cd"), 1.5)),
            vec!["materials.glass.restitution: must be >= 0 and <= 1 with method cd, got 1.5"]
        );
    }

    fn soft_scene(method: serde_json::Value, law: serde_json::Value, extra: serde_json::Value) -> String {
        let mut v = serde_json::json!({
            "dimension": 2,
            "method": method,
            "materials": {"rubber": {"density": 990, "friction": 0.5, "deformable": law}},
            "particles": [{"material": "rubber", "count": 4, "size": {"kind": "monodisperse", "diameter": 0.002}, "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "rubber"},
            "stop": {"steps": 10}
        });
        if let (Some(o), Some(e)) = (v.as_object_mut(), extra.as_object()) {
            for (k, x) in e {
                o.insert(k.clone(), x.clone());
            }
        }
        v.to_string()
    }

    #[test]
    fn a_deformable_scene_parses_with_method_mpm() {
        let law = serde_json::json!({"law": "neo_hookean", "shear_modulus": 1.5e6, "lambda": 3e6});
        let scene = parse_scene(&soft_scene(serde_json::json!({"kind": "mpm", "cells_per_diameter": 5}), law, serde_json::json!({})))
            .expect("valid");
        match &scene.method {
            Method::Mpm(p) => assert_eq!((p.cells_per_diameter, p.points_per_cell, p.theta), (5.0, 2, 1.0)),
            other => panic!("method {}", other.name()),
        }
        let m = &scene.materials[0];
        assert_eq!(m.deformable, Some(LawSpec::NeoHookean { shear_modulus: 1.5e6, lambda: 3e6 }));
        // The advisor's elastic constants: E = μ(3λ + 2μ)/(λ + μ), ν = λ / 2(λ + μ).
        assert_eq!(m.law, ElasticLaw::HertzMindlin { young: 1.5e6 * 12e6 / 4.5e6, poisson: 3e6 / 9e6 });
    }

    /// Every bad parameter of a deformable material and of method mpm named at once.
    #[test]
    fn bad_deformable_input_names_every_field() {
        let law =
            serde_json::json!({"law": "elastoplastic", "young_modulus": 0, "poisson_ratio": 0.5, "yield_stress": -1, "hardening": -2});
        let got = rules(&soft_scene(
            serde_json::json!({"kind": "mpm", "cells_per_diameter": 0.5, "points_per_cell": 1, "theta": 0.2, "max_newton": 0}),
            law,
            serde_json::json!({}),
        ));
        for want in [
            "materials.rubber.deformable.young_modulus: must be > 0",
            "materials.rubber.deformable.poisson_ratio: must be > -1 and < 0.5, got 0.5",
            "materials.rubber.deformable.yield_stress: must be > 0",
            "materials.rubber.deformable.hardening: must be >= 0",
            "method.cells_per_diameter: must be >= 1 (a grid cell larger than the smallest grain cannot tell its shape), got 0.5",
            "method.theta: must be",
            "method.max_newton: must be >= 1",
        ] {
            assert!(got.iter().any(|g| g.starts_with(want)), "missing {want:?} in {got:#?}");
        }
        let neo = rules(&soft_scene(
            serde_json::json!("mpm"),
            serde_json::json!({"law": "neo_hookean", "shear_modulus": -1, "lambda": -3}),
            serde_json::json!({}),
        ));
        assert!(neo.iter().any(|g| g.starts_with("materials.rubber.deformable.shear_modulus: must be > 0")), "{neo:?}");
        assert!(neo.iter().any(|g| g.starts_with("materials.rubber.deformable.lambda: must be >= 0")), "{neo:?}");
        let few = rules(&soft_scene(
            serde_json::json!({"kind": "mpm", "cells_per_diameter": 1, "points_per_cell": 1}),
            serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45}),
            serde_json::json!({}),
        ));
        assert!(few.iter().any(|g| g.starts_with("method.points_per_cell: gives 1 point(s) across the smallest grain")), "{few:?}");
    }

    /// Method `fem`: its own knob named with its rule, the knobs it shares with `mpm` under the
    /// same names and rules, and the same fit rules named for `fem`; a sound scene passes.
    #[test]
    fn fem_params_and_fit_are_checked() {
        let law = serde_json::json!({"law": "neo_hookean", "shear_modulus": 1.5e5, "lambda": 1.5e7});
        let got = rules(&soft_scene(
            serde_json::json!({"kind": "fem", "elements_per_diameter": 1.5, "theta": 0.2, "max_newton": 0}),
            law.clone(),
            serde_json::json!({"dimension": 3, "container": {"min": [0, 0, 0], "max": [0.01, 0.01, 0.01], "wall_material": "rubber"}}),
        ));
        for want in [
            "method.elements_per_diameter: must be >= 2 (an element larger than half the smallest grain cannot tell its shape), got 1.5",
            "method.theta: must be",
            "method.max_newton: must be >= 1",
            "dimension: method fem is 2D",
        ] {
            assert!(got.iter().any(|g| g.starts_with(want)), "missing {want:?} in {got:#?}");
        }
        let grid = rules(&soft_scene(serde_json::json!({"kind": "fem", "points_per_cell": 2}), law.clone(), serde_json::json!({})));
        assert!(grid.iter().any(|g| g.starts_with("method.points_per_cell: unknown field")), "{grid:?}");
        let rigid = rules(&scene_with(serde_json::json!("fem"), 0.5));
        assert!(rigid.iter().any(|g| g.starts_with("particles[0].material: method fem needs deformable grains")), "{rigid:?}");
        let scene =
            parse_scene(&soft_scene(serde_json::json!({"kind": "fem", "elements_per_diameter": 6}), law.clone(), serde_json::json!({})))
                .expect("valid");
        match scene.method {
            Method::Fem(p) => assert_eq!((p.elements_per_diameter, p.theta, p.symmetric_contact), (6.0, 1.0, true)),
            other => panic!("method {}", other.name()),
        }
        // Both grains' boundaries are held by default for fem, one side for mpm; each may be set.
        let sides =
            |method: serde_json::Value| match parse_scene(&soft_scene(method, law.clone(), serde_json::json!({}))).expect("valid").method {
                Method::Fem(p) => p.symmetric_contact,
                Method::Mpm(p) => p.symmetric_contact.expect("mpm given symmetric_contact"),
                other => panic!("method {}", other.name()),
            };
        assert!(!sides(serde_json::json!({"kind": "fem", "symmetric_contact": false})));
        assert!(sides(serde_json::json!({"kind": "mpm", "symmetric_contact": true})));
        assert!(!sides(serde_json::json!({"kind": "mpm", "symmetric_contact": false})));
        // mpm left to choose: it decides by the grains' law when it is built.
        match parse_scene(&soft_scene(serde_json::json!({"kind": "mpm"}), law.clone(), serde_json::json!({}))).expect("valid").method {
            Method::Mpm(p) => assert_eq!(p.symmetric_contact, None),
            other => panic!("method {}", other.name()),
        }
        let bad = rules(&soft_scene(serde_json::json!({"kind": "mpm", "symmetric_contact": 1}), law, serde_json::json!({})));
        assert!(bad.iter().any(|g| g.starts_with("method.symmetric_contact: invalid type: integer `1`, expected a boolean")), "{bad:?}");
    }

    /// Deformable grains need mpm, mpm needs deformable grains in a 2D box with walls; a contact
    /// law or restitution on a deformable material is refused.
    #[test]
    fn deformable_grains_and_methods_must_fit() {
        let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
        let dem = rules(&soft_scene(serde_json::json!("dem"), law.clone(), serde_json::json!({})));
        assert_eq!(
            dem,
            vec!["particles[0].material: 'rubber' is deformable: its grains need method mpm or fem (method dem moves rigid grains)"]
        );
        let periodic = rules(&soft_scene(
            serde_json::json!("mpm"),
            law.clone(),
            serde_json::json!({"container": {"min": [0, 0], "max": [0.01, 0.01], "periodic": ["x"], "wall_material": "rubber"}, "dimension": 3}),
        ));
        assert!(periodic.iter().any(|g| g.starts_with("container.periodic: not with method mpm")), "{periodic:?}");
        assert!(periodic.iter().any(|g| g.starts_with("dimension: method mpm is 2D")), "{periodic:?}");
        let mut both: serde_json::Value =
            serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law, serde_json::json!({}))).expect("json");
        both["materials"]["rubber"]["restitution"] = serde_json::json!(0.5);
        both["materials"]["rubber"]["contact"] = serde_json::json!({"law": "linear", "k_n": 1e5});
        let got = rules(&both.to_string());
        assert!(got.iter().any(|g| g.starts_with("materials.rubber.contact: not for a deformable material")), "{got:?}");
        assert!(got.iter().any(|g| g.starts_with("materials.rubber.restitution: not for a deformable material")), "{got:?}");
        let rigid = rules(&scene_with(serde_json::json!("mpm"), 0.5));
        assert!(rigid.iter().any(|g| g.starts_with("particles[0].material: method mpm needs deformable grains")), "{rigid:?}");
        let mut missing: serde_json::Value = serde_json::from_str(&scene_with(serde_json::json!("dem"), 0.5)).expect("json");
        let glass = missing["materials"]["glass"].as_object_mut().expect("object");
        glass.remove("contact");
        glass.remove("restitution");
        let got = rules(&missing.to_string());
        assert!(
            got.contains(&"materials.glass.contact: required (the elastic contact law), unless the material is deformable".to_string()),
            "{got:?}"
        );
        assert!(got.contains(&"materials.glass.restitution: required, unless the material is deformable".to_string()), "{got:?}");
    }

    /// Stress walls with `mpm` need the speed that sets the step; the experiments it cannot run
    /// are named; those it can run pass.
    #[test]
    fn mpm_takes_stress_walls_and_its_experiments() {
        let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
        let box_with = |walls: serde_json::Value| serde_json::json!({"container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "rubber", "walls": walls}});
        let unbounded = rules(&soft_scene(
            serde_json::json!("mpm"),
            law.clone(),
            box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4}})),
        ));
        assert_eq!(
            unbounded,
            vec!["container.walls.y_max.max_speed: required with method mpm (unless method.time_step is given): the fastest wall sets the time step"]
        );
        let bounded = box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4, "max_speed": 0.1}}));
        assert!(parse_scene(&soft_scene(serde_json::json!("mpm"), law.clone(), bounded)).is_ok());
        let stepped = serde_json::json!({"kind": "mpm", "time_step": 1e-4});
        let unbounded = box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4}}));
        assert!(parse_scene(&soft_scene(stepped, law.clone(), unbounded)).is_ok());
        let mut drum: serde_json::Value =
            serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law.clone(), serde_json::json!({}))).expect("json");
        drum.as_object_mut().expect("object").remove("stop");
        drum["experiment"] = serde_json::json!({"kind": "deposition"});
        let got = rules(&drum.to_string());
        assert!(
            got.iter().any(|g| g.starts_with("experiment.kind: the deposition experiment is not available with method mpm")),
            "{got:?}"
        );
        let mut biaxial: serde_json::Value =
            serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law, serde_json::json!({}))).expect("json");
        biaxial.as_object_mut().expect("object").remove("stop");
        biaxial["experiment"] =
            serde_json::json!({"kind": "biaxial", "preparation": {"pressure": 1e4}, "strain_rate": 1.0, "axial_strain": 0.05});
        assert!(parse_scene(&biaxial.to_string()).is_ok(), "{:?}", rules(&biaxial.to_string()));
    }

    /// `auto` takes the material point method for deformable grains, and says why.
    #[test]
    fn auto_takes_mpm_for_deformable_grains() {
        let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
        let scene = parse_scene(&soft_scene(serde_json::json!("auto"), law, serde_json::json!({}))).expect("valid");
        assert!(matches!(scene.method, Method::Mpm(_)), "auto chose {}", scene.method.name());
        assert!(
            scene.method_reason.starts_with("auto chose mpm: deformable grains (materials.rubber.deformable)"),
            "{}",
            scene.method_reason
        );
    }
}
