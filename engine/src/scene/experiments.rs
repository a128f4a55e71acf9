//! The standard experiments of a scene (`experiment` section): their checks, defaults, and the
//! stages they expand into (preparation, loading), which the runner executes in order.

use super::model::*;
use super::spec::*;
use super::violation::Checker;
use crate::math::{Real, Vec3, AXES};
use crate::particles::Particles;

/// Default step limit of a stage that runs until equilibrium.
pub const DEFAULT_MAX_STEPS: u64 = 2_000_000;
/// Inertial number of the default preparation rate (fast against the loading, still far
/// below the collisional regime).
pub const PREPARATION_INERTIAL_NUMBER: Real = 1e-2;
/// Inertial number of the default loading rate of the biaxial and triaxial tests: half the
/// quasi-static bound 1e-3 (Roux & Chevoir 2005, §2.3.4; the sources keep I < 1e-3, Nezamabadi 2020, §2.2).
pub const LOADING_INERTIAL_NUMBER: Real = 5e-4;
/// Default cushion of local damping during the preparation (Yade's usual 0.2).
pub const PREPARATION_DAMPING: Real = 0.2;

/// Grain scales used by the defaults: number-mean diameter (m) and solid density (kg/m³) of the
/// first particle set.
pub struct GrainScales {
    /// Mean diameter, m.
    pub diameter: Real,
    /// Density, kg/m³.
    pub density: Real,
    /// Total solid volume (area in 2D) of the grains, m³ (expected value for random sizes).
    pub solid_volume: Real,
    /// Largest capillary force between wet grains of the mean size, `2π γ cos θ <d>/2`, N;
    /// `None` when no grain is wet.
    pub capillary_force: Option<Real>,
}

fn check_equilibrium(c: &mut Checker, path: &str, s: Option<&EquilibriumSpec>) -> Equilibrium {
    let d = Equilibrium::default();
    let Some(s) = s else { return d };
    let mut e = d;
    if let Some(x) = s.kinetic_ratio {
        c.positive(&format!("{path}.kinetic_ratio"), x);
        e.kinetic_ratio = x;
    }
    if let Some(x) = s.unbalanced_force {
        c.positive(&format!("{path}.unbalanced_force"), x);
        e.unbalanced_force = x;
    }
    if let Some(x) = s.stress_tolerance {
        c.positive(&format!("{path}.stress_tolerance"), x);
        e.stress_tolerance = x;
    }
    if let Some(n) = s.check_every {
        if n == 0 {
            c.fail(format!("{path}.check_every"), "must be >= 1");
        }
        e.check_every = n.max(1);
    }
    if let Some(n) = s.consecutive {
        if n == 0 {
            c.fail(format!("{path}.consecutive"), "must be >= 1");
        }
        e.consecutive = Some(n.max(1));
    }
    e
}

/// A step limit (>= 1), `default` when absent (`u64::MAX`: none).
fn check_max_steps(c: &mut Checker, path: &str, n: Option<u64>, default: u64) -> u64 {
    match n {
        Some(0) => {
            c.fail(path, "must be >= 1");
            1
        }
        Some(n) => n,
        None => default,
    }
}

fn check_preparation(c: &mut Checker, path: &str, s: &PreparationSpec, g: &GrainScales) -> Preparation {
    c.positive(&format!("{path}.pressure"), s.pressure);
    let friction = s.friction.unwrap_or(0.0);
    c.non_negative(&format!("{path}.friction"), friction);
    let default_rate = PREPARATION_INERTIAL_NUMBER / g.diameter * (s.pressure.max(0.0) / g.density).sqrt();
    let max_strain_rate = s.max_strain_rate.unwrap_or(default_rate);
    if s.max_strain_rate.is_some() {
        c.positive(&format!("{path}.max_strain_rate"), max_strain_rate);
    }
    let local_damping = s.local_damping.unwrap_or(PREPARATION_DAMPING);
    if !(0.0..1.0).contains(&local_damping) {
        c.fail(format!("{path}.local_damping"), format!("must be in [0, 1), got {local_damping}"));
    }
    Preparation {
        pressure: s.pressure,
        friction,
        max_strain_rate,
        local_damping,
        equilibrium: check_equilibrium(c, &format!("{path}.equilibrium"), s.equilibrium.as_ref()),
        max_steps: check_max_steps(c, &format!("{path}.max_steps"), s.max_steps, DEFAULT_MAX_STEPS),
    }
}

fn check_axis(c: &mut Checker, path: &str, name: Option<&str>, dim: usize) -> usize {
    match name {
        None => dim - 1,
        Some(n) => match AXES[..dim].iter().position(|a| *a == n) {
            Some(a) => a,
            None => {
                c.fail(path, format!("must be one of {} in {dim}D, got '{n}'", AXES[..dim].join(", ")));
                dim - 1
            }
        },
    }
}

/// Checks the experiment section against the container and returns the experiment with its
/// stages.
pub(crate) fn check_experiment(
    c: &mut Checker,
    s: &ExperimentSpec,
    dim: usize,
    container: &Container,
    grains: &GrainScales,
    gravity: &Vec3,
) -> (Experiment, Vec<Stage>) {
    let walled = container.periodic[..dim].iter().all(|p| !p);
    let periodic = container.periodic[..dim].iter().all(|&p| p);
    let need_walls = |c: &mut Checker, kind: &str| {
        if !walled {
            c.fail(
                "container.periodic",
                format!("the {kind} experiment needs walls on every face (a box with no periodic axis) in this version"),
            );
        }
    };
    if container.lees_edwards.is_some() || container.deformation.is_some() {
        c.fail("experiment", "an experiment sets the boundaries itself: remove container.lees_edwards and container.deformation");
    }
    if container.walls.iter().any(|w| w.motion != WallMotion::Fixed) {
        c.fail("container.walls", "an experiment moves the walls itself: leave them fixed in the container");
    }
    let experiment = match s {
        ExperimentSpec::Isotropic(i) => {
            if !(walled || periodic) {
                c.fail("container.periodic", "the isotropic experiment needs walls on every face or a fully periodic box");
            }
            Experiment::Isotropic { preparation: check_preparation(c, "experiment.preparation", &i.preparation, grains) }
        }
        ExperimentSpec::Biaxial(t) | ExperimentSpec::Triaxial(t) => {
            let (kind, want) = if matches!(s, ExperimentSpec::Biaxial(_)) { ("biaxial", 2) } else { ("triaxial", 3) };
            if dim != want {
                let other = if want == 2 { "triaxial" } else { "biaxial" };
                c.fail("experiment.kind", format!("'{kind}' is the {want}D test; in {dim}D use '{other}'"));
            }
            need_walls(c, kind);
            let preparation = check_preparation(c, "experiment.preparation", &t.preparation, grains);
            let axis = check_axis(c, "experiment.axis", t.axis.as_deref(), dim);
            let default_rate = LOADING_INERTIAL_NUMBER / grains.diameter * (preparation.pressure.max(0.0) / grains.density).sqrt();
            let strain_rate = t.strain_rate.unwrap_or(default_rate);
            if t.strain_rate.is_some() {
                c.positive("experiment.strain_rate", strain_rate);
            }
            let axial_strain = t.axial_strain.unwrap_or(0.2);
            if !(axial_strain > 0.0 && axial_strain < 1.0) {
                c.fail("experiment.axial_strain", format!("must be in (0, 1), got {axial_strain}"));
            }
            let max_steps = check_max_steps(c, "experiment.max_steps", t.max_steps, u64::MAX);
            Experiment::Triaxial { preparation, axis, strain_rate, axial_strain, max_steps }
        }
        ExperimentSpec::PlaneShear(k) => {
            let rough_walls = match k.boundary.as_deref() {
                None | Some("lees_edwards") => false,
                Some("rough_walls") => true,
                Some(other) => {
                    c.fail("experiment.boundary", format!("must be lees_edwards or rough_walls, got '{other}'"));
                    false
                }
            };
            if !rough_walls && !periodic {
                c.fail("container.periodic", "the plane_shear experiment needs a fully periodic box (a Lees-Edwards cell)");
            }
            let only_y_walled = (0..dim).all(|a| container.periodic[a] == (a != 1));
            if rough_walls && !only_y_walled {
                let others = if dim == 2 { "x" } else { "x and z" };
                c.fail(
                    "container.periodic",
                    format!("plane shear between rough walls needs walls on y only: make {others} periodic, not y"),
                );
            }
            let preparation = check_preparation(c, "experiment.preparation", &k.preparation, grains);
            let scale = (preparation.pressure.max(0.0) / grains.density).sqrt() / grains.diameter;
            let shear_rate = match (k.shear_rate, k.inertial_number) {
                (Some(r), None) => {
                    c.positive("experiment.shear_rate", r);
                    r
                }
                (None, i) => {
                    let i = i.unwrap_or(1e-2);
                    c.positive("experiment.inertial_number", i);
                    i * scale
                }
                (Some(_), Some(_)) => {
                    c.fail("experiment", "give shear_rate or inertial_number, not both");
                    1.0
                }
            };
            let strain = k.strain.unwrap_or(5.0);
            c.positive("experiment.strain", strain);
            let max_steps = check_max_steps(c, "experiment.max_steps", k.max_steps, u64::MAX);
            Experiment::PlaneShear { preparation, rough_walls, shear_rate, strain, max_steps }
        }
        ExperimentSpec::Deposition(k) => {
            // Gravity along one axis, towards a wall.
            let along: Vec<usize> = (0..dim).filter(|&a| gravity[a] != 0.0).collect();
            let axis = match along.as_slice() {
                [a] => *a,
                [] => {
                    c.fail("gravity", "required by the deposition experiment: the grains fall along it");
                    dim - 1
                }
                _ => {
                    c.fail("gravity", "must point along one axis for the deposition experiment (tilt the box instead)");
                    dim - 1
                }
            };
            if container.periodic[axis] {
                c.fail(
                    "container.periodic",
                    format!("the deposition needs a floor: {} (the axis of gravity) must not be periodic", AXES[axis]),
                );
            }
            let local_damping = k.local_damping.unwrap_or(0.0);
            if !(0.0..1.0).contains(&local_damping) {
                c.fail("experiment.local_damping", format!("must be in [0, 1), got {local_damping}"));
            }
            Experiment::Deposition {
                axis,
                floor_upper: gravity[axis] > 0.0,
                local_damping,
                equilibrium: check_equilibrium(c, "experiment.equilibrium", k.equilibrium.as_ref()),
                max_steps: check_max_steps(c, "experiment.max_steps", k.max_steps, DEFAULT_MAX_STEPS),
            }
        }
        ExperimentSpec::Drum(k) => check_drum(c, k, dim, container, gravity),
        ExperimentSpec::GranuleCompression(k) => {
            need_walls(c, "granule_compression");
            check_granule(c, k, dim, container, grains, gravity)
        }
        ExperimentSpec::Compaction(k) => {
            need_walls(c, "compaction");
            let axis = check_axis(c, "experiment.axis", k.axis.as_deref(), dim);
            let drive = match (k.velocity, k.stress) {
                (Some(v), None) => {
                    c.positive("experiment.velocity", v);
                    let strain = match k.strain {
                        Some(e) => {
                            if !(e > 0.0 && e < 5.0) {
                                c.fail("experiment.strain", format!("must be in (0, 5), got {e}"));
                            }
                            e
                        }
                        None => {
                            c.fail("experiment.strain", "required with velocity: the strain |ln(h/h_i)| at which the test ends");
                            1.0
                        }
                    };
                    for (field, set) in [("max_speed", k.max_speed.is_some()), ("equilibrium", k.equilibrium.is_some())] {
                        if set {
                            c.fail(format!("experiment.{field}"), "only with stress (a stress-controlled wall)");
                        }
                    }
                    CompactionDrive::Velocity { speed: v, strain }
                }
                (None, Some(sigma)) => {
                    c.positive("experiment.stress", sigma);
                    if k.strain.is_some() {
                        c.fail("experiment.strain", "only with velocity: a stress-controlled compaction ends at equilibrium");
                    }
                    let max_speed = k.max_speed.unwrap_or(f64::INFINITY);
                    if k.max_speed.is_some() {
                        c.positive("experiment.max_speed", max_speed);
                    }
                    CompactionDrive::Stress {
                        stress: sigma,
                        max_speed,
                        equilibrium: check_equilibrium(c, "experiment.equilibrium", k.equilibrium.as_ref()),
                    }
                }
                _ => {
                    c.fail("experiment", "give exactly one of velocity (with strain) and stress");
                    CompactionDrive::Velocity { speed: 1.0, strain: 1.0 }
                }
            };
            Experiment::Compaction { axis, drive, max_steps: check_max_steps(c, "experiment.max_steps", k.max_steps, DEFAULT_MAX_STEPS) }
        }
    };
    let stages = experiment.stages(container);
    (experiment, stages)
}

/// Grains whose surface lies within this fraction of the mean diameter of a wall are glued to
/// it when plane shear between rough walls starts: the layer in contact with the wall at the
/// end of the preparation, a bumpy surface one grain thick.
pub const ROUGH_LAYER: Real = 0.5;

/// Packing fraction at which the grains fill the granule's starting ball by default (a loose
/// gas the random placement reaches easily: it jams near 0.38 in 3D, 0.55 in 2D).
pub const GRANULE_GAS_FRACTION: [Real; 2] = [0.45, 0.25];
/// Default centripetal field, as a multiple of the capillary force over a mean grain's mass:
/// it packs the grains into a granule (Z ≈ 5.3 with 300 grains, against 4.4 at a tenth of it,
/// whose loose granule then hardened as it was squeezed) without overlaps beyond a few
/// thousandths of a diameter (ten times more overlapped by 10% within 500 steps).
pub const GRANULE_FIELD: Real = 1.0;
/// Default inertial number of the compression at the capillary stress
/// `σ_c = f_c / <d>^(D-1)`: `ε̇ = I / <d> × sqrt(σ_c / ρ)`.
pub const GRANULE_INERTIAL_NUMBER: Real = 1e-3;

fn check_granule(
    c: &mut Checker,
    k: &GranuleCompressionSpec,
    dim: usize,
    container: &Container,
    g: &GrainScales,
    gravity: &Vec3,
) -> Experiment {
    let axis = check_axis(c, "experiment.axis", k.axis.as_deref(), dim);
    if *gravity != Vec3::zeros() {
        c.fail("gravity", "must be absent for the granule_compression experiment (the granule floats between the plates)");
    }
    let Some(f_c) = g.capillary_force else {
        c.fail("particles", "the granule_compression experiment needs wet grains: a material with liquid and wet_fraction > 0");
        return Experiment::GranuleCompression {
            ball: Ball { center: Vec3::zeros(), radius: 1.0 },
            axis,
            acceleration: 1.0,
            strain_rate: 1.0,
            strain: 0.3,
            plateau: (0.05, 0.2),
            local_damping: 0.0,
            equilibrium: Equilibrium::default(),
            max_steps: 1,
        };
    };
    let unit = Particles::volume_of(dim, 1.0);
    let radius = match k.radius {
        Some(r) => {
            c.positive("experiment.radius", r);
            r
        }
        None => (g.solid_volume / GRANULE_GAS_FRACTION[dim - 2] / unit).powf(1.0 / dim as Real),
    };
    let mut center = 0.5 * (container.lo + container.hi);
    if dim == 2 {
        center.z = 0.0;
    }
    // The ball inside the box, and room around it for the squashed granule to spread.
    for (a, name) in AXES.iter().enumerate().take(dim) {
        let length = container.hi[a] - container.lo[a];
        let need = if a == axis { 2.0 * radius } else { 4.0 * radius };
        if length < need {
            c.fail(
                "container.max",
                format!(
                    "the box must be at least {need:.3e} m long along {name} ({} the granule's starting radius {radius:.3e} m), got {length:.3e} m",
                    if a == axis { "twice" } else { "four times" }
                ),
            );
        }
    }
    let mass = g.density * Particles::volume_of(dim, 0.5 * g.diameter);
    let acceleration = k.acceleration.unwrap_or(GRANULE_FIELD * f_c / mass.max(Real::MIN_POSITIVE));
    c.positive("experiment.acceleration", acceleration);
    let sigma_c = f_c / g.diameter.powi(dim as i32 - 1);
    let strain_rate = k.strain_rate.unwrap_or(GRANULE_INERTIAL_NUMBER / g.diameter * (sigma_c / g.density).sqrt());
    c.positive("experiment.strain_rate", strain_rate);
    let strain = k.strain.unwrap_or(0.3);
    if !(strain > 0.0 && strain < 2.0) {
        c.fail("experiment.strain", format!("must be in (0, 2), got {strain}"));
    }
    let plateau = k.plateau.map_or((0.05, 0.2), |[a, b]| (a, b));
    if !(plateau.0 >= 0.0 && plateau.0 < plateau.1 && plateau.1 <= strain) {
        c.fail(
            "experiment.plateau",
            format!("must be [from, to] with 0 <= from < to <= strain = {strain}, got [{}, {}]", plateau.0, plateau.1),
        );
    }
    let local_damping = k.local_damping.unwrap_or(PREPARATION_DAMPING);
    if !(0.0..1.0).contains(&local_damping) {
        c.fail("experiment.local_damping", format!("must be in [0, 1), got {local_damping}"));
    }
    Experiment::GranuleCompression {
        ball: Ball { center, radius },
        axis,
        acceleration,
        strain_rate,
        strain,
        plateau,
        local_damping,
        equilibrium: check_equilibrium(c, "experiment.equilibrium", k.equilibrium.as_ref()),
        max_steps: check_max_steps(c, "experiment.max_steps", k.max_steps, DEFAULT_MAX_STEPS),
    }
}

/// Default Froude number of the drum: the rolling regime of a drum of a few tens of grain
/// diameters (docs/references.md check 17: rolling for 1e-4 < Fr < 1e-2).
pub const DRUM_FROUDE: Real = 1e-3;

fn check_drum(c: &mut Checker, k: &DrumSpec, dim: usize, container: &Container, gravity: &Vec3) -> Experiment {
    let axis = if dim == 2 {
        if k.axis.is_some() {
            c.fail("experiment.axis", "only in 3D: the 2D drum is a circle in the x-y plane");
        }
        2
    } else {
        match k.axis.as_deref() {
            None => 2,
            Some(n) => match AXES.iter().position(|a| *a == n) {
                Some(a) => a,
                None => {
                    c.fail("experiment.axis", format!("must be one of x, y, z, got '{n}'"));
                    2
                }
            },
        }
    };
    // The drum is inscribed in the box's cross-section, which must be a square.
    let across: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
    let (a, b) = (across[0], across[1]);
    let (la, lb) = (container.hi[a] - container.lo[a], container.hi[b] - container.lo[b]);
    if (la - lb).abs() > 1e-9 * la.abs().max(lb.abs()) {
        c.fail(
            "container.max",
            format!(
                "the drum is inscribed in the box: its {} and {} lengths must be equal (the drum's diameter), got {la} and {lb}",
                AXES[a], AXES[b]
            ),
        );
    }
    for &x in &across {
        if container.periodic[x] {
            c.fail("container.periodic", format!("{} crosses the drum and must not be periodic", AXES[x]));
        }
    }
    let radius = 0.5 * la.min(lb);
    let mut center = 0.5 * (container.lo + container.hi);
    center[axis] = 0.0;
    let g = gravity.norm();
    let mut down = Vec3::zeros();
    if g == 0.0 {
        c.fail("gravity", "required by the drum experiment: the grains are lifted against it");
    } else if gravity[axis].abs() > 1e-9 * g {
        c.fail("gravity", format!("must be perpendicular to the drum's axis {} (tilt the drum by choosing another axis)", AXES[axis]));
    } else {
        down = gravity / g;
    }
    let angular_velocity = match (k.froude, k.angular_velocity) {
        (Some(_), Some(_)) => {
            c.fail("experiment", "give froude or angular_velocity, not both");
            1.0
        }
        (None, Some(w)) => {
            if !(w.is_finite() && w != 0.0) {
                c.fail("experiment.angular_velocity", format!("must be a non-zero number, got {w}"));
            }
            w
        }
        (f, None) => {
            let f = f.unwrap_or(DRUM_FROUDE);
            c.positive("experiment.froude", f);
            (f.max(0.0) * g / radius.max(Real::MIN_POSITIVE)).sqrt()
        }
    };
    let froude = angular_velocity * angular_velocity * radius / g.max(Real::MIN_POSITIVE);
    let revolutions = k.revolutions.unwrap_or(1.0);
    c.positive("experiment.revolutions", revolutions);
    let transient = k.transient.unwrap_or(0.25_f64.min(0.5 * revolutions));
    if !(transient >= 0.0 && transient < revolutions) {
        c.fail("experiment.transient", format!("must be in [0, revolutions = {revolutions}), got {transient}"));
    }
    let local_damping = k.local_damping.unwrap_or(PREPARATION_DAMPING);
    if !(0.0..1.0).contains(&local_damping) {
        c.fail("experiment.local_damping", format!("must be in [0, 1), got {local_damping}"));
    }
    Experiment::Drum {
        drum: DrumDef { axis, center, radius, down },
        angular_velocity,
        froude,
        revolutions,
        transient,
        local_damping,
        equilibrium: check_equilibrium(c, "experiment.equilibrium", k.equilibrium.as_ref()),
        max_steps: check_max_steps(c, "experiment.max_steps", k.max_steps, DEFAULT_MAX_STEPS),
    }
}

fn preparation_stage(p: &Preparation, container: &Container) -> Stage {
    let mut controls = Controls { friction: Some(p.friction), local_damping: Some(p.local_damping), ..Controls::default() };
    if container.walls.is_empty() {
        controls.deformation = Some(Some(Deformation::Pressure {
            target: p.pressure,
            max_strain_rate: p.max_strain_rate,
            gain: p.max_strain_rate / p.pressure,
        }));
    } else {
        // Both walls of an axis move: each at most half the rate times the length.
        controls.walls = container
            .walls
            .iter()
            .map(|w| {
                let length = container.hi[w.face.axis] - container.lo[w.face.axis];
                let max_speed = 0.5 * p.max_strain_rate * length;
                WallDef { face: w.face, motion: WallMotion::Stress { stress: p.pressure, gain: None, max_speed, integral: false } }
            })
            .collect();
    }
    Stage {
        name: "preparation".into(),
        controls,
        until: Stop { steps: Some(p.max_steps), ..Stop::default() },
        strain_axis: None,
        equilibrium: Some(p.equilibrium),
    }
}

impl Experiment {
    /// The step limits the experiment sets, with the path of the field that sets each (a
    /// server may cap them; docs/scene-format.md §13).
    pub fn step_limits(&self) -> Vec<(&'static str, u64)> {
        match self {
            Self::Isotropic { preparation } => vec![("experiment.preparation.max_steps", preparation.max_steps)],
            Self::Triaxial { preparation, max_steps, .. } => {
                let mut v = vec![("experiment.preparation.max_steps", preparation.max_steps)];
                if *max_steps < u64::MAX {
                    v.push(("experiment.max_steps", *max_steps));
                }
                v
            }
            Self::Compaction { max_steps, .. }
            | Self::Deposition { max_steps, .. }
            | Self::Drum { max_steps, .. }
            | Self::GranuleCompression { max_steps, .. } => {
                vec![("experiment.max_steps", *max_steps)]
            }
            Self::PlaneShear { preparation, max_steps, .. } => {
                let mut v = vec![("experiment.preparation.max_steps", preparation.max_steps)];
                if *max_steps < u64::MAX {
                    v.push(("experiment.max_steps", *max_steps));
                }
                v
            }
        }
    }

    /// The stages the experiment runs, in order.
    pub fn stages(&self, container: &Container) -> Vec<Stage> {
        match self {
            Self::Deposition { local_damping, equilibrium, max_steps, .. } => vec![Stage {
                name: "deposition".into(),
                controls: Controls { local_damping: Some(*local_damping), ..Controls::default() },
                until: Stop { steps: Some(*max_steps), ..Stop::default() },
                strain_axis: None,
                equilibrium: Some(*equilibrium),
            }],
            Self::Isotropic { preparation } => vec![preparation_stage(preparation, container)],
            Self::GranuleCompression { axis, acceleration, strain_rate, strain, local_damping, equilibrium, max_steps, .. } => {
                let settle = |name: &str, field: Real| Stage {
                    name: name.into(),
                    controls: Controls { centripetal: Some(field), local_damping: Some(*local_damping), ..Controls::default() },
                    until: Stop { steps: Some(*max_steps), ..Stop::default() },
                    strain_axis: None,
                    equilibrium: Some(*equilibrium),
                };
                // Both plates close at half the rate each: the gap shrinks at `strain_rate`.
                let walls = container
                    .walls
                    .iter()
                    .map(|w| WallDef {
                        face: w.face,
                        motion: if w.face.axis == *axis { WallMotion::StrainRate(-0.5 * strain_rate) } else { WallMotion::Fixed },
                    })
                    .collect();
                let compression = Stage {
                    name: "compression".into(),
                    controls: Controls { walls, close_walls: Some(*axis), ..Controls::default() },
                    until: Stop { strain: Some(*strain), ..Stop::default() },
                    strain_axis: Some(*axis),
                    equilibrium: None,
                };
                vec![settle("forming", *acceleration), settle("relaxation", 0.0), compression]
            }
            Self::Drum { angular_velocity, revolutions, local_damping, equilibrium, max_steps, .. } => {
                let filling = Stage {
                    name: "filling".into(),
                    controls: Controls { local_damping: Some(*local_damping), drum_angular_velocity: Some(0.0), ..Controls::default() },
                    until: Stop { steps: Some(*max_steps), ..Stop::default() },
                    strain_axis: None,
                    equilibrium: Some(*equilibrium),
                };
                let period = 2.0 * std::f64::consts::PI / angular_velocity.abs();
                let rotation = Stage {
                    name: "rotation".into(),
                    controls: Controls { drum_angular_velocity: Some(*angular_velocity), ..Controls::default() },
                    until: Stop { time: Some(revolutions * period), ..Stop::default() },
                    strain_axis: None,
                    equilibrium: None,
                };
                vec![filling, rotation]
            }
            Self::Triaxial { preparation, axis, strain_rate, axial_strain, max_steps } => {
                let mut walls = Vec::new();
                for w in &container.walls {
                    let motion = if w.face.axis != *axis {
                        WallMotion::Stress { stress: preparation.pressure, gain: None, max_speed: f64::INFINITY, integral: true }
                    } else if w.face.upper {
                        WallMotion::StrainRate(-strain_rate)
                    } else {
                        WallMotion::Fixed
                    };
                    walls.push(WallDef { face: w.face, motion });
                }
                let loading = Stage {
                    name: "loading".into(),
                    controls: Controls { walls, ..Controls::default() },
                    until: Stop { strain: Some(*axial_strain), steps: (*max_steps < u64::MAX).then_some(*max_steps), ..Stop::default() },
                    strain_axis: Some(*axis),
                    equilibrium: None,
                };
                vec![preparation_stage(preparation, container), loading]
            }
            Self::PlaneShear { preparation, rough_walls: true, shear_rate, strain, max_steps } => {
                // The grains within ROUGH_LAYER of a wall are glued to it; y_max slides along x
                // at the shear rate times the gap and holds the normal stress.
                let walls = container
                    .walls
                    .iter()
                    .map(|w| WallDef {
                        face: w.face,
                        motion: if w.face.upper {
                            WallMotion::Shearing {
                                stress: preparation.pressure,
                                shear_rate: *shear_rate,
                                flow: 0,
                                max_speed: f64::INFINITY,
                            }
                        } else {
                            WallMotion::Fixed
                        },
                    })
                    .collect();
                let shear = Stage {
                    name: "shear".into(),
                    controls: Controls { walls, glue: Some(ROUGH_LAYER), ..Controls::default() },
                    until: Stop {
                        time: Some(strain / shear_rate),
                        steps: (*max_steps < u64::MAX).then_some(*max_steps),
                        ..Stop::default()
                    },
                    strain_axis: None,
                    equilibrium: None,
                };
                vec![preparation_stage(preparation, container), shear]
            }
            Self::PlaneShear { preparation, rough_walls: false, shear_rate, strain, max_steps } => {
                let p = preparation.pressure;
                // The height must open as fast as the flow dilates (a rate of order the shear
                // rate times a dilatancy angle), not only at the preparation's rate.
                let max_strain_rate = preparation.max_strain_rate.max(*shear_rate);
                let servo = Deformation::NormalStress { axis: 1, target: p, max_strain_rate, gain: max_strain_rate / p };
                let shear = Stage {
                    name: "shear".into(),
                    controls: Controls { deformation: Some(Some(servo)), shear_rate: Some(*shear_rate), ..Controls::default() },
                    until: Stop { strain: Some(*strain), steps: (*max_steps < u64::MAX).then_some(*max_steps), ..Stop::default() },
                    strain_axis: None,
                    equilibrium: None,
                };
                vec![preparation_stage(preparation, container), shear]
            }
            Self::Compaction { axis, drive, max_steps } => {
                let walls = container
                    .walls
                    .iter()
                    .map(|w| {
                        let motion = match (w.face.axis == *axis && w.face.upper, drive) {
                            (false, _) => WallMotion::Fixed,
                            (true, CompactionDrive::Velocity { speed, .. }) => {
                                let mut v = crate::math::Vec3::zeros();
                                v[*axis] = -speed;
                                WallMotion::Velocity(v)
                            }
                            (true, CompactionDrive::Stress { stress, max_speed, .. }) => {
                                WallMotion::Stress { stress: *stress, gain: None, max_speed: *max_speed, integral: false }
                            }
                        };
                        WallDef { face: w.face, motion }
                    })
                    .collect();
                let (until, equilibrium) = match drive {
                    CompactionDrive::Velocity { strain, .. } => {
                        (Stop { strain: Some(*strain), steps: Some(*max_steps), ..Stop::default() }, None)
                    }
                    CompactionDrive::Stress { equilibrium, .. } => {
                        (Stop { steps: Some(*max_steps), ..Stop::default() }, Some(*equilibrium))
                    }
                };
                vec![Stage {
                    name: "compaction".into(),
                    controls: Controls { walls, ..Controls::default() },
                    until,
                    strain_axis: Some(*axis),
                    equilibrium,
                }]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{parse_scene, Experiment, WallMotion};
    use serde_json::{json, Value};

    fn scene(dim: usize, periodic: bool, experiment: Value) -> Value {
        let v = |x: f64| if dim == 2 { json!([x, x]) } else { json!([x, x, x]) };
        let mut s = json!({
            "dimension": dim,
            "method": "dem",
            "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.5}},
            "particles": [{"material": "m", "count": 50, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
            "container": {"min": v(0.0), "max": v(0.02), "wall_material": "m"},
            "experiment": experiment
        });
        if periodic {
            s["container"]["periodic"] = if dim == 2 { json!(["x", "y"]) } else { json!(["x", "y", "z"]) };
        }
        s
    }

    fn violations(s: &Value) -> Vec<String> {
        match parse_scene(&s.to_string()) {
            Ok(_) => Vec::new(),
            Err(v) => v.iter().map(|x| x.to_string()).collect(),
        }
    }

    #[test]
    fn biaxial_expands_into_preparation_and_loading() {
        let s = scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}, "strain_rate": 0.2, "axial_strain": 0.1}));
        let scene = parse_scene(&s.to_string()).expect("valid");
        assert_eq!(scene.stages.len(), 2);
        let (prep, load) = (&scene.stages[0], &scene.stages[1]);
        assert_eq!((prep.name.as_str(), load.name.as_str()), ("preparation", "loading"));
        // Preparation: all four walls servo to 100 Pa, frictionless, damped, until equilibrium.
        assert_eq!(prep.controls.walls.len(), 4);
        assert!(prep.controls.walls.iter().all(|w| matches!(w.motion, WallMotion::Stress { stress, .. } if stress == 100.0)));
        assert_eq!(prep.controls.friction, Some(0.0));
        assert!(prep.equilibrium.is_some());
        // Loading: y_max at -0.2 1/s, y_min fixed, x walls at 100 Pa; friction back to the material's.
        for w in &load.controls.walls {
            let expected = match (w.face.axis, w.face.upper) {
                (1, true) => WallMotion::StrainRate(-0.2),
                (1, false) => WallMotion::Fixed,
                _ => WallMotion::Stress { stress: 100.0, gain: None, max_speed: f64::INFINITY, integral: true },
            };
            assert_eq!(w.motion, expected, "{}", w.face.name());
        }
        assert_eq!(load.controls.friction, None);
        assert_eq!((load.until.strain, load.strain_axis), (Some(0.1), Some(1)));
        assert!(matches!(scene.experiment, Some(Experiment::Triaxial { axis: 1, .. })));
    }

    #[test]
    fn isotropic_in_a_periodic_box_uses_the_cell_servo() {
        let s = scene(3, true, json!({"kind": "isotropic", "preparation": {"pressure": 1000.0, "max_strain_rate": 5.0}}));
        let scene = parse_scene(&s.to_string()).expect("valid");
        let prep = &scene.stages[0];
        assert!(prep.controls.walls.is_empty());
        assert!(matches!(prep.controls.deformation, Some(Some(crate::scene::Deformation::Pressure { target, max_strain_rate, .. }))
            if target == 1000.0 && max_strain_rate == 5.0));
    }

    #[test]
    fn plane_shear_prepares_then_shears_under_a_normal_stress_servo() {
        let s = scene(2, true, json!({"kind": "plane_shear", "preparation": {"pressure": 2500.0}, "inertial_number": 0.02, "strain": 2.0}));
        let parsed = parse_scene(&s.to_string()).expect("valid");
        let shear = &parsed.stages[1];
        assert_eq!(shear.name, "shear");
        // sqrt(p / rho) = 1 m/s, d = 1 mm: rate = 0.02 / 1e-3 = 20 1/s.
        assert!((shear.controls.shear_rate.expect("rate") - 20.0).abs() < 1e-9);
        assert!(
            matches!(shear.controls.deformation, Some(Some(crate::scene::Deformation::NormalStress { axis: 1, target, .. })) if target == 2500.0)
        );
        assert_eq!(shear.until.strain, Some(2.0));
        let v = violations(&scene(2, false, json!({"kind": "plane_shear", "preparation": {"pressure": 1.0}})));
        assert!(v.iter().any(|x| x.starts_with("container.periodic: the plane_shear experiment needs a fully periodic box")), "{v:?}");
        let v = violations(&scene(
            2,
            true,
            json!({"kind": "plane_shear", "preparation": {"pressure": 1.0}, "shear_rate": 1.0, "inertial_number": 0.1}),
        ));
        assert!(v.iter().any(|x| x.starts_with("experiment: give shear_rate or inertial_number, not both")), "{v:?}");
    }

    #[test]
    fn drum_settles_then_turns_at_the_froude_number() {
        let mut s = scene(2, false, json!({"kind": "drum", "froude": 0.01, "revolutions": 2.0}));
        s["gravity"] = json!([0.0, -9.81]);
        let parsed = parse_scene(&s.to_string()).expect("valid");
        let (filling, rotation) = (&parsed.stages[0], &parsed.stages[1]);
        assert_eq!((filling.name.as_str(), rotation.name.as_str()), ("filling", "rotation"));
        assert_eq!(filling.controls.drum_angular_velocity, Some(0.0));
        assert!(filling.equilibrium.is_some());
        // R = 10 mm: ω = sqrt(Fr g / R) = sqrt(9.81) rad/s; two turns.
        let w = rotation.controls.drum_angular_velocity.expect("turns");
        assert!((w - 9.81f64.sqrt()).abs() < 1e-12);
        let t = rotation.until.time.expect("time");
        assert!((t - 2.0 * 2.0 * std::f64::consts::PI / w).abs() < 1e-12);
        let drum = parsed.container.drum.expect("a drum in the container");
        assert_eq!((drum.axis, drum.radius), (2, 0.01));
        assert!((drum.center - crate::math::Vec3::new(0.01, 0.01, 0.0)).norm() < 1e-15);
        let Some(Experiment::Drum { transient, .. }) = parsed.experiment else { panic!("drum") };
        assert_eq!((transient, drum.down), (0.25, crate::math::Vec3::new(0.0, -1.0, 0.0)));

        let with = |dim: usize, e: Value, gravity: Value, edit: &dyn Fn(&mut Value)| {
            let mut s = scene(dim, false, e);
            s["gravity"] = gravity;
            edit(&mut s);
            violations(&s)
        };
        let g2 = json!([0.0, -9.81]);
        let cases: Vec<(Vec<String>, &str)> = vec![
            (with(2, json!({"kind": "drum"}), json!([0.0, 0.0]), &|_| {}), "gravity: required by the drum experiment"),
            (
                with(3, json!({"kind": "drum", "axis": "y"}), json!([0.0, -9.81, 0.0]), &|_| {}),
                "gravity: must be perpendicular to the drum's axis y",
            ),
            (
                with(2, json!({"kind": "drum", "froude": 0.1, "angular_velocity": 1.0}), g2.clone(), &|_| {}),
                "experiment: give froude or angular_velocity, not both",
            ),
            (
                with(2, json!({"kind": "drum", "revolutions": 1.0, "transient": 1.0}), g2.clone(), &|_| {}),
                "experiment.transient: must be in [0, revolutions = 1)",
            ),
            (with(2, json!({"kind": "drum", "axis": "x"}), g2.clone(), &|_| {}), "experiment.axis: only in 3D"),
            (
                with(2, json!({"kind": "drum"}), g2.clone(), &|s| s["container"]["max"] = json!([0.02, 0.03])),
                "container.max: the drum is inscribed in the box: its x and y lengths must be equal",
            ),
            (
                with(3, json!({"kind": "drum"}), json!([0.0, -9.81, 0.0]), &|s| s["container"]["periodic"] = json!(["x", "z"])),
                "container.periodic: x crosses the drum and must not be periodic",
            ),
        ];
        for (v, expected) in cases {
            assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
        }
        // The fill sets the count of the one set: fill × Φ_bed × π R² / (π <d>²/4) in 2D.
        let mut s = scene(2, false, json!({"kind": "drum", "fill": 0.4}));
        s["gravity"] = json!([0.0, -9.81]);
        s["particles"][0].as_object_mut().expect("set").remove("count");
        let parsed = parse_scene(&s.to_string()).expect("valid");
        assert_eq!(parsed.sets[0].count, (0.4_f64 * 0.82 * 400.0).round() as usize);
        s["particles"][0]["count"] = json!(50);
        assert!(violations(&s).iter().any(|x| x.starts_with("experiment.fill: give particles[0].count or experiment.fill, not both")));
        s["experiment"]["fill"] = json!(1.5);
        assert!(violations(&s).iter().any(|x| x.starts_with("experiment.fill: must be in (0, 1)")));
        // In 3D the axis may be periodic (an endless drum).
        let v = with(3, json!({"kind": "drum"}), json!([0.0, -9.81, 0.0]), &|s| s["container"]["periodic"] = json!(["z"]));
        assert!(v.is_empty(), "{v:?}");
    }

    #[test]
    fn plane_shear_between_rough_walls_glues_then_slides_the_upper_wall() {
        let mut s =
            scene(2, false, json!({"kind": "plane_shear", "boundary": "rough_walls", "preparation": {"pressure": 2500.0}, "strain": 2.0}));
        s["container"]["periodic"] = json!(["x"]);
        let parsed = parse_scene(&s.to_string()).expect("valid");
        let (prep, shear) = (&parsed.stages[0], &parsed.stages[1]);
        // The y walls compress the sample; then grains within half a diameter are glued and
        // y_max shears the gap at 10 1/s (I = 1e-2) for a strain of 2 (0.2 s).
        assert_eq!(prep.controls.walls.len(), 2);
        assert_eq!(shear.controls.glue, Some(super::ROUGH_LAYER));
        for w in &shear.controls.walls {
            let expected = if w.face.upper {
                WallMotion::Shearing { stress: 2500.0, shear_rate: 10.0, flow: 0, max_speed: f64::INFINITY }
            } else {
                WallMotion::Fixed
            };
            assert_eq!(w.motion, expected);
        }
        assert!((shear.until.time.expect("time") - 0.2).abs() < 1e-12);
        let mut bad = s.clone();
        bad["container"]["periodic"] = json!(["y"]);
        assert!(violations(&bad)
            .iter()
            .any(|x| x.starts_with("container.periodic: plane shear between rough walls needs walls on y only")));
        bad["experiment"]["boundary"] = json!("smooth");
        assert!(violations(&bad).iter().any(|x| x.starts_with("experiment.boundary: must be lees_edwards or rough_walls")));
    }

    #[test]
    fn granule_forms_relaxes_then_is_squeezed() {
        let mut s = scene(3, false, json!({"kind": "granule_compression", "radius": 0.004, "strain": 0.25}));
        s["materials"]["m"]["liquid"] = json!({"surface_tension": 0.0728, "contact_angle": 0.0, "bridge_volume": 1e-12});
        s["particles"][0]["wet_fraction"] = json!(1.0);
        let parsed = parse_scene(&s.to_string()).expect("valid");
        let names: Vec<&str> = parsed.stages.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, ["forming", "relaxation", "compression"]);
        // f_c = 2π γ <d>/2; the field is f_c over a mean grain's mass, then off.
        let f_c = 2.0 * std::f64::consts::PI * 0.0728 * 0.5e-3;
        let m = 2500.0 * std::f64::consts::PI / 6.0 * 1e-9;
        let a = parsed.stages[0].controls.centripetal.expect("field");
        assert!((a - f_c / m).abs() < 1e-9 * a);
        assert_eq!(parsed.stages[1].controls.centripetal, Some(0.0));
        let squeeze = &parsed.stages[2];
        assert_eq!((squeeze.controls.close_walls, squeeze.strain_axis, squeeze.until.strain), (Some(2), Some(2), Some(0.25)));
        // Default rate: I = 1e-3 at σ_c = f_c / d²: ε̇ = 1e-3 / d × sqrt(σ_c / ρ); half each plate.
        let rate = 1e-3 / 1e-3 * (f_c / 1e-6 / 2500.0).sqrt();
        for w in &squeeze.controls.walls {
            let expected = if w.face.axis == 2 { WallMotion::StrainRate(-0.5 * rate) } else { WallMotion::Fixed };
            match (w.motion, expected) {
                (WallMotion::StrainRate(x), WallMotion::StrainRate(y)) => assert!((x - y).abs() < 1e-12 * y.abs()),
                (x, y) => assert_eq!(x, y),
            }
        }
        let ball = parsed.container.granule.expect("ball");
        assert_eq!(ball.radius, 0.004);
        // Dry grains, gravity, a small box and a bad window are refused.
        let dry = scene(3, false, json!({"kind": "granule_compression"}));
        assert!(violations(&dry).iter().any(|x| x.starts_with("particles: the granule_compression experiment needs wet grains")));
        let mut bad = s.clone();
        bad["gravity"] = json!([0.0, 0.0, -9.81]);
        bad["experiment"]["radius"] = json!(0.006);
        bad["experiment"]["plateau"] = json!([0.2, 0.1]);
        let v = violations(&bad);
        for expected in [
            "gravity: must be absent",
            "container.max: the box must be at least 2.400e-2 m long along x",
            "experiment.plateau: must be [from, to]",
        ] {
            assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
        }
    }

    #[test]
    fn default_rates_follow_the_inertial_numbers() {
        let s = scene(3, false, json!({"kind": "triaxial", "preparation": {"pressure": 2500.0}}));
        let scene = parse_scene(&s.to_string()).expect("valid");
        let Some(Experiment::Triaxial { preparation, strain_rate, axial_strain, .. }) = scene.experiment else { panic!("triaxial") };
        // sqrt(p / rho) = 1 m/s, d = 1 mm: I / d.
        assert!((preparation.max_strain_rate - 10.0).abs() < 1e-9);
        assert!((strain_rate - 0.5).abs() < 1e-9);
        assert_eq!(axial_strain, 0.2);
    }

    #[test]
    fn broken_experiments_name_the_field_and_the_rule() {
        let cases = [
            (scene(3, false, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}})), "experiment.kind: 'biaxial' is the 2D test"),
            (
                scene(2, true, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}})),
                "container.periodic: the biaxial experiment needs walls",
            ),
            (
                scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": -1.0}})),
                "experiment.preparation.pressure: must be > 0",
            ),
            (
                scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 1.0}, "axial_strain": 1.5})),
                "experiment.axial_strain: must be in (0, 1)",
            ),
            (
                scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 1.0}, "axis": "z"})),
                "experiment.axis: must be one of x, y in 2D",
            ),
            (scene(2, false, json!({"kind": "compaction", "velocity": 0.01})), "experiment.strain: required with velocity"),
            (scene(2, false, json!({"kind": "compaction", "velocity": 0.01, "stress": 5.0})), "experiment: give exactly one of velocity"),
            (
                scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0, "equilibrium": {"check_every": 0}}})),
                "experiment.preparation.equilibrium.check_every: must be >= 1",
            ),
        ];
        for (s, expected) in cases {
            let v = violations(&s);
            assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
        }
        // Unknown fields are refused with their path.
        let v = violations(&scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0, "presure": 2.0}})));
        assert!(v.iter().any(|x| x.starts_with("experiment.preparation.presure") || x.contains("unknown field `presure`")), "{v:?}");
        // Moving walls, stop targets other than limits, and no stop without an experiment.
        let mut s = scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0}}));
        s["container"]["walls"] = json!({"y_max": {"kind": "velocity", "velocity": [0.0, -1.0]}});
        s["stop"] = json!({"strain": 0.1, "steps": 10});
        let v = violations(&s);
        assert!(v.iter().any(|x| x.starts_with("container.walls: an experiment moves the walls itself")), "{v:?}");
        assert!(v.iter().any(|x| x.starts_with("stop.strain: not with an experiment")), "{v:?}");
        let mut s = scene(2, false, json!(null));
        s.as_object_mut().expect("object").remove("experiment");
        assert!(violations(&s).iter().any(|x| x.starts_with("stop: required")));
    }
}
