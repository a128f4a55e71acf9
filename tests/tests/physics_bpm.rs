//! The bonded particle method's soft grains (docs/physics.md §4; Nezamabadi 2020, §1.2.1 and
//! §2.1.3): aggregates of rigid primaries bound by the attraction `F_0 (1 + δ/a_0)^(−γ)`, run by
//! contact dynamics and by DEM.
//!
//! Tolerances: an aggregate at rest is static; what moves it is the contact solver's leftover
//! (relative change 1e-6 of impulses set by `F_0` ≈ 100 N/m, [`AGGREGATE_TOLERANCE`]),
//! measured at 4e-8 m of creep per 1e4 steps of 1e-7 s for 227 primaries — the test allows 1% of
//! the smallest primary's diameter (7e-7 m) over 2e4 steps; by DEM, over 1e5 steps.

use crate::common;

use sable_engine::methods::cd::AGGREGATE_TOLERANCE;
use sable_engine::observe::{GrainSample, PrimarySample};
use sable_engine::run::Simulation;
use serde_json::json;

/// Primaries of the sources: 0.07–0.13 mm, ρ = 2000 kg/m³, F_0 = 100 N/m, γ = 7.
fn primaries_material() -> serde_json::Value {
    json!({"density": 2000.0, "contact": {"law": "linear", "k_n": 1e6}, "restitution": 0.0, "friction": 0.0})
}

fn bonded(min_primaries: usize) -> serde_json::Value {
    json!({
        "kind": "bonded_primaries",
        "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4},
        "min_primaries": min_primaries,
        "attraction": {"force": 100.0}
    })
}

/// One grain of the sources' size (1.8 mm, over 200 primaries of [`bonded`]) in the middle of a
/// 4 mm box without gravity, run for `steps` by contact dynamics.
fn one_grain(steps: u64) -> sable_engine::methods::Plan {
    one_grain_by(json!("cd"), primaries_material(), steps)
}

/// [`one_grain`] by `method`, its primaries of `material`.
fn one_grain_by(method: serde_json::Value, material: serde_json::Value, steps: u64) -> sable_engine::methods::Plan {
    let container = json!({"min": [0.0, 0.0], "max": [4e-3, 4e-3], "wall_material": "primary"});
    lone_grain(2, method, material, (1.8e-3, json!([2e-3, 2e-3]), bonded(200)), container, steps)
}

/// A scene in `dimension` of one grain of primaries of `material` (`"primary"`): its diameter,
/// centre and model; in `container`, by `method`, for `steps`.
fn lone_grain(
    dimension: usize,
    method: serde_json::Value,
    material: serde_json::Value,
    (diameter, centre, model): (f64, serde_json::Value, serde_json::Value),
    container: serde_json::Value,
    steps: u64,
) -> sable_engine::methods::Plan {
    common::scene(json!({
        "dimension": dimension,
        "method": method,
        "materials": {"primary": material},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": diameter},
            "placement": {"kind": "list", "positions": [centre]},
            "model": model
        }],
        "container": container,
        "stop": {"steps": steps}
    }))
}

fn grains(s: &sable_engine::observe::Sample) -> GrainSample {
    match &s.grains {
        Some(g) => **g,
        None => panic!("a sample of aggregates without grain measures"),
    }
}

/// The primaries' measures of a sample of aggregates.
fn primaries_of(s: &sable_engine::observe::Sample) -> PrimarySample {
    match s.primaries {
        Some(a) => a,
        None => panic!("a sample of aggregates without the primaries' measures"),
    }
}

/// One aggregate of the sources' size alone ([`one_grain`]): once relaxed (at build), 2e4 steps
/// move no primary by more than 1% of the smallest primary's diameter, the grain keeps its area
/// within 0.1% and stays round (aspect ratio below 1.1), and its primaries keep touching (their
/// coordination at least 3). (1e5 steps, as the issue asks, moved none by more than 1.8e-8 m,
/// 3e-4 of the smallest primary; DEM's test below runs its 1e5 steps in a quarter of the time.)
#[test]
fn an_isolated_aggregate_stays_intact_and_round() {
    let scene = one_grain(20_000);
    let Some(params) = scene.params::<sable_engine::methods::cd::CdParams>() else { panic!("not cd") };
    assert_eq!(params.tolerance, AGGREGATE_TOLERANCE);
    let mut sim = common::cd(&scene);
    stays_intact_and_round(&mut sim, |s| s.particles(), 20_000);
}

/// Runs `steps` of `sim`, one aggregate of [`one_grain`] relaxed at build, and checks that no
/// primary (of `particles(sim)`) moves by more than 1% of the smallest primary's diameter, the
/// grain's area stays within 0.1%, its aspect ratio below 1.1 and its primaries' coordination
/// at least 3.
fn stays_intact_and_round<S: Simulation>(sim: &mut S, particles: fn(&S) -> &sable_engine::particles::Particles, steps: u64) {
    let n = sim.particle_count();
    assert!((200..260).contains(&n), "{n} primaries");
    stays_intact(sim, particles, steps, 3.0);
}

/// [`stays_intact_and_round`] for any count of primaries, their coordination at least `z_min`.
fn stays_intact<S: Simulation>(sim: &mut S, particles: fn(&S) -> &sable_engine::particles::Particles, steps: u64, z_min: f64) {
    let n = sim.particle_count();
    let start_positions = particles(sim).pos.clone();
    let d_min = 2.0 * particles(sim).radius.iter().copied().fold(f64::INFINITY, f64::min);
    let g0 = grains(&sim.sample().expect("sample"));
    assert_eq!(g0.count, 1);
    for _ in 0..steps {
        sim.step().expect("step");
    }
    let last = sim.sample().expect("sample");
    let g1 = grains(&last);
    let drift = particles(sim).pos.iter().zip(&start_positions).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    eprintln!(
        "by {}, {n} primaries: largest drift {drift:e} m over {steps} steps of {:e} s; area {:e} -> {:e} m²; aspect ratio {} -> {}; Z {}",
        sim.method(),
        sim.dt(),
        g0.mean_area,
        g1.mean_area,
        g0.max_aspect_ratio,
        g1.max_aspect_ratio,
        primaries_of(&last).z
    );
    assert!(drift < 0.01 * d_min, "a primary moved {drift:e} m ({:.2e} of d_min)", drift / d_min);
    assert!((g1.mean_area / g0.mean_area - 1.0).abs() < 1e-3, "area {:e} -> {:e} m²", g0.mean_area, g1.mean_area);
    assert!(g1.max_aspect_ratio < 1.1, "aspect ratio {}", g1.max_aspect_ratio);
    assert!(primaries_of(&last).z >= z_min, "primaries' coordination {}", primaries_of(&last).z);
}

/// Two aggregates in a box: the saved state keeps each primary's aggregate and the laws of
/// each aggregate, and a scene that starts from it runs the same aggregates.
#[test]
fn a_saved_state_keeps_the_aggregates() {
    let scene = common::scene(json!({
        "dimension": 2,
        "method": "cd",
        "materials": {"primary": primaries_material()},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": 1.0e-3},
            "placement": {"kind": "list", "positions": [[0.8e-3, 1e-3], [2.2e-3, 1e-3]]},
            "model": {
                "kind": "bonded_primaries",
                "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4},
                "min_primaries": 60,
                "attraction": {"force": 100.0, "exponent": 6.0, "cutoff": 1e-4},
                "friction": 0.1
            }
        }],
        "container": {"min": [0.0, 0.0], "max": [3e-3, 2e-3], "wall_material": "primary"},
        "stop": {"steps": 10}
    }));
    let sim = common::cd(&scene);
    let p = sim.particles();
    assert_eq!(p.aggregate_count(), 2);
    let state = sim.saved_state();
    assert_eq!(state.bondings.len(), 2);
    assert_eq!(
        (state.bondings[0].force, state.bondings[0].exponent, state.bondings[0].cutoff, state.bondings[0].friction),
        (100.0, 6.0, 1e-4, 0.1)
    );
    let text = serde_json::to_string(&state).expect("state to JSON");
    let again = common::scene(json!({
        "dimension": 2,
        "method": "cd",
        "materials": {"primary": primaries_material()},
        "start_from": {"state": serde_json::from_str::<serde_json::Value>(&text).expect("JSON")},
        "container": {"wall_material": "primary"},
        "stop": {"steps": 10}
    }));
    let sim2 = common::cd(&again);
    let q = sim2.particles();
    assert_eq!(q.bondings, p.bondings);
    // Both runs sort their particles by cell: compare the aggregates' sizes.
    let sizes = |a: &[u32]| (0..2).map(|k| a.iter().filter(|&&x| x == k).count()).collect::<Vec<_>>();
    assert_eq!(sizes(&q.aggregate), sizes(&p.aggregate));
    assert!(q.aggregate.iter().all(|&a| a < 2));
}

/// The check at generation behind the scene's estimate: a set whose grains hold fewer
/// primaries than it asks for is an error that names the set's field, not a smaller aggregate.
#[test]
fn an_aggregate_that_does_not_fit_is_an_error_naming_the_set() {
    let mut scene = one_grain(10);
    if let Some(a) = scene.sets[0].aggregate.as_mut() {
        a.min_primaries = 400;
    }
    let Some(params) = scene.params::<sable_engine::methods::cd::CdParams>() else { panic!("not cd") };
    match sable_engine::methods::cd::Cd::new(&scene, params) {
        Err(sable_engine::EngineError::Build { field, reason }) => {
            assert_eq!(field, "particles[0].model.primaries");
            assert!(reason.contains("fewer than min_primaries (400)"), "{reason}");
        }
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("an aggregate of fewer primaries than asked was built"),
    }
}

/// The shipped examples parse, with their four grains of about 220 primaries run by contact
/// dynamics at the aggregates' tolerance and by DEM, and the 3D example's eight.
#[test]
fn the_example_scene_is_valid() {
    let scene = match sable_engine::methods::plan_scene(include_str!("../../scenes/bpm_compaction_2d.json")) {
        Ok(s) => s,
        Err(v) => panic!("scenes/bpm_compaction_2d.json: {v:?}"),
    };
    assert!(scene.sets[0].aggregate.is_some());
    assert_eq!(scene.particle_count(), 880);
    assert!(scene.params::<sable_engine::methods::cd::CdParams>().is_some_and(|p| p.tolerance == AGGREGATE_TOLERANCE));
    let dem = match sable_engine::methods::plan_scene(include_str!("../../scenes/bpm_compaction_dem_2d.json")) {
        Ok(s) => s,
        Err(v) => panic!("scenes/bpm_compaction_dem_2d.json: {v:?}"),
    };
    assert_eq!(dem.particle_count(), 880);
    assert_eq!(dem.method.name(), "dem");
    // In 3D: eight grains of 0.9 mm, about 0.39 × D³/⟨d³⟩ = 260 primaries each.
    let dem_3d = match sable_engine::methods::plan_scene(include_str!("../../scenes/bpm_compaction_dem_3d.json")) {
        Ok(s) => s,
        Err(v) => panic!("scenes/bpm_compaction_dem_3d.json: {v:?}"),
    };
    assert_eq!((dem_3d.dim, dem_3d.particle_count()), (3, 2080));
    assert_eq!(dem_3d.method.name(), "dem");
}

/// The primaries' material for DEM: contacts stiff enough to hold `F_0` at 0.7% of the smallest
/// primary's diameter (k_n = 2e8 N/m against the rule's 1.4e8), slightly inelastic.
fn dem_primaries_material() -> serde_json::Value {
    json!({"density": 2000.0, "contact": {"law": "linear", "k_n": 2e8}, "restitution": 0.2, "friction": 0.0})
}

/// Two primaries of one aggregate released apart, by DEM: they fall together under the
/// attraction alone, and at every step before they touch the kinetic energy they gained is
/// the bond energy they lost, `½ m* v² = U(δ_0) − U(δ)` with
/// `U(δ) = −F_0 a_0/(γ − 1) (1 + δ/a_0)^(1−γ)` (the law's integral written out here, not
/// taken from the engine). Velocity Verlet at the default step (t_c/50 of the contact) errs
/// by O(dt²) on this smooth force: the test allows 0.1% of the energy gained by touching.
/// The stability guard's account holds the bond energy too.
#[test]
fn two_primaries_fall_together_with_the_bond_energy_in_dem() {
    let (r1, r2, f0, gamma, cutoff) = (5e-5, 6e-5, 100.0, 7.0, 1.3e-4);
    let a0 = r1 + r2;
    let delta0 = 0.6 * a0;
    let state = json!({
        "format": "sable-state", "version": 1, "dimension": 2,
        "min": [0.0, 0.0], "max": [1e-3, 1e-3],
        "materials": ["primary"],
        "particles": {
            "material": [0, 0], "radius": [r1, r2],
            "position": [[4e-4, 5e-4], [4e-4 + a0 + delta0, 5e-4]],
            "velocity": [[0.0, 0.0], [0.0, 0.0]], "angular_velocity": [[0.0], [0.0]],
            "aggregate": [0, 0]
        },
        "bondings": [{"force": f0, "exponent": gamma, "cutoff": cutoff, "friction": 0.0}]
    });
    let scene = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"primary": dem_primaries_material()},
        "start_from": {"state": state},
        "container": {"wall_material": "primary"},
        "stop": {"steps": 100000}
    }));
    let mut sim = common::dem(&scene);
    // The relaxation at build has brought them into contact: set them apart again.
    {
        let p = sim.particles_mut();
        let (a, b) = if p.radius[0] < p.radius[1] { (0, 1) } else { (1, 0) };
        p.pos[a] = sable_engine::math::Vec3::new(4e-4, 5e-4, 0.0);
        p.pos[b] = sable_engine::math::Vec3::new(4e-4 + a0 + delta0, 5e-4, 0.0);
        for v in p.vel.iter_mut().chain(p.omega.iter_mut()) {
            *v = sable_engine::math::Vec3::zeros();
        }
    }
    sim.reset_forces();
    let u = |d: f64| -f0 * a0 / (gamma - 1.0) * (1.0 + d / a0).powf(1.0 - gamma);
    let gained_at_touch = u(delta0) - u(0.0);
    let (m1, m2) = (sim.particles().mass[0], sim.particles().mass[1]);
    let m_eff = m1 * m2 / (m1 + m2);
    let (mut worst, mut steps, mut closest) = (0.0f64, 0, delta0);
    loop {
        sim.step().expect("step");
        steps += 1;
        let p = sim.particles();
        let gap = (p.pos[1] - p.pos[0]).norm() - a0;
        if gap <= 0.0 {
            break;
        }
        let v = (p.vel[1] - p.vel[0]).norm();
        let error = (0.5 * m_eff * v * v - (u(delta0) - u(gap))).abs() / gained_at_touch;
        worst = worst.max(error);
        closest = gap;
        assert!(steps < 100_000, "no contact after {steps} steps");
    }
    eprintln!(
        "{steps} steps of {:e} s to touch; last gap {closest:e} m; worst energy error {worst:.2e} of the {gained_at_touch:e} J/m gained",
        sim.dt()
    );
    assert!(steps > 50, "the fall took only {steps} steps: the test resolves nothing");
    assert!(worst < 1e-3, "kinetic energy off the bond energy lost by {worst:.2e} of the energy gained");
    // The guard's account: the bond energy is counted, so the fall itself is not a growth.
    let s = sim.sample().expect("a sample: the energy account holds");
    assert!(s.kinetic_energy > 0.5 * gained_at_touch, "kinetic energy {:e}", s.kinetic_energy);
}

/// [`an_isolated_aggregate_stays_intact_and_round`] by DEM: once relaxed (at build), 1e5 steps
/// (at the default t_c/50, about 1.3e-8 s) move no primary by more than 1% of the smallest
/// primary's diameter, keep the grain's area within 0.1% and its aspect ratio below 1.1, and
/// the primaries keep touching. A DEM aggregate at rest vibrates at round-off only once the
/// relaxation's damping has removed its kinetic energy.
#[test]
fn an_isolated_aggregate_stays_intact_and_round_in_dem() {
    let mut sim = common::dem(&one_grain_by(json!({"kind": "dem", "threads": 1}), dem_primaries_material(), 100_000));
    stays_intact_and_round(&mut sim, |s| s.particles(), 100_000);
}

/// One aggregate of 1 mm in 3D (about 390 primaries of the sources' sizes grown in its ball,
/// `F_0` = 0.01 N, so that `p_I = F_0/⟨a_0⟩²` = 1 MPa), in the middle of a 2 mm box, by
/// `method` with primaries of `material`, run for `steps`.
fn one_grain_3d(method: serde_json::Value, material: serde_json::Value, steps: u64) -> sable_engine::methods::Plan {
    let model = json!({
        "kind": "bonded_primaries",
        "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4},
        "min_primaries": 300,
        "attraction": {"force": 0.01}
    });
    let container = json!({"min": [0.0, 0.0, 0.0], "max": [2e-3, 2e-3, 2e-3], "wall_material": "primary"});
    lone_grain(3, method, material, (1.0e-3, json!([1e-3, 1e-3, 1e-3]), model), container, steps)
}

/// [`an_isolated_aggregate_stays_intact_and_round_in_dem`] in 3D ([`one_grain_3d`]; contacts
/// holding `F_0` at 0.5% of the smallest primary, k_n = 3e4 N/m): once relaxed, 2e4 steps move
/// no primary by more than 1% of the smallest primary's diameter, the grain keeps its volume
/// within 0.1% and stays round, and its primaries keep touching (coordination at least 5: a
/// random packing of balls has about 6 inside, fewer on its surface; measured 6.85 for 385
/// primaries, which moved at most 1.1e-8 m, 1.6e-4 of the smallest primary).
#[test]
fn an_isolated_aggregate_stays_intact_and_round_in_3d() {
    let material = json!({"density": 2000.0, "contact": {"law": "linear", "k_n": 3e4}, "restitution": 0.2, "friction": 0.0});
    let mut sim = common::dem(&one_grain_3d(json!({"kind": "dem", "threads": 1}), material, 20_000));
    let n = sim.particle_count();
    assert!((300..500).contains(&n), "{n} primaries");
    stays_intact(&mut sim, |s| s.particles(), 20_000, 5.0);
}

/// Steps `sim` 2,000 steps at a time until it is in equilibrium: its stress-controlled
/// boundaries within 2% of their targets and the net forces below 2% of the contact forces, at
/// three checks in a row. Returns the steps taken, or the last balance when `most_steps` did
/// not reach it.
fn settle(sim: &mut sable_engine::methods::dem::Dem, most_steps: u64) -> Result<u64, sable_engine::run::Balance> {
    let (mut settled, mut steps) = (0, 0);
    loop {
        for _ in 0..2_000 {
            sim.step().expect("step");
        }
        steps += 2_000;
        let b = sim.balance();
        settled = if b.stress_error < 0.02 && b.unbalanced_force < 0.02 { settled + 1 } else { 0 };
        if settled == 3 {
            return Ok(steps);
        }
        if steps >= most_steps {
            return Err(b);
        }
    }
}

/// Four aggregates of 1.2 mm (about 100 primaries of the sources' sizes each, `F_0` = 100 N/m,
/// `p_I` ≈ 1 MPa), by DEM, in a 2.7 mm box whose four walls are servoed to the same pressure,
/// raised step by step through `levels` (over `p_I`); at each, once the walls hold their
/// target within 2% and the net forces are below 2% of the contact forces at three checks in
/// a row, the grains' measures and the walls' mean normal stress (Pa). The walls move at most at 0.1 m/s: an inertial number
/// `ε̇ D sqrt(ρ/p)` of at most 8e-3 at 0.2 `p_I`, less above.
fn pressed_levels(levels: &[f64]) -> Vec<(f64, GrainSample, f64)> {
    let scene = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"primary": dem_primaries_material()},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": 1.2e-3},
            "placement": {"kind": "list", "positions": [[0.63e-3, 0.63e-3], [1.87e-3, 0.63e-3], [0.63e-3, 1.87e-3], [1.87e-3, 1.87e-3]]},
            "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "min_primaries": 80, "attraction": {"force": 100.0}}
        }],
        "container": {"min": [0.0, 0.0], "max": [2.5e-3, 2.5e-3], "wall_material": "primary"},
        "stop": {"steps": 1},
        "seed": 4
    }));
    let mut sim = common::dem(&scene);
    let p = sim.particles();
    let p_i = 100.0 / (2.0 * p.radius.iter().sum::<f64>() / p.len() as f64);
    let mut out = Vec::new();
    for &level in levels {
        let walls = ["x_min", "x_max", "y_min", "y_max"]
            .iter()
            .enumerate()
            .map(|(k, _)| sable_engine::scene::WallDef {
                face: sable_engine::scene::Face { axis: k / 2, upper: k % 2 == 1 },
                motion: sable_engine::scene::WallMotion::Stress { stress: level * p_i, gain: None, max_speed: 0.1, integral: false },
            })
            .collect();
        sim.apply_controls(&sable_engine::scene::Controls { walls, ..Default::default() }).expect("controls");
        if let Err(b) = settle(&mut sim, 1_000_000) {
            panic!("no equilibrium at {level} p_I in 1e6 steps: {b:?}");
        }
        let s = sim.sample().expect("sample");
        let g = grains(&s);
        eprintln!(
            "p = {level} p_I ({:e} Pa), {} steps: grains' Φ {:.4}, Z {:.2}, aspect {:.3}/{:.3}, pressure {:e} Pa; primaries' Φ {:.4}; walls {:e} Pa",
            level * p_i,
            sim.steps_done(),
            g.phi,
            g.z,
            g.mean_aspect_ratio,
            g.max_aspect_ratio,
            g.pressure,
            primaries_of(&s).phi,
            s.walls.iter().map(|w| w.normal_stress).sum::<f64>() / s.walls.len() as f64
        );
        let walls = s.walls.iter().map(|w| w.normal_stress).sum::<f64>() / s.walls.len() as f64;
        out.push((level, g, walls));
    }
    out
}

/// Aggregates pressed isotropically ([`pressed_levels`]) at 0.1, 0.3 and 1 `p_I`:
///
/// - the grains' Φ rises with `p/p_I` and stays below 1, within 0.04 of the sources' fit of their
///   isotropic BPM samples (Nezamabadi 2020, §2.2.1, eq. 2.21: 300 grains of about 330 primaries),
///   `Φ = 0.92 + 0.13 log10(p/p_I)`. Measured 0.764, 0.844, 0.929 against 0.790, 0.852, 0.920; four
///   grains are a small sample (another placement gave 0.913 and 0.936 at 1 `p_I`), hence 0.04;
/// - the grains carry the walls' stress: their area-weighted pressure times their Φ (the
///   grains' share of the box) is the walls' pressure within 2% (measured 0.2%, 0.04% and
///   0.02%), as it must be when every force between grains and walls passes through the grains'
///   contacts (Love–Weber over the grains, `observe/grains/`).
#[test]
fn pressed_aggregates_densify_with_the_pressure_over_p_i() {
    let r = pressed_levels(&[0.1, 0.3, 1.0]);
    for w in r.windows(2) {
        assert!(w[1].1.phi > w[0].1.phi + 0.02, "grains' Φ {} at {} p_I, {} at {} p_I", w[0].1.phi, w[0].0, w[1].1.phi, w[1].0);
    }
    for (level, g, walls) in &r {
        let fit = 0.92 + 0.13 * level.log10();
        assert!((g.phi - fit).abs() < 0.04, "grains' Φ {} at {level} p_I against the sources' {fit}", g.phi);
        assert!(g.phi < 0.97, "grains' Φ {} at {level} p_I", g.phi);
        assert!(
            (g.pressure * g.phi / walls - 1.0).abs() < 0.02,
            "grains' pressure {} × Φ {} against the walls' {walls}",
            g.pressure,
            g.phi
        );
    }
}

/// One aggregate of 1.4 mm (129 primaries of the sources' sizes, `F_0` = `f0`) between two
/// plates, by DEM (contacts of k_n = 4e8 N/m: `F_0` = 200 N/m at 0.7% of the smallest
/// primary), the top plate servoed at most at 0.1 m/s to the forces `loads` in turn, in units
/// of `p_I D` (N/m: the grain's mean stress over its diameter in units of `p_I`), each with the
/// most steps it is held. Each load is
/// held until the grain is in equilibrium (the plate within 2% of its target, the net forces
/// below 2% of the contact forces, at three checks 2,000 steps apart), or for at most its
/// number of steps; then the height strain `1 − h/h_0` (`h_0` the plates' gap on the grain at
/// rest). Returns the strains, one per load.
fn plates(f0: f64, loads: &[(f64, u64)]) -> Vec<f64> {
    let diameter = 1.4e-3;
    let scene = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"primary": {"density": 2000.0, "contact": {"law": "linear", "k_n": 4e8}, "restitution": 0.2, "friction": 0.0}},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": diameter},
            "placement": {"kind": "list", "positions": [[2e-3, 0.75e-3]]},
            "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "min_primaries": 100, "attraction": {"force": f0}}
        }],
        "container": {"min": [0.0, 0.0], "max": [4e-3, 1.5e-3], "wall_material": "primary"},
        "stop": {"steps": 1},
        "seed": 1
    }));
    let mut sim = common::dem(&scene);
    let p = sim.particles();
    let p_i = f0 / (2.0 * p.radius.iter().sum::<f64>() / p.len() as f64);
    sim.apply_controls(&sable_engine::scene::Controls { close_walls: Some(1), ..Default::default() }).expect("close the plates");
    let height = |sim: &sable_engine::methods::dem::Dem| sim.domain().hi.y - sim.domain().lo.y;
    let (h0, width) = (height(&sim), sim.domain().hi.x - sim.domain().lo.x);
    let mut strains = Vec::new();
    for &(load, most_steps) in loads {
        let motion =
            sable_engine::scene::WallMotion::Stress { stress: load * p_i * diameter / width, gain: None, max_speed: 0.1, integral: false };
        let walls = vec![sable_engine::scene::WallDef { face: sable_engine::scene::Face { axis: 1, upper: true }, motion }];
        sim.apply_controls(&sable_engine::scene::Controls { walls, ..Default::default() }).expect("controls");
        // A load the grain does not carry in equilibrium is held for its most steps (it flows).
        let _ = settle(&mut sim, most_steps);
        strains.push(1.0 - height(&sim) / h0);
    }
    eprintln!("F_0 {f0} N/m, p_I {p_i:.4e} Pa: loads (p_I D, most steps) {loads:?}, strains {strains:.4?}");
    strains
}

/// One aggregate between plates ([`plates`]) is elastic below a load set by `p_I` and flows
/// plastically above it. Seated at 0.02 `p_I D`, then loaded to 0.05, 0.1 and 0.4 `p_I D`,
/// back to the seating load after each:
///
/// - after 0.05 and 0.1 it comes back to its seated height within 0.05% of strain (measured:
///   exactly, to the 4th digit), and the strain under load grows with the load (measured
///   0.18% and 0.37% above the seat at `F_0` = 100 N/m, 0.21% and 0.46% at 200 N/m): elastic;
/// - after 0.4 (held at most 60,000 steps: it flows on) it keeps more than 2% of strain
///   (measured 4.1% at 100 N/m, 3.0% at 200 N/m): plastic.
///
/// Bounds: the seat is held to 0.05% of strain, an eighth of the smallest elastic strain
/// measured (0.18%); the load increments above the seat, 0.03 and 0.08 `p_I D`, would give
/// strains 2.7 times apart if linear, measured 2.0–2.2 (the contact widens and stiffens), and
/// the test asks 1.5; under 0.1 the strain must stay below 1%, where a grain that yielded
/// shows several percent (4.5–5.3% under 0.2 `p_I D` in the load steps below).
///
/// The same in units of `p_I` for `F_0` = 100 and 200 N/m (at one contact stiffness, so not a
/// mere change of units): the yield load scales with `p_I`. Measured by load steps of 0.05,
/// 0.1, 0.2, 0.4 `p_I D` (unloading to 0.005 between them, 2026-11-27): this grain yields
/// between 0.1 and 0.2 `p_I D` at both `F_0`; another placement (seed 2) between 0.2 and 0.4
/// at 100 N/m and between 0.1 and 0.2 at 200 N/m; a grain of 1.8 mm (seed 1) already at
/// 0.08. A grain of some hundred primaries yields where its weakest cluster gives way: at a
/// load of order 0.1 `p_I D`, scattered by a factor of about 2 from grain to grain.
fn elastic_below_and_plastic_above(f0: f64) {
    let loads = [(0.02, 200_000), (0.05, 200_000), (0.02, 200_000), (0.1, 200_000), (0.02, 200_000), (0.4, 60_000), (0.02, 200_000)];
    let e = plates(f0, &loads);
    let seat = e[0];
    for (k, load) in [(2, 0.05), (4, 0.1)] {
        assert!((e[k] - seat).abs() < 5e-4, "F_0 {f0}: back from {load} p_I D at strain {} against the seat's {seat}", e[k]);
    }
    let (under_half, under_full) = (e[1] - seat, e[3] - seat);
    assert!(under_half > 0.0 && under_full > 1.5 * under_half, "F_0 {f0}: strains under 0.05 and 0.1 p_I D: {under_half}, {under_full}");
    assert!(under_full < 0.01, "F_0 {f0}: {under_full} of strain under 0.1 p_I D is not a small elastic strain");
    assert!(e[6] - seat > 0.02, "F_0 {f0}: back from 0.4 p_I D at strain {} against the seat's {seat}: no plastic strain", e[6]);
}

/// [`elastic_below_and_plastic_above`] at the sources' `F_0`.
#[test]
fn an_aggregate_between_plates_is_elastic_below_a_load_set_by_p_i_and_flows_above() {
    elastic_below_and_plastic_above(100.0);
}

/// [`elastic_below_and_plastic_above`] with twice the attraction: the same in units of `p_I`.
#[test]
fn twice_the_attraction_doubles_the_load_an_aggregate_carries_elastically() {
    elastic_below_and_plastic_above(200.0);
}

/// One aggregate of [`one_grain_by`]'s size by DEM in a box periodic along x, its centre
/// `x0` from the boundary, after relaxing and `steps` at rest: its grain measures.
fn periodic_grain(x0: f64, steps: u64) -> (GrainSample, GrainSample) {
    periodic_grain_by(json!({"kind": "dem", "threads": 1}), dem_primaries_material(), common::dem, (1.8e-3, 200), x0, steps)
}

/// [`periodic_grain`] by `method` (built by `build`), its primaries of `material`, the grain's
/// diameter and least number of primaries `size`.
fn periodic_grain_by<S: Simulation>(
    method: serde_json::Value,
    material: serde_json::Value,
    build: fn(&sable_engine::methods::Plan) -> S,
    (diameter, primaries): (f64, usize),
    x0: f64,
    steps: u64,
) -> (GrainSample, GrainSample) {
    let container = json!({"min": [0.0, 0.0], "max": [4e-3, 4e-3], "wall_material": "primary", "periodic": ["x"]});
    let scene = lone_grain(2, method, material, (diameter, json!([x0, 2e-3]), bonded(primaries)), container, steps);
    let mut sim = build(&scene);
    let g0 = grains(&sim.sample().expect("sample"));
    for _ in 0..steps {
        sim.step().expect("step");
    }
    (g0, grains(&sim.sample().expect("sample")))
}

/// A grain across a periodic boundary is whole: an aggregate centred 0.2 mm from the boundary
/// of a box periodic along x (its primaries on both sides, at their images) is measured as the
/// same aggregate centred in the box (the same primaries, grown from the same draws): area
/// within 0.5% and aspect ratio within 1%, after relaxing and 1e4 DEM steps at rest, in which
/// its area keeps within 0.1%.
#[test]
fn an_aggregate_across_a_periodic_boundary_is_one_grain() {
    let (inside0, inside) = periodic_grain(2e-3, 10_000);
    let (across0, across) = periodic_grain(0.2e-3, 10_000);
    eprintln!("inside {inside0:?} -> {inside:?}; across {across0:?} -> {across:?}");
    assert_eq!((across.count, inside.count), (1, 1));
    assert!((across.mean_area / inside.mean_area - 1.0).abs() < 5e-3, "area {:e} against {:e}", across.mean_area, inside.mean_area);
    assert!(
        (across.max_aspect_ratio / inside.max_aspect_ratio - 1.0).abs() < 0.01,
        "aspect {} against {}",
        across.max_aspect_ratio,
        inside.max_aspect_ratio
    );
    assert!((across.mean_area / across0.mean_area - 1.0).abs() < 1e-3, "area {:e} -> {:e}", across0.mean_area, across.mean_area);
    assert!(across.max_aspect_ratio < 1.1, "aspect {}", across.max_aspect_ratio);
}

/// [`an_aggregate_across_a_periodic_boundary_is_one_grain`] by contact dynamics (the attraction
/// and the repulsion of primaries on both sides of the boundary solved through their images),
/// for a grain of 1.2 mm (about 90 primaries: a tenth of the cost), 2,000 steps at rest: one
/// grain, whole (round: aspect ratio below 1.1, where a grain cut in two by the boundary
/// measures above 2), of the area the same draws give inside the box within 0.5%, kept within
/// 0.1%. Not the same shape to 1% as by DEM: the relaxation at build moves primaries by up to
/// 0.6 of a diameter (`methods/cd/relax.rs`), and Gauss-Seidel meets the contacts across the
/// boundary in another order, so the two may relax to different packings (measured at 1.8 mm:
/// areas 0.2% apart, aspect ratios 1.018 and 1.039; at 1.2 mm: areas 0.01% apart, aspect
/// ratios 1.005 and 1.010; all unchanged to 1e-6 over the 2,000 steps).
#[test]
fn an_aggregate_across_a_periodic_boundary_is_one_grain_in_cd() {
    let (inside0, inside) = periodic_grain_by(json!("cd"), primaries_material(), common::cd, (1.2e-3, 80), 2e-3, 2_000);
    let (across0, across) = periodic_grain_by(json!("cd"), primaries_material(), common::cd, (1.2e-3, 80), 0.2e-3, 2_000);
    eprintln!("inside {inside0:?} -> {inside:?}; across {across0:?} -> {across:?}");
    assert_eq!((across.count, inside.count), (1, 1));
    assert!((across.mean_area / inside.mean_area - 1.0).abs() < 5e-3, "area {:e} against {:e}", across.mean_area, inside.mean_area);
    assert!(
        across.max_aspect_ratio < 1.1 && inside.max_aspect_ratio < 1.1,
        "aspect {} and {}",
        across.max_aspect_ratio,
        inside.max_aspect_ratio
    );
    assert!((across.mean_area / across0.mean_area - 1.0).abs() < 1e-3, "area {:e} -> {:e}", across0.mean_area, across.mean_area);
}

/// A cell's pressure servo reads the aggregates' attraction too: one aggregate alone in a fully
/// periodic cell servoed towards 10 kPa carries no load, so the cell closes at its full rate
/// (50/s on each axis: Φ grows as `exp(2 × 50 t)`, within 2% of that exponent; measured
/// 0.994 of it, the servo starting from rest and updating every 10 steps), and the
/// grain, which follows the remap and relaxes as it goes, keeps its area within 1%. When the
/// servo read only the contacts, the repulsion that balances the attraction inside the
/// aggregate counted as a pressure of order `p_I`, and the cell opened instead.
#[test]
fn a_periodic_cell_servo_closes_on_an_unloaded_aggregate() {
    let method = json!({"kind": "dem", "threads": 1});
    cell_closes_on_an_unloaded_aggregate(method, dem_primaries_material(), common::dem, (1.8e-3, 200), 5_000);
}

/// [`a_periodic_cell_servo_closes_on_an_unloaded_aggregate`] by `method` (built by `build`),
/// its primaries of `material`, the grain's diameter and least number of primaries `size`,
/// over `steps`: checks the closing rate and the grain's area, and returns the cell's last
/// pressure, Pa.
fn cell_closes_on_an_unloaded_aggregate<S: Simulation>(
    method: serde_json::Value,
    material: serde_json::Value,
    build: fn(&sable_engine::methods::Plan) -> S,
    (diameter, primaries): (f64, usize),
    steps: u64,
) -> f64 {
    let container = json!({
        "min": [0.0, 0.0], "max": [4e-3, 4e-3], "periodic": ["x", "y"],
        "deformation": {"kind": "pressure", "target": 1e4, "max_strain_rate": 50.0}
    });
    let scene = lone_grain(2, method, material, (diameter, json!([2e-3, 2e-3]), bonded(primaries)), container, steps);
    let mut sim = build(&scene);
    let s0 = sim.sample().expect("sample");
    for _ in 0..steps {
        sim.step().expect("step");
    }
    let s1 = sim.sample().expect("sample");
    let (g0, g1) = (grains(&s0), grains(&s1));
    let (a0, a1) = (primaries_of(&s0), primaries_of(&s1));
    let exponent = (a1.phi / a0.phi).ln() / (2.0 * 50.0 * (s1.time - s0.time));
    eprintln!(
        "by {}: Φ {} -> {} in {:e} s: exponent {exponent} of full rate; p {} Pa; grain area {:e} -> {:e}",
        sim.method(),
        a0.phi,
        a1.phi,
        s1.time - s0.time,
        s1.p,
        g0.mean_area,
        g1.mean_area
    );
    assert!((exponent - 1.0).abs() < 0.02, "the cell closed at {exponent} of its full rate");
    assert!((g1.mean_area / g0.mean_area - 1.0).abs() < 0.01, "grain area {:e} -> {:e}", g0.mean_area, g1.mean_area);
    s1.p
}

/// Four aggregates of 1.2 mm (about 80 primaries of the sources' sizes each, `F_0` = 100 N/m,
/// `p_I` ≈ 1 MPa) on a 2 × 2 lattice in a cell of 2.45 mm periodic along x and y (no walls, no
/// corners), by DEM with contacts of k_n = 1e9 N/m (at 10 `p_I` a contact's force of about
/// `10 p_I d` overlaps it by 1% of a primary), the cell servoed to an isotropic pressure
/// through `levels` (over `p_I`): to the first at a strain rate of at most 500/s (the loose
/// lattice closes), to the others at most 124/s (an inertial number `ε̇ D sqrt(ρ/p)` of at most
/// 7e-3 at `p_I`). At each, once the cell holds its target within 2% and the net forces are
/// below 2% of the contact forces at three checks in a row: the grains' measures and the
/// cell's pressure (Pa).
fn pressed_in_a_cell(levels: &[f64]) -> Vec<(f64, GrainSample, f64)> {
    let side = 2.45e-3;
    let (a, b) = (0.25 * side, 0.75 * side);
    let scene = common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"primary": {"density": 2000.0, "contact": {"law": "linear", "k_n": 1e9}, "restitution": 0.2, "friction": 0.0}},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": 1.2e-3},
            "placement": {"kind": "list", "positions": [[a, a], [b, a], [a, b], [b, b]]},
            "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "min_primaries": 80, "attraction": {"force": 100.0}}
        }],
        "container": {"min": [0.0, 0.0], "max": [side, side], "periodic": ["x", "y"]},
        "stop": {"steps": 1},
        "seed": 4
    }));
    let mut sim = common::dem(&scene);
    let p = sim.particles();
    let p_i = 100.0 / (2.0 * p.radius.iter().sum::<f64>() / p.len() as f64);
    let mut out = Vec::new();
    for (k, &level) in levels.iter().enumerate() {
        let max_strain_rate = if k == 0 { 500.0 } else { 124.0 };
        let target = level * p_i;
        let deformation = sable_engine::scene::Deformation::Pressure { target, max_strain_rate, gain: max_strain_rate / target };
        let controls =
            sable_engine::scene::Controls { deformation: Some(Some(deformation)), local_damping: Some(0.2), ..Default::default() };
        sim.apply_controls(&controls).expect("controls");
        if let Err(b) = settle(&mut sim, 1_000_000) {
            panic!("no equilibrium at {level} p_I in 1e6 steps: {b:?}");
        }
        let s = sim.sample().expect("sample");
        let g = grains(&s);
        eprintln!(
            "p = {level} p_I ({target:e} Pa), {} steps: grains' Φ {:.4}, Z {:.2}, aspect {:.3}/{:.3}, pressure {:e} Pa; primaries' Φ {:.4}; cell {:e} Pa",
            sim.steps_done(),
            g.phi,
            g.z,
            g.mean_aspect_ratio,
            g.max_aspect_ratio,
            g.pressure,
            primaries_of(&s).phi,
            s.p,
        );
        out.push((level, g, s.p));
    }
    out
}

/// Aggregates pressed isotropically in a periodic cell ([`pressed_in_a_cell`]) to 0.1 `p_I`,
/// then 1, 3 and 10 `p_I`: the grains' Φ rises with `p/p_I` and saturates below 1.
///
/// - At 1 and 3 `p_I` it follows the sources' fit `Φ = 0.92 + 0.13 log10(p/p_I)` (Nezamabadi 2020,
///   eq. 2.21) within 0.04, as the walled test above (measured 0.930 and 0.974 against 0.920 and
///   0.982). Below `p_I` the grains are nearly round and a 2 × 2 lattice's Φ is its geometry's
///   (round disks on a square lattice fill π/4 = 0.785; measured 0.773 at 0.1 `p_I` and 0.811 at
///   0.3, 0.041 under the fit): the walled test holds the fit there.
/// - Above, it saturates: from 3 to 10 `p_I` the fit (which passes 1 at 4.1 `p_I`) would add
///   0.068; the grains add less than a quarter of it, and less than half what they gained from
///   1 to 3 `p_I` (measured +0.011 against +0.043), and stay below 0.995 (measured 0.985; the
///   9-grain walled study gave 0.978 → 0.977 → 0.982 at 3, 10 and 30 `p_I`, README). What is
///   left is the primaries' scale: the outline of a grain (its primaries closed by half the
///   smallest one) cannot fill the gaps between grains' outlines.
/// - The grains carry the cell's pressure: their pressure times their Φ is the cell's within
///   2% (measured within 0.3%). From 3 `p_I` on, grains in this cell two grains across press
///   against their own periodic images (11–15 such contacts); before the grains' measures
///   counted those as contacts between grains, they gave 0.93 of the cell's pressure.
#[test]
fn pressed_aggregates_in_a_periodic_cell_saturate_below_one_above_p_i() {
    let r = pressed_in_a_cell(&[0.1, 1.0, 3.0, 10.0]);
    let fit = |level: f64| 0.92 + 0.13 * level.log10();
    for w in r.windows(2) {
        assert!(w[1].1.phi > w[0].1.phi, "grains' Φ {} at {} p_I, {} at {} p_I", w[0].1.phi, w[0].0, w[1].1.phi, w[1].0);
    }
    for (level, g, cell) in &r {
        if (1.0..=3.0).contains(level) {
            assert!((g.phi - fit(*level)).abs() < 0.04, "grains' Φ {} at {level} p_I against the sources' {}", g.phi, fit(*level));
        }
        assert!((g.pressure * g.phi / cell - 1.0).abs() < 0.02, "grains' pressure {} × Φ {} against the cell's {cell}", g.pressure, g.phi);
    }
    let phi = |level: f64| r.iter().find(|x| x.0 == level).map(|x| x.1.phi).unwrap_or(f64::NAN);
    let (low, high) = (phi(3.0) - phi(1.0), phi(10.0) - phi(3.0));
    assert!(high < 0.25 * (fit(10.0) - fit(3.0)) && high < 0.5 * low, "Φ gains {high} from 3 to 10 p_I, {low} from 1 to 3 p_I");
    assert!(phi(10.0) < 0.995, "grains' Φ {} at 10 p_I", phi(10.0));
}

/// [`a_periodic_cell_servo_closes_on_an_unloaded_aggregate`] by contact dynamics (the cell a
/// body of the contact problem, `methods/cd/cell.rs`), one grain of 1.2 mm, 1,000 steps: the
/// cell closes at its full rate within 2% (measured 0.998 of it) and the grain keeps its area
/// within 1% (measured: unchanged); the cell reads a pressure below 1 Pa (measured 6e-3 Pa)
/// against the 10 kPa it seeks, where the attraction inside the aggregate taken for a load
/// would read of order `p_I` × Φ, 5e4 Pa.
#[test]
fn a_periodic_cell_servo_closes_on_an_unloaded_aggregate_in_cd() {
    let p = cell_closes_on_an_unloaded_aggregate(json!("cd"), primaries_material(), common::cd, (1.2e-3, 80), 1_000);
    assert!(p.abs() < 1.0, "the cell reads {p} Pa");
}
