//! The `materials` section: density, contact law, restitution, friction, rolling resistance,
//! cohesion, liquid and, for deformable grains, the constitutive law.

use serde::{Deserialize, Serialize};

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
