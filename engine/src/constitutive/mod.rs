//! Constitutive laws of deformable grains (docs/physics.md §5.3; Nezamabadi 2020, §1.2.2 and
//! eq. 2.3): the stress a material point carries at a deformation, in 2D plane strain, at finite
//! strain.
//!
//! One trait, [`ConstitutiveLaw`], one small file per law:
//! - [`linear_elastic`]: Hooke's law (Young's modulus, Poisson's ratio) on the logarithmic
//!   strain — the small-strain linear elasticity of the sources, made frame-invariant;
//! - [`neo_hookean`]: the compressible neo-Hookean solid of the sources,
//!   `S = (λ ln J − μ) C⁻¹ + μ I`;
//! - [`elastoplastic`]: von Mises plasticity with linear isotropic hardening (yield stress `σ_y`,
//!   hardening modulus `H`), return mapping in the logarithmic strains.
//!
//! Adding a law is one file implementing the trait and one line in [`build`].
//!
//! A law maps the in-plane deformation gradient `F` (plane strain: `F_zz = 1`) and the point's
//! history at the start of the step to the Kirchhoff stress `τ = J σ` (Pa) and the history at
//! `F`. Methods need the first Piola-Kirchhoff stress `P = τ F⁻ᵀ` and its derivative
//! `A = ∂P/∂F` (the material tangent of the Newton iterations): [`ConstitutiveLaw::tangent`]
//! gives it by central differences of the law's own stress update unless a law overrides it in
//! closed form, so that the tangent is always the one consistent with the algorithm (the return
//! mapping included) to about 1e-9 relative.

pub mod elastoplastic;
pub mod linear_elastic;
pub mod neo_hookean;
pub mod plane;

use crate::math::Real;
pub use plane::{left_cauchy_green, Mat2, PlaneSym, Spectral};

/// What a material point remembers between steps: the inverse plastic right Cauchy-Green
/// tensor `C_p⁻¹` (identity for a law without plasticity) and the equivalent plastic strain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct History {
    /// `C_p⁻¹ = F⁻¹ b_e F⁻ᵀ`, dimensionless.
    pub inv_plastic: PlaneSym,
    /// Equivalent (accumulated) plastic strain `α`, dimensionless.
    pub alpha: Real,
}

impl Default for History {
    fn default() -> Self {
        Self { inv_plastic: PlaneSym::IDENTITY, alpha: 0.0 }
    }
}

/// Lamé's constants of the law at small strain, Pa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lame {
    /// First Lamé constant `λ`, Pa.
    pub lambda: Real,
    /// Shear modulus `μ`, Pa.
    pub mu: Real,
}

impl Lame {
    /// From Young's modulus `e` (Pa) and Poisson's ratio `nu`.
    pub fn from_young(e: Real, nu: Real) -> Self {
        Self { lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), mu: e / (2.0 * (1.0 + nu)) }
    }

    /// The P-wave (constrained) modulus `λ + 2μ`, Pa: the speed of sound is `sqrt((λ + 2μ)/ρ)`.
    pub fn p_wave(&self) -> Real {
        self.lambda + 2.0 * self.mu
    }

    /// Bulk modulus in 3D, `λ + 2μ/3`, Pa.
    pub fn bulk(&self) -> Real {
        self.lambda + 2.0 * self.mu / 3.0
    }
}

/// The stress of a point at a deformation and its history there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// Kirchhoff stress `τ = J σ`, Pa.
    pub tau: PlaneSym,
    /// The history at this deformation (the return mapping's result).
    pub history: History,
}

/// `∂P_aB / ∂F_cE`, indexed `[2a + B][2c + E]`, Pa.
pub type Tangent = [[Real; 4]; 4];

/// A constitutive law of plane strain (see the module documentation).
pub trait ConstitutiveLaw: Send + Sync + std::fmt::Debug {
    /// The law's name in the scene format.
    fn name(&self) -> &'static str;

    /// Lamé's constants at small strain (wave speed, time-step estimates, the advisor).
    fn moduli(&self) -> Lame;

    /// Kirchhoff stress and history at `f`, from the history `h` at the start of the step;
    /// `None` where the law is undefined (`det F <= 0`).
    fn response(&self, f: &Mat2, h: &History) -> Option<Response>;

    /// Energy stored per unit reference volume at `f` with history `h` (the elastic part for a
    /// plastic law), J/m³; `None` where `det F <= 0`.
    fn stored_energy(&self, f: &Mat2, h: &History) -> Option<Real>;

    /// First Piola-Kirchhoff stress `P = τ F⁻ᵀ` at `f` (Pa) and the history there.
    fn first_piola(&self, f: &Mat2, h: &History) -> Option<(Mat2, History)> {
        let r = self.response(f, h)?;
        Some((plane::first_piola(&r.tau, f)?, r.history))
    }

    /// Whether the law yields (its grains keep the dents their contacts press in). `mpm` holds
    /// both grains' outlines by default for such grains ([`crate::methods::mpm::MpmParams`]).
    fn plastic(&self) -> bool {
        false
    }

    /// `A = ∂P/∂F` at `f` for the history `h` at the start of the step (plastic flow
    /// included). By default central differences of [`ConstitutiveLaw::first_piola`] with a
    /// step of 1e-6 on each component of `F`: the algorithmic tangent to about 1e-9.
    fn tangent(&self, f: &Mat2, h: &History) -> Option<Tangent> {
        central_tangent(|g| self.first_piola(g, h).map(|(p, _)| p), f)
    }
}

/// `∂P/∂F` of a stress function `p` at `f` by central differences (step 1e-6).
pub fn central_tangent(p: impl Fn(&Mat2) -> Option<Mat2>, f: &Mat2) -> Option<Tangent> {
    const STEP: Real = 1e-6;
    let mut a = [[0.0; 4]; 4];
    for ce in 0..4 {
        let (c, e) = (ce / 2, ce % 2);
        let mut plus = *f;
        plus[(c, e)] += STEP;
        let mut minus = *f;
        minus[(c, e)] -= STEP;
        let d = (p(&plus)? - p(&minus)?) / (2.0 * STEP);
        for (ab, row) in a.iter_mut().enumerate() {
            row[ce] = d[(ab / 2, ab % 2)];
        }
    }
    Some(a)
}

impl LawSpec {
    /// Young's modulus (Pa) and Poisson's ratio of the law at small strain.
    pub fn young_poisson(&self) -> (Real, Real) {
        match *self {
            Self::LinearElastic { young, poisson } | Self::Elastoplastic { young, poisson, .. } => (young, poisson),
            Self::NeoHookean { shear_modulus: mu, lambda } => {
                (mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu), lambda / (2.0 * (lambda + mu)))
            }
        }
    }
}

/// The laws a scene can name, with their parameters (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LawSpec {
    /// [`linear_elastic::LinearElastic`].
    LinearElastic {
        /// Young's modulus, Pa.
        young: Real,
        /// Poisson's ratio.
        poisson: Real,
    },
    /// [`neo_hookean::NeoHookean`].
    NeoHookean {
        /// Shear modulus `μ`, Pa.
        shear_modulus: Real,
        /// First Lamé constant `λ`, Pa.
        lambda: Real,
    },
    /// [`elastoplastic::Elastoplastic`].
    Elastoplastic {
        /// Young's modulus, Pa.
        young: Real,
        /// Poisson's ratio.
        poisson: Real,
        /// Initial yield stress `σ_y`, Pa.
        yield_stress: Real,
        /// Linear isotropic hardening modulus `H`, Pa.
        hardening: Real,
    },
}

/// The registry: the law a spec names.
pub fn build(spec: &LawSpec) -> Box<dyn ConstitutiveLaw> {
    match *spec {
        LawSpec::LinearElastic { young, poisson } => Box::new(linear_elastic::LinearElastic::new(young, poisson)),
        LawSpec::NeoHookean { shear_modulus, lambda } => Box::new(neo_hookean::NeoHookean { mu: shear_modulus, lambda }),
        LawSpec::Elastoplastic { young, poisson, yield_stress, hardening } => {
            Box::new(elastoplastic::Elastoplastic::new(young, poisson, yield_stress, hardening))
        }
    }
}

/// The logarithmic (Hencky) strain `½ ln b` of a symmetric positive-definite plane tensor `b`
/// (its in-plane block through [`Spectral`], `zz` directly), with the decomposition used;
/// `None` unless every eigenvalue is positive.
pub(crate) fn log_strain(b: &PlaneSym) -> Option<(Spectral, [Real; 3])> {
    let e = b.spectral();
    if !(e.l2 > 0.0 && b.zz > 0.0) {
        return None;
    }
    Some((e, [0.5 * e.l1.ln(), 0.5 * e.l2.ln(), 0.5 * b.zz.ln()]))
}

/// Hooke's law on principal strains: `τ_A = λ tr ε + 2μ ε_A`, Pa.
pub(crate) fn hooke(m: &Lame, eps: &[Real; 3]) -> [Real; 3] {
    let tr = eps[0] + eps[1] + eps[2];
    [m.lambda * tr + 2.0 * m.mu * eps[0], m.lambda * tr + 2.0 * m.mu * eps[1], m.lambda * tr + 2.0 * m.mu * eps[2]]
}

/// Hooke's energy on principal strains, `λ/2 (tr ε)² + μ ε:ε`, J/m³.
pub(crate) fn hooke_energy(m: &Lame, eps: &[Real; 3]) -> Real {
    let tr = eps[0] + eps[1] + eps[2];
    0.5 * m.lambda * tr * tr + m.mu * (eps[0] * eps[0] + eps[1] * eps[1] + eps[2] * eps[2])
}

/// The plane tensor with in-plane principal directions `e` and principal values `v`
/// (`v[2]` on `zz`).
pub(crate) fn principal(e: &Spectral, v: &[Real; 3]) -> PlaneSym {
    PlaneSym::from_in_plane(&e.compose(v[0], v[1]), v[2])
}

#[cfg(test)]
mod tests;
