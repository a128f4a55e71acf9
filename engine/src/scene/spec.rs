//! The scene file as written by users: plain serde types, SI units, unknown fields rejected.
//!
//! These types describe the physics of a scene, not the algorithm that simulates it. They are
//! turned into the checked [`Scene`](super::Scene) by [`validate`](super::validate), which
//! reports every broken rule at once. The full format is documented in `docs/scene-format.md`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Top level of a scene file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Optional human-readable name.
    #[serde(default)]
    pub name: Option<String>,
    /// 2 (disks, plane problems; quantities per metre of thickness) or 3 (spheres).
    pub dimension: u8,
    /// Method name (`"dem"`) or object `{"kind": "dem", ...parameters}`.
    pub method: serde_json::Value,
    /// Named materials.
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Particle sets, placed in order (none when the scene starts from a saved state).
    #[serde(default)]
    pub particles: Vec<ParticleSetSpec>,
    /// A saved state to start from instead of placing particle sets (its particles and box).
    #[serde(default)]
    pub start_from: Option<StartFromSpec>,
    /// The box, its walls, periodic directions and imposed deformation.
    pub container: ContainerSpec,
    /// Gravity vector, m/s² (length = dimension). Default: none.
    #[serde(default)]
    pub gravity: Option<Vec<f64>>,
    /// When to stop; the first criterion reached ends the run.
    #[serde(default)]
    pub stop: Option<StopSpec>,
    /// How often to take a sample. Default: 100 samples over the run.
    #[serde(default)]
    pub sampling: Option<SamplingSpec>,
    /// VTK snapshots for ParaView (particles, contact network, walls). Default: none.
    #[serde(default)]
    pub snapshots: Option<SnapshotSpec>,
    /// A standard experiment: its preparation and loading program replace `stop` (which then
    /// only limits the whole run, if given).
    #[serde(default)]
    pub experiment: Option<ExperimentSpec>,
    /// Seed of every random draw (placement, velocities). Default 0.
    #[serde(default)]
    pub seed: Option<u64>,
}

/// Where a scene's particles come from when it starts from a saved state: exactly one field.
/// The engine reads only `state`; the `sable` CLI replaces `file` by the file's content and the
/// service replaces `job` by that job's final state before validation.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartFromSpec {
    /// Id of a succeeded job of the service, whose final state to start from.
    #[serde(default)]
    pub job: Option<i64>,
    /// Path of a state file (`sable run --save-state`, `sable state`), relative to the scene file.
    #[serde(default)]
    pub file: Option<String>,
    /// The state itself.
    #[serde(default)]
    pub state: Option<Box<super::state::StateFile>>,
}

/// A material: density and contact law (rigid or soft-contact grains), or density and
/// constitutive law (grains that deform, method `mpm`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Density, kg/m³.
    pub density: f64,
    /// Elastic contact law (required unless `deformable`).
    #[serde(default)]
    pub contact: Option<ContactLawSpec>,
    /// Normal coefficient of restitution in (0, 1] (required unless `deformable`).
    #[serde(default)]
    pub restitution: Option<f64>,
    /// The grains deform under their constitutive law (method `mpm`); they touch through it,
    /// with no contact stiffness and no restitution.
    #[serde(default)]
    pub deformable: Option<DeformableSpec>,
    /// Coulomb friction coefficient (>= 0). Default 0.
    #[serde(default)]
    pub friction: f64,
    /// gamma_t / gamma_n for the linear law (>= 0). Default 0.5 (LAMMPS's default).
    #[serde(default)]
    pub tangential_damping_ratio: Option<f64>,
    /// If true (default) damping cannot make the normal force attractive.
    #[serde(default)]
    pub limit_damping: Option<bool>,
    /// Optional rolling resistance.
    #[serde(default)]
    pub rolling: Option<RollingSpec>,
    /// Optional interstitial liquid (capillary bridges and lubrication).
    #[serde(default)]
    pub liquid: Option<LiquidSpec>,
    /// Optional dry cohesion: a constant attraction within a distance (Roux & Chevoir 2005, §2.2.3).
    #[serde(default)]
    pub cohesion: Option<CohesionSpec>,
}

/// The constitutive law of a deformable material (plane strain).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum DeformableSpec {
    /// Hooke's law (on the logarithmic strain at finite strain).
    LinearElastic {
        /// Young's modulus E, Pa.
        young_modulus: f64,
        /// Poisson's ratio ν in (-1, 0.5).
        poisson_ratio: f64,
    },
    /// Compressible neo-Hookean, `S = (λ ln J − μ) C⁻¹ + μ I`.
    NeoHookean {
        /// Shear modulus μ, Pa.
        shear_modulus: f64,
        /// First Lamé constant λ, Pa (>= 0).
        lambda: f64,
    },
    /// Von Mises plasticity with linear isotropic hardening.
    Elastoplastic {
        /// Young's modulus E, Pa.
        young_modulus: f64,
        /// Poisson's ratio ν in (-1, 0.5).
        poisson_ratio: f64,
        /// Initial yield stress σ_y, Pa.
        yield_stress: f64,
        /// Hardening modulus H, Pa (>= 0). Default 0 (perfect plasticity).
        #[serde(default)]
        hardening: f64,
    },
}

/// The elastic part of the contact law.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case", deny_unknown_fields)]
pub enum ContactLawSpec {
    /// Linear springs: normal stiffness `k_n` and tangential `k_t` (N/m). `k_t` defaults to 2/7 k_n.
    Linear {
        /// Normal stiffness, N/m.
        k_n: f64,
        /// Tangential stiffness, N/m.
        #[serde(default)]
        k_t: Option<f64>,
    },
    /// Hertz normal force and Mindlin tangential stiffness from Young's modulus and Poisson's ratio.
    HertzMindlin {
        /// Young's modulus E, Pa.
        young_modulus: f64,
        /// Poisson's ratio nu in (-1, 0.5).
        poisson_ratio: f64,
    },
}

/// Rolling resistance: elastic moment spring with a plastic threshold.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RollingSpec {
    /// Rolling stiffness, N·m/rad.
    pub stiffness: f64,
    /// Rolling friction coefficient mu_r (moment limit mu_r R* f_n).
    pub friction: f64,
}

/// Dry cohesion (Roux & Chevoir 2005, §2.2.3): a constant attraction `force` between surfaces closer than
/// `distance`, in contact included.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CohesionSpec {
    /// Attraction F_0, N (> 0).
    pub force: f64,
    /// Range D_0 beyond contact, m (>= 0).
    pub distance: f64,
}

/// Interstitial liquid (Nezamabadi 2020, eqs. 1.5–1.11).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LiquidSpec {
    /// Liquid-vapour surface tension gamma_s, N/m.
    pub surface_tension: f64,
    /// Contact angle theta, radians, in [0, pi/2).
    #[serde(default)]
    pub contact_angle: f64,
    /// Liquid volume of one bridge V_b, m³.
    pub bridge_volume: f64,
    /// Liquid viscosity eta, Pa·s (0 disables lubrication).
    #[serde(default)]
    pub viscosity: f64,
    /// Roughness length h_0 that bounds the lubrication force, m (required if viscosity > 0).
    #[serde(default)]
    pub roughness: Option<f64>,
}

/// A set of particles sharing a material, a size distribution and a placement.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleSetSpec {
    /// Name of the material (a key of `materials`).
    pub material: String,
    /// Number of particles (ignored for `list` placement, which gives its own count).
    #[serde(default)]
    pub count: Option<usize>,
    /// Size distribution (not used by `list` placement with diameters).
    #[serde(default)]
    pub size: Option<SizeSpec>,
    /// Where the particles start.
    pub placement: PlacementSpec,
    /// Initial velocities. Default: at rest.
    #[serde(default)]
    pub velocity: Option<VelocitySpec>,
    /// Fraction of the set that carries liquid (0..1); default 1 if the material has a liquid.
    #[serde(default)]
    pub wet_fraction: Option<f64>,
    /// What each grain is made of. Default: one rigid particle (or a deformable body, by its
    /// material).
    #[serde(default)]
    pub model: Option<GrainModelSpec>,
}

/// What the grains of a particle set are made of.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum GrainModelSpec {
    /// An aggregate of rigid primaries of the set's material that attract one another (the
    /// bonded particle method, docs/physics.md §4): the set's `size` is the grains', each grain's
    /// disk filled with primaries.
    BondedPrimaries {
        /// Size distribution of the primaries (diameters, m).
        primaries: SizeSpec,
        /// Fewest primaries a grain may hold. Default 200 (the sources'); at least 30.
        #[serde(default)]
        min_primaries: Option<usize>,
        /// The attraction between primaries of one grain.
        attraction: BondAttractionSpec,
        /// Friction between primaries of one grain. Default 0 (the sources'). Primaries of
        /// different grains rub with the material's friction.
        #[serde(default)]
        friction: Option<f64>,
    },
}

/// The attraction `F_0 (1 + δ/a_0)^(−γ)` between primaries of one aggregate (Nezamabadi 2020, §1.2.1, eq. 1.12).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BondAttractionSpec {
    /// Largest attraction `F_0`, at touching: N/m in 2D (> 0). The sources: 100 N/m.
    pub force: f64,
    /// Exponent `γ` (> 1). Default 7 (the sources').
    #[serde(default)]
    pub exponent: Option<f64>,
    /// Gap beyond which primaries do not attract, m (at least the smallest primary's
    /// diameter). Default: the largest primary's diameter.
    #[serde(default)]
    pub cutoff: Option<f64>,
}

/// Size distribution of a particle set (diameters, m).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SizeSpec {
    /// All particles have `diameter`.
    Monodisperse {
        /// Diameter, m.
        diameter: f64,
    },
    /// Diameters uniform between `min` and `max`.
    Uniform {
        /// Smallest diameter, m.
        min: f64,
        /// Largest diameter, m.
        max: f64,
    },
    /// Two sizes: `diameter` (small) and `ratio * diameter`; `fraction_small` by number.
    Bidisperse {
        /// Small diameter, m.
        diameter: f64,
        /// Large-to-small diameter ratio (>= 1).
        ratio: f64,
        /// Number fraction of small particles. Default 0.5.
        #[serde(default)]
        fraction_small: Option<f64>,
    },
}

/// An axis-aligned region (length = dimension).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Lower corner, m.
    pub min: Vec<f64>,
    /// Upper corner, m.
    pub max: Vec<f64>,
}

/// Placement of a particle set.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PlacementSpec {
    /// Random non-overlapping positions in a region (default: the whole container).
    Random {
        /// Region; default the container.
        #[serde(default)]
        region: Option<RegionSpec>,
    },
    /// Lattice sites in a region (default: the whole container).
    Lattice {
        /// `square` or `hexagonal` (2D), `cubic` or `fcc` (3D).
        lattice: String,
        /// Region; default the container.
        #[serde(default)]
        region: Option<RegionSpec>,
        /// Nearest-neighbour distance, m. Default: largest diameter × 1.01.
        #[serde(default)]
        spacing: Option<f64>,
        /// `first` (default) fills sites in order; `random` picks a random subset.
        #[serde(default)]
        select: Option<String>,
    },
    /// Explicit positions (and optionally diameters).
    List {
        /// Centres, m (each of length = dimension).
        positions: Vec<Vec<f64>>,
        /// Diameters, m; if absent the size distribution is used.
        #[serde(default)]
        diameters: Option<Vec<f64>>,
        /// Velocities, m/s; if absent `velocity` is used.
        #[serde(default)]
        velocities: Option<Vec<Vec<f64>>>,
    },
}

/// Initial velocity of a particle set.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum VelocitySpec {
    /// Every particle at rest.
    Zero,
    /// The same velocity for every particle, m/s.
    Uniform {
        /// Velocity, m/s (length = dimension).
        value: Vec<f64>,
    },
    /// Each component drawn from a zero-mean Gaussian with standard deviation `std`, m/s.
    Gaussian {
        /// Standard deviation per component, m/s.
        std: f64,
    },
}

/// The container: a box with walls on non-periodic faces.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContainerSpec {
    /// Lower corner, m (left out when the scene starts from a state, whose box it takes).
    #[serde(default)]
    pub min: Vec<f64>,
    /// Upper corner, m (left out when the scene starts from a state).
    #[serde(default)]
    pub max: Vec<f64>,
    /// Periodic axes (`"x"`, `"y"`, `"z"`).
    #[serde(default)]
    pub periodic: Vec<String>,
    /// Wall of each non-periodic face, by name (`x_min`, `x_max`, ...). Missing faces are fixed.
    #[serde(default)]
    pub walls: BTreeMap<String, WallSpec>,
    /// Material of the walls (required when the box has walls).
    #[serde(default)]
    pub wall_material: Option<String>,
    /// Lees-Edwards shear: flow along x, gradient along y (both periodic).
    #[serde(default)]
    pub lees_edwards: Option<LeesEdwardsSpec>,
    /// Homogeneous deformation of the periodic cell.
    #[serde(default)]
    pub deformation: Option<DeformationSpec>,
}

/// Motion of one wall.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum WallSpec {
    /// Does not move.
    Fixed,
    /// Moves at an imposed velocity (m/s, length = dimension); the normal part moves the wall,
    /// the tangential part slides its surface.
    Velocity {
        /// Velocity, m/s.
        velocity: Vec<f64>,
    },
    /// Servo-controlled to an imposed compressive normal stress, Pa.
    Stress {
        /// Target normal stress, Pa (> 0).
        stress: f64,
        /// Servo gain, m/(s·Pa). Default from the contact stiffness and time step.
        #[serde(default)]
        gain: Option<f64>,
        /// Largest wall speed, m/s. Default: unbounded.
        #[serde(default)]
        max_speed: Option<f64>,
    },
}

/// Lees-Edwards periodic shear.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LeesEdwardsSpec {
    /// Shear rate d u_x / d y, 1/s.
    pub shear_rate: f64,
    /// Start particles on the linear velocity profile. Default false.
    #[serde(default)]
    pub initial_profile: bool,
}

/// Homogeneous deformation of the periodic directions.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DeformationSpec {
    /// Constant true strain rate on each axis, 1/s (negative compresses; length = dimension;
    /// non-zero only on periodic axes).
    StrainRate {
        /// Rates, 1/s.
        rate: Vec<f64>,
    },
    /// Isotropic servo of the periodic axes to a target mean pressure p, Pa.
    Pressure {
        /// Target pressure, Pa (> 0).
        target: f64,
        /// Largest strain rate magnitude, 1/s (> 0).
        max_strain_rate: f64,
        /// Gain, 1/(s·Pa). Default max_strain_rate / target.
        #[serde(default)]
        gain: Option<f64>,
    },
}

/// Stop criteria; the first one reached ends the run.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopSpec {
    /// Simulated time, s.
    #[serde(default)]
    pub time: Option<f64>,
    /// Number of steps.
    #[serde(default)]
    pub steps: Option<u64>,
    /// Target packing fraction: stop when Φ >= this value.
    #[serde(default)]
    pub packing_fraction: Option<f64>,
    /// Target strain magnitude: shear strain with Lees-Edwards, else the largest |ln(L/L0)|.
    #[serde(default)]
    pub strain: Option<f64>,
}

/// Sampling interval: give exactly one.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingSpec {
    /// Sample every this many steps.
    #[serde(default)]
    pub every_steps: Option<u64>,
    /// Sample every this much simulated time, s.
    #[serde(default)]
    pub every_time: Option<f64>,
}

/// When to take snapshots.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SnapshotSpec {
    /// Every this many steps; absent: with every sample.
    #[serde(default)]
    pub every_steps: Option<u64>,
}

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
