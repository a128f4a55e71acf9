//! The geometry of a drum's sample: the drum as the methods show it ([`DrumView`]), the frames
//! of the cross-section and of the free surface, the grains that bear a load, the bed's
//! centroid, the fitted surface and the velocity profile across it (`drum::measure_drum` puts
//! them together).

use serde::{Deserialize, Serialize};

use super::contacts::ContactRecord;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

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

/// The drum's cross-section: `h` across the drum (towards the side where the bed rises), `u`
/// up, from its axis.
pub(super) struct DrumFrame {
    /// A point of the drum's axis.
    center: Vec3,
    /// The drum's axis.
    axis: usize,
    /// Unit vector across the drum, towards the rising side.
    e_h: Vec3,
    /// Unit vector up.
    e_up: Vec3,
}

impl DrumFrame {
    /// The cross-section frame of the drum `d`.
    pub(super) fn new(d: &DrumView) -> Self {
        let mut e_axis = Vec3::zeros();
        e_axis[d.axis] = 1.0;
        // The bed rises towards +h: the drum's surface moves up on that side.
        let sense = if d.angular_velocity < 0.0 { -1.0 } else { 1.0 };
        let e_h = e_axis.cross(&d.down) * sense;
        let e_up = -d.down;
        Self { center: d.center, axis: d.axis, e_h, e_up }
    }

    /// Coordinates `(h, u)` of a point.
    pub(super) fn at(&self, x: &Vec3) -> (Real, Real) {
        let mut r = x - self.center;
        r[self.axis] = 0.0;
        (r.dot(&self.e_h), r.dot(&self.e_up))
    }
}

/// The frame of the surface: `s` along it (rising), `w` across it (up, out of the bed).
pub(super) struct SurfaceFrame<'a> {
    /// The drum's cross-section.
    pub(super) drum: &'a DrumFrame,
    /// Direction along the surface, in `(h, u)`.
    pub(super) t: (Real, Real),
    /// Direction across the surface, in `(h, u)`.
    pub(super) nrm: (Real, Real),
}

impl SurfaceFrame<'_> {
    /// Coordinates `(s, w)` of a point.
    pub(super) fn at(&self, x: &Vec3) -> (Real, Real) {
        let (h, u) = self.drum.at(x);
        (h * self.t.0 + u * self.t.1, h * self.nrm.0 + u * self.nrm.1)
    }

    /// Component of a velocity up the slope (along `s`).
    pub(super) fn up_slope(&self, v: &Vec3) -> Real {
        let (vh, vu) = (v.dot(&self.drum.e_h), v.dot(&self.drum.e_up));
        vh * self.t.0 + vu * self.t.1
    }
}

/// The free surface fitted through the tops of the grains.
pub(super) struct SurfaceFit {
    /// Angle of the fitted line, degrees.
    pub(super) surface_angle: Option<Real>,
    /// Angle of the upper half, degrees.
    pub(super) upper_angle: Option<Real>,
    /// Angle of the lower half, degrees.
    pub(super) lower_angle: Option<Real>,
    /// Height of the surface at mid-chord (not finite when no grain is near it).
    pub(super) surface_w: Real,
    /// The fitted line `w = a + b s`.
    pub(super) line: Option<(Real, Real)>,
}

/// Which of the `n` particles bear a load through a contact.
pub(super) fn load_bearing(n: usize, contacts: &[ContactRecord]) -> Vec<bool> {
    let mut touching = vec![false; n];
    for c in contacts.iter().filter(|c| c.bears_load()) {
        touching[c.i as usize] = true;
        if let Some(j) = c.j {
            touching[j as usize] = true;
        }
    }
    touching
}

/// The grains' volume-weighted centroid `(h, u)` in the drum's cross-section.
pub(super) fn mass_centroid(dim: usize, p: &Particles, frame: &DrumFrame) -> (Real, Real) {
    let (mut vol, mut ch, mut cu) = (0.0, 0.0, 0.0);
    for k in 0..p.len() {
        let v = Particles::volume_of(dim, p.radius[k]);
        let (h, u) = frame.at(&p.pos[k]);
        vol += v;
        ch += v * h;
        cu += v * u;
    }
    if vol > 0.0 {
        ch /= vol;
        cu /= vol;
    }
    (ch, cu)
}

/// Fits the free surface through the highest grain tops `(s, w)` in bins along the chord: a
/// first guess of its height at mid-chord, then the line and its two halves.
pub(super) fn fit_surface(tops: &[(Real, Real)], theta: Real, mean_d: Real, radius: Real) -> SurfaceFit {
    let w0 = tops.iter().filter(|(s, _)| s.abs() < 2.0 * mean_d).map(|x| x.1).fold(Real::NEG_INFINITY, Real::max);
    let mut out = SurfaceFit { surface_angle: None, upper_angle: None, lower_angle: None, surface_w: w0, line: None };
    if !(w0.is_finite() && w0.abs() < radius && mean_d > 0.0) {
        return out;
    }
    let half = SURFACE_SPAN * (radius * radius - w0 * w0).sqrt();
    let width = 2.0 * mean_d;
    let bins = ((2.0 * half / width).floor() as usize).max(1);
    let mut top = vec![Real::NEG_INFINITY; bins];
    for &(s, w) in tops {
        if s.abs() < half {
            let b = (((s + half) / width) as usize).min(bins - 1);
            top[b] = top[b].max(w);
        }
    }
    let points: Vec<(Real, Real)> =
        top.iter().enumerate().filter(|(_, w)| w.is_finite()).map(|(b, &w)| (-half + (b as Real + 0.5) * width, w)).collect();
    let deg = |slope: Real| (theta + slope.atan()).to_degrees();
    if let Some((a, b)) = fit(&points) {
        out.surface_angle = Some(deg(b));
        out.surface_w = a;
        out.line = Some((a, b));
    }
    let lower: Vec<(Real, Real)> = points.iter().copied().filter(|p| p.0 < 0.0).collect();
    let upper: Vec<(Real, Real)> = points.iter().copied().filter(|p| p.0 >= 0.0).collect();
    out.lower_angle = fit(&lower).map(|(_, b)| deg(b));
    out.upper_angle = fit(&upper).map(|(_, b)| deg(b));
    out
}

/// Velocity profile along the mid-chord normal, from the surface down to the wall of a drum of
/// radius `radius`: the mean velocity down the slope of the load-bearing grains, in bins a mean
/// diameter deep.
pub(super) fn velocity_profile(
    p: &Particles,
    touching: &[bool],
    surface: &SurfaceFrame,
    surface_w: Real,
    mean_d: Real,
    radius: Real,
) -> Vec<ProfileBin> {
    let depth_max = surface_w + radius;
    let bins = (depth_max / mean_d).ceil().max(0.0) as usize;
    let mut sum = vec![0.0; bins];
    let mut count = vec![0u64; bins];
    for k in (0..p.len()).filter(|&k| touching[k]) {
        let (s, w) = surface.at(&p.pos[k]);
        let depth = surface_w - w;
        if s.abs() > PROFILE_STRIP * mean_d || depth < 0.0 {
            continue;
        }
        if bins == 0 {
            continue;
        }
        let b = ((depth / mean_d) as usize).min(bins - 1);
        // Down the slope is -t.
        sum[b] -= surface.up_slope(&p.vel[k]);
        count[b] += 1;
    }
    (0..bins)
        .map(|b| ProfileBin {
            depth: (b as Real + 0.5) * mean_d,
            velocity: if count[b] > 0 { sum[b] / count[b] as Real } else { 0.0 },
            count: count[b],
        })
        .collect()
}

/// Least-squares line `w = a + b s` through points; `None` with fewer than two distinct `s`.
fn fit(points: &[(Real, Real)]) -> Option<(Real, Real)> {
    let n = points.len() as Real;
    if points.len() < 2 {
        return None;
    }
    let (ms, mw) = points.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |a, p| (a.0 + (p.0 - ms).powi(2), a.1 + (p.0 - ms) * (p.1 - mw)));
    (sxx > 0.0).then(|| {
        let b = sxy / sxx;
        (mw - b * ms, b)
    })
}
