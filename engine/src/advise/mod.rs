//! The method advisor: a scene's dimensionless numbers, and from them the lightest model that
//! is adequate for it (docs/physics.md §8 and §10.3).
//!
//! The numbers are estimated from the scene as written, before anything runs: the confining
//! stress `p` and the strain rate `ε̇` its loading imposes, the grains' mean diameter `d` and
//! density `ρ`, and their contact law. From them:
//!
//! - inertial number `I = ε̇ d sqrt(ρ/p)` (Nezamabadi 2020, §3.1; Roux & Chevoir 2005, §2.3.4):
//!   quasi-static below [`QUASI_STATIC_INERTIAL`] (GDR MiDi 2004), dense inertial flow above;
//! - stiffness number `κ = k_n/(p d)` (3D linear), `k_n/p` (2D linear), `(E/((1 − ν²) p))^(2/3)`
//!   (Hertz) (Roux & Chevoir 2005, §2.3.4), whose inverse is the contact deflection over `d`: rigid
//!   grains above [`RIGID_STIFFNESS`], grains that deform (a soft-particle method) when `1/κ`
//!   exceeds [`DEFORMABLE_DEFLECTION`];
//! - cohesion index `ξ = f_c/(p d^(D-1))` with `f_c` the largest capillary (`2π γ cosθ R`) or dry
//!   cohesive force (Nezamabadi 2020, §3.1);
//! - Stokes number `St = σ_i/σ_v = ρ d² ε̇ / η` for a viscous liquid (Nezamabadi 2020, §3.1);
//! - the initial solid fraction, which tells a dilute gas from a packing.
//!
//! The choice: a soft-particle method when grains deform (not in this version: DEM is used and
//! the advice says so); DEM for collisional scenes (dilute gases, free fall, a drum's surface
//! flow), dense inertial flows, moderately soft grains, and imposed motions that squeeze a
//! packing at constant volume (rigid grains have no solution once jammed); contact dynamics for
//! rigid grains in quasi-static loading. The advice also lists the terms the scene does not
//! need, which the engine leaves out.
//!
//! The advice and its numbers are the types of `advice.rs`; `loading.rs` estimates the stress
//! and rate a scene's loading imposes, and the grains' wetness and attraction.

mod advice;
mod loading;
#[cfg(test)]
mod tests;

pub use advice::{Advice, ExpectedCost, Numbers, Regime};

use crate::math::Real;
use crate::scene::{CompactionDrive, Experiment, Scene};
use loading::{adhesion, axis_of_gravity, close_packing, loading_of_container, wet, Loading};

/// Below this inertial number a loading is quasi-static (GDR MiDi 2004; da Cruz et al. 2005).
pub const QUASI_STATIC_INERTIAL: Real = 1e-3;
/// Above this stiffness number grains are rigid for the purpose of the model: contact deflections
/// below 1e-4 d leave the quasi-static response at its rigid limit (Roux & Chevoir 2005, §2.3.4;
/// Agnolin & Roux 2007).
pub const RIGID_STIFFNESS: Real = 1e4;
/// Above this contact deflection over the diameter (1/κ) grains deform beyond what point
/// contacts describe: a soft-particle method (MPM-CD, FEM-CD; Nezamabadi 2020, §2.1) is needed.
pub const DEFORMABLE_DEFLECTION: Real = 0.05;
/// Below this ratio of the fastest imposed speed to the slowest elastic wave of deformable
/// grains (the loading's Mach number), their inertia is left out: bringing a grain to the speed
/// `v` stresses it by `ρ c v` (the impact stress of an elastic rod, `c` its wave speed), so the
/// ratio is the inertial stress over the modulus `ρ c²`; below 1e-2 it is less than the stress
/// of a 1% strain, the smallest deformation the soft-grain methods are used to resolve. The
/// shipped compactions (0.1 m/s against a shear wave of 59 m/s: 1.7e-3) fall below it; free
/// fall across a 2 cm box (0.63 m/s: 1.1e-2) does not.
pub const SOFT_QUASI_STATIC_MACH: Real = 1e-2;
/// Below this fraction of random close packing a scene starts as a dilute gas.
pub const DILUTE_FRACTION: Real = 0.5;
/// The error (relative to a study's reference) within which a stored study's run is good
/// enough for `auto` to take its method and parameters: the cheapest such run wins
/// ([`Advice::learn`]). A percent is below the agreement the soft-grain methods are asked for
/// (2% on Φ at a wall stress) and above the scatter of a converged run.
pub const LEARNED_ACCURACY: Real = 0.01;
/// The grains' mean diameter, density and initial solid fraction, from which the numbers follow.
struct Grains {
    /// Number-mean diameter, m.
    d: Real,
    /// Volume-weighted density, kg/m³.
    rho: Real,
    /// Solid fraction in the box at the start.
    phi0: Real,
}

/// Advises on a validated scene.
pub fn advise(scene: &Scene) -> Advice {
    let grains = grains(scene);
    let mut l = loading(scene, &grains);
    let numbers = numbers(scene, &l, &grains);
    let (regime, why) = match l.regime.take() {
        Some(r) => r,
        None => regime_of(&numbers),
    };
    if let Some(name) = first_deformable(scene) {
        return deformable_advice(scene, name, regime, numbers, why);
    }
    let mut reasons = Vec::new();
    let needs = soft_needs(scene, &numbers, &mut reasons);
    let method = choose_method(regime, why, &numbers, needs.is_some(), &mut reasons);
    if let Some(xi) = numbers.cohesion_index.filter(|x| *x > 1.0) {
        reasons.push(format!("cohesion dominates the confining stress: ξ = {xi:.1e} > 1"));
    }
    Advice {
        method: method.to_string(),
        requested: String::new(),
        regime,
        numbers,
        reasons,
        dropped: dropped(scene),
        needs,
        suggestions: suggestions(scene),
        expected_cost: Vec::new(),
    }
}

/// Whether a scene's deformable grains can be stepped quasi-statically, their inertia left out
/// (`method.dynamics` `"auto"` of `mpm` and `fem`): `Ok` with the reason when the loading is
/// neither collisional nor a dense inertial flow and the fastest imposed motion (walls, cell,
/// free fall across the box, the grains' initial speeds) is slower than
/// [`SOFT_QUASI_STATIC_MACH`] of the slowest shear wave `√(μ/ρ)` of their materials; `Err` with
/// the reason otherwise.
pub fn soft_inertia(scene: &Scene) -> Result<String, String> {
    let grains = grains(scene);
    let mut l = loading(scene, &grains);
    let numbers = numbers(scene, &l, &grains);
    let (regime, _) = l.regime.take().unwrap_or_else(|| regime_of(&numbers));
    if matches!(regime, Regime::Collisional | Regime::DenseFlow) {
        return Err(format!("the loading is {}: the grains' inertia matters", regime.name()));
    }
    let wave = scene
        .materials
        .iter()
        .filter_map(|m| m.deformable.as_ref().map(|d| (crate::constitutive::build(d).moduli().mu / m.density).sqrt()))
        .fold(Real::INFINITY, Real::min);
    if !wave.is_finite() {
        return Err("no deformable material".into());
    }
    let speed = scene.imposed_speed(loading::initial_speed(scene), true);
    let mach = speed / wave;
    if mach < SOFT_QUASI_STATIC_MACH {
        Ok(format!(
            "the grains' inertia (quasi-static load steps, each solved to equilibrium): the fastest imposed motion, {speed:.2e} m/s, is {mach:.1e} of the slowest shear wave ({wave:.3e} m/s), below {SOFT_QUASI_STATIC_MACH:.0e}"
        ))
    } else {
        Err(format!(
            "the fastest imposed motion, {speed:.2e} m/s, is {mach:.1e} of the slowest shear wave ({wave:.3e} m/s), not below {SOFT_QUASI_STATIC_MACH:.0e}: the grains' inertia is kept"
        ))
    }
}

/// The grains' mean diameter, density (volume-weighted over the sets) and solid fraction.
fn grains(scene: &Scene) -> Grains {
    let dim = scene.dim;
    let c = &scene.container;
    let length = |a: usize| c.hi[a] - c.lo[a];
    let box_volume: Real = (0..dim).map(length).product();
    let ball = |d: Real| crate::particles::Particles::volume_of(dim, 0.5 * d);
    let (mut count, mut dsum, mut solid, mut mass) = (0.0, 0.0, 0.0, 0.0);
    match &scene.initial {
        Some(st) => {
            for (r, m) in st.radius.iter().zip(&st.material) {
                let v = ball(2.0 * r);
                count += 1.0;
                dsum += 2.0 * r;
                solid += v;
                mass += v * scene.materials.get(*m).map_or(0.0, |m| m.density);
            }
        }
        None => {
            for s in &scene.sets {
                let n = s.count as Real;
                let v = n * ball(1.0) * s.size.mean_power(dim as Real);
                count += n;
                dsum += n * s.size.mean_diameter();
                solid += v;
                mass += v * scene.materials.get(s.material).map_or(0.0, |m| m.density);
            }
        }
    }
    let d = if count > 0.0 { dsum / count } else { 0.0 };
    let rho = if solid > 0.0 { mass / solid } else { scene.materials.first().map_or(0.0, |m| m.density) };
    let phi0 = if box_volume > 0.0 { solid / box_volume } else { 0.0 };
    Grains { d, rho, phi0 }
}

/// The stress and rate the scene's experiment (or, without one, its container) imposes.
fn loading(scene: &Scene, grains: &Grains) -> Loading {
    let dim = scene.dim;
    let c = &scene.container;
    let length = |a: usize| c.hi[a] - c.lo[a];
    let Grains { d, rho, phi0 } = *grains;
    let g = scene.gravity.norm();
    let mut l = Loading::default();
    match &scene.experiment {
        Some(Experiment::Isotropic { preparation }) => {
            l.stress(preparation.pressure, "experiment.pressure");
            l.rate(preparation.max_strain_rate, "experiment.max_strain_rate (the servo's cap)");
            l.regime = Some((Regime::QuasiStatic, "quasi-static: the compression ends at equilibrium, where the state is measured".into()));
        }
        Some(Experiment::Triaxial { preparation, strain_rate, .. }) => {
            l.stress(preparation.pressure, "experiment.pressure");
            l.rate(*strain_rate, "experiment.strain_rate");
        }
        Some(Experiment::PlaneShear { preparation, shear_rate, .. }) => {
            l.stress(preparation.pressure, "experiment.pressure");
            l.rate(*shear_rate, "experiment.shear_rate");
        }
        Some(Experiment::Compaction { axis, drive, .. }) => match drive {
            CompactionDrive::Velocity { speed, .. } => {
                l.rate(speed / length(*axis), "experiment.speed / box length");
                l.regime = Some((Regime::KinematicSqueeze, "the compaction wall moves at an imposed speed, with no stress control".into()));
            }
            CompactionDrive::Stress { stress, max_speed, .. } => {
                l.stress(*stress, "experiment.stress");
                l.rate(max_speed / length(*axis), "experiment.max_speed / box length");
            }
        },
        Some(Experiment::Deposition { .. }) => {
            l.stress(0.5 * rho * g * phi0 * length(axis_of_gravity(scene)), "weight of the deposit (ρ g Φ H / 2)");
            l.regime = Some((Regime::Collisional, "the grains fall from a gas onto the floor and collide".into()));
        }
        Some(Experiment::Drum { drum, angular_velocity, froude, .. }) => {
            l.stress(0.5 * rho * g * close_packing(dim) * drum.radius, "weight across the drum (ρ g Φ R / 2)");
            l.rate(*angular_velocity, "experiment.angular_velocity");
            l.regime = Some((
                Regime::Collisional,
                format!("the drum's surface flows as a dense inertial layer (Fr = {froude:.1e}, drum regimes after Mellmann, Powder Technol. 118, 251, 2001; I ~ 0.1–0.5 in the flowing layer)"),
            ));
        }
        Some(Experiment::GranuleCompression { strain_rate, .. }) => {
            // The granule holds by its bridges: the stress scale is the cohesive one.
            if let Some(f) = adhesion(scene, d) {
                l.stress(f / d.powi(dim as i32 - 1), "cohesive stress of the bridges (f_c / d^(D-1))");
            }
            l.rate(*strain_rate, "experiment.strain_rate");
        }
        None => loading_of_container(scene, &mut l, rho, phi0, g),
    }
    l
}

/// The dimensionless numbers of the grains under the loading.
fn numbers(scene: &Scene, l: &Loading, grains: &Grains) -> Numbers {
    let dim = scene.dim;
    let Grains { d, rho, phi0 } = *grains;
    let p = l.pressure.as_ref().map(|x| x.0);
    let rate = l.rate.as_ref().map(|x| x.0);
    let law = scene.materials.first().map(|m| m.law);
    let kappa = p.zip(law).map(|(p, law)| law.stiffness_number(dim, p, d));
    let inertial = match (p, rate) {
        (Some(p), Some(r)) if d > 0.0 => Some(r * d * (rho / p).sqrt()),
        (Some(_), None) => Some(0.0),
        _ => None,
    };
    let cohesion_index = adhesion(scene, d).zip(p).map(|(f, p)| f / (p * d.powi(dim as i32 - 1)));
    let viscosity = scene.materials.iter().filter_map(|m| m.liquid).map(|l| l.viscosity).fold(0.0, Real::max);
    let stokes = rate.filter(|_| viscosity > 0.0 && wet(scene)).map(|r| rho * d * d * r / viscosity);
    Numbers {
        mean_diameter: d,
        density: rho,
        pressure: p,
        pressure_source: l.pressure.as_ref().map(|x| x.1.clone()),
        strain_rate: rate,
        strain_rate_source: l.rate.as_ref().map(|x| x.1.clone()),
        initial_solid_fraction: phi0,
        inertial_number: inertial,
        stiffness_number: kappa,
        deflection: kappa.map(|k| 1.0 / k),
        cohesion_index,
        stokes_number: stokes,
    }
}

/// The regime the numbers put the loading in, and why, when the experiment does not fix it.
fn regime_of(numbers: &Numbers) -> (Regime, String) {
    match (numbers.inertial_number, numbers.pressure) {
        (_, None) if numbers.strain_rate.is_some() => {
            (Regime::KinematicSqueeze, "an imposed motion loads the grains and no boundary holds a stress".into())
        }
        (_, None) => (Regime::Unloaded, "nothing imposes a stress or a motion".into()),
        (Some(i), Some(_)) if i >= QUASI_STATIC_INERTIAL => {
            (Regime::DenseFlow, format!("dense inertial flow: I = {i:.1e} ≥ {QUASI_STATIC_INERTIAL:.0e} (GDR MiDi 2004)"))
        }
        (i, Some(_)) => (Regime::QuasiStatic, format!("quasi-static loading: I = {:.1e} < {QUASI_STATIC_INERTIAL:.0e}", i.unwrap_or(0.0))),
    }
}

/// The name of the first deformable material a set of grains is made of, if any.
fn first_deformable(scene: &Scene) -> Option<&str> {
    scene.sets.iter().filter_map(|s| scene.materials.get(s.material)).find(|m| m.deformable.is_some()).map(|m| m.name.as_str())
}

/// The advice for deformable grains, which have one method: their shape is the unknown.
fn deformable_advice(scene: &Scene, name: &str, regime: Regime, numbers: Numbers, why: String) -> Advice {
    let mut reasons = vec![format!(
        "deformable grains (materials.{name}.deformable): the material point method with contact dynamics follows their shape (Nezamabadi 2020, §1.2.2)"
    )];
    if let Some(x) = numbers.deflection {
        reasons.push(format!("contact deflection ~ 1/κ = {x:.2e} of the diameter at the loading's stress"));
    }
    reasons.push(why);
    let mut dropped = dropped(scene);
    match soft_inertia(scene) {
        Ok(left_out) => dropped.push(left_out),
        Err(kept) => reasons.push(kept),
    }
    Advice {
        method: "mpm".to_string(),
        requested: String::new(),
        regime,
        numbers,
        reasons,
        dropped,
        needs: None,
        suggestions: suggestions(scene),
        expected_cost: Vec::new(),
    }
}

/// What the scene needs beyond DEM when its grains deform past point contacts, with the reason.
fn soft_needs(scene: &Scene, numbers: &Numbers, reasons: &mut Vec<String>) -> Option<String> {
    let x = numbers.deflection.filter(|x| *x > DEFORMABLE_DEFLECTION)?;
    reasons.push(format!(
        "the grains deform: contact deflection ~ 1/κ = {x:.2} of the diameter (> {DEFORMABLE_DEFLECTION}, κ < {:.0}); DEM's overlaps stand in for the deformation beyond their validity",
        1.0 / DEFORMABLE_DEFLECTION
    ));
    Some(if scene.dim == 2 {
        "deformable grains: give the material a `deformable` constitutive law (its Young's modulus and Poisson's ratio) and method mpm"
            .to_string()
    } else {
        "a soft-particle method in 3D, which this version does not have (method mpm is 2D)".to_string()
    })
}

/// The method for rigid or soft point-contact grains in the regime, pushing the reasons for it.
fn choose_method(regime: Regime, why: String, numbers: &Numbers, needs: bool, reasons: &mut Vec<String>) -> &'static str {
    let mut method = "dem";
    match regime {
        Regime::Collisional => reasons.push(format!("collisional: {why}; DEM resolves each collision in time")),
        Regime::DenseFlow => reasons.push(format!("{why}: the grains' inertia and collisions matter, which DEM resolves")),
        Regime::KinematicSqueeze => reasons.push(format!(
            "{why}: once the packing jams, rigid grains cannot follow an imposed squeeze at constant volume (contact dynamics has no solution), soft contacts can"
        )),
        Regime::Unloaded => reasons.push(format!("{why}: no stiffness or inertial number to weigh, DEM by default")),
        Regime::QuasiStatic => match numbers.stiffness_number {
            Some(k) if k >= RIGID_STIFFNESS && !needs => {
                method = "cd";
                reasons.push(format!("{why} (ε̇ from {})", numbers.strain_rate_source.as_deref().unwrap_or("nothing: the grains only relax")));
                reasons.push(format!(
                    "rigid grains: κ = {k:.1e} ≥ {RIGID_STIFFNESS:.0e} (Roux & Chevoir 2005, §2.3.4), contact deflections ~ {:.1e} d; contact dynamics takes steps set by the grains' motion, not by the collision time",
                    1.0 / k
                ));
            }
            Some(k) => {
                reasons.push(why);
                if !needs {
                    reasons.push(format!("moderately soft grains: κ = {k:.1e} < {RIGID_STIFFNESS:.0e} (Roux & Chevoir 2005, §2.3.4), the contact deflections (~ {:.1e} d) shape the response, which DEM models", 1.0 / k));
                }
            }
            None => reasons.push(why),
        },
    }
    method
}

/// The terms the scene does not need, which the engine leaves out.
fn dropped(scene: &Scene) -> Vec<String> {
    let mut out = Vec::new();
    let frictionless =
        scene.materials.iter().all(|m| m.friction == 0.0) && scene.stages.iter().all(|s| s.controls.friction.is_none_or(|f| f == 0.0));
    let rolling = scene.materials.iter().any(|m| m.rolling.is_some());
    if frictionless && !rolling {
        out.push("tangential forces and their spring history (no friction: the Coulomb cap is zero); no torque acts, so spins stay as they start".into());
    } else if frictionless {
        out.push("tangential forces and their spring history (no friction: the Coulomb cap is zero)".into());
    }
    if !wet(scene) {
        out.push("capillary bridges and lubrication (a dry scene)".into());
    }
    if scene.dim == 2 {
        out.push("the third dimension: a plane scene of disks, quantities per metre of thickness".into());
    }
    out
}

/// Changes the advisor cannot make itself: a 3D box less than two grains thick along an axis
/// without gravity is a plane scene written in 3D.
fn suggestions(scene: &Scene) -> Vec<String> {
    let c = &scene.container;
    let dmax = scene.sets.iter().map(|s| s.size.max_diameter()).fold(0.0, Real::max);
    (0..3)
        .filter(|&a| scene.dim == 3 && dmax > 0.0 && c.hi[a] - c.lo[a] < 2.0 * dmax && scene.gravity[a] == 0.0)
        .map(|a| {
            format!(
                "the box is less than two grains thick along {}: if nothing varies along it, the scene is plane and a 2D scene (disks, dimension 2) models it at a fraction of the cost",
                crate::math::AXES[a]
            )
        })
        .take(1)
        .collect()
}
