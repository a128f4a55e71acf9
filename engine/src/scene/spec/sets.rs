//! The `particles` section: each set's grain model (aggregates), size distribution, placement
//! and initial velocities.

use serde::{Deserialize, Serialize};

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

/// A ball (a disk in 2D).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallSpec {
    /// Centre, m (length = dimension).
    pub center: Vec<f64>,
    /// Radius, m.
    pub radius: f64,
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
        /// A ball (disk in 2D) the grains must lie in, besides the region.
        #[serde(default)]
        within: Option<BallSpec>,
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
        /// A ball (disk in 2D) the grains must lie in, besides the region: a packed
        /// agglomerate.
        #[serde(default)]
        within: Option<BallSpec>,
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
