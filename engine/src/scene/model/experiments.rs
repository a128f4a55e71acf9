//! The checked standard experiments ([`Experiment`]) and their preparation; the stages they
//! expand into are built by [`crate::scene::experiments`].

use super::{Ball, DrumDef, Equilibrium};
use crate::math::Real;

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
