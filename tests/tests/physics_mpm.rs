//! Deformable grains through the whole engine (method `mpm`): a scene file parsed, validated,
//! built and run by the same runner as rigid grains, and its samples checked against the
//! physics they must obey.

use sable_engine::observe::Sample;

fn run(path: &str) -> Vec<Sample> {
    let json = std::fs::read_to_string(path).expect("scene file");
    let scene = sable_engine::scene::parse_scene(&json).expect("valid scene");
    let mut sim = sable_engine::methods::build(&scene).expect("buildable");
    let runner = sable_engine::run::Runner::for_scene(&scene);
    let mut samples = Vec::new();
    runner.run(sim.as_mut(), &mut |s, _| samples.push(s.clone())).expect("stable");
    samples
}

/// The CI-sized soft compaction (`scenes/mpm_compaction_2d.json`, N 2.1.1's grains and law):
/// the top wall compacts twelve disks past Φ = 0.9 without inverting a point; every sample
/// keeps the grains' mass-weighted stress from the contacts (Love–Weber) and the walls' loads
/// in agreement (the walls carry what crosses the packing), the grains carry force (Z > 2) and
/// flatten (aspect ratio > 1), and no energy is created. Measured: Φ 0.9008 after 1037 steps
/// (31 s), Love–Weber σ_yy 4.8% above the top wall's stress, Z 3.17, aspect ratio 1.022 (max
/// 1.050), smallest J 0.924.
#[test]
fn soft_grains_compact_past_phi_0_9() {
    let samples = run(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/mpm_compaction_2d.json"));
    let last = samples.last().expect("samples");
    let d = last.deformable.as_ref().expect("deformable sample");
    let top = last.walls.iter().find(|w| w.name == "y_max").expect("top wall");
    eprintln!(
        "Φ {:.4} Z {:.3} (no rattlers {:.3}) σ_yy {:.4e} top wall {:.4e} Pa, aspect {:.3} (max {:.3}), J_min {:.3}, kinetic {:.3e} strain {:.3e} dissipated {:.3e} J/m, {} samples",
        last.phi, last.z, last.z_no_rattlers, last.stress.yy, top.normal_stress, d.mean_aspect_ratio, d.max_aspect_ratio, d.min_jacobian,
        last.kinetic_energy, last.elastic_energy, d.dissipated_energy, samples.len()
    );
    assert!(last.phi >= 0.9, "Φ {}", last.phi);
    assert!(d.min_jacobian > 0.0);
    assert!(last.z > 2.0, "Z {}", last.z);
    assert!(d.mean_aspect_ratio > 1.01, "the grains did not flatten: {}", d.mean_aspect_ratio);
    let rel = (last.stress.yy - top.normal_stress).abs() / top.normal_stress;
    assert!(rel < 0.1, "Love–Weber σ_yy {} against the top wall's {} ({rel:.3})", last.stress.yy, top.normal_stress);
    assert!(d.dissipated_energy > -1e-3 * last.elastic_energy, "energy created: {}", d.dissipated_energy);
}
