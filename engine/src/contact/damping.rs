//! Damping from a coefficient of restitution, for the linear spring-dashpot (Roux & Chevoir 2005,
//! eqs. 6 and 10; docs/references.md check 1) and for Hertz contacts (Tsuji et al. 1992;
//! docs/references.md check 4).
//!
//! Two conventions exist for the linear law. If the normal force may turn attractive at the end
//! of a collision (`limit_damping = false`, LAMMPS's default), the contact ends when the overlap
//! returns to zero and `e = exp(-pi zeta / sqrt(1 - zeta^2))`. If the force is floored at zero
//! (`limit_damping = true`, our default, docs/physics.md §2.2), the grains separate when the force
//! vanishes, earlier, and the restitution follows Schwager & Pöschel (Granular Matter 9, 2007):
//! `e = exp(-eta t_f) |cos(w t_f) - (eta / w) sin(w t_f)|` with
//! `w t_f = pi - atan2(2 eta w, w0^2 - 2 eta^2)`. In both cases the damping ratio is chosen so that
//! a head-on collision returns exactly the requested restitution.

/// Smallest restitution reachable when damping is limited (critical damping gives e^-2 ≈ 0.135).
pub const MIN_LIMITED_RESTITUTION: f64 = 0.14;

/// Damping ratio zeta = gamma_n / (2 sqrt(m* k_n)) giving restitution `e` when the force may turn
/// attractive (Roux & Chevoir 2005, eq. 10, inverted): `zeta = -ln e / sqrt(pi^2 + ln^2 e)`.
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

/// Hertz damping coefficient `c` (gamma_n = c sqrt(S m*), S the contact's tangent stiffness:
/// the damping of Tsuji, Tanaka & Ishida, Powder Technol. 71, 1992) that returns the restitution
/// `e` of a head-on collision, for a force that may turn attractive (`limited` false) or is
/// floored at zero (`limited` true).
///
/// The restitution of this law does not depend on the impact speed (the equation of motion
/// scales out, see [`hertz_restitution`]). For a force that may turn attractive the relation of
/// LIGGGHTS's `gran/hertz/history`, `c = -2 sqrt(5/6) beta` with
/// `beta = ln e / sqrt(ln² e + pi²)`, is exact: integrating the equation gives `e` back to 1e-4
/// (tested; Tsuji's fitted polynomial, LAMMPS `pair granular ... damping tsuji`, agrees to
/// 0.3%). With the force floored at zero the grains part before the overlap closes, as for the
/// linear law (Schwager & Pöschel 2007), and that relation rebounds too fast (e = 0.3 gives
/// 0.397, 0.5 gives 0.550); there is no closed form, so `c` is found by bisection on the
/// integrated restitution. Any `e` in (0, 1] is reachable either way.
pub fn hertz_damping_coefficient(e: f64, limited: bool) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let l = e.ln();
    let beta = l / (l * l + std::f64::consts::PI.powi(2)).sqrt();
    let unlimited = -2.0 * (5.0_f64 / 6.0).sqrt() * beta;
    if !limited {
        return unlimited;
    }
    // Flooring the force only raises the restitution, so the answer lies above the unlimited
    // coefficient: bracket it by doubling, then bisect.
    let (mut lo, mut hi) = (unlimited, 2.0 * unlimited.max(1e-3));
    while hertz_restitution(hi, true) > e && hi < 1e6 {
        lo = hi;
        hi *= 2.0;
    }
    while hi - lo > 1e-9 * hi {
        let mid = 0.5 * (lo + hi);
        if hertz_restitution(mid, true) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Restitution of a head-on Hertz collision with damping coefficient `c` (see
/// [`hertz_damping_coefficient`]). In units where the mass, the Hertz constant and the impact
/// speed are 1, the overlap obeys `y'' = -y^(3/2) - c sqrt(3/2) y^(1/4) y'` from `y = 0`,
/// `y' = 1`, whatever the real values (scaling y by v^(4/5) and time by v^(-1/5) removes v);
/// integrated by RK4 with 1/1000 of the unit time (the restitution changes by 2e-5 when the
/// step is divided by 5). The grains part when the overlap returns to zero, or, with
/// `limited`, when the floored force first vanishes (it then stays zero: its elastic part
/// shrinks faster than its damping part as the overlap closes at constant speed).
pub fn hertz_restitution(c: f64, limited: bool) -> f64 {
    const H: f64 = 1e-3;
    let k = c * 1.5_f64.sqrt();
    // Force of the contact (repulsive positive) at overlap y and rate v.
    let force = |y: f64, v: f64| {
        let s = y.max(0.0).sqrt();
        y.max(0.0) * s + k * s.sqrt() * v
    };
    let (mut y, mut v) = (0.0_f64, 1.0_f64);
    // An overdamped contact (only without the floor) creeps back for ever: stop at a time far
    // beyond any rebound (the elastic contact lasts about 3.2 units) and call it dead.
    for _ in 0..(200.0 / H) as usize {
        let f1 = (v, -force(y, v));
        let f2 = (v + 0.5 * H * f1.1, -force(y + 0.5 * H * f1.0, v + 0.5 * H * f1.1));
        let f3 = (v + 0.5 * H * f2.1, -force(y + 0.5 * H * f2.0, v + 0.5 * H * f2.1));
        let f4 = (v + H * f3.1, -force(y + H * f3.0, v + H * f3.1));
        let yn = y + H / 6.0 * (f1.0 + 2.0 * f2.0 + 2.0 * f3.0 + f4.0);
        let vn = v + H / 6.0 * (f1.1 + 2.0 * f2.1 + 2.0 * f3.1 + f4.1);
        // The end of the contact, interpolated linearly within the step.
        if limited && vn < 0.0 {
            let (a, b) = (force(y, v), force(yn, vn));
            if b <= 0.0 {
                let s = if a > b { a / (a - b) } else { 1.0 };
                return -(v + s * (vn - v));
            }
        }
        if yn <= 0.0 {
            let s = y / (y - yn);
            return -(v + s * (vn - v));
        }
        (y, v) = (yn, vn);
    }
    0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unlimited_map_matches_reference_table() {
        // docs/references.md check 1: zeta 0.05 -> 0.854, 0.1 -> 0.729, 0.2 -> 0.527, 0.3 -> 0.372.
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
            // (docs/references.md check 1, Schwager & Pöschel), so more damping is needed.
            assert!(z > zeta_unlimited(e), "e {e}: {z} vs {}", zeta_unlimited(e));
        }
    }

    #[test]
    fn hertz_damping_returns_the_requested_restitution_with_and_without_the_floor() {
        // Tsuji et al.'s fitted alpha(e) (LAMMPS pair granular, damping tsuji), with eta =
        // sqrt(2) alpha sqrt(m* F/delta) (Marshall 2009's convention): c = sqrt(4/3) alpha.
        let tsuji = |e: f64| {
            let p = [1.2728, -4.2783, 11.087, -22.348, 27.467, -18.022, 4.8218];
            p.iter().rev().fold(0.0, |acc, a| acc * e + a)
        };
        for e in [0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99] {
            let free = hertz_damping_coefficient(e, false);
            assert!((hertz_restitution(free, false) - e).abs() < 1e-4, "e {e}: {}", hertz_restitution(free, false));
            if (0.1..=0.9).contains(&e) {
                let fit = (4.0_f64 / 3.0).sqrt() * tsuji(e);
                assert!((free - fit).abs() < 3e-3 * fit, "e {e}: c {free} against Tsuji's fit {fit}");
            }
            let floored = hertz_damping_coefficient(e, true);
            assert!((hertz_restitution(floored, true) - e).abs() < 1e-6, "e {e}: {}", hertz_restitution(floored, true));
            // The floor lets the grains part early: more damping for the same restitution.
            assert!(floored > free, "e {e}: {floored} vs {free}");
        }
        assert_eq!(hertz_damping_coefficient(1.0, true), 0.0);
        assert!((hertz_restitution(0.0, true) - 1.0).abs() < 1e-6);
    }
}
