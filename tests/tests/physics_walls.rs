//! Stress-controlled walls: a packing confined by two servo walls (x_max, y_max) against two
//! fixed ones comes to rest with every wall carrying the imposed stress within 1%. The walls are
//! frictionless, so that the fixed walls must balance the servo walls exactly (with wall
//! friction, the side walls would carry part of the load, as in a silo).
//!
//! Why 1% is a fair bound: at rest the servo walls stop only where the measured stress equals
//! the target (their speed is `gain × error`, and a wall at rest has no lag), and the fixed walls
//! balance them through the packing; what remains is the residual motion allowed by the rest
//! criterion (kinetic energy below 1e-4 of the elastic energy — the jamming tests use 1e-3 — and
//! walls moving by less than 1e-3 of an overlap per 1,000 steps), far below 1%.

use crate::common;

use sable_engine::run::Simulation;
use serde_json::json;

#[test]
fn servo_walls_hold_the_imposed_stress_at_equilibrium() {
    let k_n = 1e5;
    let stress = 1e-3 * k_n; // overlaps of about 1e-3 d
    let (n, d) = (120, 1e-3);
    let area = std::f64::consts::PI / 4.0 * d * d * (1.0 + 1.4 * 1.4) / 2.0;
    let side = (n as f64 * area / 0.5).sqrt();
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "local_damping": 0.3},
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.3, "friction": 0.3},
                      "wall": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.3, "friction": 0.0}},
        "particles": [{"material": "m", "count": n, "size": {"kind": "bidisperse", "diameter": d, "ratio": 1.4}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [side, side], "wall_material": "wall",
                      "walls": {"x_max": {"kind": "stress", "stress": stress, "max_speed": 0.05},
                                "y_max": {"kind": "stress", "stress": stress, "max_speed": 0.05}}},
        "stop": {"steps": 1},
        "seed": 8
    }));
    let mut sim = common::dem(&s);
    let mut sample = sim.sample().expect("sample");
    let mut rest_checks = 0;
    let positions = |sim: &sable_engine::methods::dem::Dem| sim.walls().iter().map(|w| w.position).collect::<Vec<f64>>();
    let mut before = positions(&sim);
    while rest_checks < 3 {
        for _ in 0..1000 {
            sim.step().expect("stable");
        }
        sample = sim.sample().expect("sample");
        // At rest: three checks in a row (3,000 steps) with almost no translational kinetic
        // energy and walls that moved by less than 1e-3 of the typical overlap (1e-3 d) in 1,000
        // steps. Spins do not count: a rattler spinning against a frictionless wall keeps its
        // spin for ever (nothing exerts a torque on it) while the packing is at rest, which is
        // why the engine's own equilibrium test leaves them out too (`Dem::balance`); whether
        // one is left spinning depends on the last bits of the trajectory.
        let after = positions(&sim);
        let still = before.iter().zip(&after).all(|(a, b)| (a - b).abs() < 1e-3 * 1e-3 * d);
        before = after;
        let p = sim.particles();
        let translational: f64 = (0..p.len()).map(|i| 0.5 * p.mass[i] * p.vel[i].norm_squared()).sum();
        rest_checks = if still && translational < 1e-4 * sample.elastic_energy { rest_checks + 1 } else { 0 };
        assert!(sim.steps_done() < 600_000, "no equilibrium: translational KE {translational:e}, elastic {:e}", sample.elastic_energy);
    }
    assert!(sample.phi > 0.75, "the packing must be jammed, phi = {}", sample.phi);
    for w in &sample.walls {
        let error = (w.normal_stress - stress).abs() / stress;
        assert!(error < 0.01, "wall {} carries {} Pa against {stress} Pa ({:.3}%)", w.name, w.normal_stress, 100.0 * error);
    }
    assert_eq!(sample.walls.len(), 4);
}

/// The stability guard watches wall contacts too: one grain (no pair at all) squeezed between a
/// fixed floor and a lid driven down at an imposed speed overlaps them more and more, and the
/// run must stop with a typed overlap error once the overlap passes `max_overlap` (0.1 of the
/// radius here), not run on. The lid starts 0.1 mm above the 1 mm grain resting on the floor and
/// closes at 2 mm/s: it touches after 50 ms, and the grain, pressed evenly from both sides,
/// overlaps each wall by half the closure, 10% of its radius (0.05 mm) after 50 ms more. The
/// guard runs every 20 steps (20 x 6.4e-5 s ~ 1.3 ms) and the grain, centred between two damped
/// springs, follows the closing walls with a lag of the order of a collision time (a few ms at
/// most), so it must stop between 0.1 and 0.105 s with an overlap just past 0.1 (measured:
/// 0.1004 s, 0.1009).
#[test]
fn the_guard_stops_a_grain_crushed_by_a_wall_with_an_overlap_error() {
    let d = 1e-3;
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1, "max_overlap": 0.1},
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e3}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "m", "placement": {"kind": "list", "positions": [[0.002, 0.0005]], "diameters": [d]}}],
        "container": {"min": [0, 0], "max": [0.004, 0.0011], "wall_material": "m",
                      "walls": {"y_max": {"kind": "velocity", "velocity": [0.0, -2e-3]}}},
        "stop": {"steps": 1},
        "seed": 1
    }));
    let mut sim = common::dem(&s);
    let dt = sim.time_step();
    let error = loop {
        match sim.step() {
            Ok(()) => assert!(sim.time() < 0.2, "the guard never fired; the lid is at {:?}", sim.walls().last().map(|w| w.position)),
            Err(e) => break e,
        }
    };
    match &error {
        sable_engine::EngineError::Unstable {
            cause: sable_engine::error::InstabilityCause::Overlap { fraction, limit },
            time,
            suggestion,
            ..
        } => {
            assert_eq!(*limit, 0.1);
            // The step is already the default t_c/50: the advice is about the contacts, and never
            // asks for the step in use.
            assert!(suggestion.contains("too soft") && !suggestion.contains("use dt"), "{suggestion}");
            assert!(*fraction > 0.1 && *fraction < 0.11, "stopped at an overlap of {fraction} of the radius");
            assert!(*time > 0.1 && *time < 0.105, "stopped at t = {time} s");
            println!("stopped at t = {time:.4} s (dt {dt:.2e} s) with an overlap of {fraction:.4} of the radius");
        }
        other => panic!("expected an overlap error, got {other}"),
    }
}
