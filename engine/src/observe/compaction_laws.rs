//! The sources' compaction laws fitted to a measured compaction beyond jamming: how the packing
//! fraction `Φ` of soft grains rises with the applied stress `σ` (Pa, compression positive) and
//! the coordination `Z` (docs/physics.md §9; Nezamabadi 2020, §2.1). Each fit is a linear least
//! squares problem in its constants, solved with their standard errors:
//!
//! - [`LinearLawFit`]: `Φ − Φ₀ = α (σ − σ₀)/K` (Nezamabadi 2020, eq. 2.2, with every stress in the
//!   unit `σ₀`), from a uniform strain of grains and pores whose effective bulk modulus grows
//!   as `Φ K` (Voigt), `K` the grains' bulk modulus;
//! - [`NeoHookeanLawFit`]: `σ = M_eff (ln Φ + c₂)/(1 + M_eff/(c₁ K Z Φ))`, `M_eff = Φ M`, `M` the
//!   grains' P-wave modulus (Nezamabadi 2020, eq. 2.9; written there for a compressive stress
//!   counted negative);
//! - [`ExponentialLawFit`]: `1 − Φ = (1 − Φ₀) e^(−r (σ − σ₀))`, the law of plastic grains
//!   (Nezamabadi 2020, eq. 2.19, with `r = α/σ₀`).

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::observe::power::line_fit;

/// One compacted state: packing fraction, coordination, stress (Pa, compression positive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompactedState {
    /// Packing fraction `Φ`.
    pub phi: Real,
    /// Mean coordination `Z`.
    pub z: Real,
    /// Applied stress `σ`, Pa.
    pub stress: Real,
}

/// The grains' moduli the laws are written with, Pa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainModuli {
    /// Bulk modulus `K` (in 2D the plane-strain one, `λ + μ`; in 3D `λ + 2μ/3`), Pa.
    pub bulk: Real,
    /// P-wave modulus `M = λ + 2μ`, Pa.
    pub p_wave: Real,
}

/// `Φ − Φ₀ = α (σ − σ₀)/K` fitted beyond jamming (Nezamabadi 2020, eq. 2.2; the sources find
/// `α ≈ 0.73` for linear-elastic disks).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LinearLawFit {
    /// `α = K dΦ/dσ`, dimensionless.
    pub alpha: f64,
    /// Standard error of `α`.
    pub alpha_error: f64,
    /// The slope `dΦ/dσ`, 1/Pa.
    pub slope: f64,
    /// Coefficient of determination of `Φ`.
    pub r2: f64,
    /// States fitted.
    pub points: usize,
}

/// `σ = M_eff (ln Φ + c₂)/(1 + M_eff/(c₁ K Z Φ))` fitted beyond jamming (Nezamabadi 2020, eq. 2.9;
/// the sources find `c₂ ≈ 0.27` and `c₁ ≈ 0.01, 0.23, 1.3` for neo-Hookean disks with
/// `λ = 100, 3, 0` MPa).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct NeoHookeanLawFit {
    /// `c₁`, the share of the grains' stress the packing carries per contact, dimensionless.
    pub c1: f64,
    /// Standard error of `c₁`.
    pub c1_error: f64,
    /// `c₂`, the constant of integration: the law's stress vanishes at `Φ = e^(−c₂)`.
    pub c2: f64,
    /// Standard error of `c₂`.
    pub c2_error: f64,
    /// Coefficient of determination of the stress the fitted law gives.
    pub r2: f64,
    /// States fitted.
    pub points: usize,
}

/// `1 − Φ = (1 − Φ₀) e^(−r (σ − σ₀))` fitted beyond jamming (Nezamabadi 2020, eq. 2.19: `r =
/// α/σ₀`, `α ≈ 0.27` for aggregates of primaries up to `Φ ≈ 0.98`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExponentialLawFit {
    /// The rate `r = −d ln(1 − Φ)/dσ`, 1/Pa.
    pub rate: f64,
    /// Standard error of `r`, 1/Pa.
    pub rate_error: f64,
    /// Coefficient of determination of `ln(1 − Φ)`.
    pub r2: f64,
    /// States fitted.
    pub points: usize,
}

fn usable(states: &[CompactedState]) -> impl Iterator<Item = &CompactedState> {
    states.iter().filter(|s| s.phi > 0.0 && s.phi < 1.0 && s.stress > 0.0 && s.phi.is_finite() && s.stress.is_finite())
}

/// Fits [`LinearLawFit`] to `states`.
pub fn linear_law(states: &[CompactedState], moduli: GrainModuli) -> Option<LinearLawFit> {
    let pts: Vec<(Real, Real)> = usable(states).map(|s| (s.stress, s.phi)).collect();
    let l = line_fit(&pts)?;
    Some(LinearLawFit {
        alpha: moduli.bulk * l.slope,
        alpha_error: moduli.bulk * l.slope_error,
        slope: l.slope,
        r2: l.r2,
        points: pts.len(),
    })
}

/// Fits [`ExponentialLawFit`] to `states`.
pub fn exponential_law(states: &[CompactedState]) -> Option<ExponentialLawFit> {
    let pts: Vec<(Real, Real)> = usable(states).map(|s| (s.stress, (1.0 - s.phi).ln())).collect();
    let l = line_fit(&pts)?;
    Some(ExponentialLawFit { rate: -l.slope, rate_error: l.slope_error, r2: l.r2, points: pts.len() })
}

/// Fits [`NeoHookeanLawFit`] to `states`. Multiplied out, the law is a line in `x = σ/(K Z Φ)`:
/// `ln Φ − σ/M_eff = a x − c₂` with `a = 1/c₁`, fitted by least squares ([`line_fit`]); `None`
/// with fewer than three states of positive `Z`, no spread in `x` or `a ≤ 0` (no positive `c₁`
/// fits).
pub fn neo_hookean_law(states: &[CompactedState], moduli: GrainModuli) -> Option<NeoHookeanLawFit> {
    if moduli.bulk <= 0.0 || moduli.p_wave <= 0.0 {
        return None;
    }
    let used: Vec<CompactedState> = usable(states).filter(|s| s.z > 0.0).copied().collect();
    let rows: Vec<(Real, Real)> =
        used.iter().map(|s| (s.stress / (moduli.bulk * s.z * s.phi), s.phi.ln() - s.stress / (s.phi * moduli.p_wave))).collect();
    let line = line_fit(&rows)?;
    let (a, c2) = (line.slope, -line.intercept);
    if a <= 0.0 || !a.is_finite() || !c2.is_finite() {
        return None;
    }
    let predicted = |s: &CompactedState| {
        let m_eff = s.phi * moduli.p_wave;
        m_eff * (s.phi.ln() + c2) / (1.0 + m_eff * a / (moduli.bulk * s.z * s.phi))
    };
    let n = used.len() as Real;
    let mean = used.iter().map(|s| s.stress).sum::<Real>() / n;
    let (res, tot) = used.iter().fold((0.0, 0.0), |(r, t), s| (r + (s.stress - predicted(s)).powi(2), t + (s.stress - mean).powi(2)));
    Some(NeoHookeanLawFit {
        c1: 1.0 / a,
        c1_error: line.slope_error / (a * a),
        c2,
        c2_error: line.intercept_error,
        r2: if tot > 0.0 { 1.0 - res / tot } else { 1.0 },
        points: used.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODULI: GrainModuli = GrainModuli { bulk: 3.0e6, p_wave: 6.0e6 };

    /// States on the neo-Hookean law with `c₁ = 0.23`, `c₂ = 0.27` and `Z = 4 + 8 (Φ − 0.8)^½`.
    fn on_the_law(c1: Real, c2: Real) -> Vec<CompactedState> {
        (1..=30)
            .map(|k| {
                let phi = 0.77 + 0.006 * k as Real;
                let z = 4.0 + 8.0 * (phi - 0.77).sqrt();
                let m_eff = phi * MODULI.p_wave;
                let stress = m_eff * (phi.ln() + c2) / (1.0 + m_eff / (c1 * MODULI.bulk * z * phi));
                CompactedState { phi, z, stress }
            })
            .collect()
    }

    #[test]
    fn the_neo_hookean_law_returns_its_constants() {
        for (c1, c2) in [(0.23, 0.27), (1.3, 0.27), (0.01, 0.3)] {
            let fit = neo_hookean_law(&on_the_law(c1, c2), MODULI).expect("a fit");
            assert!((fit.c1 / c1 - 1.0).abs() < 1e-9 && (fit.c2 - c2).abs() < 1e-9, "{c1} {c2}: {fit:?}");
            assert!(fit.c1_error < 1e-9 * c1 && fit.c2_error < 1e-9 && (fit.r2 - 1.0).abs() < 1e-9, "{fit:?}");
            assert_eq!(fit.points, 30);
        }
    }

    #[test]
    fn scatter_gives_the_neo_hookean_constants_an_error_that_covers_them() {
        let mut states = on_the_law(0.23, 0.27);
        for (k, s) in states.iter_mut().enumerate() {
            s.stress *= 1.0 + if k % 2 == 0 { 0.03 } else { -0.03 };
        }
        let fit = neo_hookean_law(&states, MODULI).expect("a fit");
        assert!(fit.c1_error > 0.0 && fit.c2_error > 0.0 && fit.r2 < 1.0 && fit.r2 > 0.9, "{fit:?}");
        assert!((fit.c1 - 0.23).abs() < 4.0 * fit.c1_error + 0.02, "{fit:?}");
        assert!((fit.c2 - 0.27).abs() < 4.0 * fit.c2_error + 0.005, "{fit:?}");
    }

    #[test]
    fn the_linear_and_exponential_laws_return_their_constants() {
        let linear: Vec<CompactedState> = (0..20)
            .map(|k| CompactedState { phi: 0.8 + 0.73 * 1e4 * k as Real / MODULI.bulk, z: 4.0, stress: 1e4 * k as Real + 1.0 })
            .collect();
        let fit = linear_law(&linear, MODULI).expect("a fit");
        assert!((fit.alpha - 0.73).abs() < 1e-9 && fit.alpha_error < 1e-9 && fit.points == 20, "{fit:?}");
        let exponential: Vec<CompactedState> =
            (1..20).map(|k| CompactedState { phi: 1.0 - 0.2 * (-2e-6 * 1e5 * k as Real).exp(), z: 4.0, stress: 1e5 * k as Real }).collect();
        let fit = exponential_law(&exponential).expect("a fit");
        assert!((fit.rate / 2e-6 - 1.0).abs() < 1e-9 && fit.points == 19, "{fit:?}");
    }

    #[test]
    fn too_few_or_unusable_states_give_no_fit() {
        let two = &on_the_law(0.23, 0.27)[..2];
        assert!(neo_hookean_law(two, MODULI).is_none() && linear_law(two, MODULI).is_none() && exponential_law(two).is_none());
        let unloaded: Vec<CompactedState> = (0..5).map(|k| CompactedState { phi: 0.8 + 0.01 * k as Real, z: 4.0, stress: 0.0 }).collect();
        assert!(neo_hookean_law(&unloaded, MODULI).is_none() && linear_law(&unloaded, MODULI).is_none());
    }
}
