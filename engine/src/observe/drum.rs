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
//! The experiment's result, averaged over the samples of the rotation, with its flow regime,
//! is in `results/drum.rs`.
//! The frames, the surface fit and the profile of one sample are in `drum_surface.rs`.

use serde::{Deserialize, Serialize};

use super::contacts::ContactRecord;
use super::drum_surface::{fit_surface, load_bearing, mass_centroid, velocity_profile, DrumFrame, SurfaceFrame};
pub use super::drum_surface::{DrumView, ProfileBin, PROFILE_STRIP, SURFACE_SPAN};
use crate::math::Real;
use crate::particles::Particles;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

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
