//! The measures at the scale of the grains when the grains are aggregates of primaries (the
//! bonded particle method, [`crate::particles::aggregate`]): the sample's own Φ, Z and stress
//! are those of the primaries; [`GrainSample`] holds the grains'.
//!
//! - **Area** of a grain (2D): the union of its primaries closed by a disk of radius
//!   `h = d_min / 2` (half the smallest primary's diameter), with its holes filled: the pores
//!   between primaries inside the grain belong to it, the primaries on its outline bound it
//!   (the sources' rule, N 2.1.3). Computed on a square grid of `d_min / 8`.
//! - **Coordination** between grains: pairs of aggregates with at least one force-bearing
//!   contact between their primaries.
//! - **Shape**: the aspect ratio `sqrt(λ_max / λ_min)` of the primaries' inertia tensor about
//!   the grain's centre of mass (1 for a round grain).
//! - **Stress** of a grain: `σ_g = (1 / A_g) Σ f ⊗ (x_c − x_g)` over the contacts its primaries
//!   have with other grains and walls, `x_c` the contact point; the sample holds the mean
//!   pressure over the grains, weighted by area (Pa, compression positive).

use serde::{Deserialize, Serialize};

use super::metrics::ContactRecord;
use crate::math::{Real, Vec3};
use crate::particles::aggregate::NO_AGGREGATE;
use crate::particles::Particles;

/// Grid cells across the smallest primary's diameter for a grain's area.
const CELLS_PER_PRIMARY: Real = 8.0;

/// The grains' own measures (scenes whose grains are aggregates of primaries).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct GrainSample {
    /// Number of grains (aggregates).
    pub count: u64,
    /// Packing fraction of the grains: their areas (the closed union of their primaries, module
    /// documentation) over the box's.
    pub phi: f64,
    /// Mean coordination of the grains, `2 N_gg / N_g`, `N_gg` the pairs of grains in contact.
    pub z: f64,
    /// Mean pressure of the grains, weighted by area, Pa.
    pub pressure: f64,
    /// Mean aspect ratio of the grains (1 for a round grain).
    pub mean_aspect_ratio: f64,
    /// Largest aspect ratio of a grain.
    pub max_aspect_ratio: f64,
    /// Mean area of a grain, m² (2D).
    pub mean_area: f64,
}

/// One grain's measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainShape {
    /// Area, m².
    pub area: Real,
    /// Centre of mass of its primaries, m.
    pub centre: Vec3,
    /// Aspect ratio.
    pub aspect_ratio: Real,
}

/// The grains' measures of `p` (2D) in a box of area `volume`, from the `contacts` of the sample,
/// or `None` if `p` has no aggregate.
pub fn measure_grains(p: &Particles, contacts: &[ContactRecord], volume: Real) -> Option<GrainSample> {
    let n = p.aggregate_count();
    if n == 0 {
        return None;
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, &a) in p.aggregate.iter().enumerate() {
        if a != NO_AGGREGATE {
            if let Some(m) = members.get_mut(a as usize) {
                m.push(i);
            }
        }
    }
    let d_min = 2.0 * members.iter().flatten().map(|&i| p.radius[i]).fold(Real::INFINITY, Real::min);
    let shapes: Vec<GrainShape> = members.iter().map(|m| grain_shape(p, m, d_min)).collect();
    let grain_of = |i: u32| p.aggregate.get(i as usize).copied().filter(|&a| a != NO_AGGREGATE);
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut moment = vec![0.0; n];
    for c in contacts.iter().filter(|c| c.bears_load()) {
        let (a, b) = (grain_of(c.i), c.j.and_then(grain_of));
        if a == b {
            // Within one grain, or between particles of no grain.
            continue;
        }
        let xi = p.pos[c.i as usize];
        // The contact point: on the line of centres at i's radius, or `branch` from a wall.
        let point = match c.j {
            Some(j) => xi - c.branch * (p.radius[c.i as usize] / (p.radius[c.i as usize] + p.radius[j as usize])),
            None => xi - c.branch,
        };
        // f ⊗ (x_c − x_g) traced: the force on i dotted with its lever from its grain's centre;
        // the force on j, −f, likewise from j's.
        if let Some(a) = a {
            moment[a as usize] += c.force.dot(&(point - shapes[a as usize].centre));
        }
        if let Some(b) = b {
            moment[b as usize] -= c.force.dot(&(point - shapes[b as usize].centre));
        }
        if let (Some(a), Some(b)) = (a, b) {
            pairs.push((a.min(b), a.max(b)));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    let area: Real = shapes.iter().map(|s| s.area).sum();
    // p_g = −tr σ_g / 2: the contact forces press inward, against the lever.
    let pressure = if area > 0.0 { -moment.iter().sum::<Real>() / (2.0 * area) } else { 0.0 };
    let aspects = shapes.iter().map(|s| s.aspect_ratio);
    Some(GrainSample {
        count: n as u64,
        phi: if volume > 0.0 { area / volume } else { 0.0 },
        z: 2.0 * pairs.len() as Real / n as Real,
        pressure,
        mean_aspect_ratio: aspects.clone().sum::<Real>() / n as Real,
        max_aspect_ratio: aspects.fold(1.0, Real::max),
        mean_area: area / n as Real,
    })
}

/// Area, centre and aspect ratio of the grain made of primaries `members` of `p` (module
/// documentation), `d_min` the smallest primary's diameter.
pub fn grain_shape(p: &Particles, members: &[usize], d_min: Real) -> GrainShape {
    let mass: Real = members.iter().map(|&i| p.mass[i]).sum();
    if members.is_empty() || mass <= 0.0 {
        return GrainShape { area: 0.0, centre: Vec3::zeros(), aspect_ratio: 1.0 };
    }
    let centre = members.iter().fold(Vec3::zeros(), |s, &i| s + p.pos[i] * p.mass[i]) / mass;
    // The inertia tensor's in-plane part: Σ m (d d^T) plus each disk's own m r²/4 per axis.
    let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
    for &i in members {
        let d = p.pos[i] - centre;
        let own = 0.25 * p.mass[i] * p.radius[i] * p.radius[i];
        xx += p.mass[i] * d.x * d.x + own;
        yy += p.mass[i] * d.y * d.y + own;
        xy += p.mass[i] * d.x * d.y;
    }
    let (mean, half) = (0.5 * (xx + yy), (0.25 * (xx - yy) * (xx - yy) + xy * xy).sqrt());
    let aspect_ratio = if mean - half > 0.0 { ((mean + half) / (mean - half)).sqrt() } else { Real::INFINITY };
    GrainShape { area: closed_area(p, members, d_min), centre, aspect_ratio }
}

/// Area of the union of the primaries `members` closed by a disk of radius `d_min / 2`, holes
/// filled, on a grid of `d_min / CELLS_PER_PRIMARY` (a cell belongs if its centre does).
fn closed_area(p: &Particles, members: &[usize], d_min: Real) -> Real {
    let cell = d_min / CELLS_PER_PRIMARY;
    let reach = 0.5 * d_min;
    let (mut lo, mut hi) = (Vec3::repeat(Real::INFINITY), Vec3::repeat(Real::NEG_INFINITY));
    for &i in members {
        let r = p.radius[i] + reach;
        for a in 0..2 {
            lo[a] = lo[a].min(p.pos[i][a] - r);
            hi[a] = hi[a].max(p.pos[i][a] + r);
        }
    }
    // A frame of empty cells around the dilated grain.
    let origin = lo - Vec3::new(2.0 * cell, 2.0 * cell, 0.0);
    let nx = ((hi.x - lo.x) / cell).ceil() as usize + 4;
    let ny = ((hi.y - lo.y) / cell).ceil() as usize + 4;
    let centre_of = |ix: usize, iy: usize| (origin.x + (ix as Real + 0.5) * cell, origin.y + (iy as Real + 0.5) * cell);
    // Cells within `radius` of the point (x, y): their index ranges.
    let span = |x: Real, y: Real, radius: Real| {
        let k = |v: Real, o: Real, n: usize| (((v - o) / cell - 0.5).floor().max(0.0) as usize).min(n - 1);
        (k(x - radius, origin.x, nx), k(x + radius, origin.x, nx) + 1, k(y - radius, origin.y, ny), k(y + radius, origin.y, ny) + 1)
    };
    // Dilation: cells within r + h of a primary's centre.
    let mut dilated = vec![false; nx * ny];
    for &i in members {
        let (x, y, r) = (p.pos[i].x, p.pos[i].y, p.radius[i] + reach);
        let (x0, x1, y0, y1) = span(x, y, r + cell);
        for iy in y0..(y1 + 1).min(ny) {
            for ix in x0..(x1 + 1).min(nx) {
                let (cx, cy) = centre_of(ix, iy);
                if (cx - x).powi(2) + (cy - y).powi(2) <= r * r {
                    dilated[iy * nx + ix] = true;
                }
            }
        }
    }
    // Erosion: a dilated cell stays unless a point of the dilated set's boundary lies within
    // h of it. The boundary is sampled exactly, every `cell` along each dilated circle where no
    // other covers it (cell centres outside the set would place it up to a cell too far out:
    // 20% too much area for a lone disk at r/4 cells).
    let mut closed = dilated;
    let bin = 2.0 * members.iter().map(|&i| p.radius[i]).fold(0.0, Real::max) + 2.0 * reach;
    let key = |x: Real, y: Real| (((x - origin.x) / bin).floor() as i64, ((y - origin.y) / bin).floor() as i64);
    let mut bins: std::collections::HashMap<(i64, i64), Vec<usize>> = std::collections::HashMap::new();
    for &i in members {
        bins.entry(key(p.pos[i].x, p.pos[i].y)).or_default().push(i);
    }
    let reach2 = reach * reach;
    for &i in members {
        let (x, y, rho) = (p.pos[i].x, p.pos[i].y, p.radius[i] + reach);
        let samples = (std::f64::consts::TAU * rho / cell).ceil() as usize;
        for k in 0..samples {
            let angle = std::f64::consts::TAU * k as Real / samples as Real;
            let (qx, qy) = (x + rho * angle.cos(), y + rho * angle.sin());
            let (bx, by) = key(qx, qy);
            let covered = (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    bins.get(&(bx + dx, by + dy)).is_some_and(|list| {
                        list.iter().any(|&j| {
                            let r = p.radius[j] + reach;
                            j != i && (p.pos[j].x - qx).powi(2) + (p.pos[j].y - qy).powi(2) < r * r
                        })
                    })
                })
            });
            if covered {
                continue;
            }
            let (x0, x1, y0, y1) = span(qx, qy, reach + cell);
            for jy in y0..(y1 + 1).min(ny) {
                for jx in x0..(x1 + 1).min(nx) {
                    let (ex, ey) = centre_of(jx, jy);
                    if (ex - qx).powi(2) + (ey - qy).powi(2) <= reach2 {
                        closed[jy * nx + jx] = false;
                    }
                }
            }
        }
    }
    // Holes: outside cells the frame cannot reach (4-connected) belong to the grain.
    let mut outside = vec![false; nx * ny];
    let mut stack = vec![0usize];
    outside[0] = true;
    while let Some(k) = stack.pop() {
        let (ix, iy) = (k % nx, k / nx);
        let mut visit = |j: usize| {
            if !closed[j] && !outside[j] {
                outside[j] = true;
                stack.push(j);
            }
        };
        if ix > 0 {
            visit(k - 1);
        }
        if ix + 1 < nx {
            visit(k + 1);
        }
        if iy > 0 {
            visit(k - nx);
        }
        if iy + 1 < ny {
            visit(k + nx);
        }
    }
    outside.iter().filter(|&&o| !o).count() as Real * cell * cell
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::aggregate::Bonding;

    fn grain(primaries: &[(Real, Real, Real)]) -> Particles {
        let mut p = Particles::default();
        for &(x, y, r) in primaries {
            p.push(2, Vec3::new(x, y, 0.0), Vec3::zeros(), r, 1000.0, 0, false);
            if let Some(a) = p.aggregate.last_mut() {
                *a = 0;
            }
        }
        p.bondings
            .push(Bonding { attraction: crate::contact::attraction_lj::AttractionLj { f0: 1.0, gamma: 7.0, cutoff: 1.0 }, friction: 0.0 });
        p
    }

    /// A square of four touching disks of radius 1: the closing by h = 1 fills the pore between
    /// them (area of the union `4π` plus the pore `4 − π`) and rounds the outline's four
    /// re-entrant notches, so the area lies between `4 + 3π` and the convex hull's `4 + 8 + π`;
    /// on a hexagonal ring of seven disks the grain is round (aspect ratio 1 within 1e-12).
    #[test]
    fn a_grain_area_closes_its_pores_and_its_shape_is_round() {
        let square = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0), (0.0, 2.0, 1.0), (2.0, 2.0, 1.0)]);
        let shape = grain_shape(&square, &[0, 1, 2, 3], 2.0);
        let pi = std::f64::consts::PI;
        assert!(shape.area > 4.0 + 3.0 * pi && shape.area < 12.0 + pi, "area {}", shape.area);
        assert!((shape.aspect_ratio - 1.0).abs() < 1e-12);
        let mut ring = vec![(0.0, 0.0, 1.0)];
        ring.extend((0..6).map(|k| {
            let a = k as Real * pi / 3.0;
            (2.0 * a.cos(), 2.0 * a.sin(), 1.0)
        }));
        let hex = grain(&ring);
        let s = grain_shape(&hex, &(0..7).collect::<Vec<_>>(), 2.0);
        assert!((s.aspect_ratio - 1.0).abs() < 1e-12, "aspect {}", s.aspect_ratio);
        // Two disks in a row: the second moments 2·(1)² + 2·(1/4) against 2·(1/4).
        let pair = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
        let s = grain_shape(&pair, &[0, 1], 2.0);
        assert!((s.aspect_ratio - 5.0f64.sqrt()).abs() < 1e-12, "aspect {}", s.aspect_ratio);
    }

    /// Two one-disk grains of radius 1 squeezed against each other by F = 3 along x: Z = 1 and
    /// the grains' pressure `−Σ f·(x_c − x_g) / (2 ΣA) = 2F / (2 ΣA)` (each disk's force times
    /// its radius); a contact without force counts for neither.
    #[test]
    fn two_grains_in_contact_share_a_pair_and_a_pressure() {
        let mut p = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
        p.aggregate[1] = 1;
        let bond = p.bondings[0];
        p.bondings.push(bond);
        let pressed = ContactRecord {
            i: 0,
            j: Some(1),
            force: Vec3::new(-3.0, 0.0, 0.0),
            branch: Vec3::new(-2.0, 0.0, 0.0),
            touching: true,
            bonded: false,
        };
        let idle = ContactRecord { force: Vec3::zeros(), ..pressed };
        let g = measure_grains(&p, &[pressed, idle], 100.0).expect("grains");
        assert_eq!((g.count, g.z), (2, 1.0));
        let area = 2.0 * g.mean_area;
        assert!((g.pressure - 3.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 3.0 / area);
        assert!((g.phi - area / 100.0).abs() < 1e-15);
        let g = measure_grains(&p, &[idle], 100.0).expect("grains");
        assert_eq!((g.z, g.pressure), (0.0, 0.0));
    }

    /// One disk alone: closing changes nothing, the area is `π r²` within the grid's error
    /// (cells of r/32, as a grain of 1.6 mm has with primaries of 0.1 mm: under 1%).
    #[test]
    fn a_lone_disk_keeps_its_area() {
        let one = grain(&[(0.3, -0.2, 1.0)]);
        let s = grain_shape(&one, &[0], 0.25);
        let exact = std::f64::consts::PI;
        assert!((s.area - exact).abs() < 0.01 * exact, "area {} against {exact}", s.area);
    }
}
