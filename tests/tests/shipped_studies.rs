//! The studies shipped in scenes/studies/ stay valid: each expands into runs whose scenes pass
//! validation, with the measure and reference they are charted against in the README.

use sable_engine::study::{parse_study, Study};

#[test]
fn every_shipped_study_expands_into_valid_runs() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/studies");
    let mut names: Vec<(String, usize)> = Vec::new();
    for entry in std::fs::read_dir(dir).expect("scenes/studies") {
        let path = entry.expect("entry").path();
        let text = std::fs::read_to_string(&path).expect("readable");
        let (_, study) = parse_study(&text).unwrap_or_else(|v| panic!("{}: {v:?}", path.display()));
        let runs = match study {
            Study::Sweep { points, .. } => points.len(),
            Study::Search { .. } => 2,
        };
        names.push((path.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string(), runs));
    }
    names.sort();
    assert_eq!(
        names,
        vec![
            ("agglomerate_rates_2d.json".to_string(), 16),
            ("biaxial_dem_cd.json".to_string(), 10),
            ("bpm_biaxial.json".to_string(), 4),
            ("bpm_compaction_law.json".to_string(), 2),
            ("bpm_isotropic.json".to_string(), 6),
            ("bpm_isotropic_periodic.json".to_string(), 3),
            ("bpm_z_phi_periodic.json".to_string(), 9),
            ("dem_time_step_limit.json".to_string(), 2),
            ("disk_between_plates_soft.json".to_string(), 16),
            ("fem_compaction_friction.json".to_string(), 4),
            ("granule_growth_2d.json".to_string(), 8),
            ("granule_strength.json".to_string(), 16),
            ("mpm_compaction_laws.json".to_string(), 8),
            ("plane_shear_stiffness.json".to_string(), 5),
            ("restitution_dem.json".to_string(), 9),
            ("soft_compaction_bpm_mpm.json".to_string(), 3),
            ("soft_compaction_mpm_fem.json".to_string(), 5),
            ("soft_compaction_steps.json".to_string(), 10),
            ("wet_rheology.json".to_string(), 35),
        ]
    );
}

/// Every scene shipped in scenes/ passes validation; the small ones without aggregates also
/// build (their particles placed), as `sable run scenes/NAME.json` would need. (Building an
/// aggregate relaxes it, minutes for the shipped ones; the full-size scenes take long to place.)
#[test]
fn every_shipped_scene_is_valid_and_builds() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(dir).expect("scenes") {
        let path = entry.expect("entry").path();
        if path.extension().and_then(|e| e.to_str()) != Some("json") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("readable");
        let plan = sable_engine::methods::plan_scene(&text).unwrap_or_else(|v| panic!("{}: {v:?}", path.display()));
        if plan.particle_count() <= 2_000 && plan.sets.iter().all(|s| s.aggregate.is_none()) {
            plan.build().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
        count += 1;
    }
    assert!(count >= 30, "{count} scenes");
}
