//! Deformable grains through the whole engine (method `mpm`): a scene file parsed, validated,
//! built and run by the same runner as rigid grains, and its samples checked against the
//! physics they must obey.

use crate::common;

use sable_engine::observe::Sample;

fn run(path: &str) -> Vec<Sample> {
    run_with(path, |_| {})
}

/// Runs the scene file at `path` after `edit` changes its JSON.
fn run_with(path: &str, edit: impl FnOnce(&mut serde_json::Value)) -> Vec<Sample> {
    run_scene(path, edit).0
}

/// Runs the scene file at `path` after `edit` changes its JSON: its samples, and its
/// experiment's derived results if it has one.
fn run_scene(path: &str, edit: impl FnOnce(&mut serde_json::Value)) -> (Vec<Sample>, Option<sable_engine::observe::ExperimentResult>) {
    let text = std::fs::read_to_string(path).expect("scene file");
    let mut value: serde_json::Value = serde_json::from_str(&text).expect("json");
    edit(&mut value);
    let scene = sable_engine::methods::plan_scene(&value.to_string()).expect("valid scene");
    let mut sim = scene.build().expect("buildable");
    let runner = sable_engine::run::Runner::for_scene(&scene);
    let mut analysis = sable_engine::observe::Analysis::new(&scene);
    let mut samples = Vec::new();
    runner
        .run(sim.as_mut(), &mut |s, _| {
            analysis.push(s);
            samples.push(s.clone());
        })
        .expect("stable");
    let (d, rho) = sim.grain_scales();
    let result = analysis.finish(d, rho);
    (samples, result)
}

/// The CI-sized soft compaction (`scenes/mpm_compaction_2d.json`, the grains and law of
/// Nezamabadi 2020, §2.1.1): the top wall compacts twelve disks past Φ = 0.9 without inverting a
/// point; every sample keeps the grains' mass-weighted stress from the contacts (Love–Weber) and
/// the walls' loads in agreement (the walls carry what crosses the packing), the grains carry force
/// (Z > 2) and flatten (aspect ratio > 1), no energy is created, and the grains' outlines cover
/// less than 0.8% of the box twice. Measured 2026-12-06 (quasi-static steps, `dynamics` `auto`):
/// Φ 0.9004, the top wall at 660 kPa, aspect ratio 1.098, smallest J 0.880, Love–Weber σ_yy
/// within 0.9% of it, interpenetration 0.0015 (inertial steps: 476 kPa, 0.0029; the
/// contacts measure their gaps between the outlines and take the outlines' turning and sliding
/// within the step into account, the drift of `methods::mpm::contact`'s documentation). Before,
/// with one contact per node column and its gap from the points in it, the same Φ came at 421 kPa
/// with 2.6% of the box covered twice (then counted with the points' parallelograms): the gaps,
/// measured anew each step, jumped as points entered and left the columns, and every overlap once
/// measured was kept; with the contacts on the nodes' velocities at 155 kPa and 5.8%: the point
/// clouds overlapped instead of deforming. The top wall's stress at the last sample moved by 20%
/// when only the order of a sum changed: one instant of a dense packing is that sensitive, so the
/// test compares stresses measured at the same instant, not against a fixed value.
#[test]
fn soft_grains_compact_past_phi_0_9() {
    let samples = run(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/mpm_compaction_2d.json"));
    let last = samples.last().expect("samples");
    let d = last.deformable.as_ref().expect("deformable sample");
    let g = last.grains.as_ref().expect("the grains' sample");
    let top = last.walls.iter().find(|w| w.name == "y_max").expect("top wall");
    eprintln!(
        "Φ {:.4} Z {:.3} (no rattlers {:.3}) σ_yy {:.4e} top wall {:.4e} Pa, aspect {:.3} (max {:.3}), J_min {:.3}, kinetic {:.3e} strain {:.3e} dissipated {:.3e} J/m, interpenetration {:.4}, {} samples",
        last.phi, last.z, last.z_no_rattlers, last.stress.yy, top.normal_stress, g.mean_aspect_ratio, g.max_aspect_ratio, d.min_jacobian,
        last.kinetic_energy, last.elastic_energy, d.dissipated_energy, d.interpenetration, samples.len()
    );
    assert!(last.phi >= 0.9, "Φ {}", last.phi);
    assert!(d.min_jacobian > 0.0);
    assert!(last.z > 2.0, "Z {}", last.z);
    assert!(g.mean_aspect_ratio > 1.01, "the grains did not flatten: {}", g.mean_aspect_ratio);
    // The grains' sample, in the fields aggregates use: every particle is a grain, so its Φ and
    // Z are the sample's (one contact record per pair), and its pressure times Φ is the
    // contact part of the box's pressure (Σ f·ℓ over the grains' area, against over the
    // box's), the kinetic part of a quasi-static compaction being far below 1% of it.
    assert!((g.phi - last.phi).abs() < 1e-12 * last.phi, "grains Φ {} vs Φ {}", g.phi, last.phi);
    assert_eq!(g.z, last.z, "grains Z");
    assert!((g.pressure * g.phi - last.p).abs() < 1e-2 * last.p, "grains p {} × Φ {} vs p {}", g.pressure, g.phi, last.p);
    let rel = (last.stress.yy - top.normal_stress).abs() / top.normal_stress;
    assert!(rel < 0.1, "Love–Weber σ_yy {} against the top wall's {} ({rel:.3})", last.stress.yy, top.normal_stress);
    assert!(d.dissipated_energy > -1e-3 * last.elastic_energy, "energy created: {}", d.dissipated_energy);
    assert!(d.interpenetration < 0.008, "interpenetration {}", d.interpenetration);
}

/// The same compaction on one and on two threads (the grains' fields are assembled, factorised
/// and updated in parallel; sums over grains are reduced in another order): the samples agree
/// within 1e-4 (measured: identical to the last bit, Φ 0.7256 and σ_yy 16.3 kPa at step 800,
/// past the first contacts).
#[test]
fn soft_grain_results_do_not_depend_on_the_thread_count() {
    let (worst, last) = common::thread_count_difference("scenes/mpm_compaction_2d.json", 800);
    assert!(last.stress.yy > 0.0, "no load yet at step {}", last.step);
    assert!(worst < 1e-4, "results depend on the thread count: {worst:.2e}");
}

/// The biaxial experiment drives soft grains unchanged (`scenes/mpm_biaxial_2d.json`,
/// Nezamabadi 2020, §2.2, with deformable grains): the four walls' stress servos press sixteen
/// disks to 20 kPa until equilibrium, then the top wall moves down at a constant strain rate while
/// the side walls hold 20 kPa. Checked: the prepared state's pressure within 5% of the target (the
/// equilibrium criterion's default tolerance is 1%); over the loading after its first tenth, the
/// side walls within 10% of 20 kPa on average and 20% at every sample (the servo lags by
/// `n E' dt ε̇_lat` behind the sample's lateral strain rate, at most half the error a step for the
/// grains' modulus `E'`, and a rearrangement moves the stress faster than it follows: measured 6.5%
/// on average, 16.6% at the worst sample, one where the packing rearranged; at a strain rate of 2/s
/// the worst was 18%); the axial stress above the lateral one (ζ = q/p > 0.1 at the end: frictional
/// grains resist the deviator); Love–Weber p within 10% of the walls' mean stress; no inverted
/// point. Measured 2026-12-06 (quasi-static steps): prepared Φ 0.787 at 20.0 kPa, ζ 0.58 at 3%
/// axial strain, side walls 4.4% off on average and 7.7% at worst (inertial steps, 2026-11-26:
/// Φ 0.791, ζ 0.48, 6.5% and 16.6%); about half a minute.
#[test]
fn soft_grains_go_through_a_biaxial_test() {
    let (samples, result) = run_scene(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/mpm_biaxial_2d.json"), |_| {});
    let result = result.expect("experiment results");
    let prepared = result.prepared.as_ref().expect("prepared state");
    let last = samples.last().expect("samples");
    let loading: Vec<&Sample> = samples.iter().filter(|s| s.stage.as_deref() == Some("loading")).collect();
    let side = |s: &Sample| s.walls.iter().find(|w| w.name == "x_max").map(|w| w.normal_stress).expect("x_max");
    let top = |s: &Sample| s.walls.iter().find(|w| w.name == "y_max").map(|w| w.normal_stress).expect("y_max");
    let after = &loading[loading.len() / 10..];
    let worst_side = after.iter().map(|s| (side(s) / 2e4 - 1.0).abs()).fold(0.0, f64::max);
    let mean_side = after.iter().map(|s| (side(s) / 2e4 - 1.0).abs()).sum::<f64>() / after.len() as f64;
    let walls_p = 0.5 * (side(last) + top(last));
    let d = last.deformable.as_ref().expect("deformable sample");
    eprintln!(
        "prepared Φ {:.4} Z {:.3} p {:.4e}; end: Φ {:.4} ζ {:.3} p {:.4e} (walls {:.4e}), side walls mean {mean_side:.3} worst {:.3}, J_min {:.3}, {} samples ({} loading), peak {:?}",
        prepared.phi, prepared.z, prepared.p, last.phi, last.zeta, last.p, walls_p, worst_side, d.min_jacobian, samples.len(), loading.len(), result.peak
    );
    assert!((prepared.p / 2e4 - 1.0).abs() < 0.05, "prepared p {}", prepared.p);
    assert!(mean_side < 0.1, "side walls off their 20 kPa by {mean_side:.3} on average");
    assert!(worst_side < 0.2, "side walls off their 20 kPa by {worst_side:.3}");
    assert!(last.zeta > 0.1, "ζ {}", last.zeta);
    assert!(last.mu.is_none(), "no shear plane in a biaxial test, so no τ/σ_n: {:?}", last.mu);
    assert!((last.p / walls_p - 1.0).abs() < 0.1, "Love–Weber p {} against the walls' {}", last.p, walls_p);
    assert!(d.min_jacobian > 0.0);
}

type Traced = (Sample, sable_engine::methods::soft::parts::Cost, Vec<sable_engine::methods::soft::trace::NewtonRecord>);

/// The CI compaction (`scenes/mpm_compaction_2d.json`) with elastoplastic grains (σ_y 0.4 MPa,
/// H 1 MPa, the sources' plastic law), `symmetric_contact` as given (`None`: the default),
/// run to its end by the scene's runner; its last sample, what its steps cost, and the Newton
/// trace when `trace`.
fn plastic_compaction(sides: Option<bool>, trace: bool) -> Traced {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/mpm_compaction_2d.json");
    let mut value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).expect("scene file")).expect("json");
    value["materials"]["rubber"]["deformable"] = serde_json::json!({
        "law": "elastoplastic", "young_modulus": 1.0e7, "poisson_ratio": 0.45, "yield_stress": 4.0e5, "hardening": 1.0e6
    });
    if let Some(both) = sides {
        value["method"]["symmetric_contact"] = both.into();
    }
    let scene = sable_engine::methods::plan_scene(&value.to_string()).expect("valid scene");
    let Some(params) = scene.params::<sable_engine::methods::mpm::MpmParams>() else { panic!("mpm scene") };
    let mut sim = sable_engine::methods::mpm::sim::mpm(&scene, params).expect("buildable");
    let records = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    if trace {
        let into = records.clone();
        assert!(sable_engine::run::Simulation::trace_newton(&mut sim, Box::new(move |r| into.lock().expect("lock").push(r.clone()))));
    }
    let runner = sable_engine::run::Runner::for_scene(&scene);
    let mut last = None;
    runner.run(&mut sim, &mut |s, _| last = Some(s.clone())).expect("stable");
    let cost = sim.cost();
    drop(sim);
    let records = std::mem::take(&mut *records.lock().expect("lock"));
    (last.expect("samples"), cost, records)
}

/// The plastic compaction with the default sides and its trace, run once for the tests that
/// read it.
fn plastic_compaction_by_default() -> &'static Traced {
    static RUN: std::sync::OnceLock<Traced> = std::sync::OnceLock::new();
    RUN.get_or_init(|| plastic_compaction(None, true))
}

/// Plastic grains keep the dents their contacts press in, and one-sided contacts let the
/// other grain's outline into them (`methods::mpm::contact`): `mpm` holds both outlines by
/// default when a grain's law is plastic. The CI compaction of plastic grains: with the
/// default the outlines cover less than a tenth of what they cover one-sided. Measured
/// (2026-12-06, quasi-static steps): Φ 0.9002 at σ_yy 325 kPa with no measurable overlap;
/// one-sided Φ 0.9007 with 0.20% of the box covered twice (inertial steps, 2026-11-29: 345 kPa,
/// one-sided 4.4%).
#[test]
fn plastic_grains_hold_both_outlines_by_default() {
    let (both, _, _) = plastic_compaction_by_default();
    let (one, _, _) = plastic_compaction(Some(false), false);
    let overlap = |s: &Sample| s.deformable.as_ref().expect("deformable sample").interpenetration;
    eprintln!(
        "plastic CI compaction: default Φ {:.4} overlap {:.5}, Love–Weber σ_yy {:.4e} Pa; one-sided Φ {:.4} overlap {:.5}",
        both.phi,
        overlap(both),
        both.stress.yy,
        one.phi,
        overlap(&one)
    );
    assert!(both.phi >= 0.9 && one.phi >= 0.9);
    assert!(overlap(both) < 0.1 * overlap(&one), "default {} against one-sided {}", overlap(both), overlap(&one));
}

/// `sable run --trace`'s records account for every Newton iteration: on the plastic CI
/// compaction, each part ends with one record (converged, or failed with the cause the
/// splitting counted), the iterations and sweeps of the converged parts sum to the method's
/// totals, a converged part's last correction is within Newton's tolerance (1e-5) and the
/// earlier ones are not, and the points' switching between elastic and plastic is reported.
/// The grains whose matrices were damped to make them definite are counted at every
/// iteration, at most the twelve grains, and an iteration that keeps the matrices keeps the
/// count of the one before. Each iteration says whether its correction turned back on the
/// previous one (never the first). The fraction of the correction each iteration takes follows
/// `mpm`'s rule (`CYCLE_RATE`, `REVERSAL`, `MIN_FRACTION`): halved (down to 1/16) after one
/// that shrank the correction by less than 0.9 while points switched or, in the deepest split,
/// while it turned back; doubled (up to 1) after one that shrank it below 0.6; else kept.
#[test]
fn the_newton_trace_accounts_for_every_iteration() {
    let (_, cost, records) = plastic_compaction_by_default();
    let (mut newton, mut sweeps, mut parts, mut failed) = (0u64, 0u64, 0u64, std::collections::BTreeMap::<String, u64>::new());
    let mut part: Vec<&sable_engine::methods::soft::trace::NewtonRecord> = Vec::new();
    let (mut switched, mut damped, mut reversed, mut halved_on_reversal) = (0usize, 0usize, 0usize, 0usize);
    // The parts of the deepest split, the last chance ([`sable_engine::methods::soft::parts`]).
    let longest = records.iter().map(|r| r.dt).fold(0.0, f64::max);
    let deepest = longest / f64::from(1u32 << sable_engine::methods::soft::parts::MAX_DEPTH);
    for r in records {
        let Some(end) = &r.end else {
            assert_eq!(r.iteration as usize, part.len() + 1, "iterations numbered within a part: {r:?}");
            switched += r.switching.expect("mpm reports switching points");
            let d = r.damped_grains.expect("mpm reports damped grains");
            assert!(d <= 12, "{r:?}");
            if r.refreshed == Some(false) {
                let before = part.last().expect("the first iteration assembles the matrices");
                assert_eq!(before.damped_grains, Some(d), "kept matrices, another count: {r:?}");
            }
            damped += d;
            let turned = r.reversed.expect("mpm reports reversals");
            assert!(!(turned && r.iteration == 1), "the first iteration has nothing to turn back on: {r:?}");
            reversed += usize::from(turned);
            if let [.., before2, before] = part.as_slice() {
                // The fraction the iteration after `before` takes.
                let rate = before.correction.unwrap_or(0.0) / before2.correction.unwrap_or(f64::INFINITY);
                let was = before.fraction.expect("mpm reports the fraction");
                let last_chance = r.dt <= deepest * (1.0 + 1e-12);
                let cycle = before.switching.unwrap_or(0) > 0 || (before.reversed == Some(true) && last_chance);
                let expected = if rate >= 0.9 && cycle {
                    (0.5 * was).max(1.0 / 16.0)
                } else if rate < 0.6 {
                    (2.0 * was).min(1.0)
                } else {
                    was
                };
                assert_eq!(r.fraction, Some(expected), "after rate {rate}, last chance {last_chance}: {before:?} then {r:?}");
                halved_on_reversal += usize::from(expected < was && before.switching == Some(0));
            }
            part.push(r);
            continue;
        };
        assert_eq!(r.iteration as usize, part.len(), "the end record counts the part's iterations: {r:?}");
        assert_eq!(r.sweeps as usize, part.iter().map(|p| p.sweeps as usize).sum::<usize>(), "{r:?}");
        assert!(part.iter().all(|p| p.step == r.step && p.dt == r.dt && p.time == r.time), "{r:?}");
        if end == "converged" {
            parts += 1;
            newton += u64::from(r.iteration);
            sweeps += u64::from(r.sweeps);
            let (last, earlier) = part.split_last().expect("a converged part iterated");
            assert!(last.correction.is_some_and(|c| c <= 1e-5), "{last:?}");
            assert!(earlier.iter().all(|p| p.correction.is_some_and(|c| c > 1e-5)), "{earlier:?}");
        } else {
            let kind = end.split(':').next().unwrap_or_default().to_string();
            *failed.entry(kind).or_default() += 1;
        }
        part.clear();
    }
    eprintln!(
        "trace: {} records, {parts} parts, {newton} Newton iterations, {sweeps} sweeps, failed {failed:?}, {switched} switches, {damped} damped grain-iterations, {reversed} reversals ({halved_on_reversal} halved the fraction)",
        records.len()
    );
    assert!(part.is_empty(), "a part without its end record");
    assert_eq!((parts, newton, sweeps), (cost.parts, cost.newton, cost.sweeps));
    let counted: std::collections::BTreeMap<String, u64> = cost.failures.iter().map(|(k, n)| (k.to_string(), *n)).collect();
    assert_eq!(failed, counted);
    assert!(switched > 0, "plastic grains yield somewhere in the compaction");
}
