//! Power laws fitted to measured curves: the coordination and the wall stress of a packing
//! compacted beyond jamming against `Φ − Φ_J` (docs/physics.md §8-9; Nezamabadi 2020, eq. 2.20:
//! `Z − Z_J ∝ (Φ − Φ_J)^½` for soft grains; Nezamabadi 2020, §2.1.2: the wall stress as a power of
//! `Φ − Φ_J`).

use serde::{Deserialize, Serialize};

use crate::math::Real;

/// `y = prefactor · x^exponent`, fitted by least squares on `ln y` against `ln x`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PowerFit {
    /// The prefactor, in the unit of `y` over that of `x` to the exponent.
    pub prefactor: f64,
    /// The exponent.
    pub exponent: f64,
    /// Coefficient of determination of the fit of `ln y` (1: every point on the line).
    pub r2: f64,
    /// Points fitted (those with `x > 0` and `y > 0`).
    pub points: usize,
}

/// Fits `y = a x^b` to the pairs with `x > 0` and `y > 0`; `None` with fewer than three such
/// pairs or when their `x` are all equal.
pub fn power_fit(pairs: impl IntoIterator<Item = (Real, Real)>) -> Option<PowerFit> {
    let logs: Vec<(Real, Real)> =
        pairs.into_iter().filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()).map(|(x, y)| (x.ln(), y.ln())).collect();
    let line = line_fit(&logs)?;
    Some(PowerFit { prefactor: line.intercept.exp(), exponent: line.slope, r2: line.r2, points: logs.len() })
}

/// An ordinary least-squares line `y = intercept + slope x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LineFit {
    pub intercept: Real,
    pub slope: Real,
    /// Standard error of the slope.
    pub slope_error: Real,
    /// Standard error of the intercept.
    pub intercept_error: Real,
    /// Coefficient of determination.
    pub r2: Real,
    /// Sum of the squared residuals.
    pub residual: Real,
}

/// Fits a [`LineFit`] to `points`; `None` with fewer than three points or no spread in `x`.
pub(crate) fn line_fit(points: &[(Real, Real)]) -> Option<LineFit> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let nf = n as Real;
    let (mx, my) = points.iter().fold((0.0, 0.0), |(a, b), &(x, y)| (a + x / nf, b + y / nf));
    let (sxx, sxy, syy) = points.iter().fold((0.0, 0.0, 0.0), |(a, b, c), &(x, y)| {
        let (dx, dy) = (x - mx, y - my);
        (a + dx * dx, b + dx * dy, c + dy * dy)
    });
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    // Summed from the residuals themselves: `syy − slope sxy` loses them to cancellation when
    // the points lie on the line.
    let residual: Real = points.iter().map(|&(x, y)| (y - my - slope * (x - mx)).powi(2)).sum();
    let variance = residual / (nf - 2.0);
    Some(LineFit {
        intercept: my - slope * mx,
        slope,
        slope_error: (variance / sxx).sqrt(),
        intercept_error: (variance * (1.0 / nf + mx * mx / sxx)).sqrt(),
        r2: if syy > 0.0 { 1.0 - residual / syy } else { 1.0 },
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exact_power_law_is_recovered() {
        let fit = power_fit((1..=10).map(|k| {
            let x = 0.01 * k as Real;
            (x, 3.0 * x.powf(0.5))
        }))
        .expect("ten points");
        assert!((fit.exponent - 0.5).abs() < 1e-12, "{fit:?}");
        assert!((fit.prefactor - 3.0).abs() < 1e-12, "{fit:?}");
        assert!((fit.r2 - 1.0).abs() < 1e-12);
        assert_eq!(fit.points, 10);
    }

    #[test]
    fn scatter_lowers_r2_and_bad_points_are_skipped() {
        let noisy = [(0.01, 0.3), (0.02, 0.5), (0.04, 0.55), (0.08, 0.9), (0.0, 1.0), (0.1, -1.0)];
        let fit = power_fit(noisy).expect("four usable points");
        assert_eq!(fit.points, 4);
        assert!(fit.r2 < 0.99 && fit.r2 > 0.5, "{fit:?}");
        assert!(power_fit([(0.1, 1.0), (0.1, 2.0), (0.1, 3.0)]).is_none());
        assert!(power_fit([(0.1, 1.0), (0.2, 2.0)]).is_none());
    }
}
