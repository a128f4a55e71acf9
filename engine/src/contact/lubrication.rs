//! Normal lubrication force of a liquid bridge (Nezamabadi 2020, eqs. 1.9-1.11;
//! docs/physics.md §2.9): `f_vis = 3/2 pi R² eta hdot / (h + h_0)` for a gap h > 0 and
//! `3/2 pi R² eta hdot / h_0` in contact, with `hdot` the approach speed (positive when the gap
//! closes), eta the viscosity and h_0 the roughness length. Nezamabadi 2020 does not say which
//! radius R eq. 1.9 takes for unequal grains (its eq. 1.5 uses the geometric mean for the capillary
//! force); we take the harmonic mean radius `R = 2 R_i R_j / (R_i + R_j)`, which makes the law
//! Reynolds' `6 pi eta R*² hdot / h` with `R* = R_i R_j / (R_i + R_j)` and gives R for equal
//! grains. Units: Pa·s, m, m/s, N.

/// Lubrication law of one pair of wet materials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lubrication {
    /// Viscosity eta, Pa·s.
    pub viscosity: f64,
    /// Roughness length h_0, m.
    pub roughness: f64,
}

impl Lubrication {
    /// Repulsive (positive) when the gap closes, N.
    #[inline(always)]
    pub fn force(&self, h: f64, hdot: f64, ri: f64, rj: f64) -> f64 {
        let r = 2.0 * ri * rj / (ri + rj);
        let denom = if h > 0.0 { h + self.roughness } else { self.roughness };
        1.5 * std::f64::consts::PI * r * r * self.viscosity * hdot / denom
    }
}
