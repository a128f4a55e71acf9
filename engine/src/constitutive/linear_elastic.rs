//! Linear elasticity (Hooke) on the logarithmic strain: `τ = λ tr(ε) I + 2μ ε` with
//! `ε = ½ ln b`, `b = F Fᵀ`, `τ = J σ` (Pa).
//!
//! At small strain this is the small-strain linear elasticity of the sources (PHYSICS.md §5;
//! the habilitation N 2.1.1: E = 10 MPa, ν = 0.45): `ε → sym(F) − I`, `τ → σ`, and the two
//! agree to second order in the strain. Unlike `σ = C : (sym F − I)` it is frame-invariant: a
//! grain that turns by 0.1 rad without deforming carries no stress, where the small-strain law
//! would put E·0.005 in it (a tenth of the sources' yield stress for E = 10 MPa). It is also
//! the elastic part of [`super::elastoplastic`], so the two coincide below yield.

use super::{hooke, hooke_energy, left_cauchy_green, log_strain, principal, ConstitutiveLaw, History, Lame, Mat2, Response};
use crate::math::Real;

/// Hooke's law on the logarithmic strain (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearElastic {
    /// Lamé's constants, Pa.
    pub lame: Lame,
}

impl LinearElastic {
    /// From Young's modulus (Pa) and Poisson's ratio.
    pub fn new(young: Real, poisson: Real) -> Self {
        Self { lame: Lame::from_young(young, poisson) }
    }
}

impl ConstitutiveLaw for LinearElastic {
    fn name(&self) -> &'static str {
        "linear_elastic"
    }

    fn moduli(&self) -> Lame {
        self.lame
    }

    fn response(&self, f: &Mat2, h: &History) -> Option<Response> {
        if f.determinant() <= 0.0 {
            return None;
        }
        let (e, eps) = log_strain(&left_cauchy_green(f))?;
        Some(Response { tau: principal(&e, &hooke(&self.lame, &eps)), history: *h })
    }

    fn stored_energy(&self, f: &Mat2, _h: &History) -> Option<Real> {
        if f.determinant() <= 0.0 {
            return None;
        }
        let (_, eps) = log_strain(&left_cauchy_green(f))?;
        Some(hooke_energy(&self.lame, &eps))
    }
}
