//! Where a contact may act at a step's start ([`candidates`]): which vertex of an outline may
//! touch which other outline (by the nearest segment, and the second side of a reflex corner)
//! or wall, and the segment geometry that a contact's gap is measured on again
//! ([`super::drift`]).

use nalgebra::Vector2;

use super::records::Wall;
use crate::math::Real;
use crate::methods::soft::polygon::{bounding_box, nearest, Nearest};

type V2 = Vector2<Real>;

/// Where a contact may act at the start of a step (found by [`candidates`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Candidate {
    /// Vertex `k` of grain `a`'s outline near the outline of grain `b` (`b > a` unless
    /// [`Sides::Both`]).
    Grain {
        /// The vertex's grain.
        a: usize,
        /// The vertex.
        k: usize,
        /// The other grain.
        b: usize,
        /// The segment of `b`'s outline nearest the vertex, and the gap.
        near: Nearest,
        /// Whether the contact holds the vertex on the outer side of `near`'s line only: the
        /// second side of a reflex corner of `b`'s outline ([`candidates`]); otherwise its
        /// gap follows the outline's nearest segment as the grains move.
        line: bool,
    },
    /// Vertex `k` of grain `g`'s outline near wall `w`.
    Wall {
        /// The grain.
        g: usize,
        /// The vertex.
        k: usize,
        /// The wall.
        w: usize,
        /// Gap along the wall's normal, m.
        gap: Real,
    },
}

/// Which grain's vertices a pair of grains holds outside the other's outline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sides {
    /// The grain of lower index's only (one pass): between two convex outlines the other
    /// grain's vertices can cross a segment by at most the sagitta of the segment's chord,
    /// but once outlines are dented they go in further, and the contacts then push back
    /// with work ([`super`]'s documentation, "Sides").
    One,
    /// Both grains' vertices against the other's outline (two passes; no grain privileged).
    /// Where the outlines lie flat on each other the two sets of contacts are redundant: their
    /// impulses are not unique (the solve's change is measured on the velocities, [`solve`]).
    ///
    /// [`solve`]: super::solve::solve
    Both,
}

/// The step's candidates, in a fixed order: every vertex of an outline within `reach` (m) of the
/// outline of a grain of higher index — and, with [`Sides::Both`], of lower index — (the
/// nearest segment; pairs whose boxes come within `reach`, by a sweep along x), then every
/// vertex within `reach` of a wall.
///
/// Where the nearest segment ends at a reflex corner of the other outline (a dent: the
/// outline turns towards the vertex by more than [`REFLEX_TURN`]) and the vertex is within
/// `reach` of the segment beyond the corner, that segment's line is a second contact of the
/// vertex. Outside a dent is the intersection of the two sides' outer half-planes, so the
/// vertex must stay outside both lines: held by the nearest segment's line alone, a vertex
/// sliding past the corner went into the grain beyond it (the second contact halved the meshed
/// grains' overlap: docs/methods/fem.md). At a convex corner the outside is the union of the
/// half-planes, and the nearest segment alone is right.
pub fn candidates(shapes: &[Vec<V2>], walls: &[Wall], reach: Real, sides: Sides) -> Vec<Candidate> {
    let boxes: Vec<(V2, V2)> = shapes.iter().map(|x| bounding_box(x)).collect();
    let mut order: Vec<usize> = (0..shapes.len()).filter(|&g| !shapes[g].is_empty()).collect();
    order.sort_unstable_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x).then(a.cmp(&b)));
    let mut pairs = Vec::new();
    for (i, &a) in order.iter().enumerate() {
        for &b in &order[i + 1..] {
            if boxes[b].0.x > boxes[a].1.x + reach {
                break;
            }
            if boxes[b].0.y <= boxes[a].1.y + reach && boxes[a].0.y <= boxes[b].1.y + reach {
                pairs.push((a.min(b), a.max(b)));
            }
        }
    }
    pairs.sort_unstable();
    if sides == Sides::Both {
        pairs = pairs.into_iter().flat_map(|(a, b)| [(a, b), (b, a)]).collect();
    }
    let mut out = Vec::new();
    for (a, b) in pairs {
        let (lo, hi) = (boxes[b].0 - V2::repeat(reach), boxes[b].1 + V2::repeat(reach));
        for (k, x) in shapes[a].iter().enumerate() {
            if x.x < lo.x || x.y < lo.y || x.x > hi.x || x.y > hi.y {
                continue;
            }
            let Some(near) = nearest(&shapes[b], x) else { continue };
            if near.gap.is_nan() || near.gap > reach {
                continue;
            }
            out.push(Candidate::Grain { a, k, b, near, line: false });
            let n = shapes[b].len();
            for (corner, beyond) in [(near.segment, (near.segment + n - 1) % n), ((near.segment + 1) % n, (near.segment + 1) % n)] {
                if beyond == near.segment || !reflex(&shapes[b], corner) {
                    continue;
                }
                if let Some(side) = on_segment(&shapes[b], beyond, x).filter(|s| s.1 <= reach) {
                    out.push(Candidate::Grain { a, k, b, near: side.0, line: true });
                }
            }
        }
    }
    for (g, x) in shapes.iter().enumerate() {
        for (k, x) in x.iter().enumerate() {
            for (w, wall) in walls.iter().enumerate() {
                let gap = (x - wall.point).dot(&wall.normal);
                if gap.is_nan() || gap > reach {
                    continue;
                }
                out.push(Candidate::Wall { g, k, w, gap });
            }
        }
    }
    out
}

/// The least turn, `sin` of the angle between a corner's two sides, that makes it reflex for
/// [`candidates`]: below it the two lines nearly coincide, a second contact would be redundant
/// with the first (the solver's impulses slide between redundant contacts without end), and a
/// vertex sliding past the corner in a step goes in by at most this times its slide.
pub const REFLEX_TURN: Real = 0.02;

/// Whether vertex `k` of the counter-clockwise polygon `x` is a reflex corner: the outline turns
/// clockwise there by more than [`REFLEX_TURN`].
pub(super) fn reflex(x: &[V2], k: usize) -> bool {
    let n = x.len();
    let (e1, e2) = (x[k] - x[(k + n - 1) % n], x[(k + 1) % n] - x[k]);
    let cross = e1.x * e2.y - e1.y * e2.x;
    cross < -REFLEX_TURN * e1.norm() * e2.norm()
}

/// Segment `k` of the counter-clockwise polygon `x` as seen from `at`: where `at` projects on
/// it (clamped), the outward normal, the distance from its line; and the distance from the
/// segment itself, m. `None` for a degenerate segment.
pub(super) fn on_segment(x: &[V2], k: usize, at: &V2) -> Option<(Nearest, Real)> {
    let (a, b) = (x[k], x[(k + 1) % x.len()]);
    let d = b - a;
    let len = d.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    let t = ((at - a).dot(&d) / (len * len)).clamp(0.0, 1.0);
    let normal = V2::new(d.y / len, -d.x / len);
    Some((Nearest { segment: k, t, normal, gap: (at - a).dot(&normal) }, (at - (a + d * t)).norm()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertex in a dent of the other outline touches both sides of its reflex corner; a
    /// vertex at a convex corner only the nearest side.
    #[test]
    fn a_vertex_in_a_dent_touches_both_sides_of_the_reflex_corner() {
        // Grain 1: a pentagon whose top dips to a reflex corner at the origin (vertex 3).
        let dented = vec![V2::new(-2.0, -2.0), V2::new(2.0, -2.0), V2::new(2.0, 1.0), V2::new(0.0, 0.0), V2::new(-2.0, 1.0)];
        // Grain 0: a triangle with a vertex in the dent, one by the convex corner (2, 1) and
        // one out of reach.
        let probe = vec![V2::new(0.2, 0.3), V2::new(2.3, 1.3), V2::new(1.0, 3.0)];
        let found = candidates(&[probe, dented], &[], 1.0, Sides::One);
        let of = |k: usize| -> Vec<(Nearest, bool)> {
            found
                .iter()
                .filter_map(|c| match *c {
                    Candidate::Grain { a: 0, k: v, b: 1, near, line } if v == k => Some((near, line)),
                    _ => None,
                })
                .collect()
        };
        let dent = of(0);
        assert_eq!(dent.len(), 2, "{dent:?}");
        let (near, line) = dent[0];
        assert!(!line && near.segment == 2 && (near.gap - 0.4 / 5f64.sqrt()).abs() < 1e-12, "{near:?}");
        let (side, line) = dent[1];
        assert!(line && side.segment == 3 && (side.gap - 0.8 / 5f64.sqrt()).abs() < 1e-12, "{side:?}");
        assert!((side.normal - V2::new(1.0, 2.0) / 5f64.sqrt()).norm() < 1e-12);
        assert_eq!(of(1).len(), 1, "a convex corner: {:?}", of(1));
        assert!(of(2).is_empty());
        assert_eq!(found.len(), 3);
    }

    /// One side holds only the vertices of the grain of lower index outside the other; both
    /// sides the other's vertices too, each against the nearest segment of the first.
    #[test]
    fn both_sides_hold_the_vertices_of_either_grain() {
        // Two unit squares, grain 1 shifted by (0.9, 0.2): each has one corner 0.1 inside the
        // other, and one 0.2 outside it.
        let square = |x0: Real, y0: Real| vec![V2::new(x0, y0), V2::new(x0 + 1.0, y0), V2::new(x0 + 1.0, y0 + 1.0), V2::new(x0, y0 + 1.0)];
        let shapes = [square(0.0, 0.0), square(0.9, 0.2)];
        let pairs = |sides| -> Vec<(usize, usize, usize, Real)> {
            candidates(&shapes, &[], 0.5, sides)
                .into_iter()
                .filter_map(|c| match c {
                    Candidate::Grain { a, k, b, near, line: false } => Some((a, k, b, near.gap)),
                    _ => None,
                })
                .collect()
        };
        let close = |x: Real, y: Real| (x - y).abs() < 1e-12;
        let one = pairs(Sides::One);
        assert!(one.iter().all(|&(a, _, b, _)| (a, b) == (0, 1)), "{one:?}");
        assert!(one.iter().any(|&(_, k, _, gap)| k == 2 && close(gap, -0.1)), "{one:?}");
        assert!(one.iter().any(|&(_, k, _, gap)| k == 1 && close(gap, 0.2)), "{one:?}");
        let both = pairs(Sides::Both);
        let back: Vec<_> = both.iter().filter(|&&(a, _, b, _)| (a, b) == (1, 0)).collect();
        assert_eq!(back.len(), 2, "{both:?}");
        assert!(back.iter().any(|&&(_, k, _, gap)| k == 0 && close(gap, -0.1)), "{back:?}");
        assert!(back.iter().any(|&&(_, k, _, gap)| k == 3 && close(gap, 0.2)), "{back:?}");
        assert_eq!(both.len(), one.len() + back.len());
    }
}
