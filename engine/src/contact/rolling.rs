//! Rolling resistance (Roux & Chevoir 2005, §2.1.6; Iwashita & Oda 1998; docs/physics.md §2.6):
//! an elastic spring on the relative rolling rotation with a plastic threshold. The spring `theta`
//! (rad) accumulates the tangential part of the relative angular velocity `(omega_i - omega_j)`;
//! the moment on i is `M = -k_r theta`, capped at `mu_r R* f_n` (the spring is rescaled onto the
//! cap when it slips). Units: k_r in N·m/rad, moments in N·m.

use crate::math::Vec3;

/// Rolling resistance law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingResistance {
    /// Stiffness k_r, N·m/rad.
    pub stiffness: f64,
    /// Rolling friction coefficient mu_r (dimensionless).
    pub friction: f64,
}

impl RollingResistance {
    /// Advances the spring and returns the moment on body i (N·m); body j gets the opposite.
    #[inline(always)]
    pub fn moment(&self, theta: &mut Vec3, n: &Vec3, w_rel: &Vec3, dt: f64, r_eff: f64, f_n: f64) -> Vec3 {
        // Keep the spring in the tangent plane (length preserved), then add the rolling increment.
        let len2 = theta.norm_squared();
        *theta -= n * theta.dot(n);
        let new2 = theta.norm_squared();
        if new2 > 0.0 {
            *theta *= (len2 / new2).sqrt();
        }
        let w_roll = w_rel - n * w_rel.dot(n);
        *theta += w_roll * dt;
        let mut m = -*theta * self.stiffness;
        let cap = self.friction * r_eff * f_n;
        let mag = m.norm();
        if mag > cap {
            m *= if mag > 0.0 { cap / mag } else { 0.0 };
            *theta = if self.stiffness > 0.0 { -m / self.stiffness } else { Vec3::zeros() };
        }
        m
    }
}
