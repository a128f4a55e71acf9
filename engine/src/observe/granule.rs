//! The result of a diametral compression of a wet granule (Nezamabadi 2020, §3.2.3): its
//! stress-strain curve, plastic strength and the prefactor of the strength's prediction
//! (Nezamabadi 2020, eq. 3.11; docs/physics.md §8).

use serde::{Deserialize, Serialize};

use super::sample::Sample;
use crate::math::Real;
use crate::particles::Particles;

/// Diametral compression of a wet granule (Nezamabadi 2020, §3.2.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct GranuleResult {
    /// Radius of the granule when the plates close on it (half their gap), m.
    pub radius: f64,
    /// Its packing fraction: the grains' solid volume over the ball (disk) of that radius.
    pub phi: f64,
    /// Coordination when the compression starts: force-bearing contacts and capillary bonds
    /// per grain (`2 N_c / N`).
    pub z: f64,
    /// Polydispersity factor `s = <d^1/2> <d> <d^3/2> / <d^3>` (Nezamabadi 2020, eq. 3.12; 1 for
    /// equal grains).
    pub s: f64,
    /// Capillary stress `σ_c = f_c / <d>^(D-1)`, `f_c = 2π γ cos θ <d>/2`, Pa.
    pub capillary_stress: f64,
    /// Stress-strain curve, per sample of the compression: `[strain, σ_zz, plate stress]`.
    /// σ_zz (Pa) is the granule's vertical stress: the Love-Weber stress of its contacts and
    /// bridges along the axis over the granule's volume (that of the ball of radius `radius`);
    /// the plate stress (Pa) is the plates' force over the granule's cross-section (`π R²` in
    /// 3D, `2R` per metre in 2D), which grows as the granule flattens against them.
    pub curve: Vec<[f64; 3]>,
    /// Largest σ_zz, Pa.
    pub peak_stress: f64,
    /// Strain of the largest σ_zz.
    pub peak_strain: f64,
    /// Plastic strength σ_p: the mean σ_zz over the plateau window, Pa (Nezamabadi 2020, §3.2.3
    /// and Fig. 3.12: "résistance verticale σ_zz"); `None` if no sample fell in the window.
    pub plastic_strength: Option<f64>,
    /// Standard deviation of the stress over the window, Pa (`None` without a sample in it).
    pub plastic_strength_std: Option<f64>,
    /// `σ_p / σ_c` (`None` without σ_p or capillary stress).
    pub normalized_strength: Option<f64>,
    /// Prefactor of Nezamabadi 2020, eq. 3.11, `η = 2π σ_p / (s Z Φ σ_c)` (`None` without σ_p or
    /// capillary stress).
    pub eta: Option<f64>,
    /// Size ratio `α = d_max / d_min` of the grains (0 in results stored before 2026-12-07).
    #[serde(default)]
    pub size_ratio: f64,
    /// Largest grain diameter `d_max`, m (0 in results stored before 2026-12-07).
    #[serde(default)]
    pub largest_diameter: f64,
    /// Rupture distance of the bridges `d_rupt`, m (docs/physics.md §2.8; `None` for results stored
    /// before 2026-12-07).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rupture_distance: Option<f64>,
}

/// The grains and the liquid of a granule, for its result.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct GranuleGrains {
    /// Their solid volume, m³ (m² in 2D).
    pub(crate) solid: Real,
    /// Polydispersity factor `s`.
    pub(crate) s: Real,
    /// Smallest and largest diameters, m.
    pub(crate) smallest: Real,
    pub(crate) largest: Real,
}

impl GranuleGrains {
    /// Of the diameters `d` in dimension `dim`.
    pub(crate) fn of(dim: usize, d: &[Real]) -> Self {
        let n = d.len().max(1) as Real;
        let m = |k: Real| d.iter().map(|x| x.powf(k)).sum::<Real>() / n;
        let s = if m(3.0) > 0.0 { m(0.5) * m(1.0) * m(1.5) / m(3.0) } else { 0.0 };
        let solid = d.iter().map(|x| Particles::volume_of(dim, 0.5 * x)).sum();
        let smallest = d.iter().copied().fold(Real::INFINITY, Real::min);
        let largest = d.iter().copied().fold(0.0, Real::max);
        GranuleGrains { solid, s, smallest: if smallest.is_finite() { smallest } else { 0.0 }, largest }
    }
}

/// The stress-strain curve of a granule compression and what it gives.
#[allow(clippy::too_many_arguments)]
pub(crate) fn granule_result(
    run: &[&Sample],
    relaxed: Option<&Sample>,
    axis: usize,
    plateau: (Real, Real),
    dim: usize,
    grains: GranuleGrains,
    sigma_c: Real,
    rupture_distance: Option<Real>,
) -> Option<GranuleResult> {
    let GranuleGrains { solid, s, smallest, largest } = grains;
    let first = run.first()?;
    let name = |upper: bool| format!("{}_{}", crate::math::AXES[axis], if upper { "max" } else { "min" });
    let wall = |x: &Sample, upper: bool| x.walls.iter().find(|w| w.name == name(upper)).cloned();
    let (lo, hi) = (wall(first, false)?, wall(first, true)?);
    let radius = 0.5 * (hi.position - lo.position);
    if radius <= 0.0 {
        return None;
    }
    let section = if dim == 3 { std::f64::consts::PI * radius * radius } else { 2.0 * radius };
    let phi = solid / Particles::volume_of(dim, radius);
    let curve: Vec<[f64; 3]> = run
        .iter()
        .filter_map(|x| {
            let (lo, hi) = (wall(x, false)?, wall(x, true)?);
            // The plates' mean compressive force along the axis.
            let force = 0.5 * (hi.force.get(axis).copied().unwrap_or(0.0) - lo.force.get(axis).copied().unwrap_or(0.0));
            let strain = x.strain.as_ref().and_then(|e| e.axes.get(axis).copied()).unwrap_or(0.0);
            // The box's stress is the granule's sum over the box volume (solid / Φ_box): over
            // the granule's, it is Φ_granule / Φ_box times larger.
            let s = &x.stress;
            let along = match axis {
                0 => s.xx,
                1 => s.yy,
                _ => s.zz.unwrap_or(0.0),
            };
            let sigma = if x.phi > 0.0 { along * phi / x.phi } else { 0.0 };
            Some([strain, sigma, force / section])
        })
        .collect();
    let (peak_strain, peak_stress) = curve.iter().fold((0.0, Real::NEG_INFINITY), |a, p| if p[1] > a.1 { (p[0], p[1]) } else { a });
    let window: Vec<Real> = curve.iter().filter(|p| p[0] >= plateau.0 && p[0] <= plateau.1).map(|p| p[1]).collect();
    let n = window.len() as Real;
    let plastic_strength = (!window.is_empty()).then(|| window.iter().sum::<Real>() / n);
    let plastic_strength_std = plastic_strength.map(|p| (window.iter().map(|x| (x - p).powi(2)).sum::<Real>() / n).sqrt());
    let z = relaxed.map_or(first.z, |x| x.z);
    let denominator = s * z * phi * sigma_c;
    Some(GranuleResult {
        radius,
        phi,
        z,
        s,
        capillary_stress: sigma_c,
        peak_stress: peak_stress.max(0.0),
        peak_strain,
        plastic_strength,
        plastic_strength_std,
        normalized_strength: plastic_strength.filter(|_| sigma_c > 0.0).map(|p| p / sigma_c),
        eta: plastic_strength.filter(|_| denominator > 0.0).map(|p| 2.0 * std::f64::consts::PI * p / denominator),
        curve,
        size_ratio: if smallest > 0.0 { largest / smallest } else { 0.0 },
        largest_diameter: largest,
        rupture_distance,
    })
}
