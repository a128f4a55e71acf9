//! Binary collisions against the analytic spring-dashpot and Hertz results
//! (docs/physics.md §2; docs/references.md checks 1 and 3).

use crate::common;

use sable_engine::contact::damping::{restitution_unlimited, zeta_unlimited};
use sable_engine::run::Simulation;
use serde_json::json;

const D: f64 = 1e-3;
const RHO: f64 = 2500.0;

/// Outcome of a head-on collision: measured restitution, contact duration (from the first
/// instant of overlap to the instant the overlap returns to zero, both interpolated linearly
/// between steps), largest overlap, and relative energy change.
struct Collision {
    restitution: f64,
    duration: f64,
    max_overlap: f64,
    energy_change: f64,
    dt: f64,
}

fn collide(dim: usize, contact: serde_json::Value, e: f64, limit_damping: bool, v: f64, fraction: f64) -> Collision {
    let l = 0.02;
    let (min, max, pos, vel) = if dim == 2 {
        (json!([0, 0]), json!([l, l]), json!([[0.009, 0.01], [0.011 + 1e-4, 0.01]]), json!([[v, 0], [-v, 0]]))
    } else {
        (json!([0, 0, 0]), json!([l, l, l]), json!([[0.009, 0.01, 0.01], [0.011 + 1e-4, 0.01, 0.01]]), json!([[v, 0, 0], [-v, 0, 0]]))
    };
    let periodic = if dim == 2 { json!(["x", "y"]) } else { json!(["x", "y", "z"]) };
    let s = common::scene(json!({
        "dimension": dim,
        "method": {"kind": "dem", "time_step_fraction": fraction},
        "materials": {"m": {"density": RHO, "contact": contact, "restitution": e, "friction": 0.0,
                            "limit_damping": limit_damping}},
        "particles": [{"material": "m", "placement": {"kind": "list", "positions": pos,
                        "diameters": [D, D], "velocities": vel}}],
        "container": {"min": min, "max": max, "periodic": periodic},
        "stop": {"steps": 1}
    }));
    let mut sim = common::dem(&s);
    let dt = sim.time_step();
    let energy = |sim: &sable_engine::methods::dem::Dem| {
        let p = sim.particles();
        (0..2).map(|i| 0.5 * p.mass[i] * p.vel[i].norm_squared()).sum::<f64>() + sim.elastic_energy()
    };
    let e0 = energy(&sim);
    let gap = |sim: &sable_engine::methods::dem::Dem| {
        let p = sim.particles();
        (p.pos[1] - p.pos[0]).norm() - D
    };
    let mut prev = gap(&sim);
    let (mut start, mut end) = (None, None);
    let mut max_overlap: f64 = 0.0;
    for _ in 0..2_000_000 {
        sim.step().expect("stable collision");
        let g = gap(&sim);
        max_overlap = max_overlap.max(-g);
        let t = sim.time();
        if start.is_none() && g < 0.0 {
            start = Some(t - dt * g / (g - prev));
        }
        if start.is_some() && g >= 0.0 {
            end = Some(t - dt * g / (g - prev));
            break;
        }
        prev = g;
    }
    let (start, end) = (start.expect("contact began"), end.expect("contact ended"));
    // Let the force-free flight settle (nothing acts once separated).
    for _ in 0..10 {
        sim.step().expect("stable");
    }
    let p = sim.particles();
    let v_after = (p.vel[0] - p.vel[1]).x;
    Collision { restitution: -v_after / (2.0 * v), duration: end - start, max_overlap, energy_change: (energy(&sim) - e0) / e0, dt }
}

/// Linear stiffness giving the same collision time in 2D and 3D (t_c ≈ 26 µs, as in the
/// standard benchmark scene), N/m.
fn stiffness(dim: usize) -> f64 {
    1e4 * mass(dim) / mass(3)
}

fn mass(dim: usize) -> f64 {
    if dim == 2 {
        RHO * std::f64::consts::PI * D * D / 4.0
    } else {
        RHO * std::f64::consts::PI * D * D * D / 6.0
    }
}

#[test]
fn linear_collision_restitution_and_duration_follow_damped_oscillator() {
    // Contact ends when the overlap returns to zero; the force may turn attractive at the end
    // (limit_damping false), so the textbook e_n(zeta) and t_c apply exactly (docs/references.md check 1).
    for dim in [2, 3] {
        let k_n = stiffness(dim);
        for e in [0.9, 0.7, 0.5] {
            let c = collide(dim, json!({"law": "linear", "k_n": k_n}), e, false, 0.1, 0.005);
            let zeta = zeta_unlimited(e);
            let m_eff = mass(dim) / 2.0;
            let w0 = (k_n / m_eff).sqrt();
            let t_c = std::f64::consts::PI / (w0 * (1.0 - zeta * zeta).sqrt());
            let e_theory = restitution_unlimited(zeta);
            assert!((c.restitution - e_theory).abs() / e_theory < 1e-3, "{dim}D e={e}: restitution {} vs {e_theory}", c.restitution);
            assert!((c.duration - t_c).abs() / t_c < 1e-2, "{dim}D e={e}: duration {} vs {t_c}", c.duration);
            assert!(c.dt < t_c / 100.0);
        }
    }
}

#[test]
fn limited_damping_returns_the_requested_restitution() {
    // With the normal force floored at zero (the default) the damping is chosen by the
    // Schwager-Pöschel relation so that the requested restitution comes out. The force has a kink
    // where it reaches zero, so the error is first order in dt (measured at e = 0.5: 2.6e-3 at
    // t_c/200); t_c/1000 brings it under 1e-3.
    for dim in [2, 3] {
        for e in [0.9, 0.7, 0.5] {
            let c = collide(dim, json!({"law": "linear", "k_n": stiffness(dim)}), e, true, 0.1, 0.001);
            assert!((c.restitution - e).abs() / e < 1e-3, "{dim}D e={e}: got {}", c.restitution);
        }
    }
}

#[test]
fn undamped_linear_collision_conserves_energy() {
    for dim in [2, 3] {
        let c = collide(dim, json!({"law": "linear", "k_n": stiffness(dim)}), 1.0, false, 0.1, 0.02);
        assert!(c.energy_change.abs() < 1e-4, "{dim}D: relative energy change {}", c.energy_change);
        assert!((c.restitution - 1.0).abs() < 1e-4);
    }
}

#[test]
fn hertz_collision_time_and_overlap_match_theory() {
    // Elastic Hertz impact (docs/references.md check 3): delta_max = (15 m* v² / (16 E* sqrt(R*)))^(2/5),
    // t_H = 2.87 (m*² / (R* E*² v))^(1/5) (accurate to about 0.1%).
    let nu = 0.3;
    for dim in [2, 3] {
        // Same mass-to-stiffness ratio in both dimensions (2D masses are per metre of thickness).
        let young = 1e7 * mass(dim) / mass(3);
        for v in [0.05, 0.2] {
            let c = collide(dim, json!({"law": "hertz_mindlin", "young_modulus": young, "poisson_ratio": nu}), 1.0, false, v, 0.005);
            let e_star = young / (2.0 * (1.0 - nu * nu));
            let r_eff = D / 4.0;
            let m_eff = mass(dim) / 2.0;
            let vr = 2.0 * v;
            let dmax = (15.0 * m_eff * vr * vr / (16.0 * e_star * r_eff.sqrt())).powf(0.4);
            let t_h = 2.87 * (m_eff * m_eff / (r_eff * e_star * e_star * vr)).powf(0.2);
            assert!((c.max_overlap - dmax).abs() / dmax < 5e-3, "{dim}D v={v}: overlap {} vs {dmax}", c.max_overlap);
            assert!((c.duration - t_h).abs() / t_h < 1e-2, "{dim}D v={v}: duration {} vs {t_h}", c.duration);
            assert!(c.energy_change.abs() < 1e-4, "energy change {}", c.energy_change);
        }
    }
}

#[test]
fn hertz_collisions_rebound_at_the_requested_restitution() {
    // The damping coefficient is calibrated so that a head-on Hertz collision returns the
    // requested e, with the force floored at zero (the default) or not, at any impact speed.
    // At the default step (t_c/50) the remaining error is the integrator's: the issue asks 1e-2.
    let nu = 0.3;
    for dim in [2, 3] {
        let young = 1e7 * mass(dim) / mass(3);
        for limit in [true, false] {
            for e in [0.1, 0.3, 0.5, 0.7, 0.9] {
                for v in [0.05, 0.5] {
                    let c = collide(dim, json!({"law": "hertz_mindlin", "young_modulus": young, "poisson_ratio": nu}), e, limit, v, 0.02);
                    assert!((c.restitution - e).abs() < 1e-2, "{dim}D e={e} limit_damping={limit} v={v}: rebounds at {}", c.restitution);
                }
            }
        }
    }
}
