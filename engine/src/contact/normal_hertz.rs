//! Hertz normal force (Roux & Chevoir 2005, eqs. 1-2; docs/references.md check 3):
//! `f_n = 4/3 E* sqrt(R*) delta^(3/2)`, tangent stiffness `S_n = 2 E* sqrt(R* delta)`, damping
//! `gamma_n = c sqrt(S_n m*)` with `c` from
//! [`hertz_damping_coefficient`](super::damping::hertz_damping_coefficient).
//! In 2D the same law is applied to disks (as LAMMPS's 2D granular examples do).
//! Units: E* in Pa, R* and delta in m, forces in N.

use super::NormalForce;

/// Hertz normal law with LIGGGHTS-style damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalHertz {
    /// Effective modulus E* = 1 / ((1 - nu1²)/E1 + (1 - nu2²)/E2), Pa.
    pub e_star: f64,
    /// Damping coefficient c (dimensionless).
    pub damp: f64,
}

impl NormalForce for NormalHertz {
    #[inline(always)]
    fn stiffness(&self, delta: f64, r_eff: f64) -> f64 {
        2.0 * self.e_star * (r_eff * delta.max(0.0)).sqrt()
    }
    #[inline(always)]
    fn elastic(&self, delta: f64, r_eff: f64) -> f64 {
        4.0 / 3.0 * self.e_star * (r_eff * delta).sqrt() * delta
    }
    #[inline(always)]
    fn damping(&self, delta: f64, r_eff: f64, m_eff: f64) -> f64 {
        self.damp * (self.stiffness(delta, r_eff) * m_eff).sqrt()
    }
    fn energy(&self, delta: f64, r_eff: f64) -> f64 {
        8.0 / 15.0 * self.e_star * r_eff.sqrt() * delta.powf(2.5)
    }
}
