//! The `experiment` section: one standard experiment per kind, with its preparation and
//! equilibrium criterion.

use serde::{Deserialize, Serialize};

/// A standard experiment (`docs/scene-format.md` §13).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ExperimentSpec {
    /// Isotropic compression to a pressure, until equilibrium.
    Isotropic(IsotropicSpec),
    /// 2D: isotropic compression, then axial compression at constant lateral stress.
    Biaxial(TriaxialSpec),
    /// 3D: isotropic compression, then axial compression at constant lateral stress.
    Triaxial(TriaxialSpec),
    /// Uniaxial compaction by the upper wall of an axis.
    Compaction(CompactionSpec),
    /// Plane shear in a Lees-Edwards cell under an imposed normal stress.
    PlaneShear(PlaneShearSpec),
    /// Deposition under gravity onto the floor of the box, until equilibrium.
    Deposition(DepositionSpec),
    /// Rotating drum inscribed in the box.
    Drum(DrumSpec),
    /// Diametral compression of a wet granule between two plates.
    GranuleCompression(GranuleCompressionSpec),
}

impl ExperimentSpec {
    /// The experiment's `kind` as written in scene files.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Isotropic(_) => "isotropic",
            Self::Biaxial(_) => "biaxial",
            Self::Triaxial(_) => "triaxial",
            Self::Compaction(_) => "compaction",
            Self::PlaneShear(_) => "plane_shear",
            Self::Deposition(_) => "deposition",
            Self::Drum(_) => "drum",
            Self::GranuleCompression(_) => "granule_compression",
        }
    }
}

/// Parameters of the diametral compression of a granule; every field has a default.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GranuleCompressionSpec {
    /// Axis of the plates (default the last one).
    #[serde(default)]
    pub axis: Option<String>,
    /// Radius of the ball the grains are placed in, m (default: the radius that holds them
    /// at a packing fraction of 0.25 in 3D, 0.45 in 2D).
    #[serde(default)]
    pub radius: Option<f64>,
    /// Acceleration of the centripetal field that gathers the grains, m/s² (default: the
    /// capillary force over the mean grain's mass).
    #[serde(default)]
    pub acceleration: Option<f64>,
    /// True strain rate of the compression, 1/s (default: inertial number 1e-3 at the
    /// capillary stress).
    #[serde(default)]
    pub strain_rate: Option<f64>,
    /// Final strain (default 0.3).
    #[serde(default)]
    pub strain: Option<f64>,
    /// Strain window `[from, to]` of the plastic plateau (default [0.05, 0.2]).
    #[serde(default)]
    pub plateau: Option<[f64; 2]>,
    /// Cundall's local damping while the granule forms and relaxes (default 0.2).
    #[serde(default)]
    pub local_damping: Option<f64>,
    /// Equilibrium criterion of the forming and relaxing stages.
    #[serde(default)]
    pub equilibrium: Option<EquilibriumSpec>,
    /// Step limit of each stage (default 2,000,000 for the forming and relaxing stages,
    /// none for the compression).
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// Parameters of the rotating drum: `froude` or `angular_velocity` (not both; default
/// `froude` 1e-3).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrumSpec {
    /// Axis of the drum in 3D (default z); in 2D the drum is a circle in the x-y plane.
    #[serde(default)]
    pub axis: Option<String>,
    /// Froude number `ω² R / g`.
    #[serde(default)]
    pub froude: Option<f64>,
    /// Angular velocity, rad/s (positive: right-handed about the axis).
    #[serde(default)]
    pub angular_velocity: Option<f64>,
    /// Fraction of the drum's volume the bed fills, in (0, 1): sets the count of the (one,
    /// randomly placed) particle set, which must then leave `count` out.
    #[serde(default)]
    pub fill: Option<f64>,
    /// Revolutions the drum turns (default 1).
    #[serde(default)]
    pub revolutions: Option<f64>,
    /// Revolutions discarded before the averages start (default 0.25).
    #[serde(default)]
    pub transient: Option<f64>,
    /// Cundall's local damping while the grains settle before the drum starts (default 0.2;
    /// the rotation runs with the method's own setting).
    #[serde(default)]
    pub local_damping: Option<f64>,
    /// Equilibrium criterion of the settling.
    #[serde(default)]
    pub equilibrium: Option<EquilibriumSpec>,
    /// Step limit of each stage (default 2,000,000 for the settling, none for the rotation).
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// Parameters of the deposition under gravity; every field has a default.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepositionSpec {
    /// Cundall's local damping while the grains fall and settle (default 0: the contact laws'
    /// own dissipation only).
    #[serde(default)]
    pub local_damping: Option<f64>,
    /// Equilibrium criterion (kinetic ratio and unbalanced force; no stress boundary).
    #[serde(default)]
    pub equilibrium: Option<EquilibriumSpec>,
    /// Step limit (default 2,000,000).
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// Parameters of the plane shear test: `shear_rate` or `inertial_number` (not both).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneShearSpec {
    /// The compression to the normal stress.
    pub preparation: PreparationSpec,
    /// `lees_edwards` (default: a periodic cell) or `rough_walls` (grains glued to the walls
    /// y_min and y_max).
    #[serde(default)]
    pub boundary: Option<String>,
    /// Shear rate, 1/s.
    #[serde(default)]
    pub shear_rate: Option<f64>,
    /// Inertial number that sets the shear rate: `I / <d> × sqrt(pressure / rho)` (default 1e-2).
    #[serde(default)]
    pub inertial_number: Option<f64>,
    /// Final shear strain (default 5).
    #[serde(default)]
    pub strain: Option<f64>,
    /// Step limit of the shear.
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// Parameters of the isotropic experiment.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IsotropicSpec {
    /// The compression.
    pub preparation: PreparationSpec,
}

/// Isotropic compression by a servo to a pressure, until equilibrium.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreparationSpec {
    /// Confining pressure, Pa.
    pub pressure: f64,
    /// Friction during the compression (default 0).
    #[serde(default)]
    pub friction: Option<f64>,
    /// Largest compression rate, 1/s.
    #[serde(default)]
    pub max_strain_rate: Option<f64>,
    /// Cundall's local damping during the compression (default 0.2).
    #[serde(default)]
    pub local_damping: Option<f64>,
    /// Equilibrium criterion.
    #[serde(default)]
    pub equilibrium: Option<EquilibriumSpec>,
    /// Step limit (default 2,000,000).
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// An equilibrium criterion; every field has a default.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EquilibriumSpec {
    /// Kinetic / elastic energy.
    #[serde(default)]
    pub kinetic_ratio: Option<f64>,
    /// Mean net force / mean contact force.
    #[serde(default)]
    pub unbalanced_force: Option<f64>,
    /// Relative error of stress-controlled boundaries.
    #[serde(default)]
    pub stress_tolerance: Option<f64>,
    /// Steps between checks.
    #[serde(default)]
    pub check_every: Option<u64>,
    /// Checks in a row (default: the method's, 3 for `dem` and 1 for `cd`).
    #[serde(default)]
    pub consecutive: Option<u32>,
}

/// Parameters of the biaxial (2D) and triaxial (3D) tests.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TriaxialSpec {
    /// The isotropic compression to the confining pressure.
    pub preparation: PreparationSpec,
    /// Loading axis (default the last one: y in 2D, z in 3D).
    #[serde(default)]
    pub axis: Option<String>,
    /// Axial true strain rate, 1/s (default: inertial number 5e-4 at the confining pressure).
    #[serde(default)]
    pub strain_rate: Option<f64>,
    /// Final axial strain (default 0.2).
    #[serde(default)]
    pub axial_strain: Option<f64>,
    /// Step limit of the loading.
    #[serde(default)]
    pub max_steps: Option<u64>,
}

/// Parameters of the compaction test: give `velocity` and `strain`, or `stress`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompactionSpec {
    /// Compressed axis (default the last one).
    #[serde(default)]
    pub axis: Option<String>,
    /// Speed of the upper wall, m/s.
    #[serde(default)]
    pub velocity: Option<f64>,
    /// Final strain |ln(h/h_i)| with `velocity`.
    #[serde(default)]
    pub strain: Option<f64>,
    /// Target stress of the upper wall, Pa (instead of `velocity`).
    #[serde(default)]
    pub stress: Option<f64>,
    /// Speed limit of the wall with `stress`, m/s.
    #[serde(default)]
    pub max_speed: Option<f64>,
    /// Equilibrium criterion with `stress`.
    #[serde(default)]
    pub equilibrium: Option<EquilibriumSpec>,
    /// Step limit (default 2,000,000).
    #[serde(default)]
    pub max_steps: Option<u64>,
}
