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
//! How close the values must be depends on what the checkpoint loses. A frictionless DEM
//! packing loses nothing that its next step reads (positions, velocities, the box; forces are
//! recomputed from positions), so only the order of sums changes (the resumed run sorts its
//! particles anew): its samples agree to rounding amplified by the packing's chaos over the
//! steps left. Frictional contacts lose their tangential springs, so the resumed run slips a
//! little where the first one stuck: its samples agree to a few per cent.

use crate::common;

use sable_engine::methods::plan_scene;
use sable_engine::observe::Sample;
use sable_engine::resume::Checkpoint;
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
    twins_at(scene, |_| at)
}

/// As [`twins`], the checkpoint's step chosen from the run never stopped.
fn twins_at(scene: Value, at: impl FnOnce(&(Vec<Sample>, RunSummary)) -> u64) -> Twins {
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
    let checkpoint = Checkpoint::from_json(&saved.expect("a checkpoint was taken")).expect("checkpoint from JSON");
    assert_eq!(checkpoint.samples as usize, before.len(), "the checkpoint counts the samples before it");

    // The run of the next worker, from the checkpoint.
    let resumed_plan = plan_scene(&checkpoint.scene_to_resume(&scene.to_string()).expect("scene")).expect("the scene to resume is valid");
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
    // Measured 2026-12-07: 7e-10 at the first sample after the checkpoint (250 steps on), then
    // growing as the packing's chaos amplifies it, to 1.4e-5 at the end (3,000 steps on).
    let next = a.iter().position(|s| s.step > t.checkpoint_step).expect("samples after the checkpoint");
    let first = largest_difference(&a[next..=next], &b[next..=next], |s| s.kinetic_energy);
    assert!(first < 1e-8, "kinetic energy 250 steps after the checkpoint differs by {first:e}");
    let phi = largest_difference(a, b, |s| s.phi);
    let ke = largest_difference(a, b, |s| s.kinetic_energy);
    assert!(phi < 1e-9, "packing fraction differs by {phi:e}");
    assert!(ke < 1e-4, "kinetic energy differs by {ke:e} of its largest value");
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
/// gas of grains is chaotic: the first sample after the checkpoint agrees to 1e-7 in packing
/// fraction (measured 2026-12-07: 1.1e-7, 500 steps on), later ones drift apart, and the
/// preparation ends at another step; the results then differ as two preparations would.
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
    assert!(phi < 1e-6, "packing fraction after the checkpoint differs by {phi:e}");
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
    let t = twins_at(scene, |(_, summary)| summary.steps - every);
    assert_eq!(t.whole.1.reason, sable_engine::run::StopReason::Equilibrium, "the run never stopped came to rest");
    assert_eq!(t.checkpoint_step, t.whole.1.steps - every);
    assert_eq!(t.checkpoint_settled, 1, "the checks passed in a row before the checkpoint's step");
    assert_same_steps(&t);
}

/// Contact dynamics keeps each contact's impulse from one step to the next as the next
/// solve's warm start, and sorts its grains anew when built from a state: a run resumed from
/// a checkpoint solves its first steps from a cold start, in another order, and the NLGS
/// converges to other impulses within its tolerance. In a settling deposit those differences
/// grow as any perturbation of a granular gas does. So the resumed run is held, first, to its
/// first sample after the checkpoint (200 steps on), where the difference has had little time
/// to grow: kinetic energy, mean stress and coordination within 1e-4 of the run never stopped
/// (measured on 2026-12-07: 1.1e-6, 6.9e-7 and 0, relative to the largest value). Then, over
/// the rest of the deposit, its kinetic energy and mean stress must differ from the run never
/// stopped by less than a run from another seed does (measured: 0.009 against 0.29, 0.22
/// against 0.82): the checkpoint is no larger a perturbation than a different initial gas.
/// The coordination of two deposits decorrelates whatever the perturbation (0.15 against
/// 0.14), so it is held at the first sample only.
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
    type Field = (&'static str, fn(&Sample) -> f64, bool);
    let fields: [Field; 3] =
        [("kinetic energy", |s| s.kinetic_energy, true), ("mean stress", |s| s.p, true), ("coordination", |s| s.z, false)];
    for (name, f, whole_deposit) in fields {
        let first = largest_difference(&a[next..=next], &b[next..=next], f);
        let resumed = largest_difference(&a[next..], &b[next..], f);
        let seeds = largest_difference(&a[next..], &other[next..], f);
        eprintln!("{name}: first sample after the checkpoint {first:e}, resumed {resumed:e}, another seed {seeds:e}");
        assert!(first < 1e-4, "{name}: the first sample after the checkpoint differs by {first:e}");
        if whole_deposit {
            assert!(resumed < seeds, "{name}: the resumed run differs by {resumed:e}, a run of another seed by {seeds:e}");
        }
    }
}
