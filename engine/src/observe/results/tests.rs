//! The experiments' results on hand-made samples and scenes.

use super::drum::drum_regime;
use super::*;
use crate::observe::drum::ProfileBin;
use crate::observe::{GrainSample, StrainSample, WallSample};
use crate::scene::parse_scene;

fn sample(step: u64, stage: &str, axial: f64, zeta: f64, ev: f64) -> Sample {
    Sample {
        step,
        time: step as f64,
        phi: 0.8 - 0.5 * (0.002 - ev).max(0.0),
        z: 4.0,
        z_no_rattlers: 4.0,
        zeta,
        p: 100.0,
        q: 100.0 * zeta,
        elastic_energy: 1.0,
        stage: Some(stage.into()),
        strain: Some(StrainSample { axes: vec![ev - axial, axial], volumetric: ev, deviatoric: 0.0 }),
        ..Default::default()
    }
}

#[test]
fn drum_regimes_follow_the_stated_order() {
    assert_eq!(drum_regime(0.05, 30.0, 0.0, 0.0, 0.0), "centrifuging");
    assert_eq!(drum_regime(1.0, 3.0, 0.0, 0.0, 0.0), "slipping");
    assert_eq!(drum_regime(1.0, 30.0, 0.2, 0.0, 0.0), "cataracting");
    assert_eq!(drum_regime(1.0, 30.0, 0.0, 0.5, 0.0), "slumping");
    assert_eq!(drum_regime(1.0, 30.0, 0.0, 0.0, 15.0), "cascading");
    assert_eq!(drum_regime(1.0, 30.0, 0.01, 0.1, 3.0), "rolling");
}

#[test]
fn drum_means_start_after_the_transient_and_find_the_flowing_layer() {
    let text = r#"{"dimension": 2, "method": "dem", "gravity": [0.0, -10.0],
        "materials": {"m": {"density": 2000.0, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.5}},
        "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0.0, 0.0], "max": [0.04, 0.04], "wall_material": "m"},
        "experiment": {"kind": "drum", "angular_velocity": 3.141592653589793, "revolutions": 1.0, "transient": 0.5}}"#;
    let scene = parse_scene(text).expect("valid");
    let mut a = Analysis::new(&scene);
    let drum = |angle: f64, surface_v: f64| crate::observe::DrumSample {
        mass_angle: angle,
        surface_angle: Some(angle),
        upper_angle: Some(angle),
        lower_angle: Some(angle),
        fill: 0.4,
        bed_depth: 0.01,
        centroid_offset: 0.008,
        airborne_fraction: 0.0,
        drive_torque: 0.1,
        profile: vec![ProfileBin { depth: 5e-4, velocity: surface_v, count: 2 }, ProfileBin { depth: 1.5e-3, velocity: -0.1, count: 2 }],
    };
    let mut filling = sample(0, "filling", 0.0, 0.0, 0.0);
    filling.drum = Some(Box::new(drum(0.0, 0.0)));
    a.push(&filling);
    // One revolution takes 2 s: samples at t = 1, 1.5, 2, 2.5, 3; the window starts at t = 2.
    for (k, (angle, v)) in [(10.0, 0.0), (20.0, 0.0), (28.0, 0.1), (30.0, 0.3), (32.0, 0.2)].iter().enumerate() {
        let mut s = sample(0, "rotation", 0.0, 0.0, 0.0);
        s.time = 1.0 + 0.5 * k as f64;
        s.drum = Some(Box::new(drum(*angle, *v)));
        a.push(&s);
    }
    let r = a.finish(1e-3, 2000.0).expect("result");
    let d = r.drum.expect("drum result");
    assert_eq!((d.samples, d.from_time), (3, 1.0));
    assert!((d.surface_angle - 30.0).abs() < 1e-12 && (d.mass_angle - 30.0).abs() < 1e-12);
    assert!((d.surface_velocity - 0.2).abs() < 1e-12);
    // The mean profile crosses zero two thirds of the way from 0.5 mm to 1.5 mm.
    let h = d.flowing_layer_depth.expect("flowing layer");
    assert!((h - (5e-4 + 0.2 / 0.3 * 1e-3)).abs() < 1e-12, "{h}");
    assert_eq!(d.regime, "rolling");
    // Φ_box 0.8 - 0.001 over the fill's share of the box: Φ_box × 4 / (π × 0.4).
    assert!((d.phi_bed - 0.799 * 4.0 / (std::f64::consts::PI * 0.4)).abs() < 1e-9);
    // The drum turns faster than quasi-statically by design: no inertial-number warning.
    assert!(r.warnings.iter().all(|w| !w.contains("quasi-static")), "{:?}", r.warnings);
}

/// The analysis of 10 disks of 1 mm (k_n `k_n`) in `container` under `experiment`.
fn hand_made_analysis(k_n: f64, container: serde_json::Value, experiment: serde_json::Value) -> Analysis {
    let s = serde_json::json!({
        "dimension": 2, "method": "dem",
        "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.5}},
        "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "container": container,
        "experiment": experiment
    });
    Analysis::new(&parse_scene(&s.to_string()).expect("valid"))
}

fn walled_box() -> serde_json::Value {
    serde_json::json!({"min": [0, 0], "max": [0.01, 0.01], "wall_material": "m"})
}

fn biaxial_analysis(k_n: f64, strain_rate: f64) -> Analysis {
    hand_made_analysis(
        k_n,
        walled_box(),
        serde_json::json!({"kind": "biaxial", "preparation": {"pressure": 100.0}, "strain_rate": strain_rate, "axial_strain": 0.2}),
    )
}

/// Plane shear of aggregates: the steady inertial number is the grains', the samples' own
/// (the primaries', at the box's mean diameter) rescaled by the grains' diameter.
#[test]
fn the_plane_shear_of_aggregates_reports_the_grains_inertial_number() {
    let mut a = hand_made_analysis(
        1e7,
        serde_json::json!({"min": [0, 0], "max": [0.01, 0.01], "periodic": ["x", "y"]}),
        serde_json::json!({"kind": "plane_shear", "preparation": {"pressure": 100.0}, "shear_rate": 10.0, "strain": 1.0}),
    );
    for k in 0..=10 {
        let mut x = sample(k, "shear", 0.0, 0.3, 0.0);
        x.time = 0.01 * k as f64;
        x.inertial_number = Some(2e-3);
        a.push(&x);
    }
    let plain = a.finish(1e-4, 2500.0).and_then(|r| r.shear).expect("shear");
    assert!((plain.inertial_number - 2e-3).abs() < 1e-15, "{}", plain.inertial_number);
    // Grains of 1.8 mm made of primaries of 0.1 mm: I 18 times the primaries'.
    a.aggregate_diameter = Some(1.8e-3);
    let r = a.finish(1e-4, 2500.0).expect("result");
    let grains = r.shear.expect("shear");
    assert!((grains.inertial_number - 18.0 * 2e-3).abs() < 1e-12, "{}", grains.inertial_number);
    assert_eq!(r.inertial_number, Some(grains.inertial_number));
}

/// A hand-made dense biaxial test: ζ rises to 0.5 at 2% axial strain, falls to 0.3 by 10% and
/// stays; ε_v contracts to 0.002 at 1%, then dilates to -0.03 at 10% and stays.
#[test]
fn peak_steady_state_and_dilatancy_of_a_hand_made_test() {
    let mut a = biaxial_analysis(1e7, 0.01);
    a.push(&sample(0, "preparation", 0.0, 0.0, 0.0));
    a.push(&sample(10, "preparation", 0.0, 0.01, 0.0));
    for k in 0..=200 {
        let ea = k as f64 * 0.001;
        let zeta = if ea <= 0.02 {
            25.0 * ea
        } else if ea <= 0.1 {
            0.5 - 2.5 * (ea - 0.02)
        } else {
            0.3
        };
        let ev = if ea <= 0.01 {
            0.2 * ea
        } else if ea <= 0.1 {
            0.002 - 0.032 * (ea - 0.01) / 0.09
        } else {
            -0.03
        };
        a.push(&sample(100 + k, "loading", ea, zeta, ev));
    }
    let r = a.finish(1e-3, 2500.0).expect("result");
    assert_eq!(r.experiment, "biaxial");
    assert_eq!(r.prepared.as_ref().map(|s| s.step), Some(10));
    assert_eq!(r.prepared.as_ref().map(|s| s.grains), Some(None));
    // Grains made of primaries: the states carry the grains' own measures.
    let mut g = biaxial_analysis(1e7, 0.01);
    let grains = crate::observe::GrainSample { count: 4, phi: 0.93, z: 2.5, ..Default::default() };
    let mut prepared = sample(10, "preparation", 0.0, 0.0, 0.0);
    prepared.grains = Some(Box::new(grains));
    g.push(&prepared);
    g.push(&sample(11, "loading", 0.01, 0.1, 0.0));
    let with = g.finish(1e-3, 2500.0).expect("result");
    assert_eq!(with.prepared.and_then(|s| s.grains), Some(grains));
    assert_eq!(with.last.grains, None);
    let peak = r.peak.expect("peak");
    assert!((peak.zeta - 0.5).abs() < 1e-12 && (peak.axial_strain - 0.02).abs() < 1e-12);
    let steady = r.steady.expect("steady");
    assert!((steady.from_axial_strain - 0.15).abs() < 1e-12);
    // Strains 0.150..0.200 (0.150 itself may round either side of 0.75 × 0.2).
    assert!((50..=51).contains(&steady.samples), "{}", steady.samples);
    assert!((steady.zeta - 0.3).abs() < 1e-12 && steady.zeta_std < 1e-12 && steady.dilatancy_rate.abs() < 1e-12);
    let d = r.dilatancy.expect("dilatancy");
    assert!((d.max_contraction - 0.002).abs() < 1e-12 && (d.at_axial_strain - 0.01).abs() < 1e-12);
    assert!((d.final_volumetric_strain + 0.03).abs() < 1e-12);
    // I = 0.01 × 1e-3 × sqrt(2500 / 100) = 5e-5; κ = k_n / p = 1e5 in 2D: no warning.
    assert!((r.inertial_number.expect("I") - 5e-5).abs() < 1e-15);
    assert!((r.stiffness_number.expect("kappa") - 1e5).abs() < 1e-6);
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    // A dilating window has a positive dilatancy rate.
    let mut b = biaxial_analysis(1e7, 0.01);
    for k in 0..=100 {
        b.push(&sample(k, "loading", k as f64 * 0.001, 0.4, -0.5 * k as f64 * 0.001));
    }
    assert!((b.finish(1e-3, 2500.0).and_then(|r| r.steady).expect("steady").dilatancy_rate - 0.5).abs() < 1e-9);
}

/// Aggregates in a biaxial test: the peak carries the grains' measures of its sample, and
/// the steady state their means over the last quarter of the strain (grains' Φ 0.9 + 0.1 ε_a
/// and Z 3 + 10 ε_a at the window's mean strain; aspect ratio 1.2 flat), the same as its own
/// Φ (the sample's Φ is the grains'); the inertial number is at the grains' scale.
#[test]
fn a_biaxial_test_of_aggregates_reports_its_grains_at_the_peak_and_steady_state() {
    let mut a = biaxial_analysis(1e7, 0.01);
    a.aggregates = true;
    for k in 0..=200 {
        let ea = k as f64 * 0.001;
        let mut s = sample(k, "loading", ea, if k == 20 { 0.6 } else { 0.3 }, 0.0);
        (s.phi, s.z) = (0.9 + 0.1 * ea, 3.0 + 10.0 * ea);
        s.primaries = Some(crate::observe::PrimarySample { phi: 0.8, z: 4.0, z_no_rattlers: 4.0 });
        s.grains = Some(Box::new(crate::observe::GrainSample {
            count: 9,
            phi: s.phi,
            z: s.z,
            z_no_rattlers: s.z,
            pressure: 1e6,
            mean_aspect_ratio: 1.2,
            max_aspect_ratio: 1.5,
            mean_area: 2e-6,
        }));
        a.push(&s);
    }
    let r = a.finish(1e-3, 2500.0).expect("result");
    let peak = r.peak.expect("peak");
    let at_peak = peak.grains.expect("grains at the peak");
    assert!((peak.axial_strain - 0.02).abs() < 1e-12 && (at_peak.phi - 0.902).abs() < 1e-12, "{peak:?}");
    let steady = r.steady.expect("steady");
    let g = steady.grains.expect("the grains' steady state");
    // The window's strains run back from 0.2 by 0.001 (0.150 itself may round either side).
    let ea = 0.2 - 0.0005 * (steady.samples as f64 - 1.0);
    assert!((g.phi - (0.9 + 0.1 * ea)).abs() < 1e-9 && (g.z - (3.0 + 10.0 * ea)).abs() < 1e-9, "{g:?}");
    assert!((g.mean_aspect_ratio - 1.2).abs() < 1e-12 && (g.max_aspect_ratio - 1.5).abs() < 1e-12 && g.count == 9);
    assert!((steady.phi - g.phi).abs() < 1e-12, "the sample's Φ is the grains': {} against {}", steady.phi, g.phi);
    // The inertial number is the grains': with no set to name their size (the hand-made
    // analysis's set is of plain disks) the disk of their mean area, 2e-6 m², 1.596 mm:
    // I = 0.01 × 1.596e-3 × sqrt(2500 / 100), not the primaries' 0.01 × 1e-3 × 5.
    let d = 2.0 * (2e-6 / std::f64::consts::PI).sqrt();
    assert!((r.inertial_number.expect("I") - 0.01 * d * 5.0).abs() < 1e-15, "{:?}", r.inertial_number);
    // With a set of aggregates, its nominal diameter.
    a.aggregate_diameter = Some(1.8e-3);
    assert!((a.finish(1e-3, 2500.0).and_then(|r| r.inertial_number).expect("I") - 0.01 * 1.8e-3 * 5.0).abs() < 1e-15);
    // One sample without them: no grains' steady state rather than a mean over part.
    let mut b = biaxial_analysis(1e7, 0.01);
    for k in 0..=100 {
        let mut s = sample(k, "loading", k as f64 * 0.001, 0.3, 0.0);
        if k != 90 {
            s.grains = Some(Box::default());
        }
        b.push(&s);
    }
    assert_eq!(b.finish(1e-3, 2500.0).and_then(|r| r.steady).map(|s| s.grains), Some(None));
}

#[test]
fn fast_or_soft_tests_are_flagged() {
    // I = 10 × 1e-3 × 5 = 0.05; κ = 1e5 / 100 = 1e3.
    let mut a = biaxial_analysis(1e5, 10.0);
    a.push(&sample(0, "loading", 0.0, 0.0, 0.0));
    a.push(&sample(1, "loading", 0.01, 0.1, 0.0));
    let r = a.finish(1e-3, 2500.0).expect("result");
    assert_eq!(r.warnings.len(), 2, "{:?}", r.warnings);
    assert!(r.warnings[0].starts_with("not quasi-static") && r.warnings[1].starts_with("not in the rigid limit"));
}

/// Aggregates: κ = 1e3 is rigid enough for their primaries (their contacts deflect by 0.1%
/// of a primary); κ = 50 is not, and the warning says it of the primaries.
#[test]
fn aggregates_are_judged_by_the_rigidity_of_their_primaries() {
    let warnings = |k_n: f64| {
        let mut a = biaxial_analysis(k_n, 1e-4);
        a.aggregates = true;
        a.push(&sample(0, "loading", 0.0, 0.0, 0.0));
        a.push(&sample(1, "loading", 0.01, 0.1, 0.0));
        a.finish(1e-3, 2500.0).expect("result").warnings
    };
    assert!(warnings(1e5).is_empty(), "{:?}", warnings(1e5));
    let w = warnings(5e3);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with(
            "not in the rigid limit: stiffness number 5.00e1 < 1e2 (the primaries' contacts deflect by about 2.0e-2 of a primary"
        ),
        "{w:?}"
    );
}

/// A hand-made compaction of soft grains: `Z − Z_J = 5 (Φ − Φ_J)^½` past the wall's first
/// load. The results: Φ at the onset, at the end and the largest, the coordination fit
/// (exponent ½, prefactor 5) and the grains' shapes at the end.
#[test]
fn a_compaction_of_soft_grains_fits_its_coordination_and_keeps_their_shapes() {
    let mut a = hand_made_analysis(1e7, walled_box(), serde_json::json!({"kind": "compaction", "velocity": 0.01, "strain": 0.5}));
    for k in 0..=40u64 {
        let phi = 0.6 + 0.008 * k as f64;
        let beyond = (phi - 0.68).max(0.0);
        let mut x = sample(k, "compaction", 0.0, 0.0, 0.0);
        (x.phi, x.z) = (phi, 2.0 + 5.0 * beyond.sqrt());
        x.walls = vec![WallSample {
            name: "y_max".into(),
            position: 0.01,
            force: vec![0.0, 0.0],
            normal_stress: if k >= 10 { 1e5 + 1e6 * beyond } else { 0.0 },
        }];
        x.grains = Some(Box::new(GrainSample {
            count: 10,
            phi: x.phi,
            z: x.z,
            z_no_rattlers: x.z,
            pressure: 0.0,
            mean_aspect_ratio: 1.1 + 0.001 * k as f64,
            max_aspect_ratio: 1.3,
            mean_area: 1e-6,
        }));
        a.push(&x);
    }
    let r = a.finish(1e-3, 2500.0).expect("result");
    let c = r.compaction.expect("a compaction result");
    assert!((c.phi_onset.expect("an onset") - 0.68).abs() < 1e-12, "{c:?}");
    assert!((c.phi_final - 0.92).abs() < 1e-12 && (c.phi_max - 0.92).abs() < 1e-12, "{c:?}");
    let fit = c.coordination_fit.clone().expect("a coordination fit");
    assert!((fit.exponent - 0.5).abs() < 1e-9 && (fit.prefactor - 5.0).abs() < 1e-8, "{fit:?}");
    assert!(c.mean_aspect_ratio.is_some_and(|m| (m - 1.14).abs() < 1e-12) && c.max_aspect_ratio == Some(1.3), "{c:?}");
}

/// A compaction of neo-Hookean grains (μ 1.5 MPa, λ 3 MPa) whose wall stress follows the
/// sources' law with `c₁ = 0.23`, `c₂ = 0.27` beyond the onset: the results give the two
/// constants back, and `α = K dΦ/dσ` of the linear law with the grains' plane-strain `K = λ + μ`.
#[test]
fn a_compaction_of_deformable_grains_fits_the_sources_laws() {
    let s = serde_json::json!({
        "dimension": 2, "method": {"kind": "mpm"},
        "materials": {"m": {"density": 990.0, "friction": 0.0, "deformable": {"law": "neo_hookean", "shear_modulus": 1.5e6, "lambda": 3e6}}},
        "particles": [{"material": "m", "count": 10, "size": {"kind": "monodisperse", "diameter": 2e-3}, "placement": {"kind": "random"}}],
        "container": walled_box(),
        "experiment": {"kind": "compaction", "velocity": 0.01, "strain": 0.5}
    });
    let mut a = Analysis::new(&parse_scene(&s.to_string()).expect("valid"));
    a.for_grains(crate::run::GrainModel::Deformable);
    let (bulk, p_wave, c1, c2) = (4.5e6, 6e6, 0.23, 0.27);
    let law = |phi: f64, z: f64| {
        let m_eff = phi * p_wave;
        (m_eff * (phi.ln() + c2) / (1.0 + m_eff / (c1 * bulk * z * phi))).max(0.0)
    };
    for k in 0..=40u64 {
        let phi = 0.70 + 0.006 * k as f64;
        let mut x = sample(k, "compaction", 0.0, 0.0, 0.0);
        (x.phi, x.z) = (phi, 3.0 + 6.0 * (phi - 0.70).sqrt());
        x.walls = vec![WallSample { name: "y_max".into(), position: 0.01, force: vec![0.0, 0.0], normal_stress: law(x.phi, x.z) }];
        a.push(&x);
    }
    let r = a.finish(2e-3, 990.0).expect("result");
    let c = r.compaction.expect("a compaction result");
    let fit = c.neo_hookean_law.clone().expect("the neo-Hookean law fitted");
    assert!((fit.c1 / c1 - 1.0).abs() < 1e-6 && (fit.c2 - c2).abs() < 1e-6, "{fit:?}");
    let linear = c.linear_law.clone().expect("the linear law fitted");
    // The same least squares written out over the states from the onset on (Φ_J from the result).
    let phi_j = c.phi_onset.expect("an onset");
    let pts: Vec<(f64, f64)> = (0..=40u64)
        .map(|k| 0.70 + 0.006 * k as f64)
        .filter(|&phi| phi >= phi_j - 1e-12)
        .map(|phi| (law(phi, 3.0 + 6.0 * (phi - 0.70).sqrt()), phi))
        .filter(|&(s, _)| s > 0.0)
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    assert_eq!(linear.points, pts.len(), "{linear:?}");
    assert!((linear.alpha / (bulk * slope) - 1.0).abs() < 1e-9, "{linear:?} against {}", bulk * slope);
    assert!(c.exponential_law.is_some(), "{c:?}");
}
