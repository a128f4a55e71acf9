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
            ("biaxial_dem_cd.json".to_string(), 10),
            ("bpm_biaxial.json".to_string(), 4),
            ("bpm_compaction_law.json".to_string(), 2),
            ("bpm_isotropic.json".to_string(), 6),
            ("bpm_isotropic_periodic.json".to_string(), 3),
            ("bpm_z_phi_periodic.json".to_string(), 9),
            ("dem_time_step_limit.json".to_string(), 2),
            ("disk_between_plates_soft.json".to_string(), 16),
            ("fem_compaction_friction.json".to_string(), 4),
            ("mpm_compaction_laws.json".to_string(), 8),
            ("plane_shear_stiffness.json".to_string(), 5),
            ("restitution_dem.json".to_string(), 9),
            ("soft_compaction_bpm_mpm.json".to_string(), 3),
            ("soft_compaction_mpm_fem.json".to_string(), 5),
            ("soft_compaction_steps.json".to_string(), 8),
        ]
    );
}
