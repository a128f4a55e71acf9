//! The standard experiments of a scene (`experiment` section): their checks, defaults, and the
//! stages they expand into (preparation, loading), which the runner executes in order.
//!
//! This module checks the section and holds the checks every experiment shares (preparation,
//! equilibrium, step limits, axis); `granule.rs` and `drum.rs` check those two experiments, and
//! `stages.rs` expands a checked experiment into its stages.

mod drum;
mod granule;
mod stages;
#[cfg(test)]
mod tests;

pub use drum::DRUM_FROUDE;
pub use granule::{GRANULE_FIELD, GRANULE_GAS_FRACTION, GRANULE_INERTIAL_NUMBER};
pub use stages::ROUGH_LAYER;

use super::model::*;
use super::spec::*;
use super::violation::Checker;
use crate::math::{Real, Vec3, AXES};
use drum::check_drum;
use granule::check_granule;

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
        ExperimentSpec::Biaxial(t) => check_triaxial(c, t, "biaxial", 2, dim, walled, grains),
        ExperimentSpec::Triaxial(t) => check_triaxial(c, t, "triaxial", 3, dim, walled, grains),
        ExperimentSpec::PlaneShear(k) => check_plane_shear(c, k, dim, container, periodic, grains),
        ExperimentSpec::Deposition(k) => check_deposition(c, k, dim, container, gravity),
        ExperimentSpec::Drum(k) => check_drum(c, k, dim, container, gravity),
        ExperimentSpec::GranuleCompression(k) => {
            need_walls(c, walled, "granule_compression");
            check_granule(c, k, dim, container, grains, gravity)
        }
        ExperimentSpec::Compaction(k) => {
            need_walls(c, walled, "compaction");
            let axis = check_axis(c, "experiment.axis", k.axis.as_deref(), dim);
            let drive = check_compaction_drive(c, k);
            Experiment::Compaction { axis, drive, max_steps: check_max_steps(c, "experiment.max_steps", k.max_steps, DEFAULT_MAX_STEPS) }
        }
    };
    let stages = experiment.stages(container);
    (experiment, stages)
}

/// Fails when the experiment `kind`, which needs walls on every face, has a periodic axis.
fn need_walls(c: &mut Checker, walled: bool, kind: &str) {
    if !walled {
        c.fail(
            "container.periodic",
            format!("the {kind} experiment needs walls on every face (a box with no periodic axis) in this version"),
        );
    }
}

/// Checks a biaxial (`want` = 2) or triaxial (`want` = 3) test and fills in its defaults.
fn check_triaxial(
    c: &mut Checker,
    t: &TriaxialSpec,
    kind: &str,
    want: usize,
    dim: usize,
    walled: bool,
    grains: &GrainScales,
) -> Experiment {
    if dim != want {
        let other = if want == 2 { "triaxial" } else { "biaxial" };
        c.fail("experiment.kind", format!("'{kind}' is the {want}D test; in {dim}D use '{other}'"));
    }
    need_walls(c, walled, kind);
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

/// Checks a plane shear test (Lees-Edwards cell or rough walls) and fills in its defaults.
fn check_plane_shear(
    c: &mut Checker,
    k: &PlaneShearSpec,
    dim: usize,
    container: &Container,
    periodic: bool,
    grains: &GrainScales,
) -> Experiment {
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
        c.fail("container.periodic", format!("plane shear between rough walls needs walls on y only: make {others} periodic, not y"));
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

/// Checks a deposition: gravity along one axis, towards a wall.
fn check_deposition(c: &mut Checker, k: &DepositionSpec, dim: usize, container: &Container, gravity: &Vec3) -> Experiment {
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
        c.fail("container.periodic", format!("the deposition needs a floor: {} (the axis of gravity) must not be periodic", AXES[axis]));
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

/// Checks how a compaction drives its wall: at an imposed speed up to a strain, or at a stress.
fn check_compaction_drive(c: &mut Checker, k: &CompactionSpec) -> CompactionDrive {
    match (k.velocity, k.stress) {
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
    }
}
