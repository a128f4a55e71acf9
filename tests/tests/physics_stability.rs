//! Stability maps (issue 6): the bisection of a study finds the time step at which DEM stops
//! being stable, and the theory it is compared with.

use sable_engine::run::Runner;
use sable_engine::study::search::{FailureMode, Next, Probe, Scale, SearchSpec, Side};
use sable_engine::study::{probe_scene, theory};
use serde_json::Value;

use crate::common;

/// Runs a scene in-process as a job would; `None` if it ran through, else how it failed.
fn outcome(scene: &Value) -> Option<FailureMode> {
    let s = sable_engine::methods::plan_scene(&scene.to_string()).expect("valid probe scene");
    let mut sim = s.build().expect("buildable");
    match Runner::for_scene(&s).run(sim.as_mut(), &mut |_, _| {}) {
        Ok(_) => None,
        Err(e) => Some(FailureMode::of(e.code(), &e.to_string())),
    }
}

#[test]
fn the_dem_stability_search_finds_two_over_omega_zero_for_a_bound_pair() {
    let scene = common::bound_pair();
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
    // Velocity Verlet on one linear contact is stable up to exactly 2/ω0 (its first midpoint is
    // 2/ω0 itself, marginal and bounded), so the bracket holds the theory up to rounding.
    assert!(stable <= limit * (1.0 + 1e-12) && limit < unstable, "{stable} .. {unstable} against {limit}");
    assert_eq!(found.mode, Some(FailureMode::ExcessiveOverlap), "{found:?}");
    // Below the limit the pair keeps oscillating; above, it fails within the run.
    assert_eq!(outcome(&probe_scene(&scene, &search, 0.98 * limit).expect("scene")), None);
    assert!(outcome(&probe_scene(&scene, &search, 1.02 * limit).expect("scene")).is_some());
}
