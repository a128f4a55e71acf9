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
//!   would be ([`super::contacts::rattlers`]): an aggregate's rough outline bears tangential
//!   load though its primaries slide freely. A grain's contacts with the walls count once per
//!   wall, the wall told by the axis and side its contacts face.
//! - **Shape**: the aspect ratio `sqrt(λ_max / λ_min)` of the primaries' second moments about
//!   the grain's centre of mass, each primary a uniform disk (ball) of its radius: the
//!   eigenvalues of `Σ m (d dᵀ + r²/4 I)` (`r²/5` for a ball), 1 for a round grain.
//! - **Stress** of a grain: `σ_g = (1 / A_g) Σ f ⊗ (x_c − x_g)` over the contacts its primaries
//!   have with other grains, walls and its own periodic images, `x_c` the contact point, `A_g`
//!   its area (volume); the sample holds the mean pressure `−tr σ_g / d` over the grains,
//!   weighted by area (volume) (Pa, compression positive).
//!
//! The area and shape of one grain are computed in `shape.rs`.

mod shape;
#[cfg(test)]
mod tests;

pub use shape::{grain_shape, GrainShape};

use serde::{Deserialize, Serialize};

use super::contacts::ContactRecord;
use crate::geometry::Domain;
use crate::math::{Real, Vec3};
use crate::particles::aggregate::NO_AGGREGATE;
use crate::particles::Particles;

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

/// The grains' measures of `p` in `dim` dimensions in a box of area (volume) `volume`, from the
/// `contacts` of the sample, or `None` if `p` has no aggregate. Across the periodic boundaries
/// of `domain` each grain is taken whole: its primaries at their images nearest its first one
/// (a grain less than half the period across).
pub fn measure_grains(p: &Particles, dim: usize, contacts: &[ContactRecord], volume: Real, domain: &Domain) -> Option<GrainSample> {
    let n = p.aggregate_count();
    if n == 0 {
        return None;
    }
    let members = grain_members(p, n);
    let d_min = 2.0 * members.iter().flatten().map(|&i| p.radius[i]).fold(Real::INFINITY, Real::min);
    let pos = whole_positions(p, &members, domain);
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

/// The primaries of each of the `n` grains, in order.
fn grain_members(p: &Particles, n: usize) -> Vec<Vec<usize>> {
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (i, &a) in p.aggregate.iter().enumerate() {
        if a != NO_AGGREGATE {
            if let Some(m) = members.get_mut(a as usize) {
                m.push(i);
            }
        }
    }
    members
}

/// Each primary where its grain is whole: at the image nearest the grain's first primary (a
/// copy only in a periodic box).
fn whole_positions<'a>(p: &'a Particles, members: &[Vec<usize>], domain: &Domain) -> std::borrow::Cow<'a, [Vec3]> {
    if domain.periodic.iter().any(|&q| q) {
        let mut pos = p.pos.clone();
        for m in members {
            let Some(&first) = m.first() else { continue };
            for &i in &m[1..] {
                pos[i] = p.pos[first] - domain.separation(&p.pos[first], &p.pos[i]).0;
            }
        }
        pos.into()
    } else {
        (&p.pos[..]).into()
    }
}

/// The mean coordination of the backbone of `n` grains whose force-bearing contacts are
/// `contacts` (a grain and another, or a wall), rattlers removed recursively as for frictional
/// particles (module documentation).
fn grain_backbone(n: usize, dim: usize, contacts: impl Iterator<Item = (u32, Option<u32>)>) -> Real {
    let records: Vec<ContactRecord> =
        contacts.map(|(i, j)| ContactRecord { i, j, force: Vec3::x(), branch: Vec3::zeros(), touching: true, bonded: false }).collect();
    super::contacts::coordination(n, super::contacts::rattler_threshold(dim, true), &records).1
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
