//! The bonded particle method's soft grains (PHYSICS.md §4; N 1.2.1, 2.1.3): aggregates of
//! rigid primaries bound by the attraction `F_0 (1 + δ/a_0)^(−γ)`, run by contact dynamics.
//!
//! Tolerances: an aggregate at rest is static; what moves it is the contact solver's leftover
//! (relative change 1e-6 of impulses set by `F_0` ≈ 100 N/m, [`AGGREGATE_TOLERANCE`]),
//! measured at 4e-8 m of creep per 1e4 steps of 1e-7 s for 227 primaries — the test allows 1% of
//! the smallest primary's diameter (7e-7 m) over 1e5 steps.

mod common;

use sable_engine::observe::GrainSample;
use sable_engine::run::Simulation;
use sable_engine::scene::AGGREGATE_TOLERANCE;
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
/// 4 mm box without gravity, run for `steps`.
fn one_grain(steps: u64) -> sable_engine::scene::Scene {
    common::scene(json!({
        "dimension": 2,
        "method": "cd",
        "materials": {"primary": primaries_material()},
        "particles": [{
            "material": "primary",
            "size": {"kind": "monodisperse", "diameter": 1.8e-3},
            "placement": {"kind": "list", "positions": [[2e-3, 2e-3]]},
            "model": bonded(200)
        }],
        "container": {"min": [0.0, 0.0], "max": [4e-3, 4e-3], "wall_material": "primary"},
        "stop": {"steps": steps}
    }))
}

fn grains(s: &sable_engine::observe::Sample) -> GrainSample {
    match &s.grains {
        Some(g) => **g,
        None => panic!("a sample of aggregates without grain measures"),
    }
}

/// One aggregate of the sources' size alone ([`one_grain`]): once relaxed (at build), 1e5 steps move no primary by more than 1% of the smallest primary's
/// diameter, the grain keeps its area within 0.1% and stays round (aspect ratio below 1.1),
/// and its primaries keep touching (their coordination at least 3).
#[test]
fn an_isolated_aggregate_stays_intact_and_round() {
    let scene = one_grain(100_000);
    let sable_engine::scene::Method::Cd(params) = &scene.method else { panic!("not cd") };
    assert_eq!(params.tolerance, AGGREGATE_TOLERANCE);
    let mut sim = common::cd(&scene);
    let n = sim.particle_count();
    assert!((200..260).contains(&n), "{n} primaries");
    let start_positions = sim.particles().pos.clone();
    let d_min = 2.0 * sim.particles().radius.iter().copied().fold(f64::INFINITY, f64::min);
    let first = sim.sample().expect("sample");
    let g0 = grains(&first);
    assert_eq!(g0.count, 1);
    for _ in 0..100_000 {
        sim.step().expect("step");
    }
    let last = sim.sample().expect("sample");
    let g1 = grains(&last);
    let drift = sim.particles().pos.iter().zip(&start_positions).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    eprintln!(
        "{n} primaries: largest drift {drift:e} m over 1e5 steps of {:e} s; area {:e} -> {:e} m²; aspect ratio {} -> {}; Z {}",
        sim.dt(),
        g0.mean_area,
        g1.mean_area,
        g0.max_aspect_ratio,
        g1.max_aspect_ratio,
        last.z
    );
    assert!(drift < 0.01 * d_min, "a primary moved {drift:e} m ({:.2e} of d_min)", drift / d_min);
    assert!((g1.mean_area / g0.mean_area - 1.0).abs() < 1e-3, "area {:e} -> {:e} m²", g0.mean_area, g1.mean_area);
    assert!(g1.max_aspect_ratio < 1.1, "aspect ratio {}", g1.max_aspect_ratio);
    assert!(last.z >= 3.0, "primaries' coordination {}", last.z);
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
    let sable_engine::scene::Method::Cd(params) = &scene.method else { panic!("not cd") };
    match sable_engine::methods::cd::Cd::new(&scene, params) {
        Err(sable_engine::EngineError::Build { field, reason }) => {
            assert_eq!(field, "particles[0].model.primaries");
            assert!(reason.contains("fewer than min_primaries (400)"), "{reason}");
        }
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("an aggregate of fewer primaries than asked was built"),
    }
}

/// The shipped example parses, with its four grains of about 220 primaries run by contact
/// dynamics at the aggregates' tolerance.
#[test]
fn the_example_scene_is_valid() {
    let scene = match sable_engine::scene::parse_scene(include_str!("../../scenes/bpm_compaction_2d.json")) {
        Ok(s) => s,
        Err(v) => panic!("scenes/bpm_compaction_2d.json: {v:?}"),
    };
    assert!(scene.sets[0].aggregate.is_some());
    assert_eq!(scene.particle_count(), 880);
    assert!(matches!(scene.method, sable_engine::scene::Method::Cd(ref p) if p.tolerance == AGGREGATE_TOLERANCE));
}
