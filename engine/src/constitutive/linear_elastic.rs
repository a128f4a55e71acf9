//! Linear elasticity (Hooke) on the logarithmic strain: `τ = λ tr(ε) I + 2μ ε` with
//! `ε = ½ ln b`, `b = F Fᵀ`, `τ = J σ` (Pa).
//!
//! At small strain this is the small-strain linear elasticity of the sources (docs/physics.md §5.3;
//! Nezamabadi 2020, §2.1.1: E = 10 MPa, ν = 0.45): `ε → sym(F) − I`, `τ → σ`, and the two agree to
//! second order in the strain. Unlike `σ = C : (sym F − I)` it is frame-invariant: a grain that
//! turns by 0.1 rad without deforming carries no stress, where the small-strain law would put
//! E·0.005 in it (a tenth of the sources' yield stress for E = 10 MPa). It is also the elastic part
//! of [`super::elastoplastic`], so the two coincide below yield.
//!
//! Its tangent is in closed form, in the principal axes of the stretch (Ogden, *Non-linear
//! Elastic Deformations*, 1984, §6.1.4): with `F = Σ_i λ_i n_i ⊗ N_i`, the stored energy's
//! derivatives `W_i = τ_i / λ_i`, `W_ii = (λ + 2μ − τ_i) / λ_i²`, `W_ij = λ / (λ_i λ_j)`
//! (`λ`, `μ` Lamé's constants),
//! `A = Σ_ij W_ij (n_i⊗N_i)⊗(n_j⊗N_j) + Σ_(i≠j) [f (n_i⊗N_j)⊗(n_i⊗N_j) + g (n_i⊗N_j)⊗(n_j⊗N_i)]`,
//! `f = (λ_i W_i − λ_j W_j) / (λ_i² − λ_j²)`, `g = (λ_j W_i − λ_i W_j) / (λ_i² − λ_j²)`, and
//! their limits `½ (W_ii − W_ij ± W_i / λ_i)` at equal stretches. (Central differences of the
//! stress, the default, took eight stress evaluations a point and a sixth of a dense
//! compaction's run.)

use super::{
    hooke, hooke_energy, left_cauchy_green, log_strain, principal, ConstitutiveLaw, History, Lame, Mat2, Response, Spectral, Tangent,
};
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

    fn tangent(&self, f: &Mat2, _h: &History) -> Option<Tangent> {
        if f.determinant() <= 0.0 {
            return None;
        }
        // Material principal directions and stretches from C = FᵀF; spatial ones n_i = F N_i / λ_i.
        let c = f.transpose() * f;
        let e = Spectral::of(c[(0, 0)], c[(1, 1)], c[(0, 1)]);
        if e.l2.is_nan() || e.l2 <= 0.0 {
            return None;
        }
        let stretch = [e.l1.sqrt(), e.l2.sqrt()];
        let big_n = [nalgebra::Vector2::new(e.c, e.s), nalgebra::Vector2::new(-e.s, e.c)];
        let n = [f * big_n[0] / stretch[0], f * big_n[1] / stretch[1]];
        let tau = hooke(&self.lame, &[stretch[0].ln(), stretch[1].ln(), 0.0]);
        let (lm, mu) = (self.lame.lambda, self.lame.mu);
        let w1 = [tau[0] / stretch[0], tau[1] / stretch[1]];
        let w11 = (lm + 2.0 * mu - tau[0]) / (stretch[0] * stretch[0]);
        let w22 = (lm + 2.0 * mu - tau[1]) / (stretch[1] * stretch[1]);
        let w12 = lm / (stretch[0] * stretch[1]);
        let w2 = [[w11, w12], [w12, w22]];
        // The shear coefficients; below a relative difference of 1e-8 between the stretches
        // their limits (first order in the difference, as is the quotients' rounding there).
        let (l1, l2) = (stretch[0], stretch[1]);
        let (sf, sg) = if l1 - l2 > 1e-8 * l1 {
            let d = l1 * l1 - l2 * l2;
            ((l1 * w1[0] - l2 * w1[1]) / d, (l2 * w1[0] - l1 * w1[1]) / d)
        } else {
            (0.5 * (w11 - w12 + w1[0] / l1), 0.5 * (w11 - w12 - w1[0] / l1))
        };
        let mut a = [[0.0; 4]; 4];
        // Adds `k (p ⊗ P) ⊗ (q ⊗ Q)`.
        let mut add = |k: Real,
                       p: &nalgebra::Vector2<Real>,
                       pp: &nalgebra::Vector2<Real>,
                       q: &nalgebra::Vector2<Real>,
                       qq: &nalgebra::Vector2<Real>| {
            for (ab, row) in a.iter_mut().enumerate() {
                let x = k * p[ab / 2] * pp[ab % 2];
                for (ce, v) in row.iter_mut().enumerate() {
                    *v += x * q[ce / 2] * qq[ce % 2];
                }
            }
        };
        for i in 0..2 {
            for j in 0..2 {
                add(w2[i][j], &n[i], &big_n[i], &n[j], &big_n[j]);
            }
            let j = 1 - i;
            add(sf, &n[i], &big_n[j], &n[i], &big_n[j]);
            add(sg, &n[i], &big_n[j], &n[j], &big_n[i]);
        }
        Some(a)
    }
}
