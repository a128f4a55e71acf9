//! Helpers shared by the physics tests.
#![allow(dead_code)]

/// The throw-away PostgreSQL of the tests (shared with the server's tests).
#[path = "../../../server/tests/common/postgres.rs"]
pub mod postgres;

use sable_engine::methods::cd::CdParams;
use sable_engine::methods::dem::{Dem, DemParams};
use sable_engine::methods::{plan_scene, Plan};

/// Parses a scene given as a JSON value with its method, panicking with the violations if
/// invalid.
pub fn scene(v: serde_json::Value) -> Plan {
    match plan_scene(&v.to_string()) {
        Ok(s) => s,
        Err(e) => panic!("invalid test scene: {e:?}"),
    }
}

/// Builds the DEM simulation of a scene.
pub fn dem(s: &Plan) -> Dem {
    let Some(p) = s.params::<DemParams>() else { panic!("not a DEM scene") };
    match Dem::new(s, p) {
        Ok(d) => d,
        Err(e) => panic!("cannot build test scene: {e}"),
    }
}

/// A material object with a linear law.
pub fn linear_material(k_n: f64, e: f64, mu: f64) -> serde_json::Value {
    serde_json::json!({"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": e, "friction": mu})
}

/// Builds the contact-dynamics simulation of a scene.
pub fn cd(s: &Plan) -> sable_engine::methods::cd::Cd {
    let Some(p) = s.params::<CdParams>() else { panic!("not a CD scene") };
    match sable_engine::methods::cd::Cd::new(s, p) {
        Ok(d) => d,
        Err(e) => panic!("cannot build test scene: {e}"),
    }
}

/// Contact dynamics for grains of diameter `d` at `positions` in a box periodic along x (and
/// z), 0.02 m wide and 0.05 m high, between a floor and a ceiling of material `wall`, with
/// gravity `gravity`, at the step `dt`, solved tightly (relative change 1e-10, violation 1e-12).
pub fn cd_box(
    dim: usize,
    positions: serde_json::Value,
    d: f64,
    gravity: serde_json::Value,
    grain: serde_json::Value,
    wall: serde_json::Value,
    dt: f64,
) -> sable_engine::methods::cd::Cd {
    use serde_json::json;
    let count = positions.as_array().map_or(0, Vec::len);
    let (min, max, periodic) = if dim == 2 {
        (json!([0, 0]), json!([0.02, 0.05]), json!(["x"]))
    } else {
        (json!([0, 0, 0]), json!([0.02, 0.05, 0.02]), json!(["x", "z"]))
    };
    cd(&scene(json!({
        "dimension": dim,
        "method": {"kind": "cd", "time_step": dt, "tolerance": 1e-10, "violation_tolerance": 1e-12, "max_iterations": 100000},
        "materials": {"grain": grain, "wall": wall},
        "particles": [{"material": "grain", "placement": {"kind": "list", "positions": positions, "diameters": vec![d; count]}}],
        "container": {"min": min, "max": max, "periodic": periodic, "wall_material": "wall"},
        "gravity": gravity,
        "stop": {"steps": 1}
    })))
}

/// The granule of the `granule_compression` tests: 300 wet glass spheres (d 0.9-1.1 mm,
/// γ = `gamma` N/m, bridges of 1e-12 m³, μ = 0.3) in a 24 mm box, squeezed at 3 1/s, with
/// `method`. The caller adds `sampling` if it wants one.
pub fn granule_scene(method: serde_json::Value, gamma: f64) -> serde_json::Value {
    serde_json::json!({
        "dimension": 3,
        "method": method,
        "materials": {
            "wet_glass": {"density": 2500.0, "contact": {"law": "linear", "k_n": 500.0}, "restitution": 0.3, "friction": 0.3,
                          "liquid": {"surface_tension": gamma, "contact_angle": 0.0, "bridge_volume": 1.0e-12, "viscosity": 1.0e-3, "roughness": 1.0e-5}},
            "plate": {"density": 2500.0, "contact": {"law": "linear", "k_n": 500.0}, "restitution": 0.3, "friction": 0.3}
        },
        "particles": [{"material": "wet_glass", "count": 300, "size": {"kind": "uniform", "min": 0.9e-3, "max": 1.1e-3},
                       "placement": {"kind": "random"}, "wet_fraction": 1.0}],
        "container": {"min": [0, 0, 0], "max": [0.024, 0.024, 0.024], "wall_material": "plate"},
        "experiment": {"kind": "granule_compression", "strain_rate": 3.0},
        "seed": 3
    })
}

/// Two disks (d = 1 mm, ρ = 2500 kg/m³) held in contact by a capillary bridge: the attraction
/// κR balances the linear spring k_n at δ_eq = κR/k_n = 0.06 R. Released at rest from 1.1 δ_eq,
/// without damping (e = 1) or friction, the pair oscillates about δ_eq at ω0 = sqrt(k_n/m*),
/// m* = m/2, for ever when velocity Verlet is stable; past dt = 2/ω0 the oscillation grows
/// until the overlap passes the guard's limit (0.1 R).
pub fn bound_pair() -> serde_json::Value {
    let r = 5e-4;
    let k_n = 1e3;
    let delta_eq = 0.06 * r;
    let kappa = k_n * delta_eq / r; // κ = 2π γ cos θ
    let gamma = kappa / (2.0 * std::f64::consts::PI);
    let gap = 2.0 * r - 1.1 * delta_eq;
    // Overlapping grains cannot be placed by a particle set: the pair starts from a state.
    let state = serde_json::json!({
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
    serde_json::json!({
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

/// Runs the scene file at `path` (relative to the repository) after `edit` changes its JSON:
/// its samples.
pub fn run_file_with(path: &str, edit: impl FnOnce(&mut serde_json::Value)) -> Vec<sable_engine::observe::Sample> {
    let full = format!("{}/../{path}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&full).expect("scene file");
    let mut value: serde_json::Value = serde_json::from_str(&text).expect("json");
    edit(&mut value);
    let s = scene(value);
    let mut sim = s.build().expect("buildable");
    let runner = sable_engine::run::Runner::for_scene(&s);
    let mut samples = Vec::new();
    runner.run(sim.as_mut(), &mut |x, _| samples.push(x.clone())).expect("stable");
    samples
}

/// The scene file at `path` run to `steps` on one and on two threads: the largest relative
/// difference of Φ and σ_yy between the two runs' samples (Z must be equal), and the last
/// sample of the one-thread run.
pub fn thread_count_difference(path: &str, steps: u64) -> (f64, sable_engine::observe::Sample) {
    let on = |threads: usize| {
        run_file_with(path, |v| {
            v["method"]["threads"] = serde_json::json!(threads);
            v["stop"] = serde_json::json!({ "steps": steps });
        })
    };
    let (one, two) = (on(1), on(2));
    assert_eq!(one.len(), two.len());
    let mut worst: f64 = 0.0;
    for (a, b) in one.iter().zip(&two) {
        let scale = a.stress.yy.abs().max(1.0);
        worst = worst.max((a.phi - b.phi).abs() / a.phi).max((a.stress.yy - b.stress.yy).abs() / scale);
        assert_eq!(a.z, b.z, "Z at step {}", a.step);
    }
    let last = one.last().expect("samples").clone();
    eprintln!(
        "threads 1 and 2: largest relative difference {worst:.2e} (Φ {:.4}, σ_yy {:.4e} Pa at step {})",
        last.phi, last.stress.yy, last.step
    );
    (worst, last)
}
