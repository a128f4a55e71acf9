//! `sable run` as a user calls it (server/src/cli/run.rs, cli/trace.rs): the Newton trace of a
//! soft-grain run, a saved `mpm` state that another scene starts from by file, and the errors
//! for a trace of a method without Newton iterations and for a state whose points break a rule.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::{json, Value};

fn sable(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sable")).args(args).output().expect("sable runs")
}

/// The CI soft compaction (`scenes/mpm_compaction_2d.json`) stopped after `steps` steps.
fn soft_scene(steps: u64) -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/mpm_compaction_2d.json");
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("scene")).expect("json");
    scene["stop"] = json!({"steps": steps});
    scene
}

/// The same scene started from the state file `state` (relative to the scene file).
fn from_state(steps: u64, state: &str) -> Value {
    let mut scene = soft_scene(steps);
    scene["start_from"] = json!({"file": state});
    scene["particles"] = json!([]);
    scene["container"].as_object_mut().expect("container").retain(|k, _| k != "min" && k != "max");
    scene
}

fn write(dir: &Path, name: &str, v: &Value) -> String {
    let path = dir.join(name);
    std::fs::write(&path, v.to_string()).expect("write");
    path.to_string_lossy().into_owned()
}

fn lines(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path).expect("read").lines().map(|l| serde_json::from_str(l).expect("a JSON line")).collect()
}

/// A run of 40 steps writes one trace record per Newton iteration and one end record per step
/// part (each part ends converged here, and the parts cover the 40 steps), and a state with
/// the grains' points; a scene started from that file goes on from the same packing fraction.
#[test]
fn a_soft_run_traces_newton_and_goes_on_from_its_saved_points() {
    let dir = tempfile::tempdir().expect("dir");
    let scene = write(dir.path(), "first.json", &soft_scene(40));
    let (trace, state) = (dir.path().join("trace.jsonl"), dir.path().join("state.json"));
    let out = sable(&["run", &scene, "--format", "jsonl", "--trace", &trace.to_string_lossy(), "--save-state", &state.to_string_lossy()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let records = lines(&trace);
    let ends: Vec<&Value> = records.iter().filter(|r| r.get("end").is_some()).collect();
    let iterations = records.len() - ends.len();
    assert!(ends.iter().all(|r| r["end"] == "converged"), "a part failed: {ends:?}");
    assert!(ends.len() >= 40, "{} parts for 40 steps", ends.len());
    assert!(iterations >= ends.len(), "{iterations} iterations for {} parts", ends.len());
    assert_eq!(ends.last().expect("an end")["step"], 40);
    // Every part's iterations are numbered from 1 without a gap, and its end follows them.
    let mut next = 1;
    for r in &records {
        if r.get("end").is_some() {
            assert!(next > 1, "a part ended before any iteration: {r}");
            next = 1;
        } else {
            assert_eq!(r["iteration"], next, "{r}");
            next += 1;
        }
    }
    let samples: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|v| v.get("phi").is_some())
        .collect();
    let last_phi = samples.last().expect("samples")["phi"].as_f64().expect("phi");
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&state).expect("state")).expect("json");
    assert!(saved["material_points"]["position"].as_array().is_some_and(|p| !p.is_empty()), "no points saved");

    let second = write(dir.path(), "second.json", &from_state(5, "state.json"));
    let out = sable(&["run", &second, "--format", "jsonl"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let first: Value = String::from_utf8_lossy(&out.stdout).lines().find_map(|l| serde_json::from_str(l).ok()).expect("a sample");
    let phi = first["phi"].as_f64().expect("phi");
    assert!((phi - last_phi).abs() <= 1e-12 * last_phi, "went on from phi {phi}, the first run ended at {last_phi}");
}

/// `--trace` on a method without Newton iterations is refused before the run and creates no
/// file; a state file whose points break a rule is refused with the field in the user's file.
#[test]
fn a_trace_of_dem_and_a_broken_state_file_are_refused() {
    let dir = tempfile::tempdir().expect("dir");
    let mut dem = soft_scene(5);
    dem["method"] = json!("dem");
    dem["materials"] = json!({"rubber": {"density": 990.0, "friction": 0.0, "contact": {"law": "linear", "k_n": 1.0e5}, "restitution": 0.5},
                              "wall": {"density": 990.0, "friction": 0.0, "contact": {"law": "linear", "k_n": 1.0e5}, "restitution": 0.5}});
    let scene = write(dir.path(), "dem.json", &dem);
    let trace = dir.path().join("trace.jsonl");
    let out = sable(&["run", &scene, "--trace", &trace.to_string_lossy()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--trace: method dem has no Newton iterations"), "{err}");
    assert!(!trace.exists(), "a trace file was created");

    let first = write(dir.path(), "first.json", &soft_scene(5));
    let state = dir.path().join("state.json");
    let out = sable(&["run", &first, "--quiet", "--save-state", &state.to_string_lossy()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut saved: Value = serde_json::from_str(&std::fs::read_to_string(&state).expect("state")).expect("json");
    saved["material_points"]["deformation"][3] = json!([0.0, 1.0, 1.0, 0.0]);
    std::fs::write(&state, saved.to_string()).expect("write");
    let second = write(dir.path(), "second.json", &from_state(5, "state.json"));
    let out = sable(&["run", &second, "--quiet"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("start_from.file.material_points.deformation[3]: must have a positive determinant"),
        "{err}"
    );
}
