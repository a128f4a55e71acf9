//! Contact dynamics (Moreau-Jean, docs/physics.md §3) against statics and kinematics with known
//! answers (docs/references.md check 23): resting grains and columns, blocks and round grains on an
//! incline, the three-disk pile, the bouncing ball.
//!
//! Tolerances: rigid contacts and an implicit scheme make the static answers exact up to the
//! solver's tolerance (1e-10 here: forces within 1e-6 relative need the impulses converged
//! well below it); kinematic answers carry the error of the time discretisation, stated per
//! test.

use crate::common;

use sable_engine::methods::cd::Cd;
use sable_engine::observe::contacts::rattlers;
use sable_engine::run::Simulation;
use serde_json::json;

const G: f64 = 9.81;
const D: f64 = 0.002;
const R: f64 = D / 2.0;
const RHO: f64 = 2500.0;

fn material(e: f64, mu: f64) -> serde_json::Value {
    json!({"density": RHO, "contact": {"law": "linear", "k_n": 1e5}, "restitution": e, "friction": mu})
}

fn mass(dim: usize) -> f64 {
    if dim == 2 {
        RHO * std::f64::consts::PI * R * R
    } else {
        RHO * 4.0 / 3.0 * std::f64::consts::PI * R * R * R
    }
}

/// [`common::cd_box`] for grains of diameter `D`.
fn scene(
    dim: usize,
    positions: serde_json::Value,
    gravity: serde_json::Value,
    grain: serde_json::Value,
    wall: serde_json::Value,
    dt: f64,
) -> Cd {
    common::cd_box(dim, positions, D, gravity, grain, wall, dt)
}

fn point(dim: usize, x: f64, y: f64) -> serde_json::Value {
    if dim == 2 {
        json!([x, y])
    } else {
        json!([x, y, 0.01])
    }
}

fn down(dim: usize) -> serde_json::Value {
    if dim == 2 {
        json!([0.0, -G])
    } else {
        json!([0.0, -G, 0.0])
    }
}

/// Force the particles exert on the floor, N (positive pressing down).
fn floor_load(sim: &Cd) -> f64 {
    sim.walls().iter().find(|w| w.face.name() == "y_min").map_or(f64::NAN, |w| -w.force.y)
}

#[test]
fn a_grain_and_a_column_rest_and_load_the_floor_with_their_weight() {
    for dim in [2, 3] {
        for n in [1usize, 5] {
            let positions: Vec<_> = (0..n).map(|k| point(dim, 0.01, R + k as f64 * D)).collect();
            let mut sim = scene(dim, json!(positions), down(dim), material(0.5, 0.3), material(0.5, 0.3), 1e-4);
            let start = sim.particles().pos.clone();
            for _ in 0..500 {
                sim.step().expect("stable");
            }
            let weight = n as f64 * mass(dim) * G;
            let load = floor_load(&sim);
            assert!(((load - weight) / weight).abs() < 1e-6, "dim {dim}, {n} grains: floor load {load:e} N, weight {weight:e} N");
            let drift = sim.particles().pos.iter().zip(&start).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
            assert!(drift < 1e-9 * R, "dim {dim}, {n} grains: drifted {drift:e} m");
            // Placed touching up to rounding (1e-19 m): contacts within ALERT count as closed,
            // so no grain ever falls into another.
            let (worst, _) = sim.interpenetration();
            assert!(worst < 1e-12, "dim {dim}, {n} grains: interpenetration {worst:e} of the radius");
            let report = sim.solver_report();
            assert!(report.converged && report.contacts == n);
        }
    }
}

/// Velocity along the slope and spin of a grain on an incline tilted by `theta` (gravity
/// rotated), after `t` seconds from rest; `spin` false holds the grain's rotation (a block).
fn incline(dim: usize, theta: f64, mu: f64, spin: bool, t: f64) -> (f64, f64) {
    let dt = 1e-4;
    let gravity = if dim == 2 { json!([G * theta.sin(), -G * theta.cos()]) } else { json!([G * theta.sin(), -G * theta.cos(), 0.0]) };
    let mut sim = scene(dim, json!([point(dim, 0.01, R)]), gravity, material(0.0, mu), material(0.0, mu), dt);
    if !spin {
        sim.particles_mut().inv_inertia[0] = 0.0;
    }
    let steps = (t / dt).round() as usize;
    for _ in 0..steps {
        sim.step().expect("stable");
    }
    let p = sim.particles();
    assert!(p.pos[0].y > R * (1.0 - 1e-9) && p.vel[0].y.abs() < 1e-12, "stays on the plane: {:?} {:?}", p.pos[0], p.vel[0]);
    (p.vel[0].x, p.omega[0].z)
}

#[test]
fn a_block_rests_on_an_incline_iff_tan_theta_is_at_most_mu_and_otherwise_slides_at_the_coulomb_rate() {
    let mu: f64 = 0.4;
    let t = 0.05;
    for dim in [2, 3] {
        // At rest just below the friction angle.
        let (v, _) = incline(dim, (0.99 * mu).atan(), mu, false, t);
        assert!(v.abs() < 1e-12, "dim {dim}: slid at {v:e} m/s below the friction angle");
        // Slides above it at a = g (sin θ - μ cos θ): the implicit step makes it exact for a
        // constant acceleration (velocity v = a t).
        for deg in [25.0f64, 40.0] {
            let theta = deg.to_radians();
            let (v, _) = incline(dim, theta, mu, false, t);
            let expected = G * (theta.sin() - mu * theta.cos()) * t;
            assert!(((v - expected) / expected).abs() < 1e-9, "dim {dim}, {deg}°: v {v} against {expected}");
        }
    }
}

#[test]
fn round_grains_roll_without_slip_at_the_rigid_body_rate_and_slip_past_the_friction_bound() {
    let t = 0.05;
    let theta = 30f64.to_radians();
    for (dim, factor, bound) in [(3, 5.0 / 7.0, 2.0 / 7.0), (2, 2.0 / 3.0, 1.0 / 3.0)] {
        // Rolling: mu above the no-slip bound, a = factor g sin θ and v = ω R.
        let mu = 1.2 * bound * theta.tan();
        let (v, w) = incline(dim, theta, mu, true, t);
        let expected = factor * G * theta.sin() * t;
        assert!(((v - expected) / expected).abs() < 1e-9, "dim {dim}: rolling at {v} against {expected}");
        assert!((v + w * R).abs() < 1e-9 * v, "dim {dim}: slips while rolling (v {v}, ω R {})", w * R);
        // Slipping: mu below the bound, a = g (sin θ - μ cos θ), and the spin lags.
        let mu = 0.8 * bound * theta.tan();
        let (v, w) = incline(dim, theta, mu, true, t);
        let expected = G * (theta.sin() - mu * theta.cos()) * t;
        assert!(((v - expected) / expected).abs() < 1e-9, "dim {dim}: slipping at {v} against {expected}");
        assert!(-w * R < 0.99 * v, "dim {dim}: should slip (v {v}, ω R {})", -w * R);
    }
}

/// Height the top disk of a three-disk pile falls in `t` seconds, with disk-disk friction
/// `mu` (floor friction well above its own bound).
fn pile_fall(mu: f64, t: f64) -> f64 {
    // Touching up to 1e-9 of the radius (exact contact would count as an overlap at placement).
    let gap = 1e-9 * R;
    let h = R + 3f64.sqrt() * (R + gap);
    let positions = json!([[0.01 - R - gap, R], [0.01 + R + gap, R], [0.01, h]]);
    let dt = 1e-4;
    // Walls' friction mixes with the disks' as a geometric mean: sqrt(mu · 1) >= 0.45 here, far
    // above the floor bound (2 - √3)/3 = 0.089.
    let mut sim = scene(2, positions, down(2), material(0.0, mu), material(0.0, 1.0), dt);
    for _ in 0..20 {
        sim.step().expect("stable");
    }
    let h = sim.particles().pos[2].y;
    for _ in 0..(t / dt).round() as usize {
        sim.step().expect("stable");
    }
    h - sim.particles().pos[2].y
}

#[test]
fn the_three_disk_pile_stands_iff_friction_reaches_two_minus_root_three() {
    let bound = 2.0 - 3f64.sqrt();
    let t = 0.1;
    let stands = pile_fall(1.05 * bound, t);
    assert!(stands.abs() < 1e-9 * R, "μ = 1.05 (2 - √3): the top disk fell {stands:e} m");
    let falls = pile_fall(0.95 * bound, t);
    assert!(falls > 0.05 * R, "μ = 0.95 (2 - √3): the top disk fell only {falls:e} m in {t} s");
}

#[test]
fn rebound_heights_of_a_bouncing_grain_scale_by_e_squared() {
    let e: f64 = 0.8;
    for dim in [2, 3] {
        let h0 = 0.02;
        let dt = 2e-5;
        let mut sim = scene(dim, json!([point(dim, 0.01, R + h0)]), down(dim), material(e, 0.0), material(e, 0.0), dt);
        // Apex heights: the grain's height where its vertical velocity turns from up to down.
        let mut apexes = Vec::new();
        let mut last_v = 0.0;
        while apexes.len() < 3 && sim.time() < 1.0 {
            sim.step().expect("stable");
            let p = sim.particles();
            let v = p.vel[0].y;
            if last_v > 0.0 && v <= 0.0 {
                apexes.push(p.pos[0].y - R);
            }
            last_v = v;
        }
        assert_eq!(apexes.len(), 3, "dim {dim}: apexes {apexes:?}");
        // The impact is resolved within one step: the speed at the start of that step differs
        // from the true impact speed by at most g dt (1e-3 relative here), the height by twice
        // that; 1% covers it with margin, and a wrong law (e instead of e², or no restitution)
        // misses by 20% or more.
        let mut previous = h0;
        for h in &apexes {
            let ratio = h / previous;
            assert!((ratio / (e * e) - 1.0).abs() < 0.01, "dim {dim}: apexes {apexes:?}, ratio {ratio} against e² = {}", e * e);
            previous = *h;
        }
    }
}

/// A 2D scene with explicit walls, for the stress-controlled wall tests.
fn walled(positions: serde_json::Value, container: serde_json::Value, gravity: serde_json::Value, tolerance: f64) -> Cd {
    let count = positions.as_array().map_or(0, Vec::len);
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": tolerance, "violation_tolerance": 1e-12, "max_iterations": 1000000},
        "materials": {"grain": material(0.0, 0.3), "wall": material(0.0, 0.3)},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": positions, "diameters": vec![D; count]}}],
        "container": container,
        "gravity": gravity,
        "stop": {"steps": 1}
    }));
    common::cd(&s)
}

#[test]
fn a_stress_controlled_lid_comes_to_rest_on_a_column_carrying_its_target() {
    // Three disks stacked on the floor; the lid starts 10 mm above them and is pushed down by
    // 50 Pa over the box width 0.02 m (1 N/m), at most 0.05 m/s.
    let positions = json!([[0.01, R], [0.01, R + D], [0.01, R + 2.0 * D]]);
    let container = json!({
        "min": [0, 0], "max": [0.02, 0.016], "periodic": ["x"], "wall_material": "wall",
        "walls": {"y_max": {"kind": "stress", "stress": 50.0, "max_speed": 0.05}}
    });
    let mut sim = walled(positions, container, down(2), 1e-10);
    for _ in 0..5000 {
        sim.step().expect("stable");
    }
    let lid = sim.walls().iter().find(|w| w.face.name() == "y_max").expect("lid");
    let weight = 3.0 * mass(2) * G;
    let push = 50.0 * 0.02;

    // At rest the lid sits on the top disk — within one step's travel, at max_speed plus the
    // push of its target over the step (Moreau-Jean stops velocities, not gaps) — and the
    // contacts carry exactly its target.
    let travel = 1e-4 * (0.05 + 1e-4 * push / sim.wall_mass());
    assert!((lid.position - 3.0 * D).abs() <= travel, "lid at {} m, column top at {} m", lid.position, 3.0 * D);
    assert!((lid.force.y - push).abs() < 1e-6 * push, "lid carries {} N/m against {push}", lid.force.y);
    let load = floor_load(&sim);
    assert!((load - weight - push).abs() < 1e-6 * (weight + push), "floor {load} N/m against {}", weight + push);
    assert!(sim.particles().vel.iter().all(|v| v.norm() < 1e-9), "the column is at rest");
}

#[test]
fn two_stress_controlled_walls_of_an_axis_squeeze_symmetrically_without_drifting() {
    // A row of three disks with gaps, off centre, between the x walls at 80 Pa each (y periodic,
    // no gravity). The walls share the box length as one degree of freedom: they close on the
    // row from both sides at opposite speeds, so the box centre never moves, and at rest each
    // carries its target.
    let positions = json!([[0.005, 0.01], [0.008, 0.01], [0.0115, 0.01]]);
    let container = json!({
        "min": [0, 0], "max": [0.02, 0.02], "periodic": ["y"], "wall_material": "wall",
        "walls": {"x_min": {"kind": "stress", "stress": 80.0, "max_speed": 0.05}, "x_max": {"kind": "stress", "stress": 80.0, "max_speed": 0.05}}
    });
    let mut sim = walled(positions, container, json!([0.0, 0.0]), 1e-10);
    for _ in 0..5000 {
        sim.step().expect("stable");
        let w = sim.walls();
        let centre = 0.5 * (w[0].position + w[1].position);
        assert!((centre - 0.01).abs() < 1e-12, "the box centre moved to {centre}");
    }
    let w = sim.walls();
    // Each wall lands within one step's travel of the row's end: at max_speed plus the push of
    // its target over the step (h σ A / M), which acts before the contacts stop it.
    let push = 80.0 * 0.02;
    let travel = 1e-4 * (0.05 + 1e-4 * push / sim.wall_mass());
    let gap = w[1].position - w[0].position;
    assert!((gap - 3.0 * D).abs() <= 2.0 * travel, "walls {} apart against {} (travel {travel:e})", gap, 3.0 * D);
    for wall in w {
        assert!((wall.force.x.abs() - push).abs() < 1e-6 * push, "{} carries {} N/m against {push}", wall.face.name(), wall.force.x);
    }
}

/// Force-bearing contacts (all, particle-particle and wall) and particles of the backbone: the
/// particles left after removing the rattlers (fewer than `threshold` contacts, walls included,
/// recursively; [`rattlers`]), counting only contacts that carry more than `floor` N.
fn backbone(sim: &Cd, threshold: usize, floor: f64) -> (usize, usize) {
    let n = sim.particles().len();
    let contacts: Vec<_> = sim.contacts().into_iter().filter(|c| c.bears_load() && c.force.norm() > floor).collect();
    let rattler = rattlers(n, threshold, &contacts);
    let kept = contacts.iter().filter(|c| !rattler[c.i as usize] && c.j.is_none_or(|j| !rattler[j as usize])).count();
    (kept, rattler.iter().filter(|r| !**r).count())
}

#[test]
fn a_frictionless_packing_compressed_by_stress_walls_is_isostatic() {
    // 120 frictionless disks (50:50, size ratio 1.4) compressed from a gas by the four walls at
    // 100 Pa, no gravity, no restitution. Rigid frictionless disks at rest are isostatic:
    // the force-bearing contacts of the backbone (walls included) number exactly the equations
    // of its equilibrium, D per disk plus one per axis for the two paired walls' shared degree
    // of freedom (Roux 2000; docs/physics.md §8).
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": 1e-6, "violation_tolerance": 1e-9, "max_iterations": 200000},
        "materials": {"grain": material(0.0, 0.0)},
        "particles": [{"material": "grain", "count": 120, "size": {"kind": "bidisperse", "diameter": 0.001, "ratio": 1.4},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.03, 0.03], "wall_material": "grain",
            "walls": {
                "x_min": {"kind": "stress", "stress": 100.0, "max_speed": 0.02}, "x_max": {"kind": "stress", "stress": 100.0, "max_speed": 0.02},
                "y_min": {"kind": "stress", "stress": 100.0, "max_speed": 0.02}, "y_max": {"kind": "stress", "stress": 100.0, "max_speed": 0.02}
            }},
        "gravity": [0.0, 0.0],
        "seed": 5,
        "stop": {"steps": 1}
    }));
    let mut sim = common::cd(&s);
    for _ in 0..8000 {
        sim.step().expect("stable");
    }
    let mean = {
        let c = sim.contacts();
        c.iter().map(|c| c.force.norm()).sum::<f64>() / c.len().max(1) as f64
    };
    let (contacts, particles) = backbone(&sim, 3, 1e-6 * mean);
    let equations = 2 * particles + 2;
    eprintln!("backbone {particles} disks, {contacts} contacts, {equations} equations, phi {}", sim.packing_fraction());
    assert!(particles > 100, "the backbone holds most disks: {particles}");
    assert_eq!(contacts, equations, "isostatic: {contacts} force-bearing contacts for {equations} equations");
}

#[test]
fn grains_faster_than_the_default_step_allows_get_shorter_steps() {
    // Two disks at rest in a closed box without gravity: the default step lets the 0.1 m/s
    // floor of the reference velocity cover 0.02 of a diameter (4e-4 s). Launched head-on at
    // 2 m/s each, a step that long would carry them 0.8 diameters into each other; the steps
    // shorten so that the pair closes by at most 0.02 diameters per step, the interpenetration
    // stays below that, and the impact restores e = 0.5 of the approach exactly (velocities
    // swap to ∓1 m/s within the solver's tolerance).
    let s = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "tolerance": 1e-10, "violation_tolerance": 1e-12, "max_iterations": 100000},
        "materials": {"grain": material(0.5, 0.0)},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": [[0.006, 0.01], [0.014, 0.01]], "diameters": [D, D]}}],
        "container": {"min": [0, 0], "max": [0.02, 0.02], "wall_material": "grain"},
        "gravity": [0.0, 0.0],
        "stop": {"steps": 1}
    }));
    let mut sim = common::cd(&s);
    let dt = sim.time_step();
    assert!((dt - 0.02 * D / 0.1).abs() < 1e-12 * dt, "default step {dt}");
    sim.particles_mut().vel[0].x = 2.0;
    sim.particles_mut().vel[1].x = -2.0;
    let mut worst: f64 = 0.0;
    // They meet after 1.5 ms and reach the walls after 10 ms: 300 steps end in between.
    for _ in 0..300 {
        let (t, fastest) = (sim.time(), sim.particles().vel.iter().map(|v| v.norm()).fold(0.0, f64::max));
        sim.step().expect("stable");
        let h = sim.time() - t;
        let expected = dt.min(0.02 * D / (2.0 * fastest));
        assert!((h - expected).abs() < 1e-9 * expected, "step {h} s, expected {expected} s");
        worst = worst.max(sim.interpenetration().0);
    }
    let v = &sim.particles().vel;
    assert!((v[0].x + 1.0).abs() < 1e-6 && (v[1].x - 1.0).abs() < 1e-6, "after the impact {} and {} m/s", v[0].x, v[1].x);
    assert!(worst <= 0.04, "interpenetration {worst} of the radius");
    assert!(sim.time() < 300.0 * dt / 10.0, "the steps were shortened: {} s", sim.time());
}

/// A triangular stack of `cols` x `rows` touching disks on the floor of a box periodic along x,
/// frictionless, with the velocities of a gas (up to 0.05 m/s each way), contact dynamics with
/// the sweep `sweep` on `threads` threads.
fn agitated_stack(cols: usize, rows: usize, sweep: &str, threads: usize) -> Cd {
    let s = D * (1.0 + 1e-9);
    let mut positions = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            let x = (c as f64 + 0.5 * (r % 2) as f64 + 0.25) * s;
            positions.push(json!([x, R * (1.0 + 1e-9) + r as f64 * s * 3f64.sqrt() / 2.0]));
        }
    }
    let count = positions.len();
    let scene = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "cd", "time_step": 1e-4, "tolerance": 1e-9, "violation_tolerance": 1e-12, "max_iterations": 1000000,
                   "sweep": sweep, "threads": threads},
        "materials": {"grain": material(0.0, 0.0)},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": positions, "diameters": vec![D; count]}}],
        "container": {"min": [0, 0], "max": [cols as f64 * s, rows as f64 * s + 0.01], "periodic": ["x"], "wall_material": "grain"},
        "gravity": [0.0, -G],
        "stop": {"steps": 1}
    }));
    let mut sim = common::cd(&scene);
    let mut state = 12345u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.1
    };
    for v in sim.particles_mut().vel.iter_mut() {
        v.x = next();
        v.y = next();
    }
    sim
}

#[test]
fn the_coloured_parallel_sweep_converges_to_the_serial_answer_whatever_the_threads() {
    // 1,600 disks, 2,346 contacts in the step (the pairs that close within it): colours of
    // several hundred contacts, swept by two threads. Frictionless, the end-of-step velocities
    // are unique (the projection of the free velocities on the admissible ones in the kinetic
    // metric; the impulses of this hyperstatic stack are not), so two solves converged to a
    // relative change of 1e-9 agree to a small multiple of that relative to the speeds
    // (0.05 m/s): measured 7.6e-10 m/s, bound 1e-8. The floor carries the same load (measured:
    // equal to 1e-16).
    let (cols, rows) = (40, 40);
    let mut serial = agitated_stack(cols, rows, "serial", 1);
    let mut coloured = agitated_stack(cols, rows, "coloured", 2);
    serial.step().expect("stable");
    coloured.step().expect("stable");
    let contacts = coloured.solver_report().contacts;
    assert!(contacts > 2000, "{contacts} contacts");
    let gap = |a: &Cd, b: &Cd| a.particles().vel.iter().zip(&b.particles().vel).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max);
    let dv = gap(&serial, &coloured);
    assert!(dv < 1e-8, "velocities differ by up to {dv:e} m/s");
    let (fs, fc) = (floor_load(&serial), floor_load(&coloured));
    assert!(((fs - fc) / fs).abs() < 1e-6, "floor loads {fs} and {fc} N");
    // The coloured answer does not depend on the number of threads, bit for bit. (Later steps
    // of this stack, whose impulses are not unique, take many more sweeps to meet 1e-9.)
    let mut one = agitated_stack(cols, rows, "coloured", 1);
    one.step().expect("stable");
    assert_eq!(one.particles().vel, coloured.particles().vel);
    assert_eq!(one.solver_report(), coloured.solver_report());
}

/// Three disks on a line without gravity, fixed step 1 ms: C strikes B at 1 m/s (both
/// perfectly plastic), and B sits 0.5% of the radius from A, at rest. Their start velocities do
/// not close the gap A-B within the step, so Moreau's anticipation alone leaves that pair out,
/// and B, driven at 0.5 m/s within the step, would end a quarter of the radius deep in A. As a
/// near pair it is a contact of the step (`method::cd`, `Detect`): nothing within the step may
/// drive it deeper than the slop (1% of the radius): it may approach at (0.5% + 1%) R /
/// (theta h) = 0.03 m/s. So C and B end at the common
/// velocity u and A at u - 0.03 m/s, with the momentum kept (3u - 0.03 = 1 m/s × one mass), and
/// A-B ends the step exactly the slop deep. The solve is converged to 1e-10: 1e-9 covers it.
#[test]
fn a_grain_struck_within_the_step_pushes_the_neighbour_its_start_velocity_did_not_reach() {
    for dim in [2, 3] {
        let (y, gap) = (0.025, 0.005 * R);
        let xs = [0.005, 0.005 + D, 0.005 + 2.0 * D + gap];
        let positions = json!(xs.iter().map(|&x| point(dim, x, y)).collect::<Vec<_>>());
        let zero = if dim == 2 { json!([0.0, 0.0]) } else { json!([0.0, 0.0, 0.0]) };
        let h = 1e-3;
        let mut sim = scene(dim, positions, zero, material(0.0, 0.0), material(0.0, 0.0), h);
        sim.particles_mut().vel[0].x = 1.0;
        sim.step().expect("stable");
        let p = sim.particles();
        let u = (1.0 + 0.03) / 3.0;
        let v: Vec<f64> = p.vel.iter().map(|v| v.x).collect();
        assert!((v[0] - u).abs() < 1e-9 && (v[1] - u).abs() < 1e-9 && (v[2] - (u - 0.03)).abs() < 1e-9, "dim {dim}: velocities {v:?}");
        assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-9, "dim {dim}: momentum {v:?}");
        let end_gap = p.pos[2].x - p.pos[1].x - D;
        assert!((end_gap + 0.01 * R).abs() < 1e-9 * R, "dim {dim}: gap A-B at the end of the step {end_gap:e} m");
    }
}

/// `scenes/biaxial_2d.json` with `"method": "cd"`: 400 disks on a loose lattice, the platen
/// driven down at 3.5 mm/s, the lateral wall held at 500 Pa with `max_speed` 0.01 m/s. Rigid
/// grains jam, then flow under the platen. The lateral wall is a body of the contact problem
/// whose speed is bounded within it (`nscd::Mobility`): it never ends a step faster than
/// 0.01 m/s, and in the steps where it moves below that bound it carries its target — the mean
/// of its stress over those steps, from t = 0.3 s (loaded) to 0.6 s, is within 2% of 500 Pa
/// (measured 497.5 Pa over 353 steps; one step scatters by 11.9 Pa, so 2%, 10 Pa, would be
/// sixteen standard errors of the mean if the steps were independent — they are not, the
/// packing evolves slowly — and less than one step's scatter). In the
/// other steps (326: the dilating packing pushes it out faster than it may go) the bound's
/// reaction holds it back, and it carries more (over a whole run, 1,074 Pa on average at the
/// bound, 784 Pa over all steps), so that without the split this would not hold.
#[test]
fn a_driven_biaxial_compression_holds_its_lateral_wall_at_its_target_below_its_speed_bound() {
    let mut scene: serde_json::Value = serde_json::from_str(include_str!("../../scenes/biaxial_2d.json")).expect("scene JSON");
    scene["method"] = json!({"kind": "cd", "threads": 1});
    let scene = common::scene(scene);
    let mut sim = common::cd(&scene);
    // The plain scene's one stage, as the runner begins it (an imposed motion: the loading bound).
    let stages = sable_engine::run::Runner::for_scene(&scene).stages;
    assert_eq!(stages.len(), 1);
    sim.begin_stage(&stages[0]).expect("stage");
    let max_speed = 0.01;
    let (mut free, mut bound) = (Vec::new(), 0);
    while sim.time() < 0.6 {
        sim.step().expect("stable");
        let speed = sim.walls().iter().find(|w| w.face.name() == "x_max").expect("lateral wall").velocity.x.abs();
        // The wall's stress as the samples measure it (its contacts' force over its area).
        let sample = sim.sample().expect("sample");
        let stress = sample.walls.iter().find(|w| w.name == "x_max").expect("lateral wall").normal_stress;
        assert!(speed <= max_speed * (1.0 + 1e-12), "lateral wall at {speed} m/s at t = {} s", sim.time());
        if sim.time() > 0.3 {
            if speed < max_speed * (1.0 - 1e-9) {
                free.push(stress);
            } else {
                bound += 1;
            }
        }
    }
    assert!(free.len() >= 100 && bound > 0, "{} steps below the bound, {bound} at it", free.len());
    let mean = free.iter().sum::<f64>() / free.len() as f64;
    let sd = (free.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / free.len() as f64).sqrt();
    eprintln!("{} steps below the bound, mean stress {mean} Pa (sd {sd}); {bound} at the bound", free.len());
    assert!((mean / 500.0 - 1.0).abs() < 0.02, "mean lateral stress below the bound {mean} Pa over {} steps", free.len());
}

/// The step covers the closing that body forces make within it: under the centripetal field
/// that gathers a granule, two grains at rest pulled head on close by `a h²` over a step, so
/// from rest the step is `sqrt(max_displacement d_min / a)` wherever that is shorter than the
/// scene's `dt`. (Without it, the 5,000 wet grains of `scenes/granule_full_3d.json` stepped at
/// 4.4e-4 s, a step's field impulse was too large against the violation bound, and Gauss-Seidel
/// stalled on the gathered ball.) Exact to rounding: the grains start at rest.
#[test]
fn the_step_shortens_under_the_granules_centripetal_field() {
    let s = common::scene(common::granule_scene(json!({"kind": "cd", "threads": 1}), 0.0728));
    let mut sim = common::cd(&s);
    let forming = &s.stages[0];
    let a = forming.controls.centripetal.expect("the forming stage pulls");
    sim.begin_stage(forming).expect("stage");
    let d_min = 2.0 * sim.particles().radius.iter().copied().fold(f64::INFINITY, f64::min);
    let max_displacement = sable_engine::methods::cd::CdParams::default().max_displacement;
    let expected = (max_displacement * d_min / a).sqrt();
    assert!(expected < 0.9 * sim.dt(), "the field must bind: {expected:.3e} s against dt {:.3e} s", sim.dt());
    let t0 = sim.time();
    sim.step().expect("step");
    let h = sim.time() - t0;
    println!("field {a:.1} m/s², dt {:.3e} s, step {h:.4e} s (expected {expected:.4e} s)", sim.dt());
    assert!((h - expected).abs() < 1e-9 * expected, "step {h:.6e} s against {expected:.6e} s");
}
