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

/// Relative pressure error within which the servo holds the volume: the packing then relaxes at
/// fixed volume instead of being kept moving by ever smaller corrections (near jamming those
/// corrections kept the kinetic energy at ~1e-2 of the elastic energy for a million steps in a
/// 1,000-sphere preparation). Half the default 1% stress tolerance of the equilibrium criterion.
pub const SERVO_DEADBAND: Real = 0.005;

/// Below this fraction of the target pressure the stiffness limit of the gain is not applied:
/// the packing is compressed at the full rate until it carries the target, then the limited
/// servo brings it back from above. Below the target the stiffness estimate counts the transient
/// collisions of a compressed gas (which slowed its compression tenfold), and approaching from
/// below a frictionless packing near jamming kept rearranging under ever smaller increments
/// (kinetic energy at 1e-2..1e-1 of the elastic energy for 400,000 steps); from above it is
/// rigid and relaxes (the protocol of `tests/physics_jamming.rs`). The overshoot is one
/// update's compression at `max_strain_rate`.
pub const SERVO_FREE_BELOW: Real = 1.0;

impl CellDeformation {
    /// Starts the deformation (a pressure servo starts at rest).
    pub fn new(kind: Deformation) -> Self {
        let rate = match kind {
            Deformation::StrainRate(r) => r,
            Deformation::Pressure { .. } | Deformation::NormalStress { .. } => Vec3::zeros(),
        };
        Self { kind, rate }
    }

    /// Updates the servo from the measured mean pressure `pressure` (Pa) and an estimate of the
    /// packing's bulk stiffness `bulk` (Pa per unit volumetric strain; 0 for a gas); no-op for
    /// constant rates. The rate is `gain (p - target)`, bounded by `max_strain_rate`, zero within
    /// [`SERVO_DEADBAND`] of the target, with the gain lowered once the packing carries
    /// the target ([`SERVO_FREE_BELOW`]) so that one step changes the pressure by at most
    /// [`SERVO_STEP_FRACTION`] of the error: a stiff packing would otherwise overshoot every update
    /// (bang-bang oscillation), and a servo as fast as the collisions drives the packing
    /// dynamically and keeps feeding it kinetic energy.
    ///
    /// In a sheared (Lees-Edwards) cell the stiffness bound is not applied: a flowing packing
    /// rearranges instead of storing the strain of its height, so the static contact stiffness
    /// overstates how much σ_yy answers to it, and the bound kept the height from opening as
    /// fast as the flow dilates (a jammed sample sheared at I = 0.1 was crushed to 9 times the
    /// target within 260 steps; in steady flow σ_yy ran 5-10% above the target at I = 1e-2).
    /// Without it σ_yy holds the target within 1% from I = 4e-3 to 0.4.
    ///
    /// `stress` holds the diagonal of the measured stress tensor (σ_xx, σ_yy, σ_zz), Pa: the
    /// pressure servo reads its mean, a normal-stress servo its own axis (with the same
    /// stiffness bound, one axis's strain moving σ_aa about as much as the volumetric strain
    /// moves p).
    pub fn servo(&mut self, stress: Vec3, bulk: Real, dt: Real, domain: &Domain) {
        let d = domain.dim as Real;
        let (measured, target, max_strain_rate, gain, axis) = match self.kind {
            Deformation::Pressure { target, max_strain_rate, gain } => {
                ((0..domain.dim).map(|a| stress[a]).sum::<Real>() / d, target, max_strain_rate, gain, None)
            }
            Deformation::NormalStress { axis, target, max_strain_rate, gain } => (stress[axis], target, max_strain_rate, gain, Some(axis)),
            Deformation::StrainRate(_) => return,
        };
        let limited = bulk > 0.0 && measured > SERVO_FREE_BELOW * target && !domain.sheared();
        let g = if limited { gain.min(SERVO_STEP_FRACTION / (bulk * d * dt)) } else { gain };
        let error = measured - target;
        let r = if error.abs() <= SERVO_DEADBAND * target { 0.0 } else { (g * error).clamp(-max_strain_rate, max_strain_rate) };
        for a in 0..domain.dim {
            let driven = axis.is_none_or(|b| b == a);
            self.rate[a] = if domain.periodic[a] && driven { r } else { 0.0 };
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
