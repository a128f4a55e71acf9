//! The shipped scenes' samples, held byte for byte against `tests/golden/`: a change that is
//! meant to leave the physics alone (a refactoring, a speed-up that keeps the arithmetic) must
//! leave every sample and experiment result of these scenes as it was. Each scene runs as
//! shipped except for a cap on its steps (and, for the slow ones, a denser sampling), so the
//! whole file takes seconds; the cap and the interval are part of the reference.
//!
//! A change that is meant to move the numbers regenerates the references with
//! `SABLE_BLESS_GOLDEN=1 cargo test -p sable-tests --test physics golden_samples::` and says
//! in its commit message why they moved and by how much.

use std::path::{Path, PathBuf};

use sable_engine::run::Runner;
use serde_json::Value;

/// A shipped scene, the steps it runs here and the sampling interval (`None`: the scene's).
struct Case {
    scene: &'static str,
    steps: u64,
    every_steps: Option<u64>,
}

const CASES: [Case; 6] = [
    Case { scene: "quickstart", steps: 30_000, every_steps: Some(2_500) },
    Case { scene: "quickstart_cd", steps: 3_000, every_steps: Some(250) },
    Case { scene: "biaxial_test_2d", steps: 300_000, every_steps: Some(20_000) },
    Case { scene: "mpm_compaction_2d", steps: 800, every_steps: Some(100) },
    Case { scene: "fem_compaction_2d", steps: 800, every_steps: Some(100) },
    Case { scene: "bpm_compaction_dem_2d", steps: 4_000, every_steps: Some(500) },
];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The samples (one JSON line each) and the run's end (steps, time, experiment result) of a
/// case, as text.
fn run(case: &Case) -> String {
    let path = repo().join("scenes").join(format!("{}.json", case.scene));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut v: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    v["stop"]["steps"] = case.steps.into();
    if let Some(n) = case.every_steps {
        v["sampling"] = serde_json::json!({"every_steps": n});
    }
    let scene = sable_engine::methods::plan_scene(&v.to_string()).unwrap_or_else(|e| panic!("{}: {e:?}", case.scene));
    let mut sim = scene.build().unwrap_or_else(|e| panic!("{}: {e}", case.scene));
    let runner = Runner::for_scene(&scene);
    let mut out = String::new();
    let summary = runner
        .run(sim.as_mut(), &mut |s, _| {
            out.push_str(&serde_json::to_string(s).expect("a sample serialises"));
            out.push('\n');
        })
        .unwrap_or_else(|e| panic!("{}: {e}", case.scene));
    let end = serde_json::json!({"steps": summary.steps, "time": summary.time, "result": summary.result});
    out.push_str(&end.to_string());
    out.push('\n');
    out
}

/// The first line where two runs differ, with the first field that differs in it.
fn first_difference(want: &str, got: &str) -> String {
    for (k, (w, g)) in want.lines().zip(got.lines()).enumerate() {
        if w != g {
            let (wv, gv): (Value, Value) = (serde_json::from_str(w).unwrap_or(Value::Null), serde_json::from_str(g).unwrap_or(Value::Null));
            return format!("line {}: first difference at {}", k + 1, first_field(&wv, &gv, String::new()));
        }
    }
    format!("{} lines expected, {} produced", want.lines().count(), got.lines().count())
}

fn first_field(w: &Value, g: &Value, path: String) -> String {
    match (w, g) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, x) in a {
                match b.get(k) {
                    Some(y) if x == y => {}
                    Some(y) => return first_field(x, y, format!("{path}.{k}")),
                    None => return format!("{path}.{k} (missing now)"),
                }
            }
            b.keys().find(|k| !a.contains_key(*k)).map_or_else(|| path.clone(), |k| format!("{path}.{k} (new)"))
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
            .iter()
            .zip(b)
            .enumerate()
            .find(|(_, (x, y))| x != y)
            .map_or(path.clone(), |(i, (x, y))| first_field(x, y, format!("{path}[{i}]"))),
        _ => format!("{path}: expected {w}, got {g}"),
    }
}

#[test]
fn the_shipped_scenes_give_the_samples_they_gave() {
    let bless = std::env::var_os("SABLE_BLESS_GOLDEN").is_some();
    let dir = repo().join("tests").join("golden");
    let mut failures = Vec::new();
    for case in &CASES {
        let start = std::time::Instant::now();
        let got = run(case);
        eprintln!("{}: {:.1} s", case.scene, start.elapsed().as_secs_f64());
        let file = dir.join(format!("{}.jsonl", case.scene));
        if bless {
            std::fs::create_dir_all(&dir).expect("golden directory");
            std::fs::write(&file, &got).expect("golden file");
            continue;
        }
        let want = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e} (bless with SABLE_BLESS_GOLDEN=1)", file.display()));
        // Each reference holds its samples and the run's end: a run cut short cannot pass.
        assert!(want.lines().count() >= 3, "{}: too few lines to hold anything", file.display());
        if want != got {
            failures.push(format!("{}: {}", case.scene, first_difference(&want, &got)));
        }
    }
    assert!(failures.is_empty(), "samples moved:\n{}", failures.join("\n"));
}
