//! The checked scene: typed values that the methods build from. Produced only by
//! [`validate`](super::validate), so every invariant stated here holds.

use crate::math::{Real, Vec3};

/// A validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name (the file's `name`, or `"scene"`).
    pub name: String,
    /// 2 or 3.
    pub dim: usize,
    /// Method chosen and why.
    pub method: Method,
    /// Why this method was chosen (the user's choice, or the advisor's reason for `auto`).
    pub method_reason: String,
    /// Materials; particle sets and walls refer to them by index.
    pub materials: Vec<Material>,
    /// Particle sets in placement order.
    pub sets: Vec<ParticleSet>,
    /// Box, walls, periodicity and imposed deformation.
    pub container: Container,
    /// Gravity, m/s² (z = 0 in 2D).
    pub gravity: Vec3,
    /// Stop criteria.
    pub stop: Stop,
    /// Sampling interval.
    pub sampling: Sampling,
    /// Snapshot interval in steps (0: with every sample); `None`: no snapshots.
    pub snapshots: Option<u64>,
    /// Seed of all random draws.
    pub seed: u64,
}

/// A simulation method and its parameters.
#[derive(Debug, Clone)]
pub enum Method {
    /// Soft-contact DEM (PHYSICS.md §2).
    Dem(DemParams),
}

impl Method {
    /// The method's name as written in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Dem(_) => "dem",
        }
    }
}

/// Parameters of soft-contact DEM.
#[derive(Debug, Clone, PartialEq)]
pub struct DemParams {
    /// Time step, s; `None` = `time_step_fraction` × collision time.
    pub time_step: Option<Real>,
    /// Fraction of the collision time used when `time_step` is absent.
    pub time_step_fraction: Real,
    /// Verlet skin as a fraction of the smallest diameter.
    pub skin: Real,
    /// Impact velocity for the Hertz collision time, m/s (`None`: estimated).
    pub reference_velocity: Option<Real>,
    /// Largest allowed overlap / smaller radius.
    pub max_overlap: Real,
    /// Threads for the force loop; 0 = rayon's global pool.
    pub threads: usize,
    /// Cundall's local damping coefficient in [0, 1).
    pub local_damping: Real,
}

impl Default for DemParams {
    fn default() -> Self {
        Self {
            time_step: None,
            time_step_fraction: 0.02,
            skin: 0.1,
            reference_velocity: None,
            max_overlap: 0.1,
            threads: 0,
            local_damping: 0.0,
        }
    }
}

/// A material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name in the scene file.
    pub name: String,
    /// Density, kg/m³.
    pub density: Real,
    /// Elastic law.
    pub law: ElasticLaw,
    /// Normal restitution in (0, 1].
    pub restitution: Real,
    /// Coulomb friction coefficient.
    pub friction: Real,
    /// gamma_t / gamma_n (linear law).
    pub tangential_damping_ratio: Real,
    /// Damping may not make the normal force attractive.
    pub limit_damping: bool,
    /// Rolling resistance.
    pub rolling: Option<Rolling>,
    /// Interstitial liquid.
    pub liquid: Option<Liquid>,
}

/// Elastic contact law of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ElasticLaw {
    /// Linear springs, N/m.
    Linear {
        /// Normal stiffness.
        k_n: Real,
        /// Tangential stiffness.
        k_t: Real,
    },
    /// Hertz-Mindlin from elastic constants.
    HertzMindlin {
        /// Young's modulus, Pa.
        young: Real,
        /// Poisson's ratio.
        poisson: Real,
    },
}

/// Rolling resistance parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rolling {
    /// Stiffness, N·m/rad.
    pub stiffness: Real,
    /// Rolling friction coefficient.
    pub friction: Real,
}

/// Interstitial liquid parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Liquid {
    /// Surface tension, N/m.
    pub surface_tension: Real,
    /// Contact angle, rad.
    pub contact_angle: Real,
    /// Bridge volume, m³.
    pub bridge_volume: Real,
    /// Viscosity, Pa·s.
    pub viscosity: Real,
    /// Roughness length, m.
    pub roughness: Real,
}

/// A particle set.
#[derive(Debug, Clone)]
pub struct ParticleSet {
    /// Material index.
    pub material: usize,
    /// Number of particles.
    pub count: usize,
    /// Size distribution.
    pub size: SizeDist,
    /// Placement.
    pub placement: Placement,
    /// Initial velocity.
    pub velocity: InitialVelocity,
    /// Fraction of wet particles.
    pub wet_fraction: Real,
}

/// Size distribution (diameters, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SizeDist {
    /// One diameter.
    Monodisperse(Real),
    /// Uniform in diameter.
    Uniform {
        /// Smallest.
        min: Real,
        /// Largest.
        max: Real,
    },
    /// Two diameters.
    Bidisperse {
        /// Small diameter.
        small: Real,
        /// Large / small.
        ratio: Real,
        /// Number fraction of small particles.
        fraction_small: Real,
    },
}

impl SizeDist {
    /// Largest diameter the distribution can produce.
    pub fn max_diameter(&self) -> Real {
        match *self {
            Self::Monodisperse(d) => d,
            Self::Uniform { max, .. } => max,
            Self::Bidisperse { small, ratio, .. } => small * ratio,
        }
    }
    /// Smallest diameter the distribution can produce.
    pub fn min_diameter(&self) -> Real {
        match *self {
            Self::Monodisperse(d) => d,
            Self::Uniform { min, .. } => min,
            Self::Bidisperse { small, .. } => small,
        }
    }
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub lo: Vec3,
    /// Upper corner.
    pub hi: Vec3,
}

/// Lattice types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatticeKind {
    /// 2D square.
    Square,
    /// 2D hexagonal (triangular).
    Hexagonal,
    /// 3D simple cubic.
    Cubic,
    /// 3D face-centred cubic.
    Fcc,
}

/// Placement of a set.
#[derive(Debug, Clone)]
pub enum Placement {
    /// Random sequential addition without overlap.
    Random(Aabb),
    /// Lattice sites.
    Lattice {
        /// Lattice type.
        kind: LatticeKind,
        /// Region to fill.
        region: Aabb,
        /// Nearest-neighbour distance (`None`: largest diameter × 1.01).
        spacing: Option<Real>,
        /// Random subset of sites instead of the first ones.
        random_select: bool,
    },
    /// Explicit positions.
    List {
        /// Centres.
        positions: Vec<Vec3>,
        /// Diameters (else the size distribution).
        diameters: Option<Vec<Real>>,
        /// Velocities (else the set's velocity).
        velocities: Option<Vec<Vec3>>,
    },
}

/// Initial velocities.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialVelocity {
    /// Uniform value (zero by default).
    Uniform(Vec3),
    /// Gaussian components with this standard deviation.
    Gaussian(Real),
}

/// Which face of the box a wall closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    /// Axis 0, 1, 2.
    pub axis: usize,
    /// True for the upper face (`x_max`), false for the lower one.
    pub upper: bool,
}

impl Face {
    /// `x_min`, `y_max`, ...
    pub fn name(&self) -> String {
        format!("{}_{}", crate::math::AXES[self.axis], if self.upper { "max" } else { "min" })
    }
    /// Unit normal pointing into the box.
    pub fn inward_normal(&self) -> Vec3 {
        let mut n = Vec3::zeros();
        n[self.axis] = if self.upper { -1.0 } else { 1.0 };
        n
    }
}

/// How a wall moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WallMotion {
    /// At rest.
    Fixed,
    /// Imposed velocity, m/s.
    Velocity(Vec3),
    /// Servo to a compressive normal stress.
    Stress {
        /// Target, Pa.
        stress: Real,
        /// Gain, m/(s·Pa); `None` = default from stiffness and time step.
        gain: Option<Real>,
        /// Speed limit, m/s.
        max_speed: Real,
    },
}

/// A wall on one face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallDef {
    /// The face.
    pub face: Face,
    /// Motion.
    pub motion: WallMotion,
}

/// Imposed homogeneous deformation of the periodic cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deformation {
    /// Constant true strain rates, 1/s.
    StrainRate(Vec3),
    /// Isotropic pressure servo.
    Pressure {
        /// Target, Pa.
        target: Real,
        /// Largest strain-rate magnitude, 1/s.
        max_strain_rate: Real,
        /// Gain, 1/(s·Pa).
        gain: Real,
    },
}

/// The container.
#[derive(Debug, Clone)]
pub struct Container {
    /// Lower corner, m.
    pub lo: Vec3,
    /// Upper corner, m.
    pub hi: Vec3,
    /// Periodic axes.
    pub periodic: [bool; 3],
    /// Walls on every non-periodic face (in 2D, z has none).
    pub walls: Vec<WallDef>,
    /// Material of the walls.
    pub wall_material: Option<usize>,
    /// Lees-Edwards shear rate, 1/s, and whether particles start on the profile.
    pub lees_edwards: Option<(Real, bool)>,
    /// Deformation of the periodic cell.
    pub deformation: Option<Deformation>,
}

/// Stop criteria.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stop {
    /// Simulated time, s.
    pub time: Option<Real>,
    /// Steps.
    pub steps: Option<u64>,
    /// Packing fraction reached.
    pub packing_fraction: Option<Real>,
    /// Strain reached.
    pub strain: Option<Real>,
}

/// Sampling interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// Every n steps.
    Steps(u64),
    /// Every t seconds of simulated time.
    Time(Real),
}
