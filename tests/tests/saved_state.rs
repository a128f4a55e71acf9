//! Saved states (`engine/src/scene/state.rs`, docs/scene-format.md §14): a run's final particles
//! and box, written as JSON, start another run where the first one stopped.
//!
//! The checks compare the first sample of the second run with the last sample of the first:
//! packing fraction and coordination are functions of the positions and radii only, so they must
//! agree to rounding (the new run sorts its particles differently, which changes the order of
//! sums, hence the 1e-9 tolerance). A state at equilibrium must still be at equilibrium: the same
//! preparation, started from it, meets its criterion at the first checks.

use crate::common;

use sable_engine::methods::plan_scene as parse_scene;
use sable_engine::observe::Sample;
use sable_engine::run::{Runner, StopReason};
use sable_engine::scene::StateFile;
use serde_json::{json, Value};

/// Runs a scene to its end; returns its samples, the stop reason, the steps and the final state
/// after a round trip through JSON text.
fn run(scene: Value) -> (Vec<Sample>, StopReason, u64, StateFile) {
    let scene = common::scene(scene);
    let mut sim = scene.build().expect("build");
    let runner = Runner::for_scene(&scene);
    let mut samples = Vec::new();
    let summary = runner.run(sim.as_mut(), &mut |s, _| samples.push(s.clone())).expect("run");
    let text = serde_json::to_string(&sim.saved_state()).expect("state to JSON");
    let state: StateFile = serde_json::from_str(&text).expect("state from JSON");
    (samples, summary.reason, summary.steps, state)
}

fn disks() -> Value {
    json!({"disks": common::linear_material(1.0e5, 0.5, 0.5)})
}

fn assert_same_packing(before: &Sample, after: &Sample) {
    assert!((before.phi - after.phi).abs() < 1e-9, "phi {} then {}", before.phi, after.phi);
    assert!((before.z - after.z).abs() < 1e-9, "Z {} then {}", before.z, after.z);
}

/// The isotropic preparation of 150 disks at 100 Pa by `method` in a 20 mm periodic cell
/// (`start` null), or from the saved state `start` (the box is the state's), with the
/// `equilibrium` criterion of the preparation.
fn isotropic_scene(method: Value, start: Value, equilibrium: Value) -> Value {
    let mut scene = json!({
        "dimension": 2,
        "method": method,
        "materials": disks(),
        "container": {"periodic": ["x", "y"]},
        "experiment": {"kind": "isotropic", "preparation": {"pressure": 100.0, "equilibrium": equilibrium}},
        "sampling": {"every_steps": 500},
        "seed": 5
    });
    match start {
        Value::Null => {
            scene["container"] = json!({"min": [0, 0], "max": [0.02, 0.02], "periodic": ["x", "y"]});
            scene["particles"] = json!([{"material": "disks", "count": 150, "size": {"kind": "uniform", "min": 8.0e-4, "max": 1.2e-3},
                                        "placement": {"kind": "random"}}]);
        }
        state => scene["start_from"] = json!({"state": state}),
    }
    scene
}

#[test]
fn a_prepared_state_starts_another_run_at_equilibrium() {
    let prepare = |start: Value| run(isotropic_scene(json!({"kind": "dem", "threads": 1}), start, json!({})));
    let (first, reason, steps, state) = prepare(Value::Null);
    assert_eq!(reason, StopReason::Equilibrium);
    assert!(steps > 5_000, "the gas took only {steps} steps to compress");
    assert_eq!(state.particles.radius.len(), 150);
    assert_eq!(state.periodic, vec!["x".to_string(), "y".to_string()]);
    // The cell shrank: the state carries the compressed box.
    assert!(state.max[0] - state.min[0] < 0.02 * 0.8, "box {:?} .. {:?}", state.min, state.max);

    let (second, reason, steps, _) = prepare(serde_json::to_value(&state).expect("state value"));
    assert_same_packing(first.last().expect("samples"), &second[0]);
    // Equilibrium at the checks of steps 0, 500 and 1000 (defaults: every 500, 3 in a row).
    assert_eq!(reason, StopReason::Equilibrium);
    assert!(steps <= 1_000, "the prepared state needed {steps} steps to settle again");
}

/// Contact dynamics judges equilibrium on means over each check interval, so one passing
/// window ends a stage by default (`Simulation::equilibrium_checks`); a scene that asks for three
/// in a row gets three. A CD packing prepared at 100 Pa in a periodic cell, restarted under the
/// same preparation: the check of step 0 has no window (no contact yet: it fails), the window
/// of steps 0-500 passes.
#[test]
fn a_contact_dynamics_state_at_rest_settles_at_its_first_window_unless_asked_for_more() {
    let scene = |start: Value, equilibrium: Value| isotropic_scene(json!({"kind": "cd", "threads": 1}), start, equilibrium);
    let (_, reason, steps, state) = run(scene(Value::Null, json!({})));
    assert_eq!(reason, StopReason::Equilibrium);
    assert!(steps > 500, "the gas took only {steps} steps to compress");
    let state = serde_json::to_value(&state).expect("state value");
    let (_, reason, steps, _) = run(scene(state.clone(), json!({})));
    assert_eq!((reason, steps), (StopReason::Equilibrium, 500));
    let (_, reason, steps, _) = run(scene(state, json!({"consecutive": 3})));
    assert_eq!((reason, steps), (StopReason::Equilibrium, 1500));
}

#[test]
fn a_sheared_lees_edwards_state_keeps_its_image_offset() {
    let rate = 3.0;
    let (first, _, _, state) = run(json!({
        "dimension": 2,
        "method": {"kind": "dem", "threads": 1},
        "materials": disks(),
        "particles": [{"material": "disks", "count": 200, "size": {"kind": "uniform", "min": 8.0e-4, "max": 1.2e-3},
                       "placement": {"kind": "random"}}],
        "container": {"min": [0, 0], "max": [0.018, 0.018], "periodic": ["x", "y"]},
        "experiment": {"kind": "plane_shear", "preparation": {"pressure": 100.0}, "shear_rate": rate, "strain": 0.37},
        "sampling": {"every_steps": 5000},
        "seed": 6
    }));
    let lx = state.max[0] - state.min[0];
    // The test means something only if the images are shifted by much more than a grain.
    assert!(
        state.lees_edwards_offset > 2.4e-3 && state.lees_edwards_offset < lx - 2.4e-3,
        "offset {} in a cell {lx} wide",
        state.lees_edwards_offset
    );
    // Sheared on, the run goes on where it stopped.
    let scene = |lees_edwards: Value| {
        let mut container = json!({"periodic": ["y", "x"]});
        if !lees_edwards.is_null() {
            container["lees_edwards"] = lees_edwards;
        }
        json!({
            "dimension": 2,
            "method": {"kind": "dem", "threads": 1},
            "materials": disks(),
            "start_from": {"state": state},
            "container": container,
            "stop": {"steps": 1}
        })
    };
    let (second, _, _, _) = run(scene(json!({"shear_rate": rate})));
    assert_same_packing(first.last().expect("samples"), &second[0]);
    assert!(second[0].z > 2.5, "Z = {}: too few contacts to test", second[0].z);

    // Sheared or at rest, the images stay shifted by the offset: the touching pairs are those
    // found by brute force over the shifted images.
    let touching = brute_force_touching(&state);
    for lees_edwards in [json!({"shear_rate": rate}), Value::Null] {
        let sim = common::dem(&common::scene(scene(lees_edwards)));
        assert_eq!(sim.interacting_pairs(), touching);
    }
}

/// Overlapping pairs of a 2D state periodic along x and y, each pair's nearest image among the
/// 3 x 3 neighbouring periods (one period up along y is shifted by the offset along x).
fn brute_force_touching(s: &StateFile) -> usize {
    let (lx, ly, off) = (s.max[0] - s.min[0], s.max[1] - s.min[1], s.lees_edwards_offset);
    let (x, r) = (&s.particles.position, &s.particles.radius);
    let mut n = 0;
    for i in 0..r.len() {
        for j in i + 1..r.len() {
            let mut best = f64::INFINITY;
            for ky in [-1.0, 0.0, 1.0] {
                for kx in [-2.0, -1.0, 0.0, 1.0, 2.0] {
                    let dx = x[i][0] - x[j][0] - kx * lx - ky * off;
                    let dy = x[i][1] - x[j][1] - ky * ly;
                    best = best.min((dx * dx + dy * dy).sqrt());
                }
            }
            if best < r[i] + r[j] {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn a_state_that_does_not_fit_the_scene_is_rejected_with_its_fields() {
    let state = json!({
        "format": "sable-state", "version": 1, "dimension": 3,
        "min": [0, 0], "max": [0.01, 0.01], "periodic": ["x"],
        "materials": ["clay"],
        "particles": {"material": [0, 1], "radius": [5e-4, -1.0], "position": [[0.005, 0.005], [0.02, 0.005]],
                      "velocity": [[0, 0], [0, 0]], "angular_velocity": [[0], [0]]}
    });
    let scene = json!({
        "dimension": 2, "method": "dem",
        "materials": disks(),
        "particles": [{"material": "disks", "count": 3, "size": {"kind": "monodisperse", "diameter": 1e-3}, "placement": {"kind": "random"}}],
        "start_from": {"state": state, "job": 4},
        "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "disks"},
        "stop": {"steps": 10}
    });
    let violations = parse_scene(&scene.to_string()).expect_err("invalid");
    assert_fields(
        &violations,
        &[
            "start_from",
            "particles",
            "start_from.job",
            "container.min",
            "container.periodic",
            "start_from.state.dimension",
            "start_from.state.materials[0]",
            "start_from.state.particles.radius[1]",
            "start_from.state.particles.material[1]",
            "start_from.state.particles.position[1]",
        ],
    );
}

/// The CI soft compaction (`scenes/mpm_compaction_2d.json`) with elastoplastic grains (σ_y
/// 0.4 MPa, H 1 MPa, so that the points' plastic history matters), or the same scene started
/// from `start`, as JSON.
fn soft_compaction_json(start: Option<Value>) -> Value {
    soft_compaction_json_of("mpm_compaction_2d.json", start)
}

/// [`soft_compaction_json`] from the scene file `file` of `scenes/` (`mpm_compaction_2d.json`,
/// or `fem_compaction_2d.json`: the same grains meshed).
fn soft_compaction_json_of(file: &str, start: Option<Value>) -> Value {
    let path = format!("{}/../scenes/{file}", env!("CARGO_MANIFEST_DIR"));
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("scene file")).expect("json");
    scene["materials"]["rubber"]["deformable"] =
        json!({"law": "elastoplastic", "young_modulus": 1.0e7, "poisson_ratio": 0.45, "yield_stress": 4.0e5, "hardening": 1.0e6});
    if let Some(state) = start {
        scene["start_from"] = json!({"state": state});
        scene["particles"] = json!([]);
        scene["container"].as_object_mut().expect("container").retain(|k, _| k != "min" && k != "max");
    }
    scene
}

/// [`soft_compaction_json`], parsed.
fn soft_compaction(start: Option<Value>) -> sable_engine::methods::Plan {
    common::scene(soft_compaction_json(start))
}

/// Asserts that `violations` name every field of `want`.
fn assert_fields(violations: &[sable_engine::scene::Violation], want: &[&str]) {
    let fields: Vec<&str> = violations.iter().map(|v| v.field.as_str()).collect();
    for w in want {
        assert!(fields.contains(w), "no violation of {w}: {violations:?}");
    }
}

/// What the restored run and the run that saved its state must agree on: packing fraction, the
/// stored energy (which depends on every point's deformation gradient and plastic history), the
/// grains' mean aspect ratio and the top wall's stress.
fn soft_measures(s: &Sample) -> [f64; 4] {
    let g = s.grains.as_ref().expect("the grains' sample");
    let top = s.walls.iter().find(|w| w.name == "y_max").expect("top wall");
    [s.phi, s.elastic_energy, g.mean_aspect_ratio, top.normal_stress]
}

/// A state saved by `mpm` past jamming holds its material points, its steps' splitting level
/// and its contacts' impulses: a run started from it begins with exactly the saved grains
/// (packing fraction, stored energy and shape to rounding) and goes on as the run that saved it
/// does. Measured over the next 10 steps: within 5e-12 (round-off in sums taken in another
/// order); the test allows 1e-9. Without the impulses (a cold first contact solve) the two
/// differed by 2e-4 after one step, and by 1e-3 twenty steps on, where the packing rearranged.
#[test]
fn an_mpm_state_goes_on_from_its_material_points() {
    let scene = soft_compaction(None);
    let mut sim = scene.build().expect("build");
    while sim.packing_fraction() < 0.86 {
        sim.step().expect("stable");
    }
    let saved = sim.sample().expect("sample");
    let text = serde_json::to_string(&sim.saved_state()).expect("state to JSON");
    let state: Value = serde_json::from_str(&text).expect("state from JSON");
    let points = &state["material_points"];
    assert!(points["plastic_strain"].as_array().expect("points").iter().any(|a| a.as_f64() > Some(0.0)), "no point yielded");
    let mut restored = soft_compaction(Some(state)).build().expect("build from the state");
    let first = restored.sample().expect("sample");
    let (a, b) = (soft_measures(&saved), soft_measures(&first));
    for k in 0..3 {
        assert!((a[k] - b[k]).abs() <= 1e-12 * a[k].abs(), "measure {k}: saved {} restored {}", a[k], b[k]);
    }
    for _ in 0..10 {
        sim.step().expect("stable");
        restored.step().expect("stable");
    }
    let (a, b) = (soft_measures(&sim.sample().expect("sample")), soft_measures(&restored.sample().expect("sample")));
    eprintln!("after 10 steps: went on {a:?}, restored {b:?}");
    assert!(a[3] > 1e4, "the top wall carries {} Pa: not past jamming", a[3]);
    for k in 0..4 {
        assert!((a[k] - b[k]).abs() <= 1e-9 * a[k].abs(), "measure {k}: went on {} restored {}", a[k], b[k]);
    }
}

/// Without its material points the same state is a packing of disks: `mpm` fills them afresh
/// (their solid area within the point lattice's error of the disks'), and a rigid method that
/// starts from a state of deformable grains, or a state whose points break a rule, is refused
/// with every field named.
#[test]
fn an_mpm_state_without_points_or_with_bad_ones_is_handled() {
    let scene = soft_compaction(None);
    let mut sim = scene.build().expect("build");
    for _ in 0..200 {
        sim.step().expect("stable");
    }
    let phi = sim.packing_fraction();
    let mut state = serde_json::to_value(sim.saved_state()).expect("state");
    let points = state.as_object_mut().expect("state").remove("material_points").expect("mpm saves its points");

    let fresh = soft_compaction(Some(state.clone())).build().expect("build from disks");
    assert!((fresh.packing_fraction() - phi).abs() < 0.03 * phi, "disks filled afresh: phi {} against {phi}", fresh.packing_fraction());

    let rigid = json!({"dimension": 2, "method": "dem", "materials": {"rubber": {"density": 990.0, "friction": 0.0,
        "deformable": {"law": "linear_elastic", "young_modulus": 1.0e7, "poisson_ratio": 0.45}}},
        "start_from": {"state": state.clone()}, "container": {"wall_material": "rubber"}, "stop": {"steps": 10}});
    let violations = parse_scene(&rigid.to_string()).expect_err("a rigid method on deformable grains");
    assert!(violations.iter().any(|v| v.field == "start_from.state.materials" && v.rule.contains("deformable")), "{violations:?}");

    let mut bad = points.clone();
    // Grain 0 gives all but 3 of its points to grain 1 (the total stays).
    let (c0, c1) = (bad["count"][0].as_u64().expect("count"), bad["count"][1].as_u64().expect("count"));
    bad["count"][0] = json!(3);
    bad["count"][1] = json!(c1 + c0 - 3);
    bad["deformation"][5] = json!([1.0, 0.0, 0.0, -1.0]);
    bad["plastic_strain"][7] = json!(-0.1);
    bad["outline_point"][0] = json!(100000);
    bad["impulses"] = json!([{"grain": 0, "vertex": 0, "other": 1, "impulse": [1.0]}]);
    bad["velocity"].as_array_mut().expect("velocity").pop();
    state["material_points"] = bad;
    let mut spec = soft_compaction_json(Some(state.clone()));
    let violations = parse_scene(&spec.to_string()).expect_err("bad points");
    let fields: Vec<&str> = violations.iter().map(|v| v.field.as_str()).collect();
    // A length that does not match stops the per-entry rules (their indices would mislead).
    assert_eq!(fields, ["start_from.state.material_points.velocity"], "{violations:?}");
    state["material_points"]["velocity"] = points["velocity"].clone();
    spec["start_from"] = json!({"state": state});
    let violations = parse_scene(&spec.to_string()).expect_err("bad points");
    assert_fields(
        &violations,
        &[
            "start_from.state.material_points.count[0]",
            "start_from.state.material_points.deformation[5]",
            "start_from.state.material_points.plastic_strain[7]",
            "start_from.state.material_points.outline_point[0]",
            "start_from.state.material_points.impulses[0]",
        ],
    );
}

/// A state saved by `fem` past jamming holds its grains' meshes (reference positions,
/// displacements, velocities, the Gauss points' plastic history), its steps' splitting level
/// and its contacts' impulses: a run started from it begins with exactly the saved grains (to
/// rounding) and goes on as the run that saved it does, within Newton's tolerance: the saving
/// run keeps each grain's Newton matrix from the steps before (modified Newton, while it
/// contracts), the restored one assembles them anew, and the two converge to the same fixed
/// point only within the tolerance. Measured over 10 steps: the stored energy within 2e-8, Φ
/// within 1e-9, the top wall's stress within 5e-9 (relative); with every matrix assembled anew
/// at every part in both runs (a throw-away switch) within 3e-11. The test allows 1e-6.
#[test]
fn a_fem_state_goes_on_from_its_meshes() {
    let scene = common::scene(soft_compaction_json_of("fem_compaction_2d.json", None));
    let mut sim = scene.build().expect("build");
    while sim.packing_fraction() < 0.86 {
        sim.step().expect("stable");
    }
    let saved = sim.sample().expect("sample");
    let text = serde_json::to_string(&sim.saved_state()).expect("state to JSON");
    let state: Value = serde_json::from_str(&text).expect("state from JSON");
    let meshes = &state["meshes"];
    assert!(meshes["plastic_strain"].as_array().expect("histories").iter().any(|a| a.as_f64() > Some(0.0)), "no point yielded");
    assert!(!meshes["impulses"].as_array().expect("impulses").is_empty(), "no contact impulse saved");
    let restored_scene = common::scene(soft_compaction_json_of("fem_compaction_2d.json", Some(state)));
    let mut restored = restored_scene.build().expect("build from the state");
    let first = restored.sample().expect("sample");
    let (a, b) = (soft_measures(&saved), soft_measures(&first));
    eprintln!("saved {a:?}, restored {b:?}");
    for k in 0..3 {
        assert!((a[k] - b[k]).abs() <= 1e-12 * a[k].abs(), "measure {k}: saved {} restored {}", a[k], b[k]);
    }
    for _ in 0..10 {
        sim.step().expect("stable");
        restored.step().expect("stable");
    }
    let (a, b) = (soft_measures(&sim.sample().expect("sample")), soft_measures(&restored.sample().expect("sample")));
    eprintln!("after 10 steps: went on {a:?}, restored {b:?}");
    assert!(a[3] > 1e4, "the top wall carries {} Pa: not past jamming", a[3]);
    for k in 0..4 {
        assert!((a[k] - b[k]).abs() <= 1e-6 * a[k].abs(), "measure {k}: went on {} restored {}", a[k], b[k]);
    }
}

/// A `fem` state whose meshes break a rule is refused with every field named: counts that do
/// not add up stop the per-entry rules; then a node number beyond its grain's, an element
/// turned clockwise, one inverted by its displacements, a negative plastic strain and an
/// impulse of one component. Without its meshes the state is a packing of disks that `fem`
/// meshes afresh.
#[test]
fn a_fem_state_with_bad_meshes_is_refused() {
    let scene = common::scene(soft_compaction_json_of("fem_compaction_2d.json", None));
    let mut sim = scene.build().expect("build");
    for _ in 0..200 {
        sim.step().expect("stable");
    }
    let phi = sim.packing_fraction();
    let mut state = serde_json::to_value(sim.saved_state()).expect("state");
    let meshes = state.as_object_mut().expect("state").remove("meshes").expect("fem saves its meshes");
    assert!(meshes.get("plastic").is_none(), "elastic grains: no history is written");
    let fresh_scene = common::scene(soft_compaction_json_of("fem_compaction_2d.json", Some(state.clone())));
    let fresh = fresh_scene.build().expect("build from disks");
    assert!((fresh.packing_fraction() - phi).abs() < 1e-3 * phi, "disks meshed afresh: phi {} against {phi}", fresh.packing_fraction());

    let mut bad = meshes.clone();
    bad["node_count"][0] = json!(bad["node_count"][0].as_u64().expect("count") + 1);
    state["meshes"] = bad;
    let violations =
        parse_scene(&soft_compaction_json_of("fem_compaction_2d.json", Some(state.clone())).to_string()).expect_err("bad counts");
    let fields: Vec<&str> = violations.iter().map(|v| v.field.as_str()).collect();
    assert_eq!(fields, ["start_from.state.meshes.reference", "start_from.state.meshes.displacement", "start_from.state.meshes.velocity"]);

    let mut bad = meshes.clone();
    bad["elements"][0][2] = json!(100000);
    let q = bad["elements"][1].clone();
    bad["elements"][1] = json!([q[3], q[2], q[1], q[0]]);
    // Node 0's displacement takes it across the grain: the elements around it invert.
    let x0 = bad["reference"][0].clone();
    let far = bad["reference"][bad["node_count"][0].as_u64().expect("count") as usize - 1].clone();
    bad["displacement"][0] = json!([
        2.0 * (far[0].as_f64().expect("x") - x0[0].as_f64().expect("x")),
        2.0 * (far[1].as_f64().expect("y") - x0[1].as_f64().expect("y"))
    ]);
    bad["plastic"] = json!(vec![[1.0, 0.0, 1.0, 1.0]; 4 * bad["elements"].as_array().expect("elements").len()]);
    bad["plastic_strain"] = json!(vec![0.0; 4 * bad["elements"].as_array().expect("elements").len()]);
    bad["plastic_strain"][5] = json!(-0.1);
    bad["impulses"] = json!([{"grain": 0, "vertex": 0, "other": 1, "impulse": [1.0]}]);
    state["meshes"] = bad;
    let violations = parse_scene(&soft_compaction_json_of("fem_compaction_2d.json", Some(state)).to_string()).expect_err("bad meshes");
    assert_fields(
        &violations,
        &[
            "start_from.state.meshes.elements[0]",
            "start_from.state.meshes.elements[1]",
            "start_from.state.meshes.plastic_strain[5]",
            "start_from.state.meshes.impulses[0]",
        ],
    );
    assert!(
        violations.iter().any(|v| v.field.starts_with("start_from.state.meshes.elements[") && v.rule.contains("inverted")),
        "no inverted element named: {violations:?}"
    );
}
