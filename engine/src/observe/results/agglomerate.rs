//! An agglomerate in a shear flow ([`AgglomerateResult`]): how the wet grains' cluster
//! ([`crate::observe::cluster`]) elongates, loses bridges (damage) and loses grains (erosion)
//! per unit of shear strain, the rates `K/γ̇` whose dependence on the inertial number and the
//! cohesion index Vo et al. studied (Physical Review E 101, 2020; docs/physics.md §8).
//!
//! Each rate is the least-squares slope over the shear stage: of the elongation, of the damage
//! `1 − N_b / N_b(0)` (the fraction of the first sample's bridges lost) and of the erosion
//! `(N_out − N_out(0)) / N(0)` (the grains the cluster lost, over those it held), against the
//! shear strain `γ̇ (t − t_0)`. They are Sable's own reductions of the cluster's series; the
//! published rates' exact definitions were not checked against them.

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::observe::sample::Sample;

/// The agglomerate's evolution over the shear stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct AgglomerateResult {
    /// Samples of the shear stage with a cluster.
    pub samples: usize,
    /// Shear strain between the first and the last of them.
    pub strain: f64,
    /// Grains, bridges and elongation of the cluster at the first sample.
    pub initial_count: u64,
    /// Bridges at the first sample.
    pub initial_bridges: u64,
    /// Elongation at the first sample.
    pub initial_elongation: f64,
    /// Grains of the cluster at the last sample.
    pub final_count: u64,
    /// Bridges at the last sample.
    pub final_bridges: u64,
    /// Elongation at the last sample.
    pub final_elongation: f64,
    /// Damage at the last sample, `1 − N_b / N_b(0)`.
    pub damage: f64,
    /// Erosion at the last sample, `(N_out − N_out(0)) / N(0)`.
    pub erosion: f64,
    /// Elongation per unit strain, `K_g / γ̇`.
    pub elongation_rate: f64,
    /// Damage per unit strain, `K_b / γ̇`.
    pub damage_rate: f64,
    /// Erosion per unit strain, `K_e / γ̇`.
    pub erosion_rate: f64,
}

/// The agglomerate's evolution from the shear stage's samples at shear rate `rate` (1/s); `None`
/// without three samples carrying a cluster (a slope and its scatter need three).
pub(super) fn agglomerate_result(shear: &[&Sample], rate: Real) -> Option<AgglomerateResult> {
    let series: Vec<(Real, &crate::observe::cluster::ClusterSample)> =
        shear.iter().filter_map(|s| s.cluster.as_deref().map(|c| (s.time, c))).collect();
    let (&(t0, first), &(t1, last)) = (series.first()?, series.last()?);
    if series.len() < 3 || t1 <= t0 {
        return None;
    }
    let strain = |t: Real| rate * (t - t0);
    let damage = |b: u64| if first.bridges > 0 { 1.0 - b as Real / first.bridges as Real } else { 0.0 };
    let erosion = |out: u64| if first.count > 0 { (out as Real - first.outside as Real) / first.count as Real } else { 0.0 };
    let slope = |f: &dyn Fn(&crate::observe::cluster::ClusterSample) -> Real| {
        let pts: Vec<(Real, Real)> = series.iter().map(|(t, c)| (strain(*t), f(c))).collect();
        crate::observe::power::line_fit(&pts).map_or(0.0, |l| l.slope)
    };
    Some(AgglomerateResult {
        samples: series.len(),
        strain: strain(t1),
        initial_count: first.count,
        initial_bridges: first.bridges,
        initial_elongation: first.elongation,
        final_count: last.count,
        final_bridges: last.bridges,
        final_elongation: last.elongation,
        damage: damage(last.bridges),
        erosion: erosion(last.outside),
        elongation_rate: slope(&|c| c.elongation),
        damage_rate: slope(&|c| damage(c.bridges)),
        erosion_rate: slope(&|c| erosion(c.outside)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observe::cluster::ClusterSample;

    /// A hand-made agglomerate of 40 grains and 100 bridges sheared at 2 1/s for 1 s (strain 2):
    /// it elongates by 0.3 per unit strain and loses 5 bridges and one grain every 0.25 s (every
    /// 0.5 of strain): damage 0.1 and erosion 0.05 per unit strain, 0.2 and 0.1 at the end.
    #[test]
    fn the_rates_are_the_slopes_per_unit_strain() {
        let samples: Vec<Sample> = (0..=4)
            .map(|k| {
                let t = 0.25 * k as f64;
                Sample {
                    time: 10.0 + t,
                    cluster: Some(Box::new(ClusterSample {
                        wet: 42,
                        count: 40 - k,
                        bridges: 100 - 5 * k,
                        outside: 2 + k,
                        clusters: 1,
                        largest: 40 - k,
                        accreted: 0,
                        eroded: k,
                        axes: vec![2e-3, 1e-3],
                        elongation: 0.1 + 0.3 * 2.0 * t,
                    })),
                    ..Default::default()
                }
            })
            .collect();
        let refs: Vec<&Sample> = samples.iter().collect();
        let r = agglomerate_result(&refs, 2.0).expect("an agglomerate");
        assert_eq!((r.samples, r.initial_count, r.final_count, r.initial_bridges, r.final_bridges), (5, 40, 36, 100, 80));
        assert!((r.strain - 2.0).abs() < 1e-12);
        assert!((r.elongation_rate - 0.3).abs() < 1e-12, "{}", r.elongation_rate);
        // 5 of 100 bridges per 0.25 s = per 0.5 strain: 0.1 per unit strain; 1 of 40 grains per
        // 0.5 strain: 0.05.
        assert!((r.damage_rate - 0.1).abs() < 1e-12, "{}", r.damage_rate);
        assert!((r.erosion_rate - 0.05).abs() < 1e-12, "{}", r.erosion_rate);
        assert!((r.damage - 0.2).abs() < 1e-12 && (r.erosion - 0.1).abs() < 1e-12, "{r:?}");
        // Without three samples with a cluster there is no result.
        assert!(agglomerate_result(&refs[..2], 2.0).is_none());
    }
}
