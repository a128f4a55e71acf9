//! Capillary bridge force of the pendular state (Richefeu, El Youssoufi & Radjai 2006;
//! Nezamabadi 2020, eqs. 1.5-1.8; docs/references.md check 14), attractive, along the normal:
//!
//! - `f_c = -kappa R` in contact (gap h < 0),
//! - `f_c = -kappa R exp(-h / lambda)` for `0 <= h <= d_rupt`,
//! - 0 beyond, where the bridge breaks;
//!
//! with `R = sqrt(R_i R_j)`, `kappa = 2 pi gamma_s cos(theta)`, `d_rupt = (1 + theta/2) V_b^(1/3)`,
//! `lambda = c h(r) sqrt(V_b / R')`, `c = 0.9`, `h(r) = r^(-1/2)`, `R' = 2 R_i R_j / (R_i + R_j)`,
//! `r = max(R_i/R_j, R_j/R_i)`. A bridge forms when two wet grains touch and persists until the
//! gap exceeds `d_rupt` (the pair history holds its state). Units: N/m, m, m³, N.

/// Capillary law of one pair of wet materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CapillaryRichefeu {
    /// kappa = 2 pi gamma_s cos(theta), N/m.
    pub kappa: f64,
    /// Bridge volume V_b, m³.
    pub bridge_volume: f64,
    /// Rupture distance d_rupt, m.
    pub rupture_distance: f64,
}

/// The prefactor c of lambda (Nezamabadi 2020, eq. 1.8).
pub const LAMBDA_PREFACTOR: f64 = 0.9;

impl CapillaryRichefeu {
    /// Builds the law from surface tension (N/m), contact angle (rad) and bridge volume (m³).
    pub fn new(surface_tension: f64, contact_angle: f64, bridge_volume: f64) -> Self {
        Self {
            kappa: 2.0 * std::f64::consts::PI * surface_tension * contact_angle.cos(),
            bridge_volume,
            rupture_distance: (1.0 + 0.5 * contact_angle) * bridge_volume.cbrt(),
        }
    }

    /// Decay length lambda for radii `ri`, `rj`, m.
    #[inline(always)]
    pub fn decay_length(&self, ri: f64, rj: f64) -> f64 {
        let r_harm = 2.0 * ri * rj / (ri + rj);
        let ratio = if ri > rj { ri / rj } else { rj / ri };
        LAMBDA_PREFACTOR * ratio.powf(-0.5) * (self.bridge_volume / r_harm).sqrt()
    }

    /// Normal force (N, negative = attractive) at gap `h` (m; negative in contact) for a pair
    /// whose bridge exists. Zero beyond the rupture distance.
    #[inline(always)]
    pub fn force(&self, h: f64, ri: f64, rj: f64) -> f64 {
        let r = (ri * rj).sqrt();
        if h < 0.0 {
            -self.kappa * r
        } else if h <= self.rupture_distance {
            -self.kappa * r * (-h / self.decay_length(ri, rj)).exp()
        } else {
            0.0
        }
    }

    /// Potential energy of the bridge (J), zero at rupture, so that `force = -dU/dh`.
    pub fn energy(&self, h: f64, ri: f64, rj: f64) -> f64 {
        let r = (ri * rj).sqrt();
        let lambda = self.decay_length(ri, rj);
        let at_zero = -self.kappa * r * lambda * (1.0 - (-self.rupture_distance / lambda).exp());
        if h < 0.0 {
            at_zero + self.kappa * r * h
        } else if h <= self.rupture_distance {
            -self.kappa * r * lambda * ((-h / lambda).exp() - (-self.rupture_distance / lambda).exp())
        } else {
            0.0
        }
    }
}
