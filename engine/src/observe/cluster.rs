//! The wet grains' cluster: grains held together, directly or through others, by capillary
//! bridges. Its size, bridges, the wet grains outside it and its shape are what the studies of
//! an agglomerate follow as it elongates, loses bridges and is eroded in a shear flow (Vo,
//! Nezamabadi, Mutabaruka, Delenne & Radjai, "Evolution of wet agglomerates inside inertial
//! shear flow of dry granules", Physical Review E 101, 2020) or grows in a drum (Vo, Mutabaruka,
//! Nezamabadi, Delenne & Radjai, "Combined effects of particle size ratio and friction on
//! granule growth in a rotating drum", European Physical Journal E 42:127, 2019);
//! docs/physics.md §8.
//!
//! The cluster followed is the largest at the first sample with a bridge; at each later sample
//! it is the cluster holding the most of the grains it held at the one before (the larger on a
//! tie), so that a granule is followed as it grows, sheds grains or splits, and the grains that
//! joined it (accretion) and left it (erosion) between samples are counted separately
//! ([`ClusterTrack`]). Grains that join and leave between two samples are not seen.
//!
//! The cluster's shape is measured by its gyration tensor: the volume-weighted second moment
//! of its grains about their centre, each grain counted as the uniform disk (ball) it is. A
//! uniform ellipse (ellipsoid) of semi-axes `a_k` has the principal moments `a_k² / (D + 2)`,
//! so the cluster's semi-axes are reported as `sqrt((D + 2) λ_k)`: a packed disk of grains
//! reads as a disk of about its outer radius. Positions are followed from grain to grain along
//! the bridges' branch vectors, so a cluster across a periodic boundary is measured whole.

use nalgebra::{Matrix3, SymmetricEigen};
use serde::{Deserialize, Serialize};

use super::contacts::ContactRecord;
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// The wet grains' cluster held by capillary bridges and followed from sample to sample (module
/// documentation), in a sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ClusterSample {
    /// Wet grains.
    pub wet: u64,
    /// Grains of the followed cluster: wet grains joined, directly or through others, by
    /// capillary bridges (a lone wet grain is a cluster of one).
    pub count: u64,
    /// Bridges between grains of the followed cluster.
    pub bridges: u64,
    /// Wet grains outside the followed cluster (for an agglomerate: those it lost, or never
    /// held).
    pub outside: u64,
    /// Clusters of two grains or more, the followed one included.
    pub clusters: u64,
    /// Grains of the largest cluster (the followed one's count unless it split or another
    /// outgrew it).
    #[serde(default)]
    pub largest: u64,
    /// Grains that joined the followed cluster since it was first followed, counted at each
    /// sample (accretion, `N⁺`).
    #[serde(default)]
    pub accreted: u64,
    /// Grains that left it since then (erosion, `N⁻`): `count` is its first count plus
    /// `accreted` minus `eroded`.
    #[serde(default)]
    pub eroded: u64,
    /// Semi-axes of the followed cluster, longest first, m: `sqrt((D + 2) λ_k)` of its gyration
    /// tensor's eigenvalues `λ_k` (module documentation).
    pub axes: Vec<f64>,
    /// Elongation of the followed cluster, `a_1 / a_D − 1` (longest over shortest semi-axis,
    /// minus one): 0 for a round cluster.
    pub elongation: f64,
}

/// What following the cluster carries from one sample to the next (and across a checkpoint:
/// [`crate::resume::Carried`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClusterTrack {
    /// The followed cluster's grains at the last sample, in increasing order (particle indices
    /// in the run's order); empty before the first sample.
    pub members: Vec<u32>,
    /// Grains that joined it since it was first followed.
    pub accreted: u64,
    /// Grains that left it since it was first followed.
    pub eroded: u64,
}

impl ClusterTrack {
    /// Nothing followed yet.
    pub fn is_empty(&self) -> bool {
        self.members.is_empty() && self.accreted == 0 && self.eroded == 0
    }
}

/// Measures the wet grains' clusters from the bonded pair records among `contacts`, following
/// the cluster of `track` (module documentation) and updating it; `None` when no grain is wet.
pub(crate) fn measure_cluster(p: &Particles, dim: usize, contacts: &[ContactRecord], track: &mut ClusterTrack) -> Option<ClusterSample> {
    let n = p.len();
    let wet = p.wet.iter().filter(|&&w| w).count();
    if wet == 0 || p.wet.len() != n {
        return None;
    }
    // The bridges: bonded pairs of two wet grains, as (i, j, r_i - r_j).
    let bridges: Vec<(usize, usize, Vec3)> = contacts
        .iter()
        .filter(|c| c.bonded)
        .filter_map(|c| c.j.map(|j| (c.i as usize, j as usize, c.branch)))
        .filter(|&(i, j, _)| i < n && j < n && i != j && p.wet[i] && p.wet[j])
        .collect();
    let mut sets = DisjointSets::new(n);
    for &(i, j, _) in &bridges {
        sets.join(i, j);
    }
    let mut size = vec![0usize; n];
    for i in (0..n).filter(|&i| p.wet[i]) {
        size[sets.root(i)] += 1;
    }
    let clusters = size.iter().filter(|&&s| s >= 2).count();
    // The largest cluster, the one of the lowest-numbered grain among equals.
    let (mut largest_root, mut largest) = (usize::MAX, 0);
    for i in (0..n).filter(|&i| p.wet[i]) {
        let r = sets.root(i);
        if size[r] > largest {
            (largest_root, largest) = (r, size[r]);
        }
    }
    // The followed cluster: the one holding most of the last sample's members, the larger on
    // a tie (then the lower root); the largest at the first sample.
    let mut held = vec![0usize; n];
    for &m in track.members.iter().filter(|&&m| (m as usize) < n && p.wet[m as usize]) {
        held[sets.root(m as usize)] += 1;
    }
    // Before the first bridge there is nothing to follow yet (a granule placed with its grains
    // touching is bridged at the first force evaluation, after the first sample).
    let started = !track.members.is_empty() || largest >= 2;
    let mut best = largest_root;
    if !track.members.is_empty() {
        let key = |r: usize| (held[r], size[r], std::cmp::Reverse(r));
        best = (0..n).filter(|&r| held[r] > 0).max_by_key(|&r| key(r)).unwrap_or(largest_root);
    }
    let members: Vec<usize> = (0..n).filter(|&i| p.wet[i] && sets.root(i) == best).collect();
    if !track.members.is_empty() {
        let now: Vec<u32> = members.iter().map(|&i| i as u32).collect();
        let (joined, left) = differences(&track.members, &now);
        track.accreted += joined;
        track.eroded += left;
    }
    if started {
        track.members = members.iter().map(|&i| i as u32).collect();
    }
    let count = members.len();
    let inside: Vec<(usize, usize, Vec3)> = bridges.into_iter().filter(|&(i, _, _)| sets.root(i) == best).collect();
    let positions = unwrapped(p, &members, &inside);
    let axes = semi_axes(p, dim, &members, &positions);
    let elongation = match (axes.first(), axes.last()) {
        (Some(&a), Some(&b)) if b > 0.0 => a / b - 1.0,
        _ => 0.0,
    };
    Some(ClusterSample {
        wet: wet as u64,
        count: count as u64,
        bridges: inside.len() as u64,
        outside: (wet - count) as u64,
        clusters: clusters as u64,
        largest: largest as u64,
        accreted: track.accreted,
        eroded: track.eroded,
        axes,
        elongation,
    })
}

/// The grains in `now` and not in `before`, and those in `before` and not in `now` (both lists
/// in increasing order).
fn differences(before: &[u32], now: &[u32]) -> (u64, u64) {
    let (mut a, mut b) = (0, 0);
    let (mut joined, mut left) = (0, 0);
    while a < before.len() || b < now.len() {
        match (before.get(a), now.get(b)) {
            (Some(x), Some(y)) if x == y => (a, b) = (a + 1, b + 1),
            (Some(x), Some(y)) if x < y => (a, left) = (a + 1, left + 1),
            (Some(_), Some(_)) | (None, Some(_)) => (b, joined) = (b + 1, joined + 1),
            (Some(_), None) => (a, left) = (a + 1, left + 1),
            (None, None) => break,
        }
    }
    (joined, left)
}

/// The positions of the cluster's `members`, followed from the first along the `bridges`
/// (`r_i − r_j` each), so that no periodic image splits it; indexed like `members`.
fn unwrapped(p: &Particles, members: &[usize], bridges: &[(usize, usize, Vec3)]) -> Vec<Vec3> {
    let index = |i: usize| members.binary_search(&i).ok();
    let mut links: Vec<Vec<(usize, Vec3)>> = vec![Vec::new(); members.len()];
    for &(i, j, d) in bridges {
        if let (Some(a), Some(b)) = (index(i), index(j)) {
            links[a].push((b, -d));
            links[b].push((a, d));
        }
    }
    let mut pos: Vec<Option<Vec3>> = vec![None; members.len()];
    let mut stack = Vec::new();
    if let Some(&first) = members.first() {
        pos[0] = Some(p.pos[first]);
        stack.push(0);
    }
    while let Some(a) = stack.pop() {
        let Some(x) = pos[a] else { continue };
        for &(b, step) in &links[a] {
            if pos[b].is_none() {
                pos[b] = Some(x + step);
                stack.push(b);
            }
        }
    }
    // A cluster is connected: every member was reached (a lone grain is its own start).
    pos.into_iter().zip(members).map(|(x, &i)| x.unwrap_or(p.pos[i])).collect()
}

/// The semi-axes of the grains `members` at `positions`, longest first (module documentation).
fn semi_axes(p: &Particles, dim: usize, members: &[usize], positions: &[Vec3]) -> Vec<Real> {
    let weight = |i: usize| Particles::volume_of(dim, p.radius[i]);
    let total: Real = members.iter().map(|&i| weight(i)).sum();
    if total <= 0.0 {
        return vec![0.0; dim];
    }
    let centre = members.iter().zip(positions).map(|(&i, x)| x * weight(i)).sum::<Vec3>() / total;
    let d = dim as Real;
    let mut g = Matrix3::zeros();
    for (&i, x) in members.iter().zip(positions) {
        let r = x - centre;
        let own = p.radius[i] * p.radius[i] / (d + 2.0);
        g += (r * r.transpose() + Matrix3::identity() * own) * weight(i);
    }
    g /= total;
    let block = g.view((0, 0), (dim, dim)).clone_owned();
    let mut axes: Vec<Real> = SymmetricEigen::new(block).eigenvalues.iter().map(|&l| ((d + 2.0) * l.max(0.0)).sqrt()).collect();
    axes.sort_by(|a, b| b.total_cmp(a));
    axes
}

/// Union-find over grain indices, with path halving.
struct DisjointSets {
    parent: Vec<usize>,
}

impl DisjointSets {
    fn new(n: usize) -> Self {
        Self { parent: (0..n).collect() }
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    fn join(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.root(a), self.root(b));
        if ra != rb {
            // The lower index roots the set: the result does not depend on the order of joins.
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi] = lo;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grains(dim: usize, at: &[Vec3], r: Real, wet: &[bool]) -> Particles {
        let mut p = Particles::default();
        for (x, &w) in at.iter().zip(wet) {
            p.push(dim, *x, Vec3::zeros(), r, 1000.0, 0, w);
        }
        p
    }

    fn bridge(p: &Particles, i: u32, j: u32) -> ContactRecord {
        let branch = p.pos[i as usize] - p.pos[j as usize];
        ContactRecord { i, j: Some(j), force: Vec3::zeros(), branch, touching: true, bonded: true }
    }

    /// A row of `k` touching disks of radius r bridged in a chain: a rod of length 2kr and
    /// width 2r. Its gyration along the row is that of the k disks, `r² ((k² − 1)/3 + 1/4)`,
    /// so the long semi-axis is `2r sqrt((k² − 1)/3 + 1/4)`, the short one `r`.
    #[test]
    fn a_row_of_bridged_disks_is_as_long_as_its_gyration_says() {
        let (r, k) = (1e-3, 9usize);
        let at: Vec<Vec3> = (0..k).map(|m| Vec3::new(2.0 * r * m as Real, 0.0, 0.0)).collect();
        let p = grains(2, &at, r, &vec![true; k]);
        let contacts: Vec<_> = (0..k as u32 - 1).map(|m| bridge(&p, m, m + 1)).collect();
        let c = measure_cluster(&p, 2, &contacts, &mut ClusterTrack::default()).expect("wet grains");
        let long = 2.0 * r * (((k * k - 1) as Real) / 3.0 + 0.25).sqrt();
        assert_eq!((c.count, c.bridges, c.outside, c.clusters), (9, 8, 0, 1));
        assert!((c.axes[0] - long).abs() < 1e-12 * long, "{:?} against {long}", c.axes);
        assert!((c.axes[1] - r).abs() < 1e-12 * r, "{:?}", c.axes);
        assert!((c.elongation - (long / r - 1.0)).abs() < 1e-9);
    }

    /// A hexagonal patch of bridged disks is round: its elongation is that of the lattice's
    /// facets only, and both semi-axes come out near its outer radius.
    #[test]
    fn a_hexagonal_patch_is_round() {
        let r = 1e-3;
        let mut at = Vec::new();
        for a in -3i32..=3 {
            for b in -3i32..=3 {
                let x = Vec3::new(2.0 * r * (a as Real + 0.5 * b as Real), 2.0 * r * (b as Real) * (0.75f64).sqrt(), 0.0);
                if x.norm() <= 6.0 * r + 1e-12 {
                    at.push(x);
                }
            }
        }
        let p = grains(2, &at, r, &vec![true; at.len()]);
        let mut contacts = Vec::new();
        for i in 0..at.len() {
            for j in i + 1..at.len() {
                if (at[i] - at[j]).norm() < 2.0 * r * 1.001 {
                    contacts.push(bridge(&p, i as u32, j as u32));
                }
            }
        }
        let c = measure_cluster(&p, 2, &contacts, &mut ClusterTrack::default()).expect("wet grains");
        assert_eq!(c.count as usize, at.len());
        assert!(c.elongation < 1e-9, "elongation {}", c.elongation);
        assert!(c.axes[0] > 6.0 * r && c.axes[0] < 7.0 * r, "{:?}", c.axes);
    }

    /// Erosion counted by hand: eight wet grains, of which five form the agglomerate, two
    /// left it as a pair, one alone; dry grains and a bridge to a dry grain do not count; a
    /// touching wet pair without a bridge is not joined.
    #[test]
    fn the_grains_an_agglomerate_lost_are_counted_outside_it() {
        let r = 1e-3;
        let at: Vec<Vec3> = (0..11).map(|m| Vec3::new(3.0 * r * m as Real, 0.0, 0.0)).collect();
        let wet = [true, true, true, true, true, true, true, true, false, false, false];
        let p = grains(3, &at, r, &wet);
        let mut contacts = vec![bridge(&p, 0, 1), bridge(&p, 1, 2), bridge(&p, 2, 3), bridge(&p, 3, 4), bridge(&p, 5, 6)];
        contacts.push(bridge(&p, 7, 8));
        contacts.push(ContactRecord { bonded: false, ..bridge(&p, 6, 7) });
        let c = measure_cluster(&p, 3, &contacts, &mut ClusterTrack::default()).expect("wet grains");
        assert_eq!((c.wet, c.count, c.bridges, c.outside, c.clusters), (8, 5, 4, 3, 2));
        assert_eq!(c.axes.len(), 3);
        assert!(measure_cluster(&grains(3, &at, r, &[false; 11]), 3, &contacts, &mut ClusterTrack::default()).is_none());
    }

    /// A cluster across a periodic boundary is measured whole: the same row, with its grains
    /// wrapped into a box cutting it in two, has the same axes.
    #[test]
    fn a_cluster_across_a_periodic_boundary_is_whole() {
        let (r, k) = (1e-3, 6usize);
        let at: Vec<Vec3> = (0..k).map(|m| Vec3::new(2.0 * r * m as Real, 0.0, 0.0)).collect();
        let whole = grains(2, &at, r, &vec![true; k]);
        let contacts: Vec<_> = (0..k as u32 - 1).map(|m| bridge(&whole, m, m + 1)).collect();
        let mut wrapped = whole.clone();
        let period = 7.0 * r;
        for x in wrapped.pos.iter_mut() {
            x.x = x.x.rem_euclid(period);
        }
        let (a, b) = (
            measure_cluster(&whole, 2, &contacts, &mut ClusterTrack::default()).expect("wet"),
            measure_cluster(&wrapped, 2, &contacts, &mut ClusterTrack::default()).expect("wet"),
        );
        for (x, y) in a.axes.iter().zip(&b.axes) {
            assert!((x - y).abs() < 1e-12, "{:?} against {:?}", a.axes, b.axes);
        }
    }

    /// A granule followed over three samples, counted by hand: ten wet grains in a row, the
    /// granule first grains 0-4 (bridged in a chain), a pair 5-6 and lone grains 7-9. Then
    /// grain 4 leaves and the pair joins through grain 3 (accretion 2, erosion 1); then the
    /// chain breaks between 1 and 2: the part 2-3-5-6 holds four of the granule's six grains,
    /// the part 0-1 two, so the first is followed and grains 0 and 1 count as eroded.
    #[test]
    fn a_granule_is_followed_and_its_accretion_and_erosion_counted() {
        let r = 1e-3;
        let at: Vec<Vec3> = (0..10).map(|m| Vec3::new(2.0 * r * m as Real, 0.0, 0.0)).collect();
        let p = grains(2, &at, r, &[true; 10]);
        let mut track = ClusterTrack::default();
        // Before any bridge nothing is followed.
        let c = measure_cluster(&p, 2, &[], &mut track).expect("wet");
        assert_eq!((c.count, c.accreted, c.eroded), (1, 0, 0));
        assert!(track.is_empty());
        let first = [bridge(&p, 0, 1), bridge(&p, 1, 2), bridge(&p, 2, 3), bridge(&p, 3, 4), bridge(&p, 5, 6)];
        let c = measure_cluster(&p, 2, &first, &mut track).expect("wet");
        assert_eq!((c.count, c.largest, c.accreted, c.eroded, c.outside), (5, 5, 0, 0, 5));
        assert_eq!(track.members, vec![0, 1, 2, 3, 4]);
        let second = [bridge(&p, 0, 1), bridge(&p, 1, 2), bridge(&p, 2, 3), bridge(&p, 3, 5), bridge(&p, 5, 6)];
        let c = measure_cluster(&p, 2, &second, &mut track).expect("wet");
        assert_eq!((c.count, c.accreted, c.eroded), (6, 2, 1));
        let third = [bridge(&p, 0, 1), bridge(&p, 2, 3), bridge(&p, 3, 5), bridge(&p, 5, 6)];
        let c = measure_cluster(&p, 2, &third, &mut track).expect("wet");
        assert_eq!((c.count, c.accreted, c.eroded), (4, 2, 3));
        assert_eq!(track.members, vec![2, 3, 5, 6]);
        // The count is always the first count plus the accreted minus the eroded.
        assert_eq!(c.count, 5 + c.accreted - c.eroded);
    }

    /// A split granule is followed into the part that holds most of its grains, even when
    /// another cluster is larger; the largest is reported beside it.
    #[test]
    fn a_split_granule_is_followed_by_its_grains_not_by_size() {
        let r = 1e-3;
        let at: Vec<Vec3> = (0..12).map(|m| Vec3::new(2.0 * r * m as Real, 0.0, 0.0)).collect();
        let p = grains(2, &at, r, &[true; 12]);
        let chain = |range: std::ops::Range<u32>| range.map(|m| bridge(&p, m, m + 1)).collect::<Vec<_>>();
        let mut track = ClusterTrack::default();
        // The granule: 0-5. A second cluster 7-9 forms apart.
        let mut first = chain(0..5);
        first.extend(chain(7..9));
        let c = measure_cluster(&p, 2, &first, &mut track).expect("wet");
        assert_eq!(c.count, 6);
        // It splits into 0-3 (4 of its grains) and 4-5 (2), while 6-11 bridge into a cluster of
        // six, larger than either part.
        let mut second = chain(0..3);
        second.extend(chain(4..5));
        second.extend(chain(6..11));
        let c = measure_cluster(&p, 2, &second, &mut track).expect("wet");
        assert_eq!((c.count, c.largest, c.accreted, c.eroded, c.clusters), (4, 6, 0, 2, 3));
        assert_eq!(track.members, vec![0, 1, 2, 3]);
    }
}
