//! Contact dynamics in a rotating drum (docs/physics.md §3; Nezamabadi 2020, §3.2.1) against the
//! balance of one round grain worked out by hand: with rolling friction `mu_r` against the drum
//! (and sliding friction above it), a grain rolling without slip on the turning wall keeps its
//! place at the angle `alpha` from the bottom where `tan alpha = mu_r`, carried up below it and
//! rolling down above.
//!
//! Tolerances: the balance is exact for the implicit scheme (constant forces over whole steps),
//! so it holds to the solver's tolerance (1e-10 relative): the grain's centre moves by less than
//! 1e-9 of its radius in 2,000 steps, the drum's torque matches within 1e-6.

use crate::common;

use sable_engine::methods::cd::Cd;
use sable_engine::run::Simulation;
use sable_engine::scene::Controls;
use serde_json::json;
use std::f64::consts::PI;

const G: f64 = 9.81;
const D: f64 = 0.002;
const R: f64 = D / 2.0;
/// The drum's inner radius (inscribed in a 0.02 m square), m.
const DRUM: f64 = 0.01;
const RHO: f64 = 2500.0;

/// A grain in a drum of axis z about (0.01, 0.01) at the angle `alpha` from the bottom on the
/// side towards +x, with rolling friction `mu_r` and sliding friction 1 (grain and drum), at rest
/// and spinning as if rolling without slip on the drum turning at `omega`; the drum turns.
fn grain_in_drum(dim: usize, alpha: f64, mu_r: f64, omega: f64) -> Cd {
    let rough = json!({"density": RHO, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.0, "friction": 1.0,
                       "rolling": {"stiffness": 1e-3, "friction": mu_r}});
    // Touching the drum (within 1e-14 m: placement wants the grain inside).
    let arm = (DRUM - R) * (1.0 - 1e-12);
    let (x, y) = (DRUM + arm * alpha.sin(), DRUM - arm * alpha.cos());
    let (position, min, max, periodic, gravity) = if dim == 2 {
        (json!([x, y]), json!([0, 0]), json!([0.02, 0.02]), json!([]), json!([0, -G]))
    } else {
        (json!([x, y, 0.005]), json!([0, 0, 0]), json!([0.02, 0.02, 0.01]), json!(["z"]), json!([0, -G, 0]))
    };
    let mut sim = common::cd(&common::scene(json!({
        "dimension": dim,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": 1e-10, "violation_tolerance": 1e-12, "max_iterations": 100000},
        "materials": {"grain": rough},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": [position], "diameters": [D]}}],
        "container": {"min": min, "max": max, "periodic": periodic, "wall_material": "grain"},
        "gravity": gravity,
        "experiment": {"kind": "drum", "angular_velocity": omega, "revolutions": 1.0}
    })));
    // Rolling without slip on the drum's surface (speed omega DRUM) with the centre at rest.
    sim.particles_mut().omega[0].z = omega * DRUM / R;
    sim.apply_controls(&Controls { drum_angular_velocity: Some(omega), ..Controls::default() }).expect("controls");
    sim
}

/// Angle of the grain's centre from the bottom of the drum, rad.
fn angle(sim: &Cd) -> f64 {
    let x = sim.particles().pos[0];
    (x.x - DRUM).atan2(DRUM - x.y)
}

#[test]
fn a_grain_rolling_on_a_turning_drum_keeps_its_place_where_tan_alpha_is_mu_r() {
    let (mu_r, omega) = (0.2f64, 2.0);
    let alpha = mu_r.atan();
    for dim in [2, 3] {
        let mass = if dim == 2 { RHO * PI * R * R } else { RHO * 4.0 / 3.0 * PI * R.powi(3) };
        let mut sim = grain_in_drum(dim, alpha, mu_r, omega);
        let start = sim.particles().pos[0];
        for _ in 0..2000 {
            sim.step().expect("stable");
        }
        let p = sim.particles();
        assert!((p.pos[0] - start).norm() < 1e-9 * R, "dim {dim}: the grain moved by {:e} m", (p.pos[0] - start).norm());
        assert!((p.omega[0].z - omega * DRUM / R).abs() < 1e-9 * omega * DRUM / R, "dim {dim}: spin {}", p.omega[0].z);
        // The drum carries the grain's weight, and the drive turns it against the moment of
        // that weight about the axis: -m g (DRUM - R) sin alpha (the contact force at DRUM from
        // the axis less the rolling moment).
        let drum = sim.drum().expect("drum");
        assert!((drum.force.y + mass * G).abs() < 1e-6 * mass * G, "dim {dim}: drum loaded by {:?}", drum.force);
        let torque = -mass * G * (DRUM - R) * alpha.sin();
        assert!(((drum.torque - torque) / torque).abs() < 1e-6, "dim {dim}: torque {} N m, expected {torque}", drum.torque);
    }
}

#[test]
fn below_that_angle_the_drum_carries_the_grain_up_and_above_it_the_grain_rolls_down() {
    let (mu_r, omega) = (0.2f64, 2.0);
    for dim in [2, 3] {
        for (factor, up) in [(0.8, true), (1.2, false)] {
            let alpha = factor * mu_r.atan();
            let mut sim = grain_in_drum(dim, alpha, mu_r, omega);
            for _ in 0..200 {
                sim.step().expect("stable");
            }
            let moved = angle(&sim) - alpha;
            assert!(moved.abs() > 1e-4 && (moved > 0.0) == up, "dim {dim}: at {factor} atan(mu_r) the grain turned by {moved:e} rad");
            // Rolling, not sliding: the contact point moves with the drum's surface (its
            // velocity from the drive of the last step's contact).
            let p = sim.particles();
            let c = sim.contact_list().first().expect("in contact");
            let boundaries = vec![sable_engine::math::Vec3::zeros(); sim.walls().len() + 1];
            let u = c.relative_velocity(&p.vel, &p.omega, &boundaries);
            assert!(u.norm() < 1e-9 * omega * DRUM, "dim {dim}: slides at {u:?} m/s");
        }
    }
}
