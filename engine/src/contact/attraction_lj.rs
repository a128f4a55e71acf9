//! Attraction between the primary particles of one aggregate, the bonded particle method's soft
//! grain (Nguyen's thesis, as Nezamabadi 2020, §1.2.1, eq. 1.12 gives it; docs/physics.md §4): the
//! attractive branch of a Lennard-Jones-type law, along the normal,
//!
//! - `F_a(δ) = F_0 (1 + δ/a_0)^(−γ)` for a gap `0 <= δ <= δ_c` between the surfaces,
//!   `a_0 = R_1 + R_2`, `F_0` the largest attraction (at touching), `γ = 7` in the sources;
//! - `F_0` in contact (`δ < 0`): the repulsion is the contact's own (frictionless and inelastic
//!   in the sources, solved by contact dynamics);
//! - 0 beyond the cut-off `δ_c`.
//!
//! The energy `U(δ) = −∫_δ^{δ_c} F_a = −F_0 a_0 / (γ − 1) [(1 + δ/a_0)^(1−γ) − (1 + δ_c/a_0)^(1−γ)]`
//! is zero at the cut-off and `U(0) + F_0 δ` in contact, so that `F = −dU/dδ` everywhere but at
//! the cut-off, where the force drops from `F_0 (1 + δ_c/a_0)^(−γ)` to zero (0.3% of `F_0` for
//! `γ = 7` and `δ_c = 1.3 a_0`).
//!
//! An aggregate of such primaries is elastic–perfectly plastic with the characteristic stress
//! `p_I = F_0 / ⟨a_0⟩` in 2D (forces per unit length, N/m: the sources' `F_0 = 100` with
//! primaries of 0.07–0.13 mm give `p_I ≈ 1 MPa`), `F_0 / ⟨a_0⟩²` in 3D ([`characteristic_stress`]).
//! Units: N (N/m in 2D), m, J (J/m in 2D).

/// The attraction of one pair of primaries of the same aggregate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttractionLj {
    /// Largest attraction `F_0`, at touching, N (N/m in 2D).
    pub f0: f64,
    /// Exponent `γ` (7 in the sources), > 1.
    pub gamma: f64,
    /// Cut-off `δ_c`: the gap beyond which the primaries do not attract, m.
    pub cutoff: f64,
}

/// The sources' exponent `γ`.
pub const GAMMA: f64 = 7.0;

impl AttractionLj {
    /// Normal force, negative (attractive), at gap `gap` (m; negative in contact) between
    /// primaries of radii `ri`, `rj` (m).
    #[inline(always)]
    pub fn force(&self, gap: f64, ri: f64, rj: f64) -> f64 {
        if gap < 0.0 {
            -self.f0
        } else if gap <= self.cutoff {
            -self.f0 * decay(1.0 + gap / (ri + rj), self.gamma)
        } else {
            0.0
        }
    }

    /// Potential energy of the pair (J), zero at and beyond the cut-off: `force = −dU/dgap`.
    pub fn energy(&self, gap: f64, ri: f64, rj: f64) -> f64 {
        let a0 = ri + rj;
        let power = |d: f64| (1.0 + d / a0).powf(1.0 - self.gamma);
        let at = |d: f64| -self.f0 * a0 / (self.gamma - 1.0) * (power(d) - power(self.cutoff));
        if gap < 0.0 {
            at(0.0) + self.f0 * gap
        } else if gap <= self.cutoff {
            at(gap)
        } else {
            0.0
        }
    }

    /// Gap within which the pair attracts, m.
    pub fn range(&self) -> f64 {
        self.cutoff
    }
}

/// `base^(−γ)`: by multiplications for a whole `γ` up to 16 (the sources' 7), by `powf`
/// otherwise (which took 40% of a 3D DEM step of aggregates, whose primaries have some 60
/// neighbours within the cut-off).
#[inline(always)]
fn decay(base: f64, gamma: f64) -> f64 {
    let n = gamma as i32;
    if f64::from(n) == gamma && (1..=16).contains(&n) {
        base.powi(-n)
    } else {
        base.powf(-gamma)
    }
}

/// The characteristic stress `p_I` (Pa) of aggregates of primaries attracting with `f0` (N/m in
/// 2D, N in 3D) at the mean contact distance `mean_a0` (m, the mean of `R_1 + R_2`), in
/// `dimension` 2 or 3 (module documentation).
pub fn characteristic_stress(f0: f64, mean_a0: f64, dimension: usize) -> f64 {
    if dimension == 2 {
        f0 / mean_a0
    } else {
        f0 / (mean_a0 * mean_a0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sources' law: `F_0` = 100 N/m, γ = 7, primaries of 0.05 and 0.06 mm radius, cut-off
    /// 0.13 mm (the largest primary's diameter).
    fn law() -> (AttractionLj, f64, f64) {
        (AttractionLj { f0: 100.0, gamma: GAMMA, cutoff: 0.13e-3 }, 0.05e-3, 0.06e-3)
    }

    /// The force against the formula at touching, at `δ = a_0` (`2^−γ F_0`) and at the cut-off,
    /// `F_0` in contact and zero beyond the cut-off.
    #[test]
    fn the_force_is_the_attractive_branch_cut_off() {
        let (l, ri, rj) = law();
        let a0 = ri + rj;
        assert_eq!(l.force(0.0, ri, rj), -100.0);
        assert_eq!(l.force(-1e-6, ri, rj), -100.0);
        assert!((l.force(a0, ri, rj) + 100.0 / 128.0).abs() < 1e-12);
        let at_cutoff = 100.0 * (1.0 + 0.13 / 0.11f64).powi(-7);
        assert!((l.force(l.cutoff, ri, rj) + at_cutoff).abs() < 1e-12 * 100.0);
        assert!(at_cutoff < 0.0045 * 100.0, "the drop at the cut-off: {at_cutoff} N/m");
        assert_eq!(l.force(l.cutoff * 1.0001, ri, rj), 0.0);
        assert_eq!(characteristic_stress(100.0, 0.1e-3, 2), 1e6);
    }

    /// `U(δ) = ∫_δ^{δ_c} F_a` by Simpson's rule on 2,000 intervals (error ~1e-12 of `U(0)`), zero
    /// at the cut-off, `U(0) = −F_0 a_0/(γ − 1) (1 − (1 + δ_c/a_0)^(1−γ))`, and `F = −dU/dδ` by
    /// central differences in contact and apart.
    #[test]
    fn the_energy_is_the_integral_of_the_force() {
        let (l, ri, rj) = law();
        let a0 = ri + rj;
        let u0 = -100.0 * a0 / 6.0 * (1.0 - (1.0 + l.cutoff / a0).powi(-6));
        assert!((l.energy(0.0, ri, rj) - u0).abs() < 1e-12 * u0.abs());
        assert_eq!(l.energy(l.cutoff, ri, rj), 0.0);
        assert_eq!(l.energy(2.0 * l.cutoff, ri, rj), 0.0);
        for start in [0.0, 0.2 * a0, 0.9 * a0] {
            let n = 2000;
            let h = (l.cutoff - start) / n as f64;
            let f = |k: usize| l.force(start + k as f64 * h, ri, rj);
            let simpson: f64 = (0..n / 2).map(|k| f(2 * k) + 4.0 * f(2 * k + 1) + f(2 * k + 2)).sum::<f64>() * h / 3.0;
            let u = l.energy(start, ri, rj);
            assert!((u - simpson).abs() < 1e-9 * u0.abs(), "at {start}: U {u} against the integral {simpson}");
        }
        for gap in [-0.1 * a0, 0.1 * a0, 0.7 * a0] {
            let e = 1e-6 * a0;
            let derivative = (l.energy(gap + e, ri, rj) - l.energy(gap - e, ri, rj)) / (2.0 * e);
            let f = l.force(gap, ri, rj);
            assert!((f + derivative).abs() < 1e-6 * f.abs(), "at {gap}: F {f} against −dU/dδ {}", -derivative);
        }
    }
}
