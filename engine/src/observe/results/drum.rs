//! The result of a rotating drum (docs/references.md check 17): the drum samples of the steady
//! rotation averaged after the transient revolutions, and the flow regime they show.

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::observe::drum::{DrumSample, ProfileBin};
use crate::observe::sample::Sample;
use crate::scene::Experiment;

/// The steady rotation of a drum: means over the samples after the transient revolutions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DrumResult {
    /// Froude number `ω² R / g`.
    pub froude: f64,
    /// Angular velocity, rad/s.
    pub angular_velocity: f64,
    /// Time since the drum started where the averages start, s.
    pub from_time: f64,
    /// Samples averaged.
    pub samples: usize,
    /// Dynamic angle of repose: mean angle of the fitted free surface, degrees.
    pub surface_angle: f64,
    /// Its standard deviation over the samples, degrees (large when the bed slumps).
    pub surface_angle_std: f64,
    /// Mean angle of the bed's centroid from straight down, degrees.
    pub mass_angle: f64,
    /// Mean angle of the upper half of the surface, degrees.
    pub upper_angle: f64,
    /// Mean angle of the lower half of the surface, degrees.
    pub lower_angle: f64,
    /// Mean fraction of the cross-section below the surface.
    pub fill: f64,
    /// Packing fraction of the bed (solid volume over the volume below the surface).
    pub phi_bed: f64,
    /// Mean fraction of grains in flight.
    pub airborne_fraction: f64,
    /// Mean torque the drive supplies, N·m (per metre in 2D).
    pub drive_torque: f64,
    /// Mean velocity down the slope of the top bin of the profile, m/s.
    pub surface_velocity: f64,
    /// Depth below the surface where the mean velocity down the slope changes sign, m (the
    /// flowing layer's thickness; absent when the surface does not flow).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flowing_layer_depth: Option<f64>,
    /// Inertial number of the flowing layer, `(v_s / h) <d> sqrt(ρ / p)` with `p` the weight of
    /// half the layer (`Φ ρ g cos θ h / 2`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flow_inertial_number: Option<f64>,
    /// `slipping`, `slumping`, `rolling`, `cascading`, `cataracting` or `centrifuging`
    /// ([`drum_regime`]).
    pub regime: String,
    /// Mean velocity profile across the flowing layer (counts summed over the samples).
    pub profile: Vec<ProfileBin>,
    /// With wet grains: their granule's accretion and erosion over the whole rotation, and the
    /// rates of Vo et al.'s law ([`super::granule_growth`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub granule: Option<super::granule_growth::GranuleGrowth>,
}

/// Mass angle (degrees) below which the bed is not lifted: the drum slips under it.
pub const SLIP_ANGLE: Real = 5.0;
/// Fraction of the settled bed's centroid offset below which the grains ride the wall all
/// round.
pub const CENTRIFUGE_OFFSET: Real = 0.1;
/// Fraction of grains in flight above which the flow cataracts.
pub const CATARACT_AIRBORNE: Real = 0.05;
/// Fraction of the samples with the surface at rest above which the flow is intermittent.
pub const SLUMP_AT_REST: Real = 0.2;
/// Difference of the upper and lower surface angles (degrees) above which the surface is
/// curved (cascading).
pub const CASCADE_CURVATURE: Real = 10.0;

/// The flow regime of a drum from its measured means (Mellmann, Powder Technol. 118, 251,
/// 2001; docs/references.md check 17), the first that applies:
/// - `centrifuging`: the bed's centroid is within [`CENTRIFUGE_OFFSET`] of its settled offset
///   from the axis (the grains ride the wall all round);
/// - `slipping`: the bed's centroid turned by less than [`SLIP_ANGLE`];
/// - `cataracting`: more than [`CATARACT_AIRBORNE`] of the grains are in flight;
/// - `slumping`: in more than [`SLUMP_AT_REST`] of the samples the surface is not flowing down;
/// - `cascading`: the surface's upper and lower halves differ by more than
///   [`CASCADE_CURVATURE`] degrees;
/// - `rolling` otherwise: a flat surface flowing steadily.
pub fn drum_regime(centroid_ratio: Real, mass_angle: Real, airborne: Real, at_rest: Real, curvature: Real) -> &'static str {
    if centroid_ratio < CENTRIFUGE_OFFSET {
        "centrifuging"
    } else if mass_angle < SLIP_ANGLE {
        "slipping"
    } else if airborne > CATARACT_AIRBORNE {
        "cataracting"
    } else if at_rest > SLUMP_AT_REST {
        "slumping"
    } else if curvature > CASCADE_CURVATURE {
        "cascading"
    } else {
        "rolling"
    }
}

/// Averages the drum samples after the transient; also returns the weight per area on the
/// bottom of the bed, Pa (for the stiffness number).
pub(crate) fn drum_result(
    experiment: &Experiment,
    settled: Option<&Sample>,
    rotation: &[&Sample],
    mean_diameter: Real,
    density: Real,
) -> Option<(DrumResult, Real)> {
    let Experiment::Drum { drum, angular_velocity, froude, transient, .. } = experiment else { return None };
    let first = rotation.first()?;
    let period = 2.0 * std::f64::consts::PI / angular_velocity.abs();
    let from = first.time + transient * period;
    let window: Vec<&DrumSample> = rotation.iter().filter(|s| s.time >= from - 1e-12 * period).filter_map(|s| s.drum.as_deref()).collect();
    if window.is_empty() {
        return None;
    }
    let n = window.len() as Real;
    let mean = |f: &dyn Fn(&DrumSample) -> Real| window.iter().map(|d| f(d)).sum::<Real>() / n;
    let surface_angle = mean_present(&window, |d| d.surface_angle);
    let surface_angle_std = surface_angle_std(&window, surface_angle);
    let (upper_angle, lower_angle) = (mean_present(&window, |d| d.upper_angle), mean_present(&window, |d| d.lower_angle));
    let fill = mean(&|d| d.fill);
    // Solid volume over the volume below the surface: Φ_box × box cross-section (2R)² / (fill π R²).
    let phi_box = rotation.iter().filter(|s| s.time >= from - 1e-12 * period).map(|s| s.phi).sum::<Real>() / n;
    let phi_bed = if fill > 0.0 { phi_box * 4.0 / (std::f64::consts::PI * fill) } else { 0.0 };
    let profile = mean_profile(&window, mean_diameter);
    let (surface_velocity, flowing_layer_depth) = surface_flow(&profile);
    let mass_angle = mean(&|d| d.mass_angle);
    // g from Fr = ω² R / g.
    let gravity = angular_velocity * angular_velocity * drum.radius / froude;
    let flow_inertial_number = flowing_layer_depth.and_then(|h| {
        let p = phi_bed * density * gravity * surface_angle.to_radians().cos() * 0.5 * h;
        (p > 0.0 && h > 0.0).then(|| surface_velocity / h * mean_diameter * (density / p).sqrt())
    });
    let at_rest = window.iter().filter(|d| d.profile.iter().find(|b| b.count > 0).is_none_or(|b| b.velocity <= 0.0)).count() as Real / n;
    let settled_offset = settled.and_then(|s| s.drum.as_ref()).map_or(0.0, |d| d.centroid_offset);
    let centroid_ratio = if settled_offset > 0.0 { mean(&|d| d.centroid_offset) / settled_offset } else { 1.0 };
    let regime = drum_regime(centroid_ratio, mass_angle, mean(&|d| d.airborne_fraction), at_rest, (upper_angle - lower_angle).abs());
    let bottom = phi_bed * density * gravity * mean(&|d| d.bed_depth);
    let result = DrumResult {
        froude: *froude,
        angular_velocity: *angular_velocity,
        from_time: from - first.time,
        samples: window.len(),
        surface_angle,
        surface_angle_std,
        mass_angle,
        upper_angle,
        lower_angle,
        fill,
        phi_bed,
        airborne_fraction: mean(&|d| d.airborne_fraction),
        drive_torque: mean(&|d| d.drive_torque),
        surface_velocity,
        flowing_layer_depth,
        flow_inertial_number,
        regime: regime.to_string(),
        profile,
        granule: None,
    };
    Some((result, bottom))
}

/// Mean of the values the samples have, 0 when none has one.
fn mean_present(window: &[&DrumSample], f: impl Fn(&DrumSample) -> Option<Real>) -> Real {
    let v: Vec<Real> = window.iter().filter_map(|d| f(d)).collect();
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<Real>() / v.len() as Real
    }
}

/// Standard deviation of the samples' surface angles about their mean, 0 when none has one.
fn surface_angle_std(window: &[&DrumSample], surface_angle: Real) -> Real {
    let angles: Vec<Real> = window.iter().filter_map(|d| d.surface_angle).collect();
    if angles.is_empty() {
        0.0
    } else {
        (angles.iter().map(|a| (a - surface_angle).powi(2)).sum::<Real>() / angles.len() as Real).sqrt()
    }
}

/// Mean velocity profile of the samples, bins weighted by their counts.
fn mean_profile(window: &[&DrumSample], mean_diameter: Real) -> Vec<ProfileBin> {
    let bins = window.iter().map(|d| d.profile.len()).max().unwrap_or(0);
    let mut profile: Vec<ProfileBin> =
        (0..bins).map(|b| ProfileBin { depth: (b as Real + 0.5) * mean_diameter, velocity: 0.0, count: 0 }).collect();
    for d in window {
        for (acc, bin) in profile.iter_mut().zip(&d.profile) {
            acc.velocity += bin.velocity * bin.count as Real;
            acc.count += bin.count;
        }
    }
    for b in &mut profile {
        if b.count > 0 {
            b.velocity /= b.count as Real;
        }
    }
    profile
}

/// The surface velocity (top filled bin) of a mean profile, and the depth where the velocity
/// down the slope changes sign (when the surface flows).
fn surface_flow(profile: &[ProfileBin]) -> (Real, Option<Real>) {
    let filled: Vec<&ProfileBin> = profile.iter().filter(|b| b.count > 0).collect();
    let surface_velocity = filled.first().map_or(0.0, |b| b.velocity);
    let flowing_layer_depth = if surface_velocity > 0.0 {
        filled.windows(2).find(|w| w[1].velocity <= 0.0).map(|w| {
            let (a, b) = (w[0], w[1]);
            a.depth + a.velocity / (a.velocity - b.velocity) * (b.depth - a.depth)
        })
    } else {
        None
    };
    (surface_velocity, flowing_layer_depth)
}
