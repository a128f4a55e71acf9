//! The checked materials: density, contact law, restitution, friction, rolling resistance,
//! cohesion, liquid and, for deformable grains, the constitutive law.

use crate::math::Real;

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

    /// The rupture distance of a bridge `d_rupt = (1 + θ/2) V_b^(1/3)`, m (Lian, Thornton &
    /// Adams 1993; docs/physics.md §2.8).
    pub fn rupture_distance(&self) -> Real {
        (1.0 + 0.5 * self.contact_angle) * self.bridge_volume.cbrt()
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
