//! The `Sample` record: one row of a run's time series.

use serde::{Deserialize, Serialize};

use super::drum::DrumSample;
use super::grains::{GrainSample, PrimarySample};

/// Stress tensor components, Pa (compression positive; 2D: force per metre of thickness per
/// metre, i.e. Pa for unit thickness). `zz`, `xz`, `yz` are absent in 2D.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Stress {
    /// σ_xx.
    pub xx: f64,
    /// σ_yy.
    pub yy: f64,
    /// σ_zz (3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zz: Option<f64>,
    /// σ_xy.
    pub xy: f64,
    /// σ_xz (3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xz: Option<f64>,
    /// σ_yz (3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yz: Option<f64>,
}

/// Load on one wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct WallSample {
    /// `x_min`, `y_max`, ...
    pub name: String,
    /// Coordinate of the wall along its axis, m.
    pub position: f64,
    /// Force exerted by the particles on the wall, N (length = dimension).
    pub force: Vec<f64>,
    /// Compressive normal stress on the wall, Pa.
    pub normal_stress: f64,
}

/// The measured state at one instant (field names are part of the API: CSV columns, JSON keys,
/// database columns). The default is an empty box at step 0, every measure 0 or absent.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Sample {
    /// Step number.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Packing fraction Φ of the grains (solid volume / container volume; area fraction in 2D).
    /// For aggregates (bonded particle method) the grains' areas ([`GrainSample::phi`]); the
    /// primaries' are under [`Sample::primaries`].
    pub phi: f64,
    /// Mean coordination of the grains, 2 N_c / N (grain-grain force-bearing contacts; pairs of
    /// aggregates in contact for the bonded particle method).
    pub z: f64,
    /// Mean coordination of the grains' force-bearing backbone, rattlers removed recursively.
    pub z_no_rattlers: f64,
    /// Stress ratio ζ = q/p (0 when p ≤ 0): the friction of a biaxial or triaxial test.
    pub zeta: f64,
    /// Effective friction μ = τ/σ_n on the shear plane, where a shear is defined (Lees-Edwards
    /// or a sliding wall; 0 when σ_n ≤ 0); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu: Option<f64>,
    /// Mean pressure p, Pa (tr σ / D).
    pub p: f64,
    /// Deviatoric stress q, Pa ((σ1 - σ2)/2 in 2D; von Mises sqrt(3/2 s:s) in 3D).
    pub q: f64,
    /// Love-Weber stress (contact and kinetic parts).
    pub stress: Stress,
    /// Inertial number I = γ̇ <d> sqrt(ρ / P), where a shear rate is defined.
    pub inertial_number: Option<f64>,
    /// Kinetic energy (translation and rotation), J.
    pub kinetic_energy: f64,
    /// Elastic energy stored in contacts, J.
    pub elastic_energy: f64,
    /// Loads on the walls.
    pub walls: Vec<WallSample>,
    /// Stage of the loading program the sample belongs to (scenes with an experiment).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage: Option<String>,
    /// Strain of the box since the stage started (scenes with an experiment).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strain: Option<StrainSample>,
    /// The rotating drum's surface, fill and flow (drum experiment).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drum: Option<Box<DrumSample>>,
    /// The contact solver's work on the last step (contact dynamics).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<Box<SolverSample>>,
    /// The grains' own deformation and the energy it took (deformable grains).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deformable: Option<Box<DeformableSample>>,
    /// The grains' own measures, the same fields for every method with grains that are not
    /// single rigid particles: aggregates of primaries (bonded particle method) and deformable
    /// grains (MPM, FEM): their packing fraction, coordination, pressure and shape (Φ and Z
    /// equal the fields above).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grains: Option<Box<GrainSample>>,
    /// The primaries' packing fraction and coordination, when the grains are aggregates of
    /// primaries (bonded particle method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub primaries: Option<PrimarySample>,
    /// The wet grains' largest cluster held by capillary bridges, when some grains are wet
    /// ([`super::cluster`]: an agglomerate's size, bridges, the grains it lost, its shape).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cluster: Option<Box<super::cluster::ClusterSample>>,
}

/// The state of deformable grains at a sample (methods `mpm` and `fem`) besides their
/// [`GrainSample`] (Φ, Z, pressure and shape).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DeformableSample {
    /// Smallest `det F` of a material point (1 undeformed; never <= 0).
    pub min_jacobian: f64,
    /// Energy dissipated since the start, J (per metre of thickness in 2D): the work of the
    /// walls and gravity less the change of kinetic and elastic (strain) energy. The walls'
    /// work is their end-of-step force over each step, so that with backward Euler (θ = 1)
    /// it includes the scheme's numerical dissipation (a third of the stored energy over three
    /// equal steps of a linear ramp; less as steps are finer), besides plasticity, the
    /// inelastic contacts and PIC's velocity averaging. It can fall below zero where contacts
    /// push their grains apart to keep them from overlapping further, which does work
    /// (`methods::soft::contact`; issue 26).
    pub dissipated_energy: f64,
    /// The area the grains' outlines cover twice or that lies beyond the walls, as a fraction
    /// of the box's area: how far touching grains interpenetrate. `phi` less it is the packing
    /// fraction of the grains' union inside the box.
    #[serde(default)]
    pub interpenetration: f64,
    /// Newton iterations on the step before the sample.
    pub newton_iterations: u32,
    /// Contact-solver sweeps on that step.
    pub sweeps: u32,
}

/// What the contact solver of contact dynamics did on the step before a sample
/// ([`crate::nscd::nlgs`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SolverSample {
    /// NLGS sweeps.
    pub iterations: u32,
    /// Relative change of the impulses over the last sweep.
    pub change: f64,
    /// Mean violation of the Signorini condition after the last sweep, as a fraction of the
    /// mean diameter per step.
    pub violation: f64,
    /// Contacts solved (closed or closing within the step).
    pub contacts: u64,
    /// Largest interpenetration at the start of the step / smaller radius of its pair.
    pub max_interpenetration: f64,
    /// Mean interpenetration of the contacts / smaller radius of each pair.
    pub mean_interpenetration: f64,
}

/// True strains of the box since the start of a stage, compression positive:
/// `eps_a = -ln(L_a / L_a(start))` per axis.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct StrainSample {
    /// Strain of each axis (x, y[, z]).
    pub axes: Vec<f64>,
    /// Volumetric strain `eps_v = sum eps_a` (positive when the box shrinks; Nezamabadi 2020,
    /// eq. 2.28).
    pub volumetric: f64,
    /// Deviatoric strain: `eps_1 - eps_2` in 2D (Nezamabadi 2020, eq. 2.27), `2/3 (eps_1 - eps_3)`
    /// in 3D (for axisymmetric strains; in general `sqrt(2 e:e)` in 2D and `sqrt(2/3 e:e)` in 3D, e
    /// the deviator), never negative.
    pub deviatoric: f64,
}

impl StrainSample {
    /// Strains of box lengths `now` against `start` (first `dim` axes).
    pub fn between(dim: usize, start: &[f64], now: &[f64]) -> Self {
        let axes: Vec<f64> = (0..dim).map(|a| -(now[a] / start[a]).ln()).collect();
        let volumetric: f64 = axes.iter().sum();
        let mean = volumetric / dim as f64;
        let ee: f64 = axes.iter().map(|e| (e - mean).powi(2)).sum();
        let deviatoric = if dim == 2 { (2.0 * ee).sqrt() } else { (2.0 / 3.0 * ee).sqrt() };
        Self { axes, volumetric, deviatoric }
    }
}

impl Sample {
    /// Column names of the CSV form, in order.
    pub fn csv_header(dim: usize) -> Vec<String> {
        let mut h: Vec<String> =
            ["step", "time", "phi", "z", "z_no_rattlers", "zeta", "mu", "p", "q"].iter().map(|s| s.to_string()).collect();
        let comps: &[&str] = if dim == 2 { &["xx", "yy", "xy"] } else { &["xx", "yy", "zz", "xy", "xz", "yz"] };
        h.extend(comps.iter().map(|c| format!("stress_{c}")));
        h.extend(["inertial_number", "kinetic_energy", "elastic_energy"].iter().map(|s| s.to_string()));
        h
    }

    /// Values of the CSV form, matching [`Sample::csv_header`] (walls are left to JSON).
    pub fn csv_row(&self, dim: usize) -> Vec<String> {
        let f = |x: f64| format!("{x:e}");
        let mut r = vec![self.step.to_string(), f(self.time), f(self.phi), f(self.z), f(self.z_no_rattlers), f(self.zeta)];
        r.push(self.mu.map(f).unwrap_or_default());
        r.extend([f(self.p), f(self.q)]);
        let s = &self.stress;
        if dim == 2 {
            r.extend([f(s.xx), f(s.yy), f(s.xy)]);
        } else {
            let o = |x: Option<f64>| f(x.unwrap_or(0.0));
            r.extend([f(s.xx), f(s.yy), o(s.zz), f(s.xy), o(s.xz), o(s.yz)]);
        }
        r.push(self.inertial_number.map(f).unwrap_or_default());
        r.extend([f(self.kinetic_energy), f(self.elastic_energy)]);
        r
    }

    /// True if every number in the sample is finite (results with NaN are never stored).
    pub fn is_finite(&self) -> bool {
        let s = &self.stress;
        [
            self.time,
            self.phi,
            self.z,
            self.z_no_rattlers,
            self.zeta,
            self.p,
            self.q,
            s.xx,
            s.yy,
            s.xy,
            self.kinetic_energy,
            self.elastic_energy,
        ]
        .iter()
        .chain([s.zz, s.xz, s.yz, self.mu, self.inertial_number].iter().flatten())
        .all(|x| x.is_finite())
            && self.walls.iter().all(|w| w.position.is_finite() && w.normal_stress.is_finite() && w.force.iter().all(|x| x.is_finite()))
            && self
                .strain
                .as_ref()
                .is_none_or(|e| e.volumetric.is_finite() && e.deviatoric.is_finite() && e.axes.iter().all(|x| x.is_finite()))
            && self.grains.as_ref().is_none_or(|g| {
                [g.phi, g.z, g.z_no_rattlers, g.pressure, g.mean_aspect_ratio, g.max_aspect_ratio, g.mean_area]
                    .iter()
                    .all(|x| x.is_finite())
            })
            && self.primaries.as_ref().is_none_or(|a| [a.phi, a.z, a.z_no_rattlers].iter().all(|x| x.is_finite()))
            && self.drum.as_ref().is_none_or(|d| {
                [d.mass_angle, d.fill, d.centroid_offset, d.airborne_fraction, d.drive_torque]
                    .iter()
                    .chain([d.surface_angle, d.upper_angle, d.lower_angle].iter().flatten())
                    .all(|x| x.is_finite())
                    && d.profile.iter().all(|b| b.depth.is_finite() && b.velocity.is_finite())
            })
            && self
                .solver
                .as_ref()
                .is_none_or(|v| [v.change, v.violation, v.max_interpenetration, v.mean_interpenetration].iter().all(|x| x.is_finite()))
            && self
                .deformable
                .as_ref()
                .is_none_or(|d| [d.min_jacobian, d.dissipated_energy, d.interpenetration].iter().all(|x| x.is_finite()))
    }
}
