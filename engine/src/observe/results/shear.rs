//! The plane shear's steady state ([`ShearResult`]), and for wet grains the cohesion index,
//! the Stokes number and the visco-cohesive inertial number.

use serde::{Deserialize, Serialize};

use super::{Analysis, ExperimentResult, Flow};
use crate::math::Real;
use crate::observe::sample::Sample;

/// The steady state of a plane shear: means over the second half of the shear strain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ShearResult {
    /// Shear strain where the averaging window starts.
    pub from_strain: f64,
    /// Samples in the window.
    pub samples: usize,
    /// Mean effective friction `μ = τ / σ_n` (between rough walls, of the upper wall's load).
    pub mu: f64,
    /// Its standard deviation over the window.
    pub mu_std: f64,
    /// Mean packing fraction.
    pub phi: f64,
    /// Mean coordination without rattlers.
    pub z_no_rattlers: f64,
    /// Mean inertial number measured in the samples (`γ̇ <d> sqrt(ρ / σ_n)`).
    pub inertial_number: f64,
    /// Mean normal stress σ_yy, Pa (of the box in a Lees-Edwards cell, on the upper wall between
    /// rough walls).
    pub normal_stress: f64,
    /// Wet grains (Nezamabadi 2020, §3.1): cohesion index `ξ = σ_c / σ_n` with
    /// `σ_c = f_c / d^(D-1)` and `f_c = 2π γ cos θ <d>/2` the largest capillary force between
    /// grains of the mean size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cohesion_index: Option<f64>,
    /// Wet grains: Stokes number `St = σ_i / σ_v = ρ <d>² γ̇ / η` (absent for an inviscid
    /// liquid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stokes_number: Option<f64>,
    /// Wet grains: visco-cohesive inertial number `I_m = I sqrt((1 + β/St) / (1 + α ξ))`,
    /// α = 0.062, β = 0.075 (Nezamabadi 2020, eq. 3.1; Vo et al. 2020).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub viscocohesive_inertial_number: Option<f64>,
}

/// α of the visco-cohesive inertial number (Nezamabadi 2020, eq. 3.1).
pub const I_M_ALPHA: Real = 0.062;
/// β of the visco-cohesive inertial number (Nezamabadi 2020, eq. 3.1).
pub const I_M_BETA: Real = 0.075;

/// The liquid of wet grains, for the wet shear numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WetScales {
    /// `2π γ cos θ`, N/m.
    pub(super) kappa: Real,
    /// Viscosity, Pa·s.
    pub(super) viscosity: Real,
    /// Rupture distance of a bridge, m.
    pub(super) rupture_distance: Real,
}

impl Analysis {
    /// The steady state of the `shear` stage's samples at shear rate `shear_rate` (1/s),
    /// averaged over the second half of the shear strain (the strain of a sample is its time
    /// since the stage started × the rate).
    pub(super) fn plane_shear(&self, r: &mut ExperimentResult, shear: &[&Sample], shear_rate: Real, rough_walls: bool, flow: &Flow) {
        let mean_diameter = flow.mean_diameter;
        let density = flow.density;
        if let (Some(first), Some(last)) = (shear.first(), shear.last()) {
            let total = last.time - first.time;
            let from = first.time + 0.5 * total;
            let window: Vec<&&Sample> = shear.iter().filter(|s| s.time >= from).collect();
            if !window.is_empty() {
                let n = window.len() as Real;
                let mean = |f: &dyn Fn(&Sample) -> Real| window.iter().map(|s| f(s)).sum::<Real>() / n;
                // Between rough walls the upper wall's load is the measure (the stress
                // of the box misses the glued layers' load on the walls behind them):
                // μ = |F_x| / F_y and σ_n its normal stress; I from σ_n.
                let wall_mu = |s: &Sample| {
                    s.walls.iter().find(|w| w.name == "y_max").map_or(0.0, |w| {
                        let (fx, fy) = (w.force.first().copied().unwrap_or(0.0), w.force.get(1).copied().unwrap_or(0.0));
                        if fy > 0.0 {
                            fx.abs() / fy
                        } else {
                            0.0
                        }
                    })
                };
                let wall_stress = |s: &Sample| s.walls.iter().find(|w| w.name == "y_max").map_or(0.0, |w| w.normal_stress);
                let mu_of = |s: &Sample| if rough_walls { wall_mu(s) } else { s.mu.unwrap_or(0.0) };
                let mu = mean(&mu_of);
                let normal_stress = if rough_walls { mean(&wall_stress) } else { mean(&|s| s.stress.yy) };
                let i = if rough_walls {
                    flow.inertial(shear_rate, normal_stress).unwrap_or(0.0)
                } else {
                    // The samples' I is at the primaries' mean diameter (that of the
                    // box's particles, `mean_diameter`): for aggregates, rescaled to
                    // the grains' (`flow.diameter`).
                    let scale = if mean_diameter > 0.0 { flow.diameter / mean_diameter } else { 1.0 };
                    mean(&|s| s.inertial_number.unwrap_or(0.0)) * scale
                };
                r.inertial_number = Some(i);
                // Wet grains: cohesion index, Stokes number, visco-cohesive inertial number.
                let (mut xi, mut st, mut i_m) = (None, None, None);
                if let Some(w) = self.wet.filter(|_| normal_stress > 0.0) {
                    let f_c = w.kappa * 0.5 * mean_diameter;
                    let x = f_c / mean_diameter.powi(self.dim as i32 - 1) / normal_stress;
                    let stokes = (w.viscosity > 0.0).then(|| density * mean_diameter * mean_diameter * shear_rate / w.viscosity);
                    let viscous = stokes.map_or(0.0, |st| I_M_BETA / st);
                    xi = Some(x);
                    st = stokes;
                    i_m = Some(i * ((1.0 + viscous) / (1.0 + I_M_ALPHA * x)).sqrt());
                }
                r.shear = Some(ShearResult {
                    from_strain: shear_rate * (from - first.time),
                    samples: window.len(),
                    mu,
                    mu_std: (window.iter().map(|s| (mu_of(s) - mu).powi(2)).sum::<Real>() / n).sqrt(),
                    phi: mean(&|s| s.phi),
                    z_no_rattlers: mean(&|s| s.z_no_rattlers),
                    inertial_number: i,
                    normal_stress,
                    cohesion_index: xi,
                    stokes_number: st,
                    viscocohesive_inertial_number: i_m,
                });
            }
        }
    }
}
