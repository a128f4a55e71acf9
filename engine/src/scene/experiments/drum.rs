//! The rotating drum's checks and defaults: its axis, the circle inscribed in the box, the
//! direction of gravity and the rotation rate from the Froude number.

use super::{check_equilibrium, check_max_steps, DEFAULT_MAX_STEPS, PREPARATION_DAMPING};
use crate::math::{Real, Vec3, AXES};
use crate::scene::model::{Container, DrumDef, Experiment};
use crate::scene::spec::DrumSpec;
use crate::scene::violation::Checker;

/// Default Froude number of the drum: the rolling regime of a drum of a few tens of grain
/// diameters (docs/references.md check 17: rolling for 1e-4 < Fr < 1e-2).
pub const DRUM_FROUDE: Real = 1e-3;

/// Checks a rotating drum against the box and gravity and fills in its defaults.
pub(super) fn check_drum(c: &mut Checker, k: &DrumSpec, dim: usize, container: &Container, gravity: &Vec3) -> Experiment {
    let axis = check_drum_axis(c, k.axis.as_deref(), dim);
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
    let down = check_drum_gravity(c, gravity, axis);
    let angular_velocity = check_angular_velocity(c, k, g, radius);
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

/// The drum's axis: z in 2D, else the one named (z by default).
fn check_drum_axis(c: &mut Checker, name: Option<&str>, dim: usize) -> usize {
    if dim == 2 {
        if name.is_some() {
            c.fail("experiment.axis", "only in 3D: the 2D drum is a circle in the x-y plane");
        }
        return 2;
    }
    match name {
        None => 2,
        Some(n) => match AXES.iter().position(|a| *a == n) {
            Some(a) => a,
            None => {
                c.fail("experiment.axis", format!("must be one of x, y, z, got '{n}'"));
                2
            }
        },
    }
}

/// The unit vector down, from gravity, which the drum needs perpendicular to its axis (zero
/// when refused).
fn check_drum_gravity(c: &mut Checker, gravity: &Vec3, axis: usize) -> Vec3 {
    let g = gravity.norm();
    let mut down = Vec3::zeros();
    if g == 0.0 {
        c.fail("gravity", "required by the drum experiment: the grains are lifted against it");
    } else if gravity[axis].abs() > 1e-9 * g {
        c.fail("gravity", format!("must be perpendicular to the drum's axis {} (tilt the drum by choosing another axis)", AXES[axis]));
    } else {
        down = gravity / g;
    }
    down
}

/// The drum's angular velocity: given, or from the Froude number (by default [`DRUM_FROUDE`])
/// with gravity `g` and the drum's radius.
fn check_angular_velocity(c: &mut Checker, k: &DrumSpec, g: Real, radius: Real) -> Real {
    match (k.froude, k.angular_velocity) {
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
    }
}
