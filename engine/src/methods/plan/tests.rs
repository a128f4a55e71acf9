//! Scenes read with their methods: the scene's rules and each method's, every violation named
//! by its field.

use super::*;
use crate::constitutive::LawSpec;
use crate::methods::cd::{CdParams, Sweep, AGGREGATE_TOLERANCE};
use crate::methods::fem::FemParams;
use crate::methods::mpm::MpmParams;
use crate::scene::{ElasticLaw, ParticleSet, Scene, MAX_PARTICLES};

fn scene_with(method: serde_json::Value, restitution: f64) -> String {
    serde_json::json!({
        "dimension": 2, "method": method,
        "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e5}, "restitution": restitution, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 10, "size": {"kind": "monodisperse", "diameter": 0.001}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "stop": {"steps": 10}
    })
    .to_string()
}

fn rules(text: &str) -> Vec<String> {
    match plan_scene(text) {
        Ok(_) => Vec::new(),
        Err(v) => v.iter().map(|v| format!("{}: {}", v.field, v.rule)).collect(),
    }
}

/// A scene of 4 aggregate grains of 1.8 mm with the sources' primaries, `model` and
/// `method` as given, in a box periodic along x if `periodic`.
fn aggregate_scene(method: serde_json::Value, model: serde_json::Value, periodic: bool) -> String {
    serde_json::json!({
        "dimension": 2, "method": method,
        "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": 1e6}, "restitution": 0.0, "friction": 0.3}},
        "particles": [{"material": "primary", "count": 4, "size": {"kind": "monodisperse", "diameter": 1.8e-3}, "placement": {"kind": "random"}, "model": model}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "primary", "periodic": if periodic { vec!["x"] } else { vec![] }},
        "stop": {"steps": 10}
    })
    .to_string()
}

#[test]
fn aggregates_take_their_defaults_and_run_with_contact_dynamics() {
    let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
    let scene = match plan_scene(&aggregate_scene(serde_json::json!("cd"), model.clone(), false)) {
        Ok(s) => s,
        Err(v) => panic!("{v:?}"),
    };
    let a = scene.sets[0].aggregate.expect("an aggregate set");
    assert_eq!((a.min_primaries, a.bonding.attraction.gamma, a.bonding.attraction.cutoff, a.bonding.friction), (200, 7.0, 1.3e-4, 0.0));
    assert!(scene.params::<CdParams>().is_some_and(|p| p.tolerance == AGGREGATE_TOLERANCE));
    // 4 grains of about 0.70 × (1.8 / 0.1)² primaries (⟨d²⟩ of 0.07–0.13 mm: 1.03e-8 m²).
    assert_eq!(scene.particle_count(), 4 * 220);
    let auto = plan_scene(&aggregate_scene(serde_json::json!("auto"), model.clone(), false)).map(|s| s.method_name());
    assert_eq!(auto, Ok("cd"));
    // A tolerance the scene gives is kept.
    let given = plan_scene(&aggregate_scene(serde_json::json!({"kind": "cd", "tolerance": 1e-4}), model, false));
    assert!(given.is_ok_and(|s| s.params::<CdParams>().is_some_and(|p| p.tolerance == 1e-4)));
}

/// A scene's name is a description, not a document: a 15 MB name once passed every rule and
/// became the job's name, stored and listed with each page of jobs.
#[test]
fn a_scene_name_is_bounded() {
    let mut scene: serde_json::Value = serde_json::from_str(&scene_with(serde_json::json!("dem"), 0.5)).expect("json");
    scene["name"] = serde_json::json!("é".repeat(crate::scene::validate::MAX_SCENE_NAME));
    assert!(rules(&scene.to_string()).is_empty(), "1000 characters (2000 bytes) pass");
    for bad in ["x".repeat(15 << 20), String::new(), "two\nlines".into()] {
        scene["name"] = serde_json::json!(bad);
        let r = rules(&scene.to_string());
        assert_eq!(r.len(), 1, "{r:?}");
        assert!(r[0].starts_with("name: must be 1 to 1000 printable characters"), "{r:?}");
    }
}

/// Counts that overflow a machine word once multiplied (by an aggregate's primaries) or
/// added (over sets) are refused, not wrapped into a small count that passes every limit
/// and then aborts the process that allocates for it.
#[test]
fn overflowing_particle_counts_are_refused() {
    let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
    let mut scene: serde_json::Value = serde_json::from_str(&aggregate_scene(serde_json::json!("cd"), model, false)).expect("json");
    // 83848836698679781 × 220 primaries wraps to 204 in 64 bits.
    scene["particles"][0]["count"] = serde_json::json!(83_848_836_698_679_781_u64);
    let r = rules(&scene.to_string());
    assert!(r.iter().any(|r| r.starts_with("particles[0].count: must be at most 1000000000")), "{r:?}");
    // Valid per set, too many once multiplied by the primaries of each grain.
    scene["particles"][0]["count"] = serde_json::json!(20_000_000);
    let r = rules(&scene.to_string());
    assert_eq!(
        r,
        vec!["particles: the scene places at most 1000000000 particles in all (primaries of aggregates included), got 4400000000"]
    );

    // Two sets whose counts add up past u64::MAX (to 1 when wrapped).
    let mut two: serde_json::Value = serde_json::from_str(&scene_with(serde_json::json!("dem"), 0.5)).expect("json");
    let set = two["particles"][0].clone();
    two["particles"] = serde_json::json!([set.clone(), set]);
    two["particles"][0]["count"] = serde_json::json!(u64::MAX);
    two["particles"][1]["count"] = serde_json::json!(2);
    let r = rules(&two.to_string());
    assert!(r.iter().any(|r| r.starts_with("particles[0].count: must be at most")), "{r:?}");
    // Each set valid, their sum not.
    two["particles"][0]["count"] = serde_json::json!(MAX_PARTICLES);
    let r = rules(&two.to_string());
    assert_eq!(
        r,
        vec![format!(
            "particles: the scene places at most {MAX_PARTICLES} particles in all (primaries of aggregates included), got {}",
            MAX_PARTICLES + 2
        )]
    );
    // The count itself saturates rather than wraps.
    let base = plan_scene(&scene_with(serde_json::json!("dem"), 0.5)).expect("valid");
    let set = ParticleSet { count: usize::MAX, ..base.sets[0].clone() };
    let big = Scene { sets: vec![set.clone(), ParticleSet { count: 2, ..set }], ..base.scene };
    assert_eq!(big.particle_count(), usize::MAX);
}

#[test]
fn bad_aggregates_are_named_field_by_field() {
    let bad = serde_json::json!({
        "kind": "bonded_primaries",
        "primaries": {"kind": "uniform", "min": 7e-5, "max": 5e-5},
        "min_primaries": 10,
        "attraction": {"force": -1.0, "exponent": 0.5, "cutoff": 1e-6},
        "friction": -0.1
    });
    let r = rules(&aggregate_scene(serde_json::json!("mpm"), bad, true));
    for want in [
        "particles[0].model.primaries.max: must be >=",
        "particles[0].model.min_primaries: must be >= 30",
        "particles[0].model.attraction.force: must be > 0",
        "particles[0].model.attraction.exponent: must be > 1",
        "particles[0].model.attraction.cutoff: must be at least the smallest primary's diameter",
        "particles[0].model.friction: must be >= 0",
        "method: particles[0] are bonded_primaries aggregates, which run by contact dynamics (as Nezamabadi 2020 ran them) or by DEM",
    ] {
        assert!(r.iter().any(|x| x.starts_with(want)), "missing '{want}' in {r:#?}");
    }
    // By DEM, the primaries touch by their material's law: its friction (0.3) must be the
    // bond's (0 by default), and its k_n (1e6 N/m) must hold F_0 = 100 N/m at 1% of the
    // smallest primary (7e-7 m): 1.43e8 N/m at least.
    let model = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
    let r = rules(&aggregate_scene(serde_json::json!("dem"), model, false));
    for want in [
        "particles[0].model.friction: with method dem the primaries of one aggregate touch by their material's contact law: must equal materials.primary.friction (0.3), got 0",
        "materials.primary.contact: with method dem the primaries are rigid",
    ] {
        assert!(r.iter().any(|x| x.starts_with(want)), "missing '{want}' in {r:#?}");
    }
    assert!(r.iter().any(|x| x.contains("k_n >= 1.429e8")), "{r:#?}");
    assert!(!r.iter().any(|x| x.starts_with("method:")), "{r:#?}");
    // The same rules for the aggregates a saved state holds: two primaries of 0.1 and
    // 0.12 mm bonded by F_0 = 100 N/m need k_n >= 100 / 1e-6 = 1e8 N/m.
    let state = serde_json::json!({
        "format": "sable-state", "version": 1, "dimension": 2, "min": [0.0, 0.0], "max": [1e-3, 1e-3],
        "materials": ["primary"],
        "particles": {
            "material": [0, 0], "radius": [5e-5, 6e-5], "position": [[4e-4, 5e-4], [5.1e-4, 5e-4]],
            "velocity": [[0.0, 0.0], [0.0, 0.0]], "angular_velocity": [[0.0], [0.0]], "aggregate": [0, 0]
        },
        "bondings": [{"force": 100.0, "exponent": 7.0, "cutoff": 1.3e-4, "friction": 0.0}]
    });
    let saved = |k_n: f64, friction: f64| {
        rules(
            &serde_json::json!({
                "dimension": 2, "method": "dem",
                "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.2, "friction": friction}},
                "start_from": {"state": state}, "container": {"wall_material": "primary"}, "stop": {"steps": 10}
            })
            .to_string(),
        )
    };
    assert!(saved(1.1e8, 0.0).is_empty(), "{:#?}", saved(1.1e8, 0.0));
    let r = saved(1e6, 0.3);
    assert!(r.iter().any(|x| x.starts_with("start_from.state.bondings[0].friction: with method dem")), "{r:#?}");
    assert!(r.iter().any(|x| x.starts_with("materials.primary.contact: with method dem") && x.contains("k_n >= 1.000e8")), "{r:#?}");
    // Grains too small for their primaries.
    let small = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "monodisperse", "diameter": 2e-4}, "attraction": {"force": 100.0}});
    let r = rules(&aggregate_scene(serde_json::json!("cd"), small, false));
    assert!(
        r.iter().any(|x| x.starts_with("particles[0].model.primaries: the smallest grain (0.0018 m) holds about 56 primaries")),
        "{r:#?}"
    );
    // Periodic along x: the period (0.01 m) must exceed twice the largest grain.
    let wide = serde_json::json!({"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}});
    assert!(!rules(&aggregate_scene(serde_json::json!("cd"), wide.clone(), true)).iter().any(|x| x.starts_with("container.max")));
    let big = aggregate_scene(serde_json::json!("cd"), wide, true).replace("0.0018", "0.0051");
    let r = rules(&big);
    assert!(r.iter().any(|x| x.starts_with("container.max[0]: the period along x (0.01 m) must exceed twice the largest grain")), "{r:#?}");
    // In 3D the estimate is 0.39 × D³/⟨d³⟩: a grain of 0.9 mm holds about 260 of the
    // sources' primaries (⟨d³⟩ 1.09e-12 m³), one of 0.5 mm about 44, fewer than 200.
    let in_3d = |diameter: f64| {
        serde_json::json!({
            "dimension": 3, "method": "dem",
            "materials": {"primary": {"density": 2000, "contact": {"law": "linear", "k_n": 3e4}, "restitution": 0.2, "friction": 0.0}},
            "particles": [{"material": "primary", "size": {"kind": "monodisperse", "diameter": diameter},
                "placement": {"kind": "list", "positions": [[1e-3, 1e-3, 1e-3]]},
                "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7e-5, "max": 1.3e-4}, "attraction": {"force": 0.01}}}],
            "container": {"min": [0.0, 0.0, 0.0], "max": [2e-3, 2e-3, 2e-3], "wall_material": "primary"},
            "stop": {"steps": 10}
        })
        .to_string()
    };
    assert_eq!(plan_scene(&in_3d(0.9e-3)).map(|s| s.particle_count()), Ok(260));
    let r = rules(&in_3d(0.5e-3));
    assert!(
        r.iter().any(|x| x.starts_with("particles[0].model.primaries: the smallest grain (0.0005 m) holds about 44 primaries")),
        "{r:#?}"
    );
    // The method name `bpm` points to the model.
    let r = rules(&scene_with(serde_json::json!("bpm"), 0.5));
    assert!(r.iter().any(|x| x.starts_with("method: the bonded particle method is a model of the grains")), "{r:#?}");
}

#[test]
fn contact_dynamics_parameters_are_checked_by_path_and_rule() {
    let ok = plan_scene(&scene_with(serde_json::json!({"kind": "cd", "time_step": 1e-4, "theta": 0.6, "tolerance": 1e-6}), 0.5));
    let ok = ok.expect("valid");
    let p = ok.params::<CdParams>().expect("cd");
    assert_eq!((p.time_step, p.theta, p.tolerance, p.max_iterations), (Some(1e-4), 0.6, 1e-6, CdParams::default().max_iterations));
    let bad = rules(&scene_with(
        serde_json::json!({"kind": "cd", "theta": 0.3, "max_iterations": 0, "loading_violation_tolerance": 0.5, "relaxation": 1.5, "acceleration": 1.0, "time_step": 1e-4, "max_displacement": 0.1}),
        0.5,
    ));
    assert_eq!(
        bad,
        vec![
            "method.max_displacement: give either time_step or max_displacement, not both",
            "method.theta: must be between 0.5 and 1, got 0.3",
            "method.max_iterations: must be between 1 and 1000000, got 0",
            "method.loading_violation_tolerance: must be between 0.00000000000001 and 0.1, got 0.5",
            "method.relaxation: must be in (0, 1], got 1.5",
            "method.acceleration: must be in [0, 1), got 1",
        ]
    );
    let slop = rules(&scene_with(serde_json::json!({"kind": "cd", "slop": 0.05}), 0.5));
    assert_eq!(slop, vec!["method.slop: must be below method.max_interpenetration (0.05), got 0.05"]);
    match plan_scene(&scene_with(serde_json::json!({"kind": "cd", "slop": 0.02}), 0.5)).map(|s| s.params::<CdParams>().cloned()) {
        Ok(Some(p)) => assert_eq!(p.slop, 0.02),
        other => panic!("{other:?}"),
    }
    let unknown = rules(&scene_with(serde_json::json!({"kind": "cd", "skn": 0.1}), 0.5));
    assert_eq!(unknown.len(), 1);
    assert!(unknown[0].starts_with("method.skn: unknown field"), "{unknown:?}");
    let sweep = rules(&scene_with(serde_json::json!({"kind": "cd", "sweep": "parallel"}), 0.5));
    assert_eq!(sweep.len(), 1);
    assert!(sweep[0].starts_with("method.sweep: unknown variant `parallel`, expected one of `auto`, `serial`, `coloured`"), "{sweep:?}");
    match plan_scene(&scene_with(serde_json::json!({"kind": "cd", "sweep": "coloured"}), 0.5)).map(|s| s.params::<CdParams>().cloned()) {
        Ok(Some(p)) => assert_eq!(p.sweep, Sweep::Coloured),
        other => panic!("{other:?}"),
    }
}

#[test]
fn zero_restitution_is_an_impact_law_for_contact_dynamics_only() {
    // Refused by the method auto chose, which the rule says.
    let auto = rules(&scene_with(serde_json::json!("auto"), 0.0));
    assert_eq!(auto.len(), 1, "{auto:?}");
    assert!(auto[0].starts_with("materials.glass.restitution: auto chose dem: must be > 0 with method dem"), "{auto:?}");
    assert!(rules(&scene_with(serde_json::json!("cd"), 0.0)).is_empty());
    assert_eq!(
        rules(&scene_with(serde_json::json!("dem"), 0.0)),
        vec!["materials.glass.restitution: must be > 0 with method dem (a perfectly plastic impact, 0, is method cd's), got 0"]
    );
    assert_eq!(rules(&scene_with(serde_json::json!("cd"), 1.5)), vec!["materials.glass.restitution: must be >= 0 and <= 1, got 1.5"]);
}

fn soft_scene(method: serde_json::Value, law: serde_json::Value, extra: serde_json::Value) -> String {
    let mut v = serde_json::json!({
        "dimension": 2,
        "method": method,
        "materials": {"rubber": {"density": 990, "friction": 0.5, "deformable": law}},
        "particles": [{"material": "rubber", "count": 4, "size": {"kind": "monodisperse", "diameter": 0.002}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "rubber"},
        "stop": {"steps": 10}
    });
    if let (Some(o), Some(e)) = (v.as_object_mut(), extra.as_object()) {
        for (k, x) in e {
            o.insert(k.clone(), x.clone());
        }
    }
    v.to_string()
}

#[test]
fn a_deformable_scene_parses_with_method_mpm() {
    let law = serde_json::json!({"law": "neo_hookean", "shear_modulus": 1.5e6, "lambda": 3e6});
    let scene =
        plan_scene(&soft_scene(serde_json::json!({"kind": "mpm", "cells_per_diameter": 5}), law, serde_json::json!({}))).expect("valid");
    let p = scene.params::<MpmParams>().expect("mpm");
    assert_eq!((p.cells_per_diameter, p.points_per_cell, p.solver.theta), (5.0, 2, 1.0));
    let m = &scene.materials[0];
    assert_eq!(m.deformable, Some(LawSpec::NeoHookean { shear_modulus: 1.5e6, lambda: 3e6 }));
    // The advisor's elastic constants: E = μ(3λ + 2μ)/(λ + μ), ν = λ / 2(λ + μ).
    assert_eq!(m.law, ElasticLaw::HertzMindlin { young: 1.5e6 * 12e6 / 4.5e6, poisson: 3e6 / 9e6 });
}

/// Every bad parameter of a deformable material and of method mpm named at once.
#[test]
fn bad_deformable_input_names_every_field() {
    let law = serde_json::json!({"law": "elastoplastic", "young_modulus": 0, "poisson_ratio": 0.5, "yield_stress": -1, "hardening": -2});
    let got = rules(&soft_scene(
        serde_json::json!({"kind": "mpm", "cells_per_diameter": 0.5, "points_per_cell": 1, "theta": 0.2, "max_newton": 0}),
        law,
        serde_json::json!({}),
    ));
    for want in [
        "materials.rubber.deformable.young_modulus: must be > 0",
        "materials.rubber.deformable.poisson_ratio: must be > -1 and < 0.5, got 0.5",
        "materials.rubber.deformable.yield_stress: must be > 0",
        "materials.rubber.deformable.hardening: must be >= 0",
        "method.cells_per_diameter: must be >= 1 (a grid cell larger than the smallest grain cannot tell its shape), got 0.5",
        "method.theta: must be",
        "method.max_newton: must be >= 1",
    ] {
        assert!(got.iter().any(|g| g.starts_with(want)), "missing {want:?} in {got:#?}");
    }
    let neo = rules(&soft_scene(
        serde_json::json!("mpm"),
        serde_json::json!({"law": "neo_hookean", "shear_modulus": -1, "lambda": -3}),
        serde_json::json!({}),
    ));
    assert!(neo.iter().any(|g| g.starts_with("materials.rubber.deformable.shear_modulus: must be > 0")), "{neo:?}");
    assert!(neo.iter().any(|g| g.starts_with("materials.rubber.deformable.lambda: must be >= 0")), "{neo:?}");
    let few = rules(&soft_scene(
        serde_json::json!({"kind": "mpm", "cells_per_diameter": 1, "points_per_cell": 1}),
        serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45}),
        serde_json::json!({}),
    ));
    assert!(few.iter().any(|g| g.starts_with("method.points_per_cell: gives 1 point(s) across the smallest grain")), "{few:?}");
}

/// `method.dynamics`: an unknown value named with the allowed ones; quasi-static steps refuse a
/// θ below 1 and a FLIP fraction (both carry velocities from step to step), where `auto` takes
/// the inertial steps a scene asking for them means.
#[test]
fn soft_dynamics_are_checked_and_auto_gives_way_to_a_theta_method() {
    let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.3});
    let check = |method: serde_json::Value| rules(&soft_scene(method, law.clone(), serde_json::json!({})));
    let bad = check(serde_json::json!({"kind": "mpm", "dynamics": "static"}));
    assert!(
        bad.iter().any(|g| g.starts_with("method.dynamics: unknown variant `static`, expected one of `auto`, `inertial`, `quasi_static`")),
        "{bad:?}"
    );
    let theta = check(serde_json::json!({"kind": "fem", "dynamics": "quasi_static", "theta": 0.5}));
    assert!(theta.iter().any(|g| g.starts_with("method.theta: quasi_static dynamics solves each step at its end")), "{theta:?}");
    let flip = check(serde_json::json!({"kind": "mpm", "dynamics": "quasi_static", "flip": 0.5}));
    assert!(flip.iter().any(|g| g.starts_with("method.flip: must be 0 with quasi_static dynamics")), "{flip:?}");
    let dynamics = |method: serde_json::Value| {
        let scene = plan_scene(&soft_scene(method, law.clone(), serde_json::json!({}))).expect("valid");
        scene.params::<MpmParams>().expect("mpm").solver.dynamics
    };
    use crate::methods::soft::params::Dynamics;
    assert_eq!(dynamics(serde_json::json!({"kind": "mpm"})), Dynamics::Auto);
    assert_eq!(dynamics(serde_json::json!({"kind": "mpm", "theta": 0.5})), Dynamics::Inertial);
    assert_eq!(dynamics(serde_json::json!({"kind": "mpm", "flip": 1.0})), Dynamics::Inertial);
    assert_eq!(dynamics(serde_json::json!({"kind": "mpm", "dynamics": "quasi_static"})), Dynamics::QuasiStatic);
}

/// Method `fem`: its own knob named with its rule, the knobs it shares with `mpm` under the
/// same names and rules, and the same fit rules named for `fem`; a sound scene passes.
#[test]
fn fem_params_and_fit_are_checked() {
    let law = serde_json::json!({"law": "neo_hookean", "shear_modulus": 1.5e5, "lambda": 1.5e7});
    let got = rules(&soft_scene(
        serde_json::json!({"kind": "fem", "elements_per_diameter": 1.5, "theta": 0.2, "max_newton": 0}),
        law.clone(),
        serde_json::json!({"dimension": 3, "container": {"min": [0, 0, 0], "max": [0.01, 0.01, 0.01], "wall_material": "rubber"}}),
    ));
    for want in [
        "method.elements_per_diameter: must be >= 2 (an element larger than half the smallest grain cannot tell its shape), got 1.5",
        "method.theta: must be",
        "method.max_newton: must be >= 1",
        "dimension: method fem is 2D",
    ] {
        assert!(got.iter().any(|g| g.starts_with(want)), "missing {want:?} in {got:#?}");
    }
    let grid = rules(&soft_scene(serde_json::json!({"kind": "fem", "points_per_cell": 2}), law.clone(), serde_json::json!({})));
    assert!(grid.iter().any(|g| g.starts_with("method.points_per_cell: unknown field")), "{grid:?}");
    let rigid = rules(&scene_with(serde_json::json!("fem"), 0.5));
    assert!(rigid.iter().any(|g| g.starts_with("particles[0].material: method fem needs deformable grains")), "{rigid:?}");
    let scene = plan_scene(&soft_scene(serde_json::json!({"kind": "fem", "elements_per_diameter": 6}), law.clone(), serde_json::json!({})))
        .expect("valid");
    let p = scene.params::<FemParams>().expect("fem");
    assert_eq!((p.elements_per_diameter, p.solver.theta, p.symmetric_contact), (6.0, 1.0, true));
    // Both grains' boundaries are held by default for fem, one side for mpm; each may be set.
    let sides = |method: serde_json::Value| {
        let plan = plan_scene(&soft_scene(method, law.clone(), serde_json::json!({}))).expect("valid");
        match (plan.params::<FemParams>(), plan.params::<MpmParams>()) {
            (Some(p), _) => p.symmetric_contact,
            (_, Some(p)) => p.symmetric_contact.expect("mpm given symmetric_contact"),
            _ => panic!("method {}", plan.method_name()),
        }
    };
    assert!(!sides(serde_json::json!({"kind": "fem", "symmetric_contact": false})));
    assert!(sides(serde_json::json!({"kind": "mpm", "symmetric_contact": true})));
    assert!(!sides(serde_json::json!({"kind": "mpm", "symmetric_contact": false})));
    // mpm left to choose: it decides by the grains' law when it is built.
    let plan = plan_scene(&soft_scene(serde_json::json!({"kind": "mpm"}), law.clone(), serde_json::json!({}))).expect("valid");
    assert_eq!(plan.params::<MpmParams>().map(|p| p.symmetric_contact), Some(None));
    let bad = rules(&soft_scene(serde_json::json!({"kind": "mpm", "symmetric_contact": 1}), law, serde_json::json!({})));
    assert!(bad.iter().any(|g| g.starts_with("method.symmetric_contact: invalid type: integer `1`, expected a boolean")), "{bad:?}");
}

/// Deformable grains need mpm, mpm needs deformable grains in a 2D box with walls; a contact
/// law or restitution on a deformable material is refused.
#[test]
fn deformable_grains_and_methods_must_fit() {
    let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
    let dem = rules(&soft_scene(serde_json::json!("dem"), law.clone(), serde_json::json!({})));
    assert_eq!(
        dem,
        vec!["particles[0].material: 'rubber' is deformable: its grains need method mpm or fem (method dem moves rigid grains)"]
    );
    let periodic = rules(&soft_scene(
        serde_json::json!("mpm"),
        law.clone(),
        serde_json::json!({"container": {"min": [0, 0], "max": [0.01, 0.01], "periodic": ["x"], "wall_material": "rubber"}, "dimension": 3}),
    ));
    assert!(periodic.iter().any(|g| g.starts_with("container.periodic: not with method mpm")), "{periodic:?}");
    assert!(periodic.iter().any(|g| g.starts_with("dimension: method mpm is 2D")), "{periodic:?}");
    let mut both: serde_json::Value =
        serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law, serde_json::json!({}))).expect("json");
    both["materials"]["rubber"]["restitution"] = serde_json::json!(0.5);
    both["materials"]["rubber"]["contact"] = serde_json::json!({"law": "linear", "k_n": 1e5});
    let got = rules(&both.to_string());
    assert!(got.iter().any(|g| g.starts_with("materials.rubber.contact: not for a deformable material")), "{got:?}");
    assert!(got.iter().any(|g| g.starts_with("materials.rubber.restitution: not for a deformable material")), "{got:?}");
    let rigid = rules(&scene_with(serde_json::json!("mpm"), 0.5));
    assert!(rigid.iter().any(|g| g.starts_with("particles[0].material: method mpm needs deformable grains")), "{rigid:?}");
    let mut missing: serde_json::Value = serde_json::from_str(&scene_with(serde_json::json!("dem"), 0.5)).expect("json");
    let glass = missing["materials"]["glass"].as_object_mut().expect("object");
    glass.remove("contact");
    glass.remove("restitution");
    let got = rules(&missing.to_string());
    assert!(
        got.contains(&"materials.glass.contact: required (the elastic contact law), unless the material is deformable".to_string()),
        "{got:?}"
    );
    assert!(got.contains(&"materials.glass.restitution: required, unless the material is deformable".to_string()), "{got:?}");
}

/// Stress walls with `mpm` need the speed that sets the step; the experiments it cannot run
/// are named; those it can run pass.
#[test]
fn mpm_takes_stress_walls_and_its_experiments() {
    let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
    let box_with = |walls: serde_json::Value| serde_json::json!({"container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "rubber", "walls": walls}});
    let unbounded = rules(&soft_scene(
        serde_json::json!("mpm"),
        law.clone(),
        box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4}})),
    ));
    assert_eq!(
        unbounded,
        vec!["container.walls.y_max.max_speed: required with method mpm (unless method.time_step is given): the fastest wall sets the time step"]
    );
    let bounded = box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4, "max_speed": 0.1}}));
    assert!(plan_scene(&soft_scene(serde_json::json!("mpm"), law.clone(), bounded)).is_ok());
    let stepped = serde_json::json!({"kind": "mpm", "time_step": 1e-4});
    let unbounded = box_with(serde_json::json!({"y_max": {"kind": "stress", "stress": 1e4}}));
    assert!(plan_scene(&soft_scene(stepped, law.clone(), unbounded)).is_ok());
    let mut drum: serde_json::Value =
        serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law.clone(), serde_json::json!({}))).expect("json");
    drum.as_object_mut().expect("object").remove("stop");
    drum["experiment"] = serde_json::json!({"kind": "deposition"});
    let got = rules(&drum.to_string());
    assert!(got.iter().any(|g| g.starts_with("experiment.kind: the deposition experiment is not available with method mpm")), "{got:?}");
    let mut biaxial: serde_json::Value =
        serde_json::from_str(&soft_scene(serde_json::json!("mpm"), law, serde_json::json!({}))).expect("json");
    biaxial.as_object_mut().expect("object").remove("stop");
    biaxial["experiment"] =
        serde_json::json!({"kind": "biaxial", "preparation": {"pressure": 1e4}, "strain_rate": 1.0, "axial_strain": 0.05});
    assert!(plan_scene(&biaxial.to_string()).is_ok(), "{:?}", rules(&biaxial.to_string()));
}

/// `auto` takes the material point method for deformable grains, and says why.
#[test]
fn auto_takes_mpm_for_deformable_grains() {
    let law = serde_json::json!({"law": "linear_elastic", "young_modulus": 1e7, "poisson_ratio": 0.45});
    let scene = plan_scene(&soft_scene(serde_json::json!("auto"), law, serde_json::json!({}))).expect("valid");
    assert_eq!(scene.method_name(), "mpm");
    assert!(scene.reason.starts_with("auto chose mpm: deformable grains (materials.rubber.deformable)"), "{}", scene.reason);
}
