//! What the grains of the material point method look like now: each grain's centroid, mean
//! velocity, current area and shape, from its points; the smallest `det F`; the contacts
//! gathered per pair of grains and per grain and wall, as the shared metrics count them.

use super::grid::V2;
use super::system::System;
use crate::math::{Real, Vec3};
use crate::methods::soft::measure;
pub use crate::methods::soft::measure::GrainState;
use crate::observe::{ContactRecord, MaterialPoints};

/// Raster cells across a material point's initial side, for [`System::interpenetration`].
const RASTER_PER_SIDE: Real = 4.0;

impl System {
    /// Every grain's [`GrainState`]. Each point counts with its area and its own second moment,
    /// that of the parallelogram `F` makes of its square (`J V0 F Fᵀ s0² / 12`).
    pub fn grain_states(&self) -> Vec<GrainState> {
        let pts = &self.points;
        self.grains
            .iter()
            .map(|g| {
                let (mut m, mut mx, mut mv, mut area, mut ax) = (0.0, V2::zeros(), V2::zeros(), 0.0, V2::zeros());
                for p in g.points.clone() {
                    let a = pts.area(p);
                    m += pts.mass[p];
                    mx += pts.x[p] * pts.mass[p];
                    mv += pts.v[p] * pts.mass[p];
                    area += a;
                    ax += pts.x[p] * a;
                }
                let c = if area > 0.0 { ax / area } else { V2::zeros() };
                let mut second = nalgebra::Matrix2::<Real>::zeros();
                for p in g.points.clone() {
                    let a = pts.area(p);
                    let d = pts.x[p] - c;
                    let f = pts.f[p];
                    second += d * d.transpose() * a + f * f.transpose() * (a * pts.side0[p] * pts.side0[p] / 12.0);
                }
                let aspect_ratio = measure::aspect_ratio(&second);
                let (centroid, velocity) = if m > 0.0 { (mx / m, mv / m) } else { (c, V2::zeros()) };
                GrainState { centroid, velocity, mass: m, area, aspect_ratio }
            })
            .collect()
    }

    /// The points for drawing ([`MaterialPoints`]): each one's parallelogram, `det F`, the
    /// pressure and von Mises stress of its Cauchy stress `τ / J` (zero where the law is
    /// undefined: a snapshot never fails).
    pub fn material_points(&self) -> MaterialPoints {
        let pts = &self.points;
        let mut out = MaterialPoints::default();
        let v3 = |v: V2| Vec3::new(v.x, v.y, 0.0);
        for (g, grain) in self.grains.iter().enumerate() {
            let law = self.laws[grain.law].as_ref();
            for p in grain.points.clone() {
                let f = pts.f[p];
                out.grain.push(g as u32);
                out.corners.push(pts.parallelogram(p).map(v3));
                let j = f.determinant();
                out.jacobian.push(j);
                let (pressure, mises) = match law.response(&f, &pts.history[p]) {
                    Some(r) if j > 0.0 => {
                        let mean = r.tau.trace() / (3.0 * j);
                        let dev = (r.tau.norm_squared() / (j * j) - 3.0 * mean * mean).max(0.0);
                        (-mean, (1.5 * dev).sqrt())
                    }
                    _ => (0.0, 0.0),
                };
                out.pressure.push(pressure);
                out.mises.push(mises);
                out.velocity.push(v3(pts.v[p]));
            }
        }
        out
    }

    /// Smallest `det F` over the points (1 without any).
    pub fn min_jacobian(&self) -> Real {
        self.points.f.iter().map(|f| f.determinant()).fold(1.0, Real::min)
    }

    /// Mass (kg/m) and centre of mass (m) of all the points.
    pub fn center_of_mass(&self) -> (Real, V2) {
        let (mut m, mut mx) = (0.0, V2::zeros());
        for (x, &mp) in self.points.x.iter().zip(&self.points.mass) {
            m += mp;
            mx += x * mp;
        }
        (m, if m > 0.0 { mx / m } else { V2::zeros() })
    }

    /// The contacts of the last step as the metrics count them
    /// ([`crate::methods::soft::measure::contact_records`]); `grains` from
    /// [`System::grain_states`].
    pub fn contact_records(&self, grains: &[GrainState]) -> Vec<ContactRecord> {
        measure::contact_records(&self.contacts, self.walls.len(), grains, self.progress.last_dt())
    }

    /// The area the grains' outlines cover twice or outside the box `[lo, hi]`, m² per metre
    /// ([`crate::methods::soft::measure::interpenetration`]), on a raster of a quarter of the
    /// smallest initial point spacing.
    pub fn interpenetration(&self, lo: V2, hi: V2) -> Real {
        let side = self.points.side0.iter().copied().fold(Real::INFINITY, Real::min);
        let outlines: Vec<Vec<V2>> = self.grains.iter().map(|g| g.outline.positions(&self.points)).collect();
        measure::interpenetration(&outlines, side / RASTER_PER_SIDE, lo, hi)
    }
}
