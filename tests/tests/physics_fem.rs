//! Meshed deformable grains through the whole engine (method `fem`): a scene file parsed,
//! validated, built and run by the same runner as the other methods, against the physics the
//! samples must obey and against the material point method on the same scene.

use crate::common;

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
/// the top wall's within 10%; the outlines cover less than 0.05% of the box twice (both grains'
/// nodes are held outside the other's boundary, `methods::soft::contact`: one-sided they
/// covered 0.08%); the dissipated energy (the walls' work less the energy stored and moving)
/// never falls below −0.1% of the strain energy at the end (backward Euler and inelastic
/// contacts only take energy out; on the study's 30 grains one-sided contacts pushed it to
/// −0.11 J/m at Φ 0.81). The steps are quasi-static (`dynamics` `auto`: the wall at 1.7e-3 of
/// the shear wave). Measured 2026-12-06 (test build): Φ 0.9000 at 859 kPa, Love–Weber 837 kPa,
/// Z 3.50, aspect 1.092, smallest J 0.924, no overlap measurable, +1.39 J/m dissipated at the
/// end (with inertial steps: 1.277 MPa, Z 3.17, aspect 1.156). The twelve grains stand in
/// columns that carry the wall and buckle at a moment round-off decides, and the 30 random
/// grains of `scenes/studies/soft_compaction_mpm_fem.json` tell such variants apart better.
///
/// The same scene by the material point method, with ten cells across the smallest grain
/// instead of the scene's six: over the dense part (Φ 0.78 to 0.91) the mean top-wall stress is
/// 486 kPa by FEM and 455 kPa by MPM (ratio 1.07, measured 2026-12-06), checked within 20%
/// either way: the stress rises steeply with Φ there (by a factor 1.6 to 2 from Φ 0.86 to
/// 0.90), so 20% is about a hundredth of Φ, twice the 0.5% on Φ at 300 kPa the study's finest
/// runs of the two methods agree to. With inertial steps the ratio was 1.64 (667 against 406 kPa): grains that lost a
/// contact flew off with its energy, and the packing each method's wall met was not the same.
#[test]
fn meshed_soft_grains_compact_past_phi_0_9_as_the_material_points_do() {
    let fem = common::run_file_with("scenes/fem_compaction_2d.json", |_| {});
    let last = fem.last().expect("samples");
    let d = last.deformable.as_ref().expect("deformable sample");
    let g = last.grains.as_ref().expect("the grains' sample");
    eprintln!(
        "fem: Φ {:.4} Z {:.3} σ_yy {:.4e} top wall {:.4e} Pa, aspect {:.3}, J_min {:.3}, dissipated {:.3e} J/m, interpenetration {:.4}",
        last.phi,
        last.z,
        last.stress.yy,
        top(last),
        g.mean_aspect_ratio,
        d.min_jacobian,
        d.dissipated_energy,
        d.interpenetration
    );
    assert!(last.phi >= 0.9, "Φ {}", last.phi);
    assert!(d.min_jacobian > 0.0);
    assert!(last.z > 2.0, "Z {}", last.z);
    assert!(g.mean_aspect_ratio > 1.01, "the grains did not flatten: {}", g.mean_aspect_ratio);
    let rel = (last.stress.yy - top(last)).abs() / top(last);
    assert!(rel < 0.1, "Love–Weber σ_yy {} against the top wall's {} ({rel:.3})", last.stress.yy, top(last));
    assert!(d.interpenetration < 5e-4, "interpenetration {}", d.interpenetration);
    let low = fem.iter().filter_map(|s| s.deformable.as_ref()).map(|d| d.dissipated_energy).fold(f64::INFINITY, f64::min);
    let kin = fem.iter().map(|s| s.kinetic_energy).fold(0.0, f64::max);
    eprintln!("lowest dissipated {low:.3e} J/m, largest kinetic {kin:.3e} J/m, strain {:.3e} J/m at the end", last.elastic_energy);
    assert!(low >= -1e-3 * last.elastic_energy, "the dissipated energy fell to {low} J/m");
    let mpm = common::run_file_with("scenes/mpm_compaction_2d.json", |v| v["method"]["cells_per_diameter"] = 10.into());
    let (f, m) = (dense_stress(&fem), dense_stress(&mpm));
    eprintln!("mean top-wall stress for Φ 0.78 to 0.91: fem {f:.4e} Pa, mpm {m:.4e} Pa (fem/mpm {:.3})", f / m);
    assert!((f / m).ln().abs() < 1.2f64.ln(), "fem {f} against mpm {m}");
}

/// The CI compaction on one and on two threads to step 900, past the first loaded contacts
/// (the grains' matrices are assembled, factorised and solved in parallel; the contact solve
/// and every sum over grains run in one order): the samples agree within 1e-4 (measured:
/// identical to the last bit; Φ 0.7860 and σ_yy 82.9 kPa at step 900; at step 850, where the
/// test stopped before each pair's contacts were solved together, σ_yy is now 7.1 kPa).
#[test]
fn meshed_grain_results_do_not_depend_on_the_thread_count() {
    let (worst, last) = common::thread_count_difference("scenes/fem_compaction_2d.json", 900);
    assert!(last.stress.yy > 1e4, "hardly loaded yet at step {}: {} Pa", last.step, last.stress.yy);
    assert!(worst < 1e-4, "results depend on the thread count: {worst:.2e}");
}

/// Eight silicone disks of `scenes/fem_silicone_2d.json` (in a box scaled to keep its packing
/// fraction) compacted to a log strain of 0.4 with grain friction `mu`, on one thread.
fn frictional_silicone(mu: f64) -> Vec<Sample> {
    common::run_file_with("scenes/fem_silicone_2d.json", |v| {
        v["particles"][0]["count"] = 8.into();
        let scale = (8.0_f64 / 20.0).sqrt();
        for a in 0..2 {
            let max = v["container"]["max"][a].as_f64().expect("box");
            v["container"]["max"][a] = (max * scale).into();
        }
        v["materials"]["silicone"]["friction"] = mu.into();
        v["experiment"]["strain"] = 0.4.into();
        v["method"]["threads"] = 1.into();
        v["seed"] = 1.into();
    })
}

/// Frictional soft grains compacted to jamming: eight neo-Hookean disks with grain friction
/// 0.8. Before the contact solver damped its cycles (`nscd::nlgs`, "Cycles"), this run stopped
/// at step 4,121 (Φ 0.63): its Gauss–Seidel sweeps swung between stick and slip, 20,000 of them
/// at a relative change of 1e-2 where 1e-6 was asked, at every split of the step (the
/// 100-grain FEM study stopped the same way at Φ 0.797 with friction 0.3 and at 0.694 with
/// 0.8). Now every solve converges, and the run obeys what friction does: it only takes energy
/// out (the dissipated energy never falls below −0.1% of the strain energy at the end, as in
/// the frictionless test above, and ends above the frictionless run's), and it holds the
/// grains where they would slide apart, so the packing jams at a lower Φ (Vu, Nezamabadi and
/// Mora, "Compaction of elastic granular materials: inter-particles friction effects and
/// plastic events", Soft Matter 2020): at the same strain (Φ 0.66) the frictional grains store
/// more than five times the frictionless ones' strain energy. Measured 2026-12-06 (release
/// build): 0.0839 against 0.0049 J/m (17 times), dissipated 1.105 against 0.868 J/m, top wall
/// 4.1 against 1.8 kPa; 13 and 9 CPU s.
#[test]
fn frictional_soft_grains_compact_to_jamming_with_every_contact_solve_converged() {
    let rough = frictional_silicone(0.8);
    let smooth = frictional_silicone(0.0);
    let (r, s) = (rough.last().expect("samples"), smooth.last().expect("samples"));
    let dissipated = |x: &Sample| x.deformable.as_ref().expect("deformable sample").dissipated_energy;
    eprintln!(
        "friction 0.8 / 0: Φ {:.4} / {:.4}, strain energy {:.4e} / {:.4e} J/m, dissipated {:.4e} / {:.4e} J/m, top wall {:.4e} / {:.4e} Pa",
        r.phi,
        s.phi,
        r.elastic_energy,
        s.elastic_energy,
        dissipated(r),
        dissipated(s),
        top(r),
        top(s)
    );
    assert!((r.phi - s.phi).abs() < 0.01, "the same strain: Φ {} and {}", r.phi, s.phi);
    for (run, last) in [(&rough, r), (&smooth, s)] {
        let floor = -1e-3 * last.elastic_energy;
        let low = run.iter().map(dissipated).fold(f64::INFINITY, f64::min);
        assert!(low >= floor, "dissipated energy {low} J/m below {floor}");
    }
    assert!(dissipated(r) > dissipated(s), "friction dissipates: {} against {} J/m", dissipated(r), dissipated(s));
    assert!(r.elastic_energy > 5.0 * s.elastic_energy, "friction jams earlier: {} against {} J/m", r.elastic_energy, s.elastic_energy);
}
