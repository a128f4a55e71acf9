//! Plane-strain kinematics shared by the constitutive laws: the in-plane 2x2 tensors, their
//! symmetric eigen-decomposition in closed form, and the stress type.
//!
//! In plane strain the deformation gradient is `F = [[F2, 0], [0, 1]]` with `F2` the in-plane
//! 2x2 block; the laws see `F2` ([`Mat2`]). Symmetric in-plane tensors have the out-of-plane
//! axis `z` as a principal direction, so their spectral decomposition is that of a 2x2 block,
//! done here in closed form (no iteration).

use crate::math::Real;

/// An in-plane 2x2 matrix (deformation gradients, first Piola-Kirchhoff stresses).
pub type Mat2 = nalgebra::Matrix2<Real>;

/// A symmetric tensor of plane strain: the in-plane block and the out-of-plane diagonal entry
/// (`xz = yz = 0`). Units are those of the quantity it holds (Pa for stresses, 1 for strains).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlaneSym {
    /// `xx` component.
    pub xx: Real,
    /// `yy` component.
    pub yy: Real,
    /// `xy` component.
    pub xy: Real,
    /// `zz` component.
    pub zz: Real,
}

impl PlaneSym {
    /// The identity.
    pub const IDENTITY: Self = Self { xx: 1.0, yy: 1.0, xy: 0.0, zz: 1.0 };

    /// The in-plane block as a matrix.
    pub fn in_plane(&self) -> Mat2 {
        Mat2::new(self.xx, self.xy, self.xy, self.yy)
    }

    /// A tensor from its in-plane block (symmetrised) and `zz`.
    pub fn from_in_plane(m: &Mat2, zz: Real) -> Self {
        Self { xx: m[(0, 0)], yy: m[(1, 1)], xy: 0.5 * (m[(0, 1)] + m[(1, 0)]), zz }
    }

    /// Trace (all three diagonal entries).
    pub fn trace(&self) -> Real {
        self.xx + self.yy + self.zz
    }

    /// `a : a`.
    pub fn norm_squared(&self) -> Real {
        self.xx * self.xx + self.yy * self.yy + 2.0 * self.xy * self.xy + self.zz * self.zz
    }

    /// Every component finite.
    pub fn is_finite(&self) -> bool {
        self.xx.is_finite() && self.yy.is_finite() && self.xy.is_finite() && self.zz.is_finite()
    }

    /// The in-plane spectral decomposition ([`Spectral`]).
    pub fn spectral(&self) -> Spectral {
        Spectral::of(self.xx, self.yy, self.xy)
    }
}

/// The spectral decomposition of a symmetric in-plane block `[[xx, xy], [xy, yy]]`:
/// eigenvalues `l1 >= l2` and the unit eigenvector `(c, s)` of `l1` (that of `l2` is `(-s, c)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spectral {
    /// Larger eigenvalue.
    pub l1: Real,
    /// Smaller eigenvalue.
    pub l2: Real,
    /// Cosine of the angle of the first eigenvector.
    pub c: Real,
    /// Sine of the angle of the first eigenvector.
    pub s: Real,
}

impl Spectral {
    /// Decomposes `[[xx, xy], [xy, yy]]` in closed form: with `(cos 2α, sin 2α) = (xx − yy,
    /// 2 xy) / (l1 − l2)`, the half-angle formulas give `(c, s)`, the larger of the two from its
    /// square root and the other from `sin 2α = 2 s c` (no trigonometric call: this runs ten
    /// times per material point per Newton iteration). Repeated eigenvalues give the x axis.
    pub fn of(xx: Real, yy: Real, xy: Real) -> Self {
        let mean = 0.5 * (xx + yy);
        let half = 0.5 * (xx - yy);
        let r = (half * half + xy * xy).sqrt();
        let (c, s) = if r == 0.0 {
            (1.0, 0.0)
        } else if half >= 0.0 {
            let c = ((r + half) / (2.0 * r)).sqrt();
            (c, xy / (2.0 * r * c))
        } else {
            let s = ((r - half) / (2.0 * r)).sqrt().copysign(xy);
            (xy / (2.0 * r * s), s)
        };
        Self { l1: mean + r, l2: mean - r, c, s }
    }

    /// The symmetric block with the same eigenvectors and eigenvalues `(a1, a2)`:
    /// `a1 e1 e1ᵀ + a2 e2 e2ᵀ`.
    pub fn compose(&self, a1: Real, a2: Real) -> Mat2 {
        let (c, s) = (self.c, self.s);
        let xx = a1 * c * c + a2 * s * s;
        let yy = a1 * s * s + a2 * c * c;
        let xy = (a1 - a2) * c * s;
        Mat2::new(xx, xy, xy, yy)
    }
}

/// `b = F Fᵀ` of an in-plane deformation gradient (plane strain: `b_zz = 1`).
pub fn left_cauchy_green(f: &Mat2) -> PlaneSym {
    PlaneSym::from_in_plane(&(f * f.transpose()), 1.0)
}

/// The first Piola-Kirchhoff stress `P = τ F⁻ᵀ` (in-plane block, Pa) of a Kirchhoff stress
/// `τ` at the deformation gradient `F`; `None` if `F` is singular.
pub fn first_piola(tau: &PlaneSym, f: &Mat2) -> Option<Mat2> {
    let inv_t = f.try_inverse()?.transpose();
    Some(tau.in_plane() * inv_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectral_recomposes_the_block() {
        for &(xx, yy, xy) in &[
            (2.0, 1.0, 0.3),
            (1.0, 1.0, 0.0),
            (-1.0, 3.0, -2.0),
            (1.0, 1.0, 1e-9),
            (1.0, 2.0, 0.0),
            (1.0, 2.0, -0.0),
            (1.0, 1.0 + 1e-15, 1e-300),
            (3.0, -1.0, 1e-12),
        ] {
            let e = Spectral::of(xx, yy, xy);
            assert!(e.l1 >= e.l2);
            let m = e.compose(e.l1, e.l2);
            let want = Mat2::new(xx, xy, xy, yy);
            assert!((m - want).norm() < 1e-13 * (1.0 + want.norm()), "{m} against {want}");
            // The first eigenvector is one.
            let v = nalgebra::Vector2::new(e.c, e.s);
            assert!((want * v - v * e.l1).norm() < 1e-13 * (1.0 + want.norm()));
        }
    }
}
