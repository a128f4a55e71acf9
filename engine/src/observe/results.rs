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
//!   regime ([`super::drum::drum_regime`]).
//!
//! Each result states the inertial number `I = ε̇ <d> sqrt(ρ / p)` and the stiffness number
//! (Roux & Chevoir 2005, §2.3.4; docs/physics.md §8: `κ = k_n / (p d)` in 3D and `k_n / p` in 2D
//! for linear contacts, `(E / ((1 - ν²) p))^(2/3)` for Hertz), with a warning when the test is not
//! quasi-static (`I > 1e-3`) or not in the rigid limit (`κ < 1e4`: contacts deflect by more than
//! 1e-4 d; not for deformable grains, which are meant to deform).

use serde::{Deserialize, Serialize};

use super::drum::{drum_result, DrumResult};
use super::granule::{granule_result, GranuleResult};
use super::power::{power_fit, PowerFit};
use super::sample::Sample;
use crate::math::Real;
use crate::particles::Particles;
use crate::scene::{CompactionDrive, ElasticLaw, Experiment, Scene, StateFile};

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
    /// The grains' own measures when they are aggregates of primaries (the fields above are
    /// then the primaries'): Φ, Z, pressure and shape of the grains ([`Sample::grains`]).
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

/// The peak of the stress ratio in a biaxial or triaxial test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Peak {
    /// Largest `ζ = q/p`.
    pub zeta: f64,
    /// Axial strain at the peak.
    pub axial_strain: f64,
    /// Volumetric strain at the peak (compression positive).
    pub volumetric_strain: f64,
    /// Packing fraction at the peak.
    pub phi: f64,
    /// The grains' own measures at the peak when they are aggregates of primaries (`phi` is
    /// then the primaries').
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<super::grains::GrainSample>,
}

/// The steady (critical) state: means over the last quarter of the axial strain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Steady {
    /// Axial strain where the averaging window starts.
    pub from_axial_strain: f64,
    /// Samples in the window.
    pub samples: usize,
    /// Mean `ζ`.
    pub zeta: f64,
    /// Standard deviation of `ζ` over the window.
    pub zeta_std: f64,
    /// Mean packing fraction.
    pub phi: f64,
    /// Mean coordination without rattlers.
    pub z_no_rattlers: f64,
    /// Dilatancy rate `-d eps_v / d eps_a` over the window (least squares; 0 at a critical state).
    pub dilatancy_rate: f64,
    /// The grains' own measures averaged over the window when they are aggregates of
    /// primaries (`phi` and `z_no_rattlers` are then the primaries'): the steady Φ, Z, pressure
    /// and shape of the grains (`max_aspect_ratio` the mean of each sample's largest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<super::grains::GrainSample>,
}

/// Volume change along a biaxial or triaxial test (compression positive).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Dilatancy {
    /// Largest volumetric strain (the most contracted state).
    pub max_contraction: f64,
    /// Axial strain there.
    pub at_axial_strain: f64,
    /// Volumetric strain at the end; below `max_contraction` when the sample dilated.
    pub final_volumetric_strain: f64,
}

/// Results of a compaction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CompactionResult {
    /// Packing fraction when the moving wall first carries 1% of its final stress.
    pub phi_onset: Option<f64>,
    /// Final packing fraction.
    pub phi_final: f64,
    /// Final stress on the moving wall, Pa.
    pub wall_stress: f64,
    /// Final strain `|ln(h/h_i)|` of the compacted axis.
    pub strain: f64,
    /// Largest packing fraction reached.
    pub phi_max: f64,
    /// The coordination beyond the onset, `Z − Z_J = a (Φ − Φ_J)^b` over the samples after
    /// it (`Φ_J`, `Z_J`: those of the onset's sample; Z over all grains). Soft grains: `b ≈ ½`
    /// (docs/physics.md §9; Nezamabadi 2020, eq. 2.20).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coordination_fit: Option<PowerFit>,
    /// The moving wall's stress beyond the onset, `σ = a (Φ − Φ_J)^b` (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stress_fit: Option<PowerFit>,
    /// The grains' mean aspect ratio at the end (deformable grains; 1 for disks): how much
    /// their shape changed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_aspect_ratio: Option<f64>,
    /// The largest aspect ratio of a grain at the end (deformable grains).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_aspect_ratio: Option<f64>,
    /// `"grains"` when the grains are aggregates of primaries (the bonded particle method): Φ,
    /// Z and the aspect ratios above are then the grains' own ([`Sample::grains`]), not the
    /// primaries'; absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
}

/// Results of a deposition under gravity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DepositionResult {
    /// Height of the deposit above the floor, m: twice the mean height of its solid volume (exact
    /// for a layer of uniform packing fraction; a few stray grains on top barely move it).
    pub bed_height: f64,
    /// Packing fraction of the deposit: solid volume / (floor area × `bed_height`).
    pub phi_bed: f64,
    /// Normal stress on the floor at the end, Pa (the weight of the deposit per floor area,
    /// less what the side walls carry).
    pub floor_stress: f64,
    /// Time the grains took to fall and settle, s.
    pub time: f64,
}

/// Height and packing fraction of a deposit resting on the floor of axis `axis` (the upper
/// wall if `floor_upper`): twice the mean height of the solid volume above the floor, and the
/// solid volume over the floor area times that height.
pub fn deposit_of(state: &StateFile, axis: usize, floor_upper: bool) -> (Real, Real) {
    let dim = state.dimension as usize;
    let p = &state.particles;
    let (mut volume, mut moment) = (0.0, 0.0);
    for (x, &r) in p.position.iter().zip(&p.radius) {
        let v = Particles::volume_of(dim, r);
        let above = match (x.get(axis), floor_upper) {
            (Some(x), false) => x - state.min[axis],
            (Some(x), true) => state.max[axis] - x,
            (None, _) => 0.0,
        };
        volume += v;
        moment += v * above;
    }
    if volume <= 0.0 {
        return (0.0, 0.0);
    }
    let height = 2.0 * moment / volume;
    let area: Real = (0..dim).filter(|&a| a != axis).map(|a| state.max[a] - state.min[a]).product();
    (height, if height > 0.0 && area > 0.0 { volume / (area * height) } else { 0.0 })
}

/// The steady state of a plane shear: means over the second half of the shear strain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ShearResult {
    /// Shear strain where the averaging window starts.
    pub from_strain: f64,
    /// Samples in the window.
    pub samples: usize,
    /// Mean effective friction `μ = τ / σ_n` (between rough walls, of the upper wall's load).
    pub mu: f64,
    /// Its standard deviation over the window.
    pub mu_std: f64,
    /// Mean packing fraction.
    pub phi: f64,
    /// Mean coordination without rattlers.
    pub z_no_rattlers: f64,
    /// Mean inertial number measured in the samples (`γ̇ <d> sqrt(ρ / σ_n)`).
    pub inertial_number: f64,
    /// Mean normal stress σ_yy, Pa (of the box in a Lees-Edwards cell, on the upper wall between
    /// rough walls).
    pub normal_stress: f64,
    /// Wet grains (Nezamabadi 2020, §3.1): cohesion index `ξ = σ_c / σ_n` with
    /// `σ_c = f_c / d^(D-1)` and `f_c = 2π γ cos θ <d>/2` the largest capillary force between
    /// grains of the mean size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cohesion_index: Option<f64>,
    /// Wet grains: Stokes number `St = σ_i / σ_v = ρ <d>² γ̇ / η` (absent for an inviscid
    /// liquid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes_number: Option<f64>,
    /// Wet grains: visco-cohesive inertial number `I_m = I sqrt((1 + β/St) / (1 + α ξ))`,
    /// α = 0.062, β = 0.075 (Nezamabadi 2020, eq. 3.1; Vo et al. 2020).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub viscocohesive_inertial_number: Option<f64>,
}

/// α of the visco-cohesive inertial number (Nezamabadi 2020, eq. 3.1).
pub const I_M_ALPHA: Real = 0.062;
/// β of the visco-cohesive inertial number (Nezamabadi 2020, eq. 3.1).
pub const I_M_BETA: Real = 0.075;

/// The liquid of wet grains, for the wet shear numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
struct WetScales {
    /// `2π γ cos θ`, N/m.
    kappa: Real,
    /// Viscosity, Pa·s.
    viscosity: Real,
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

/// Collects the samples of a run and computes its experiment's results at the end.
#[derive(Debug, Clone)]
pub struct Analysis {
    experiment: Option<Experiment>,
    dim: usize,
    law: Option<ElasticLaw>,
    samples: Vec<Sample>,
    /// Height and packing fraction of a deposit, from the final state.
    deposit: Option<(Real, Real)>,
    /// Solid volume (m³, m² in 2D) and polydispersity factor `s` of the grains, from the final
    /// state (granule compression).
    grains: Option<(Real, Real)>,
    /// The liquid, when the grains are wet.
    wet: Option<WetScales>,
    /// The grains deform (methods `mpm`, `fem`): they are meant to be far from the rigid limit.
    deformable: bool,
    /// The grains are aggregates: the rigid limit is the primaries' ([`AGGREGATE_KAPPA`]).
    aggregates: bool,
    /// The aggregates' number-mean nominal diameter, m, when a particle set makes them: the
    /// inertial number of a flow of aggregates is the grains', not the primaries'.
    aggregate_diameter: Option<Real>,
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
        let wet = material
            .and_then(|m| m.liquid)
            .filter(|_| any_wet)
            .map(|l| WetScales { kappa: l.capillary_prefactor(), viscosity: l.viscosity });
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
                let n = d.len().max(1) as Real;
                let m = |k: Real| d.iter().map(|x| x.powf(k)).sum::<Real>() / n;
                let s = if m(3.0) > 0.0 { m(0.5) * m(1.0) * m(1.5) / m(3.0) } else { 0.0 };
                let solid = d.iter().map(|x| Particles::volume_of(self.dim, 0.5 * x)).sum();
                self.grains = Some((solid, s));
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
        let mut r = ExperimentResult {
            experiment: experiment.kind(self.dim).to_string(),
            prepared,
            peak: None,
            steady: None,
            dilatancy: None,
            compaction: None,
            shear: None,
            deposition: None,
            granule: None,
            drum: None,
            last: State::of(last),
            inertial_number: None,
            stiffness_number: None,
            warnings: Vec::new(),
        };
        // The inertial number is the grains': for aggregates their nominal diameter (from the
        // set) or, for aggregates a saved state holds, that of a disk (ball) of their measured
        // mean area (volume), not the primaries' (`mean_diameter`).
        let grain_diameter = self.aggregate_diameter.or_else(|| {
            last.grains.as_ref().filter(|g| g.mean_area > 0.0).map(|g| {
                if self.dim == 3 {
                    (6.0 * g.mean_area / std::f64::consts::PI).cbrt()
                } else {
                    2.0 * (g.mean_area / std::f64::consts::PI).sqrt()
                }
            })
        });
        let flow_diameter = grain_diameter.unwrap_or(mean_diameter);
        let inertial = |rate: Real, p: Real| (p > 0.0).then(|| rate * flow_diameter * (density / p).sqrt());
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
                // The steady state is averaged over the second half of the shear strain (the
                // strain of a sample is its time since the stage started × the rate).
                if let (Some(first), Some(last)) = (shear.first(), shear.last()) {
                    let total = last.time - first.time;
                    let from = first.time + 0.5 * total;
                    let window: Vec<&&Sample> = shear.iter().filter(|s| s.time >= from).collect();
                    if !window.is_empty() {
                        let n = window.len() as Real;
                        let mean = |f: &dyn Fn(&Sample) -> Real| window.iter().map(|s| f(s)).sum::<Real>() / n;
                        // Between rough walls the upper wall's load is the measure (the stress
                        // of the box misses the glued layers' load on the walls behind them):
                        // μ = |F_x| / F_y and σ_n its normal stress; I from σ_n.
                        let wall_mu = |s: &Sample| {
                            s.walls.iter().find(|w| w.name == "y_max").map_or(0.0, |w| {
                                let (fx, fy) = (w.force.first().copied().unwrap_or(0.0), w.force.get(1).copied().unwrap_or(0.0));
                                if fy > 0.0 {
                                    fx.abs() / fy
                                } else {
                                    0.0
                                }
                            })
                        };
                        let wall_stress = |s: &Sample| s.walls.iter().find(|w| w.name == "y_max").map_or(0.0, |w| w.normal_stress);
                        let mu_of = |s: &Sample| if *rough_walls { wall_mu(s) } else { s.mu.unwrap_or(0.0) };
                        let mu = mean(&mu_of);
                        let normal_stress = if *rough_walls { mean(&wall_stress) } else { mean(&|s| s.stress.yy) };
                        let i = if *rough_walls {
                            inertial(*shear_rate, normal_stress).unwrap_or(0.0)
                        } else {
                            // The samples' I is at the primaries' mean diameter (that of the
                            // box's particles, `mean_diameter`): for aggregates, rescaled to
                            // the grains' (`flow_diameter`).
                            let scale = if mean_diameter > 0.0 { flow_diameter / mean_diameter } else { 1.0 };
                            mean(&|s| s.inertial_number.unwrap_or(0.0)) * scale
                        };
                        r.inertial_number = Some(i);
                        // Wet grains: cohesion index, Stokes number, visco-cohesive inertial number.
                        let (mut xi, mut st, mut i_m) = (None, None, None);
                        if let Some(w) = self.wet.filter(|_| normal_stress > 0.0) {
                            let f_c = w.kappa * 0.5 * mean_diameter;
                            let x = f_c / mean_diameter.powi(self.dim as i32 - 1) / normal_stress;
                            let stokes = (w.viscosity > 0.0).then(|| density * mean_diameter * mean_diameter * shear_rate / w.viscosity);
                            let viscous = stokes.map_or(0.0, |st| I_M_BETA / st);
                            xi = Some(x);
                            st = stokes;
                            i_m = Some(i * ((1.0 + viscous) / (1.0 + I_M_ALPHA * x)).sqrt());
                        }
                        r.shear = Some(ShearResult {
                            from_strain: shear_rate * (from - first.time),
                            samples: window.len(),
                            mu,
                            mu_std: (window.iter().map(|s| (mu_of(s) - mu).powi(2)).sum::<Real>() / n).sqrt(),
                            phi: mean(&|s| s.phi),
                            z_no_rattlers: mean(&|s| s.z_no_rattlers),
                            inertial_number: i,
                            normal_stress,
                            cohesion_index: xi,
                            stokes_number: st,
                            viscocohesive_inertial_number: i_m,
                        });
                    }
                }
            }
            Experiment::GranuleCompression { axis, plateau, strain_rate, .. } => {
                let relaxed = stage("relaxation").next_back();
                let run: Vec<&Sample> = stage("compression").collect();
                let (solid, s) = self.grains.unwrap_or((0.0, 0.0));
                let f_c = self.wet.map_or(0.0, |w| w.kappa * 0.5 * mean_diameter);
                let sigma_c = f_c / mean_diameter.powi(self.dim as i32 - 1);
                r.granule = granule_result(&run, relaxed, *axis, *plateau, self.dim, solid, s, sigma_c);
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
                if let Some((d, bottom)) = drum_result(experiment, stage("filling").next_back(), &rotation, mean_diameter, density) {
                    // The weight on the bottom of the bed sets the stiffness number.
                    r.stiffness_number = self.stiffness_number(bottom, mean_diameter);
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
                let wall = format!("{}_max", crate::math::AXES[*axis]);
                let stress_of = |s: &Sample| s.walls.iter().find(|w| w.name == wall).map_or(0.0, |w| w.normal_stress);
                let final_stress = stress_of(last);
                let onset = run.iter().position(|s| final_stress > 0.0 && stress_of(s) >= ONSET_FRACTION * final_stress);
                // Grains are judged by their own Φ, Z and shapes (for aggregates of primaries
                // these differ from the primaries' in the sample's top fields).
                let grains = last.grains.is_some() && last.deformable.is_none();
                let phi = |s: &Sample| s.grains.as_ref().filter(|_| grains).map_or(s.phi, |g| g.phi);
                let z = |s: &Sample| s.grains.as_ref().filter(|_| grains).map_or(s.z, |g| g.z);
                let phi_onset = onset.map(|k| phi(run[k]));
                let strain = last.strain.as_ref().and_then(|e| e.axes.get(*axis).copied()).unwrap_or(0.0);
                let (coordination_fit, stress_fit) = match onset {
                    Some(k) => {
                        let (jammed, beyond) = (run[k], &run[k + 1..]);
                        (
                            power_fit(beyond.iter().map(|s| (phi(s) - phi(jammed), z(s) - z(jammed)))),
                            power_fit(beyond.iter().map(|s| (phi(s) - phi(jammed), stress_of(s)))),
                        )
                    }
                    None => (None, None),
                };
                let shape = last.grains.as_ref().map(|g| (g.mean_aspect_ratio, g.max_aspect_ratio));
                r.compaction = Some(CompactionResult {
                    phi_onset,
                    phi_final: phi(last),
                    wall_stress: final_stress,
                    strain,
                    phi_max: run.iter().map(|s| phi(s)).fold(phi(last), f64::max),
                    coordination_fit,
                    stress_fit,
                    mean_aspect_ratio: shape.map(|s| s.0),
                    max_aspect_ratio: shape.map(|s| s.1),
                    level: grains.then(|| "grains".to_string()),
                });
                r.stiffness_number = self.stiffness_number(final_stress, mean_diameter);
                if let CompactionDrive::Velocity { speed, .. } = drive {
                    // Strain rate at the end: speed over the current height.
                    let h = last
                        .walls
                        .iter()
                        .find(|w| w.name == wall)
                        .map(|w| w.position)
                        .zip(last.walls.iter().find(|w| w.name == format!("{}_min", crate::math::AXES[*axis])).map(|w| w.position));
                    if let Some((hi, lo)) = h.filter(|(hi, lo)| hi > lo) {
                        r.inertial_number = inertial(speed / (hi - lo), final_stress);
                    }
                }
            }
        }
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
        Some(r)
    }
}

fn triaxial_results(r: &mut ExperimentResult, loading: &[(Real, &Sample)]) {
    let Some(&(end, _)) = loading.last() else { return };
    let ev = |s: &Sample| s.strain.as_ref().map_or(0.0, |e| e.volumetric);
    if let Some(&(ea, s)) = loading.iter().filter(|(ea, _)| *ea > 0.0).max_by(|a, b| a.1.zeta.total_cmp(&b.1.zeta)) {
        r.peak = Some(Peak { zeta: s.zeta, axial_strain: ea, volumetric_strain: ev(s), phi: s.phi, grains: s.grains.as_deref().copied() });
    }
    if let Some(&(ea, s)) = loading.iter().max_by(|a, b| ev(a.1).total_cmp(&ev(b.1))) {
        r.dilatancy =
            Some(Dilatancy { max_contraction: ev(s), at_axial_strain: ea, final_volumetric_strain: ev(loading[loading.len() - 1].1) });
    }
    let from = (1.0 - STEADY_WINDOW) * end;
    let window: Vec<&(Real, &Sample)> = loading.iter().filter(|(ea, _)| *ea >= from).collect();
    if window.len() >= 2 {
        let n = window.len() as Real;
        let mean = |f: &dyn Fn(&Sample) -> Real| window.iter().map(|(_, s)| f(s)).sum::<Real>() / n;
        let zeta = mean(&|s| s.zeta);
        let zeta_std = (window.iter().map(|(_, s)| (s.zeta - zeta).powi(2)).sum::<Real>() / n).sqrt();
        // Least-squares slope of eps_v against eps_a.
        let xa = window.iter().map(|(ea, _)| ea).sum::<Real>() / n;
        let ya = mean(&ev);
        let sxy: Real = window.iter().map(|(ea, s)| (ea - xa) * (ev(s) - ya)).sum();
        let sxx: Real = window.iter().map(|(ea, _)| (ea - xa).powi(2)).sum();
        r.steady = Some(Steady {
            from_axial_strain: from,
            samples: window.len(),
            zeta,
            zeta_std,
            phi: mean(&|s| s.phi),
            z_no_rattlers: mean(&|s| s.z_no_rattlers),
            dilatancy_rate: if sxx > 0.0 { -sxy / sxx } else { 0.0 },
            grains: mean_grains(window.iter().map(|(_, s)| s.grains.as_deref())),
        });
    }
}

/// The mean of the grains' measures over samples that all carry them (`None` if one does not).
fn mean_grains<'a>(samples: impl Iterator<Item = Option<&'a super::grains::GrainSample>>) -> Option<super::grains::GrainSample> {
    let mut sum = super::grains::GrainSample::default();
    let mut n = 0usize;
    for g in samples {
        let g = g?;
        sum.count = g.count;
        sum.phi += g.phi;
        sum.z += g.z;
        sum.pressure += g.pressure;
        sum.mean_aspect_ratio += g.mean_aspect_ratio;
        sum.max_aspect_ratio += g.max_aspect_ratio;
        sum.mean_area += g.mean_area;
        n += 1;
    }
    (n > 0).then(|| {
        let k = n as Real;
        super::grains::GrainSample {
            count: sum.count,
            phi: sum.phi / k,
            z: sum.z / k,
            pressure: sum.pressure / k,
            mean_aspect_ratio: sum.mean_aspect_ratio / k,
            max_aspect_ratio: sum.max_aspect_ratio / k,
            mean_area: sum.mean_area / k,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::drum::{drum_regime, ProfileBin};
    use crate::observe::{GrainSample, StrainSample, Stress, WallSample};
    use crate::scene::parse_scene;

    fn sample(step: u64, stage: &str, axial: f64, zeta: f64, ev: f64) -> Sample {
        Sample {
            step,
            time: step as f64,
            phi: 0.8 - 0.5 * (0.002 - ev).max(0.0),
            z: 4.0,
            z_no_rattlers: 4.0,
            zeta,
            mu: None,
            p: 100.0,
            q: 100.0 * zeta,
            stress: Stress::default(),
            inertial_number: None,
            kinetic_energy: 0.0,
            elastic_energy: 1.0,
            walls: Vec::new(),
            stage: Some(stage.into()),
            strain: Some(StrainSample { axes: vec![ev - axial, axial], volumetric: ev, deviatoric: 0.0 }),
            drum: None,
            solver: None,
            deformable: None,
            grains: None,
        }
    }

    #[test]
    fn drum_regimes_follow_the_stated_order() {
        assert_eq!(drum_regime(0.05, 30.0, 0.0, 0.0, 0.0), "centrifuging");
        assert_eq!(drum_regime(1.0, 3.0, 0.0, 0.0, 0.0), "slipping");
        assert_eq!(drum_regime(1.0, 30.0, 0.2, 0.0, 0.0), "cataracting");
        assert_eq!(drum_regime(1.0, 30.0, 0.0, 0.5, 0.0), "slumping");
        assert_eq!(drum_regime(1.0, 30.0, 0.0, 0.0, 15.0), "cascading");
        assert_eq!(drum_regime(1.0, 30.0, 0.01, 0.1, 3.0), "rolling");
    }

    #[test]
    fn drum_means_start_after_the_transient_and_find_the_flowing_layer() {
        let text = r#"{"dimension": 2, "method": "dem", "gravity": [0.0, -10.0],
            "materials": {"m": {"density": 2000.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.5}},
            "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
            "container": {"min": [0.0, 0.0], "max": [0.04, 0.04], "wall_material": "m"},
            "experiment": {"kind": "drum", "angular_velocity": 3.141592653589793, "revolutions": 1.0, "transient": 0.5}}"#;
        let scene = parse_scene(text).expect("valid");
        let mut a = Analysis::new(&scene);
        let drum = |angle: f64, surface_v: f64| crate::observe::DrumSample {
            mass_angle: angle,
            surface_angle: Some(angle),
            upper_angle: Some(angle),
            lower_angle: Some(angle),
            fill: 0.4,
            bed_depth: 0.01,
            centroid_offset: 0.008,
            airborne_fraction: 0.0,
            drive_torque: 0.1,
            profile: vec![
                ProfileBin { depth: 5e-4, velocity: surface_v, count: 2 },
                ProfileBin { depth: 1.5e-3, velocity: -0.1, count: 2 },
            ],
        };
        let mut filling = sample(0, "filling", 0.0, 0.0, 0.0);
        filling.drum = Some(Box::new(drum(0.0, 0.0)));
        a.push(&filling);
        // One revolution takes 2 s: samples at t = 1, 1.5, 2, 2.5, 3; the window starts at t = 2.
        for (k, (angle, v)) in [(10.0, 0.0), (20.0, 0.0), (28.0, 0.1), (30.0, 0.3), (32.0, 0.2)].iter().enumerate() {
            let mut s = sample(0, "rotation", 0.0, 0.0, 0.0);
            s.time = 1.0 + 0.5 * k as f64;
            s.drum = Some(Box::new(drum(*angle, *v)));
            a.push(&s);
        }
        let r = a.finish(1e-3, 2000.0).expect("result");
        let d = r.drum.expect("drum result");
        assert_eq!((d.samples, d.from_time), (3, 1.0));
        assert!((d.surface_angle - 30.0).abs() < 1e-12 && (d.mass_angle - 30.0).abs() < 1e-12);
        assert!((d.surface_velocity - 0.2).abs() < 1e-12);
        // The mean profile crosses zero two thirds of the way from 0.5 mm to 1.5 mm.
        let h = d.flowing_layer_depth.expect("flowing layer");
        assert!((h - (5e-4 + 0.2 / 0.3 * 1e-3)).abs() < 1e-12, "{h}");
        assert_eq!(d.regime, "rolling");
        // Φ_box 0.8 - 0.001 over the fill's share of the box: Φ_box × 4 / (π × 0.4).
        assert!((d.phi_bed - 0.799 * 4.0 / (std::f64::consts::PI * 0.4)).abs() < 1e-9);
        // The drum turns faster than quasi-statically by design: no inertial-number warning.
        assert!(r.warnings.iter().all(|w| !w.contains("quasi-static")), "{:?}", r.warnings);
    }

    /// The analysis of 10 disks of 1 mm (k_n `k_n`) in `container` under `experiment`.
    fn hand_made_analysis(k_n: f64, container: serde_json::Value, experiment: serde_json::Value) -> Analysis {
        let s = serde_json::json!({
            "dimension": 2, "method": "dem",
            "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.5}},
            "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
            "container": container,
            "experiment": experiment
        });
        Analysis::new(&parse_scene(&s.to_string()).expect("valid"))
    }

    fn walled_box() -> serde_json::Value {
        serde_json::json!({"min": [0, 0], "max": [0.01, 0.01], "wall_material": "m"})
    }

    fn biaxial_analysis(k_n: f64, strain_rate: f64) -> Analysis {
        hand_made_analysis(
            k_n,
            walled_box(),
            serde_json::json!({"kind": "biaxial", "preparation": {"pressure": 100.0}, "strain_rate": strain_rate, "axial_strain": 0.2}),
        )
    }

    /// Plane shear of aggregates: the steady inertial number is the grains', the samples' own
    /// (the primaries', at the box's mean diameter) rescaled by the grains' diameter.
    #[test]
    fn the_plane_shear_of_aggregates_reports_the_grains_inertial_number() {
        let mut a = hand_made_analysis(
            1e7,
            serde_json::json!({"min": [0, 0], "max": [0.01, 0.01], "periodic": ["x", "y"]}),
            serde_json::json!({"kind": "plane_shear", "preparation": {"pressure": 100.0}, "shear_rate": 10.0, "strain": 1.0}),
        );
        for k in 0..=10 {
            let mut x = sample(k, "shear", 0.0, 0.3, 0.0);
            x.time = 0.01 * k as f64;
            x.inertial_number = Some(2e-3);
            a.push(&x);
        }
        let plain = a.finish(1e-4, 2500.0).and_then(|r| r.shear).expect("shear");
        assert!((plain.inertial_number - 2e-3).abs() < 1e-15, "{}", plain.inertial_number);
        // Grains of 1.8 mm made of primaries of 0.1 mm: I 18 times the primaries'.
        a.aggregate_diameter = Some(1.8e-3);
        let r = a.finish(1e-4, 2500.0).expect("result");
        let grains = r.shear.expect("shear");
        assert!((grains.inertial_number - 18.0 * 2e-3).abs() < 1e-12, "{}", grains.inertial_number);
        assert_eq!(r.inertial_number, Some(grains.inertial_number));
    }

    /// A hand-made dense biaxial test: ζ rises to 0.5 at 2% axial strain, falls to 0.3 by 10% and
    /// stays; ε_v contracts to 0.002 at 1%, then dilates to -0.03 at 10% and stays.
    #[test]
    fn peak_steady_state_and_dilatancy_of_a_hand_made_test() {
        let mut a = biaxial_analysis(1e7, 0.01);
        a.push(&sample(0, "preparation", 0.0, 0.0, 0.0));
        a.push(&sample(10, "preparation", 0.0, 0.01, 0.0));
        for k in 0..=200 {
            let ea = k as f64 * 0.001;
            let zeta = if ea <= 0.02 {
                25.0 * ea
            } else if ea <= 0.1 {
                0.5 - 2.5 * (ea - 0.02)
            } else {
                0.3
            };
            let ev = if ea <= 0.01 {
                0.2 * ea
            } else if ea <= 0.1 {
                0.002 - 0.032 * (ea - 0.01) / 0.09
            } else {
                -0.03
            };
            a.push(&sample(100 + k, "loading", ea, zeta, ev));
        }
        let r = a.finish(1e-3, 2500.0).expect("result");
        assert_eq!(r.experiment, "biaxial");
        assert_eq!(r.prepared.as_ref().map(|s| s.step), Some(10));
        assert_eq!(r.prepared.as_ref().map(|s| s.grains), Some(None));
        // Grains made of primaries: the states carry the grains' own measures.
        let mut g = biaxial_analysis(1e7, 0.01);
        let grains = crate::observe::GrainSample { count: 4, phi: 0.93, z: 2.5, ..Default::default() };
        let mut prepared = sample(10, "preparation", 0.0, 0.0, 0.0);
        prepared.grains = Some(Box::new(grains));
        g.push(&prepared);
        g.push(&sample(11, "loading", 0.01, 0.1, 0.0));
        let with = g.finish(1e-3, 2500.0).expect("result");
        assert_eq!(with.prepared.and_then(|s| s.grains), Some(grains));
        assert_eq!(with.last.grains, None);
        let peak = r.peak.expect("peak");
        assert!((peak.zeta - 0.5).abs() < 1e-12 && (peak.axial_strain - 0.02).abs() < 1e-12);
        let steady = r.steady.expect("steady");
        assert!((steady.from_axial_strain - 0.15).abs() < 1e-12);
        // Strains 0.150..0.200 (0.150 itself may round either side of 0.75 × 0.2).
        assert!((50..=51).contains(&steady.samples), "{}", steady.samples);
        assert!((steady.zeta - 0.3).abs() < 1e-12 && steady.zeta_std < 1e-12 && steady.dilatancy_rate.abs() < 1e-12);
        let d = r.dilatancy.expect("dilatancy");
        assert!((d.max_contraction - 0.002).abs() < 1e-12 && (d.at_axial_strain - 0.01).abs() < 1e-12);
        assert!((d.final_volumetric_strain + 0.03).abs() < 1e-12);
        // I = 0.01 × 1e-3 × sqrt(2500 / 100) = 5e-5; κ = k_n / p = 1e5 in 2D: no warning.
        assert!((r.inertial_number.expect("I") - 5e-5).abs() < 1e-15);
        assert!((r.stiffness_number.expect("kappa") - 1e5).abs() < 1e-6);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        // A dilating window has a positive dilatancy rate.
        let mut b = biaxial_analysis(1e7, 0.01);
        for k in 0..=100 {
            b.push(&sample(k, "loading", k as f64 * 0.001, 0.4, -0.5 * k as f64 * 0.001));
        }
        assert!((b.finish(1e-3, 2500.0).and_then(|r| r.steady).expect("steady").dilatancy_rate - 0.5).abs() < 1e-9);
    }

    /// Aggregates in a biaxial test: the peak carries the grains' measures of its sample, and
    /// the steady state their means over the last quarter of the strain (grains' Φ 0.9 + 0.1 ε_a
    /// and Z 3 + 10 ε_a at the window's mean strain; aspect ratio 1.2 flat), beside the
    /// primaries' own Φ; the inertial number is at the grains' scale.
    #[test]
    fn a_biaxial_test_of_aggregates_reports_its_grains_at_the_peak_and_steady_state() {
        let mut a = biaxial_analysis(1e7, 0.01);
        a.aggregates = true;
        for k in 0..=200 {
            let ea = k as f64 * 0.001;
            let mut s = sample(k, "loading", ea, if k == 20 { 0.6 } else { 0.3 }, 0.0);
            s.grains = Some(Box::new(crate::observe::GrainSample {
                count: 9,
                phi: 0.9 + 0.1 * ea,
                z: 3.0 + 10.0 * ea,
                pressure: 1e6,
                mean_aspect_ratio: 1.2,
                max_aspect_ratio: 1.5,
                mean_area: 2e-6,
            }));
            a.push(&s);
        }
        let r = a.finish(1e-3, 2500.0).expect("result");
        let peak = r.peak.expect("peak");
        let at_peak = peak.grains.expect("grains at the peak");
        assert!((peak.axial_strain - 0.02).abs() < 1e-12 && (at_peak.phi - 0.902).abs() < 1e-12, "{peak:?}");
        let steady = r.steady.expect("steady");
        let g = steady.grains.expect("the grains' steady state");
        // The window's strains run back from 0.2 by 0.001 (0.150 itself may round either side).
        let ea = 0.2 - 0.0005 * (steady.samples as f64 - 1.0);
        assert!((g.phi - (0.9 + 0.1 * ea)).abs() < 1e-9 && (g.z - (3.0 + 10.0 * ea)).abs() < 1e-9, "{g:?}");
        assert!((g.mean_aspect_ratio - 1.2).abs() < 1e-12 && (g.max_aspect_ratio - 1.5).abs() < 1e-12 && g.count == 9);
        assert!((steady.phi - g.phi).abs() > 0.01, "the primaries' Φ stays its own: {}", steady.phi);
        // The inertial number is the grains': with no set to name their size (the hand-made
        // analysis's set is of plain disks) the disk of their mean area, 2e-6 m², 1.596 mm:
        // I = 0.01 × 1.596e-3 × sqrt(2500 / 100), not the primaries' 0.01 × 1e-3 × 5.
        let d = 2.0 * (2e-6 / std::f64::consts::PI).sqrt();
        assert!((r.inertial_number.expect("I") - 0.01 * d * 5.0).abs() < 1e-15, "{:?}", r.inertial_number);
        // With a set of aggregates, its nominal diameter.
        a.aggregate_diameter = Some(1.8e-3);
        assert!((a.finish(1e-3, 2500.0).and_then(|r| r.inertial_number).expect("I") - 0.01 * 1.8e-3 * 5.0).abs() < 1e-15);
        // One sample without them: no grains' steady state rather than a mean over part.
        let mut b = biaxial_analysis(1e7, 0.01);
        for k in 0..=100 {
            let mut s = sample(k, "loading", k as f64 * 0.001, 0.3, 0.0);
            if k != 90 {
                s.grains = Some(Box::default());
            }
            b.push(&s);
        }
        assert_eq!(b.finish(1e-3, 2500.0).and_then(|r| r.steady).map(|s| s.grains), Some(None));
    }

    #[test]
    fn fast_or_soft_tests_are_flagged() {
        // I = 10 × 1e-3 × 5 = 0.05; κ = 1e5 / 100 = 1e3.
        let mut a = biaxial_analysis(1e5, 10.0);
        a.push(&sample(0, "loading", 0.0, 0.0, 0.0));
        a.push(&sample(1, "loading", 0.01, 0.1, 0.0));
        let r = a.finish(1e-3, 2500.0).expect("result");
        assert_eq!(r.warnings.len(), 2, "{:?}", r.warnings);
        assert!(r.warnings[0].starts_with("not quasi-static") && r.warnings[1].starts_with("not in the rigid limit"));
    }

    /// Aggregates: κ = 1e3 is rigid enough for their primaries (their contacts deflect by 0.1%
    /// of a primary); κ = 50 is not, and the warning says it of the primaries.
    #[test]
    fn aggregates_are_judged_by_the_rigidity_of_their_primaries() {
        let warnings = |k_n: f64| {
            let mut a = biaxial_analysis(k_n, 1e-4);
            a.aggregates = true;
            a.push(&sample(0, "loading", 0.0, 0.0, 0.0));
            a.push(&sample(1, "loading", 0.01, 0.1, 0.0));
            a.finish(1e-3, 2500.0).expect("result").warnings
        };
        assert!(warnings(1e5).is_empty(), "{:?}", warnings(1e5));
        let w = warnings(5e3);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with(
                "not in the rigid limit: stiffness number 5.00e1 < 1e2 (the primaries' contacts deflect by about 2.0e-2 of a primary"
            ),
            "{w:?}"
        );
    }

    /// A hand-made compaction of aggregates: the primaries' Φ and Z follow one course, the
    /// grains' another, `Z_g − Z_J = 5 (Φ_g − Φ_J)^½` past the wall's first load. The results
    /// are the grains': Φ at the onset, at the end and the largest, the coordination fit
    /// (exponent ½, prefactor 5), the shapes, and `level` says so.
    #[test]
    fn a_compaction_of_aggregates_is_judged_by_its_grains() {
        let mut a = hand_made_analysis(1e7, walled_box(), serde_json::json!({"kind": "compaction", "velocity": 0.01, "strain": 0.5}));
        for k in 0..=40u64 {
            let phi_g = 0.6 + 0.008 * k as f64;
            let beyond = (phi_g - 0.68).max(0.0);
            let mut x = sample(k, "compaction", 0.0, 0.0, 0.0);
            x.phi = 0.5 + 0.004 * k as f64;
            x.z = 6.0;
            x.walls = vec![WallSample {
                name: "y_max".into(),
                position: 0.01,
                force: vec![0.0, 0.0],
                normal_stress: if k >= 10 { 1e5 + 1e6 * beyond } else { 0.0 },
            }];
            x.grains = Some(Box::new(GrainSample {
                count: 10,
                phi: phi_g,
                z: 2.0 + 5.0 * beyond.sqrt(),
                pressure: 0.0,
                mean_aspect_ratio: 1.1 + 0.001 * k as f64,
                max_aspect_ratio: 1.3,
                mean_area: 1e-6,
            }));
            a.push(&x);
        }
        let r = a.finish(1e-3, 2500.0).expect("result");
        let c = r.compaction.expect("a compaction result");
        assert_eq!(c.level.as_deref(), Some("grains"));
        assert!((c.phi_onset.expect("an onset") - 0.68).abs() < 1e-12, "{c:?}");
        assert!((c.phi_final - 0.92).abs() < 1e-12 && (c.phi_max - 0.92).abs() < 1e-12, "{c:?}");
        let fit = c.coordination_fit.clone().expect("a coordination fit");
        assert!((fit.exponent - 0.5).abs() < 1e-9 && (fit.prefactor - 5.0).abs() < 1e-8, "{fit:?}");
        assert!(c.mean_aspect_ratio.is_some_and(|m| (m - 1.14).abs() < 1e-12) && c.max_aspect_ratio == Some(1.3), "{c:?}");
    }
}
