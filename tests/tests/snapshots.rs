//! Snapshots for ParaView: taken when asked (start, interval, end, never twice for one step),
//! and describing the same state as the samples.

use crate::common;

use sable_engine::observe::vtk::{particles_vtp, SnapshotSeries};
use sable_engine::run::Runner;
use serde_json::json;

fn deposition() -> sable_engine::methods::Plan {
    common::scene(json!({
        "dimension": 2,
        "method": {"kind": "dem", "local_damping": 0.3},
        "materials": {"m": common::linear_material(3e6, 0.2, 0.4)},
        "particles": [{"material": "m", "count": 60, "size": {"kind": "uniform", "min": 1e-3, "max": 1.4e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.012, 0.03], "periodic": ["x"], "wall_material": "m"},
        "gravity": [0, -9.81],
        "stop": {"time": 0.25},
        "sampling": {"every_steps": 40000},
        "seed": 3
    }))
}

#[test]
fn snapshots_come_at_the_start_the_interval_and_the_end() {
    let scene = deposition();
    for every in [Some(50000), Some(0), None] {
        let mut sim = common::dem(&scene);
        let mut runner = Runner::for_scene(&scene);
        runner.snapshot_every = every;
        let mut steps = Vec::new();
        let mut last = None;
        let summary = runner
            .run_with_snapshots(&mut sim, &mut |_, _| {}, &mut |s| {
                steps.push(s.step);
                last = Some(s.clone());
            })
            .expect("stable");
        // The start, every interval (a sample's when 0) before the end, and the end.
        let interval = match every {
            Some(0) => 40000,
            Some(n) => n,
            None => 0,
        };
        let end = summary.steps;
        let expected: Vec<u64> = match every {
            None => vec![],
            Some(_) => (0..end).step_by(interval as usize).chain([end]).collect(),
        };
        assert!(end > 120_000, "the run must cross several intervals, ran {end} steps");
        assert_eq!(steps, expected, "snapshot_every {every:?}");
        if let Some(last) = last {
            // The final snapshot is the final state: same coordination as the last sample, every
            // particle inside the box along the periodic axis, on the floor after deposition.
            let z = last.coordination();
            let mean = z.iter().map(|&k| k as f64).sum::<f64>() / z.len() as f64;
            assert!((mean - summary.last.z).abs() < 1e-12, "Z {mean} vs sample {}", summary.last.z);
            assert!(last.position.iter().all(|p| p.x >= last.lo.x && p.x < last.hi.x));
            assert!(last.walls.len() == 2 && last.walls.iter().any(|w| w.name == "y_min" && w.force.y < 0.0));
            let weight: f64 = sim.particles().mass.iter().sum::<f64>() * 9.81;
            let floor = last.walls.iter().find(|w| w.name == "y_min").map(|w| -w.force.y).unwrap_or(0.0);
            assert!((floor - weight).abs() < 0.05 * weight, "floor carries {floor} N of {weight} N");
            assert!(particles_vtp(&last).contains(r#"NumberOfPoints="60""#));
        }
    }
}

#[test]
fn a_series_on_disk_has_three_files_per_snapshot() {
    let scene = deposition();
    let dir = tempfile::tempdir().expect("temp dir");
    let mut series = SnapshotSeries::create(dir.path()).expect("series");
    let mut sim = common::dem(&scene);
    let mut runner = Runner::for_scene(&scene);
    runner.snapshot_every = Some(100_000);
    let summary = runner.run_with_snapshots(&mut sim, &mut |_, _| {}, &mut |s| series.push(s).expect("written")).expect("stable");
    // Steps 0 and 100,000, and the end (between 100,000 and 200,000).
    assert!(summary.steps > 100_000 && summary.steps < 200_000, "{} steps", summary.steps);
    assert_eq!(series.len(), 3);
    let files = std::fs::read_dir(dir.path()).expect("listing").count();
    assert_eq!(files, 3 * 3 + 1);
}
