//! Derived results of the standard experiments (issue "experiments"): computed from the
//! samples of the run, the same way for every method.
//!
//! - **Isotropic**: the state at equilibrium (Φ, Z, p).
//! - **Biaxial / triaxial** (Nezamabadi 2020, eqs. 2.25-2.28): the state after preparation; the
//!   peak of `ζ = q/p`; the steady (critical) state, averaged over the last quarter of the axial
//!   strain; the volumetric strain (compression positive) at its largest contraction and at the
//!   end.
//! - **Plane shear** (Nezamabadi 2020, §3.1): the steady state, averaged over the second half of
//!   the shear strain: μ = τ/σ_n (± std), Φ, Z, the measured inertial number, σ_n (the box's stress
//!   in a Lees-Edwards cell, the upper wall's load between rough walls); for wet grains the
//!   cohesion index ξ, the Stokes number St and the visco-cohesive inertial number I_m.
//! - **Compaction** (Nezamabadi 2020, §2.1): the packing fraction where the moving wall first
//!   carries load, the final and largest packing fractions, stress and strain, the coordination and
//!   the wall stress beyond that onset fitted as powers of `Φ − Φ_J` ([`super::power`]), and for
//!   deformable grains their final mean and largest aspect ratios.
//! - **Deposition**: the height and packing fraction of the settled deposit (from the final
//!   particles), the stress on the floor and the time to settle.
//! - **Granule compression** (Nezamabadi 2020, §3.2.3): the stress-strain curve, the plastic
//!   strength and the prefactor of its prediction, with I and the stiffness number at the plastic
//!   strength.
//! - **Drum** (docs/references.md check 17): means over the rotation after the transient
//!   revolutions of the surface and mass angles, fill, bed packing fraction, drive torque and
//!   velocity profile ([`super::drum`]); the flowing layer's depth and inertial number; the flow
//!   regime ([`drum::drum_regime`]); with wet grains, their granule's accretion and erosion
//!   against the revolutions and the rates of Vo et al.'s law ([`granule_growth`]).
//!
//! Each result states the inertial number `I = ε̇ <d> sqrt(ρ / p)` and the stiffness number
//! (Roux & Chevoir 2005, §2.3.4; docs/physics.md §8: `κ = k_n / (p d)` in 3D and `k_n / p` in 2D
//! for linear contacts, `(E / ((1 - ν²) p))^(2/3)` for Hertz), with a warning when the test is not
//! quasi-static (`I > 1e-3`) or not in the rigid limit (`κ < 1e4`: contacts deflect by more than
//! 1e-4 d; not for deformable grains, which are meant to deform).

mod agglomerate;
mod compaction;
mod deposition;
pub mod drum;
pub mod granule_growth;
mod shear;
#[cfg(test)]
mod tests;
mod triaxial;

use serde::{Deserialize, Serialize};

pub use agglomerate::AgglomerateResult;
pub use compaction::CompactionResult;
pub use deposition::{deposit_of, DepositionResult};
pub use shear::{ShearResult, I_M_ALPHA, I_M_BETA};
pub use triaxial::{Dilatancy, Peak, Steady};

use super::granule::{granule_result, GranuleGrains, GranuleResult};
use super::sample::Sample;
use crate::math::Real;
use crate::scene::{ElasticLaw, Experiment, Scene, StateFile};
use drum::{drum_result, DrumResult};
use shear::WetScales;
use triaxial::triaxial_results;

/// Inertial number above which a test is not quasi-static.
pub const QUASI_STATIC_I: Real = 1e-3;
/// Stiffness number below which contacts are not in the rigid limit.
pub const RIGID_KAPPA: Real = 1e4;
/// The same for the primaries of aggregates: their contacts may deflect by 1% of a primary,
/// the bound validation puts on them at `F_0` (`k_n ≥ 100 F_0 / d_min`): the attraction, not
/// the contacts, sets how an aggregate deforms, and it varies over `a_0 / γ`, 14% of a primary.
pub const AGGREGATE_KAPPA: Real = 100.0;
/// Fraction of the axial strain over which the steady state is averaged (the last quarter).
pub const STEADY_WINDOW: Real = 0.25;
/// Fraction of the final wall stress that marks the onset of load in a compaction.
pub const ONSET_FRACTION: Real = 0.01;

/// The state of the packing at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct State {
    /// Step.
    pub step: u64,
    /// Packing fraction.
    pub phi: f64,
    /// Void ratio `1/Φ - 1`.
    pub void_ratio: f64,
    /// Coordination (all particles).
    pub z: f64,
    /// Coordination without rattlers.
    pub z_no_rattlers: f64,
    /// Mean pressure, Pa.
    pub p: f64,
    /// Stress ratio q/p.
    pub zeta: f64,
    /// The grains' own measures ([`Sample::grains`]): Φ, Z, pressure and shape, for aggregates
    /// of primaries and deformable grains.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<super::grains::GrainSample>,
}

impl State {
    fn of(s: &Sample) -> Self {
        Self {
            step: s.step,
            phi: s.phi,
            void_ratio: if s.phi > 0.0 { 1.0 / s.phi - 1.0 } else { 0.0 },
            z: s.z,
            z_no_rattlers: s.z_no_rattlers,
            p: s.p,
            zeta: s.zeta,
            grains: s.grains.as_deref().copied(),
        }
    }
}

/// The derived results of an experiment (stored with the job; `GET /v1/jobs/{id}` returns them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExperimentResult {
    /// `isotropic`, `biaxial`, `triaxial`, `plane_shear`, `compaction` or `deposition`.
    pub experiment: String,
    /// State at the end of the preparation (isotropic, biaxial, triaxial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prepared: Option<State>,
    /// Peak of `ζ` (biaxial, triaxial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak: Option<Peak>,
    /// Steady state (biaxial, triaxial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady: Option<Steady>,
    /// Volume change (biaxial, triaxial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dilatancy: Option<Dilatancy>,
    /// Compaction results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compaction: Option<CompactionResult>,
    /// Plane shear results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear: Option<ShearResult>,
    /// A plane shear of wet grains: how their cluster (an agglomerate) elongates, loses bridges
    /// and is eroded per unit strain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agglomerate: Option<AgglomerateResult>,
    /// Deposition results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deposition: Option<DepositionResult>,
    /// Granule compression results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub granule: Option<GranuleResult>,
    /// Rotating drum results.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drum: Option<DrumResult>,
    /// State at the end of the run.
    pub last: State,
    /// Inertial number of the loading (of the preparation for the isotropic test).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertial_number: Option<f64>,
    /// Stiffness number at the confining (or final) stress.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_number: Option<f64>,
    /// Why the results may not mean what they seem (not quasi-static, not rigid).
    pub warnings: Vec<String>,
}

impl ExperimentResult {
    /// A result of experiment `experiment` with its prepared and last states, and nothing
    /// derived yet.
    fn new(experiment: String, prepared: Option<State>, last: State) -> Self {
        Self {
            experiment,
            prepared,
            peak: None,
            steady: None,
            dilatancy: None,
            compaction: None,
            shear: None,
            agglomerate: None,
            deposition: None,
            granule: None,
            drum: None,
            last,
            inertial_number: None,
            stiffness_number: None,
            warnings: Vec::new(),
        }
    }
}

/// Collects the samples of a run and computes its experiment's results at the end.
#[derive(Debug, Clone)]
pub struct Analysis {
    experiment: Option<Experiment>,
    dim: usize,
    law: Option<ElasticLaw>,
    samples: Vec<Sample>,
    /// Height and packing fraction of a deposit, from the final state.
    deposit: Option<(Real, Real)>,
    /// The grains' solid volume, polydispersity factor and extreme sizes, from the final state
    /// (granule compression).
    grains: Option<GranuleGrains>,
    /// The liquid, when the grains are wet.
    wet: Option<WetScales>,
    /// The grains deform (methods `mpm`, `fem`): they are meant to be far from the rigid limit.
    deformable: bool,
    /// The grains are aggregates: the rigid limit is the primaries' ([`AGGREGATE_KAPPA`]).
    aggregates: bool,
    /// The aggregates' number-mean nominal diameter, m, when a particle set makes them: the
    /// inertial number of a flow of aggregates is the grains', not the primaries'.
    aggregate_diameter: Option<Real>,
    /// The deformable grains' moduli (the first set's material), for the sources' compaction
    /// laws.
    grain_moduli: Option<crate::observe::compaction_laws::GrainModuli>,
    /// Largest over smallest grain diameter the scene places (1 for one size).
    size_ratio: Real,
    /// Friction coefficient of the first wet grains' material (0 without wet grains).
    wet_friction: Real,
}

impl Analysis {
    /// An analysis of the scene's experiment (none without one).
    pub fn new(scene: &Scene) -> Self {
        let first_material = match &scene.initial {
            Some(st) => st.material.first().copied(),
            None => scene.sets.first().map(|s| s.material),
        };
        let material = first_material.and_then(|m| scene.materials.get(m));
        let any_wet = scene.sets.iter().any(|s| s.wet_fraction > 0.0) || scene.initial.as_ref().is_some_and(|st| st.wet.iter().any(|&w| w));
        let wet = material.and_then(|m| m.liquid).filter(|_| any_wet).map(|l| WetScales {
            kappa: l.capillary_prefactor(),
            viscosity: l.viscosity,
            rupture_distance: l.rupture_distance(),
        });
        Self {
            experiment: scene.experiment.clone(),
            dim: scene.dim,
            law: material.map(|m| m.law),
            samples: Vec::new(),
            deposit: None,
            grains: None,
            wet,
            deformable: false,
            aggregates: scene.sets.iter().any(|s| s.aggregate.is_some())
                || scene.initial.as_ref().is_some_and(|st| !st.bondings.is_empty()),
            aggregate_diameter: scene.sets.iter().find(|s| s.aggregate.is_some()).map(|s| s.size.mean_diameter()),
            size_ratio: size_ratio(scene),
            wet_friction: wet_material(scene).map_or(0.0, |m| m.friction),
            grain_moduli: material.and_then(|m| m.deformable).map(|law| {
                let (young, poisson) = law.young_poisson();
                let lame = crate::constitutive::Lame::from_young(young, poisson);
                let bulk = if scene.dim == 2 { lame.lambda + lame.mu } else { lame.bulk() };
                crate::observe::compaction_laws::GrainModuli { bulk, p_wave: lame.p_wave() }
            }),
        }
    }

    /// What the method running the scene models: rigid grains (contact dynamics) have no
    /// stiffness number, they are the rigid limit; deformable grains (`mpm`, `fem`) are meant to
    /// be far from it ([`crate::run::Simulation::grain_model`]).
    pub fn for_grains(&mut self, model: crate::run::GrainModel) {
        if model == crate::run::GrainModel::Rigid {
            self.law = None;
        }
        self.deformable = model == crate::run::GrainModel::Deformable;
    }

    /// True if the results need the final particles ([`Analysis::final_state`]).
    pub fn needs_final_state(&self) -> bool {
        matches!(self.experiment, Some(Experiment::Deposition { .. } | Experiment::GranuleCompression { .. }))
    }

    /// Takes the final particles, for the results that depend on them (a deposit's height).
    pub fn final_state(&mut self, state: &StateFile) {
        match self.experiment {
            Some(Experiment::Deposition { axis, floor_upper, .. }) => self.deposit = Some(deposit_of(state, axis, floor_upper)),
            Some(Experiment::GranuleCompression { .. }) => {
                let d: Vec<Real> = state.particles.radius.iter().map(|r| 2.0 * r).collect();
                self.grains = Some(GranuleGrains::of(self.dim, &d));
            }
            _ => {}
        }
    }

    /// Takes one sample (kept only when there is an experiment).
    pub fn push(&mut self, s: &Sample) {
        if self.experiment.is_some() {
            self.samples.push(s.clone());
        }
    }

    /// Stiffness number at pressure `p` for grains of mean diameter `d` (Roux & Chevoir 2005,
    /// §2.3.4).
    pub fn stiffness_number(&self, p: Real, d: Real) -> Option<Real> {
        if p <= 0.0 {
            return None;
        }
        Some(self.law?.stiffness_number(self.dim, p, d))
    }

    /// The results, given the grains' mean diameter (m) and density (kg/m³).
    pub fn finish(&self, mean_diameter: Real, density: Real) -> Option<ExperimentResult> {
        let experiment = self.experiment.as_ref()?;
        let last = self.samples.last()?;
        let stage = |name: &'static str| self.samples.iter().filter(move |s| s.stage.as_deref() == Some(name));
        let prepared = stage("preparation").next_back().map(State::of);
        let mut r = ExperimentResult::new(experiment.kind(self.dim).to_string(), prepared, State::of(last));
        let flow = Flow { mean_diameter, diameter: self.grain_diameter(last).unwrap_or(mean_diameter), density };
        let inertial = |rate: Real, p: Real| flow.inertial(rate, p);
        match experiment {
            Experiment::Isotropic { preparation } => {
                r.inertial_number = inertial(preparation.max_strain_rate, preparation.pressure);
                r.stiffness_number = self.stiffness_number(preparation.pressure, mean_diameter);
            }
            Experiment::Triaxial { preparation, axis, strain_rate, .. } => {
                r.inertial_number = inertial(*strain_rate, preparation.pressure);
                r.stiffness_number = self.stiffness_number(preparation.pressure, mean_diameter);
                let loading: Vec<(Real, &Sample)> =
                    stage("loading").filter_map(|s| s.strain.as_ref().map(|e| (e.axes.get(*axis).copied().unwrap_or(0.0), s))).collect();
                triaxial_results(&mut r, &loading);
            }
            Experiment::PlaneShear { preparation, shear_rate, rough_walls, .. } => {
                r.stiffness_number = self.stiffness_number(preparation.pressure, mean_diameter);
                let shear: Vec<&Sample> = stage("shear").collect();
                self.plane_shear(&mut r, &shear, *shear_rate, *rough_walls, &flow);
                r.agglomerate = agglomerate::agglomerate_result(&shear, *shear_rate);
            }
            Experiment::GranuleCompression { axis, plateau, strain_rate, .. } => {
                let relaxed = stage("relaxation").next_back();
                let run: Vec<&Sample> = stage("compression").collect();
                let f_c = self.wet.map_or(0.0, |w| w.kappa * 0.5 * mean_diameter);
                let sigma_c = f_c / mean_diameter.powi(self.dim as i32 - 1);
                let grains = self.grains.unwrap_or_default();
                let rupture = self.wet.map(|w| w.rupture_distance);
                r.granule = granule_result(&run, relaxed, *axis, *plateau, self.dim, grains, sigma_c, rupture);
                if let Some(g) = &r.granule {
                    if g.plastic_strength.is_none() {
                        r.warnings.push(format!(
                            "no sample in the plateau window (strain {} to {}): no plastic strength; sample more often (sampling.every_time)",
                            plateau.0, plateau.1
                        ));
                    }
                    // At the plastic strength (the stress that holds the granule while it yields).
                    let p = g.plastic_strength.filter(|&p| p > 0.0).unwrap_or(sigma_c);
                    r.stiffness_number = self.stiffness_number(p, mean_diameter);
                    r.inertial_number = inertial(*strain_rate, p);
                }
            }
            Experiment::Drum { .. } => {
                let rotation: Vec<&Sample> = stage("rotation").collect();
                if let Some((mut d, bottom)) = drum_result(experiment, stage("filling").next_back(), &rotation, mean_diameter, density) {
                    // The weight on the bottom of the bed sets the stiffness number.
                    r.stiffness_number = self.stiffness_number(bottom, mean_diameter);
                    d.granule = granule_growth::granule_growth(&rotation, d.angular_velocity, self.size_ratio, self.wet_friction);
                    r.drum = Some(d);
                }
            }
            Experiment::Deposition { axis, floor_upper, .. } => {
                let floor = format!("{}_{}", crate::math::AXES[*axis], if *floor_upper { "max" } else { "min" });
                let floor_stress = last.walls.iter().find(|w| w.name == floor).map_or(0.0, |w| w.normal_stress);
                let (bed_height, phi_bed) = self.deposit.unwrap_or((0.0, 0.0));
                r.deposition = Some(DepositionResult { bed_height, phi_bed, floor_stress, time: last.time });
                r.stiffness_number = self.stiffness_number(floor_stress, mean_diameter);
            }
            Experiment::Compaction { axis, drive, .. } => {
                let run: Vec<&Sample> = stage("compaction").collect();
                self.compaction(&mut r, &run, *axis, drive, &flow);
            }
        }
        self.warn(&mut r);
        Some(r)
    }

    /// The diameter of the flowing grains, m, for the inertial number: for aggregates their
    /// nominal diameter (from the set) or, for aggregates a saved state holds, that of a disk
    /// (ball) of their measured mean area (volume), not the primaries'; `None` for grains that
    /// are particles.
    fn grain_diameter(&self, last: &Sample) -> Option<Real> {
        self.aggregate_diameter
            .or_else(|| last.grains.as_ref().filter(|g| g.mean_area > 0.0 && !self.deformable).map(|g| g.mean_diameter(self.dim)))
    }

    /// The warnings of a result whose test is not quasi-static or not in the rigid limit.
    fn warn(&self, r: &mut ExperimentResult) {
        // The bounds themselves do not warn (1e-9 relative margin for rounding: a rate chosen for
        // I = 1e-3 must not be flagged).
        if let Some(i) = r.inertial_number.filter(|&i| i > QUASI_STATIC_I * (1.0 + 1e-9)) {
            r.warnings.push(format!(
                "not quasi-static: inertial number I = {i:.2e} > {QUASI_STATIC_I:e}; lower the strain rate (or the wall speed) for quasi-static results"
            ));
        }
        let rigid = if self.aggregates { AGGREGATE_KAPPA } else { RIGID_KAPPA };
        if let Some(k) = r.stiffness_number.filter(|&k| !self.deformable && k < rigid * (1.0 - 1e-9)) {
            let deflection = 1.0 / k;
            let what = if self.aggregates {
                format!("the primaries' contacts deflect by about {deflection:.1e} of a primary, more than the 1% they may at F_0")
            } else {
                format!("contacts deflect by about {deflection:.1e} of a diameter")
            };
            r.warnings.push(format!(
                "not in the rigid limit: stiffness number {k:.2e} < {rigid:e} ({what}); stiffen the contacts or lower the stress"
            ));
        }
    }
}

/// The scales of a flow: the particles' mean diameter (m; the primaries' for aggregates), the
/// grains' (m; the flow's), and the density (kg/m³).
pub(super) struct Flow {
    pub(super) mean_diameter: Real,
    pub(super) diameter: Real,
    pub(super) density: Real,
}

impl Flow {
    /// The inertial number `rate d sqrt(ρ / p)` of the grains at strain rate `rate` (1/s) and
    /// pressure `p` (Pa); `None` at `p ≤ 0`.
    pub(super) fn inertial(&self, rate: Real, p: Real) -> Option<Real> {
        (p > 0.0).then(|| rate * self.diameter * (self.density / p).sqrt())
    }
}

/// Largest over smallest grain diameter the scene places: of its saved state's grains, or of
/// its particle sets' size distributions (1 when it places none).
fn size_ratio(scene: &Scene) -> Real {
    let (largest, smallest) = match &scene.initial {
        Some(st) => st.radius.iter().fold((0.0 as Real, Real::INFINITY), |(a, b), &r| (a.max(r), b.min(r))),
        None => {
            scene.sets.iter().fold((0.0 as Real, Real::INFINITY), |(a, b), s| (a.max(s.size.max_diameter()), b.min(s.size.min_diameter())))
        }
    };
    if smallest > 0.0 && smallest.is_finite() {
        largest / smallest
    } else {
        1.0
    }
}

/// The material of the scene's first wet grains.
fn wet_material(scene: &Scene) -> Option<&crate::scene::Material> {
    let index = match &scene.initial {
        Some(st) => st.wet.iter().zip(&st.material).find(|(w, _)| **w).map(|(_, &m)| m),
        None => scene.sets.iter().find(|s| s.wet_fraction > 0.0).map(|s| s.material),
    };
    scene.materials.get(index?)
}
