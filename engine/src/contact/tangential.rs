//! Tangential force with an elastic history spring and Coulomb friction (Cundall-Strack;
//! Nezamabadi 2020, eq. 1.3; Roux & Chevoir 2005, §2.1; docs/physics.md §2.3).
//!
//! The spring `xi` (m) accumulates the tangential relative displacement at the contact point.
//! Each step it is first carried along with the contact: the spin of the pair about the normal
//! turns it (twist), then it is projected onto the current tangent plane and rescaled to keep its
//! length, so that a pair in rigid rotation keeps its tangential force (objectivity). Then
//! `f_t = -(k_t xi + gamma_t v_t)`; if `|f_t| > mu f_n` the force is scaled back onto the Coulomb
//! cone and the spring reset to carry that force alone, `xi = -f_t / k_t`: a spring in series
//! with the slider holds the Coulomb force, so a sliding contact stores `|f_t|² / (2 k_t)` and
//! nothing more (Cundall & Strack 1979; LIGGGHTS's `tangential_model_history` and Yade's
//! Cundall-Strack law likewise never let the spring hold more than the Coulomb force). LAMMPS's `gran/hooke/history` keeps the dashpot's share in the spring
//! instead, `xi = -(f_t + gamma_t v_t) / k_t`: where `gamma_t |v_t|` exceeds the Coulomb force —
//! a fast slip under a light load — that spring is stretched backwards by
//! `(gamma_t |v_t| - mu f_n) / k_t` and pushes the grains along the slip once it slows, energy
//! no spring was given. Both resets give the same force while the contact slides.

use crate::math::Vec3;

/// Carries the spring along with the contact frame: twist by the mean spin about `n` over `dt`,
/// then project on the plane normal to `n`, keeping the length.
///
/// With `c = n·xi` and `s = spin_n dt`, the twist `xi × (s n)` is normal to `n` and to the
/// projected spring, so the carried spring is `xi - xi × (s n) - c n` and its squared length
/// `(|xi|² - c²)(1 + s²)`: the rescale to the old length is known from `c` and `s` alone, and
/// every part is computed side by side instead of one after the other (the carry was a quarter
/// of a dense packing's contact cost as a chain of dependent operations).
#[inline(always)]
pub fn carry_spring(xi: &mut Vec3, n: &Vec3, spin_n: f64, dt: f64) {
    let len2 = xi.norm_squared();
    if len2 == 0.0 {
        return;
    }
    let s = spin_n * dt;
    let c = n.dot(xi);
    // Rotation about n by the angle s (first order; the exact length is restored below).
    let twist = xi.cross(n) * s;
    // sqrt(len2 / new2) = (1 - e)^(-1/2) with e = 1 - new2/len2. A contact turns by a tiny
    // angle per step (e ~ 1e-10), where four terms of the series are exact to rounding (the next
    // is 35/128 e^4 < 3e-17 for |e| < 1e-4) and spare it a division and a square root.
    let kept = 1.0 - c * c / len2;
    let e = 1.0 - kept * (1.0 + s * s);
    let scale = if e.abs() < 1e-4 {
        1.0 + e * (0.5 + e * (0.375 + e * 0.3125))
    } else if kept > 0.0 {
        (1.0 / (kept * (1.0 + s * s))).sqrt()
    } else {
        // The spring lies along the normal: nothing of it is left in the tangent plane.
        0.0
    };
    *xi = (*xi - twist - n * c) * scale;
}

/// Advances the spring by `v_t dt` (mid-step sliding velocity) and returns the tangential force
/// on body i (N), with the dashpot acting on `v_damp` (end-of-step estimate), capped by Coulomb at
/// `mu f_n`. `k_t` in N/m, `gamma_t` in N·s/m, `f_n` >= 0 in N.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn tangential_force(xi: &mut Vec3, v_t: &Vec3, v_damp: &Vec3, dt: f64, k_t: f64, gamma_t: f64, mu: f64, f_n: f64) -> Vec3 {
    *xi += v_t * dt;
    let mut f_t = -(*xi * k_t + v_damp * gamma_t);
    let cap = mu * f_n;
    let mag2 = f_t.norm_squared();
    if mag2 > cap * cap {
        if mag2 > 0.0 {
            f_t *= cap / mag2.sqrt();
        }
        if k_t > 0.0 {
            *xi = -f_t / k_t;
        } else {
            *xi = Vec3::zeros();
        }
    }
    f_t
}
