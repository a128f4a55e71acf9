//! The granule compression's checks and defaults: the wet grains' starting ball, the
//! centripetal field that forms the granule and the rate at which the plates squeeze it.

use super::{check_axis, check_equilibrium, check_max_steps, GrainScales, DEFAULT_MAX_STEPS, PREPARATION_DAMPING};
use crate::math::{Real, Vec3, AXES};
use crate::particles::Particles;
use crate::scene::model::{Ball, Container, Equilibrium, Experiment};
use crate::scene::spec::GranuleCompressionSpec;
use crate::scene::violation::Checker;

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

/// Checks a granule compression against the box, gravity and the grains, and fills in its
/// defaults.
pub(super) fn check_granule(
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
    let ball = granule_ball(c, k, dim, container, g, axis);
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
        ball,
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

/// The granule's starting ball (by default the grains as a gas at [`GRANULE_GAS_FRACTION`])
/// at the box's centre, which must leave room for the squashed granule to spread.
fn granule_ball(c: &mut Checker, k: &GranuleCompressionSpec, dim: usize, container: &Container, g: &GrainScales, axis: usize) -> Ball {
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
    Ball { center, radius }
}
