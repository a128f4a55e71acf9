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

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::scene::{CompactionDrive, Deformation, Experiment, Placement, Scene, WallMotion};

/// Below this inertial number a loading is quasi-static (GDR MiDi 2004; da Cruz et al. 2005).
pub const QUASI_STATIC_INERTIAL: Real = 1e-3;
/// Above this stiffness number grains are rigid for the purpose of the model: contact deflections
/// below 1e-4 d leave the quasi-static response at its rigid limit (Roux & Chevoir 2005, §2.3.4;
/// Agnolin & Roux 2007).
pub const RIGID_STIFFNESS: Real = 1e4;
/// Above this contact deflection over the diameter (1/κ) grains deform beyond what point
/// contacts describe: a soft-particle method (MPM-CD, FEM-CD; Nezamabadi 2020, §2.1) is needed.
pub const DEFORMABLE_DEFLECTION: Real = 0.05;
/// Below this fraction of random close packing a scene starts as a dilute gas.
pub const DILUTE_FRACTION: Real = 0.5;
/// The error (relative to a study's reference) within which a stored study's run is good
/// enough for `auto` to take its method and parameters: the cheapest such run wins
/// ([`Advice::learn`]). A percent is below the agreement the soft-grain methods are asked for
/// (2% on Φ at a wall stress) and above the scatter of a converged run.
pub const LEARNED_ACCURACY: Real = 0.01;

/// A scene's scales and dimensionless numbers, as estimated before running.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Numbers {
    /// Number-mean diameter, m.
    pub mean_diameter: Real,
    /// Density of the grains, kg/m³.
    pub density: Real,
    /// Confining stress of the loading, Pa (none when nothing confines the grains).
    pub pressure: Option<Real>,
    /// Where the stress comes from.
    pub pressure_source: Option<String>,
    /// Strain rate of the loading, 1/s (none when nothing is imposed).
    pub strain_rate: Option<Real>,
    /// Where the rate comes from.
    pub strain_rate_source: Option<String>,
    /// Solid fraction of the grains in the box at the start.
    pub initial_solid_fraction: Real,
    /// Inertial number `I = ε̇ d sqrt(ρ/p)`.
    pub inertial_number: Option<Real>,
    /// Stiffness number κ (Roux & Chevoir 2005, §2.3.4).
    pub stiffness_number: Option<Real>,
    /// Contact deflection over the diameter, `1/κ` (for Hertz contacts `((1 − ν²) p/E)^(2/3)`).
    pub deflection: Option<Real>,
    /// Cohesion index `ξ = f_c/(p d^(D-1))`.
    pub cohesion_index: Option<Real>,
    /// Stokes number `ρ d² ε̇ / η`.
    pub stokes_number: Option<Real>,
}

/// What the scene's loading is, for the choice.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Regime {
    /// Grains in free flight and binary collisions (a gas, a fall, a drum's surface flow).
    Collisional,
    /// A dense flow with `I` above the quasi-static bound.
    DenseFlow,
    /// A slow loading of a packing.
    QuasiStatic,
    /// An imposed motion squeezes or shears a closed box with no stress-controlled boundary.
    KinematicSqueeze,
    /// Nothing loads the grains.
    Unloaded,
}

impl Regime {
    /// The name used in the advice.
    pub fn name(self) -> &'static str {
        match self {
            Self::Collisional => "collisional",
            Self::DenseFlow => "dense_flow",
            Self::QuasiStatic => "quasi_static",
            Self::KinematicSqueeze => "kinematic_squeeze",
            Self::Unloaded => "unloaded",
        }
    }
}

/// The advisor's answer for a scene.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Advice {
    /// The method chosen (`dem`, `cd`, `mpm` or `fem`).
    pub method: String,
    /// The method the scene asked for (`auto`, or a name).
    pub requested: String,
    /// The regime the loading puts the grains in.
    pub regime: Regime,
    /// The scene's numbers.
    pub numbers: Numbers,
    /// Why this method, one sentence each, in order of weight.
    pub reasons: Vec<String>,
    /// What the scene does not need and the engine leaves out.
    pub dropped: Vec<String>,
    /// A method the scene needs that this version does not have.
    pub needs: Option<String>,
    /// Changes to the scene that would model it more cheaply, which the advisor cannot make.
    pub suggestions: Vec<String>,
    /// What runs of this scene cost in the studies stored by the service (filled by the
    /// service; empty when none studied it): every run that succeeded, those on their study's
    /// Pareto front marked.
    #[serde(default)]
    pub expected_cost: Vec<ExpectedCost>,
}

/// The cost and error of one stored run of the same scene (a study's run that succeeded).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExpectedCost {
    /// The study.
    pub study_id: i64,
    /// The run's job (its scene holds the method and parameters).
    #[serde(default)]
    pub job_id: i64,
    /// Its series and the run's swept values.
    pub series: String,
    /// The swept values.
    pub label: String,
    /// The method the run used.
    pub method: String,
    /// CPU seconds of the run.
    pub cpu_seconds: f64,
    /// Wall-clock seconds of the run.
    pub wall_seconds: f64,
    /// Its relative error against the study's reference (absolute when the reference is 0).
    pub error: Option<f64>,
    /// On its study's Pareto front of cost against error: no run of the study is both cheaper
    /// and closer.
    #[serde(default)]
    pub pareto: bool,
}

impl Advice {
    /// The cheapest of [`Advice::expected_cost`]'s runs whose error is within `accuracy`
    /// (relative to its study's reference), if one is.
    pub fn cheapest_within(&self, accuracy: Real) -> Option<&ExpectedCost> {
        self.expected_cost
            .iter()
            .filter(|c| c.error.is_some_and(|e| e <= accuracy) && !c.method.is_empty())
            .min_by(|a, b| a.cpu_seconds.total_cmp(&b.cpu_seconds))
    }

    /// Learns from the stored studies of the scene ([`Advice::expected_cost`]): takes the
    /// method of the cheapest run within [`LEARNED_ACCURACY`], with the reason first, and
    /// returns that run (its job's scene holds the parameters to run with). Nothing changes
    /// when no run is that accurate.
    pub fn learn(&mut self) -> Option<ExpectedCost> {
        let run = self.cheapest_within(LEARNED_ACCURACY)?.clone();
        let others: Vec<String> = {
            let mut methods: Vec<&str> = self.expected_cost.iter().map(|c| c.method.as_str()).filter(|m| *m != run.method).collect();
            methods.sort_unstable();
            methods.dedup();
            methods
                .iter()
                .map(|m| {
                    let best = self
                        .expected_cost
                        .iter()
                        .filter(|c| c.method == *m && c.error.is_some_and(|e| e <= LEARNED_ACCURACY))
                        .map(|c| c.cpu_seconds)
                        .fold(Real::INFINITY, Real::min);
                    if best.is_finite() {
                        format!("{m} needed {best:.1} s")
                    } else {
                        format!("no {m} run was that close")
                    }
                })
                .collect()
        };
        let mut why = format!(
            "study {} measured {} ({} {}) within {:.2}% of its reference in {:.1} s of CPU: the cheapest run within {}%",
            run.study_id,
            run.method,
            run.series,
            run.label,
            100.0 * run.error.unwrap_or(0.0),
            run.cpu_seconds,
            100.0 * LEARNED_ACCURACY
        );
        if !others.is_empty() {
            why.push_str(&format!(" ({})", others.join(", ")));
        }
        self.reasons.insert(0, why);
        self.method = run.method.clone();
        Some(run)
    }

    /// One line for a job's `method_reason`: the choice, each reason, what was dropped.
    pub fn summary(&self) -> String {
        let mut s = format!("auto chose {}: {}", self.method, self.reasons.join("; "));
        if let Some(n) = &self.needs {
            s.push_str(&format!("; needs {n}"));
        }
        if !self.dropped.is_empty() {
            s.push_str(&format!("; left out: {}", self.dropped.join("; ")));
        }
        s
    }
}

/// The loading's stress and rate, and what they come from.
#[derive(Default)]
struct Loading {
    pressure: Option<(Real, String)>,
    rate: Option<(Real, String)>,
    /// Set when the loading decides the regime by itself.
    regime: Option<(Regime, String)>,
}

impl Loading {
    fn stress(&mut self, p: Real, source: impl Into<String>) {
        if p > 0.0 && self.pressure.as_ref().is_none_or(|(q, _)| p > *q) {
            self.pressure = Some((p, source.into()));
        }
    }
    fn rate(&mut self, r: Real, source: impl Into<String>) {
        let r = r.abs();
        if r > 0.0 && self.rate.as_ref().is_none_or(|(q, _)| r > *q) {
            self.rate = Some((r, source.into()));
        }
    }
}

/// Random close packing fraction of the scene's dimension (disks, spheres).
fn close_packing(dim: usize) -> Real {
    if dim == 2 {
        0.82
    } else {
        0.64
    }
}

/// Advises on a validated scene.
pub fn advise(scene: &Scene) -> Advice {
    let dim = scene.dim;
    let c = &scene.container;
    let length = |a: usize| c.hi[a] - c.lo[a];
    let box_volume: Real = (0..dim).map(length).product();
    // Grains: mean diameter, density (volume-weighted over the sets), solid volume.
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
    let numbers = Numbers {
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
    };

    // The regime.
    let (regime, why) = match l.regime.take() {
        Some(r) => r,
        None => match (inertial, p) {
            (_, None) if rate.is_some() => {
                (Regime::KinematicSqueeze, "an imposed motion loads the grains and no boundary holds a stress".into())
            }
            (_, None) => (Regime::Unloaded, "nothing imposes a stress or a motion".into()),
            (Some(i), Some(_)) if i >= QUASI_STATIC_INERTIAL => {
                (Regime::DenseFlow, format!("dense inertial flow: I = {i:.1e} ≥ {QUASI_STATIC_INERTIAL:.0e} (GDR MiDi 2004)"))
            }
            (i, Some(_)) => {
                (Regime::QuasiStatic, format!("quasi-static loading: I = {:.1e} < {QUASI_STATIC_INERTIAL:.0e}", i.unwrap_or(0.0)))
            }
        },
    };

    let mut reasons = Vec::new();
    let mut needs = None;
    let mut method = "dem";
    let deflection = kappa.map(|k| 1.0 / k);
    let deformable: Vec<&str> = scene
        .sets
        .iter()
        .filter_map(|s| scene.materials.get(s.material))
        .filter(|m| m.deformable.is_some())
        .map(|m| m.name.as_str())
        .collect();
    if let Some(name) = deformable.first() {
        // Deformable grains have one method: their shape is the unknown.
        let mut reasons = vec![format!(
            "deformable grains (materials.{name}.deformable): the material point method with contact dynamics follows their shape (Nezamabadi 2020, §1.2.2)"
        )];
        if let Some(x) = deflection {
            reasons.push(format!("contact deflection ~ 1/κ = {x:.2e} of the diameter at the loading's stress"));
        }
        reasons.push(why);
        return Advice {
            method: "mpm".to_string(),
            requested: String::new(),
            regime,
            numbers,
            reasons,
            dropped: dropped(scene),
            needs: None,
            suggestions: suggestions(scene),
            expected_cost: Vec::new(),
        };
    }
    if let Some(x) = deflection.filter(|x| *x > DEFORMABLE_DEFLECTION) {
        needs = Some(if scene.dim == 2 {
            "deformable grains: give the material a `deformable` constitutive law (its Young's modulus and Poisson's ratio) and method mpm"
                .to_string()
        } else {
            "a soft-particle method in 3D, which this version does not have (method mpm is 2D)".to_string()
        });
        reasons.push(format!(
            "the grains deform: contact deflection ~ 1/κ = {x:.2} of the diameter (> {DEFORMABLE_DEFLECTION}, κ < {:.0}); DEM's overlaps stand in for the deformation beyond their validity",
            1.0 / DEFORMABLE_DEFLECTION
        ));
    }
    match regime {
        Regime::Collisional => reasons.push(format!("collisional: {why}; DEM resolves each collision in time")),
        Regime::DenseFlow => reasons.push(format!("{why}: the grains' inertia and collisions matter, which DEM resolves")),
        Regime::KinematicSqueeze => reasons.push(format!(
            "{why}: once the packing jams, rigid grains cannot follow an imposed squeeze at constant volume (contact dynamics has no solution), soft contacts can"
        )),
        Regime::Unloaded => reasons.push(format!("{why}: no stiffness or inertial number to weigh, DEM by default")),
        Regime::QuasiStatic => match kappa {
            Some(k) if k >= RIGID_STIFFNESS && needs.is_none() => {
                method = "cd";
                reasons.push(format!("{why} (ε̇ from {})", numbers.strain_rate_source.as_deref().unwrap_or("nothing: the grains only relax")));
                reasons.push(format!(
                    "rigid grains: κ = {k:.1e} ≥ {RIGID_STIFFNESS:.0e} (Roux & Chevoir 2005, §2.3.4), contact deflections ~ {:.1e} d; contact dynamics takes steps set by the grains' motion, not by the collision time",
                    1.0 / k
                ));
            }
            Some(k) => {
                reasons.push(why);
                if needs.is_none() {
                    reasons.push(format!("moderately soft grains: κ = {k:.1e} < {RIGID_STIFFNESS:.0e} (Roux & Chevoir 2005, §2.3.4), the contact deflections (~ {:.1e} d) shape the response, which DEM models", 1.0 / k));
                }
            }
            None => reasons.push(why),
        },
    }
    if let Some(xi) = cohesion_index.filter(|x| *x > 1.0) {
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

/// True if some grains carry liquid.
fn wet(scene: &Scene) -> bool {
    let liquid = |m: usize| scene.materials.get(m).is_some_and(|m| m.liquid.is_some());
    match &scene.initial {
        Some(st) => st.wet.iter().zip(&st.material).any(|(w, m)| *w && liquid(*m)),
        None => scene.sets.iter().any(|s| s.wet_fraction > 0.0 && liquid(s.material)),
    }
}

/// The largest attraction between two grains of diameter `d`, N (N/m in 2D): the capillary
/// force at contact `2π γ cosθ R` (R = d/2; docs/physics.md §2.8) or the dry cohesion F_0.
fn adhesion(scene: &Scene, d: Real) -> Option<Real> {
    let wet = wet(scene);
    let capillary = scene.materials.iter().filter_map(|m| m.liquid.filter(|_| wet)).map(|l| l.capillary_prefactor() * 0.5 * d);
    let cohesion = scene.materials.iter().filter_map(|m| m.cohesion).map(|c| c.force);
    capillary.chain(cohesion).fold(None, |f: Option<Real>, x| Some(f.map_or(x, |f| f.max(x)))).filter(|x| *x > 0.0)
}

/// The axis gravity points along (the largest component; y if there is none).
fn axis_of_gravity(scene: &Scene) -> usize {
    let g = scene.gravity;
    (0..3).max_by(|a, b| g[*a].abs().total_cmp(&g[*b].abs())).filter(|a| g[*a] != 0.0).unwrap_or(1)
}

/// The stress and rate of a scene without an experiment: its walls, cell, shear, gravity and
/// initial velocities.
fn loading_of_container(scene: &Scene, l: &mut Loading, rho: Real, phi0: Real, g: Real) {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(extra: serde_json::Value) -> Scene {
        let mut s = serde_json::json!({
            "dimension": 2, "method": "auto",
            "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e7}, "restitution": 0.5, "friction": 0.3}},
            "particles": [{"material": "glass", "count": 40, "size": {"kind": "uniform", "min": 0.0009, "max": 0.0011}, "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
            "stop": {"steps": 10}
        });
        merge(&mut s, extra);
        crate::scene::parse_scene(&s.to_string()).expect("valid scene")
    }

    fn merge(a: &mut serde_json::Value, b: serde_json::Value) {
        match (a, b) {
            (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
                for (k, v) in b {
                    merge(a.entry(k).or_insert(serde_json::Value::Null), v);
                }
            }
            (serde_json::Value::Array(a), serde_json::Value::Array(b)) if a.len() == b.len() => {
                for (x, y) in a.iter_mut().zip(b) {
                    merge(x, y);
                }
            }
            (a, b) => *a = b,
        }
    }

    fn has(list: &[String], needle: &str) -> bool {
        list.iter().any(|x| x.contains(needle))
    }

    /// A biaxial test at `pressure` (Pa) and `rate` (1/s) of grains with stiffness `k_n`.
    fn biaxial(k_n: f64, pressure: f64, rate: f64) -> Scene {
        scene(serde_json::json!({
            "materials": {"glass": {"contact": {"k_n": k_n}}},
            "experiment": {"kind": "biaxial", "preparation": {"pressure": pressure}, "strain_rate": rate, "axial_strain": 0.05}
        }))
    }

    #[test]
    fn the_advisor_chooses_the_lightest_adequate_model_and_says_why() {
        // Rigid grains (κ = 1e5), slow loading (I = 1.6e-5): contact dynamics.
        let a = advise(&biaxial(1e8, 1000.0, 0.01));
        assert_eq!((a.method.as_str(), a.regime), ("cd", Regime::QuasiStatic), "{a:?}");
        assert!(has(&a.reasons, "quasi-static loading: I = 1.6e-5") && has(&a.reasons, "rigid grains: κ = 1.0e5"), "{:?}", a.reasons);
        // The same test with soft contacts (κ = 100): DEM, because of the stiffness.
        let a = advise(&biaxial(1e5, 1000.0, 0.01));
        assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::QuasiStatic));
        assert!(has(&a.reasons, "moderately soft grains: κ = 1.0e2"), "{:?}", a.reasons);
        assert_eq!(a.needs, None);
        // Contacts deflected by a tenth of a diameter: the grains deform.
        let a = advise(&biaxial(1e4, 1000.0, 0.01));
        assert!(a.needs.as_deref().is_some_and(|n| n.contains("deformable` constitutive law") && n.contains("method mpm")), "{a:?}");
        assert!(has(&a.reasons, "the grains deform: contact deflection ~ 1/κ = 0.10"), "{:?}", a.reasons);
        assert_eq!(a.method, "dem");
        // Rigid grains loaded fast (I = 0.016): a dense inertial flow, DEM.
        let a = advise(&biaxial(1e8, 1000.0, 10.0));
        assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::DenseFlow));
        assert!(has(&a.reasons, "dense inertial flow: I = 1.6e-2"), "{:?}", a.reasons);
        // A dilute gas falling under gravity: collisional, DEM, whatever the stiffness.
        let a = advise(&scene(serde_json::json!({"materials": {"glass": {"contact": {"k_n": 1e9}}}, "gravity": [0, -9.81]})));
        assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::Collisional));
        assert!(has(&a.reasons, "collisional: the grains start as a gas (Φ = 0.32) and fall under gravity"), "{:?}", a.reasons);
        // A wall driven at an imposed speed into a closed box: rigid grains jam, DEM.
        let a = advise(&scene(serde_json::json!({
            "materials": {"glass": {"contact": {"k_n": 1e9}}},
            "experiment": {"kind": "compaction", "velocity": 0.02, "strain": 0.5}
        })));
        assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::KinematicSqueeze));
    }

    #[test]
    fn the_advice_lists_the_terms_a_scene_does_not_need() {
        // Frictionless and dry, in 2D: no tangential history or spins, no liquid, no third axis.
        let a = advise(&scene(serde_json::json!({"materials": {"glass": {"friction": 0.0}}})));
        assert!(
            has(&a.dropped, "tangential forces and their spring history") && has(&a.dropped, "spins stay as they start"),
            "{:?}",
            a.dropped
        );
        assert!(has(&a.dropped, "capillary bridges and lubrication (a dry scene)"));
        assert!(has(&a.dropped, "the third dimension"));
        // Frictional and wet: tangential forces and bridges kept; the cohesion index and the
        // Stokes number computed (f_c = 2π γ R = 2.29e-4 N against p d = 1 N/m in 2D).
        let wet = scene(serde_json::json!({
            "materials": {"glass": {"liquid": {"surface_tension": 0.0728, "contact_angle": 0.0, "bridge_volume": 1e-12, "viscosity": 0.001, "roughness": 1e-5}}},
            "particles": [{"wet_fraction": 1.0}],
            "experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}
        }));
        let a = advise(&wet);
        assert!(!has(&a.dropped, "tangential") && !has(&a.dropped, "capillary"), "{:?}", a.dropped);
        let xi = 2.0 * std::f64::consts::PI * 0.0728 * 0.0005 / (1000.0 * 0.001);
        assert!((a.numbers.cohesion_index.unwrap_or(0.0) - xi).abs() < 1e-9 * xi, "{:?}", a.numbers);
        let st = 2500.0 * 1e-6 * 0.01 / 0.001;
        assert!((a.numbers.stokes_number.unwrap_or(0.0) - st).abs() < 1e-9 * st);
        // Spheres in a box one grain thick along z: the advice says the scene is plane.
        let flat = scene(serde_json::json!({
            "dimension": 3,
            "container": {"min": [0, 0, 0], "max": [0.01, 0.01, 0.0015]},
            "gravity": [0, -9.81, 0]
        }));
        let a = advise(&flat);
        assert!(has(&a.suggestions, "less than two grains thick along z"), "{:?}", a.suggestions);
        assert!(!has(&a.dropped, "third dimension"));
    }

    #[test]
    fn auto_takes_the_advisors_method_and_records_why() {
        let rigid = |method: serde_json::Value| {
            let mut s = serde_json::json!({
                "dimension": 2, "method": method,
                "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e8}, "restitution": 0.5, "friction": 0.3}},
                "particles": [{"material": "glass", "count": 40, "size": {"kind": "monodisperse", "diameter": 0.001}, "placement": {"kind": "random"}}],
                "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
                "experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}
            });
            s["seed"] = 1.into();
            crate::methods::plan_scene(&s.to_string())
        };
        let s = rigid("auto".into()).expect("valid");
        assert_eq!(s.method_name(), "cd");
        assert!(s.reason.starts_with("auto chose cd: quasi-static loading"), "{}", s.reason);
        assert!(s.reason.contains("left out: capillary bridges"), "{}", s.reason);
        assert_eq!(s.advice.as_ref().map(|a| a.requested.as_str()), Some("auto"));
        // A scene that names its method keeps it; the advice says what auto would take.
        let named = rigid("dem".into()).expect("valid");
        assert!(named.method_name() == "dem" && named.advice.is_none());
        let a = named.advice();
        assert_eq!((a.requested.as_str(), a.method.as_str()), ("dem", "cd"));
        // auto sets the parameters itself.
        let v = rigid(serde_json::json!({"kind": "auto", "time_step": 1e-5})).expect_err("rejected");
        assert_eq!(v.len(), 1);
        assert_eq!(v[0].field, "method.time_step");
        assert!(v[0].rule.starts_with("auto chooses the method and its parameters"), "{}", v[0].rule);
    }

    #[test]
    fn the_numbers_of_a_biaxial_test_are_those_of_its_definition() {
        let s = scene(
            serde_json::json!({"experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}}),
        );
        let a = advise(&s);
        let n = &a.numbers;
        assert!((n.mean_diameter - 0.001).abs() < 1e-12);
        assert_eq!(n.pressure, Some(1000.0));
        assert_eq!(n.strain_rate, Some(0.01));
        let i = 0.01 * 0.001 * (2500.0f64 / 1000.0).sqrt();
        assert!((n.inertial_number.unwrap_or(0.0) - i).abs() < 1e-15, "{:?}", n.inertial_number);
        assert_eq!(n.stiffness_number, Some(1e7 / 1000.0));
        assert_eq!(a.regime, Regime::QuasiStatic);
        assert_eq!(a.method, "cd", "{a:?}");
    }

    /// `auto` learns from a stored study: the cheapest run within a percent of the reference
    /// wins, whatever its method; runs without an error or beyond a percent never do. The
    /// reason gives each other method's cheapest run within a percent, on the Pareto front or
    /// not (cd's here is beaten by fem's on both counts).
    #[test]
    fn the_cheapest_run_within_a_percent_sets_the_method() {
        let run = |job_id: i64, method: &str, cpu_seconds: Real, error: Option<Real>| ExpectedCost {
            study_id: 4,
            job_id,
            series: method.to_uppercase(),
            label: format!("run {job_id}"),
            method: method.into(),
            cpu_seconds,
            wall_seconds: cpu_seconds,
            error,
            pareto: false,
        };
        let mut a = advise(&scene(serde_json::json!({})));
        let before = a.method.clone();
        a.expected_cost = vec![
            run(1, "mpm", 11.0, Some(0.03)),
            run(2, "mpm", 76.0, Some(0.004)),
            run(3, "fem", 40.0, Some(0.008)),
            run(4, "fem", 5.0, None),
            run(5, "cd", 90.0, Some(0.009)),
            run(6, "dem", 2.0, Some(0.2)),
        ];
        assert_eq!(a.cheapest_within(0.01).map(|c| c.job_id), Some(3));
        assert_eq!(a.cheapest_within(0.05).map(|c| c.job_id), Some(1));
        assert_eq!(a.cheapest_within(0.001), None);
        let taken = a.learn().expect("a run within a percent");
        assert_eq!((taken.job_id, a.method.as_str()), (3, "fem"));
        assert!(a.reasons[0].starts_with("study 4 measured fem (FEM run 3) within 0.80% of its reference in 40.0 s"), "{}", a.reasons[0]);
        assert!(a.reasons[0].ends_with("(cd needed 90.0 s, no dem run was that close, mpm needed 76.0 s)"), "{}", a.reasons[0]);
        let mut b = advise(&scene(serde_json::json!({})));
        b.expected_cost = vec![run(1, "mpm", 11.0, Some(0.03))];
        assert_eq!((b.learn(), b.method), (None, before));
    }
}
