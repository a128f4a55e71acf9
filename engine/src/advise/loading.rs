//! The stress and strain rate a scene's loading imposes, and what each comes from (a scene
//! without an experiment: its walls, cell, shear, gravity and initial speeds), with the
//! grains' wetness and largest attraction.

use super::{Regime, DILUTE_FRACTION};
use crate::math::Real;
use crate::scene::{Deformation, Placement, Scene, WallMotion};

/// The loading's stress and rate, and what they come from.
#[derive(Default)]
pub(super) struct Loading {
    pub(super) pressure: Option<(Real, String)>,
    pub(super) rate: Option<(Real, String)>,
    /// Set when the loading decides the regime by itself.
    pub(super) regime: Option<(Regime, String)>,
}

impl Loading {
    pub(super) fn stress(&mut self, p: Real, source: impl Into<String>) {
        if p > 0.0 && self.pressure.as_ref().is_none_or(|(q, _)| p > *q) {
            self.pressure = Some((p, source.into()));
        }
    }
    pub(super) fn rate(&mut self, r: Real, source: impl Into<String>) {
        let r = r.abs();
        if r > 0.0 && self.rate.as_ref().is_none_or(|(q, _)| r > *q) {
            self.rate = Some((r, source.into()));
        }
    }
}

/// Random close packing fraction of the scene's dimension (disks, spheres).
pub(super) fn close_packing(dim: usize) -> Real {
    if dim == 2 {
        0.82
    } else {
        0.64
    }
}

/// True if some grains carry liquid.
pub(super) fn wet(scene: &Scene) -> bool {
    let liquid = |m: usize| scene.materials.get(m).is_some_and(|m| m.liquid.is_some());
    match &scene.initial {
        Some(st) => st.wet.iter().zip(&st.material).any(|(w, m)| *w && liquid(*m)),
        None => scene.sets.iter().any(|s| s.wet_fraction > 0.0 && liquid(s.material)),
    }
}

/// The largest attraction between two grains of diameter `d`, N (N/m in 2D): the capillary
/// force at contact `2π γ cosθ R` (R = d/2; docs/physics.md §2.8) or the dry cohesion F_0.
pub(super) fn adhesion(scene: &Scene, d: Real) -> Option<Real> {
    let wet = wet(scene);
    let capillary = scene.materials.iter().filter_map(|m| m.liquid.filter(|_| wet)).map(|l| l.capillary_prefactor() * 0.5 * d);
    let cohesion = scene.materials.iter().filter_map(|m| m.cohesion).map(|c| c.force);
    capillary.chain(cohesion).fold(None, |f: Option<Real>, x| Some(f.map_or(x, |f| f.max(x)))).filter(|x| *x > 0.0)
}

/// The axis gravity points along (the largest component; y if there is none).
pub(super) fn axis_of_gravity(scene: &Scene) -> usize {
    let g = scene.gravity;
    (0..3).max_by(|a, b| g[*a].abs().total_cmp(&g[*b].abs())).filter(|a| g[*a] != 0.0).unwrap_or(1)
}

/// The grains' fastest initial speed as the scene gives it, m/s: a set's uniform velocity or
/// its listed ones, a Gaussian's typical speed (its deviation times √D), a state's velocities.
pub(super) fn initial_speed(scene: &Scene) -> Real {
    let mut speed: Real = 0.0;
    for s in &scene.sets {
        speed = speed.max(match s.velocity {
            crate::scene::InitialVelocity::Uniform(v) => v.norm(),
            crate::scene::InitialVelocity::Gaussian(sd) => sd * (scene.dim as Real).sqrt(),
        });
        if let Placement::List { velocities: Some(vs), .. } = &s.placement {
            speed = speed.max(vs.iter().map(|v| v.norm()).fold(0.0, Real::max));
        }
    }
    if let Some(st) = &scene.initial {
        speed = speed.max(st.vel.iter().map(|v| v.norm()).fold(0.0, Real::max));
    }
    speed
}

/// The stress and rate of a scene without an experiment: its walls, cell, shear, gravity and
/// initial velocities.
pub(super) fn loading_of_container(scene: &Scene, l: &mut Loading, rho: Real, phi0: Real, g: Real) {
    let c = &scene.container;
    let length = |a: usize| c.hi[a] - c.lo[a];
    let mut held = false;
    for w in &c.walls {
        let face = w.face.name();
        match w.motion {
            WallMotion::Velocity(u) => l.rate(u.norm() / length(w.face.axis), format!("wall {face}: speed / box length")),
            WallMotion::StrainRate(r) => l.rate(r, format!("wall {face}: strain rate")),
            WallMotion::Stress { stress, max_speed, .. } => {
                held = true;
                l.stress(stress, format!("wall {face}: stress"));
                if max_speed.is_finite() {
                    l.rate(max_speed / length(w.face.axis), format!("wall {face}: max_speed / box length"));
                }
            }
            WallMotion::Shearing { stress, shear_rate, .. } => {
                held = true;
                l.stress(stress, format!("wall {face}: stress"));
                l.rate(shear_rate, format!("wall {face}: shear rate"));
            }
            WallMotion::Fixed => {}
        }
    }
    if let Some((rate, _)) = c.lees_edwards {
        l.rate(rate, "container.lees_edwards.shear_rate");
    }
    match c.deformation {
        Some(Deformation::StrainRate(r)) => l.rate(r.abs().max(), "container.deformation strain rates"),
        Some(Deformation::NormalStress { target, max_strain_rate, .. }) | Some(Deformation::Pressure { target, max_strain_rate, .. }) => {
            held = true;
            l.stress(target, "container.deformation target");
            l.rate(max_strain_rate, "container.deformation.max_strain_rate");
        }
        None => {}
    }
    let speed = initial_speed(scene);
    let dilute = phi0 < DILUTE_FRACTION * close_packing(scene.dim);
    if g > 0.0 {
        let h = length(axis_of_gravity(scene));
        l.stress(0.5 * rho * g * phi0 * h, "weight of the grains (ρ g Φ H / 2)");
        held = true;
        if dilute {
            l.regime = Some((Regime::Collisional, format!("the grains start as a gas (Φ = {phi0:.2}) and fall under gravity")));
        }
    }
    if dilute && speed > 0.0 && l.regime.is_none() {
        l.regime = Some((Regime::Collisional, format!("the grains start as a gas (Φ = {phi0:.2}) with speeds up to {speed:.2e} m/s")));
    }
    let closed = (0..scene.dim).all(|a| c.periodic[a] || c.walls.iter().any(|w| w.face.axis == a));
    if l.regime.is_none() && !held && closed && l.rate.is_some() && !dilute {
        l.regime = Some((Regime::KinematicSqueeze, "an imposed motion squeezes or shears a packed, closed box".into()));
    }
}
