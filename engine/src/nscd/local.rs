//! The contact laws of contact dynamics as graphs, and their exact local solvers (Moreau 1988,
//! 1994; Jean 1999; docs/physics.md §3.2; Roux & Chevoir 2005, §2.2.3 for the cohesion).
//!
//! At one contact, with the others frozen, the local velocity is affine in the local impulse:
//! `U = u + W r`, `u` the velocity the contact would have without its own impulse and `W` the
//! local block of the Delassus operator. The laws, in the local frame `(n, t1, t2)`:
//! - **Signorini at velocity level**, shifted by the cohesion: with `rho = r_n + c >= 0` (the
//!   contact's part of the normal impulse; with a liquid, below, `r_n + c + k U_n`),
//!   `U_n >= b`, `rho (U_n - b) = 0`. `b = -e min(u_n^-, 0)` is Moreau's formal-velocity
//!   condition `(U_n + e u_n^-) / (1 + e) >= 0` for the normal restitution `e` and the velocity
//!   `u_n^-` at the start of the step; `c` is the impulse of a cohesive force over the step
//!   (`F_0 h` for a constant attraction F_0 within D_0);
//! - **Coulomb**: `|r_t| <= mu rho`; where `|r_t| < mu rho` the contact sticks (`U_t = 0`),
//!   otherwise it slides with `U_t` opposite to `r_t`;
//! - **viscous liquid** (lubrication, Nezamabadi 2020, eqs. 1.9-1.11), implicit: a normal impulse
//!   `-k U_n` on top of the contact's, `k` the lubrication coefficient times the step (kg), so
//!   that the normal impulse is `r_n = rho - c - k U_n`. The friction cone bounds the contact's
//!   part `rho`.
//!
//! For two spheres (or disks), or a sphere and a wall, `W` is diagonal in the contact frame:
//! translations act on every direction alike (`1/m_i + 1/m_j`), the spins only on the
//! tangential ones (`a_i²/I_i + a_j²/I_j` more), and isotropic inertia couples no direction to
//! another. Then the normal part decouples and the tangential part is isotropic, so the
//! solution below — normal impulse from the Signorini graph, then the sticking impulse
//! projected on the disk of radius `mu rho` — solves the 2x2 (2D) and 3x3 (3D) problem exactly.
//!
//! Rolling resistance ([`Rolling`]) is a graph of its own on the moment impulse, solved as a
//! separate block of the Gauss-Seidel sweep (its bound depends on the normal impulse as
//! Coulomb's does).

use super::frame::tangential_norm;
use crate::math::{Real, Vec3};

/// The local block of the Delassus operator of a contact between round bodies, 1/kg: `n` on the
/// normal, `t` on each tangent (no coupling between directions; see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Delassus {
    /// Normal entry, 1/kg.
    pub n: Real,
    /// Tangential entry, 1/kg.
    pub t: Real,
}

impl Delassus {
    /// `W r` for a local impulse `r`.
    #[inline(always)]
    pub fn apply(&self, r: &Vec3) -> Vec3 {
        Vec3::new(self.n * r.x, self.t * r.y, self.t * r.z)
    }
}

/// The law of one contact for the current step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalLaw {
    /// Lower bound `b` of the normal velocity at the end of the step, m/s (the restitution
    /// term; see the module documentation).
    pub target: Real,
    /// Coulomb friction coefficient.
    pub friction: Real,
    /// Cohesive impulse `c` over the step, N·s (>= 0): the normal impulse may go down to `-c`.
    pub cohesion: Real,
    /// Viscous coefficient `k` over the step, kg (>= 0): the liquid's normal impulse per m/s of
    /// approach at the end of the step.
    pub viscosity: Real,
}

impl LocalLaw {
    /// The contact's compressive part `rho` of a normal impulse `r_n` that leaves the normal
    /// velocity `u_n`, N·s.
    #[inline(always)]
    pub fn contact_part(&self, r_n: Real, u_n: Real) -> Real {
        r_n + self.cohesion + self.viscosity * u_n
    }
}

/// Solves the local problem exactly: the impulse `r` (local components, N·s) such that
/// `U = u + W r` and `r` satisfy the law. `u` is the local velocity without the contact's own
/// impulse.
#[inline(always)]
pub fn solve(w: &Delassus, u: &Vec3, law: &LocalLaw) -> Vec3 {
    // Normal, open (rho = 0): U_n = u_n + w_n (-c - k U_n). If that leaves U_n below b, the
    // contact closes: U_n = b, r_n = (b - u_n) / w_n and rho = r_n + c + k b.
    let open = (u.x - w.n * law.cohesion) / (1.0 + w.n * law.viscosity);
    let (r_n, rho) = if open >= law.target {
        (-law.cohesion - law.viscosity * open, 0.0)
    } else {
        let r_n = (law.target - u.x) / w.n;
        (r_n, law.contact_part(r_n, law.target))
    };
    // Tangential: the sticking impulse, projected on the disk |r_t| <= mu rho.
    let (r1, r2) = within_disk(-u.y / w.t, -u.z / w.t, law.friction * rho);
    Vec3::new(r_n, r1, r2)
}

/// A tangential impulse `(t1, t2)` (N·s) brought within Coulomb's disk of radius `limit`:
/// unchanged inside, scaled onto the edge outside (along itself).
#[inline(always)]
pub fn within_disk(t1: Real, t2: Real, limit: Real) -> (Real, Real) {
    let size = (t1 * t1 + t2 * t2).sqrt();
    if size > limit {
        let s = if size > 0.0 { limit / size } else { 0.0 };
        (t1 * s, t2 * s)
    } else {
        (t1, t2)
    }
}

/// Rolling resistance of a contact as a graph (the rigid-plastic limit of the moment law of
/// Roux & Chevoir 2005, §2.1.6; the elastic stiffness plays no part between rigid grains): the
/// rolling moment impulse `m` (N·m·s on the first body, the opposite on the second) lies in the
/// tangent plane, with `|m| <= bound rho` (`bound = mu_r R*`, m; `rho` the contact's compressive
/// normal impulse); where `|m| < bound rho` the pair does not roll (the tangential part of
/// `omega_i - omega_j` vanishes), otherwise it rolls against `m`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rolling {
    /// `mu_r R*`, m (0: no rolling resistance).
    pub bound: Real,
    /// Rolling block of the Delassus operator, `1/I_i + 1/I_j`, 1/(kg·m²) (0, bodies that do
    /// not turn: no rolling block).
    pub w: Real,
    /// Moment impulse, global components, N·m·s: the warm start on entry, the solution on
    /// exit.
    pub m: Vec3,
}

/// Solves the rolling graph exactly with the rest frozen: the moment impulse for a rolling
/// velocity `free` (the tangential part of `omega_i - omega_j` without the contact's own
/// moment, rad/s) and the compressive normal impulse `rho`, N·s.
#[inline(always)]
pub fn solve_rolling(rolling: &Rolling, free: &Vec3, rho: Real) -> Vec3 {
    let m = -free / rolling.w;
    let (size, limit) = (m.norm(), rolling.bound * rho.max(0.0));
    if size > limit {
        if size > 0.0 {
            m * (limit / size)
        } else {
            Vec3::zeros()
        }
    } else {
        m
    }
}

/// How far `(r, U = u + W r)` is from satisfying the law, in velocity units (m/s): the
/// violation of the Signorini graph (`max(0, b - U_n)`, and `U_n - b` where `rho > 0`), of the
/// friction cone and of the sliding rule. Zero for the exact solution. For tests and
/// diagnostics.
pub fn law_residual(w: &Delassus, u: &Vec3, law: &LocalLaw, r: &Vec3) -> Real {
    let big_u = u + w.apply(r);
    let mut rho = law.contact_part(r.x, big_u.x);
    // Zero up to the rounding of the terms that make it.
    if rho.abs() <= 1e-12 * (r.x.abs() + law.cohesion + law.viscosity * big_u.x.abs()) {
        rho = 0.0;
    }
    let mut res = (law.target - big_u.x).max(0.0);
    if rho < 0.0 {
        res = res.max(-rho * w.n);
    } else if rho > 0.0 {
        res = res.max((big_u.x - law.target).abs().min(rho * w.n));
    }
    let rt = tangential_norm(r);
    let ut = tangential_norm(&big_u);
    let limit = law.friction * rho.max(0.0);
    res = res.max((rt - limit).max(0.0) * w.t);
    if rt < limit * (1.0 - 1e-12) {
        res = res.max(ut);
    } else if rt > 0.0 {
        // Sliding: U_t opposite to r_t, i.e. U_t + (|U_t|/|r_t|) r_t = 0.
        let k = ut / rt;
        res = res.max(((big_u.y + k * r.y).powi(2) + (big_u.z + k * r.z).powi(2)).sqrt());
    }
    res
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (no dependency for tests of a pure function).
    fn lcg(state: &mut u64) -> Real {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*state >> 11) as Real) / ((1u64 << 53) as Real)
    }

    #[test]
    fn the_local_solution_satisfies_the_law() {
        let mut s = 7u64;
        for case in 0..20_000 {
            let w = Delassus { n: 0.1 + 10.0 * lcg(&mut s), t: 0.0 };
            let w = Delassus { t: w.n * (1.0 + 3.0 * lcg(&mut s)), ..w };
            let u = Vec3::new(4.0 * lcg(&mut s) - 2.0, 4.0 * lcg(&mut s) - 2.0, if case % 2 == 0 { 0.0 } else { 4.0 * lcg(&mut s) - 2.0 });
            let law = LocalLaw {
                target: if case % 3 == 0 { 0.0 } else { lcg(&mut s) },
                friction: if case % 5 == 0 { 0.0 } else { lcg(&mut s) },
                cohesion: if case % 4 == 0 { 0.3 * lcg(&mut s) } else { 0.0 },
                viscosity: if case % 7 < 3 { 2.0 * lcg(&mut s) } else { 0.0 },
            };
            let r = solve(&w, &u, &law);
            let res = law_residual(&w, &u, &law, &r);
            assert!(res < 1e-12, "case {case}: residual {res:e} for u {u:?}, law {law:?}, r {r:?}");
        }
    }

    #[test]
    fn known_cases() {
        let w = Delassus { n: 2.0, t: 7.0 };
        let free = LocalLaw { target: 0.0, friction: 0.5, cohesion: 0.0, viscosity: 0.0 };
        // Separating: no impulse.
        assert_eq!(solve(&w, &Vec3::new(1.0, 3.0, 0.0), &free), Vec3::zeros());
        // Approaching head-on, perfectly plastic: the impulse stops it.
        let r = solve(&w, &Vec3::new(-1.0, 0.0, 0.0), &free);
        assert!((r.x - 0.5).abs() < 1e-15 && r.y == 0.0);
        // Elastic rebound: b = 1 m/s doubles the impulse.
        let r = solve(&w, &Vec3::new(-1.0, 0.0, 0.0), &LocalLaw { target: 1.0, ..free });
        assert!((r.x - 1.0).abs() < 1e-15);
        // Sticks: the tangential impulse within the cone cancels the slip.
        let r = solve(&w, &Vec3::new(-1.0, 0.7, 0.0), &free);
        assert!((r.y + 0.1).abs() < 1e-15 && (r.y.abs() - 0.1).abs() < 1e-15);
        // Slides: at the cone, opposite to the slip.
        let r = solve(&w, &Vec3::new(-1.0, 7.0, 0.0), &free);
        assert!((r.y + 0.25).abs() < 1e-15);
        // Cohesion holds a separating contact up to the cohesive impulse.
        // Rolling: stops a rolling velocity within the bound, or resists it at the bound.
        let roll = Rolling { bound: 0.01, w: 4.0, m: Vec3::zeros() };
        let m = solve_rolling(&roll, &Vec3::new(0.0, 0.0, 0.2), 10.0);
        assert!((m.z + 0.05).abs() < 1e-15, "{m:?}");
        let m = solve_rolling(&roll, &Vec3::new(0.0, 0.0, 2.0), 10.0);
        assert!((m.z + 0.1).abs() < 1e-15, "{m:?}");
        assert_eq!(solve_rolling(&roll, &Vec3::new(0.0, 0.0, 2.0), -1.0), Vec3::zeros());
        let coh = LocalLaw { cohesion: 0.2, ..free };
        let r = solve(&w, &Vec3::new(0.3, 0.0, 0.0), &coh);
        assert!((r.x + 0.15).abs() < 1e-15, "{r:?}");
        let r = solve(&w, &Vec3::new(1.0, 0.0, 0.0), &coh);
        assert!((r.x + 0.2).abs() < 1e-15, "{r:?}");
        // A liquid of k = 0.5 kg slows an open approach: U = u / (1 + w k) = -0.5 m/s, impulse
        // -k U = 0.25 N·s; at a target of -0.4 m/s the contact closes and takes the rest.
        let wet = LocalLaw { viscosity: 0.5, target: -1.0, ..free };
        let r = solve(&w, &Vec3::new(-1.0, 0.0, 0.0), &wet);
        assert!((r.x - 0.25).abs() < 1e-15, "{r:?}");
        let r = solve(&w, &Vec3::new(-1.0, 0.0, 0.0), &LocalLaw { target: -0.4, ..wet });
        assert!((r.x - 0.3).abs() < 1e-15 && (wet.contact_part(r.x, -0.4) - 0.1).abs() < 1e-15, "{r:?}");
    }
}
