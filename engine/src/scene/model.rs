//! The checked scene: typed values that the methods build from. Produced only by
//! [`validate`](super::validate), so every invariant stated here holds. A scene knows no
//! method: `methods::Plan` pairs it with the one that runs it.

use crate::math::{Real, Vec3};

/// A validated scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Name (the file's `name`, or `"scene"`).
    pub name: String,
    /// 2 or 3.
    pub dim: usize,
    /// Materials; particle sets and walls refer to them by index.
    pub materials: Vec<Material>,
    /// Particle sets in placement order (empty when the scene starts from a state).
    pub sets: Vec<ParticleSet>,
    /// The saved state the scene starts from (`start_from`), whose particles replace the sets.
    pub initial: Option<std::sync::Arc<super::state::InitialState>>,
    /// Box, walls, periodicity and imposed deformation.
    pub container: Container,
    /// Gravity, m/s² (z = 0 in 2D).
    pub gravity: Vec3,
    /// Stop criteria of the whole run (for a scene with an `experiment`, the limits it gives,
    /// possibly none: each stage then ends by its own criteria).
    pub stop: Stop,
    /// The loading program, in order: one stage built from `stop` for a plain scene, or the
    /// stages of the scene's experiment ([`Experiment::stages`]). Never empty.
    pub stages: Vec<Stage>,
    /// The standard experiment the scene runs, if any (its derived results are computed by
    /// [`crate::observe::results`]).
    pub experiment: Option<Experiment>,
    /// Sampling interval.
    pub sampling: Sampling,
    /// Snapshot interval in steps (0: with every sample); `None`: no snapshots.
    pub snapshots: Option<u64>,
    /// Seed of all random draws.
    pub seed: u64,
}

/// The most particles a scene may place (primaries of aggregates included), whatever the
/// machine: beyond it the engine's per-particle arrays alone would take hundreds of gigabytes.
/// A server bounds scenes further by its own limit.
pub const MAX_PARTICLES: usize = 1_000_000_000;

impl Scene {
    /// Number of particles: those of the sets (an aggregate set's estimated primaries), or of
    /// the state the scene starts from. Saturates at `usize::MAX` rather than wrapping, so a
    /// scene whose counts overflow compares above every limit.
    pub fn particle_count(&self) -> usize {
        let from_state = self.initial.as_ref().map_or(0, |st| st.radius.len());
        self.sets.iter().map(ParticleSet::particle_count).fold(from_state, usize::saturating_add)
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
    /// Dry cohesion.
    pub cohesion: Option<Cohesion>,
    /// The constitutive law of a deformable material (method `mpm`); its `law` is then the
    /// Hertz–Mindlin law of its small-strain elastic constants, which only the advisor reads.
    pub deformable: Option<crate::constitutive::LawSpec>,
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

impl ElasticLaw {
    /// Stiffness number at confining stress `p` (Pa) for grains of mean diameter `d` (m)
    /// (Roux & Chevoir 2005, §2.3.4): `k_n/(p d)` (linear, 3D), `k_n/p` (linear, 2D: k_n per metre),
    /// `(E/((1-ν²) p))^(2/3)` (Hertz). Its inverse is the contact deflection over `d`.
    pub fn stiffness_number(&self, dim: usize, p: Real, d: Real) -> Real {
        match *self {
            Self::Linear { k_n, .. } if dim == 3 => k_n / (p * d),
            Self::Linear { k_n, .. } => k_n / p,
            Self::HertzMindlin { young, poisson } => (young / ((1.0 - poisson * poisson) * p)).powf(2.0 / 3.0),
        }
    }
}

/// Rolling resistance parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rolling {
    /// Stiffness, N·m/rad.
    pub stiffness: Real,
    /// Rolling friction coefficient.
    pub friction: Real,
}

/// Dry cohesion (Roux & Chevoir 2005, §2.2.3): a constant attraction within a distance of contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cohesion {
    /// Attraction F_0, N.
    pub force: Real,
    /// Range D_0 beyond contact, m.
    pub distance: Real,
}

impl Liquid {
    /// The capillary prefactor `κ = 2π γ cos θ`, N/m: the bridge pulls with `κ R` at contact
    /// (docs/physics.md §1, eq. 1.5-1.6).
    pub fn capillary_prefactor(&self) -> Real {
        2.0 * std::f64::consts::PI * self.surface_tension * self.contact_angle.cos()
    }
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
    /// The grains are aggregates of bonded primaries (`None`: each grain is one particle).
    pub aggregate: Option<AggregateModel>,
}

impl ParticleSet {
    /// Number of particles the set places: its grains, or the primaries of its aggregates
    /// (estimated, [`AggregateModel::estimated_primaries`]). Saturates at `usize::MAX`.
    pub fn particle_count(&self) -> usize {
        match &self.aggregate {
            Some(a) => self.count.saturating_mul(a.estimated_primaries(self.size.mean_power(a.dim as Real))),
            None => self.count,
        }
    }
}

/// Grains that are aggregates of rigid primaries bonded by an attraction: the bonded particle
/// method (docs/physics.md §4; Nezamabadi 2020, §1.2.1), in 2D and 3D. The set's own size distribution is the
/// grains'.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AggregateModel {
    /// The scene's dimension, 2 or 3: disks in disks, or balls in balls.
    pub dim: usize,
    /// Diameters of the primaries, m.
    pub primaries: SizeDist,
    /// Fewest primaries a grain may be made of.
    pub min_primaries: usize,
    /// The laws between primaries of one grain.
    pub bonding: crate::particles::aggregate::Bonding,
}

/// Fraction of a grain's disk (2D) or ball (3D) that its grown aggregate fills
/// ([`crate::particles::aggregate::grow_disk`], measured 0.70 and 0.73 in grains of 1.6 and
/// 1.8 mm with primaries of 0.07–0.13 mm; [`crate::particles::aggregate::grow_ball`], 0.39, 0.43
/// and 0.46 in balls of 0.8, 1 and 1.2 mm, whose ragged outer shell is a larger part).
pub const AGGREGATE_FILL: [Real; 2] = [0.70, 0.39];

impl AggregateModel {
    /// Primaries in a grain whose diameter to the power of the dimension is `grain_power`
    /// (m² in 2D, m³ in 3D): the disk's area (ball's volume) times [`AGGREGATE_FILL`] over a
    /// primary's mean area (volume).
    pub fn estimated_primaries(&self, grain_power: Real) -> usize {
        let fill = AGGREGATE_FILL[usize::from(self.dim == 3)];
        (fill * grain_power / self.primaries.mean_power(self.dim as Real)).floor() as usize
    }
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
    /// Number-mean diameter, m.
    pub fn mean_diameter(&self) -> Real {
        match *self {
            Self::Monodisperse(d) => d,
            Self::Uniform { min, max } => 0.5 * (min + max),
            Self::Bidisperse { small, ratio, fraction_small } => small * (fraction_small + (1.0 - fraction_small) * ratio),
        }
    }
    /// Mean of the diameter to the power `k`, `<d^k>`, m^k.
    pub fn mean_power(&self, k: Real) -> Real {
        match *self {
            Self::Monodisperse(d) => d.powf(k),
            Self::Uniform { min, max } if max > min => (max.powf(k + 1.0) - min.powf(k + 1.0)) / ((k + 1.0) * (max - min)),
            Self::Uniform { min, .. } => min.powf(k),
            Self::Bidisperse { small, ratio, fraction_small } => {
                fraction_small * small.powf(k) + (1.0 - fraction_small) * (small * ratio).powf(k)
            }
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
    /// Moves along its axis at `rate × L`, `L` the current box length on that axis, so that
    /// the length changes at the constant true strain rate `rate`, 1/s (negative compresses),
    /// while the opposite wall is fixed.
    StrainRate(Real),
    /// Servo to a compressive normal stress.
    Stress {
        /// Target, Pa.
        stress: Real,
        /// Gain, m/(s·Pa); `None` = default from stiffness and time step.
        gain: Option<Real>,
        /// Speed limit, m/s.
        max_speed: Real,
        /// Add the integral action of [`crate::loading::Wall::servo`] (walls that must follow
        /// a deforming sample, such as the lateral walls of a biaxial test); plain servo walls
        /// of the container are proportional only.
        integral: bool,
    },
    /// The upper wall of a shear cell: servo-controlled along its axis to a compressive
    /// normal stress (with the integral action), while it slides along `flow` at
    /// `shear_rate × L`, `L` the current gap, so that the gap shears at a constant rate
    /// against a fixed opposite wall.
    Shearing {
        /// Target normal stress, Pa.
        stress: Real,
        /// Shear rate, 1/s.
        shear_rate: Real,
        /// Axis of the sliding.
        flow: usize,
        /// Speed limit along the axis, m/s.
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
    /// Servo of one axis's length to a normal stress σ_aa (the other axes keep their length):
    /// the height of a sheared Lees-Edwards cell under an imposed normal stress.
    NormalStress {
        /// The controlled axis.
        axis: usize,
        /// Target σ_aa, Pa.
        target: Real,
        /// Largest strain-rate magnitude, 1/s.
        max_strain_rate: Real,
        /// Gain, 1/(s·Pa).
        gain: Real,
    },
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
    /// A rotating drum inscribed in the box (set by the `drum` experiment).
    pub drum: Option<DrumDef>,
    /// The ball (disk in 2D) the grains are placed in to form a granule (set by the
    /// `granule_compression` experiment).
    pub granule: Option<Ball>,
}

/// A ball (a disk in 2D: its z is not used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Centre, m.
    pub center: Vec3,
    /// Radius, m.
    pub radius: Real,
}

/// A cylindrical wall (a circle in 2D) about an axis of the box, which may turn about it: the
/// rotating drum. Its surface is made of the container's wall material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumDef {
    /// Axis of the cylinder (z in 2D).
    pub axis: usize,
    /// A point of the axis, m (its coordinate along the axis is not used).
    pub center: Vec3,
    /// Inner radius, m.
    pub radius: Real,
    /// Unit vector of gravity (perpendicular to the axis), for the measurements of the bed.
    pub down: Vec3,
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

/// One stage of a loading program: the boundary controls set at its start and the criteria
/// that end it.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// Name reported with every sample of the stage (`preparation`, `loading`, ...).
    pub name: String,
    /// Boundary and material controls applied when the stage starts.
    pub controls: Controls,
    /// Ends the stage (first criterion reached). `strain` counts from the stage's start.
    pub until: Stop,
    /// Axis whose true strain `|ln(L/L_start)|` the `until.strain` criterion reads; `None`: the
    /// largest over the axes (the Lees-Edwards strain under shear).
    pub strain_axis: Option<usize>,
    /// When set, the stage ends once the system is at equilibrium; reaching `until`'s time or
    /// steps first is then an error ([`crate::EngineError::NotConverged`]).
    pub equilibrium: Option<Equilibrium>,
}

/// Controls that a stage changes when it starts. Fields left empty keep what the stage before
/// set (or the container's initial settings).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Controls {
    /// New motion of these walls (the others keep theirs).
    pub walls: Vec<WallDef>,
    /// `Some(d)`: the cell deformation becomes `d` (`None` inside: the cell stops).
    pub deformation: Option<Option<Deformation>>,
    /// Coulomb friction of every particle-particle contact during the stage (wall contacts keep
    /// their material's); `None`: the materials' own.
    pub friction: Option<Real>,
    /// Cundall's local damping during the stage; `None`: the method's own setting.
    pub local_damping: Option<Real>,
    /// `Some(rate)`: the Lees-Edwards shear rate becomes `rate` (1/s; x and y periodic), and the
    /// grains' x-velocities get the change of the linear profile `Δrate (y - y_centre)`.
    pub shear_rate: Option<Real>,
    /// `Some(ω)`: the drum turns at ω, rad/s (right-handed about its axis).
    pub drum_angular_velocity: Option<Real>,
    /// `Some(gap)`: the grains whose surface lies within `gap` mean diameters of a wall are
    /// glued to it (rough walls): from then on they move with the wall, do not turn, and the
    /// load the other grains put on them is the wall's.
    pub glue: Option<Real>,
    /// `Some(a)`: every grain is pulled towards the centre of the container's granule ball
    /// with the acceleration `a`, m/s² (0 switches the field off).
    pub centripetal: Option<Real>,
    /// `Some(axis)`: the two walls of this axis jump to the grains' extent along it (they
    /// touch the outermost grains) when the stage starts.
    pub close_walls: Option<usize>,
}

/// The equilibrium criterion of a stage: all must hold at `consecutive` checks in a row,
/// `check_every` steps apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equilibrium {
    /// Translational kinetic energy / elastic energy stored in the contacts.
    pub kinetic_ratio: Real,
    /// Mean norm of the net force on a particle / mean norm of a contact force (Yade's
    /// "unbalanced force").
    pub unbalanced_force: Real,
    /// Relative error of every stress-controlled boundary against its target.
    pub stress_tolerance: Real,
    /// Steps between checks.
    pub check_every: u64,
    /// Checks in a row that must pass; `None`: the method's own number
    /// ([`crate::run::Simulation::equilibrium_checks`]).
    pub consecutive: Option<u32>,
}

impl Default for Equilibrium {
    fn default() -> Self {
        Self { kinetic_ratio: 1e-4, unbalanced_force: 1e-2, stress_tolerance: 0.01, check_every: 500, consecutive: None }
    }
}

/// How the grains are brought to the initial state of an experiment: compressed by a servo to
/// an isotropic pressure, with the stress-controlled walls (walled box) or the periodic cell
/// (fully periodic box), until equilibrium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preparation {
    /// Confining pressure, Pa.
    pub pressure: Real,
    /// Friction of every contact during the compression (0 gives the densest state; the
    /// material friction a looser one).
    pub friction: Real,
    /// Largest compression rate of the servo, 1/s (true strain rate per axis).
    pub max_strain_rate: Real,
    /// Cundall's local damping during the compression.
    pub local_damping: Real,
    /// When the compression is over.
    pub equilibrium: Equilibrium,
    /// Step limit of the compression.
    pub max_steps: u64,
}

/// A standard numerical experiment (issue "experiments"; docs/physics.md §9).
#[derive(Debug, Clone, PartialEq)]
pub enum Experiment {
    /// Isotropic compression to a pressure, until equilibrium.
    Isotropic {
        /// The compression.
        preparation: Preparation,
    },
    /// Isotropic compression, then compression along `axis` at a constant true strain rate with
    /// the lateral walls servo-controlled to the confining pressure: biaxial in 2D, triaxial in
    /// 3D (Nezamabadi 2020, §2.2, 2.25-2.28).
    Triaxial {
        /// The isotropic compression to the confining pressure.
        preparation: Preparation,
        /// Loading axis.
        axis: usize,
        /// Axial true strain rate, 1/s (> 0, compression).
        strain_rate: Real,
        /// Axial strain at which the test ends.
        axial_strain: Real,
        /// Step limit of the loading.
        max_steps: u64,
    },
    /// Plane shear flow (Nezamabadi 2020, §3.1; GDR MiDi 2004) under the normal stress σ_yy = pressure, at a
    /// constant shear rate: in a Lees-Edwards cell whose height (y) is servo-controlled
    /// (isotropic preparation by the cell), or between rough walls — grains glued to the walls
    /// y_min and y_max, the upper one sliding along x and servo-controlled along y, x (and z)
    /// periodic (preparation by the y walls).
    PlaneShear {
        /// The compression to the pressure.
        preparation: Preparation,
        /// Rough walls instead of a Lees-Edwards cell.
        rough_walls: bool,
        /// Shear rate, 1/s.
        shear_rate: Real,
        /// Shear strain at which the test ends.
        strain: Real,
        /// Step limit of the shear.
        max_steps: u64,
    },
    /// Deposition under gravity (the grains fall onto the floor of the box and settle), until
    /// equilibrium.
    Deposition {
        /// Axis of gravity.
        axis: usize,
        /// The floor (the wall gravity points to) is the upper wall of the axis.
        floor_upper: bool,
        /// Cundall's local damping while the grains settle.
        local_damping: Real,
        /// When the deposit is settled.
        equilibrium: Equilibrium,
        /// Step limit.
        max_steps: u64,
    },
    /// Uniaxial compaction (Nezamabadi 2020, §2.1): the upper wall of `axis` moves down at a constant speed (or
    /// is servo-controlled to a stress), the other walls are fixed.
    Compaction {
        /// Compressed axis.
        axis: usize,
        /// How the upper wall moves.
        drive: CompactionDrive,
        /// Step limit.
        max_steps: u64,
    },
    /// Rotating drum (Nezamabadi 2020, §3.2.1; docs/references.md check 17): the grains settle at the bottom of the drum at
    /// rest, then the drum turns at a constant angular velocity; the free surface, the flow
    /// regime and the velocity profile across the flowing layer are measured once the flow is
    /// steady.
    Drum {
        /// The drum.
        drum: DrumDef,
        /// Angular velocity, rad/s (positive: right-handed about the axis).
        angular_velocity: Real,
        /// Froude number `Fr = ω² R / g`.
        froude: Real,
        /// Revolutions turned in all.
        revolutions: Real,
        /// Revolutions discarded before the averages start (the transient).
        transient: Real,
        /// Cundall's local damping while the grains settle.
        local_damping: Real,
        /// When the grains have settled before the drum starts.
        equilibrium: Equilibrium,
        /// Step limit of each stage.
        max_steps: u64,
    },
    /// Diametral compression of a wet granule (Nezamabadi 2020, §3.2.3): the grains, placed in a ball, are
    /// pulled together by a centripetal field until equilibrium (capillary bridges form), left
    /// to hold by themselves, then squeezed between the two plates of `axis` closing at a
    /// constant true strain rate: stress-strain curve, plastic strength and its prediction.
    GranuleCompression {
        /// The ball the grains start in.
        ball: Ball,
        /// Axis of the plates.
        axis: usize,
        /// Acceleration of the centripetal field that forms the granule, m/s².
        acceleration: Real,
        /// True strain rate of the compression, 1/s (> 0).
        strain_rate: Real,
        /// Final strain `|ln(h/h_0)|`.
        strain: Real,
        /// Strain window over which the plastic strength is averaged.
        plateau: (Real, Real),
        /// Cundall's local damping while the granule forms and relaxes.
        local_damping: Real,
        /// When the granule has formed, and when it holds by itself.
        equilibrium: Equilibrium,
        /// Step limit of each stage.
        max_steps: u64,
    },
}

/// How the compaction wall moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CompactionDrive {
    /// At this speed, m/s, until the axial strain `strain`.
    Velocity {
        /// Speed, m/s.
        speed: Real,
        /// Final strain `|ln(h/h_i)|`.
        strain: Real,
    },
    /// Servo-controlled to this stress, Pa, until equilibrium.
    Stress {
        /// Target, Pa.
        stress: Real,
        /// Speed limit, m/s.
        max_speed: Real,
        /// When the compaction is over.
        equilibrium: Equilibrium,
    },
}

impl Experiment {
    /// The name written in scene files.
    pub fn kind(&self, dim: usize) -> &'static str {
        match self {
            Self::Isotropic { .. } => "isotropic",
            Self::Triaxial { .. } if dim == 2 => "biaxial",
            Self::Triaxial { .. } => "triaxial",
            Self::Compaction { .. } => "compaction",
            Self::PlaneShear { .. } => "plane_shear",
            Self::Deposition { .. } => "deposition",
            Self::Drum { .. } => "drum",
            Self::GranuleCompression { .. } => "granule_compression",
        }
    }
}
