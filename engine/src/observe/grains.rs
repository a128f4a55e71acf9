//! The measures at the scale of the grains when the grains are aggregates of primaries (the
//! bonded particle method, [`crate::particles::aggregate`]) or deformable grains (MPM, FEM):
//! [`GrainSample`] holds the grains' Φ, Z, pressure and shape, and the sample's own Φ and Z are
//! the grains'; for aggregates [`PrimarySample`] keeps the primaries' beside them.
//!
//! - **Area** of a grain (2D; its volume in 3D): the union of its primaries closed by a disk (a
//!   ball) of radius `h = d_min / 2` (half the smallest primary's diameter), with its holes filled:
//!   the pores between primaries inside the grain belong to it, the primaries on its outline bound
//!   it (the rule of Nezamabadi 2020, §2.1.3). Computed on a square grid of `d_min / 8` (a cubic
//!   one of `d_min / 4` in 3D: a lone ball comes out 1% too large at cells of a sixteenth of its
//!   radius, 0.4% at a thirty-second; a grain of the sources' primaries 1 mm across is about 60
//!   cells wide).
//! - **Periodic boxes**: a grain across a periodic boundary is taken whole, each primary at its
//!   image nearest the grain's first primary, grown at its centre: right while no primary
//!   lies more than half a period from it (validation asks a period of twice a grain at the
//!   start; a closing cell keeps it for round grains down to a period of one grain and a bit).
//! - **Coordination** between grains: pairs of aggregates with at least one force-bearing
//!   contact between their primaries; in a periodic box, pairs of a grain and an image of
//!   another (or of itself): in a cell two grains across, a grain may touch the same grain on
//!   both sides, two neighbours of the packing.
//! - **Rattlers** among grains: a grain with fewer than two force-bearing contacts with grains
//!   still in the backbone (walls included) is removed, recursively, as a frictional particle
//!   would be ([`super::metrics::rattlers`]): an aggregate's rough outline bears tangential
//!   load though its primaries slide freely. A grain's contacts with the walls count once per
//!   wall, the wall told by the axis and side its contacts face.
//! - **Shape**: the aspect ratio `sqrt(λ_max / λ_min)` of the primaries' second moments about
//!   the grain's centre of mass, each primary a uniform disk (ball) of its radius: the
//!   eigenvalues of `Σ m (d dᵀ + r²/4 I)` (`r²/5` for a ball), 1 for a round grain.
//! - **Stress** of a grain: `σ_g = (1 / A_g) Σ f ⊗ (x_c − x_g)` over the contacts its primaries
//!   have with other grains, walls and its own periodic images, `x_c` the contact point, `A_g`
//!   its area (volume); the sample holds the mean pressure `−tr σ_g / d` over the grains,
//!   weighted by area (volume) (Pa, compression positive).

use serde::{Deserialize, Serialize};

use super::metrics::ContactRecord;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::particles::aggregate::NO_AGGREGATE;
use crate::particles::Particles;

/// Grid cells across the smallest primary's diameter for a grain's area (2D) and volume (3D).
const CELLS_PER_PRIMARY: [Real; 2] = [8.0, 4.0];

/// The grains' own measures, in the same fields whatever the method: aggregates of primaries
/// ([`measure_grains`]) or deformable grains ([`measure_whole_grains`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct GrainSample {
    /// Number of grains.
    pub count: u64,
    /// Packing fraction of the grains: their areas (volumes in 3D: the closed union of their
    /// primaries, module documentation) over the box's.
    pub phi: f64,
    /// Mean coordination of the grains, `2 N_gg / N_g`, `N_gg` the pairs of grains in contact.
    pub z: f64,
    /// Mean coordination of the grains' backbone, rattlers removed recursively (module
    /// documentation). Samples stored before it was measured read 0.
    #[serde(default)]
    pub z_no_rattlers: f64,
    /// Mean pressure of the grains, weighted by area (volume in 3D), Pa.
    pub pressure: f64,
    /// Mean aspect ratio of the grains (1 for a round grain).
    pub mean_aspect_ratio: f64,
    /// Largest aspect ratio of a grain.
    pub max_aspect_ratio: f64,
    /// Mean area of a grain, m² (2D); its mean volume in 3D, m³.
    pub mean_area: f64,
}

impl GrainSample {
    /// The diameter of the disk (ball in 3D) of the grains' mean area (volume), m: the grains'
    /// size for an inertial number.
    pub fn mean_diameter(&self, dim: usize) -> Real {
        if dim == 3 {
            (6.0 * self.mean_area / std::f64::consts::PI).cbrt()
        } else {
            2.0 * (self.mean_area / std::f64::consts::PI).sqrt()
        }
    }
}

/// The primaries' own packing fraction and coordination when the grains are aggregates of
/// primaries (bonded particle method): the measures of every particle the method moves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PrimarySample {
    /// Packing fraction of the primaries: their disks' areas (balls' volumes) over the box's.
    pub phi: f64,
    /// Mean coordination of the primaries, `2 N_c / N` (within and between grains).
    pub z: f64,
    /// Mean coordination of the primaries' backbone, rattlers removed recursively.
    pub z_no_rattlers: f64,
}

/// One grain's measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainShape {
    /// Area, m² (volume in 3D, m³).
    pub area: Real,
    /// Centre of mass of its primaries, m.
    pub centre: Vec3,
    /// Aspect ratio.
    pub aspect_ratio: Real,
}

/// The grains' measures of `p` in `dim` dimensions in a box of area (volume) `volume`, from the
/// `contacts` of the sample, or `None` if `p` has no aggregate. Across the periodic boundaries
/// of `domain` each grain is taken whole: its primaries at their images nearest its first one
/// (a grain less than half the period across).
pub fn measure_grains(p: &Particles, dim: usize, contacts: &[ContactRecord], volume: Real, domain: &Domain) -> Option<GrainSample> {
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
    // Each primary where its grain is whole (a copy only in a periodic box).
    let pos: std::borrow::Cow<[Vec3]> = if domain.periodic.iter().any(|&q| q) {
        let mut pos = p.pos.clone();
        for m in &members {
            let Some(&first) = m.first() else { continue };
            for &i in &m[1..] {
                pos[i] = p.pos[first] - domain.separation(&p.pos[first], &p.pos[i]).0;
            }
        }
        pos.into()
    } else {
        (&p.pos[..]).into()
    };
    let shapes: Vec<GrainShape> = members.iter().map(|m| grain_shape(p, &pos, dim, m, d_min)).collect();
    let grain_of = |i: u32| p.aggregate.get(i as usize).copied().filter(|&a| a != NO_AGGREGATE);
    let mut pairs: Vec<(u32, u32, [i64; 3])> = Vec::new();
    let mut walls: Vec<(u32, usize, bool)> = Vec::new();
    let mut moment = vec![0.0; n];
    for c in contacts.iter().filter(|c| c.bears_load()) {
        let (a, b) = (grain_of(c.i), c.j.and_then(grain_of));
        let i = c.i as usize;
        // The contact point: on the line of centres (`branch` = x_i − x_j) at i's radius, or
        // `branch` from a wall; from i's place in its grain, and from j's in its own. `image`:
        // the periods between the copy of j's grain the contact touches and the one where that
        // grain is whole (none in a walled box).
        let (at_i, at_j, image) = match c.j {
            Some(j) => {
                let share = p.radius[i] / (p.radius[i] + p.radius[j as usize]);
                let image = periods(domain, &(pos[i] - pos[j as usize] - c.branch));
                (pos[i] - c.branch * share, pos[j as usize] + c.branch * (1.0 - share), image)
            }
            None => (pos[i] - c.branch, Vec3::zeros(), [0; 3]),
        };
        if a == b && (a.is_none() || image == [0; 3]) {
            // Within one grain, or between particles of no grain. A grain pressed against its
            // own periodic image (a cell less than two grains across) is a contact between grains.
            continue;
        }
        // f ⊗ (x_c − x_g) traced: the force on i dotted with its lever from its grain's centre;
        // the force on j, −f, likewise from j's.
        if let Some(a) = a {
            moment[a as usize] += c.force.dot(&(at_i - shapes[a as usize].centre));
        }
        if let Some(b) = b {
            moment[b as usize] -= c.force.dot(&(at_j - shapes[b as usize].centre));
        }
        match (a, b, c.j) {
            (Some(a), Some(b), _) => pairs.push(grain_pair(a, b, image)),
            (Some(a), None, None) => walls.push((a, c.branch.iamax(), c.branch[c.branch.iamax()] > 0.0)),
            _ => {}
        }
    }
    // One pair per two grains in contact, and per image: in a cell two grains across, a grain
    // touches another on both sides (two neighbours of the packing, one pair each).
    pairs.sort_unstable();
    pairs.dedup();
    walls.sort_unstable();
    walls.dedup();
    let z_no_rattlers = grain_backbone(n, dim, pairs.iter().map(|&(a, b, _)| (a, Some(b))).chain(walls.iter().map(|&(a, ..)| (a, None))));
    let area: Real = shapes.iter().map(|s| s.area).sum();
    // p_g = −tr σ_g / d: the contact forces press inward, against the lever.
    let pressure = if area > 0.0 { -moment.iter().sum::<Real>() / (dim as Real * area) } else { 0.0 };
    let aspects = shapes.iter().map(|s| s.aspect_ratio);
    Some(GrainSample {
        count: n as u64,
        phi: if volume > 0.0 { area / volume } else { 0.0 },
        z: 2.0 * pairs.len() as Real / n as Real,
        z_no_rattlers,
        pressure,
        mean_aspect_ratio: aspects.clone().sum::<Real>() / n as Real,
        max_aspect_ratio: aspects.fold(1.0, Real::max),
        mean_area: area / n as Real,
    })
}

/// The mean coordination of the backbone of `n` grains whose force-bearing contacts are
/// `contacts` (a grain and another, or a wall), rattlers removed recursively as for frictional
/// particles (module documentation).
fn grain_backbone(n: usize, dim: usize, contacts: impl Iterator<Item = (u32, Option<u32>)>) -> Real {
    let records: Vec<ContactRecord> =
        contacts.map(|(i, j)| ContactRecord { i, j, force: Vec3::x(), branch: Vec3::zeros(), touching: true, bonded: false }).collect();
    super::metrics::coordination(n, super::metrics::rattler_threshold(dim, true), &records).1
}

/// The grains' measures when every particle of `p` is a grain (deformable grains, measured as
/// disks or spheres of their current area or volume), in the same fields as aggregates':
/// `shape` the grains' mean and largest aspect ratios, `z_no_rattlers` the backbone's
/// coordination the sample measured. The pressure is that of
/// [`measure_grains`], `−Σ_g Σ_c f·(x_c − x_g) / (D Σ A_g)`, which for grains with one centre
/// each is `Σ_c f·ℓ_c / (D Σ A_g)` over the load-bearing contacts, `ℓ_c` their branch vectors
/// (grain to grain, or wall contact point to grain).
pub fn measure_whole_grains(
    p: &Particles,
    dim: usize,
    contacts: &[ContactRecord],
    volume: Real,
    shape: (Real, Real),
    z_no_rattlers: Real,
) -> GrainSample {
    let n = p.len();
    let area: Real = p.radius.iter().map(|&r| Particles::volume_of(dim, r)).sum();
    let mut pairs: Vec<(u32, u32)> = Vec::new();
    let mut virial = 0.0;
    for c in contacts.iter().filter(|c| c.bears_load()) {
        virial += c.force.dot(&c.branch);
        if let Some(j) = c.j.filter(|&j| j != c.i) {
            pairs.push((c.i.min(j), c.i.max(j)));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    GrainSample {
        count: n as u64,
        phi: if volume > 0.0 { area / volume } else { 0.0 },
        z: if n > 0 { 2.0 * pairs.len() as Real / n as Real } else { 0.0 },
        z_no_rattlers,
        pressure: if area > 0.0 { virial / (dim as Real * area) } else { 0.0 },
        mean_aspect_ratio: shape.0,
        max_aspect_ratio: shape.1,
        mean_area: if n > 0 { area / n as Real } else { 0.0 },
    }
}

/// The whole periods (along x, y, z) of a lattice vector `shift` of `domain` (Lees-Edwards: a
/// period along y also shifts x by the offset); 0 along an axis that is not periodic.
fn periods(domain: &Domain, shift: &Vec3) -> [i64; 3] {
    let mut k = [0; 3];
    let mut s = *shift;
    if domain.periodic[1] {
        k[1] = (s.y / domain.length(1)).round() as i64;
        s.x -= k[1] as Real * domain.le_offset;
    }
    for a in [0, 2] {
        if domain.periodic[a] {
            k[a] = (s[a] / domain.length(a)).round() as i64;
        }
    }
    k
}

/// The pair of grains `a` and `b`, the copy of `b` at `image` periods from `a`'s, in one form
/// whichever grain comes first (a grain and its own image: either sign of the image).
fn grain_pair(a: u32, b: u32, image: [i64; 3]) -> (u32, u32, [i64; 3]) {
    let negative = image.map(|k| -k);
    match a.cmp(&b) {
        std::cmp::Ordering::Less => (a, b, image),
        std::cmp::Ordering::Greater => (b, a, negative),
        std::cmp::Ordering::Equal => (a, a, image.max(negative)),
    }
}

/// Area (volume in 3D), centre and aspect ratio of the grain made of primaries `members` of
/// `p` at positions `pos` (the grain whole) in `dim` dimensions (module documentation), `d_min`
/// the smallest primary's diameter.
pub fn grain_shape(p: &Particles, pos: &[Vec3], dim: usize, members: &[usize], d_min: Real) -> GrainShape {
    let mass: Real = members.iter().map(|&i| p.mass[i]).sum();
    if members.is_empty() || mass <= 0.0 {
        return GrainShape { area: 0.0, centre: Vec3::zeros(), aspect_ratio: 1.0 };
    }
    let centre = members.iter().fold(Vec3::zeros(), |s, &i| s + pos[i] * p.mass[i]) / mass;
    let aspect_ratio = if dim == 2 {
        // The in-plane second moments: Σ m (d d^T) plus each disk's own m r²/4 per axis.
        let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
        for &i in members {
            let d = pos[i] - centre;
            let own = 0.25 * p.mass[i] * p.radius[i] * p.radius[i];
            xx += p.mass[i] * d.x * d.x + own;
            yy += p.mass[i] * d.y * d.y + own;
            xy += p.mass[i] * d.x * d.y;
        }
        let (mean, half) = (0.5 * (xx + yy), (0.25 * (xx - yy) * (xx - yy) + xy * xy).sqrt());
        if mean - half > 0.0 {
            ((mean + half) / (mean - half)).sqrt()
        } else {
            Real::INFINITY
        }
    } else {
        // Σ m (d d^T) plus each ball's own m r²/5 per axis.
        let mut moments = nalgebra::Matrix3::<Real>::zeros();
        for &i in members {
            let d = pos[i] - centre;
            moments += d * d.transpose() * p.mass[i] + nalgebra::Matrix3::identity() * (0.2 * p.mass[i] * p.radius[i] * p.radius[i]);
        }
        let eigen = moments.symmetric_eigenvalues();
        let (lo, hi) = (eigen.min(), eigen.max());
        if lo > 0.0 {
            (hi / lo).sqrt()
        } else {
            Real::INFINITY
        }
    };
    GrainShape { area: closed_measure(p, pos, dim, members, d_min), centre, aspect_ratio }
}

/// Points spread evenly on the circle (2D) or sphere (3D) of radius `rho` about `x`, about
/// `spacing` apart (a golden-angle spiral on the sphere).
fn surface_points(x: Vec3, rho: Real, dim: usize, spacing: Real) -> impl Iterator<Item = Vec3> {
    let tau = std::f64::consts::TAU;
    let count =
        if dim == 2 { (tau * rho / spacing).ceil() } else { (2.0 * tau * rho * rho / (spacing * spacing)).ceil() }.max(1.0) as usize;
    let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    (0..count).map(move |k| {
        if dim == 2 {
            let angle = tau * k as Real / count as Real;
            Vec3::new(x.x + rho * angle.cos(), x.y + rho * angle.sin(), x.z)
        } else {
            let z = 1.0 - (2.0 * k as Real + 1.0) / count as Real;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let angle = golden * k as Real;
            x + Vec3::new(s * angle.cos(), s * angle.sin(), z) * rho
        }
    })
}

/// Area (2D) or volume (3D) of the union of the primaries `members` closed by a disk (ball) of
/// radius `d_min / 2`, holes filled, on a grid of `d_min / CELLS_PER_PRIMARY` (a cell belongs
/// if its centre does).
fn closed_measure(p: &Particles, pos: &[Vec3], dim: usize, members: &[usize], d_min: Real) -> Real {
    let cell = d_min / CELLS_PER_PRIMARY[usize::from(dim == 3)];
    let reach = 0.5 * d_min;
    let (mut lo, mut hi) = (Vec3::repeat(Real::INFINITY), Vec3::repeat(Real::NEG_INFINITY));
    for &i in members {
        let r = p.radius[i] + reach;
        for a in 0..dim {
            lo[a] = lo[a].min(pos[i][a] - r);
            hi[a] = hi[a].max(pos[i][a] + r);
        }
    }
    // A frame of empty cells around the dilated grain (one layer of cells in 2D, at z = 0).
    let mut origin = lo - Vec3::new(2.0 * cell, 2.0 * cell, 2.0 * cell);
    let count = |a: usize| ((hi[a] - lo[a]) / cell).ceil() as usize + 4;
    let (nx, ny) = (count(0), count(1));
    let nz = if dim == 3 {
        count(2)
    } else {
        origin.z = -0.5 * cell;
        1
    };
    let n = [nx, ny, nz];
    let centre_of = |ix: usize, iy: usize, iz: usize| {
        Vec3::new(origin.x + (ix as Real + 0.5) * cell, origin.y + (iy as Real + 0.5) * cell, origin.z + (iz as Real + 0.5) * cell)
    };
    // Cells within `radius` of the point x: their index ranges, per axis (end excluded).
    let span = |x: &Vec3, radius: Real| {
        let k = |v: Real, o: Real, n: usize| (((v - o) / cell - 0.5).floor().max(0.0) as usize).min(n - 1);
        let range = |a: usize| {
            if a >= dim {
                0..1
            } else {
                k(x[a] - radius, origin[a], n[a])..(k(x[a] + radius, origin[a], n[a]) + 2).min(n[a])
            }
        };
        (range(0), range(1), range(2))
    };
    let flat = |ix: usize, iy: usize, iz: usize| (iz * ny + iy) * nx + ix;
    // Dilation: cells within r + h of a primary's centre.
    let mut dilated = vec![false; nx * ny * nz];
    for &i in members {
        let (x, r) = (pos[i], p.radius[i] + reach);
        let (rx, ry, rz) = span(&x, r + cell);
        for iz in rz {
            for iy in ry.clone() {
                for ix in rx.clone() {
                    if (centre_of(ix, iy, iz) - x).norm_squared() <= r * r {
                        dilated[flat(ix, iy, iz)] = true;
                    }
                }
            }
        }
    }
    // Erosion: a dilated cell stays unless a point of the dilated set's boundary lies within
    // h of it. The boundary is sampled exactly, every `cell` along each dilated circle (over
    // each dilated sphere) where no other covers it (cell centres outside the set would place
    // it up to a cell too far out: 20% too much area for a lone disk at r/4 cells).
    let mut closed = dilated;
    let bin = 2.0 * members.iter().map(|&i| p.radius[i]).fold(0.0, Real::max) + 2.0 * reach;
    let key = |x: &Vec3| {
        let k = |a: usize| if a < dim { ((x[a] - origin[a]) / bin).floor() as i64 } else { 0 };
        (k(0), k(1), k(2))
    };
    let mut bins: std::collections::HashMap<(i64, i64, i64), Vec<usize>> = std::collections::HashMap::new();
    for &i in members {
        bins.entry(key(&pos[i])).or_default().push(i);
    }
    let reach2 = reach * reach;
    let layers: i64 = if dim == 3 { 1 } else { 0 };
    for &i in members {
        for q in surface_points(pos[i], p.radius[i] + reach, dim, cell) {
            let (bx, by, bz) = key(&q);
            let covered = (-layers..=layers).any(|dz| {
                (-1..=1).any(|dy| {
                    (-1..=1).any(|dx| {
                        bins.get(&(bx + dx, by + dy, bz + dz)).is_some_and(|list| {
                            list.iter().any(|&j| {
                                let r = p.radius[j] + reach;
                                j != i && (pos[j] - q).norm_squared() < r * r
                            })
                        })
                    })
                })
            });
            if covered {
                continue;
            }
            let (rx, ry, rz) = span(&q, reach + cell);
            for jz in rz {
                for jy in ry.clone() {
                    for jx in rx.clone() {
                        if (centre_of(jx, jy, jz) - q).norm_squared() <= reach2 {
                            closed[flat(jx, jy, jz)] = false;
                        }
                    }
                }
            }
        }
    }
    // Holes: outside cells the frame cannot reach (through faces) belong to the grain.
    let mut outside = vec![false; nx * ny * nz];
    let mut stack = vec![0usize];
    outside[0] = true;
    while let Some(k) = stack.pop() {
        let (ix, iy, iz) = (k % nx, (k / nx) % ny, k / (nx * ny));
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
        if iz > 0 {
            visit(k - nx * ny);
        }
        if iz + 1 < nz {
            visit(k + nx * ny);
        }
    }
    outside.iter().filter(|&&o| !o).count() as Real * cell.powi(dim as i32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::aggregate::Bonding;

    fn grain(primaries: &[(Real, Real, Real)]) -> Particles {
        grain_in(2, &primaries.iter().map(|&(x, y, r)| (Vec3::new(x, y, 0.0), r)).collect::<Vec<_>>())
    }

    /// A walled box in `dim` dimensions (no periodic image).
    fn walled(dim: usize) -> Domain {
        Domain { dim, lo: Vec3::repeat(-10.0), hi: Vec3::repeat(10.0), periodic: [false; 3], shear_rate: 0.0, le_offset: 0.0 }
    }

    /// A 2D box from the origin, `length` long and periodic along x, 10 high and walled along y.
    fn periodic_along_x(length: Real) -> Domain {
        Domain {
            dim: 2,
            lo: Vec3::zeros(),
            hi: Vec3::new(length, 10.0, 0.0),
            periodic: [true, false, false],
            shear_rate: 0.0,
            le_offset: 0.0,
        }
    }

    /// One grain in `dim` dimensions of the primaries at these centres and radii.
    fn grain_in(dim: usize, primaries: &[(Vec3, Real)]) -> Particles {
        let mut p = Particles::default();
        for &(x, r) in primaries {
            p.push(dim, x, Vec3::zeros(), r, 1000.0, 0, false);
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
        let shape = grain_shape(&square, &square.pos, 2, &[0, 1, 2, 3], 2.0);
        let pi = std::f64::consts::PI;
        assert!(shape.area > 4.0 + 3.0 * pi && shape.area < 12.0 + pi, "area {}", shape.area);
        assert!((shape.aspect_ratio - 1.0).abs() < 1e-12);
        let mut ring = vec![(0.0, 0.0, 1.0)];
        ring.extend((0..6).map(|k| {
            let a = k as Real * pi / 3.0;
            (2.0 * a.cos(), 2.0 * a.sin(), 1.0)
        }));
        let hex = grain(&ring);
        let s = grain_shape(&hex, &hex.pos, 2, &(0..7).collect::<Vec<_>>(), 2.0);
        assert!((s.aspect_ratio - 1.0).abs() < 1e-12, "aspect {}", s.aspect_ratio);
        // Two disks in a row: the second moments 2·(1)² + 2·(1/4) against 2·(1/4).
        let pair = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
        let s = grain_shape(&pair, &pair.pos, 2, &[0, 1], 2.0);
        assert!((s.aspect_ratio - 5.0f64.sqrt()).abs() < 1e-12, "aspect {}", s.aspect_ratio);
    }

    /// Makes the second primary of `p` a grain of its own and returns the contact of the two
    /// pressed together by F = 3 along x (centres 2 apart).
    fn into_two_grains(p: &mut Particles) -> ContactRecord {
        p.aggregate[1] = 1;
        let bond = p.bondings[0];
        p.bondings.push(bond);
        ContactRecord {
            i: 0,
            j: Some(1),
            force: Vec3::new(-3.0, 0.0, 0.0),
            branch: Vec3::new(-2.0, 0.0, 0.0),
            touching: true,
            bonded: false,
        }
    }

    /// Two one-disk grains of radius 1 squeezed against each other by F = 3 along x: Z = 1 and
    /// the grains' pressure `−Σ f·(x_c − x_g) / (2 ΣA) = 2F / (2 ΣA)` (each disk's force times
    /// its radius); a contact without force counts for neither.
    #[test]
    fn two_grains_in_contact_share_a_pair_and_a_pressure() {
        let mut p = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0)]);
        let pressed = into_two_grains(&mut p);
        let idle = ContactRecord { force: Vec3::zeros(), ..pressed };
        let g = measure_grains(&p, 2, &[pressed, idle], 100.0, &walled(2)).expect("grains");
        assert_eq!((g.count, g.z), (2, 1.0));
        let area = 2.0 * g.mean_area;
        assert!((g.pressure - 3.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 3.0 / area);
        assert!((g.phi - area / 100.0).abs() < 1e-15);
        let g = measure_grains(&p, 2, &[idle], 100.0, &walled(2)).expect("grains");
        assert_eq!((g.z, g.pressure), (0.0, 0.0));
    }

    /// Three grains on a floor (a walled box's y_min: contacts facing +y): grain 0 (two
    /// primaries) touches only the floor, through both primaries; grains 1 and 2 (one primary
    /// each) press on each other and on the floor. Z over the three is 2/3; grain 0's two wall
    /// contacts are one wall, too few to keep it (a grain needs two), so the backbone is grains 1
    /// and 2 and its coordination 1. Counting each wall contact apart would keep grain 0 (2/3).
    #[test]
    fn a_grain_on_one_wall_alone_is_a_rattler() {
        let mut p = grain(&[(0.0, 1.0, 1.0), (2.0, 1.0, 1.0), (6.0, 1.0, 1.0), (8.0, 1.0, 1.0)]);
        let bond = p.bondings[0];
        p.bondings.extend([bond, bond]);
        p.aggregate[2] = 1;
        p.aggregate[3] = 2;
        let floor = |i: u32| ContactRecord {
            i,
            j: None,
            force: Vec3::new(0.0, 1.0, 0.0),
            branch: Vec3::new(0.0, 1.0, 0.0),
            touching: true,
            bonded: false,
        };
        let between = ContactRecord {
            i: 2,
            j: Some(3),
            force: Vec3::new(-1.0, 0.0, 0.0),
            branch: Vec3::new(-2.0, 0.0, 0.0),
            touching: true,
            bonded: false,
        };
        let g = measure_grains(&p, 2, &[floor(0), floor(1), floor(2), floor(3), between], 100.0, &walled(2)).expect("grains");
        assert!((g.z - 2.0 / 3.0).abs() < 1e-15, "Z {}", g.z);
        assert_eq!(g.z_no_rattlers, 1.0);
        // A second wall (x_min: contacts facing +x) keeps grain 0 in the backbone.
        let side = ContactRecord { branch: Vec3::new(1.0, 0.0, 0.0), force: Vec3::new(1.0, 0.0, 0.0), ..floor(0) };
        let g = measure_grains(&p, 2, &[floor(0), floor(1), side, floor(2), floor(3), between], 100.0, &walled(2)).expect("grains");
        assert!((g.z_no_rattlers - 2.0 / 3.0).abs() < 1e-15, "Z without rattlers {}", g.z_no_rattlers);
    }

    /// A sample of aggregates ([`super::super::metrics::measure`]) reports the grains' Φ and Z
    /// in its own fields, the same as its `grains` block, and the primaries' beside them: two
    /// grains of two disks of radius 1 in a box of area 100, pressed by one contact, each
    /// grain's own primaries bonded. The primaries' Φ is their disks' area, 4π / 100, their Z
    /// counts the bonds (3 pairs over 4 disks); the grains' Φ is larger (closed outlines) and
    /// their Z is 1.
    #[test]
    fn a_sample_of_aggregates_reports_its_grains_and_its_primaries() {
        let mut p = grain(&[(0.0, 0.0, 1.0), (2.0, 0.0, 1.0), (4.0, 0.0, 1.0), (6.0, 0.0, 1.0)]);
        let bond = p.bondings[0];
        p.bondings.push(bond);
        p.aggregate[2] = 1;
        p.aggregate[3] = 1;
        let pair = |i: u32, bonded: bool| ContactRecord {
            i,
            j: Some(i + 1),
            force: Vec3::new(-1.0, 0.0, 0.0),
            branch: Vec3::new(-2.0, 0.0, 0.0),
            touching: true,
            bonded,
        };
        let contacts = [pair(0, true), pair(1, false), pair(2, true)];
        let domain = walled(2);
        let view = super::super::metrics::SystemView {
            dim: 2,
            step: 0,
            time: 0.0,
            particles: &p,
            volume: 100.0,
            contacts: &contacts,
            walls: &[],
            shear: None,
            elastic_energy: 0.0,
            rattler_threshold: 3,
            drum: None,
            deformable: None,
            domain: &domain,
        };
        let s = super::super::metrics::measure(&view);
        let g = s.grains.as_deref().copied().expect("grains");
        let primaries = s.primaries.expect("primaries");
        assert_eq!((s.phi, s.z, s.z_no_rattlers), (g.phi, g.z, g.z_no_rattlers));
        assert_eq!((g.count, g.z), (2, 1.0));
        assert!((primaries.phi - 4.0 * std::f64::consts::PI / 100.0).abs() < 1e-15 && primaries.z == 1.5, "{primaries:?}");
        assert!(g.phi > primaries.phi * 1.05, "the grains' outline closes their pores: {} against {}", g.phi, primaries.phi);
    }

    /// One disk alone: closing changes nothing, the area is `π r²` within the grid's error
    /// (cells of r/32, as a grain of 1.6 mm has with primaries of 0.1 mm: under 1%).
    #[test]
    fn a_lone_disk_keeps_its_area() {
        let one = grain(&[(0.3, -0.2, 1.0)]);
        let s = grain_shape(&one, &one.pos, 2, &[0], 0.25);
        let exact = std::f64::consts::PI;
        assert!((s.area - exact).abs() < 0.01 * exact, "area {} against {exact}", s.area);
    }

    /// In 3D: one ball alone keeps its volume `4/3 π r³` within 1.5% (cells of r/16: measured
    /// +2.8%, +1.0% and +0.4% at r/8, r/16 and r/32, about a tenth of a cell too far out); six balls of
    /// radius 1 touching a seventh at the centre along the axes make a round grain (aspect
    /// ratio 1 within 1e-12) whose volume lies between the union's `7 · 4/3 π` and the cube
    /// that holds them, its pores closed; two balls in a row have the aspect ratio
    /// `sqrt((2 + 2/5) / (2/5)) = sqrt(6)`; two one-ball grains pressed by F = 3 have Z = 1 and
    /// the pressure `2F / (3 ΣV)`.
    #[test]
    fn in_3d_a_grain_has_its_volume_and_shape() {
        let ball = 4.0 / 3.0 * std::f64::consts::PI;
        let one = grain_in(3, &[(Vec3::new(0.3, -0.2, 0.1), 1.0)]);
        let s = grain_shape(&one, &one.pos, 3, &[0], 0.25);
        assert!((s.area - ball).abs() < 0.015 * ball, "volume {} against {ball}", s.area);
        let mut seven = vec![(Vec3::zeros(), 1.0)];
        for a in 0..3 {
            for sign in [-2.0, 2.0] {
                let mut x = Vec3::zeros();
                x[a] = sign;
                seven.push((x, 1.0));
            }
        }
        let cluster = grain_in(3, &seven);
        let s = grain_shape(&cluster, &cluster.pos, 3, &(0..7).collect::<Vec<_>>(), 2.0);
        assert!((s.aspect_ratio - 1.0).abs() < 1e-12, "aspect {}", s.aspect_ratio);
        // Bounded above by the cube of side 6 that holds the seven.
        assert!(s.area > 7.0 * ball && s.area < 216.0, "volume {}", s.area);
        let pair = grain_in(3, &[(Vec3::zeros(), 1.0), (Vec3::new(2.0, 0.0, 0.0), 1.0)]);
        let s = grain_shape(&pair, &pair.pos, 3, &[0, 1], 2.0);
        assert!((s.aspect_ratio - 6.0f64.sqrt()).abs() < 1e-12, "aspect {}", s.aspect_ratio);
        let mut p = pair;
        let pressed = into_two_grains(&mut p);
        let g = measure_grains(&p, 3, &[pressed], 1000.0, &walled(3)).expect("grains");
        assert_eq!((g.count, g.z), (2, 1.0));
        let volume = 2.0 * g.mean_area;
        assert!((g.pressure - 6.0 / (3.0 * volume)).abs() < 1e-12 * g.pressure, "pressure {}", g.pressure);
    }

    /// A grain across a periodic boundary is measured whole: a ring of seven disks about
    /// x = 0 in a box periodic along x from 0 to 10, its primaries left of the boundary at their
    /// images near x = 10, has the area (within a few grid cells) and aspect ratio it has inside
    /// the box about x = 5; and two one-disk grains pressed across the boundary share a pair and
    /// the pressure they have inside.
    #[test]
    fn a_grain_across_a_periodic_boundary_is_measured_whole() {
        let pi = std::f64::consts::PI;
        let ring = |x0: f64| {
            let mut r = vec![(Vec3::new(x0, 5.0, 0.0), 1.0)];
            r.extend((0..6).map(|k| {
                let a = k as Real * pi / 3.0 + 0.3;
                (Vec3::new((x0 + 2.0 * a.cos()).rem_euclid(10.0), 5.0 + 2.0 * a.sin(), 0.0), 1.0)
            }));
            grain_in(2, &r)
        };
        let periodic = periodic_along_x(10.0);
        let inside = measure_grains(&ring(5.0), 2, &[], 100.0, &periodic).expect("grains");
        let across = measure_grains(&ring(0.0), 2, &[], 100.0, &periodic).expect("grains");
        // The grid's cells fall differently by round-off: within a few cells (of 1/16 each).
        assert!((across.mean_area - inside.mean_area).abs() < 0.005 * inside.mean_area, "{across:?} against {inside:?}");
        assert!((across.max_aspect_ratio - inside.max_aspect_ratio).abs() < 1e-9, "{across:?} against {inside:?}");
        // Walled, the same primaries make a grain split in two far apart: no longer round.
        let split = measure_grains(&ring(0.0), 2, &[], 100.0, &walled(2)).expect("grains");
        assert!(split.max_aspect_ratio > 2.0, "{split:?}");
        // Two one-disk grains at x = 9.5 and 1.5 (2 apart through the boundary), pressed by F = 3.
        let mut p = grain(&[(9.5, 5.0, 1.0), (1.5, 5.0, 1.0)]);
        let pressed = into_two_grains(&mut p);
        let g = measure_grains(&p, 2, &[pressed], 100.0, &periodic).expect("grains");
        let area = 2.0 * g.mean_area;
        assert_eq!(g.z, 1.0);
        assert!((g.pressure - 3.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 3.0 / area);
    }

    /// In a cell a grain or two across, the contacts with an image count as contacts between
    /// grains. Along x, period 4:
    ///
    /// - a grain of two disks of radius 1 at x = 1 and 2.9, pressed by F = 3 against its own
    ///   image (its second disk against the first's image at x = 5) has Z = 2 (a neighbour on
    ///   each side) and the pressure of Love–Weber across the cell, `F L / (2 A)`; before, this
    ///   contact counted as one inside the grain: no load, no neighbour;
    /// - two one-disk grains at x = 1 and 3, pressed by F = 3 on both sides (directly and
    ///   through the boundary), make two pairs (Z = 2, not 1) and twice one contact's pressure.
    #[test]
    fn a_grain_pressed_against_its_own_image_in_a_small_cell_is_loaded() {
        let cell = periodic_along_x(4.0);
        let long = grain(&[(1.0, 5.0, 1.0), (2.9, 5.0, 1.0)]);
        let inside = ContactRecord {
            i: 0,
            j: Some(1),
            force: Vec3::new(1.0, 0.0, 0.0),
            branch: Vec3::new(-1.9, 0.0, 0.0),
            touching: true,
            bonded: true,
        };
        let against_image = ContactRecord {
            i: 1,
            j: Some(0),
            force: Vec3::new(-3.0, 0.0, 0.0),
            branch: Vec3::new(-2.1, 0.0, 0.0),
            touching: true,
            bonded: false,
        };
        let g = measure_grains(&long, 2, &[inside, against_image], 40.0, &cell).expect("grains");
        assert_eq!((g.count, g.z), (1, 2.0));
        assert!((g.pressure - 3.0 * 4.0 / (2.0 * g.mean_area)).abs() < 1e-12 * g.pressure, "pressure {}", g.pressure);
        let alone = measure_grains(&long, 2, &[inside], 40.0, &cell).expect("grains");
        assert_eq!((alone.z, alone.pressure), (0.0, 0.0));

        let mut p = grain(&[(1.0, 5.0, 1.0), (3.0, 5.0, 1.0)]);
        let direct = into_two_grains(&mut p);
        let through = ContactRecord { force: Vec3::new(3.0, 0.0, 0.0), branch: Vec3::new(2.0, 0.0, 0.0), ..direct };
        let g = measure_grains(&p, 2, &[direct, through], 40.0, &cell).expect("grains");
        let area = 2.0 * g.mean_area;
        assert_eq!(g.z, 2.0);
        assert!((g.pressure - 6.0 / area).abs() < 1e-12 * g.pressure, "pressure {} against {}", g.pressure, 6.0 / area);
        // The same contact twice is one pair.
        assert_eq!(measure_grains(&p, 2, &[direct, direct], 40.0, &cell).expect("grains").z, 1.0);
    }
}
