//! Contact dynamics in a deforming periodic cell (engine/src/methods/cd/cell.rs), against what
//! lattices of equal frictionless disks must do.
//!
//! The lattices keep every force along x or y exactly (rows and columns share their coordinates
//! to the last bit), so nothing buckles, and their answers are worked out by hand:
//! - compressed at an imposed strain rate, the columns on either side of the boundary meet across
//!   it first; a perfectly plastic impact (e = 0) between two equal grains closing at the cell's
//!   speed `V` leaves them moving inwards at `V/2` each, and they stay together since the image
//!   keeps coming at `V`;
//! - a row of grains around a cell whose length is held at a normal stress: the cell closes the
//!   gaps and stops when the row is a closed chain, each contact carrying `σ L_y`.
//!
//! Tolerances: the impact and the chain's balance are solved to the solver's tolerance (1e-10
//! relative), so velocities, forces and stresses hold to 1e-9..1e-6 relative; the closed chain's
//! length is that of its touching grains within the alert distance and the slop the restoration
//! allows (Φ within 1e-3 relative).

use crate::common;

use sable_engine::methods::cd::Cd;
use sable_engine::run::Simulation;
use sable_engine::scene::{Controls, Deformation};
use serde_json::json;
use std::f64::consts::PI;

const D: f64 = 1e-3;
const N: usize = 4;
const RHO: f64 = 2500.0;

/// N × N disks of diameter D on a square lattice of spacing `spacing` in a periodic cell of side
/// N × spacing deformed as `deformation`, frictionless, perfectly plastic, no gravity, at 1e-4 s,
/// solved to the relative change `tolerance` and the violation `tolerance / 100`.
fn lattice(spacing: f64, deformation: serde_json::Value, tolerance: f64) -> Cd {
    let positions: Vec<serde_json::Value> =
        (0..N * N).map(|k| json!([(0.5 + (k % N) as f64) * spacing, (0.5 + (k / N) as f64) * spacing])).collect();
    let side = N as f64 * spacing;
    common::cd(&common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": tolerance, "violation_tolerance": tolerance * 1e-2, "max_iterations": 100000},
        "materials": {"grain": {"density": RHO, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.0, "friction": 0.0}},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": positions, "diameters": vec![D; N * N]}}],
        "container": {"min": [0, 0], "max": [side, side], "periodic": ["x", "y"], "deformation": deformation},
        "gravity": [0, 0],
        "stop": {"steps": 100000}
    })))
}

/// Compressed along x at 1/s, the cell shortens at the imposed rate; the grains do not move
/// until the columns on either side of the boundary meet across it, then those two columns move
/// inwards at half the cell's speed, and the others stay at rest.
#[test]
fn an_imposed_strain_rate_moves_the_images_and_the_boundary_columns_meet_halfway() {
    let spacing = 1.1 * D;
    let rate = -1.0;
    let mut sim = lattice(spacing, json!({"kind": "strain_rate", "rate": [rate, 0.0]}), 1e-10);
    let l0 = N as f64 * spacing;
    // The gap across the boundary (0.1 D) closes when L has lost 0.1 D.
    let meet = ((l0 - 0.1 * D) / l0).ln() / rate;
    let steps = (meet / 1e-4).ceil() as usize + 20;
    // When they meet, and the cell's closing speed over that step (its length at the step's
    // start times the rate).
    let mut met = None;
    for s in 0..steps {
        let before = sim.box_lengths().x;
        sim.step().expect("step");
        let p = sim.particles();
        if met.is_none() && p.vel.iter().any(|v| v.norm() > 0.0) {
            met = Some((s as f64 * 1e-4, -rate * before));
        }
    }
    let t = sim.time();
    let l = sim.box_lengths();
    // Lengths: exp(rate t), to rounding.
    assert!((l.x / (l0 * (rate * t).exp()) - 1.0).abs() < 1e-12, "L_x {} against {}", l.x, l0 * (rate * t).exp());
    assert!((l.y - l0).abs() < 1e-15, "L_y {}", l.y);
    let (met, v) = met.expect("the columns met");
    assert!((met - meet).abs() <= 2e-4, "met at {met} s, expected {meet} s");
    // The images then slow down with the cell (the speed is rate × L): the pair parts and keeps
    // the velocities of the impact.
    let p = sim.particles();
    // Columns by position (the grains are stored in cell order); the cell shrinks about its
    // centre.
    let lo = 0.5 * l0 - 0.5 * l.x;
    for (k, (x, vel)) in p.pos.iter().zip(&p.vel).enumerate() {
        let column = ((x.x - lo) / (l.x / N as f64)).floor() as usize;
        let expected = match column {
            0 => 0.5 * v,
            c if c == N - 1 => -0.5 * v,
            _ => 0.0,
        };
        assert!((vel.x - expected).abs() <= 1e-9 * v && vel.y.abs() <= 1e-12 * v, "grain {k} (column {column}): {vel} against {expected}");
    }
}

/// A row of N disks (spacing 1.1 D) around a cell periodic along x and y, 3 D high, whose
/// length along x is held at the normal stress `target` (the control of a sheared cell's
/// height): the cell closes the gaps at its largest strain rate at most, then holds. The row is a
/// single chain around the period, so its force is determined: `σ_xx L_y`; Φ = π/12.
#[test]
fn a_stress_controlled_cell_closes_a_row_and_holds_the_target() {
    let (target, max_rate, spacing) = (100.0, 1.0, 1.1 * D);
    let positions: Vec<serde_json::Value> = (0..N).map(|k| json!([(0.5 + k as f64) * spacing, 1.5 * D])).collect();
    let mut sim = common::cd(&common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": 1e-10, "violation_tolerance": 1e-12, "max_iterations": 100000},
        "materials": {"grain": {"density": RHO, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.0, "friction": 0.0}},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": positions, "diameters": vec![D; N]}}],
        "container": {"min": [0, 0], "max": [N as f64 * spacing, 3.0 * D], "periodic": ["x", "y"]},
        "gravity": [0, 0],
        "stop": {"steps": 100000}
    })));
    let servo = Deformation::NormalStress { axis: 0, target, max_strain_rate: max_rate, gain: 0.0 };
    sim.apply_controls(&Controls { deformation: Some(Some(servo)), ..Controls::default() }).expect("controls");
    // The cell cannot close faster than its largest strain rate: from 1.1 N D to within 1e-3 of
    // N D takes at least ln(1.1 / 1.001) / max_rate.
    let earliest = (1.1f64 / 1.001).ln() / max_rate;
    let mut closed_at = None;
    for s in 0..5_000 {
        sim.step().expect("step");
        if closed_at.is_none() && sim.box_lengths().x <= N as f64 * D * (1.0 + 1e-3) {
            closed_at = Some(s as f64 * 1e-4);
        }
    }
    let closed_at = closed_at.expect("the row closed");
    assert!(closed_at >= earliest * 0.999, "closed at {closed_at} s, before {earliest} s");
    let phi = sim.packing_fraction();
    assert!((phi - PI / 12.0).abs() < 1e-3 * PI / 12.0, "phi {phi} against {}", PI / 12.0);
    // A window at rest: no motion, the cell on target.
    sim.balance();
    for _ in 0..200 {
        sim.step().expect("step");
    }
    let b = sim.balance();
    assert!(b.stress_error < 1e-6, "stress error {}", b.stress_error);
    assert!(b.kinetic_ratio() < 1e-8, "kinetic ratio {}", b.kinetic_ratio());
    let s = sim.sample().expect("sample");
    assert!((s.stress.xx - target).abs() < 1e-6 * target && s.stress.yy.abs() < 1e-9 * target, "stress {:?}", s.stress);
    // Each contact of the chain carries σ_xx L_y along x.
    let contacts = sim.contacts();
    assert_eq!(contacts.len(), N, "a closed ring of N contacts");
    for c in &contacts {
        assert!((c.force.x.abs() / (target * 3.0 * D) - 1.0).abs() < 1e-6 && c.force.y.abs() < 1e-12, "contact force {}", c.force);
    }
}
