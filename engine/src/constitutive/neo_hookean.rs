//! The compressible neo-Hookean solid of the sources (Nezamabadi 2020, eq. 2.3;
//! docs/physics.md §5.3): `S = (λ ln J − μ) C⁻¹ + μ I`, that is `τ = μ (b − I) + λ ln J I` (Pa),
//! stored energy `W = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)²` per reference volume (J/m³); `μ` the
//! shear modulus and `λ` the first Lamé constant at small strain. Its tangent is in closed form:
//! `A_aBcE = μ δ_ac δ_BE + (μ − λ ln J) F⁻¹_Bc F⁻¹_Ea + λ F⁻¹_Ba F⁻¹_Ec`.

use super::{left_cauchy_green, ConstitutiveLaw, History, Lame, Mat2, PlaneSym, Response, Tangent};
use crate::math::Real;

/// The compressible neo-Hookean law (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeoHookean {
    /// Shear modulus `μ`, Pa.
    pub mu: Real,
    /// First Lamé constant `λ`, Pa.
    pub lambda: Real,
}

impl ConstitutiveLaw for NeoHookean {
    fn name(&self) -> &'static str {
        "neo_hookean"
    }

    fn moduli(&self) -> Lame {
        Lame { lambda: self.lambda, mu: self.mu }
    }

    fn response(&self, f: &Mat2, h: &History) -> Option<Response> {
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        let b = left_cauchy_green(f);
        let p = self.lambda * j.ln();
        let tau = PlaneSym { xx: self.mu * (b.xx - 1.0) + p, yy: self.mu * (b.yy - 1.0) + p, xy: self.mu * b.xy, zz: p };
        Some(Response { tau, history: *h })
    }

    fn stored_energy(&self, f: &Mat2, _h: &History) -> Option<Real> {
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        let tr_c = f.norm_squared() + 1.0;
        let l = j.ln();
        Some(0.5 * self.mu * (tr_c - 3.0) - self.mu * l + 0.5 * self.lambda * l * l)
    }

    fn tangent(&self, f: &Mat2, _h: &History) -> Option<Tangent> {
        let j = f.determinant();
        if j <= 0.0 {
            return None;
        }
        let inv = f.try_inverse()?;
        let c1 = self.mu - self.lambda * j.ln();
        let mut a = [[0.0; 4]; 4];
        for (ab, row) in a.iter_mut().enumerate() {
            let (aa, bb) = (ab / 2, ab % 2);
            for (ce, x) in row.iter_mut().enumerate() {
                let (c, e) = (ce / 2, ce % 2);
                let delta = if aa == c && bb == e { self.mu } else { 0.0 };
                *x = delta + c1 * inv[(e, aa)] * inv[(bb, c)] + self.lambda * inv[(bb, aa)] * inv[(e, c)];
            }
        }
        Some(a)
    }
}
