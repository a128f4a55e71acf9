//! The material points of deformable grains, struct of arrays, grouped by grain: each point's
//! mass, reference volume, position, velocity, deformation gradient and history (the state
//! the constitutive law needs between steps).

use std::ops::Range;

use super::grid::V2;
use crate::constitutive::{History, Mat2};
use crate::math::Real;

/// The points of every grain (struct of arrays; a grain's points are contiguous).
#[derive(Debug, Clone, Default)]
pub struct Points {
    /// Mass, kg per metre of thickness (plane strain).
    pub mass: Vec<Real>,
    /// Reference (initial) area, m² (volume per metre of thickness).
    pub vol0: Vec<Real>,
    /// Side of the square the point stood for when placed, m: with `F` it gives the
    /// parallelogram the point covers now (as drawn in snapshots).
    pub side0: Vec<Real>,
    /// Position, m.
    pub x: Vec<V2>,
    /// Velocity, m/s.
    pub v: Vec<V2>,
    /// Deformation gradient (in-plane block; plane strain).
    pub f: Vec<Mat2>,
    /// Constitutive history.
    pub history: Vec<History>,
}

impl Points {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Adds a point at rest, undeformed.
    pub fn push(&mut self, x: V2, v: V2, side: Real, density: Real) {
        let vol = side * side;
        self.mass.push(density * vol);
        self.vol0.push(vol);
        self.side0.push(side);
        self.x.push(x);
        self.v.push(v);
        self.f.push(Mat2::identity());
        self.history.push(History::default());
    }

    /// Current area of point `p`, m² (`J V0`).
    pub fn area(&self, p: usize) -> Real {
        self.f[p].determinant() * self.vol0[p]
    }

    /// The corners of the parallelogram `F` makes of point `p`'s initial square, counter-clockwise
    /// (m): the area the point covers now (`det F` times its initial area).
    pub fn parallelogram(&self, p: usize) -> [V2; 4] {
        let half = 0.5 * self.side0[p];
        let corner = |a: Real, b: Real| self.x[p] + self.f[p] * V2::new(a * half, b * half);
        [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)]
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let n = self.x.capacity();
        n * (3 * std::mem::size_of::<Real>() + 2 * std::mem::size_of::<V2>() + std::mem::size_of::<Mat2>() + std::mem::size_of::<History>())
    }

    /// Fills a disk of radius `r` centred at `c` with points on a square lattice of spacing
    /// `s` (the cells of the lattice whose centres fall in the disk), moving at `v`; returns
    /// their range.
    pub fn fill_disk(&mut self, c: V2, r: Real, s: Real, v: V2, density: Real) -> Range<usize> {
        let start = self.len();
        let k = (r / s).ceil() as i64;
        for j in -k..k {
            for i in -k..k {
                let d = V2::new((i as Real + 0.5) * s, (j as Real + 0.5) * s);
                if d.norm_squared() <= r * r {
                    self.push(c + d, v, s, density);
                }
            }
        }
        start..self.len()
    }

    /// Fills the rectangle `[min, max]` with points on a square lattice of spacing `s`
    /// (`max - min` a multiple of `s` along each axis), moving at `v(x)`; returns their range.
    pub fn fill_rectangle(&mut self, min: V2, max: V2, s: Real, v: impl Fn(&V2) -> V2, density: Real) -> Range<usize> {
        let start = self.len();
        let (nx, ny) = (((max.x - min.x) / s).round() as usize, ((max.y - min.y) / s).round() as usize);
        for j in 0..ny {
            for i in 0..nx {
                let x = min + V2::new((i as Real + 0.5) * s, (j as Real + 0.5) * s);
                self.push(x, v(&x), s, density);
            }
        }
        start..self.len()
    }
}
