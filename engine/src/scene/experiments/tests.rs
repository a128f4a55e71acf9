//! The experiments' checks and stages on hand-made scenes: defaults, stages and the violations
//! of broken sections.

use crate::scene::{parse_scene, Experiment, WallMotion};
use serde_json::{json, Value};

fn scene(dim: usize, periodic: bool, experiment: Value) -> Value {
    let v = |x: f64| if dim == 2 { json!([x, x]) } else { json!([x, x, x]) };
    let mut s = json!({
        "dimension": dim,
        "method": "dem",
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.5}},
        "particles": [{"material": "m", "count": 50, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": v(0.0), "max": v(0.02), "wall_material": "m"},
        "experiment": experiment
    });
    if periodic {
        s["container"]["periodic"] = if dim == 2 { json!(["x", "y"]) } else { json!(["x", "y", "z"]) };
    }
    s
}

fn violations(s: &Value) -> Vec<String> {
    match parse_scene(&s.to_string()) {
        Ok(_) => Vec::new(),
        Err(v) => v.iter().map(|x| x.to_string()).collect(),
    }
}

#[test]
fn biaxial_expands_into_preparation_and_loading() {
    let s = scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}, "strain_rate": 0.2, "axial_strain": 0.1}));
    let scene = parse_scene(&s.to_string()).expect("valid");
    assert_eq!(scene.stages.len(), 2);
    let (prep, load) = (&scene.stages[0], &scene.stages[1]);
    assert_eq!((prep.name.as_str(), load.name.as_str()), ("preparation", "loading"));
    // Preparation: all four walls servo to 100 Pa, frictionless, damped, until equilibrium.
    assert_eq!(prep.controls.walls.len(), 4);
    assert!(prep.controls.walls.iter().all(|w| matches!(w.motion, WallMotion::Stress { stress, .. } if stress == 100.0)));
    assert_eq!(prep.controls.friction, Some(0.0));
    assert!(prep.equilibrium.is_some());
    // Loading: y_max at -0.2 1/s, y_min fixed, x walls at 100 Pa; friction back to the material's.
    for w in &load.controls.walls {
        let expected = match (w.face.axis, w.face.upper) {
            (1, true) => WallMotion::StrainRate(-0.2),
            (1, false) => WallMotion::Fixed,
            _ => WallMotion::Stress { stress: 100.0, gain: None, max_speed: f64::INFINITY, integral: true },
        };
        assert_eq!(w.motion, expected, "{}", w.face.name());
    }
    assert_eq!(load.controls.friction, None);
    assert_eq!((load.until.strain, load.strain_axis), (Some(0.1), Some(1)));
    assert!(matches!(scene.experiment, Some(Experiment::Triaxial { axis: 1, .. })));
}

#[test]
fn isotropic_in_a_periodic_box_uses_the_cell_servo() {
    let s = scene(3, true, json!({"kind": "isotropic", "preparation": {"pressure": 1000.0, "max_strain_rate": 5.0}}));
    let scene = parse_scene(&s.to_string()).expect("valid");
    let prep = &scene.stages[0];
    assert!(prep.controls.walls.is_empty());
    assert!(matches!(prep.controls.deformation, Some(Some(crate::scene::Deformation::Pressure { target, max_strain_rate, .. }))
        if target == 1000.0 && max_strain_rate == 5.0));
}

#[test]
fn plane_shear_prepares_then_shears_under_a_normal_stress_servo() {
    let s = scene(2, true, json!({"kind": "plane_shear", "preparation": {"pressure": 2500.0}, "inertial_number": 0.02, "strain": 2.0}));
    let parsed = parse_scene(&s.to_string()).expect("valid");
    let shear = &parsed.stages[1];
    assert_eq!(shear.name, "shear");
    // sqrt(p / rho) = 1 m/s, d = 1 mm: rate = 0.02 / 1e-3 = 20 1/s.
    assert!((shear.controls.shear_rate.expect("rate") - 20.0).abs() < 1e-9);
    assert!(
        matches!(shear.controls.deformation, Some(Some(crate::scene::Deformation::NormalStress { axis: 1, target, .. })) if target == 2500.0)
    );
    assert_eq!(shear.until.strain, Some(2.0));
    let v = violations(&scene(2, false, json!({"kind": "plane_shear", "preparation": {"pressure": 1.0}})));
    assert!(v.iter().any(|x| x.starts_with("container.periodic: the plane_shear experiment needs a fully periodic box")), "{v:?}");
    let v = violations(&scene(
        2,
        true,
        json!({"kind": "plane_shear", "preparation": {"pressure": 1.0}, "shear_rate": 1.0, "inertial_number": 0.1}),
    ));
    assert!(v.iter().any(|x| x.starts_with("experiment: give shear_rate or inertial_number, not both")), "{v:?}");
}

#[test]
fn drum_settles_then_turns_at_the_froude_number() {
    let mut s = scene(2, false, json!({"kind": "drum", "froude": 0.01, "revolutions": 2.0}));
    s["gravity"] = json!([0.0, -9.81]);
    let parsed = parse_scene(&s.to_string()).expect("valid");
    let (filling, rotation) = (&parsed.stages[0], &parsed.stages[1]);
    assert_eq!((filling.name.as_str(), rotation.name.as_str()), ("filling", "rotation"));
    assert_eq!(filling.controls.drum_angular_velocity, Some(0.0));
    assert!(filling.equilibrium.is_some());
    // R = 10 mm: ω = sqrt(Fr g / R) = sqrt(9.81) rad/s; two turns.
    let w = rotation.controls.drum_angular_velocity.expect("turns");
    assert!((w - 9.81f64.sqrt()).abs() < 1e-12);
    let t = rotation.until.time.expect("time");
    assert!((t - 2.0 * 2.0 * std::f64::consts::PI / w).abs() < 1e-12);
    let drum = parsed.container.drum.expect("a drum in the container");
    assert_eq!((drum.axis, drum.radius), (2, 0.01));
    assert!((drum.center - crate::math::Vec3::new(0.01, 0.01, 0.0)).norm() < 1e-15);
    let Some(Experiment::Drum { transient, .. }) = parsed.experiment else { panic!("drum") };
    assert_eq!((transient, drum.down), (0.25, crate::math::Vec3::new(0.0, -1.0, 0.0)));

    let with = |dim: usize, e: Value, gravity: Value, edit: &dyn Fn(&mut Value)| {
        let mut s = scene(dim, false, e);
        s["gravity"] = gravity;
        edit(&mut s);
        violations(&s)
    };
    let g2 = json!([0.0, -9.81]);
    let cases: Vec<(Vec<String>, &str)> = vec![
        (with(2, json!({"kind": "drum"}), json!([0.0, 0.0]), &|_| {}), "gravity: required by the drum experiment"),
        (
            with(3, json!({"kind": "drum", "axis": "y"}), json!([0.0, -9.81, 0.0]), &|_| {}),
            "gravity: must be perpendicular to the drum's axis y",
        ),
        (
            with(2, json!({"kind": "drum", "froude": 0.1, "angular_velocity": 1.0}), g2.clone(), &|_| {}),
            "experiment: give froude or angular_velocity, not both",
        ),
        (
            with(2, json!({"kind": "drum", "revolutions": 1.0, "transient": 1.0}), g2.clone(), &|_| {}),
            "experiment.transient: must be in [0, revolutions = 1)",
        ),
        (with(2, json!({"kind": "drum", "axis": "x"}), g2.clone(), &|_| {}), "experiment.axis: only in 3D"),
        (
            with(2, json!({"kind": "drum"}), g2.clone(), &|s| s["container"]["max"] = json!([0.02, 0.03])),
            "container.max: the drum is inscribed in the box: its x and y lengths must be equal",
        ),
        (
            with(3, json!({"kind": "drum"}), json!([0.0, -9.81, 0.0]), &|s| s["container"]["periodic"] = json!(["x", "z"])),
            "container.periodic: x crosses the drum and must not be periodic",
        ),
    ];
    for (v, expected) in cases {
        assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
    }
    // The fill sets the count of the one set: fill × Φ_bed × π R² / (π <d>²/4) in 2D.
    let mut s = scene(2, false, json!({"kind": "drum", "fill": 0.4}));
    s["gravity"] = json!([0.0, -9.81]);
    s["particles"][0].as_object_mut().expect("set").remove("count");
    let parsed = parse_scene(&s.to_string()).expect("valid");
    assert_eq!(parsed.sets[0].count, (0.4_f64 * 0.82 * 400.0).round() as usize);
    s["particles"][0]["count"] = json!(50);
    assert!(violations(&s).iter().any(|x| x.starts_with("experiment.fill: give particles[0].count or experiment.fill, not both")));
    s["experiment"]["fill"] = json!(1.5);
    assert!(violations(&s).iter().any(|x| x.starts_with("experiment.fill: must be in (0, 1)")));
    // In 3D the axis may be periodic (an endless drum).
    let v = with(3, json!({"kind": "drum"}), json!([0.0, -9.81, 0.0]), &|s| s["container"]["periodic"] = json!(["z"]));
    assert!(v.is_empty(), "{v:?}");
}

#[test]
fn plane_shear_between_rough_walls_glues_then_slides_the_upper_wall() {
    let mut s =
        scene(2, false, json!({"kind": "plane_shear", "boundary": "rough_walls", "preparation": {"pressure": 2500.0}, "strain": 2.0}));
    s["container"]["periodic"] = json!(["x"]);
    let parsed = parse_scene(&s.to_string()).expect("valid");
    let (prep, shear) = (&parsed.stages[0], &parsed.stages[1]);
    // The y walls compress the sample; then grains within half a diameter are glued and
    // y_max shears the gap at 10 1/s (I = 1e-2) for a strain of 2 (0.2 s).
    assert_eq!(prep.controls.walls.len(), 2);
    assert_eq!(shear.controls.glue, Some(super::ROUGH_LAYER));
    for w in &shear.controls.walls {
        let expected = if w.face.upper {
            WallMotion::Shearing { stress: 2500.0, shear_rate: 10.0, flow: 0, max_speed: f64::INFINITY }
        } else {
            WallMotion::Fixed
        };
        assert_eq!(w.motion, expected);
    }
    assert!((shear.until.time.expect("time") - 0.2).abs() < 1e-12);
    let mut bad = s.clone();
    bad["container"]["periodic"] = json!(["y"]);
    assert!(violations(&bad).iter().any(|x| x.starts_with("container.periodic: plane shear between rough walls needs walls on y only")));
    bad["experiment"]["boundary"] = json!("smooth");
    assert!(violations(&bad).iter().any(|x| x.starts_with("experiment.boundary: must be lees_edwards or rough_walls")));
}

#[test]
fn granule_forms_relaxes_then_is_squeezed() {
    let mut s = scene(3, false, json!({"kind": "granule_compression", "radius": 0.004, "strain": 0.25}));
    s["materials"]["m"]["liquid"] = json!({"surface_tension": 0.0728, "contact_angle": 0.0, "bridge_volume": 1e-12});
    s["particles"][0]["wet_fraction"] = json!(1.0);
    let parsed = parse_scene(&s.to_string()).expect("valid");
    let names: Vec<&str> = parsed.stages.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["forming", "relaxation", "compression"]);
    // f_c = 2π γ <d>/2; the field is f_c over a mean grain's mass, then off.
    let f_c = 2.0 * std::f64::consts::PI * 0.0728 * 0.5e-3;
    let m = 2500.0 * std::f64::consts::PI / 6.0 * 1e-9;
    let a = parsed.stages[0].controls.centripetal.expect("field");
    assert!((a - f_c / m).abs() < 1e-9 * a);
    assert_eq!(parsed.stages[1].controls.centripetal, Some(0.0));
    let squeeze = &parsed.stages[2];
    assert_eq!((squeeze.controls.close_walls, squeeze.strain_axis, squeeze.until.strain), (Some(2), Some(2), Some(0.25)));
    // Default rate: I = 1e-3 at σ_c = f_c / d²: ε̇ = 1e-3 / d × sqrt(σ_c / ρ); half each plate.
    let rate = 1e-3 / 1e-3 * (f_c / 1e-6 / 2500.0).sqrt();
    for w in &squeeze.controls.walls {
        let expected = if w.face.axis == 2 { WallMotion::StrainRate(-0.5 * rate) } else { WallMotion::Fixed };
        match (w.motion, expected) {
            (WallMotion::StrainRate(x), WallMotion::StrainRate(y)) => assert!((x - y).abs() < 1e-12 * y.abs()),
            (x, y) => assert_eq!(x, y),
        }
    }
    let ball = parsed.container.granule.expect("ball");
    assert_eq!(ball.radius, 0.004);
    // Dry grains, gravity, a small box and a bad window are refused.
    let dry = scene(3, false, json!({"kind": "granule_compression"}));
    assert!(violations(&dry).iter().any(|x| x.starts_with("particles: the granule_compression experiment needs wet grains")));
    let mut bad = s.clone();
    bad["gravity"] = json!([0.0, 0.0, -9.81]);
    bad["experiment"]["radius"] = json!(0.006);
    bad["experiment"]["plateau"] = json!([0.2, 0.1]);
    let v = violations(&bad);
    for expected in [
        "gravity: must be absent",
        "container.max: the box must be at least 2.400e-2 m long along x",
        "experiment.plateau: must be [from, to]",
    ] {
        assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
    }
}

#[test]
fn default_rates_follow_the_inertial_numbers() {
    let s = scene(3, false, json!({"kind": "triaxial", "preparation": {"pressure": 2500.0}}));
    let scene = parse_scene(&s.to_string()).expect("valid");
    let Some(Experiment::Triaxial { preparation, strain_rate, axial_strain, .. }) = scene.experiment else { panic!("triaxial") };
    // sqrt(p / rho) = 1 m/s, d = 1 mm: I / d.
    assert!((preparation.max_strain_rate - 10.0).abs() < 1e-9);
    assert!((strain_rate - 0.5).abs() < 1e-9);
    assert_eq!(axial_strain, 0.2);
}

#[test]
fn broken_experiments_name_the_field_and_the_rule() {
    let cases = [
        (scene(3, false, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}})), "experiment.kind: 'biaxial' is the 2D test"),
        (
            scene(2, true, json!({"kind": "biaxial", "preparation": {"pressure": 100.0}})),
            "container.periodic: the biaxial experiment needs walls",
        ),
        (scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": -1.0}})), "experiment.preparation.pressure: must be > 0"),
        (
            scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 1.0}, "axial_strain": 1.5})),
            "experiment.axial_strain: must be in (0, 1)",
        ),
        (
            scene(2, false, json!({"kind": "biaxial", "preparation": {"pressure": 1.0}, "axis": "z"})),
            "experiment.axis: must be one of x, y in 2D",
        ),
        (scene(2, false, json!({"kind": "compaction", "velocity": 0.01})), "experiment.strain: required with velocity"),
        (scene(2, false, json!({"kind": "compaction", "velocity": 0.01, "stress": 5.0})), "experiment: give exactly one of velocity"),
        (
            scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0, "equilibrium": {"check_every": 0}}})),
            "experiment.preparation.equilibrium.check_every: must be >= 1",
        ),
    ];
    for (s, expected) in cases {
        let v = violations(&s);
        assert!(v.iter().any(|x| x.starts_with(expected)), "expected '{expected}' in {v:?}");
    }
    // Unknown fields are refused with their path.
    let v = violations(&scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0, "presure": 2.0}})));
    assert!(v.iter().any(|x| x.starts_with("experiment.preparation.presure") || x.contains("unknown field `presure`")), "{v:?}");
    // Moving walls, stop targets other than limits, and no stop without an experiment.
    let mut s = scene(2, false, json!({"kind": "isotropic", "preparation": {"pressure": 1.0}}));
    s["container"]["walls"] = json!({"y_max": {"kind": "velocity", "velocity": [0.0, -1.0]}});
    s["stop"] = json!({"strain": 0.1, "steps": 10});
    let v = violations(&s);
    assert!(v.iter().any(|x| x.starts_with("container.walls: an experiment moves the walls itself")), "{v:?}");
    assert!(v.iter().any(|x| x.starts_with("stop.strain: not with an experiment")), "{v:?}");
    let mut s = scene(2, false, json!(null));
    s.as_object_mut().expect("object").remove("experiment");
    assert!(violations(&s).iter().any(|x| x.starts_with("stop: required")));
}
