//! Ready-made scenes used by benchmarks and examples.

use serde_json::json;

/// The standard DEM benchmark scene (issue "engine foundation", item 8): 3D, `particles`
/// monodisperse spheres (d = 1 mm, rho = 2500 kg/m³) in a fully periodic cube at Φ ≈ 0.57, linear
/// spring-dashpot with tangential history (k_n = 1e4 N/m, k_t = 2857.14 N/m, mu = 0.5, e_n = 0.7,
/// gamma_t = gamma_n / 2, force allowed to turn attractive as in LAMMPS `gran/hooke/history`),
/// dt = 5e-7 s (about t_c/51), Gaussian initial velocities with 0.2 m/s per component.
///
/// Positions: a random subset of the sites of an FCC lattice of `ceil((particles/4)^(1/3))`
/// cubic cells spanning the box (20,000 particles: 18³ cells, 23,328 sites, nearest-neighbour
/// distance 1.037 mm), so that nothing overlaps at that density.
pub fn dem_benchmark(particles: usize, steps: u64, threads: usize) -> serde_json::Value {
    let d: f64 = 1e-3;
    let phi = 0.57;
    let side = (particles as f64 * std::f64::consts::PI / 6.0 * d.powi(3) / phi).cbrt();
    let cells = ((particles as f64 / 4.0).cbrt().ceil()).max(1.0);
    let spacing = side / cells / 2f64.sqrt();
    json!({
        "name": format!("dem-benchmark-{particles}"),
        "dimension": 3,
        "method": {"kind": "dem", "time_step": 5e-7, "threads": threads},
        "materials": {"glass": {
            "density": 2500.0,
            "contact": {"law": "linear", "k_n": 1e4, "k_t": 2857.14},
            "restitution": 0.7,
            "friction": 0.5,
            "tangential_damping_ratio": 0.5,
            "limit_damping": false
        }},
        "particles": [{
            "material": "glass",
            "count": particles,
            "size": {"kind": "monodisperse", "diameter": d},
            "placement": {"kind": "lattice", "lattice": "fcc", "spacing": spacing, "select": "random"},
            "velocity": {"kind": "gaussian", "std": 0.2}
        }],
        "container": {"min": [0.0, 0.0, 0.0], "max": [side, side, side], "periodic": ["x", "y", "z"]},
        "stop": {"steps": steps},
        "sampling": {"every_steps": steps},
        "seed": 42
    })
}

/// The contact-dynamics benchmark scene: `particles` rigid spheres (d = 1 mm, ρ = 2500 kg/m³,
/// μ = 0.5, no restitution) stacked on an FCC lattice 0.1% looser than touching, on the floor of
/// a box periodic along x and y, under gravity: within a few steps every sphere rests on its
/// neighbours, a dense packing with about six contacts per sphere for the solver at every step.
pub fn cd_benchmark(particles: usize, steps: u64, threads: usize) -> serde_json::Value {
    let d: f64 = 1e-3;
    let spacing = 1.001 * d;
    let cell = spacing * 2f64.sqrt();
    let across = ((particles as f64 / 4.0).cbrt().ceil()).max(2.0);
    let layers = (particles as f64 / (4.0 * across * across)).ceil() + 1.0;
    let side = across * cell;
    json!({
        "name": format!("cd-benchmark-{particles}"),
        "dimension": 3,
        "method": {"kind": "cd", "time_step": 1e-4, "threads": threads},
        "materials": {"glass": {
            "density": 2500.0,
            "contact": {"law": "linear", "k_n": 1e4},
            "restitution": 0.0,
            "friction": 0.5
        }},
        "particles": [{
            "material": "glass",
            "count": particles,
            "size": {"kind": "monodisperse", "diameter": d},
            "placement": {"kind": "lattice", "lattice": "fcc", "spacing": spacing, "select": "first"}
        }],
        "container": {"min": [0.0, 0.0, 0.0], "max": [side, side, layers * cell], "periodic": ["x", "y"], "wall_material": "glass"},
        "gravity": [0.0, 0.0, -9.81],
        "stop": {"steps": steps},
        "sampling": {"every_steps": steps},
        "seed": 42
    })
}

/// The quasi-static biaxial test of the CD-versus-DEM comparison (issue 5; the scene of
/// `scenes/biaxial_test_2d.json`, to `axial_strain`): `particles` disks of 0.8-1.2 mm (μ = 0.5,
/// e = 0.5) in a square box scaled to keep the 400-disk density (0.03 m for 400), frictionless
/// walls, prepared frictionless at 100 Pa, then the upper wall driven at 0.3/s. `method` is the
/// scene's method section; `k_n` (N/m) the linear stiffness, whose stiffness number is
/// `k_n / 100 Pa` for DEM (CD ignores it).
pub fn biaxial_benchmark(method: serde_json::Value, k_n: f64, particles: usize, axial_strain: f64) -> serde_json::Value {
    let side = 0.03 * (particles as f64 / 400.0).sqrt();
    json!({
        "name": format!("biaxial-benchmark-{particles}"),
        "dimension": 2,
        "method": method,
        "materials": {
            "disks": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.5, "friction": 0.5},
            "platen": {"density": 2500.0, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.5, "friction": 0.0}
        },
        "particles": [{"material": "disks", "count": particles, "size": {"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3}, "placement": {"kind": "random"}}],
        "container": {"min": [0.0, 0.0], "max": [side, side], "wall_material": "platen"},
        "experiment": {"kind": "biaxial", "preparation": {"pressure": 100.0, "friction": 0.0}, "strain_rate": 0.3, "axial_strain": axial_strain},
        "sampling": {"every_time": 0.005},
        "seed": 3
    })
}

/// The sources' soft-grain compaction (Nezamabadi 2020, §2.1.1; issue 25's full-size study): `grains` disks of
/// 1.4–2.4 mm (uniform in diameter), E = 10 MPa, ν = 0.45, ρ = 990 kg/m³, grain friction
/// `friction`, frictionless walls, no gravity, placed at random at Φ ≈ 0.5 in a box 1.5 times
/// as high as wide, the top wall moving down at 0.1 m/s until Φ = `phi` (or `steps`), method
/// `mpm` with six cells across the smallest grain and dt = 5e-5 s (the CI compaction's).
pub fn mpm_compaction(grains: usize, friction: f64, phi: f64, steps: u64, threads: usize) -> serde_json::Value {
    let (dmin, dmax): (f64, f64) = (1.4e-3, 2.4e-3);
    // <d²> of a uniform diameter distribution.
    let mean_square = (dmax.powi(3) - dmin.powi(3)) / (3.0 * (dmax - dmin));
    let solid = grains as f64 * std::f64::consts::PI / 4.0 * mean_square;
    let width = (solid / 0.5 / 1.5).sqrt();
    let law = json!({"law": "linear_elastic", "young_modulus": 1.0e7, "poisson_ratio": 0.45});
    json!({
        "name": format!("mpm-compaction-{grains}"),
        "dimension": 2,
        "method": {"kind": "mpm", "cells_per_diameter": 6, "time_step": 5e-5, "threads": threads},
        "materials": {
            "rubber": {"density": 990.0, "friction": friction, "deformable": law},
            "wall": {"density": 990.0, "friction": 0.0, "deformable": law}
        },
        "particles": [{"material": "rubber", "count": grains, "size": {"kind": "uniform", "min": dmin, "max": dmax}, "placement": {"kind": "random"}}],
        "container": {"min": [0.0, 0.0], "max": [width, 1.5 * width], "wall_material": "wall",
                      "walls": {"y_max": {"kind": "velocity", "velocity": [0.0, -0.1]}}},
        "stop": {"packing_fraction": phi, "steps": steps},
        "sampling": {"every_steps": 200},
        "seed": 7
    })
}

/// The bonded particle method's compaction (Nezamabadi 2020, §2.1.3; issue 27's benchmark): `grains` aggregates
/// of 1.8–2.4 mm (uniform in diameter; about 220 to 390 primaries each), the sources' primaries
/// (0.07–0.13 mm, ρ = 2000 kg/m³, frictionless, `F_0` = 100 N/m, γ = 7: p_I ≈ 1 MPa), placed at
/// random at a grain Φ ≈ 0.5 in a box 1.5 times as high as wide without gravity; the top wall
/// moves down at 0.4 m/s (inertial number `ε̇ ⟨D⟩ sqrt(ρ/p)` ≈ 1e-3 at p = p_I for 100
/// grains: the quasi-static limit of the sources' biaxial tests) for `steps` steps. `method` is `"dem"` (contacts of k_n = 2e8 N/m, which
/// hold `F_0` at 0.7% of the smallest primary, restitution 0.2) or `"cd"` (restitution 0, the
/// aggregates' tolerance).
pub fn bpm_compaction(grains: usize, method: &str, steps: u64, threads: usize) -> serde_json::Value {
    let (dmin, dmax): (f64, f64) = (1.8e-3, 2.4e-3);
    let mean_square = (dmax.powi(3) - dmin.powi(3)) / (3.0 * (dmax - dmin));
    let solid = grains as f64 * std::f64::consts::PI / 4.0 * mean_square;
    let width = (solid / 0.5 / 1.5).sqrt();
    let restitution = if method == "cd" { 0.0 } else { 0.2 };
    json!({
        "name": format!("bpm-compaction-{grains}-{method}"),
        "dimension": 2,
        "method": {"kind": method, "threads": threads},
        "materials": {
            "primary": {"density": 2000.0, "contact": {"law": "linear", "k_n": 2.0e8}, "restitution": restitution, "friction": 0.0}
        },
        "particles": [{
            "material": "primary", "count": grains,
            "size": {"kind": "uniform", "min": dmin, "max": dmax},
            "placement": {"kind": "random"},
            "model": {"kind": "bonded_primaries", "primaries": {"kind": "uniform", "min": 7.0e-5, "max": 1.3e-4}, "attraction": {"force": 100.0}}
        }],
        "container": {"min": [0.0, 0.0], "max": [width, 1.5 * width], "wall_material": "primary",
                      "walls": {"y_max": {"kind": "velocity", "velocity": [0.0, -0.4]}}},
        "stop": {"steps": steps},
        "sampling": {"every_steps": steps.max(1)},
        "seed": 11
    })
}

/// The time step of [`fem_compaction`], s: the wall moves 20 µm, a 625th of the mean
/// diameter, a step. The longest step whose results differ from shorter steps' no more than
/// the moment a column of grains buckles makes them; twice as long is off by 2%, and no
/// cheaper, the dense part splitting its steps (docs/methods/fem.md, "Parameters").
pub const FEM_COMPACTION_STEP: f64 = 4e-4;

/// The sources' FEM compaction (Nezamabadi 2020, §2.1.2; issue 26's full-size scene): `grains` neo-Hookean disks
/// of 10–15 mm (uniform in diameter), shear modulus 0.15 MPa, ν = 0.495 (λ = 2μν/(1 − 2ν) =
/// 14.85 MPa), ρ = 1180 kg/m³, grain friction `friction`, frictionless walls, no gravity, placed
/// at random at Φ ≈ 0.5 in a box 1.5 times as high as wide; the top wall moves down at
/// 0.05 m/s (half a percent of the shear wave speed, 11 m/s: quasi-static, as the
/// sources' imposed displacement) until Φ = `phi` (or `steps`); method `fem` with
/// `elements_per_diameter` boundary elements across the smallest grain and steps of
/// `time_step` s ([`FEM_COMPACTION_STEP`] by default).
pub fn fem_compaction(
    grains: usize,
    friction: f64,
    phi: f64,
    steps: u64,
    elements_per_diameter: f64,
    time_step: f64,
    threads: usize,
) -> serde_json::Value {
    let (dmin, dmax): (f64, f64) = (10e-3, 15e-3);
    // <d²> of a uniform diameter distribution.
    let mean_square = (dmax.powi(3) - dmin.powi(3)) / (3.0 * (dmax - dmin));
    let solid = grains as f64 * std::f64::consts::PI / 4.0 * mean_square;
    let width = (solid / 0.5 / 1.5).sqrt();
    let (mu, nu) = (0.15e6, 0.495);
    let law = json!({"law": "neo_hookean", "shear_modulus": mu, "lambda": 2.0 * mu * nu / (1.0 - 2.0 * nu)});
    json!({
        "name": format!("fem-compaction-{grains}"),
        "dimension": 2,
        "method": {"kind": "fem", "elements_per_diameter": elements_per_diameter, "time_step": time_step, "threads": threads},
        "materials": {
            "silicone": {"density": 1180.0, "friction": friction, "deformable": law},
            "wall": {"density": 1180.0, "friction": 0.0, "deformable": law}
        },
        "particles": [{"material": "silicone", "count": grains, "size": {"kind": "uniform", "min": dmin, "max": dmax}, "placement": {"kind": "random"}}],
        "container": {"min": [0.0, 0.0], "max": [width, 1.5 * width], "wall_material": "wall",
                      "walls": {"y_max": {"kind": "velocity", "velocity": [0.0, -0.05]}}},
        "stop": {"packing_fraction": phi, "steps": steps},
        "sampling": {"every_steps": 200},
        "seed": 7
    })
}
