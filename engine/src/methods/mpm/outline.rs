//! A grain's outline: a closed polygon whose vertices ride on the grain's outer material
//! points, the surface its contacts are measured on ([`super::contact`]).
//!
//! The vertices are placed on the shape the grain was cut from (a disk: the regular polygon of
//! its area; a rectangle), about one grid cell apart, each on the grain's point nearest it:
//! its position is `x_p + F_p o`, `o` its offset from the point's centre when placed. A point
//! cloud has no surface of its own — which point is outermost along a line changes as points
//! slide past each other, and a gap measured from them jumps — but the outline's vertices
//! are material: the same points all run long, and the outline moves only as they move and
//! deform. Vertices a point spacing apart were tried on the Hertz disk: the contact solver
//! did not converge within its budget (more constraints than the grid's nodes can meet).

use super::grid::V2;
use super::points::Points;
use crate::math::Real;
use std::ops::Range;

/// One vertex of an outline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex {
    /// The material point it rides on (index in [`Points`]).
    pub point: u32,
    /// Its offset from the point's centre in the point's reference configuration, m.
    pub offset: V2,
}

/// A closed polygon, counter-clockwise, of vertices riding on material points.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outline {
    /// The vertices, counter-clockwise.
    pub vertices: Vec<Vertex>,
}

impl Outline {
    /// The outline of a disk of radius `r` centred at `c`, its points `range` of `points`: a
    /// regular polygon of the disk's area, its vertices about `spacing` apart (at least 8).
    pub fn disk(points: &Points, range: Range<usize>, c: V2, r: Real, spacing: Real) -> Self {
        let two_pi = 2.0 * std::f64::consts::PI as Real;
        let n = ((two_pi * r / spacing).round() as usize).max(8);
        // The n-gon of circumradius R has the area ½ n R² sin(2π/n).
        let angle = two_pi / n as Real;
        let big = r * (angle / angle.sin()).sqrt();
        let at = (0..n).map(|k| {
            let t = angle * k as Real;
            c + V2::new(t.cos(), t.sin()) * big
        });
        Self::riding(points, range, at)
    }

    /// The outline of the rectangle `[min, max]`, its points `range` of `points`: the four
    /// corners and vertices about `spacing` apart along each side.
    pub fn rectangle(points: &Points, range: Range<usize>, min: V2, max: V2, spacing: Real) -> Self {
        let corners = [min, V2::new(max.x, min.y), max, V2::new(min.x, max.y)];
        let mut at = Vec::new();
        for k in 0..4 {
            let (p, q) = (corners[k], corners[(k + 1) % 4]);
            let n = (((q - p).norm() / spacing).round() as usize).max(1);
            at.extend((0..n).map(|i| p + (q - p) * (i as Real / n as Real)));
        }
        Self::riding(points, range, at.into_iter())
    }

    /// Vertices at the places `at` (counter-clockwise), each on the point of `range` nearest it.
    fn riding(points: &Points, range: Range<usize>, at: impl Iterator<Item = V2>) -> Self {
        let vertices = at
            .filter_map(|x| {
                let p = range.clone().min_by(|&a, &b| (points.x[a] - x).norm_squared().total_cmp(&(points.x[b] - x).norm_squared()))?;
                Some(Vertex { point: p as u32, offset: x - points.x[p] })
            })
            .collect();
        Self { vertices }
    }

    /// Vertices.
    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    /// True without vertices.
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// Where vertex `k` is now, m.
    #[inline(always)]
    pub fn position(&self, points: &Points, k: usize) -> V2 {
        let v = &self.vertices[k];
        let p = v.point as usize;
        points.x[p] + points.f[p] * v.offset
    }

    /// Every vertex's position now, m.
    pub fn positions(&self, points: &Points) -> Vec<V2> {
        let mut out = Vec::with_capacity(self.len());
        self.positions_into(points, &mut out);
        out
    }

    /// Every vertex's position now into `out` (cleared first), m.
    pub fn positions_into(&self, points: &Points, out: &mut Vec<V2>) {
        out.clear();
        out.extend((0..self.len()).map(|k| self.position(points, k)));
    }

    /// Area enclosed, m² ([`crate::methods::soft::polygon::area`]).
    pub fn area(positions: &[V2]) -> Real {
        crate::methods::soft::polygon::area(positions)
    }

    /// Whether `x` is inside the polygon `positions` ([`crate::methods::soft::polygon::contains`]).
    pub fn contains(positions: &[V2], x: &V2) -> bool {
        crate::methods::soft::polygon::contains(positions, x)
    }
}

pub use crate::methods::soft::polygon::{nearest, Nearest};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_disk_outline_rides_its_points_and_follows_a_stretch() {
        let mut points = Points::default();
        let (c, r, s) = (V2::new(0.3, -0.2), 0.01, 0.001);
        let range = points.fill_disk(c, r, s, V2::zeros(), 1000.0);
        let outline = Outline::disk(&points, range.clone(), c, r, 2.0 * s);
        assert_eq!(outline.len(), 31);
        let x = outline.positions(&points);
        // The disk's area, and a vertex's point is within a spacing of it.
        let exact = std::f64::consts::PI as Real * r * r;
        assert!((Outline::area(&x) / exact - 1.0).abs() < 1e-12);
        for (k, v) in outline.vertices.iter().enumerate() {
            assert!(((x[k] - c).norm() - r).abs() < 0.01 * r);
            assert!(v.offset.norm() < s, "{:?}", v.offset);
        }
        // A homogeneous stretch about the centre moves every vertex with it.
        let f = crate::constitutive::Mat2::new(1.2, 0.1, 0.0, 0.9);
        for p in range {
            points.x[p] = c + f * (points.x[p] - c);
            points.f[p] = f;
        }
        let y = outline.positions(&points);
        for k in 0..x.len() {
            assert!((y[k] - (c + f * (x[k] - c))).norm() < 1e-15);
        }
    }

    #[test]
    fn nearest_segment_and_signed_gap() {
        let mut points = Points::default();
        let range = points.fill_rectangle(V2::new(0.0, 0.0), V2::new(1.0, 0.5), 0.1, |_| V2::zeros(), 1.0);
        let outline = Outline::rectangle(&points, range, V2::new(0.0, 0.0), V2::new(1.0, 0.5), 0.25);
        let x = outline.positions(&points);
        assert_eq!(x.len(), 12);
        assert!((Outline::area(&x) - 0.5).abs() < 1e-12);
        let above = nearest(&x, &V2::new(0.4, 0.6)).expect("a segment");
        assert!((above.gap - 0.1).abs() < 1e-12 && (above.normal - V2::new(0.0, 1.0)).norm() < 1e-12);
        let inside = nearest(&x, &V2::new(0.95, 0.2)).expect("a segment");
        assert!((inside.gap + 0.05).abs() < 1e-12 && (inside.normal - V2::new(1.0, 0.0)).norm() < 1e-12);
        assert!(Outline::contains(&x, &V2::new(0.95, 0.2)) && !Outline::contains(&x, &V2::new(0.4, 0.6)));
    }
}
