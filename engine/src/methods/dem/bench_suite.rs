//! The DEM benchmark suite (`sable bench dem --scene NAME`): the scenes users run — walled,
//! dense, contact-heavy, 2D and 3D, polydisperse — besides the periodic gas of
//! [`crate::scene::presets::dem_benchmark`]. Each has a twin for LAMMPS in `benches/peers/`, run from
//! the same initial state.
//!
//! A scene may need a preparation that is not timed (a dense packing to shear or to load): its
//! [`BenchScene::preparation`] is run first, and the timed scene starts from its final state
//! (`start_from.state`, filled in by the caller).
//!
//! All grains are glass-like (ρ = 2500 kg/m³, mean d = 1 mm) with the linear spring-dashpot law
//! and tangential history, friction 0.5 (the preparations of dense packings run frictionless,
//! as the experiments' do).

use serde_json::{json, Value};

use crate::scene::presets::dem_benchmark;

/// Names of the scenes of the suite, in the order the README's table lists them.
pub const SUITE: [&str; 6] = ["gas", "deposition_3d", "shear_3d", "deposition_2d", "biaxial_2d", "polydisperse_3d"];

/// One scene of the suite.
#[derive(Debug, Clone)]
pub struct BenchScene {
    /// Its name in [`SUITE`].
    pub name: &'static str,
    /// What it is, in a line.
    pub description: String,
    /// A scene run before the timed one, untimed, whose first stage (an experiment's
    /// preparation) ends at equilibrium; the timed scene starts from its final state.
    pub preparation: Option<Value>,
    /// The timed scene (without `start_from` when there is a preparation).
    pub timed: Value,
    /// Stages of the timed scene's experiment left out (its preparation, already done by
    /// `preparation`).
    pub skip_stages: usize,
}

/// Default particle count of each scene.
pub fn default_particles(name: &str) -> Option<usize> {
    Some(match name {
        "gas" | "deposition_2d" | "biaxial_2d" | "polydisperse_3d" => 20_000,
        "deposition_3d" | "shear_3d" => 10_000,
        _ => return None,
    })
}

/// The scene `name` of the suite with `particles` grains (its default when `None`), `steps`
/// timed steps (the scene's own when `None`), on `threads` threads; `None` for an unknown name.
pub fn bench_scene(name: &str, particles: Option<usize>, steps: Option<u64>, threads: usize) -> Option<BenchScene> {
    let n = particles.or_else(|| default_particles(name))?;
    let mut scene = match name {
        "gas" => BenchScene {
            name: "gas",
            description: format!("{n} spheres, fully periodic gas at Φ 0.57, no gravity (few lasting contacts)"),
            preparation: None,
            timed: dem_benchmark(n, 2_000, threads),
            skip_stages: 0,
        },
        "deposition_3d" => deposition_3d(n, threads),
        "shear_3d" => shear_3d(n, threads),
        "deposition_2d" => deposition_2d(n, threads),
        "biaxial_2d" => biaxial_2d(n, threads),
        "polydisperse_3d" => polydisperse_3d(n, threads),
        _ => return None,
    };
    if let Some(steps) = steps {
        scene.timed["stop"] = json!({"steps": steps});
    }
    Some(scene)
}

/// Glass with the linear law of stiffness `k_n` (N/m), restitution `e` and friction `mu`.
fn glass(k_n: f64, e: f64, mu: f64) -> Value {
    json!({"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": e, "friction": mu})
}

/// Gravity deposition into a box closed by walls on every face (3D): monodisperse spheres
/// (d = 1 mm) start on a loose cubic lattice (spacing 1.25 d, 31 mm high for 10,000 in a
/// 25 mm × 25 mm box) with random velocities of 0.05 m/s, fall and settle into a bed about
/// 14 mm high with four lasting contacts per grain (k_n = 500 N/m: a grain at the bottom is
/// squeezed by about 4e-4 d; e = 0.7, μ = 0.5), to rest. The footprint grows with the count, the
/// bed's height does not.
fn deposition_3d(n: usize, threads: usize) -> BenchScene {
    let (d, spacing) = (1e-3, 1.25e-3);
    let side = 0.025 * (n as f64 / 10_000.0).sqrt();
    let per_layer = ((side / spacing).floor()).powi(2);
    let height = ((n as f64 / per_layer).ceil() + 1.0) * spacing * 1.3;
    BenchScene {
        name: "deposition_3d",
        description: format!("{n} spheres poured into a box walled on every face, to rest (3D)"),
        preparation: None,
        skip_stages: 0,
        timed: json!({
            "name": format!("bench-deposition_3d-{n}"),
            "dimension": 3,
            "method": {"kind": "dem", "threads": threads},
            "materials": {"glass": glass(500.0, 0.7, 0.5)},
            "particles": [{"material": "glass", "count": n, "size": {"kind": "monodisperse", "diameter": d},
                "placement": {"kind": "lattice", "lattice": "cubic", "spacing": spacing},
                "velocity": {"kind": "gaussian", "std": 0.05}}],
            "container": {"min": [0.0, 0.0, 0.0], "max": [side, side, height], "wall_material": "glass"},
            "gravity": [0.0, 0.0, -9.81],
            "stop": {"steps": 120_000},
            "seed": 1
        }),
    }
}

/// The same deposition in 2D: disks (d = 1 mm) on a loose square lattice (spacing 1.25 d, up to
/// 105 mm high for 20,000) in a box walled on every side, 300 mm wide for 20,000 (the width
/// grows with the count), falling into a bed about 65 mm high: after the 120,000 steps (0.27 s)
/// the bed has formed and still creeps (kinetic energy 1.9e-4 J/m at the end, measured).
/// k_n = 7.5e5 N/m gives the 3D scene's collision time with the 2D masses (per metre of
/// thickness).
fn deposition_2d(n: usize, threads: usize) -> BenchScene {
    let (d, spacing) = (1e-3, 1.25e-3);
    let width = 0.3 * n as f64 / 20_000.0;
    let per_row = (width / spacing).floor();
    let height = ((n as f64 / per_row).ceil() + 1.0) * spacing * 1.3;
    BenchScene {
        name: "deposition_2d",
        description: format!("{n} disks poured into a box walled on every side (2D)"),
        preparation: None,
        skip_stages: 0,
        timed: json!({
            "name": format!("bench-deposition_2d-{n}"),
            "dimension": 2,
            "method": {"kind": "dem", "threads": threads},
            "materials": {"glass": glass(7.5e5, 0.7, 0.5)},
            "particles": [{"material": "glass", "count": n, "size": {"kind": "monodisperse", "diameter": d},
                "placement": {"kind": "lattice", "lattice": "square", "spacing": spacing},
                "velocity": {"kind": "gaussian", "std": 0.05}}],
            "container": {"min": [0.0, 0.0], "max": [width, height], "wall_material": "glass"},
            "gravity": [0.0, -9.81],
            "stop": {"steps": 120_000},
            "seed": 1
        }),
    }
}

/// A biaxial test of 20,000 disks (0.8–1.2 mm, k_n = 1e5 N/m, e = 0.5), the scene of
/// `scenes/biaxial_test_2d.json` at fifty times its size: prepared frictionless at 100 Pa by the
/// `biaxial` experiment's preparation (untimed), then loaded with μ = 0.5: the upper wall driven
/// down at 0.01 of the initial side a second (1.5% of the prepared height a second), the right
/// wall held at 100 Pa by its servo, the others fixed, frictionless walls (timed). The small
/// scene's 0.3/s would not be quasi-static here: the wall's speed (6.4 cm/s) over the speed of
/// sound in the packing (~9 m/s) is a strain seven times the contacts' static one at 100 Pa,
/// and the compression front overlapped grains past 10% within 6,000 steps.
fn biaxial_2d(n: usize, threads: usize) -> BenchScene {
    let side = 0.03 * (n as f64 / 400.0).sqrt();
    let materials = |mu: f64| json!({"disks": glass(1e5, 0.5, mu), "platen": glass(1e5, 0.5, 0.0)});
    BenchScene {
        name: "biaxial_2d",
        description: format!("{n} disks (0.8-1.2 mm) prepared at 100 Pa, then loaded biaxially between walls (2D)"),
        preparation: Some(json!({
            "name": format!("bench-biaxial_2d-{n}-preparation"),
            "dimension": 2,
            "method": {"kind": "dem", "threads": threads},
            "materials": materials(0.0),
            "particles": [{"material": "disks", "count": n, "size": {"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3}, "placement": {"kind": "random"}}],
            "container": {"min": [0.0, 0.0], "max": [side, side], "wall_material": "platen"},
            "experiment": {"kind": "biaxial", "preparation": {"pressure": 100.0, "friction": 0.0}, "strain_rate": 0.3, "axial_strain": 0.15},
            "seed": 3
        })),
        skip_stages: 0,
        timed: json!({
            "name": format!("bench-biaxial_2d-{n}"),
            "dimension": 2,
            "method": {"kind": "dem", "threads": threads},
            "materials": materials(0.5),
            "container": {"wall_material": "platen", "walls": {
                "x_max": {"kind": "stress", "stress": 100.0},
                "y_max": {"kind": "velocity", "velocity": [0.0, -0.01 * side]}
            }},
            "stop": {"steps": 20_000},
            "seed": 3
        }),
    }
}

/// Dense plane shear of 10,000 spheres (0.9–1.1 mm, k_n = 1e3 N/m, e = 0.5) in a fully periodic
/// cell, the `plane_shear` experiment: prepared frictionless at 1 kPa by the cell's pressure
/// servo (untimed; κ = k_n/(p d) = 1e3), then sheared with μ = 0.5 by Lees–Edwards boundaries at
/// 6.3/s (inertial number 0.01) from the linear velocity profile, the cell's height held at
/// σ_yy = 1 kPa by its servo (timed: the experiment's shear stage alone). At constant volume the
/// frictional packing, denser than it can flow, jams and overlaps past 10% within 13,000 steps.
fn shear_3d(n: usize, threads: usize) -> BenchScene {
    let side = 0.0258 * (n as f64 / 10_000.0).cbrt();
    let experiment =
        json!({"kind": "plane_shear", "preparation": {"pressure": 1000.0, "friction": 0.0}, "inertial_number": 0.01, "strain": 1.0});
    BenchScene {
        name: "shear_3d",
        description: format!("{n} spheres (0.9-1.1 mm) prepared at 1 kPa, sheared by Lees-Edwards boundaries at I = 0.01 under 1 kPa (3D)"),
        preparation: Some(json!({
            "name": format!("bench-shear_3d-{n}-preparation"),
            "dimension": 3,
            "method": {"kind": "dem", "threads": threads},
            "materials": {"glass": glass(1e3, 0.5, 0.5)},
            "particles": [{"material": "glass", "count": n, "size": {"kind": "uniform", "min": 0.9e-3, "max": 1.1e-3}, "placement": {"kind": "random"}}],
            "container": {"min": [0.0, 0.0, 0.0], "max": [side, side, side], "periodic": ["x", "y", "z"]},
            "experiment": experiment,
            "seed": 5
        })),
        timed: json!({
            "name": format!("bench-shear_3d-{n}"),
            "dimension": 3,
            "method": {"kind": "dem", "threads": threads},
            "materials": {"glass": glass(1e3, 0.5, 0.5)},
            "container": {"periodic": ["x", "y", "z"]},
            "experiment": experiment,
            "stop": {"steps": 20_000},
            "seed": 5
        }),
        skip_stages: 1,
    }
}

/// Polydisperse compression: 20,000 spheres of 0.5–1.5 mm (size ratio 3, uniform in diameter;
/// k_n = 1e3 N/m, e = 0.5, μ = 0.5) placed at random in a fully periodic cube at Φ 0.3, squeezed
/// isotropically at a true strain rate of 17/s per axis: the 20,000 steps of 5.9e-7 s (0.0118 s)
/// take Φ to 0.3 e^(3 × 17 × 0.0118) ≈ 0.54, into a contact network (24,000 contacts at the end,
/// p ≈ 1 kPa; at 20/s the small grains between large ones overlap past 10% near Φ 0.575). The
/// neighbour search meets many small grains around every large one.
fn polydisperse_3d(n: usize, threads: usize) -> BenchScene {
    // Mean volume of a sphere with d uniform on [0.5, 1.5] mm: π/6 <d³> = π/6 × (1.5⁴ - 0.5⁴)/(4 × 1.0) mm³.
    let mean_volume = std::f64::consts::PI / 6.0 * (1.5f64.powi(4) - 0.5f64.powi(4)) / 4.0 * 1e-9;
    let side = (n as f64 * mean_volume / 0.3).cbrt();
    BenchScene {
        name: "polydisperse_3d",
        description: format!("{n} spheres of 0.5-1.5 mm (size ratio 3) squeezed isotropically from Φ 0.3 in a periodic cell (3D)"),
        preparation: None,
        skip_stages: 0,
        timed: json!({
            "name": format!("bench-polydisperse_3d-{n}"),
            "dimension": 3,
            "method": {"kind": "dem", "threads": threads},
            "materials": {"glass": glass(1e3, 0.5, 0.5)},
            "particles": [{"material": "glass", "count": n, "size": {"kind": "uniform", "min": 0.5e-3, "max": 1.5e-3}, "placement": {"kind": "random"}}],
            "container": {"min": [0.0, 0.0, 0.0], "max": [side, side, side], "periodic": ["x", "y", "z"],
                          "deformation": {"kind": "strain_rate", "rate": [-17.0, -17.0, -17.0]}},
            "stop": {"steps": 20_000},
            "seed": 7
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scene_of_the_suite_is_valid() {
        for name in SUITE {
            let s = bench_scene(name, Some(500), Some(10), 1).unwrap_or_else(|| panic!("{name}"));
            if let Some(prep) = &s.preparation {
                if let Err(v) = crate::methods::plan_scene(&prep.to_string()) {
                    panic!("{name} preparation: {v:?}");
                }
            }
            // A timed scene that starts from a preparation gets its state from the caller.
            if s.preparation.is_none() {
                if let Err(v) = crate::methods::plan_scene(&s.timed.to_string()) {
                    panic!("{name}: {v:?}");
                }
            }
            assert_eq!(s.timed["stop"]["steps"], 10);
        }
        assert!(bench_scene("nope", None, None, 1).is_none());
    }
}
