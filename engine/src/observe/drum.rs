//! What a rotating drum shows at one instant (docs/references.md check 17): the angle of the bed,
//! the free surface, the fill, the grains in flight and the velocity profile across the flowing
//! layer.
//!
//! Everything is measured in the drum's cross-section (in 3D the grains are projected along
//! the axis), in a frame where the bed rises towards `+h` whatever the sense of rotation:
//! `h` horizontal across the axis, `u` up against gravity.
//!
//! - **Mass angle**: the direction of the bed's centroid from the axis, measured from straight
//!   down. For a flat free surface the bed is a circular segment whose centroid lies on the
//!   perpendicular to the surface through the axis, so this is the surface's angle; it needs
//!   no surface detection and is the robust one.
//! - **Surface angle**: the slope of a least-squares line through the free surface, in the
//!   frame tilted by the mass angle: over the middle 70% of the chord, in bins two mean
//!   diameters wide, the top of the highest grain in contact with another (grains in flight
//!   are not the surface). The halves of the chord give the upper and lower angles; they
//!   differ when the surface is curved (the S shape of the cascading regime).
//! - **Fill**: the fraction of the cross-section below the fitted surface.
//! - **Velocity profile**: along the perpendicular to the surface through the mid-chord
//!   (grains within a strip of ±1.5 `<d>` of it), the mean velocity down the slope in bins one
//!   mean diameter deep, from the surface to the wall: positive in the flowing layer, negative
//!   where the bed turns with the drum.
//!
//! `drum_result` averages the samples of the rotation into the experiment's result, and
//! [`drum_regime`] names the flow regime.
//! The frames, the surface fit and the profile of one sample are in `drum_surface.rs`.

use serde::{Deserialize, Serialize};

use super::drum_surface::{fit_surface, load_bearing, mass_centroid, velocity_profile, DrumFrame, SurfaceFrame};
use super::metrics::ContactRecord;
use super::sample::Sample;
use crate::math::{Real, Vec3};
use crate::particles::Particles;
use crate::scene::Experiment;

/// Half-width of the part of the chord where the surface is fitted, as a fraction of the
/// chord's half-length (the ends touch the wall and bend).
pub const SURFACE_SPAN: Real = 0.7;
/// Half-width of the strip about the mid-chord normal where the velocity profile is taken, in
/// mean diameters.
pub const PROFILE_STRIP: Real = 1.5;

/// A drum as the methods show it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumView {
    /// Axis (0, 1, 2).
    pub axis: usize,
    /// A point of the axis, m.
    pub center: Vec3,
    /// Inner radius, m.
    pub radius: Real,
    /// Angular velocity, rad/s (right-handed about the axis).
    pub angular_velocity: Real,
    /// Unit vector of gravity (perpendicular to the axis).
    pub down: Vec3,
    /// Torque about the axis exerted by the grains on the drum, N·m (per metre of thickness
    /// in 2D).
    pub torque: Real,
}

/// One depth bin of the velocity profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ProfileBin {
    /// Depth of the bin's middle below the free surface, m.
    pub depth: f64,
    /// Mean velocity down the slope, m/s (negative: up, with the drum).
    pub velocity: f64,
    /// Grains counted.
    pub count: u64,
}

/// The drum at one instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DrumSample {
    /// Angle of the bed's centroid from straight down, degrees.
    pub mass_angle: f64,
    /// Angle of the free surface to the horizontal, degrees (absent when no surface was
    /// found).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface_angle: Option<f64>,
    /// Angle of the upper half of the surface, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upper_angle: Option<f64>,
    /// Angle of the lower half of the surface, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lower_angle: Option<f64>,
    /// Fraction of the cross-section below the free surface.
    pub fill: f64,
    /// Depth of the bed at mid-chord (from the fitted surface to the wall), m.
    pub bed_depth: f64,
    /// Distance of the bed's centroid from the axis, m.
    pub centroid_offset: f64,
    /// Fraction of the grains in flight: touching nothing, and more than a mean diameter above
    /// the fitted surface.
    pub airborne_fraction: f64,
    /// Torque the drive supplies to keep the drum turning, N·m (per metre in 2D).
    pub drive_torque: f64,
    /// Velocity down the slope against depth, from the surface to the wall.
    pub profile: Vec<ProfileBin>,
}

/// Fraction of a circle of radius `r` lying below a chord at signed height `w` from its centre.
pub fn segment_fraction(w: Real, r: Real) -> Real {
    let x = (w / r).clamp(-1.0, 1.0);
    let cap_above = x.acos() - x * (1.0 - x * x).sqrt();
    1.0 - cap_above / std::f64::consts::PI
}

/// Measures the drum in `dim` dimensions: particles, their contacts (to tell grains in flight)
/// and the drum.
pub fn measure_drum(dim: usize, p: &Particles, contacts: &[ContactRecord], d: &DrumView) -> DrumSample {
    let n = p.len();
    let frame = DrumFrame::new(d);
    let touching = load_bearing(n, contacts);
    let (ch, cu) = mass_centroid(dim, p, &frame);
    let theta = ch.atan2(-cu);
    let mean_d = if n > 0 { 2.0 * p.radius.iter().sum::<Real>() / n as Real } else { 0.0 };
    let surface = SurfaceFrame { drum: &frame, t: (theta.cos(), theta.sin()), nrm: (-theta.sin(), theta.cos()) };
    let tops: Vec<(Real, Real)> =
        (0..n).filter(|&k| touching[k]).map(|k| (surface.at(&p.pos[k]), p.radius[k])).map(|((s, w), r)| (s, w + r)).collect();
    let fitted = fit_surface(&tops, theta, mean_d, d.radius);
    let surface_w = fitted.surface_w;
    let fill = if surface_w.is_finite() { segment_fraction(surface_w, d.radius) } else { 0.0 };
    let profile = if surface_w.is_finite() && mean_d > 0.0 {
        velocity_profile(p, &touching, &surface, surface_w, mean_d, d.radius)
    } else {
        Vec::new()
    };
    // In flight: touching nothing, and more than a mean diameter above the surface (grains of
    // a dense flowing layer are often between two collisions).
    let airborne = (0..n)
        .filter(|&k| !touching[k])
        .filter(|&k| {
            let (s, w) = surface.at(&p.pos[k]);
            fitted.line.is_none_or(|(a, b)| w - (a + b * s) > mean_d)
        })
        .count();
    DrumSample {
        mass_angle: theta.to_degrees(),
        surface_angle: fitted.surface_angle,
        upper_angle: fitted.upper_angle,
        lower_angle: fitted.lower_angle,
        fill,
        bed_depth: if surface_w.is_finite() { surface_w + d.radius } else { 0.0 },
        centroid_offset: (ch * ch + cu * cu).sqrt(),
        airborne_fraction: if n > 0 { airborne as Real / n as Real } else { 0.0 },
        drive_torque: -d.torque,
        profile,
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// Disks of diameter 1 on a triangular lattice filling a 2D drum of radius 20 below a
    /// surface tilted by `tilt` degrees (rising to +x for a counter-clockwise drum), each
    /// touching its neighbours, moving in solid rotation at ω = 1 except a layer of
    /// `layer` diameters under the surface that slides down at speed 1.
    fn bed(tilt: Real, layer: Real) -> (Particles, Vec<ContactRecord>, DrumView) {
        let r_drum = 20.0;
        let (c, s) = (tilt.to_radians().cos(), tilt.to_radians().sin());
        let mut p = Particles::default();
        let surface_w = -5.0;
        let mut k = 0;
        let mut y = -r_drum;
        while y < r_drum {
            let shift = if k % 2 == 0 { 0.0 } else { 0.5 };
            let mut x = -r_drum + shift;
            while x < r_drum {
                // (x, y) in the surface frame; rotate into the drum's.
                let pos = Vec3::new(x * c - y * s, x * s + y * c, 0.0);
                if pos.norm() < r_drum - 0.5 && y < surface_w - 0.5 {
                    let depth = surface_w - y;
                    let vel = if depth < layer { Vec3::new(-c, -s, 0.0) } else { Vec3::new(-pos.y, pos.x, 0.0) };
                    p.push(2, pos, vel, 0.5, 1.0, 0, false);
                }
                x += 1.0;
            }
            y += 3f64.sqrt() / 2.0;
            k += 1;
        }
        let contacts: Vec<ContactRecord> = (0..p.len())
            .map(|i| ContactRecord {
                i: i as u32,
                j: None,
                force: Vec3::new(0.0, 1.0, 0.0),
                branch: Vec3::zeros(),
                touching: true,
                bonded: false,
            })
            .collect();
        let view = DrumView {
            axis: 2,
            center: Vec3::zeros(),
            radius: r_drum,
            angular_velocity: 1.0,
            down: Vec3::new(0.0, -1.0, 0.0),
            torque: -2.0,
        };
        (p, contacts, view)
    }

    #[test]
    fn a_tilted_flat_bed_gives_its_angle_fill_and_profile() {
        for tilt in [0.0, 25.0, 35.0] {
            let (p, contacts, view) = bed(tilt, 4.0);
            let m = measure_drum(2, &p, &contacts, &view);
            // The lattice is symmetric about the mid-chord normal only on average: within 1.5°.
            assert!((m.mass_angle - tilt).abs() < 1.5, "tilt {tilt}: mass angle {}", m.mass_angle);
            let sa = m.surface_angle.expect("surface");
            assert!((sa - tilt).abs() < 1.5, "tilt {tilt}: surface angle {sa}");
            // Fill below a chord 5 radii-of-1 below the centre of a radius-20 drum (the top
            // grains reach w = -5 - 0.5 + 0.5 at most, and the fit passes through the tops).
            let expected = segment_fraction(-5.0, 20.0);
            assert!((m.fill - expected).abs() < 0.03, "tilt {tilt}: fill {} vs {expected}", m.fill);
            assert_eq!(m.airborne_fraction, 0.0);
            assert_eq!(m.drive_torque, 2.0);
            // The top layer slides down at 1; deeper grains go up with the drum (ω r > 0).
            let first = &m.profile[0];
            assert!((first.velocity - 1.0).abs() < 1e-9 && first.count > 0, "{:?}", m.profile);
            let deep = m.profile.iter().filter(|b| b.depth > 6.0 && b.count > 0).collect::<Vec<_>>();
            assert!(!deep.is_empty() && deep.iter().all(|b| b.velocity < 0.0), "{:?}", m.profile);
        }
    }

    #[test]
    fn the_sense_of_rotation_mirrors_the_frame() {
        let (mut p, contacts, mut view) = bed(30.0, 2.0);
        // Mirror the bed (x -> -x) and turn the drum the other way: the same angles.
        for (x, v) in p.pos.iter_mut().zip(p.vel.iter_mut()) {
            x.x = -x.x;
            v.x = -v.x;
        }
        view.angular_velocity = -1.0;
        let m = measure_drum(2, &p, &contacts, &view);
        assert!((m.mass_angle - 30.0).abs() < 1.5, "{}", m.mass_angle);
        assert!((m.profile[0].velocity - 1.0).abs() < 1e-9);
    }

    #[test]
    fn segment_fractions() {
        assert!((segment_fraction(0.0, 1.0) - 0.5).abs() < 1e-12);
        assert!(segment_fraction(-1.0, 1.0).abs() < 1e-12);
        assert!((segment_fraction(1.0, 1.0) - 1.0).abs() < 1e-12);
        // Below y = -0.5 in a unit circle: (π/3 - sqrt(3)/4) / π.
        let expected = (std::f64::consts::PI / 3.0 - 3f64.sqrt() / 4.0) / std::f64::consts::PI;
        assert!((segment_fraction(-0.5, 1.0) - expected).abs() < 1e-12);
    }
}
