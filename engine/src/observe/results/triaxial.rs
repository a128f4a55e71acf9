//! The biaxial and triaxial tests' results: the peak of ζ, the steady (critical) state over the
//! last quarter of the axial strain, and the volume change.

use serde::{Deserialize, Serialize};

use super::{ExperimentResult, STEADY_WINDOW};
use crate::math::Real;
use crate::observe::grains::GrainSample;
use crate::observe::sample::Sample;

/// The peak of the stress ratio in a biaxial or triaxial test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Peak {
    /// Largest `ζ = q/p`.
    pub zeta: f64,
    /// Axial strain at the peak.
    pub axial_strain: f64,
    /// Volumetric strain at the peak (compression positive).
    pub volumetric_strain: f64,
    /// Packing fraction at the peak.
    pub phi: f64,
    /// The grains' own measures at the peak, for aggregates of primaries and deformable
    /// grains.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<GrainSample>,
}

/// The steady (critical) state: means over the last quarter of the axial strain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Steady {
    /// Axial strain where the averaging window starts.
    pub from_axial_strain: f64,
    /// Samples in the window.
    pub samples: usize,
    /// Mean `ζ`.
    pub zeta: f64,
    /// Standard deviation of `ζ` over the window.
    pub zeta_std: f64,
    /// Mean packing fraction.
    pub phi: f64,
    /// Mean coordination without rattlers.
    pub z_no_rattlers: f64,
    /// Dilatancy rate `-d eps_v / d eps_a` over the window (least squares; 0 at a critical state).
    pub dilatancy_rate: f64,
    /// The grains' own measures averaged over the window, for aggregates of primaries and
    /// deformable grains: the steady Φ, Z, pressure and shape of the grains
    /// (`max_aspect_ratio` the mean of each sample's largest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<GrainSample>,
}

/// Volume change along a biaxial or triaxial test (compression positive).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Dilatancy {
    /// Largest volumetric strain (the most contracted state).
    pub max_contraction: f64,
    /// Axial strain there.
    pub at_axial_strain: f64,
    /// Volumetric strain at the end; below `max_contraction` when the sample dilated.
    pub final_volumetric_strain: f64,
}

pub(super) fn triaxial_results(r: &mut ExperimentResult, loading: &[(Real, &Sample)]) {
    let Some(&(end, _)) = loading.last() else { return };
    let ev = |s: &Sample| s.strain.as_ref().map_or(0.0, |e| e.volumetric);
    if let Some(&(ea, s)) = loading.iter().filter(|(ea, _)| *ea > 0.0).max_by(|a, b| a.1.zeta.total_cmp(&b.1.zeta)) {
        r.peak = Some(Peak { zeta: s.zeta, axial_strain: ea, volumetric_strain: ev(s), phi: s.phi, grains: s.grains.as_deref().copied() });
    }
    if let Some(&(ea, s)) = loading.iter().max_by(|a, b| ev(a.1).total_cmp(&ev(b.1))) {
        r.dilatancy =
            Some(Dilatancy { max_contraction: ev(s), at_axial_strain: ea, final_volumetric_strain: ev(loading[loading.len() - 1].1) });
    }
    let from = (1.0 - STEADY_WINDOW) * end;
    let window: Vec<&(Real, &Sample)> = loading.iter().filter(|(ea, _)| *ea >= from).collect();
    if window.len() >= 2 {
        let n = window.len() as Real;
        let mean = |f: &dyn Fn(&Sample) -> Real| window.iter().map(|(_, s)| f(s)).sum::<Real>() / n;
        let zeta = mean(&|s| s.zeta);
        let zeta_std = (window.iter().map(|(_, s)| (s.zeta - zeta).powi(2)).sum::<Real>() / n).sqrt();
        // Least-squares slope of eps_v against eps_a.
        let xa = window.iter().map(|(ea, _)| ea).sum::<Real>() / n;
        let ya = mean(&ev);
        let sxy: Real = window.iter().map(|(ea, s)| (ea - xa) * (ev(s) - ya)).sum();
        let sxx: Real = window.iter().map(|(ea, _)| (ea - xa).powi(2)).sum();
        r.steady = Some(Steady {
            from_axial_strain: from,
            samples: window.len(),
            zeta,
            zeta_std,
            phi: mean(&|s| s.phi),
            z_no_rattlers: mean(&|s| s.z_no_rattlers),
            dilatancy_rate: if sxx > 0.0 { -sxy / sxx } else { 0.0 },
            grains: mean_grains(window.iter().map(|(_, s)| s.grains.as_deref())),
        });
    }
}

/// The mean of the grains' measures over samples that all carry them (`None` if one does not).
fn mean_grains<'a>(samples: impl Iterator<Item = Option<&'a GrainSample>>) -> Option<GrainSample> {
    let mut sum = GrainSample::default();
    let mut n = 0usize;
    for g in samples {
        let g = g?;
        sum.count = g.count;
        sum.phi += g.phi;
        sum.z += g.z;
        sum.z_no_rattlers += g.z_no_rattlers;
        sum.pressure += g.pressure;
        sum.mean_aspect_ratio += g.mean_aspect_ratio;
        sum.max_aspect_ratio += g.max_aspect_ratio;
        sum.mean_area += g.mean_area;
        n += 1;
    }
    (n > 0).then(|| {
        let k = n as Real;
        GrainSample {
            count: sum.count,
            phi: sum.phi / k,
            z: sum.z / k,
            z_no_rattlers: sum.z_no_rattlers / k,
            pressure: sum.pressure / k,
            mean_aspect_ratio: sum.mean_aspect_ratio / k,
            max_aspect_ratio: sum.max_aspect_ratio / k,
            mean_area: sum.mean_area / k,
        }
    })
}
