//! The reference geometry of a four-node quadrilateral (bilinear shape functions, 2×2 Gauss
//! points): what the finite element method integrates over, and what a saved mesh is checked
//! against (an element degenerate or inverted at a Gauss point has no such geometry).

use nalgebra::{Matrix2, Vector2};

use crate::math::Real;

type V2 = Vector2<Real>;

/// The reference coordinates of the 2×2 Gauss points, ±1/√3.
const GAUSS: Real = 0.577_350_269_189_625_8;

/// Natural coordinates of the nodes, counter-clockwise.
const CORNERS: [(Real, Real); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];

/// An element's reference geometry: its shape functions' gradients and its points' weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Reference gradients `∇N_a` at the four Gauss points and, last, at the centre, 1/m.
    pub grad: [[V2; 4]; 5],
    /// Each Gauss point's weight times the reference Jacobian, m² (they sum to the area).
    pub weight: [Real; 4],
    /// `∫ N_a dA` over the reference element, m² (the lumped mass over the density).
    pub share: [Real; 4],
    /// Square root of the area, m (the finite-difference step's unit).
    pub length: Real,
}

impl Geometry {
    /// The geometry of the element with reference nodes `x` (counter-clockwise); `None` if it
    /// is degenerate or inverted at a Gauss point.
    pub fn new(x: &[V2; 4]) -> Option<Self> {
        let at = |xi: Real, eta: Real| -> Option<([V2; 4], Real, [Real; 4])> {
            let dn: [V2; 4] = CORNERS.map(|(a, b)| V2::new(0.25 * a * (1.0 + b * eta), 0.25 * b * (1.0 + a * xi)));
            let n: [Real; 4] = CORNERS.map(|(a, b)| 0.25 * (1.0 + a * xi) * (1.0 + b * eta));
            // J = ∂x/∂ξ.
            let mut j = Matrix2::<Real>::zeros();
            for k in 0..4 {
                j += x[k] * dn[k].transpose();
            }
            let det = j.determinant();
            if det.is_nan() || det <= 0.0 {
                return None;
            }
            let inv_t = j.try_inverse()?.transpose();
            Some((dn.map(|d| inv_t * d), det, n))
        };
        let mut grad = [[V2::zeros(); 4]; 5];
        let mut weight = [0.0; 4];
        let mut share = [0.0; 4];
        for (g, (a, b)) in CORNERS.iter().enumerate() {
            let (gr, det, n) = at(a * GAUSS, b * GAUSS)?;
            grad[g] = gr;
            weight[g] = det;
            for k in 0..4 {
                share[k] += det * n[k];
            }
        }
        grad[4] = at(0.0, 0.0)?.0;
        let area: Real = weight.iter().sum();
        Some(Self { grad, weight, share, length: area.sqrt() })
    }

    /// The deformation gradient at point `g` (4: the centre) for nodal displacements `u`.
    #[inline]
    pub fn deformation(&self, g: usize, u: &[V2; 4]) -> Matrix2<Real> {
        let mut f = Matrix2::<Real>::identity();
        for (ua, ga) in u.iter().zip(&self.grad[g]) {
            f += ua * ga.transpose();
        }
        f
    }
}
