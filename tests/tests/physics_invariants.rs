//! Invariants every contact-mechanics engine must keep (docs/physics.md §2):
//! objectivity of the tangential spring under rigid rotation, Newton's third law and momentum
//! conservation in an isolated periodic system, and independence of the result from the number
//! of threads.

use crate::common;

use sable_engine::contact::{ContactInput, PairLaw};
use sable_engine::math::Vec3;
use sable_engine::methods::dem::Dem;
use sable_engine::run::Simulation;
use serde_json::json;

const RHO: f64 = 2500.0;

/// Rotation matrix applied to a vector: Rodrigues' formula about unit `axis` by `angle`.
fn rotate(v: &Vec3, axis: &Vec3, angle: f64) -> Vec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * (axis.dot(v) * (1.0 - c))
}

/// Result of a rigid rotation of a loaded contact.
struct Objectivity {
    /// Largest relative change of |f_t|.
    magnitude: f64,
    /// Largest |f - (f_n n(t) + R(t) f_t(0))| / |f_t(0)| (an angle in rad for small values).
    direction: f64,
    /// Largest relative change of the normal force.
    normal: f64,
    /// Largest |xi · n| / |xi| (the spring must stay in the tangent plane).
    off_plane: f64,
}

/// A 3D pair of equal spheres in contact (overlap 1e-6 m) with a tangential spring `xi0` in
/// the tangent plane, turned rigidly by a quarter turn about `axis` (through the pair's centre)
/// in `steps` steps. Positions follow the exact rotation; velocities are those of the rigid body
/// (v = Ω × (x - c)), both spins equal Ω. The inputs are built exactly as the DEM force loop
/// builds them (`methods/dem/forces.rs`).
fn rotate_pair(law: &PairLaw, axis: Vec3, xi_mix: f64, steps: usize) -> Objectivity {
    let r = 0.5e-3;
    let m = RHO * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    let delta = 1e-6;
    let axis = axis.normalize();
    // Initial normal: x; the pair's centre at the origin.
    let n0 = Vec3::new(1.0, 0.0, 0.0);
    let half = 0.5 * (2.0 * r - delta);
    let (xi0, xj0) = (n0 * half, -n0 * half);
    // Tangent basis at t = 0: t1 in the tangent plane and perpendicular to the axis where
    // possible, t2 = n × t1.
    let mut t1 = axis.cross(&n0);
    if t1.norm() < 1e-12 {
        t1 = Vec3::new(0.0, 1.0, 0.0);
    }
    t1 = t1.normalize();
    let t2 = n0.cross(&t1);
    let dt = 1e-7;
    let quarter = 0.5 * std::f64::consts::PI;
    let omega = axis * (quarter / (steps as f64 * dt));
    let input = |k: usize| -> ContactInput {
        let angle = quarter * k as f64 / steps as f64;
        let (pi, pj) = (rotate(&xi0, &axis, angle), rotate(&xj0, &axis, angle));
        let (vi, vj) = (omega.cross(&pi), omega.cross(&pj));
        let d = pi - pj;
        let dist = d.norm();
        let n = d / dist;
        let delta = 2.0 * r - dist;
        let (a_i, a_j) = (r - 0.5 * delta, r - 0.5 * delta);
        let v_c = (vi - vj) - (omega * a_i + omega * a_j).cross(&n);
        ContactInput {
            n,
            delta,
            r_i: r,
            r_j: r,
            r_eff: 0.5 * r,
            m_eff: 0.5 * m,
            a_i,
            a_j,
            v_c,
            v_damp: v_c,
            w_rel: Vec3::zeros(),
            spin_n: omega.dot(&n),
        }
    };
    // Pre-loaded spring: 1e-6 m (k_t |xi| = 2.9e-3 N, below the Coulomb cap 5e-3 N).
    let mut xi = (t1 * xi_mix.cos() + t2 * xi_mix.sin()) * 1e-6;
    let c0 = input(0);
    let f0 = law.compute(&c0, &mut xi, None, None, dt).force;
    let fn0 = f0.dot(&c0.n);
    let ft0 = f0 - c0.n * fn0;
    assert!(ft0.norm() > 1e-3, "the spring must be loaded, |f_t| = {}", ft0.norm());
    let mut o = Objectivity { magnitude: 0.0, direction: 0.0, normal: 0.0, off_plane: 0.0 };
    for k in 1..=steps {
        let c = input(k);
        let f = law.compute(&c, &mut xi, None, None, dt).force;
        let fnk = f.dot(&c.n);
        let ft = f - c.n * fnk;
        // The whole force must be the initial one turned with the pair: f_n n(t) + R(t) f_t(0)
        // (this also checks that the tangential part stays tangent).
        let expected = c.n * fn0 + rotate(&ft0, &axis, quarter * k as f64 / steps as f64);
        o.magnitude = o.magnitude.max((ft.norm() - ft0.norm()).abs() / ft0.norm());
        o.direction = o.direction.max((f - expected).norm() / ft0.norm());
        o.normal = o.normal.max((fnk - fn0).abs() / fn0);
        o.off_plane = o.off_plane.max(xi.dot(&c.n).abs() / xi.norm());
    }
    o
}

fn material(k_n: f64, e: f64, mu: f64) -> sable_engine::scene::Material {
    let s = common::scene(json!({
        "dimension": 3, "method": "dem",
        "materials": {"m": common::linear_material(k_n, e, mu)},
        "particles": [{"material": "m", "placement": {"kind": "list", "positions": [[0.005, 0.005, 0.005]], "diameters": [1e-3]}}],
        "container": {"min": [0, 0, 0], "max": [0.01, 0.01, 0.01], "periodic": ["x", "y", "z"]},
        "stop": {"steps": 1}
    }));
    s.materials[0].clone()
}

#[test]
fn tangential_spring_is_objective_under_rigid_rotation() {
    let mat = material(1e4, 0.5, 0.5);
    let law = PairLaw::between(&mat, &mat);
    let quarter = 0.5 * std::f64::consts::PI;
    // (name, rotation axis); the initial normal is x.
    let cases = [
        ("axis perpendicular to the normal", Vec3::new(0.0, 0.0, 1.0)),
        ("axis along the normal", Vec3::new(1.0, 0.0, 0.0)),
        ("oblique axis", Vec3::new(1.0, 2.0, 3.0)),
    ];
    for (name, axis) in cases {
        // A spring at 45° between the in-plane tangent and the axis direction has both
        // components, the hardest case for the projection onto the rotated tangent plane.
        let mut errors = Vec::new();
        for steps in [5_000, 10_000] {
            let o = rotate_pair(&law, axis, 0.25 * std::f64::consts::PI, steps);
            let eps = quarter / steps as f64;
            println!(
                "{name}, {steps} steps (turn {eps:.2e} rad/step): |f_t| {:.2e}, direction {:.2e}, f_n {:.2e}, off-plane {:.2e}",
                o.magnitude, o.direction, o.normal, o.off_plane
            );
            // The carry step rescales the spring to its previous length, so |f_t| is kept to
            // accumulated rounding (measured <= 5e-13 after 10^4 steps); 1e-9 is far tighter
            // than the 1e-6 anything physical would need.
            assert!(o.magnitude < 1e-9, "{name}: |f_t| changed by {:.3e} (relative)", o.magnitude);
            // The normal force does not depend on the rotation (the rigid-body contact velocity
            // is zero to rounding); measured 2.2e-13, the rounding of a 1e-6 m overlap computed
            // from 1e-3 m coordinates.
            assert!(o.normal < 1e-9, "{name}: f_n changed by {:.3e} (relative)", o.normal);
            assert!(o.off_plane < 1e-12, "{name}: the spring left the tangent plane ({:.3e})", o.off_plane);
            // Direction: projecting the spring onto the new tangent plane each step (then
            // restoring its length) rotates the component in the plane of motion by the right
            // angle but loses a factor cos(eps) on it relative to the component along the
            // axis: a first-order error of at most Φ eps / 4 after a turn Φ (sin 2φ / 2 = 1/2 for
            // the 45° spring). The twist about the normal is first order too, with its length
            // restored: angle atan(eps) per step, error Φ eps² / 3. Bound: Φ eps / 2.
            // Measured: 1.23e-4 and 6.17e-5 (perpendicular axis; Φ eps / 4 exactly), 5.2e-8 and
            // 1.3e-8 (axis along the normal; Φ eps² / 3), 1.15e-4 and 5.7e-5 (oblique).
            let bound = quarter * eps / 2.0;
            assert!(o.direction < bound, "{name}: f_t off the rigidly rotated force by {:.3e} (bound {bound:.3e})", o.direction);
            errors.push(o.direction);
        }
        // The direction error is a time-discretisation error: it shrinks at least linearly with
        // the step (halving the step must at least halve it, up to rounding).
        assert!(errors[1] < 0.55 * errors[0] + 1e-12, "{name}: direction error does not converge: {errors:?}");
    }
}

/// A dense 3D gas in a fully periodic box: 340 spheres (0.8-1.2 mm) at solid fraction 0.36, no
/// gravity, friction 0.5 and rolling resistance, Gaussian velocities (0.3 m/s per component).
fn gas_scene(threads: usize) -> serde_json::Value {
    json!({
        "dimension": 3,
        "method": {"kind": "dem", "threads": threads},
        "materials": {"m": {"density": RHO, "contact": {"law": "linear", "k_n": 1e4}, "restitution": 0.7, "friction": 0.5,
                             "rolling": {"stiffness": 1e-4, "friction": 0.1}}},
        "particles": [{"material": "m", "count": 340, "size": {"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3},
                       "placement": {"kind": "random"}, "velocity": {"kind": "gaussian", "std": 0.3}}],
        "container": {"min": [0, 0, 0], "max": [0.008, 0.008, 0.008], "periodic": ["x", "y", "z"]},
        "stop": {"steps": 1},
        "seed": 7
    })
}

#[test]
fn isolated_periodic_gas_has_zero_total_force_and_conserves_momentum() {
    let s = common::scene(gas_scene(0));
    let mut sim = common::dem(&s);
    let momentum = |sim: &Dem| {
        let p = sim.particles();
        (0..p.len()).map(|i| p.vel[i] * p.mass[i]).fold(Vec3::zeros(), |a, b| a + b)
    };
    let scale = {
        let p = sim.particles();
        (0..p.len()).map(|i| p.mass[i] * p.vel[i].norm()).sum::<f64>()
    };
    let p0 = momentum(&sim);
    let (mut worst_force, mut loaded_steps, mut contacts_seen) = (0.0_f64, 0, 0usize);
    for _ in 0..4000 {
        sim.step().expect("stable");
        let p = sim.particles();
        let total = p.force.iter().fold(Vec3::zeros(), |a, b| a + b);
        let magnitude: f64 = p.force.iter().map(|f| f.norm()).sum();
        if magnitude > 0.0 {
            loaded_steps += 1;
            worst_force = worst_force.max(total.norm() / magnitude);
        }
        contacts_seen += sim.contacts().len();
    }
    let drift = (momentum(&sim) - p0).norm() / scale;
    println!(
        "gas: {loaded_steps} loaded steps, {contacts_seen} contact-steps; |Σ F| / Σ |F| <= {worst_force:.2e}; momentum drift {drift:.2e}"
    );
    assert!(
        loaded_steps > 3000 && contacts_seen > 10_000,
        "the gas must collide ({loaded_steps} steps with forces, {contacts_seen} contact-steps)"
    );
    // Each pair force is added to i and subtracted from j exactly; the only error is the
    // rounding of the per-particle sums (~1e-16 relative; measured 7.7e-17), so 1e-12 is a
    // wide margin.
    assert!(worst_force < 1e-12, "total force not zero: |Σ F| / Σ |F| = {worst_force:.3e}");
    // Velocity Verlet with a zero force sum keeps Σ m v to rounding per step (4000 steps of
    // ~1e-16 rounding: ~1e-13 at worst; measured 6.8e-17), relative to Σ m |v|.
    assert!(drift < 1e-11, "momentum drifted by {drift:.3e} of Σ m|v|");
}

/// A box with walls (one moving), friction and rolling resistance, gravity, and enough particles
/// (600) for the force loop to split across threads (pairs are processed in chunks of 256).
fn walled_scene(dim: usize, threads: usize) -> serde_json::Value {
    let (min, max, periodic, gravity, top) = if dim == 2 {
        (json!([0, 0]), json!([0.032, 0.03]), json!([]), json!([0.0, -9.81]), json!([0.0, -0.5]))
    } else {
        (json!([0, 0, 0]), json!([0.01, 0.01, 0.01]), json!(["z"]), json!([0.0, -9.81, 0.0]), json!([0.0, -0.5, 0.0]))
    };
    let k_n = if dim == 2 { 1.5e7 } else { 1e4 };
    json!({
        "dimension": dim,
        "method": {"kind": "dem", "threads": threads, "skin": 0.5},
        "materials": {"m": {"density": RHO, "contact": {"law": "linear", "k_n": k_n}, "restitution": 0.6, "friction": 0.5,
                             "rolling": {"stiffness": 0.1 * k_n * 0.25e-6, "friction": 0.05}}},
        "particles": [{"material": "m", "count": 600, "size": {"kind": "uniform", "min": 0.8e-3, "max": 1.2e-3},
                       "placement": {"kind": "random"}, "velocity": {"kind": "gaussian", "std": 0.5}}],
        "container": {"min": min, "max": max, "periodic": periodic, "wall_material": "m",
                      "walls": {"y_max": {"kind": "velocity", "velocity": top}}},
        "gravity": gravity,
        "stop": {"steps": 1},
        "seed": 3
    })
}

#[test]
fn parallel_force_loop_reproduces_the_serial_run_bit_for_bit() {
    for dim in [2, 3] {
        let mut serial = common::dem(&common::scene(walled_scene(dim, 1)));
        let mut parallel = common::dem(&common::scene(walled_scene(dim, 2)));
        assert!(serial.neighbor_pairs() > 512, "{dim}D: too few pairs ({}) to exercise several chunks", serial.neighbor_pairs());
        let mut contact_samples = 0;
        for k in 0..4000 {
            serial.step().expect("stable");
            parallel.step().expect("stable");
            if k % 100 == 0 {
                contact_samples += serial.contacts().len();
            }
        }
        let (a, b) = (serial.particles(), parallel.particles());
        let contacts = serial.contacts().len();
        println!(
            "{dim}D: {} particles, {} pairs, {contacts} contacts after 4000 steps, {contact_samples} contacts in 40 samples",
            a.len(),
            serial.neighbor_pairs()
        );
        // The run must exercise pair and wall contacts all along (measured: ~20 (2D) and ~40 (3D)
        // at any instant).
        assert!(contact_samples > 200, "{dim}D: too few contacts ({contact_samples} in 40 samples)");
        // Bitwise: every pair writes its own slot and the per-particle gather runs in a fixed
        // order, so no floating-point sum depends on the thread count.
        for i in 0..a.len() {
            assert_eq!(a.pos[i], b.pos[i], "{dim}D: position of particle {i} differs");
            assert_eq!(a.vel[i], b.vel[i], "{dim}D: velocity of particle {i} differs");
            assert_eq!(a.omega[i], b.omega[i], "{dim}D: spin of particle {i} differs");
        }
        assert_eq!(serial.walls()[..], parallel.walls()[..], "{dim}D: wall states differ");
        assert_eq!(serial.sample().expect("sample"), parallel.sample().expect("sample"), "{dim}D: samples differ");
    }
}
