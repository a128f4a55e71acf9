//! Stability maps (issue 6): the bisection of a study finds the time step at which DEM stops
//! being stable, and the theory it is compared with.

use sable_engine::run::Runner;
use sable_engine::study::search::{FailureMode, Next, Probe, Scale, SearchSpec, Side};
use sable_engine::study::{probe_scene, theory};
use serde_json::{json, Value};

/// Runs a scene in-process as a job would; `None` if it ran through, else how it failed.
fn outcome(scene: &Value) -> Option<FailureMode> {
    let s = sable_engine::scene::parse_scene(&scene.to_string()).expect("valid probe scene");
    let mut sim = sable_engine::methods::build(&s).expect("buildable");
    match Runner::for_scene(&s).run(sim.as_mut(), &mut |_, _| {}) {
        Ok(_) => None,
        Err(e) => Some(FailureMode::of(e.code(), &e.to_string())),
    }
}

/// Two disks (d = 1 mm, ρ = 2500 kg/m³) held in contact by a capillary bridge: the attraction
/// κR balances the linear spring k_n at δ_eq = κR/k_n = 0.06 R. Released at rest from 1.1 δ_eq,
/// without damping (e = 1) or friction, the pair oscillates about δ_eq at ω0 = sqrt(k_n/m*),
/// m* = m/2, for ever when velocity Verlet is stable; past dt = 2/ω0 the oscillation grows
/// until the overlap passes the guard's limit (0.1 R).
fn bound_pair() -> Value {
    let r = 5e-4;
    let k_n = 1e3;
    let delta_eq = 0.06 * r;
    let kappa = k_n * delta_eq / r; // κ = 2π γ cos θ
    let gamma = kappa / (2.0 * std::f64::consts::PI);
    let gap = 2.0 * r - 1.1 * delta_eq;
    // Overlapping grains cannot be placed by a particle set: the pair starts from a state.
    let state = json!({
        "format": "sable-state", "version": 1, "dimension": 2,
        "min": [0.0, 0.0], "max": [0.01, 0.01],
        "materials": ["wet"],
        "particles": {
            "material": [0, 0], "radius": [r, r],
            "position": [[0.005 - 0.5 * gap, 0.005], [0.005 + 0.5 * gap, 0.005]],
            "velocity": [[0.0, 0.0], [0.0, 0.0]], "angular_velocity": [[0.0], [0.0]],
            "wet": [true, true]
        }
    });
    json!({
        "dimension": 2,
        "method": {"kind": "dem", "time_step": 1e-3, "threads": 1},
        "materials": {"wet": {
            "density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 1.0, "friction": 0.0,
            "liquid": {"surface_tension": gamma, "contact_angle": 0.0, "bridge_volume": 1e-12, "viscosity": 0.0}
        }},
        "start_from": {"state": state},
        "container": {"wall_material": "wet"},
        "stop": {"steps": 4000},
        "sampling": {"every_steps": 4000}
    })
}

#[test]
fn the_dem_stability_search_finds_two_over_omega_zero_for_a_bound_pair() {
    let scene = bound_pair();
    let m = 2500.0 * std::f64::consts::PI * 5e-4f64.powi(2);
    let limit = 2.0 / (1e3 / (0.5 * m)).sqrt(); // 1.98e-3 s
    let search = SearchSpec {
        parameter: "method.time_step".into(),
        low: 0.5 * limit,
        high: 2.0 * limit,
        unstable: Side::Above,
        iterations: Some(10),
        scale: Scale::Log,
        integer: false,
    };
    // The theory the service reports: 2/ω0 of the pair.
    let t = theory::dem_limit(&scene, &search).expect("a DEM time-step search has a theory");
    assert!((t.value / limit - 1.0).abs() < 1e-9, "theory {} s against 2/ω0 = {limit} s", t.value);
    let mut probes: Vec<Probe> = Vec::new();
    let found = loop {
        match search.next(&probes, 0) {
            Next::Probe(values) => {
                for value in values {
                    let failure = outcome(&probe_scene(&scene, &search, value).expect("probe scene"));
                    probes.push(Probe { value, failure });
                }
            }
            Next::Wait => unreachable!("nothing runs in the background here"),
            Next::Done(l) => break l,
        }
    };
    let (stable, unstable) = (found.stable.expect("a stable step"), found.unstable.expect("a failing step"));
    eprintln!("limit between {stable:.5e} and {unstable:.5e} s; 2/ω0 = {limit:.5e} s; modes {:?}", found.modes_seen);
    // The search brackets the limit to 4^(1/1024) = 0.14%; the issue asks for 5%.
    assert!((stable / limit - 1.0).abs() < 0.05 && (unstable / limit - 1.0).abs() < 0.05, "{stable} .. {unstable} against {limit}");
    assert!(unstable / stable < 1.01);
    assert_eq!(found.mode, Some(FailureMode::ExcessiveOverlap), "{found:?}");
    // Below the limit the pair keeps oscillating; above, it fails within the run.
    assert_eq!(outcome(&probe_scene(&scene, &search, 0.98 * limit).expect("scene")), None);
    assert!(outcome(&probe_scene(&scene, &search, 1.02 * limit).expect("scene")).is_some());
}
