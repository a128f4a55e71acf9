//! The checked particle sets: grain model (aggregates), size distribution, placement and
//! initial velocities.

use crate::math::{Real, Vec3};

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
    /// A ball (disk) the grains of a random or lattice placement must lie in (an agglomerate).
    pub within: Option<super::container::Ball>,
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
