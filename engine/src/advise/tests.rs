//! The advisor's choices, reasons, dropped terms and numbers on hand-made scenes.

use super::*;

fn scene(extra: serde_json::Value) -> Scene {
    let mut s = serde_json::json!({
        "dimension": 2, "method": "auto",
        "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e7}, "restitution": 0.5, "friction": 0.3}},
        "particles": [{"material": "glass", "count": 40, "size": {"kind": "uniform", "min": 0.0009, "max": 0.0011}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
        "stop": {"steps": 10}
    });
    merge(&mut s, extra);
    crate::scene::parse_scene(&s.to_string()).expect("valid scene")
}

fn merge(a: &mut serde_json::Value, b: serde_json::Value) {
    match (a, b) {
        (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
            for (k, v) in b {
                merge(a.entry(k).or_insert(serde_json::Value::Null), v);
            }
        }
        (serde_json::Value::Array(a), serde_json::Value::Array(b)) if a.len() == b.len() => {
            for (x, y) in a.iter_mut().zip(b) {
                merge(x, y);
            }
        }
        (a, b) => *a = b,
    }
}

fn has(list: &[String], needle: &str) -> bool {
    list.iter().any(|x| x.contains(needle))
}

/// A biaxial test at `pressure` (Pa) and `rate` (1/s) of grains with stiffness `k_n`.
fn biaxial(k_n: f64, pressure: f64, rate: f64) -> Scene {
    scene(serde_json::json!({
        "materials": {"glass": {"contact": {"k_n": k_n}}},
        "experiment": {"kind": "biaxial", "preparation": {"pressure": pressure}, "strain_rate": rate, "axial_strain": 0.05}
    }))
}

#[test]
fn the_advisor_chooses_the_lightest_adequate_model_and_says_why() {
    // Rigid grains (κ = 1e5), slow loading (I = 1.6e-5): contact dynamics.
    let a = advise(&biaxial(1e8, 1000.0, 0.01));
    assert_eq!((a.method.as_str(), a.regime), ("cd", Regime::QuasiStatic), "{a:?}");
    assert!(has(&a.reasons, "quasi-static loading: I = 1.6e-5") && has(&a.reasons, "rigid grains: κ = 1.0e5"), "{:?}", a.reasons);
    // The same test with soft contacts (κ = 100): DEM, because of the stiffness.
    let a = advise(&biaxial(1e5, 1000.0, 0.01));
    assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::QuasiStatic));
    assert!(has(&a.reasons, "moderately soft grains: κ = 1.0e2"), "{:?}", a.reasons);
    assert_eq!(a.needs, None);
    // Contacts deflected by a tenth of a diameter: the grains deform.
    let a = advise(&biaxial(1e4, 1000.0, 0.01));
    assert!(a.needs.as_deref().is_some_and(|n| n.contains("deformable` constitutive law") && n.contains("method mpm")), "{a:?}");
    assert!(has(&a.reasons, "the grains deform: contact deflection ~ 1/κ = 0.10"), "{:?}", a.reasons);
    assert_eq!(a.method, "dem");
    // Rigid grains loaded fast (I = 0.016): a dense inertial flow, DEM.
    let a = advise(&biaxial(1e8, 1000.0, 10.0));
    assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::DenseFlow));
    assert!(has(&a.reasons, "dense inertial flow: I = 1.6e-2"), "{:?}", a.reasons);
    // A dilute gas falling under gravity: collisional, DEM, whatever the stiffness.
    let a = advise(&scene(serde_json::json!({"materials": {"glass": {"contact": {"k_n": 1e9}}}, "gravity": [0, -9.81]})));
    assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::Collisional));
    assert!(has(&a.reasons, "collisional: the grains start as a gas (Φ = 0.32) and fall under gravity"), "{:?}", a.reasons);
    // A wall driven at an imposed speed into a closed box: rigid grains jam, DEM.
    let a = advise(&scene(serde_json::json!({
        "materials": {"glass": {"contact": {"k_n": 1e9}}},
        "experiment": {"kind": "compaction", "velocity": 0.02, "strain": 0.5}
    })));
    assert_eq!((a.method.as_str(), a.regime), ("dem", Regime::KinematicSqueeze));
}

#[test]
fn the_advice_lists_the_terms_a_scene_does_not_need() {
    // Frictionless and dry, in 2D: no tangential history or spins, no liquid, no third axis.
    let a = advise(&scene(serde_json::json!({"materials": {"glass": {"friction": 0.0}}})));
    assert!(
        has(&a.dropped, "tangential forces and their spring history") && has(&a.dropped, "spins stay as they start"),
        "{:?}",
        a.dropped
    );
    assert!(has(&a.dropped, "capillary bridges and lubrication (a dry scene)"));
    assert!(has(&a.dropped, "the third dimension"));
    // Frictional and wet: tangential forces and bridges kept; the cohesion index and the
    // Stokes number computed (f_c = 2π γ R = 2.29e-4 N against p d = 1 N/m in 2D).
    let wet = scene(serde_json::json!({
        "materials": {"glass": {"liquid": {"surface_tension": 0.0728, "contact_angle": 0.0, "bridge_volume": 1e-12, "viscosity": 0.001, "roughness": 1e-5}}},
        "particles": [{"wet_fraction": 1.0}],
        "experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}
    }));
    let a = advise(&wet);
    assert!(!has(&a.dropped, "tangential") && !has(&a.dropped, "capillary"), "{:?}", a.dropped);
    let xi = 2.0 * std::f64::consts::PI * 0.0728 * 0.0005 / (1000.0 * 0.001);
    assert!((a.numbers.cohesion_index.unwrap_or(0.0) - xi).abs() < 1e-9 * xi, "{:?}", a.numbers);
    let st = 2500.0 * 1e-6 * 0.01 / 0.001;
    assert!((a.numbers.stokes_number.unwrap_or(0.0) - st).abs() < 1e-9 * st);
    // Spheres in a box one grain thick along z: the advice says the scene is plane.
    let flat = scene(serde_json::json!({
        "dimension": 3,
        "container": {"min": [0, 0, 0], "max": [0.01, 0.01, 0.0015]},
        "gravity": [0, -9.81, 0]
    }));
    let a = advise(&flat);
    assert!(has(&a.suggestions, "less than two grains thick along z"), "{:?}", a.suggestions);
    assert!(!has(&a.dropped, "third dimension"));
}

#[test]
fn auto_takes_the_advisors_method_and_records_why() {
    let rigid = |method: serde_json::Value| {
        let mut s = serde_json::json!({
            "dimension": 2, "method": method,
            "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e8}, "restitution": 0.5, "friction": 0.3}},
            "particles": [{"material": "glass", "count": 40, "size": {"kind": "monodisperse", "diameter": 0.001}, "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
            "experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}
        });
        s["seed"] = 1.into();
        crate::methods::plan_scene(&s.to_string())
    };
    let s = rigid("auto".into()).expect("valid");
    assert_eq!(s.method_name(), "cd");
    assert!(s.reason.starts_with("auto chose cd: quasi-static loading"), "{}", s.reason);
    assert!(s.reason.contains("left out: capillary bridges"), "{}", s.reason);
    assert_eq!(s.advice.as_ref().map(|a| a.requested.as_str()), Some("auto"));
    // A scene that names its method keeps it; the advice says what auto would take.
    let named = rigid("dem".into()).expect("valid");
    assert!(named.method_name() == "dem" && named.advice.is_none());
    let a = named.advice();
    assert_eq!((a.requested.as_str(), a.method.as_str()), ("dem", "cd"));
    // auto sets the parameters itself.
    let v = rigid(serde_json::json!({"kind": "auto", "time_step": 1e-5})).expect_err("rejected");
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].field, "method.time_step");
    assert!(v[0].rule.starts_with("auto chooses the method and its parameters"), "{}", v[0].rule);
}

#[test]
fn the_numbers_of_a_biaxial_test_are_those_of_its_definition() {
    let s = scene(
        serde_json::json!({"experiment": {"kind": "biaxial", "preparation": {"pressure": 1000.0}, "strain_rate": 0.01, "axial_strain": 0.05}}),
    );
    let a = advise(&s);
    let n = &a.numbers;
    assert!((n.mean_diameter - 0.001).abs() < 1e-12);
    assert_eq!(n.pressure, Some(1000.0));
    assert_eq!(n.strain_rate, Some(0.01));
    let i = 0.01 * 0.001 * (2500.0f64 / 1000.0).sqrt();
    assert!((n.inertial_number.unwrap_or(0.0) - i).abs() < 1e-15, "{:?}", n.inertial_number);
    assert_eq!(n.stiffness_number, Some(1e7 / 1000.0));
    assert_eq!(a.regime, Regime::QuasiStatic);
    assert_eq!(a.method, "cd", "{a:?}");
}

/// `auto` learns from a stored study: the cheapest run within a percent of the reference
/// wins, whatever its method; runs without an error or beyond a percent never do. The
/// reason gives each other method's cheapest run within a percent, on the Pareto front or
/// not (cd's here is beaten by fem's on both counts).
#[test]
fn the_cheapest_run_within_a_percent_sets_the_method() {
    let run = |job_id: i64, method: &str, cpu_seconds: Real, error: Option<Real>| ExpectedCost {
        study_id: 4,
        job_id,
        series: method.to_uppercase(),
        label: format!("run {job_id}"),
        method: method.into(),
        cpu_seconds,
        wall_seconds: cpu_seconds,
        error,
        pareto: false,
    };
    let mut a = advise(&scene(serde_json::json!({})));
    let before = a.method.clone();
    a.expected_cost = vec![
        run(1, "mpm", 11.0, Some(0.03)),
        run(2, "mpm", 76.0, Some(0.004)),
        run(3, "fem", 40.0, Some(0.008)),
        run(4, "fem", 5.0, None),
        run(5, "cd", 90.0, Some(0.009)),
        run(6, "dem", 2.0, Some(0.2)),
    ];
    assert_eq!(a.cheapest_within(0.01).map(|c| c.job_id), Some(3));
    assert_eq!(a.cheapest_within(0.05).map(|c| c.job_id), Some(1));
    assert_eq!(a.cheapest_within(0.001), None);
    let taken = a.learn().expect("a run within a percent");
    assert_eq!((taken.job_id, a.method.as_str()), (3, "fem"));
    assert!(a.reasons[0].starts_with("study 4 measured fem (FEM run 3) within 0.80% of its reference in 40.0 s"), "{}", a.reasons[0]);
    assert!(a.reasons[0].ends_with("(cd needed 90.0 s, no dem run was that close, mpm needed 76.0 s)"), "{}", a.reasons[0]);
    let mut b = advise(&scene(serde_json::json!({})));
    b.expected_cost = vec![run(1, "mpm", 11.0, Some(0.03))];
    assert_eq!((b.learn(), b.method), (None, before));
}

/// Soft grains drop their inertia under a slow squeeze (the shipped disk between plates, Mach
/// 1.6e-4) and keep it when they may fall across the box or when the plate moves at a tenth of
/// the shear wave; a scene without deformable grains has no waves to weigh.
#[test]
fn soft_grains_are_stepped_quasi_statically_only_under_a_slow_loading() {
    let disk = |extra: serde_json::Value| {
        let mut s: serde_json::Value =
            serde_json::from_str(include_str!("../../../scenes/disk_between_plates_fem_2d.json")).expect("shipped scene");
        merge(&mut s, extra);
        crate::scene::parse_scene(&s.to_string()).expect("valid scene")
    };
    let slow = disk(serde_json::json!({}));
    let why = soft_inertia(&slow).expect("quasi-static");
    assert!(why.contains("1.6e-4 of the slowest shear wave"), "{why}");
    let a = advise(&slow);
    assert!(has(&a.dropped, "the grains' inertia"), "{:?}", a.dropped);
    // Free fall across the box's largest side, 2 cm: sqrt(2 g 0.02) = 0.63 m/s, 1.0e-2 of the wave.
    let falling = disk(serde_json::json!({"gravity": [0.0, -9.81]}));
    assert!(soft_inertia(&falling).is_err());
    let fast = disk(serde_json::json!({"container": {"walls": {"y_max": {"kind": "velocity", "velocity": [0.0, -6.3]}}}}));
    let why = soft_inertia(&fast).expect_err("inertial");
    assert!(why.contains("1.0e-1 of the slowest shear wave"), "{why}");
    assert!(has(&advise(&fast).reasons, "the grains' inertia is kept"));
    let rigid = scene(serde_json::json!({}));
    assert_eq!(soft_inertia(&rigid), Err("no deformable material".to_string()));
}
