//! The four-node quadrilateral at finite strain, total Lagrangian, with the F-bar treatment of
//! near incompressibility (de Souza Neto, Perić, Dutko & Owen, Int. J. Solids Struct. 33, 3277,
//! 1996), 2×2 Gauss points, in plane strain (per metre of thickness).
//!
//! At a Gauss point the deformation gradient is `F = I + Σ_a u_a ⊗ ∇N_a` (reference gradients,
//! `u_a` the nodal displacements). A plain element evaluates the law at `F`: its four points each
//! hold the volume, and a nearly incompressible material (ν → ½) then locks — the element can
//! barely bend. The F-bar element evaluates the law at `F̄ = (J₀/J)^{1/2} F`, `J = det F` and
//! `J₀` the determinant at the element's centre: the volume change is the centre's, one
//! constraint an element, and the deviatoric part is the point's own. The element's internal
//! forces are the derivative of its stored energy `Σ_g w_g ψ(F̄_g)`:
//! `f_a = Σ_g w_g r [P G_a + ½ (P : F)(F₀⁻ᵀ G₀_a − F⁻ᵀ G_a)]`, `r = (J₀/J)^{1/2}`,
//! `P = P(F̄)` the first Piola-Kirchhoff stress, `G_a` and `G₀_a` the reference gradients of
//! `N_a` at the point and at the centre. A uniform `F` gives `F̄ = F` (the patch test holds).
//!
//! The element's tangent `∂f/∂u` is in closed form from the law's tangent `A = ∂P/∂F̄`
//! ([`ConstitutiveLaw::tangent`], itself the algorithmic one). With `δF = e_i ⊗ G_a` for the
//! displacement `u_a·e_i`, `s = tr(F₀⁻¹δF₀) − tr(F⁻¹δF)` and `δF̄ = r (δF + ½ s F)`, the
//! second variation of `w ψ(F̄)` is `w [(A : δF̄_d) : δF̄_c + P : Δ_d δF̄_c]`, with
//! `P : Δ_d δF̄_c = ½ r [s_d P:δF_c + s_c P:δF_d + ½ s_c s_d P:F + Δ_d s_c P:F]` and
//! `Δ_d s_c = tr(F⁻¹δF_d F⁻¹δF_c) − tr(F₀⁻¹δF₀_d F₀⁻¹δF₀_c)` — first derivatives of the
//! law only. It agrees with central differences of the forces to 1e-6 relative (tests) at a
//! sixteenth of their cost: four law tangents an element instead of sixty-four stress
//! updates.

use nalgebra::Vector2;

use crate::constitutive::{ConstitutiveLaw, History, Mat2};
pub use crate::geometry::quad::Geometry;
use crate::math::Real;

type V2 = Vector2<Real>;

/// Why an element cannot be evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ElementFailure {
    /// The element is inverted at a Gauss point or its centre (`det F <= 0`), or its law is
    /// undefined there.
    Inverted {
        /// The smallest `det F` found.
        jacobian: Real,
    },
}

/// An element's state at a displacement: its internal forces and, at each Gauss point, the
/// deformation the law saw and the history it returned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Internal force on each node, N/m (the force the element exerts is its opposite).
    pub force: [V2; 4],
    /// The deformation gradient each point's law saw (`F̄` for the F-bar element).
    pub f: [Mat2; 4],
    /// The history at each point.
    pub history: [History; 4],
}

/// The deformation gradient `F` at Gauss point `g`, its determinant and the F-bar ratio
/// `r = (J₀/J)^{1/2}` (1 for the plain element; `j0` the determinant at the centre), or the
/// failure where the point, or for the F-bar element the centre, is inverted.
fn at_point(geo: &Geometry, u: &[V2; 4], g: usize, j0: Real, fbar: bool) -> Result<(Mat2, Real, Real), ElementFailure> {
    let f = geo.deformation(g, u);
    let j = f.determinant();
    if j.is_nan() || j <= 0.0 || (fbar && (j0.is_nan() || j0 <= 0.0)) {
        return Err(ElementFailure::Inverted { jacobian: j.min(j0) });
    }
    Ok((f, j, if fbar { (j0 / j).sqrt() } else { 1.0 }))
}

/// The element's internal forces at nodal displacements `u` from the points' histories `h` at
/// the step's start (module documentation); `fbar`: the F-bar element, else the plain one.
pub fn state(geo: &Geometry, u: &[V2; 4], h: &[History; 4], law: &dyn ConstitutiveLaw, fbar: bool) -> Result<State, ElementFailure> {
    let f0 = geo.deformation(4, u);
    let j0 = f0.determinant();
    let f0_inv_t = f0.try_inverse().map(|m| m.transpose());
    let mut out = State { force: [V2::zeros(); 4], f: [Mat2::identity(); 4], history: *h };
    for g in 0..4 {
        let (f, j, r) = at_point(geo, u, g, j0, fbar)?;
        let inverted = || ElementFailure::Inverted { jacobian: j.min(j0) };
        let fb = f * r;
        let (p, hist) = law.first_piola(&fb, &h[g]).ok_or_else(inverted)?;
        let w = geo.weight[g] * r;
        if fbar {
            let (Some(f_inv_t), Some(f0_inv_t)) = (f.try_inverse().map(|m| m.transpose()), f0_inv_t) else {
                return Err(inverted());
            };
            let pf = 0.5 * p.component_mul(&f).sum();
            for a in 0..4 {
                out.force[a] += (p * geo.grad[g][a] + (f0_inv_t * geo.grad[4][a] - f_inv_t * geo.grad[g][a]) * pf) * w;
            }
        } else {
            for a in 0..4 {
                out.force[a] += p * geo.grad[g][a] * w;
            }
        }
        out.f[g] = fb;
        out.history[g] = hist;
    }
    Ok(out)
}

/// The element's stiffness `∂f/∂u` at `u` (8×8, row `2a + i` the force on node `a` along `i`),
/// in closed form (module documentation), made symmetric.
pub fn stiffness(
    geo: &Geometry,
    u: &[V2; 4],
    h: &[History; 4],
    law: &dyn ConstitutiveLaw,
    fbar: bool,
) -> Result<[[Real; 8]; 8], ElementFailure> {
    let f0 = geo.deformation(4, u);
    let j0 = f0.determinant();
    let mut k = [[0.0; 8]; 8];
    for g in 0..4 {
        let (f, j, r) = at_point(geo, u, g, j0, fbar)?;
        let inverted = || ElementFailure::Inverted { jacobian: j.min(j0) };
        // The dof d = 2b + i moves node b along i: δF = e_i ⊗ G_b.
        let unit = |grad: &V2, d: usize| {
            let mut m = Mat2::zeros();
            m[(d % 2, 0)] = grad.x;
            m[(d % 2, 1)] = grad.y;
            m
        };
        let df: [Mat2; 8] = std::array::from_fn(|d| unit(&geo.grad[g][d / 2], d));
        let (fb, s, inv, inv0) = if fbar {
            let (Some(inv), Some(inv0)) = (f.try_inverse(), f0.try_inverse()) else {
                return Err(inverted());
            };
            // F⁻¹δF and F₀⁻¹δF₀: their traces make s, their products its second variation.
            let a: [Mat2; 8] = std::array::from_fn(|d| inv * df[d]);
            let a0: [Mat2; 8] = std::array::from_fn(|d| inv0 * unit(&geo.grad[4][d / 2], d));
            let s: [Real; 8] = std::array::from_fn(|d| a0[d].trace() - a[d].trace());
            (f * r, s, Some(a), Some(a0))
        } else {
            (f, [0.0; 8], None, None)
        };
        let (p, _) = law.first_piola(&fb, &h[g]).ok_or_else(inverted)?;
        let a = law.tangent(&fb, &h[g]).ok_or_else(inverted)?;
        let dfb: [Mat2; 8] = std::array::from_fn(|d| (df[d] + f * (0.5 * s[d])) * r);
        // A : δF̄_d.
        let adf: [Mat2; 8] =
            std::array::from_fn(|d| Mat2::from_fn(|x, y| (0..4).map(|ce| a[2 * x + y][ce] * dfb[d][(ce / 2, ce % 2)]).sum()));
        let pdf: [Real; 8] = std::array::from_fn(|d| p.component_mul(&df[d]).sum());
        let pf = p.component_mul(&f).sum();
        let w = geo.weight[g];
        for c in 0..8 {
            for d in 0..8 {
                let mut v = adf[d].component_mul(&dfb[c]).sum();
                if let (Some(a), Some(a0)) = (&inv, &inv0) {
                    let dds = (a[d] * a[c]).trace() - (a0[d] * a0[c]).trace();
                    v += 0.5 * r * (s[d] * pdf[c] + s[c] * pdf[d] + (0.5 * s[c] * s[d] + dds) * pf);
                }
                k[c][d] += w * v;
            }
        }
    }
    symmetrise(&mut k);
    Ok(k)
}

/// Replaces `k` by its symmetric part.
fn symmetrise(k: &mut [[Real; 8]; 8]) {
    for r in 0..8 {
        for c in 0..r {
            let m = 0.5 * (k[r][c] + k[c][r]);
            k[r][c] = m;
            k[c][r] = m;
        }
    }
}

/// The element's stiffness by central differences of [`state`] (one step of a millionth of
/// the element's size on each displacement), made symmetric: the check of [`stiffness`].
#[cfg(test)]
pub fn stiffness_by_differences(
    geo: &Geometry,
    u: &[V2; 4],
    h: &[History; 4],
    law: &dyn ConstitutiveLaw,
    fbar: bool,
) -> Result<[[Real; 8]; 8], ElementFailure> {
    let step = 1e-6 * geo.length;
    let mut k = [[0.0; 8]; 8];
    for col in 0..8 {
        let (b, d) = (col / 2, col % 2);
        let mut plus = *u;
        plus[b][d] += step;
        let mut minus = *u;
        minus[b][d] -= step;
        let (fp, fm) = (state(geo, &plus, h, law, fbar)?.force, state(geo, &minus, h, law, fbar)?.force);
        for a in 0..4 {
            for i in 0..2 {
                k[2 * a + i][col] = (fp[a][i] - fm[a][i]) / (2.0 * step);
            }
        }
    }
    symmetrise(&mut k);
    Ok(k)
}

/// Energy stored in the element at the deformations its points' laws saw, J/m: the energy whose
/// derivative [`state`]'s forces are (`ψ` per unit reference volume, each point's weight its
/// reference area).
pub fn stored_energy(geo: &Geometry, st: &State, law: &dyn ConstitutiveLaw) -> Real {
    (0..4).map(|g| geo.weight[g] * law.stored_energy(&st.f[g], &st.history[g]).unwrap_or(0.0)).sum()
}
