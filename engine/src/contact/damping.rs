//! Damping from a coefficient of restitution, for the linear spring-dashpot (RC 6, 10;
//! REFERENCES.md check 1) and for Hertz contacts (LIGGGHTS-style, REFERENCES.md check 4).
//!
//! Two conventions exist for the linear law. If the normal force may turn attractive at the end
//! of a collision (`limit_damping = false`, LAMMPS's default), the contact ends when the overlap
//! returns to zero and `e = exp(-pi zeta / sqrt(1 - zeta^2))`. If the force is floored at zero
//! (`limit_damping = true`, our default, as PHYSICS.md §2 asks), the grains separate when the force
//! vanishes, earlier, and the restitution follows Schwager & Pöschel (Granular Matter 9, 2007):
//! `e = exp(-eta t_f) |cos(w t_f) - (eta / w) sin(w t_f)|` with
//! `w t_f = pi - atan2(2 eta w, w0^2 - 2 eta^2)`. In both cases the damping ratio is chosen so that
//! a head-on collision returns exactly the requested restitution.

/// Smallest restitution reachable when damping is limited (critical damping gives e^-2 ≈ 0.135).
pub const MIN_LIMITED_RESTITUTION: f64 = 0.14;

/// Damping ratio zeta = gamma_n / (2 sqrt(m* k_n)) giving restitution `e` when the force may turn
/// attractive (RC 10): `zeta = -ln e / sqrt(pi^2 + ln^2 e)`.
pub fn zeta_unlimited(e: f64) -> f64 {
    let l = e.ln();
    -l / (std::f64::consts::PI.powi(2) + l * l).sqrt()
}

/// Restitution of a linear contact with damping ratio `zeta` when the force may turn attractive.
pub fn restitution_unlimited(zeta: f64) -> f64 {
    (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp()
}

/// Restitution of a linear contact with damping ratio `zeta < 1` when the normal force is floored
/// at zero (Schwager & Pöschel 2007), and the time at which the grains separate, in units of
/// 1/omega_0 = sqrt(m*/k_n).
pub fn restitution_limited(zeta: f64) -> (f64, f64) {
    let eta = zeta;
    let w = (1.0 - zeta * zeta).sqrt();
    if eta == 0.0 {
        return (1.0, std::f64::consts::PI);
    }
    let phi = (2.0 * eta * w).atan2(1.0 - 2.0 * eta * eta);
    let tf = (std::f64::consts::PI - phi) / w;
    let e = (-eta * tf).exp() * ((w * tf).cos() - eta / w * (w * tf).sin()).abs();
    (e, tf)
}

/// Damping ratio giving restitution `e` when the normal force is floored at zero; found by
/// bisection (`restitution_limited` decreases monotonically with zeta on [0, 1)).
/// `e` must be at least [`MIN_LIMITED_RESTITUTION`].
pub fn zeta_limited(e: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 0.999_f64);
    if e >= 1.0 {
        return 0.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if restitution_limited(mid).0 > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Hertz damping coefficient `c` such that gamma = c sqrt(S m*), with S the contact's tangent
/// stiffness: `c = -2 sqrt(5/6) beta`, `beta = ln e / sqrt(ln^2 e + pi^2)` (LIGGGHTS
/// `gran/hertz/history`; gives a restitution independent of impact speed, close to `e`).
pub fn hertz_damping_coefficient(e: f64) -> f64 {
    let l = e.ln();
    let beta = l / (l * l + std::f64::consts::PI.powi(2)).sqrt();
    -2.0 * (5.0_f64 / 6.0).sqrt() * beta
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unlimited_map_matches_reference_table() {
        // REFERENCES.md check 1: zeta 0.05 -> 0.854, 0.1 -> 0.729, 0.2 -> 0.527, 0.3 -> 0.372.
        for (z, e) in [(0.05, 0.854), (0.1, 0.729), (0.2, 0.527), (0.3, 0.372), (0.5, 0.163)] {
            assert!((restitution_unlimited(z) - e).abs() < 5e-4, "zeta {z}");
            assert!((zeta_unlimited(restitution_unlimited(z)) - z).abs() < 1e-12);
        }
    }

    #[test]
    fn limited_map_inverts_and_exceeds_unlimited() {
        for e in [0.2, 0.5, 0.7, 0.9, 0.99] {
            let z = zeta_limited(e);
            assert!((restitution_limited(z).0 - e).abs() < 1e-9, "e {e}");
            // Flooring the force lets the grains part before the dashpot has taken as much energy
            // (REFERENCES.md check 1, Schwager & Pöschel), so more damping is needed.
            assert!(z > zeta_unlimited(e), "e {e}: {z} vs {}", zeta_unlimited(e));
        }
    }
}
