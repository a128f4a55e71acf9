//! The compaction's results ([`CompactionResult`]): the onset of load, the packing fractions,
//! the power laws of Z and of the wall's stress beyond the onset, the grains' shapes.

use serde::{Deserialize, Serialize};

use super::{Analysis, ExperimentResult, Flow, ONSET_FRACTION};
use crate::observe::compaction_laws::{self, CompactedState, ExponentialLawFit, LinearLawFit, NeoHookeanLawFit};
use crate::observe::power::{power_fit, PowerFit};
use crate::observe::sample::Sample;
use crate::scene::CompactionDrive;

/// Results of a compaction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CompactionResult {
    /// Packing fraction when the moving wall first carries 1% of its final stress.
    pub phi_onset: Option<f64>,
    /// Final packing fraction.
    pub phi_final: f64,
    /// Final stress on the moving wall, Pa.
    pub wall_stress: f64,
    /// Final strain `|ln(h/h_i)|` of the compacted axis.
    pub strain: f64,
    /// Largest packing fraction reached.
    pub phi_max: f64,
    /// The coordination beyond the onset, `Z − Z_J = a (Φ − Φ_J)^b` over the samples after
    /// it (`Φ_J`, `Z_J`: those of the onset's sample; the grains' Φ and Z, [`Sample::phi`]). Soft grains: `b ≈ ½`
    /// (docs/physics.md §9; Nezamabadi 2020, eq. 2.20).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coordination_fit: Option<PowerFit>,
    /// The moving wall's stress beyond the onset, `σ = a (Φ − Φ_J)^b` (Pa).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stress_fit: Option<PowerFit>,
    /// The sources' linear law `Φ − Φ₀ = α (σ − σ₀)/K` fitted to the moving wall's stress
    /// beyond the onset (deformable grains; [`compaction_laws`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_law: Option<LinearLawFit>,
    /// The sources' law of neo-Hookean grains `σ = M_eff (ln Φ + c₂)/(1 + M_eff/(c₁ K Z Φ))`
    /// fitted beyond the onset (deformable grains; [`compaction_laws`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub neo_hookean_law: Option<NeoHookeanLawFit>,
    /// The sources' law of plastic grains `1 − Φ = (1 − Φ₀) e^(−r (σ − σ₀))` fitted beyond the
    /// onset ([`compaction_laws`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponential_law: Option<ExponentialLawFit>,
    /// The grains' mean aspect ratio at the end (deformable grains; 1 for disks): how much
    /// their shape changed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_aspect_ratio: Option<f64>,
    /// The largest aspect ratio of a grain at the end (deformable grains).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_aspect_ratio: Option<f64>,
}

impl Analysis {
    /// The results of the `compaction` stage's samples `run` along `axis`, driven by `drive`.
    pub(super) fn compaction(&self, r: &mut ExperimentResult, run: &[&Sample], axis: usize, drive: &CompactionDrive, flow: &Flow) {
        let Some(last) = self.samples.last() else { return };
        let wall = format!("{}_max", crate::math::AXES[axis]);
        let stress_of = |s: &Sample| s.walls.iter().find(|w| w.name == wall).map_or(0.0, |w| w.normal_stress);
        let final_stress = stress_of(last);
        let onset = run.iter().position(|s| final_stress > 0.0 && stress_of(s) >= ONSET_FRACTION * final_stress);
        let phi = |s: &Sample| s.phi;
        let z = |s: &Sample| s.z;
        let phi_onset = onset.map(|k| phi(run[k]));
        let strain = last.strain.as_ref().and_then(|e| e.axes.get(axis).copied()).unwrap_or(0.0);
        let (coordination_fit, stress_fit) = match onset {
            Some(k) => {
                let (jammed, beyond) = (run[k], &run[k + 1..]);
                (
                    power_fit(beyond.iter().map(|s| (phi(s) - phi(jammed), z(s) - z(jammed)))),
                    power_fit(beyond.iter().map(|s| (phi(s) - phi(jammed), stress_of(s)))),
                )
            }
            None => (None, None),
        };
        let loaded: Vec<CompactedState> =
            onset.map_or(&[][..], |k| &run[k..]).iter().map(|s| CompactedState { phi: phi(s), z: z(s), stress: stress_of(s) }).collect();
        let moduli = self.grain_moduli.filter(|_| self.deformable);
        let shape = last.grains.as_ref().map(|g| (g.mean_aspect_ratio, g.max_aspect_ratio));
        r.compaction = Some(CompactionResult {
            phi_onset,
            phi_final: phi(last),
            wall_stress: final_stress,
            strain,
            phi_max: run.iter().map(|s| phi(s)).fold(phi(last), f64::max),
            coordination_fit,
            stress_fit,
            linear_law: moduli.and_then(|m| compaction_laws::linear_law(&loaded, m)),
            neo_hookean_law: moduli.and_then(|m| compaction_laws::neo_hookean_law(&loaded, m)),
            exponential_law: compaction_laws::exponential_law(&loaded),
            mean_aspect_ratio: shape.map(|s| s.0),
            max_aspect_ratio: shape.map(|s| s.1),
        });
        r.stiffness_number = self.stiffness_number(final_stress, flow.mean_diameter);
        if let CompactionDrive::Velocity { speed, .. } = drive {
            // Strain rate at the end: speed over the current height.
            let h = last
                .walls
                .iter()
                .find(|w| w.name == wall)
                .map(|w| w.position)
                .zip(last.walls.iter().find(|w| w.name == format!("{}_min", crate::math::AXES[axis])).map(|w| w.position));
            if let Some((hi, lo)) = h.filter(|(hi, lo)| hi > lo) {
                r.inertial_number = flow.inertial(speed / (hi - lo), final_stress);
            }
        }
    }
}
