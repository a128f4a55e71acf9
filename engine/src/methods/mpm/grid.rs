//! The background grid of the material point method and its shape functions: quadratic
//! B-splines (Steffen, Kirby & Berzins, Int. J. Numer. Meth. Eng. 76, 922, 2008; de Vaucorbeil
//! et al., Adv. Appl. Mech. 53, 2020, §3). Each node carries the C¹ piecewise-quadratic
//! function of width three cells centred on it, so a point's weights and their gradients vary
//! smoothly as it crosses a cell boundary: no jump of the internal force there, the noise that
//! plain linear shape functions make (the cell-crossing error).

use crate::math::Real;

/// A 2-vector.
pub type V2 = nalgebra::Vector2<Real>;

/// A uniform grid of square cells: node `(i, j)` at `origin + h (i, j)`, `0 <= i < nx`,
/// `0 <= j < ny`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Position of node (0, 0), m.
    pub origin: V2,
    /// Cell size, m.
    pub h: Real,
    /// Nodes along x.
    pub nx: usize,
    /// Nodes along y.
    pub ny: usize,
}

/// The 3x3 nodes a point's shape functions reach, with their weights and gradients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stencil {
    /// The first node along x and y.
    pub base: [usize; 2],
    /// Weights along each axis of the three nodes (`w[axis][k]`).
    pub w: [[Real; 3]; 2],
    /// Derivatives of those weights along their axis, 1/m.
    pub dw: [[Real; 3]; 2],
}

impl Stencil {
    /// Weight of node `(base + (a, b))`.
    #[inline(always)]
    pub fn weight(&self, a: usize, b: usize) -> Real {
        self.w[0][a] * self.w[1][b]
    }

    /// Gradient of the weight of node `(base + (a, b))`, 1/m.
    #[inline(always)]
    pub fn gradient(&self, a: usize, b: usize) -> V2 {
        V2::new(self.dw[0][a] * self.w[1][b], self.w[0][a] * self.dw[1][b])
    }
}

impl Grid {
    /// A grid of cell `h` covering `[min, max]` with `margin` cells more on every side.
    pub fn covering(min: V2, max: V2, h: Real, margin: usize) -> Self {
        let origin = min - V2::repeat(h * margin as Real);
        let cells = |a: usize| (((max[a] - min[a]) / h).ceil() as usize) + 2 * margin;
        Self { origin, h, nx: cells(0) + 1, ny: cells(1) + 1 }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.nx * self.ny
    }

    /// Position of node `(i, j)`, m.
    pub fn node_position(&self, i: usize, j: usize) -> V2 {
        self.origin + V2::new(i as Real, j as Real) * self.h
    }

    /// The stencil of a point at `x`, or `None` if its nodes are not all on the grid.
    pub fn stencil(&self, x: &V2) -> Option<Stencil> {
        let mut base = [0; 2];
        let mut w = [[0.0; 3]; 2];
        let mut dw = [[0.0; 3]; 2];
        let n = [self.nx, self.ny];
        for a in 0..2 {
            let s = (x[a] - self.origin[a]) / self.h;
            // The node nearest to the point is the middle one of the three.
            let b = (s - 0.5).floor();
            if b.is_nan() || b < 0.0 || b as usize + 2 >= n[a] {
                return None;
            }
            base[a] = b as usize;
            let f = s - b; // in [0.5, 1.5)
            w[a] = [0.5 * (1.5 - f) * (1.5 - f), 0.75 - (f - 1.0) * (f - 1.0), 0.5 * (f - 0.5) * (f - 0.5)];
            dw[a] = [(f - 1.5) / self.h, -2.0 * (f - 1.0) / self.h, (f - 0.5) / self.h];
        }
        Some(Stencil { base, w, dw })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Partition of unity, linear completeness (Σ w x_i = x) and Σ ∇w = 0, Σ ∇w ⊗ x_i = I, at
    /// points across cells.
    #[test]
    fn quadratic_b_splines_reproduce_linear_fields() {
        let g = Grid::covering(V2::new(0.0, 0.0), V2::new(1.0, 1.0), 0.1, 2);
        for k in 0..97 {
            let x = V2::new(0.0101 * k as Real, 0.5 + 0.3 * (k as Real * 0.7).sin());
            let s = g.stencil(&x).expect("on the grid");
            let (mut sum, mut first, mut grad, mut dx) = (0.0, V2::zeros(), V2::zeros(), nalgebra::Matrix2::zeros());
            for a in 0..3 {
                for b in 0..3 {
                    let p = g.node_position(s.base[0] + a, s.base[1] + b);
                    sum += s.weight(a, b);
                    first += p * s.weight(a, b);
                    grad += s.gradient(a, b);
                    dx += p * s.gradient(a, b).transpose();
                }
            }
            assert!((sum - 1.0).abs() < 1e-14);
            assert!((first - x).norm() < 1e-14);
            assert!(grad.norm() < 1e-12);
            assert!((dx - nalgebra::Matrix2::identity()).norm() < 1e-12);
        }
        assert!(g.stencil(&V2::new(-0.3, 0.5)).is_none(), "beyond the margin");
    }
}
