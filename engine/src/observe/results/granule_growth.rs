//! A wet granule growing in a rotating drum ([`GranuleGrowth`]): the grains the followed
//! cluster ([`crate::observe::cluster`]) gains (accretion `N⁺`) and loses (erosion `N⁻`) against
//! the drum's revolutions `N_r`, and the rates of the law Vo, Mutabaruka, Nezamabadi, Delenne &
//! Radjai found for them ("Combined effects of particle size ratio and friction on granule
//! growth in a rotating drum", European Physical Journal E 42:127, 2019; Nezamabadi 2020,
//! §3.2.1, eqs. 3.4–3.5):
//!
//! - erosion linear in the revolutions, `N⁻ = k⁻ N_r`;
//! - accretion `N⁺ = [N_w (1 − k⁻/k⁺) − N_g0] (1 − exp(−k⁺ N_r / N_w)) + k⁻ N_r`, with `N_w`
//!   the wet grains and `N_g0` the granule's grains at the start of the rotation: the granule
//!   captures the free wet grains at a rate `k⁺` times their fraction, `N_w − N_g` of `N_w`,
//!   while it loses `k⁻` a revolution, so that its size `N_g = N_g0 + N⁺ − N⁻` tends to
//!   `N_w (1 − k⁻/k⁺)`.
//!
//! `k⁻` is the least-squares slope of `N⁻` through the origin; `k⁺` is fitted to `N⁺` with that
//! `k⁻` by least squares (Levenberg–Marquardt on `ln k⁺`). Both carry their standard errors.

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::observe::least_squares::minimise;
use crate::observe::sample::Sample;

/// The granule's growth over the drum's rotation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct GranuleGrowth {
    /// Wet grains, `N_w`.
    pub wet: u64,
    /// Grains of the granule at the start of the rotation, `N_g0`.
    pub initial: u64,
    /// Grains of the granule at the end.
    pub final_count: u64,
    /// Revolutions of the drum at the end, `N_r`.
    pub revolutions: f64,
    /// Grains accreted over the rotation, `N⁺` at the end.
    pub accreted: u64,
    /// Grains eroded over the rotation, `N⁻` at the end.
    pub eroded: u64,
    /// Largest over smallest grain diameter of the scene, `α = d_max / d_min`.
    pub size_ratio: f64,
    /// Friction coefficient of the wet grains' material.
    pub friction: f64,
    /// Erosion rate `k⁻`, grains per revolution.
    pub erosion_rate: f64,
    /// Its standard error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub erosion_rate_error: Option<f64>,
    /// Accretion rate `k⁺`, grains per revolution: 0 when no grain was accreted (the law's
    /// `N⁺` vanishes as `k⁺ → 0` whatever `k⁻`); absent when no wet grain was free.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accretion_rate: Option<f64>,
    /// Its standard error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accretion_rate_error: Option<f64>,
    /// The rotation's samples: `[N_r, N⁺, N⁻]`.
    pub history: Vec<[f64; 3]>,
}

/// The accretion law's `N⁺` after `n_r` revolutions (module documentation); 0 at `k⁺ = 0`, its
/// limit whatever `k⁻`.
pub fn accretion(n_r: Real, k_plus: Real, k_minus: Real, wet: Real, initial: Real) -> Real {
    if k_plus <= 0.0 {
        return 0.0;
    }
    (wet * (1.0 - k_minus / k_plus) - initial) * (1.0 - (-k_plus * n_r / wet).exp()) + k_minus * n_r
}

/// The granule's growth from the rotation's samples at `angular_velocity` (rad/s), with the
/// scene's size ratio and the wet grains' friction; `None` without three samples carrying a
/// followed cluster.
pub(super) fn granule_growth(rotation: &[&Sample], angular_velocity: Real, size_ratio: Real, friction: Real) -> Option<GranuleGrowth> {
    let series: Vec<(Real, &crate::observe::cluster::ClusterSample)> =
        rotation.iter().filter_map(|s| s.cluster.as_deref().map(|c| (s.time, c))).collect();
    let (&(t0, first), &(_, last)) = (series.first()?, series.last()?);
    if series.len() < 3 || angular_velocity == 0.0 {
        return None;
    }
    let turns = |t: Real| angular_velocity.abs() * (t - t0) / (2.0 * std::f64::consts::PI);
    let history: Vec<[f64; 3]> = series
        .iter()
        .map(|(t, c)| [turns(*t), c.accreted.saturating_sub(first.accreted) as Real, c.eroded.saturating_sub(first.eroded) as Real])
        .collect();
    let (wet, initial) = (first.wet as Real, first.count as Real);
    let (erosion_rate, erosion_rate_error) = slope_through_origin(&history.iter().map(|h| (h[0], h[2])).collect::<Vec<_>>());
    let (accretion_rate, accretion_rate_error) = match fit_accretion(&history, erosion_rate, wet, initial) {
        Some((k, e)) => (Some(k), e),
        None => (None, None),
    };
    Some(GranuleGrowth {
        wet: first.wet,
        initial: first.count,
        final_count: last.count,
        revolutions: history.last().map_or(0.0, |h| h[0]),
        accreted: last.accreted.saturating_sub(first.accreted),
        eroded: last.eroded.saturating_sub(first.eroded),
        size_ratio,
        friction,
        erosion_rate,
        erosion_rate_error,
        accretion_rate,
        accretion_rate_error,
        history,
    })
}

/// The least-squares slope of `y = k x` and its standard error (none with fewer than two
/// points or all `x` zero).
fn slope_through_origin(points: &[(Real, Real)]) -> (Real, Option<Real>) {
    let sxx: Real = points.iter().map(|p| p.0 * p.0).sum();
    if sxx <= 0.0 {
        return (0.0, None);
    }
    let k = points.iter().map(|p| p.0 * p.1).sum::<Real>() / sxx;
    let error = (points.len() >= 2).then(|| {
        let squares: Real = points.iter().map(|p| (p.1 - k * p.0).powi(2)).sum();
        (squares / (points.len() - 1) as Real / sxx).sqrt()
    });
    (k, error)
}

/// `k⁺` and its standard error fitted to the history's accretion with erosion rate `k_minus`:
/// 0 (no error) when nothing was accreted, `None` when no wet grain was free.
fn fit_accretion(history: &[[f64; 3]], k_minus: Real, wet: Real, initial: Real) -> Option<(Real, Option<Real>)> {
    let &[n_end, a_end, _] = history.last()?;
    if wet <= initial || n_end <= 0.0 {
        return None;
    }
    if history.iter().all(|h| h[1] <= 0.0) {
        return Some((0.0, None));
    }
    let residuals = |q: &[f64], r: &mut Vec<f64>| {
        r.clear();
        let k = q[0].exp();
        r.extend(history.iter().map(|h| accretion(h[0], k, k_minus, wet, initial) - h[1]));
    };
    // Starts: the mean accretion rate over the run, over the free wet grains' fraction, and
    // ten times above and below it (the law saturates: the slope alone may be far off).
    let guess = (a_end / n_end * wet / (wet - initial)).max(k_minus.abs() + 1e-9).max(1e-9);
    let best = [guess, 10.0 * guess, 0.1 * guess]
        .iter()
        .filter_map(|k| minimise(&[k.ln()], &residuals))
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    let k = best.params[0].exp();
    k.is_finite().then(|| (k, best.std_errors[0].map(|e| e * k)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::cluster::ClusterSample;

    fn sample(time: Real, count: u64, accreted: u64, eroded: u64) -> Sample {
        Sample {
            time,
            cluster: Some(Box::new(ClusterSample {
                wet: 200,
                count,
                bridges: count,
                outside: 200 - count,
                clusters: 1,
                largest: count,
                accreted,
                eroded,
                axes: vec![1e-3, 1e-3],
                elongation: 0.0,
            })),
            ..Sample::default()
        }
    }

    /// The law's own accretion and a linear erosion, sampled each tenth of a revolution (in
    /// whole grains, as counted), give back `k⁺ = 60` and `k⁻ = 3` per revolution within the
    /// rounding; the counts before the rotation are left out.
    #[test]
    fn the_rates_of_a_growth_following_the_law_come_back() {
        let (w, period) = (2.0 * std::f64::consts::PI, 1.0);
        let (k_plus, k_minus, wet, initial) = (60.0, 3.0, 200.0, 50.0);
        // Before the rotation the granule already gained 7 and lost 2.
        let mut samples = Vec::new();
        for k in 0..=80 {
            let n_r = 0.1 * k as Real;
            let plus = accretion(n_r, k_plus, k_minus, wet, initial).round() as u64;
            let minus = (k_minus * n_r).round() as u64;
            samples.push(sample(10.0 + n_r * period, 50 + plus - minus, 7 + plus, 2 + minus));
        }
        let refs: Vec<&Sample> = samples.iter().collect();
        let g = granule_growth(&refs, w, 5.0, 0.5).expect("a growth");
        assert_eq!((g.wet, g.initial, g.history.len()), (200, 50, 81));
        assert!((g.revolutions - 8.0).abs() < 1e-9);
        assert!((g.erosion_rate - k_minus).abs() < 0.02, "k- {}", g.erosion_rate);
        let k = g.accretion_rate.expect("k+");
        assert!((k - k_plus).abs() < 0.02 * k_plus, "k+ {k}");
        let e = g.accretion_rate_error.expect("its error");
        assert!(e > 0.0 && e < 0.02 * k_plus, "error {e}");
        assert_eq!(g.final_count, 50 + g.accreted - g.eroded);
        assert_eq!((g.size_ratio, g.friction), (5.0, 0.5));
    }

    /// A granule that neither gains nor loses has both rates 0; without a free wet grain there
    /// is no accretion rate.
    #[test]
    fn a_granule_at_rest_has_no_rates() {
        let samples: Vec<Sample> = (0..10).map(|k| sample(0.1 * k as Real, 50, 3, 1)).collect();
        let refs: Vec<&Sample> = samples.iter().collect();
        let g = granule_growth(&refs, 1.0, 1.0, 0.3).expect("a growth");
        assert_eq!((g.accreted, g.eroded, g.accretion_rate, g.accretion_rate_error), (0, 0, Some(0.0), None));
        assert_eq!(g.erosion_rate, 0.0);
        // The law at k+ = 0 is its limit, not 0/0.
        assert_eq!(accretion(3.0, 0.0, 2.0, 200.0, 50.0), 0.0);
        assert!((accretion(3.0, 1e-9, 2.0, 200.0, 50.0)).abs() < 1e-6);
        let all_wet: Vec<Sample> = (0..10).map(|k| sample(0.1 * k as Real, 200, 0, 0)).collect();
        let refs: Vec<&Sample> = all_wet.iter().collect();
        assert_eq!(granule_growth(&refs, 1.0, 1.0, 0.3).expect("a growth").accretion_rate, None);
        assert!(granule_growth(&refs[..2], 1.0, 1.0, 0.3).is_none());
    }
}
