//! What soft grains look like to the shared metrics, whatever the method: each grain's
//! centroid, velocity, area and shape ([`GrainState`]), the contacts gathered per pair of
//! grains and per grain and wall, and the area the grains' outlines cover twice.

use nalgebra::{Matrix2, Vector2};

use super::contact::{Other, VertexContact};
use crate::math::{Real, Vec3};
use crate::observe::ContactRecord;

type V2 = Vector2<Real>;

/// One grain now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrainState {
    /// Centroid (mass centre), m.
    pub centroid: V2,
    /// Mean velocity, m/s.
    pub velocity: V2,
    /// Mass, kg/m.
    pub mass: Real,
    /// Current area, m².
    pub area: Real,
    /// Aspect ratio: `sqrt(I1 / I2)` of the principal second moments of its area about the
    /// centroid (1 for a disk, `a / b` for an ellipse of half-axes `a`, `b`).
    pub aspect_ratio: Real,
}

/// The aspect ratio `sqrt(I1 / I2)` of a shape whose second moments of area about its centroid
/// are `second` (m⁴ per metre): 1 for a disk, `a / b` for an ellipse of half-axes `a`, `b`.
pub fn aspect_ratio(second: &Matrix2<Real>) -> Real {
    let (xx, yy, xy) = (second[(0, 0)], second[(1, 1)], second[(0, 1)]);
    let mean = 0.5 * (xx + yy);
    let radius = (0.25 * (xx - yy) * (xx - yy) + xy * xy).sqrt();
    let (big, small) = (mean + radius, mean - radius);
    if small > 0.0 {
        (big / small).sqrt()
    } else {
        Real::INFINITY
    }
}

/// The contacts of the last step as the metrics count them (forces in N/m): one record per
/// pair of grains in contact, the sum of their contacts' forces, with the branch between
/// their centroids (each contact's force acts on both grains, equal and opposite, so the
/// sum of `f ⊗ (x_a − x_b)` is exactly the Love–Weber sum over the contacts); one per
/// grain and wall, its branch from the force-weighted contact point to the centroid.
/// `dt` the last step's (part's) duration, s: the impulses are over it.
pub fn contact_records(contacts: &[VertexContact], walls: usize, grains: &[GrainState], dt: Real) -> Vec<ContactRecord> {
    // (a, b or u32::MAX - wall) -> (force on a, Σ |f_n| at, Σ |f_n|)
    let mut pairs: std::collections::BTreeMap<(u32, u32), (V2, V2, Real)> = std::collections::BTreeMap::new();
    for c in contacts {
        if c.r == Vec3::zeros() {
            continue;
        }
        let g = c.frame.to_global(&c.r) / dt;
        let f = V2::new(g.x, g.y);
        let (a, b) = match c.b {
            // Pairs keyed with the smaller grain first, the force taken on it.
            Other::Grain { grain, .. } if grain < c.a => (grain, c.a),
            Other::Grain { grain, .. } => (c.a, grain),
            Other::Wall(w) => (c.a, u32::MAX - w),
        };
        let sign = if a == c.a { 1.0 } else { -1.0 };
        let e = pairs.entry((a, b)).or_insert((V2::zeros(), V2::zeros(), 0.0));
        e.0 += f * sign;
        let weight = c.r.x.abs();
        e.1 += c.at * weight;
        e.2 += weight;
    }
    let v3 = |v: V2| Vec3::new(v.x, v.y, 0.0);
    pairs
        .into_iter()
        .map(|((a, b), (force, at, weight))| {
            let ca = grains[a as usize].centroid;
            let wall = b > u32::MAX - walls as u32;
            let branch = if wall { ca - if weight > 0.0 { at / weight } else { ca } } else { ca - grains[b as usize].centroid };
            ContactRecord { i: a, j: (!wall).then_some(b), force: v3(force), branch: v3(branch), touching: true, bonded: false }
        })
        .collect()
}

/// The area the grains cover twice (two grains' outlines over the same place) or outside
/// the box `[lo, hi]`, m² per metre: what the contacts let the grains interpenetrate. It
/// is counted on a raster of cells of side `c` (m; a cell inside `k` outlines counts `k − 1`
/// times). `Φ` less this over the box area is the packing
/// fraction of the grains' union inside the box.
pub fn interpenetration(outlines: &[Vec<V2>], c: Real, lo: V2, hi: V2) -> Real {
    if !c.is_finite() || c <= 0.0 || hi.x <= lo.x || hi.y <= lo.y {
        return 0.0;
    }
    let margin = V2::new(16.0 * c, 16.0 * c);
    let (m0, m1) = (lo - margin, hi + margin);
    let nx = ((m1.x - m0.x) / c).ceil() as usize;
    let ny = ((m1.y - m0.y) / c).ceil() as usize;
    let mut count = vec![0u16; nx * ny];
    let cell = |i: usize, j: usize| V2::new(m0.x + (i as Real + 0.5) * c, m0.y + (j as Real + 0.5) * c);
    for x in outlines {
        if x.is_empty() {
            continue;
        }
        let (mut min, mut max) = (x[0], x[0]);
        for p in x {
            min = min.inf(p);
            max = max.sup(p);
        }
        let j0 = ((min.y - m0.y) / c).floor().max(0.0) as usize;
        let j1 = (((max.y - m0.y) / c).ceil().max(0.0) as usize).min(ny);
        // Row by row, the cells whose centres lie between the outline's crossings of the
        // row (even-odd, as [`super::polygon::contains`]).
        let mut crossings = Vec::new();
        for j in j0..j1 {
            let y = m0.y + (j as Real + 0.5) * c;
            crossings.clear();
            for k in 0..x.len() {
                let (a, b) = (x[k], x[(k + 1) % x.len()]);
                if (a.y > y) != (b.y > y) {
                    crossings.push(a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x));
                }
            }
            crossings.sort_unstable_by(Real::total_cmp);
            for pair in crossings.chunks_exact(2) {
                // Cells with pair[0] <= centre < pair[1].
                let first = ((pair[0] - m0.x) / c - 0.5).ceil().max(0.0) as usize;
                let end = (((pair[1] - m0.x) / c - 0.5).ceil().max(0.0) as usize).min(nx);
                for i in first..end {
                    count[i + nx * j] = count[i + nx * j].saturating_add(1);
                }
            }
        }
    }
    let mut area = 0.0;
    for j in 0..ny {
        for i in 0..nx {
            let k = i + nx * j;
            if count[k] == 0 {
                continue;
            }
            let x = cell(i, j);
            let outside = x.x < lo.x || x.y < lo.y || x.x > hi.x || x.y > hi.y;
            area += c * c * (count[k] as Real - if outside { 0.0 } else { 1.0 });
        }
    }
    area
}
