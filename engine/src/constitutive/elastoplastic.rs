//! Von Mises elastoplasticity with linear isotropic hardening at finite strain (the sources'
//! elastoplastic grains, Nezamabadi 2020, §2.1.3 and docs/physics.md §5.3: E = 10 MPa, ν = 0.45,
//! σ_y = 0.4 MPa, H ∈ {0, 1, 3} MPa; plastic tangent in uniaxial stress `E H / (E + H)`).
//!
//! Multiplicative split `F = F_e F_p`, Hooke's law on the elastic logarithmic strain
//! `ε_e = ½ ln b_e` (the law of [`super::linear_elastic`]), yield function
//! `f = q − (σ_y + H α)` with `q = sqrt(3/2 s:s)` the von Mises stress of the Kirchhoff
//! deviator `s` and `α` the equivalent plastic strain, associative flow. The return mapping is
//! the exponential one of Simo (Comput. Methods Appl. Mech. Eng. 99, 61, 1992; Simo & Hughes,
//! *Computational Inelasticity*, 1998, §8.3): trial `b_e = F C_p⁻¹ Fᵀ`, radial return on the
//! principal logarithmic strains, `Δα = f_trial / (3μ + H)`; along fixed principal axes it is
//! exactly the small-strain radial return written in logarithmic strains. The history holds
//! `C_p⁻¹` and `α`. The tangent is the default one (central differences of the return mapping:
//! the consistent algorithmic tangent).

use super::{hooke, hooke_energy, log_strain, principal, ConstitutiveLaw, History, Lame, Mat2, PlaneSym, Response};
use crate::math::Real;

/// Von Mises plasticity with linear isotropic hardening (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elastoplastic {
    /// Lamé's constants, Pa.
    pub lame: Lame,
    /// Initial yield stress `σ_y`, Pa.
    pub yield_stress: Real,
    /// Hardening modulus `H`, Pa.
    pub hardening: Real,
}

impl Elastoplastic {
    /// From Young's modulus (Pa), Poisson's ratio, yield stress (Pa) and hardening modulus (Pa).
    pub fn new(young: Real, poisson: Real, yield_stress: Real, hardening: Real) -> Self {
        Self { lame: Lame::from_young(young, poisson), yield_stress, hardening }
    }

    /// The trial elastic left Cauchy-Green tensor `F C_p⁻¹ Fᵀ` (plane strain: `zz` is
    /// `C_p⁻¹_zz`).
    fn trial(f: &Mat2, h: &History) -> PlaneSym {
        PlaneSym::from_in_plane(&(f * h.inv_plastic.in_plane() * f.transpose()), h.inv_plastic.zz)
    }

    /// The returned principal elastic strains and the plastic increment `Δα`.
    fn returned(&self, eps: [Real; 3], alpha: Real) -> ([Real; 3], Real) {
        let tau = hooke(&self.lame, &eps);
        let mean = (tau[0] + tau[1] + tau[2]) / 3.0;
        let s = [tau[0] - mean, tau[1] - mean, tau[2] - mean];
        let q = (1.5 * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2])).sqrt();
        let over = q - (self.yield_stress + self.hardening * alpha);
        if over <= 0.0 || q == 0.0 {
            return (eps, 0.0);
        }
        let d_alpha = over / (3.0 * self.lame.mu + self.hardening);
        // Flow along the unit deviator direction n = 3/2 s / q (|n| = sqrt(3/2)).
        let k = d_alpha * 1.5 / q;
        ([eps[0] - k * s[0], eps[1] - k * s[1], eps[2] - k * s[2]], d_alpha)
    }
}

impl ConstitutiveLaw for Elastoplastic {
    fn name(&self) -> &'static str {
        "elastoplastic"
    }

    fn moduli(&self) -> Lame {
        self.lame
    }

    fn plastic(&self) -> bool {
        true
    }

    fn response(&self, f: &Mat2, h: &History) -> Option<Response> {
        if f.determinant() <= 0.0 {
            return None;
        }
        let (e, eps) = log_strain(&Self::trial(f, h))?;
        let (eps_e, d_alpha) = self.returned(eps, h.alpha);
        let tau = principal(&e, &hooke(&self.lame, &eps_e));
        let history = if d_alpha > 0.0 {
            // b_e = exp(2 ε_e) on the trial's axes, and C_p⁻¹ = F⁻¹ b_e F⁻ᵀ.
            let b_e = principal(&e, &[(2.0 * eps_e[0]).exp(), (2.0 * eps_e[1]).exp(), (2.0 * eps_e[2]).exp()]);
            let inv = f.try_inverse()?;
            History { inv_plastic: PlaneSym::from_in_plane(&(inv * b_e.in_plane() * inv.transpose()), b_e.zz), alpha: h.alpha + d_alpha }
        } else {
            *h
        };
        Some(Response { tau, history })
    }

    fn stored_energy(&self, f: &Mat2, h: &History) -> Option<Real> {
        if f.determinant() <= 0.0 {
            return None;
        }
        let (_, eps) = log_strain(&Self::trial(f, h))?;
        let (eps_e, _) = self.returned(eps, h.alpha);
        Some(hooke_energy(&self.lame, &eps_e))
    }
}
