//! The energy the contacts store, and the stability guard's budget built on it: a sliding
//! contact stores what its Coulomb-limited spring holds, `F_t² / (2 k_t)`, not the tangential
//! dashpot's share, and a valid run whose mechanical energy falls is never stopped.

use crate::common;

use sable_engine::run::Simulation;
use serde_json::json;

const G: f64 = 9.81;

/// Potential energy of gravity plus kinetic energy (with spins), J (J/m in 2D).
fn kinetic_and_potential(sim: &sable_engine::methods::dem::Dem, dim: usize) -> f64 {
    let p = sim.particles();
    (0..p.len()).map(|i| p.kinetic_energy_at(i, &p.vel[i]) + p.mass[i] * G * p.pos[i][dim - 1]).sum()
}

#[test]
fn three_disks_collapse_under_friction_with_default_damping() {
    // Two disks touching on the floor, one on top (d = 1 cm, k_n = 1e7 N/m, e = 0.3, mu = 0.15
    // everywhere, the default tangential damping): the top disk must push the other two apart
    // and come down to the floor (the pile stands only above mu = 0.268, docs/references.md check 23).
    // Before the spring of a sliding contact was limited to the Coulomb force, the guard counted
    // the tangential dashpot's share as stored energy and stopped this run at t = 0.086 s with
    // "mechanical energy grew by 2.9e-3 J".
    let (d, r) = (0.01, 0.005);
    let gap = 1e-9 * r;
    let top = r + 3f64.sqrt() * (r + gap) * 1.000001;
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem"},
        "materials": {"m": common::linear_material(1e7, 0.3, 0.15)},
        "particles": [{"material": "m", "placement": {"kind": "list",
            "positions": [[5.0 * d - r - gap, r], [5.0 * d + r + gap, r], [5.0 * d, top]], "diameters": [d, d, d]}}],
        "container": {"min": [0, 0], "max": [10.0 * d, 10.0 * d], "wall_material": "m"},
        "gravity": [0, -G],
        "stop": {"time": 0.3}
    }));
    let mut sim = common::dem(&s);
    let m = sim.particles().mass[0];
    // The energy the fall releases: the top disk's drop from sqrt(3) r above the floor disks.
    let released = m * G * (top - r);
    let mut previous = kinetic_and_potential(&sim, 2) + sim.elastic_energy();
    while sim.time() < 0.3 {
        for _ in 0..100 {
            sim.step().expect("a collapsing pile is a valid run");
        }
        let elastic = sim.elastic_energy();
        let total = kinetic_and_potential(&sim, 2) + elastic;
        // Damping and sliding only take energy out. Velocity Verlet's own error over 100 steps is
        // far below 1e-3 of what the fall releases.
        assert!(total <= previous + 1e-3 * released, "t = {}: mechanical energy rose from {previous} to {total}", sim.time());
        previous = total;
    }
    let p = sim.particles();
    // Collapsed: all three rest on the floor (within the static overlap mg/k_n), apart.
    for i in 0..3 {
        assert!((p.pos[i].y - r).abs() < 1e-3 * r, "disk {i} at height {} (radius {r})", p.pos[i].y);
    }
    assert!((p.pos[2].x - p.pos[0].x).abs() >= 2.0 * r && (p.pos[2].x - p.pos[1].x).abs() >= 2.0 * r);
    // At the end the three roll on the floor without slipping: the springs hold only the
    // weights, 3 (m g)² / (2 k_n) (with the dashpot's share they had held 4.7e-3 J/m during the
    // collapse, a quarter of what the fall releases).
    let resting = 3.0 * (m * G).powi(2) / (2.0 * 1e7);
    let elastic = sim.elastic_energy();
    assert!((elastic - resting).abs() < 1e-3 * resting, "elastic energy {elastic} J/m against {resting} J/m");
}

/// A grain launched along the floor without spin slides (its friction spins it up until it rolls
/// after `2 v0 / (7 mu g)` for a sphere, `v0 / (3 mu g)` for a disk); half way, the elastic energy
/// is that of the normal spring, `(m g)² / (2 k_n)`, and of the Coulomb-limited tangential spring,
/// `(mu m g)² / (2 k_t)`. With the dashpot's share in the spring (LAMMPS's reset) the tangential
/// part would be `(gamma_t v_slip - mu m g)² / (2 k_t)`, thousands of times more here.
#[test]
fn a_sliding_grain_stores_the_coulomb_force_in_its_spring() {
    let (k_n, mu, v0, r) = (1e5, 0.1, 0.5, 0.005);
    for dim in [2, 3] {
        let (min, max, pos, vel, periodic) = if dim == 2 {
            (json!([0, 0]), json!([0.2, 0.05]), json!([[0.02, r]]), json!([[v0, 0]]), json!(["x"]))
        } else {
            (json!([0, 0, 0]), json!([0.2, 0.05, 0.05]), json!([[0.02, 0.02, r]]), json!([[v0, 0, 0]]), json!(["x", "y"]))
        };
        let s = common::scene(json!({
            "dimension": dim,
            "method": {"kind": "dem"},
            "materials": {"m": common::linear_material(k_n, 0.3, mu)},
            "particles": [{"material": "m", "placement": {"kind": "list", "positions": pos, "diameters": [2.0 * r], "velocities": vel}}],
            "container": {"min": min, "max": max, "periodic": periodic, "wall_material": "m"},
            "gravity": if dim == 2 { json!([0, -G]) } else { json!([0, 0, -G]) },
            "stop": {"steps": 1}
        }));
        let mut sim = common::dem(&s);
        let sliding = if dim == 2 { v0 / (3.0 * mu * G) } else { 2.0 * v0 / (7.0 * mu * G) };
        while sim.time() < 0.5 * sliding {
            sim.step().expect("stable");
        }
        let p = sim.particles();
        let (m, axis) = (p.mass[0], dim - 1);
        // Still sliding: the contact point moves.
        let slip = p.vel[0].x + p.omega[0][if dim == 2 { 2 } else { 1 }] * r * if dim == 2 { 1.0 } else { -1.0 };
        assert!(slip.abs() > 0.1 * v0, "{dim}D: slip velocity {slip}");
        let k_t = 2.0 / 7.0 * k_n;
        let expected = (m * G).powi(2) / (2.0 * k_n) + (mu * m * G).powi(2) / (2.0 * k_t);
        let elastic = sim.elastic_energy();
        // The landing's normal oscillation (period 2 pi sqrt(m/k_n) < 9 ms, damping ratio 0.50)
        // has died out long before half the slide (85 ms in 2D, 36 ms in 3D): both the guard's
        // and the sample's value of the springs must be the static ones.
        assert!((elastic - expected).abs() < 1e-3 * expected, "{dim}D: elastic energy {elastic} J against {expected} J");
        assert!(p.pos[0][axis] < r, "{dim}D: resting on the floor");
        let sample = sim.sample().expect("sample");
        assert!((sample.elastic_energy - expected).abs() < 1e-3 * expected, "{dim}D: sample {} J", sample.elastic_energy);
    }
}
