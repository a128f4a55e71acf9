//! Checkpoints (`engine/src/resume.rs`): a run stopped after a checkpoint and resumed from it
//! takes the same samples, at the same steps, as the run that was never stopped, and ends with
//! the same results, up to what a saved state does not hold.
//!
//! Each test runs a scene twice. The first run is never stopped. The second asks for a
//! checkpoint once a sample at or past `at` is taken and is cancelled at the same moment, as a
//! worker killed right after storing it would be; the checkpoint goes through its JSON text,
//! and a third simulation, built from it, goes on with the samples before it. The samples the
//! two runs report together must be the first run's steps, each once.
//!
//! How close the values must be depends on what the checkpoint loses. DEM and contact dynamics
//! lose nothing their next step reads: the checkpoint carries, beside the state, the grains
//! glued to the walls, the contacts' springs or impulses, the loads of the last evaluation, the
//! time step and the walls' gains, and the resumed run keeps the particles' order and the
//! original scene's loading program. Only the order of some sums changes (the neighbour list
//! is built at another step), so the samples agree to rounding, amplified by the packing's
//! chaos over the steps left. FEM loses its contacts' impulses (the warm start of its solver):
//! its samples agree to rounding until grains strike each other.

use crate::common;

use sable_engine::methods::plan_scene;
use sable_engine::observe::Sample;
use sable_engine::resume::{Carried, Checkpoint};
use sable_engine::run::{Resume, RunSummary, Runner};
use serde_json::{json, Value};
use std::sync::atomic::Ordering;

/// The samples and summary of a run never stopped, and of the same run stopped after a
/// checkpoint taken at the first sample at or past step `at` and resumed from it (the samples
/// of both parts), with the step of the checkpoint.
struct Twins {
    whole: (Vec<Sample>, RunSummary),
    resumed: (Vec<Sample>, RunSummary),
    checkpoint_step: u64,
    /// The equilibrium checks passed in a row when the checkpoint was taken.
    checkpoint_settled: u32,
}

fn twins(scene: Value, at: u64) -> Twins {
    twins_at(scene, |_| at, true)
}

/// As [`twins`], the checkpoint's step chosen from the run never stopped; without `carry`, the
/// resumed run is built as a scene's `start_from` is and what the checkpoint carried beside the
/// state (glued grains, contact history) is dropped, as a checkpoint of version 1 had it.
fn twins_at(scene: Value, at: impl FnOnce(&(Vec<Sample>, RunSummary)) -> u64, carry: bool) -> Twins {
    let plan = common::scene(scene.clone());
    let runner = Runner::for_scene(&plan);
    let mut whole = Vec::new();
    let mut sim = plan.build().expect("build");
    let summary = runner.run(sim.as_mut(), &mut |s, _| whole.push(s.clone())).expect("run");
    let whole = (whole, summary);
    let at = at(&whole);

    // The run a worker was running: asked for a checkpoint and stopped at the same moment.
    let runner = Runner::for_scene(&plan);
    let (ask, stop) = (runner.checkpoint.clone(), runner.cancel.clone());
    let mut before = Vec::new();
    let mut saved = None;
    let mut sim = plan.build().expect("build");
    let stopped = runner.run_resumable(
        sim.as_mut(),
        None,
        &mut |s, _| {
            before.push(s.clone());
            if s.step >= at {
                ask.store(true, Ordering::SeqCst);
                stop.store(true, Ordering::SeqCst);
            }
        },
        &mut |_| {},
        &mut |c| saved = Some(serde_json::to_string(c).expect("checkpoint to JSON")),
    );
    assert!(matches!(stopped, Err(sable_engine::EngineError::Cancelled { .. })), "the run was not stopped: {stopped:?}");
    let mut checkpoint = Checkpoint::from_json(&saved.expect("a checkpoint was taken")).expect("checkpoint from JSON");
    assert_eq!(checkpoint.samples as usize, before.len(), "the checkpoint counts the samples before it");

    // The run of the next worker, from the checkpoint.
    let mut resumed_plan =
        plan_scene(&checkpoint.scene_to_resume(&scene.to_string()).expect("scene")).expect("the scene to resume is valid");
    if carry {
        resumed_plan.continue_saved_run(&plan);
    } else {
        checkpoint.carried = Carried::default();
    }
    let runner = Runner::for_scene(&resumed_plan);
    let mut sim = resumed_plan.build().expect("build from the checkpoint");
    let mut after = Vec::new();
    let summary = runner
        .run_resumable(
            sim.as_mut(),
            Some(Resume { checkpoint: &checkpoint, samples: &before }),
            &mut |s, _| after.push(s.clone()),
            &mut |_| {},
            &mut |_| {},
        )
        .expect("resumed run");
    before.extend(after);
    Twins { whole, resumed: (before, summary), checkpoint_step: checkpoint.clock.steps, checkpoint_settled: checkpoint.settled }
}

fn file(path: &str, edit: impl FnOnce(&mut Value)) -> Value {
    let full = format!("{}/../{path}", env!("CARGO_MANIFEST_DIR"));
    let mut v: Value = serde_json::from_str(&std::fs::read_to_string(full).expect("scene file")).expect("json");
    edit(&mut v);
    v
}

fn steps(samples: &[Sample]) -> Vec<u64> {
    samples.iter().map(|s| s.step).collect()
}

/// Largest relative difference of `f` over the two runs' samples, against the largest
/// magnitude of `f` in the first.
fn largest_difference(a: &[Sample], b: &[Sample], f: impl Fn(&Sample) -> f64) -> f64 {
    let scale = a.iter().map(|s| f(s).abs()).fold(0.0, f64::max).max(1e-300);
    a.iter().zip(b).map(|(x, y)| (f(x) - f(y)).abs() / scale).fold(0.0, f64::max)
}

fn assert_same_steps(t: &Twins) {
    assert_eq!(steps(&t.whole.0), steps(&t.resumed.0), "the samples' steps (checkpoint at step {})", t.checkpoint_step);
    assert_eq!(t.whole.1.steps, t.resumed.1.steps);
    assert_eq!(t.whole.1.reason, t.resumed.1.reason);
}

#[test]
fn a_frictionless_compaction_resumes_to_rounding() {
    let scene = json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"disks": common::linear_material(1.0e5, 0.5, 0.0)},
        "particles": [{"material": "disks", "count": 120, "size": {"kind": "uniform", "min": 8.0e-4, "max": 1.2e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.015, 0.015], "wall_material": "disks"},
        "gravity": [0, -9.81],
        "stop": {"steps": 6000},
        "sampling": {"every_steps": 250},
        "seed": 3
    });
    let t = twins(scene, 3000);
    assert_same_steps(&t);
    assert_eq!(t.checkpoint_step, 3000);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    // Measured 2026-12-07: 3.4e-16 at the first sample after the checkpoint (250 steps on),
    // 3.2e-12 at most over the 3,000 steps left; Φ identical (before the particles kept their
    // order: 7e-10, then 1.4e-5 at the end).
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    let first = largest_difference(&a[next..=next], &b[next..=next], |s| s.kinetic_energy);
    assert!(first < 1e-12, "kinetic energy 250 steps after the checkpoint differs by {first:e}");
    let phi = largest_difference(a, b, |s| s.phi);
    let ke = largest_difference(a, b, |s| s.kinetic_energy);
    assert!(phi < 1e-12, "packing fraction differs by {phi:e}");
    assert!(ke < 1e-9, "kinetic energy differs by {ke:e} of its largest value");
}

/// MPM's saved state holds every material point (position, velocity, deformation gradient):
/// nothing its next step reads is lost. Measured 2026-12-07: 2.3e-8 of the largest pressure.
#[test]
fn an_mpm_compaction_resumes_to_rounding() {
    let scene = file("scenes/mpm_compaction_2d.json", |v| {
        v["stop"] = json!({"steps": 600});
        v["sampling"] = json!({"every_steps": 50});
    });
    let t = twins(scene, 300);
    assert_same_steps(&t);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    for (name, d) in
        [("phi", largest_difference(a, b, |s| s.phi)), ("p", largest_difference(a, b, |s| s.p)), ("q", largest_difference(a, b, |s| s.q))]
    {
        assert!(d < 1e-6, "{name} differs by {d:e} of its largest value");
    }
}

/// FEM's saved state holds each mesh's displacements and velocities; its contacts' impulses
/// start afresh. Measured 2026-12-07: the samples agree to 1e-9 until a grain strikes
/// another (step 450), where the lost warm start shows: 3.2% of the largest pressure at the
/// impact, 0.6% at the end.
#[test]
fn an_fem_compaction_resumes_until_an_impact_then_within_per_cents() {
    let scene = file("scenes/fem_compaction_2d.json", |v| {
        v["stop"] = json!({"steps": 600});
        v["sampling"] = json!({"every_steps": 50});
    });
    let t = twins(scene, 300);
    assert_same_steps(&t);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    let calm = a.iter().take_while(|s| s.step <= 400).count();
    let before_impact = largest_difference(&a[..calm], &b[..calm], |s| s.p);
    assert!(before_impact < 1e-7, "pressure differs by {before_impact:e} before the impact");
    let whole = largest_difference(a, b, |s| s.p);
    assert!(whole < 0.05, "pressure differs by {whole:e} of its largest value");
    let last = (a.last().expect("samples").p - b.last().expect("samples").p).abs() / a.last().expect("samples").p;
    assert!(last < 0.02, "final pressure differs by {last:e}");
}

/// A checkpoint within a staged experiment: taken during the preparation of a biaxial test
/// (stress-controlled walls compressing a gas of grains), the resumed run goes on with the
/// walls' servos where they were, through the loading stage, to the experiment's results. A
/// gas of grains is chaotic: the first sample after the checkpoint agrees to rounding in
/// packing fraction (measured 2026-12-07: 4.3e-16, 500 steps on), later ones drift apart over
/// the 70,000 steps left, and the preparation ends at another step (89,273 and 93,773); the
/// results then differ as two preparations would.
#[test]
fn a_biaxial_test_resumes_from_its_preparation_to_its_results() {
    let scene = file("scenes/biaxial_test_2d.json", |v| {
        v["particles"][0]["count"] = json!(100);
        v["container"]["max"] = json!([0.015, 0.015]);
        v["experiment"]["axial_strain"] = json!(0.05);
        v["sampling"] = json!({"every_steps": 500});
    });
    let t = twins(scene, 20_000);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    assert_eq!(a[next].step, b[next].step);
    let phi = (a[next].phi - b[next].phi).abs() / a[next].phi;
    assert!(phi < 1e-12, "packing fraction after the checkpoint differs by {phi:e}");
    // Each sample once, in order, named by its stage; both stages ran.
    assert!(b.windows(2).all(|w| w[0].step < w[1].step || w[0].stage != w[1].stage && w[0].step == w[1].step), "steps out of order");
    let stages: Vec<_> = b.iter().filter_map(|s| s.stage.clone()).collect();
    assert!(stages.contains(&"preparation".to_string()) && stages.contains(&"loading".to_string()), "stages {stages:?}");
    let result = serde_json::to_value(t.resumed.1.result.expect("the experiment's results")).expect("JSON");
    let whole = serde_json::to_value(t.whole.1.result.expect("the experiment's results")).expect("JSON");
    for r in [&result, &whole] {
        let p = r["prepared"]["p"].as_f64().expect("prepared p");
        assert!((p - 100.0).abs() < 1.0, "prepared at {p} Pa, not 100");
        let peak = r["peak"]["zeta"].as_f64().expect("peak");
        assert!(peak > 0.3 && peak < 0.7, "peak stress ratio {peak}");
    }
}

/// The equilibrium checks a stage has passed in a row go into the checkpoint, and the check
/// due at the checkpoint's step is made once, by the resumed run: a preparation that needs
/// three passed checks in a row, resumed at the step of its second (one passed, two to come),
/// comes to rest at the same step as the run never stopped. (A checkpoint taken after that
/// step's check counted it twice, and the resumed preparation ended one check early.)
/// Frictionless disks lose nothing to the checkpoint, and 500 steps leave the two runs within
/// rounding of each other.
#[test]
fn a_preparation_resumed_between_its_equilibrium_checks_comes_to_rest_at_the_same_step() {
    let every = 500;
    let scene = json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"disks": common::linear_material(1.0e5, 0.5, 0.0)},
        "particles": [{"material": "disks", "count": 80, "size": {"kind": "uniform", "min": 8.0e-4, "max": 1.2e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.015, 0.015], "wall_material": "disks"},
        "experiment": {"kind": "isotropic",
                       "preparation": {"pressure": 100.0, "equilibrium": {"check_every": every, "consecutive": 3}}},
        "sampling": {"every_steps": every},
        "seed": 5
    });
    // The last sample before the check that ended the preparation.
    let t = twins_at(scene, |(_, summary)| summary.steps - every, true);
    assert_eq!(t.whole.1.reason, sable_engine::run::StopReason::Equilibrium, "the run never stopped came to rest");
    assert_eq!(t.checkpoint_step, t.whole.1.steps - every);
    assert_eq!(t.checkpoint_settled, 1, "the checks passed in a row before the checkpoint's step");
    assert_same_steps(&t);
}

/// Contact dynamics keeps each contact's impulse from one step to the next as the next
/// solve's warm start: the checkpoint carries them, and the resumed run keeps its grains'
/// order, so its first solves start where the run never stopped started them. Its first
/// sample after the checkpoint (200 steps on) agrees to rounding (measured on 2026-12-07:
/// 1.2e-16, 3.3e-16 and 0 for kinetic energy, mean stress and coordination; 1.1e-6, 6.9e-7
/// and 0 when the warm start was lost and the grains sorted anew). In a settling deposit even
/// rounding grows as any perturbation of a granular gas does: over the rest of the deposit, the
/// kinetic energy and mean stress must differ from the run never stopped by less than a run
/// from another seed does (measured: 0.005 against 0.29, 0.37 against 0.82). The coordination
/// of two deposits decorrelates whatever the perturbation (0.12 against 0.14), so it is held at
/// the first sample only.
#[test]
fn a_cd_deposition_resumes_within_what_tells_two_deposits_apart() {
    let deposit = |seed: u64| {
        file("scenes/quickstart_cd.json", |v| {
            v["particles"][0]["count"] = json!(80);
            v["particles"][0]["placement"]["region"]["max"] = json!([0.02, 0.012]);
            v["stop"] = json!({"steps": 2400});
            v["sampling"] = json!({"every_steps": 200});
            v["seed"] = json!(seed);
        })
    };
    let t = twins(deposit(1), 1200);
    assert_same_steps(&t);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    let other = {
        let plan = common::scene(deposit(2));
        let mut samples = Vec::new();
        let mut sim = plan.build().expect("build");
        Runner::for_scene(&plan).run(sim.as_mut(), &mut |s, _| samples.push(s.clone())).expect("run");
        samples
    };
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    let fields: [(Field, bool); 3] = [(KINETIC_ENERGY, true), (MEAN_STRESS, true), (("coordination", |s| s.z), false)];
    for ((name, f), whole_deposit) in fields {
        let first = largest_difference(&a[next..=next], &b[next..=next], f);
        let resumed = largest_difference(&a[next..], &b[next..], f);
        let seeds = largest_difference(&a[next..], &other[next..], f);
        assert!(first < 1e-12, "{name}: the first sample after the checkpoint differs by {first:e}");
        if whole_deposit {
            assert!(resumed < seeds, "{name}: the resumed run differs by {resumed:e}, a run of another seed by {seeds:e}");
        }
    }
}

/// The step of the `k`-th sample of the last stage of a run.
fn into_last_stage(samples: &[Sample], k: usize) -> u64 {
    let last = samples.last().expect("samples").stage.clone();
    let first = samples.iter().position(|s| s.stage == last).expect("the last stage's samples");
    samples[first + k].step
}

/// A quantity of the samples, by name.
type Field = (&'static str, fn(&Sample) -> f64);
const KINETIC_ENERGY: Field = ("kinetic energy", |s| s.kinetic_energy);
const MEAN_STRESS: Field = ("mean stress", |s| s.p);
const PHI: Field = ("phi", |s| s.phi);

/// The first sample after the checkpoint, and the whole run after it, of `f`: how far the
/// resumed run is from the run never stopped.
fn after_checkpoint(t: &Twins, f: impl Fn(&Sample) -> f64 + Copy) -> (f64, f64) {
    let (a, b) = (&t.whole.0, &t.resumed.0);
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    (largest_difference(&a[next..=next], &b[next..=next], f), largest_difference(&a[next..], &b[next..], f))
}

/// Frictional disks carry tangential and rolling springs from step to step: a checkpoint
/// carries them, and the resumed run goes on from the same springs, in the same particle
/// order. Its samples agree with the run never stopped to rounding (measured 2026-12-07: kinetic
/// energy 3.4e-16 at the first sample after the checkpoint and 7.4e-13 over the 3,000 steps
/// left, mean stress 2.3e-14 and 1.7e-11); the same run resumed without them (as a
/// `start_from` is, and as checkpoints of version 1 were) slips where the springs held: 8.5e-4
/// and 2.6e-2, mean stress 5.2e-2 and 0.40.
#[test]
fn a_frictional_compaction_resumes_with_its_springs() {
    let scene = json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": {"disks": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1.0e5}, "restitution": 0.5,
                                "friction": 0.5, "rolling": {"stiffness": 1.0e-6, "friction": 0.1}}},
        "particles": [{"material": "disks", "count": 120, "size": {"kind": "uniform", "min": 8.0e-4, "max": 1.2e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.015, 0.015], "wall_material": "disks"},
        "gravity": [0, -9.81],
        "stop": {"steps": 6000},
        "sampling": {"every_steps": 250},
        "seed": 3
    });
    let carried = twins(scene.clone(), 3000);
    let dropped = twins_at(scene, |_| 3000, false);
    for t in [&carried, &dropped] {
        assert_same_steps(t);
        assert_eq!(t.checkpoint_step, 3000);
    }
    for (name, f) in [KINETIC_ENERGY, MEAN_STRESS] {
        let (with, with_whole) = after_checkpoint(&carried, f);
        let (without, _) = after_checkpoint(&dropped, f);
        assert!(with < 1e-12 && with_whole < 1e-9, "{name} differs by {with:e} at the first sample, {with_whole:e} over the run");
        assert!(without > 1e-5, "{name}: without its springs the resumed run differs by only {without:e}");
    }
}

/// Grains glued to rough walls go into the checkpoint (a checkpoint of version 1 could not
/// say which grains were, and none was taken): the shear resumes with the same walls, at the
/// shear rate of the original scene. Measured 2026-12-07, 2,000 steps into the shear: the first
/// sample after the checkpoint agrees to 8.4e-14 in kinetic energy, 2.9e-14 in mean stress and
/// 3.2e-14 in q. (A loading program planned from the state instead of the original scene
/// slides the wall 0.5% faster — its inertial number's shear rate comes from the state's
/// measured mean diameter, not the sets' nominal one — and the kinetic energy was off by 1.3e-4
/// ten steps on.) Over the 26,000 steps left the flow's chaos amplifies rounding to 10% in
/// kinetic energy, as it would any perturbation.
#[test]
fn a_shear_between_rough_walls_resumes_with_its_glued_grains() {
    let scene = file("scenes/plane_shear_rough_2d.json", |v| {
        v["particles"][0]["count"] = json!(100);
        v["container"]["max"] = json!([0.01, 0.02]);
        v["experiment"]["strain"] = json!(0.2);
        v["sampling"] = json!({"every_steps": 500});
    });
    let t = twins_at(scene, |(samples, _)| into_last_stage(samples, 4), true);
    assert_same_steps(&t);
    for (name, f) in [KINETIC_ENERGY, MEAN_STRESS, ("q", |s| s.q)] {
        let (first, _) = after_checkpoint(&t, f);
        assert!(first < 1e-10, "{name} differs by {first:e} at the first sample after the checkpoint");
    }
}

/// The bonded particle method by DEM: a checkpoint's aggregates are not relaxed again (they
/// were when the run began; relaxing them again, walls held and gravity off, would damp the
/// compaction's motion), and the compaction goes on where it was. Measured 2026-12-07: kinetic
/// energy 9.0e-12, mean stress 9.8e-10 at the first sample after the checkpoint (500 steps
/// on), 1.0e-11 and 1.7e-9 over the 2,000 steps left; Φ identical.
#[test]
fn a_bpm_compaction_resumes_without_relaxing_its_aggregates_again() {
    let scene = file("scenes/bpm_compaction_dem_2d.json", |v| {
        v["stop"] = json!({"steps": 4000});
        v["sampling"] = json!({"every_steps": 500});
    });
    let t = twins(scene, 2000);
    assert_same_steps(&t);
    for (name, f) in [KINETIC_ENERGY, MEAN_STRESS, PHI] {
        let (_, whole) = after_checkpoint(&t, f);
        assert!(whole < 1e-7, "{name} differs by {whole:e} after the checkpoint");
    }
}

/// A rotating drum: the grains' springs against the drum's rim go into the checkpoint, with
/// those between grains. Measured 2026-12-07, four samples into the rotation: the first sample
/// after the checkpoint agrees to 7.2e-14 in kinetic energy and 2.9e-13 in mean stress; without
/// the springs, 3.6e-4 and 4.2e-2. Over the 38,000 steps left the avalanches' chaos amplifies
/// either to 6–26%.
#[test]
fn a_drum_resumes_with_its_rim_contacts() {
    let scene = file("scenes/drum_2d.json", |v| {
        v["particles"][0]["count"] = json!(120);
        v["container"]["max"] = json!([0.02, 0.02]);
        v["experiment"]["revolutions"] = json!(0.1);
        v["experiment"]["transient"] = json!(0.05);
        v["sampling"] = json!({"every_steps": 1000});
    });
    let carried = twins_at(scene.clone(), |(samples, _)| into_last_stage(samples, 4), true);
    let dropped = twins_at(scene, |(samples, _)| into_last_stage(samples, 4), false);
    for t in [&carried, &dropped] {
        assert_same_steps(t);
    }
    for (name, f) in [KINETIC_ENERGY, MEAN_STRESS] {
        let (with, _) = after_checkpoint(&carried, f);
        let (without, _) = after_checkpoint(&dropped, f);
        assert!(with < 1e-10, "{name} differs by {with:e} at the first sample after the checkpoint");
        assert!(without > 1e-6, "{name}: without its springs the resumed run differs by only {without:e}");
    }
}

/// A wet granule in a drum (`scenes/drum_granulation_2d.json`, reduced): the granule the
/// samples' `cluster` follows, and the grains it gained and lost so far, go into the checkpoint
/// with the contacts' history (bridges included). The sample after the checkpoint has the same
/// followed cluster, accretion and erosion as the run never stopped; resumed without what the
/// checkpoint carried, the counts start again from nothing.
#[test]
fn a_drum_granule_resumes_with_its_followed_cluster() {
    let scene = file("scenes/drum_granulation_2d.json", |v| {
        v["particles"][0]["count"] = json!(19);
        v["particles"][0]["size"]["diameter"] = json!(1e-3);
        v["particles"][0]["placement"]["spacing"] = json!(0.9999e-3);
        v["particles"][0]["placement"]["within"] = json!({"center": [0.012, 0.0065], "radius": 2.8e-3});
        v["particles"][1]["count"] = json!(30);
        v["particles"][2]["count"] = json!(110);
        for set in 1..3 {
            v["particles"][set]["size"] = json!({"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3});
        }
        v["container"]["max"] = json!([0.024, 0.024]);
        v["experiment"]["revolutions"] = json!(0.15);
        v["experiment"]["transient"] = json!(0.05);
        v["sampling"] = json!({"every_steps": 1000});
    });
    let carried = twins_at(scene.clone(), |(samples, _)| into_last_stage(samples, 6), true);
    let dropped = twins_at(scene, |(samples, _)| into_last_stage(samples, 6), false);
    for t in [&carried, &dropped] {
        assert_same_steps(t);
    }
    let counts = |s: &Sample| s.cluster.as_ref().map(|c| (c.count, c.accreted, c.eroded)).expect("a wet cluster");
    let next = carried.whole.0.iter().position(|s| s.step > carried.checkpoint_step).expect("samples after the checkpoint");
    let before = counts(&carried.whole.0[next - 1]);
    assert!(before.1 + before.2 > 0, "the granule neither gained nor lost a grain before the checkpoint: {before:?}");
    assert_eq!(counts(&carried.resumed.0[next]), counts(&carried.whole.0[next]), "at the first sample after the checkpoint");
    let restarted = counts(&dropped.resumed.0[next]);
    assert!(restarted.1 + restarted.2 < before.1 + before.2, "without the checkpoint's cluster the counts start again: {restarted:?}");
}

/// Contact dynamics with stress-controlled walls: each wall is a plate whose mass the build
/// derives from the box (which the preparation shrinks) and whose velocity comes out of the
/// contact problem. The checkpoint carries the plates' mass and velocity, the step and the
/// contacts' impulses, and the biaxial test goes on from its preparation where it was.
/// Measured 2026-12-07, checkpoint at step 600 of the preparation: Φ 2.8e-16 and mean stress
/// 6.4e-15 at the next sample (100 steps on); with the plates' mass derived anew from the
/// shrunk box instead, 6.6e-4 and 28%, and the preparation ended 500 steps later.
#[test]
fn a_cd_biaxial_test_resumes_with_its_plates() {
    let scene = file("scenes/biaxial_test_2d.json", |v| {
        v["method"] = json!({"kind": "cd", "threads": 1});
        v["particles"][0]["count"] = json!(100);
        v["container"]["max"] = json!([0.015, 0.015]);
        v["experiment"]["axial_strain"] = json!(0.02);
        v["sampling"] = json!({"every_steps": 100});
    });
    let t = twins_at(scene, |(samples, _)| samples[samples.len() / 3].step, true);
    let (a, b) = (&t.whole.0, &t.resumed.0);
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    for (name, f) in [PHI, MEAN_STRESS] {
        let first = largest_difference(&a[next..=next], &b[next..=next], f);
        assert!(first < 1e-12, "{name} differs by {first:e} at the first sample after the checkpoint");
    }
}
