//! Homogeneous deformation of the periodic cell: constant strain rates, or an isotropic servo to
//! a target pressure (a Berendsen-style barostat: the strain rate is proportional to the pressure
//! error, bounded). Positions are remapped affinely each step; velocities are left unchanged, as
//! LAMMPS `fix deform remap x` does.

use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::scene::Deformation;

/// State of the imposed cell deformation.
#[derive(Debug, Clone, PartialEq)]
pub struct CellDeformation {
    /// What is imposed.
    pub kind: Deformation,
    /// Current true strain rate of each axis, 1/s.
    pub rate: Vec3,
}

/// Largest fraction of the pressure error that one step of the servo may remove once the grains
/// touch: 0.2%, i.e. a response time of about 500 steps, ten collision times at the default
/// dt = t_c/50 — slow against the contacts, so the packing follows quasi-statically.
pub const SERVO_STEP_FRACTION: Real = 0.002;

impl CellDeformation {
    /// Starts the deformation (a pressure servo starts at rest).
    pub fn new(kind: Deformation) -> Self {
        let rate = match kind {
            Deformation::StrainRate(r) => r,
            Deformation::Pressure { .. } => Vec3::zeros(),
        };
        Self { kind, rate }
    }

    /// Updates the servo from the measured mean pressure `pressure` (Pa) and an estimate of the
    /// packing's bulk stiffness `bulk` (Pa per unit volumetric strain; 0 for a gas); no-op for
    /// constant rates. The rate is `gain (p - target)`, bounded by `max_strain_rate`, with the gain
    /// lowered once the grains touch so that one step changes the pressure by at most
    /// [`SERVO_STEP_FRACTION`] of the error: a stiff packing would otherwise overshoot every update
    /// (bang-bang oscillation), and a servo as fast as the collisions drives the packing
    /// dynamically and keeps feeding it kinetic energy.
    pub fn servo(&mut self, pressure: Real, bulk: Real, dt: Real, domain: &Domain) {
        if let Deformation::Pressure { target, max_strain_rate, gain } = self.kind {
            let d = domain.dim as Real;
            let g = if bulk > 0.0 { gain.min(SERVO_STEP_FRACTION / (bulk * d * dt)) } else { gain };
            let r = (g * (pressure - target)).clamp(-max_strain_rate, max_strain_rate);
            for a in 0..domain.dim {
                self.rate[a] = if domain.periodic[a] { r } else { 0.0 };
            }
        }
    }

    /// Scales the box about its centre by `exp(rate dt)` per axis; returns the scale factors to
    /// apply to positions relative to the old centre.
    pub fn deform(&self, domain: &mut Domain, dt: Real) -> (Vec3, Vec3) {
        let centre = 0.5 * (domain.lo + domain.hi);
        let mut scale = Vec3::repeat(1.0);
        for a in 0..domain.dim {
            let s = (self.rate[a] * dt).exp();
            scale[a] = s;
            let half = 0.5 * domain.length(a) * s;
            domain.lo[a] = centre[a] - half;
            domain.hi[a] = centre[a] + half;
        }
        (centre, scale)
    }
}
