//! Linear spring-dashpot normal force (Nezamabadi 2020, eq. 1.2; Roux & Chevoir 2005, eqs. 4-5;
//! docs/physics.md §2.2):
//! `f_n = k_n delta + gamma_n d(delta)/dt` with `gamma_n = 2 zeta sqrt(m* k_n)`.
//! Units: k_n in N/m, delta in m, forces in N.

use super::NormalForce;

/// Linear normal law with viscous damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalLinear {
    /// Normal stiffness k_n, N/m.
    pub k_n: f64,
    /// Damping ratio zeta (dimensionless).
    pub zeta: f64,
}

impl NormalForce for NormalLinear {
    #[inline(always)]
    fn stiffness(&self, _delta: f64, _r_eff: f64) -> f64 {
        self.k_n
    }
    #[inline(always)]
    fn elastic(&self, delta: f64, _r_eff: f64) -> f64 {
        self.k_n * delta
    }
    #[inline(always)]
    fn damping(&self, _delta: f64, _r_eff: f64, m_eff: f64) -> f64 {
        2.0 * self.zeta * (m_eff * self.k_n).sqrt()
    }
    fn energy(&self, delta: f64, _r_eff: f64) -> f64 {
        0.5 * self.k_n * delta * delta
    }
}
