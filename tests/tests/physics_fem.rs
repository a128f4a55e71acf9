//! Meshed deformable grains through the whole engine (method `fem`): a scene file parsed,
//! validated, built and run by the same runner as the other methods, against the physics the
//! samples must obey and against the material point method on the same scene.

mod common;

use sable_engine::observe::Sample;

fn top(s: &Sample) -> f64 {
    s.walls.iter().find(|w| w.name == "y_max").expect("top wall").normal_stress
}

/// Mean top-wall stress over the samples with Φ from 0.78 to 0.91 (Pa): one instant of a dense
/// packing moves by 20% when only the order of a sum changes (`physics_mpm`), a mean over the
/// compaction's dense part much less.
fn dense_stress(samples: &[Sample]) -> f64 {
    let dense: Vec<f64> = samples.iter().filter(|s| (0.78..0.91).contains(&s.phi)).map(top).collect();
    assert!(dense.len() >= 3, "{} dense samples", dense.len());
    dense.iter().sum::<f64>() / dense.len() as f64
}

/// The CI-sized soft compaction with meshed grains (`scenes/fem_compaction_2d.json`: the twelve
/// disks of `scenes/mpm_compaction_2d.json`, eight boundary elements across the smallest): the
/// top wall compacts them past Φ = 0.9 without inverting an element; the grains carry force
/// (Z > 2) and flatten (aspect ratio > 1.01); the Love–Weber stress from the contacts agrees with
/// the top wall's within 10%; the outlines cover less than 0.3% of the box twice. Measured
/// (release build, one thread, 74 s of CPU sharing the machine with another run, with each
/// grain's matrix kept from one step to the next, `methods::fem::system`): Φ 0.9000 at
/// 1.35 MPa, Love–Weber 1.35 MPa, Z 3.67, aspect 1.206, smallest J 0.899, interpenetration
/// 0.08%. The twelve grains stand in columns that carry the wall and buckle at a moment
/// round-off decides: with each step's matrices new it ended at 729 kPa (Z 3.33, 0.07%), with
/// the matrices kept on a decision for all grains together at 1.09 MPa, with a new matrix at
/// every Newton iteration at 1.11 MPa (1.15 MPa at half the step), and the 30 random grains of
/// `scenes/studies/soft_compaction_mpm_fem.json` tell such variants apart by 0.1% in Φ at
/// 300 kPa.
/// Before a part whose contacts outran their linearisation was split (`methods::fem::system`),
/// the run ended at 594 kPa with 0.94% of the box covered twice.
///
/// The same scene by the material point method, with ten cells across the smallest grain
/// instead of the scene's six, reaches Φ 0.9002 at 663 kPa (Z 3.17, aspect 1.074, smallest J
/// 0.878, interpenetration 0.15%, 59 s); over the dense part (Φ 0.78 to 0.91) the mean top-wall
/// stress is 756 kPa by FEM and 418 kPa by MPM: FEM 1.81 times stiffer (1.47 and 1.08 for the
/// variants above that ended at 1.09 MPa and 729 kPa), checked within a factor 2 either way.
/// MPM's grid accounts for much of the gap: its top wall at Φ 0.90 was 487 kPa with 6 cells,
/// 663 kPa with 10 and 819 kPa with 14 (dense mean 314, 418 and 418 kPa): against the scene's
/// six cells this FEM run would be 2.4 times stiffer. On 30 random grains, at 14 cells and 8
/// elements, the two agree within 0.5% on Φ at 300 kPa (the study above).
///
/// Not asserted, a known defect (issue 26): the energy balance. The dissipated energy (work in
/// less the energy stored and moving) dips below zero as the packing rearranges: not in this
/// run (it ends at +0.21 J/m), but to −0.11 J/m at Φ 0.81 on the study's 30 grains. The work
/// comes from contacts whose drift pushes their grains apart (measured in the module
/// documentation of `sable_engine::methods::soft::contact`).
#[test]
fn meshed_soft_grains_compact_past_phi_0_9_as_the_material_points_do() {
    let fem = common::run_file_with("scenes/fem_compaction_2d.json", |_| {});
    let last = fem.last().expect("samples");
    let d = last.deformable.as_ref().expect("deformable sample");
    eprintln!(
        "fem: Φ {:.4} Z {:.3} σ_yy {:.4e} top wall {:.4e} Pa, aspect {:.3}, J_min {:.3}, dissipated {:.3e} J/m, interpenetration {:.4}",
        last.phi,
        last.z,
        last.stress.yy,
        top(last),
        d.mean_aspect_ratio,
        d.min_jacobian,
        d.dissipated_energy,
        d.interpenetration
    );
    assert!(last.phi >= 0.9, "Φ {}", last.phi);
    assert!(d.min_jacobian > 0.0);
    assert!(last.z > 2.0, "Z {}", last.z);
    assert!(d.mean_aspect_ratio > 1.01, "the grains did not flatten: {}", d.mean_aspect_ratio);
    let rel = (last.stress.yy - top(last)).abs() / top(last);
    assert!(rel < 0.1, "Love–Weber σ_yy {} against the top wall's {} ({rel:.3})", last.stress.yy, top(last));
    assert!(d.interpenetration < 0.003, "interpenetration {}", d.interpenetration);
    let mpm = common::run_file_with("scenes/mpm_compaction_2d.json", |v| v["method"]["cells_per_diameter"] = 10.into());
    let (f, m) = (dense_stress(&fem), dense_stress(&mpm));
    eprintln!("mean top-wall stress for Φ 0.78 to 0.91: fem {f:.4e} Pa, mpm {m:.4e} Pa (fem/mpm {:.3})", f / m);
    assert!((f / m).ln().abs() < 2f64.ln(), "fem {f} against mpm {m}");
}

/// The CI compaction on one and on two threads to step 850, past the first loaded contacts
/// (the grains' matrices are assembled, factorised and solved in parallel; the contact solve
/// and every sum over grains run in one order): the samples agree within 1e-4 (measured:
/// identical to the last bit; Φ 0.7531 and σ_yy 17.6 kPa at step 850).
#[test]
fn meshed_grain_results_do_not_depend_on_the_thread_count() {
    let (worst, last) = common::thread_count_difference("scenes/fem_compaction_2d.json", 850);
    assert!(last.stress.yy > 1e4, "hardly loaded yet at step {}: {} Pa", last.step, last.stress.yy);
    assert!(worst < 1e-4, "results depend on the thread count: {worst:.2e}");
}
