//! Verification of the method on problems with known answers (docs/references.md §G).

use super::contact::{Sides, Wall};
use super::field::Field;
use super::grain::Grain;
use super::grid::{Grid, V2};
use super::outline::Outline;
use super::points::Points;
use super::system::{Settings, System};
use crate::constitutive::{build, LawSpec};
use crate::math::Real;

/// The tests' FLIP fraction of the points' velocity update, unless they ask for [`PIC`].
const FLIP: Real = 1.0;

/// The FLIP fraction of a pure PIC update.
const PIC: Real = 0.0;

fn settings(dt: Real) -> Settings {
    Settings {
        dt,
        theta: 0.5,
        gravity: V2::zeros(),
        quasi_static: false,
        newton_tolerance: 1e-6,
        max_newton: 20,
        contact: crate::methods::soft::tests_convergence(),
        sides: Sides::One,
    }
}

/// Mass-weighted mean velocity of the points `range`.
fn mean_velocity(p: &Points, range: std::ops::Range<usize>) -> V2 {
    let (mut mv, mut m) = (V2::zeros(), 0.0);
    for i in range {
        mv += p.v[i] * p.mass[i];
        m += p.mass[i];
    }
    mv / m
}

/// The axially vibrating bar (docs/references.md check 20; Buzzi et al. 2008's set): fixed–free, L = 25,
/// E = 100, ρ = 1, v(x, 0) = v0 sin(πx / 2L), v0 = 0.1, 16 cells along L, 2 points a cell,
/// dt = 0.2 Δx / c, five periods (T = 10). The fixed end is the middle of a free–free bar of
/// length 2L vibrating in its first antisymmetric mode, which has a node there; the half bar's
/// centre-of-mass velocity is v0 / (βL) cos(ωt), β = π / 2L. Plane strain with ν = 0 is a
/// uniaxial bar. Amplitude and period within 1% over five periods (the reference's tolerance).
#[test]
fn the_vibrating_bar_keeps_its_amplitude_and_period() {
    let (e, rho, l, v0) = (100.0, 1.0, 25.0, 0.1);
    let dx = l / 16.0;
    let c = (e / rho as Real).sqrt();
    let beta = std::f64::consts::PI / (2.0 * l);
    let omega = beta * c;
    let period = 2.0 * std::f64::consts::PI / omega;
    let mut points = Points::default();
    let range = points.fill_rectangle(V2::new(-l, 0.0), V2::new(l, dx), dx / 2.0, |x| V2::new(v0 * (beta * x.x).sin(), 0.0), rho);
    let half: Vec<usize> = range.clone().filter(|&p| points.x[p].x > 0.0).collect();
    let grid = Grid::covering(V2::new(-l, 0.0), V2::new(l, dx), dx, 4);
    let grains = vec![Grain { points: range, law: 0, friction: 0.0, radius: l, outline: Outline::default() }];
    let dt = 0.2 * dx / c;
    let mut sys =
        System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young: e, poisson: 0.0 })], vec![], settings(dt), FLIP);
    let v_cm = |sys: &System| {
        let (mut mv, mut m) = (0.0, 0.0);
        for &p in &half {
            mv += sys.points.v[p].x * sys.points.mass[p];
            m += sys.points.mass[p];
        }
        mv / m
    };
    let amplitude = v0 / (beta * l);
    let steps = (5.0 * period / dt).round() as usize;
    let mut series = vec![(0.0, v_cm(&sys))];
    for _ in 0..steps {
        sys.step().expect("stable");
        series.push((sys.progress.time, v_cm(&sys)));
    }
    // Period from the zero crossings (linear interpolation), amplitude from the last period.
    let crossings: Vec<Real> = series
        .windows(2)
        .filter(|w| w[0].1.signum() != w[1].1.signum())
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
        .collect();
    assert!(crossings.len() >= 9, "{} crossings", crossings.len());
    let measured = 2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as Real;
    let last = series.iter().filter(|s| s.0 > 4.0 * period).map(|s| s.1.abs()).fold(0.0, Real::max);
    let first = series[0].1;
    eprintln!("bar: period {measured:.5} (exact {period:.5}), start {first:.6}, last-period amplitude {last:.6} (exact {amplitude:.6})");
    assert!((first - amplitude).abs() < 0.01 * amplitude, "initial v_cm {first} against {amplitude}");
    assert!((measured - period).abs() < 0.01 * period, "period {measured} against {period}");
    assert!((last - amplitude).abs() < 0.01 * amplitude, "amplitude {last} against {amplitude}");
}

/// Two elastic disks colliding (Sulsky, Chen & Schreyer 1994; docs/references.md check 21): unit square,
/// 20x20 cells, 2x2 points a cell, radius 0.2 at (0.2, 0.2) and (0.8, 0.8), velocities
/// ±(0.1, 0.1), E = 1000, ν = 0.3, ρ = 1000, plane strain, to t = 4, at dt = 0.01 (ten times
/// the reference's explicit step). With one field per grain the disks meet through contact
/// and part again; momentum is conserved to rounding at every step and energy never grows.
/// Measured: they part at 0.76 of their approach speed, with 74% of the energy (the contact
/// is inelastic: the outlines meet at the same normal velocity, and the disks rebound only by
/// what their elasticity stored; with the contacts at the outer points' centres 0.31 and 32%,
/// on the nodes' velocities, which let the point clouds overlap, 0.54 and 45%). A shared grid
/// makes them stick (0 after).
#[test]
fn two_disks_collide_and_part() {
    disks_collide_and_part(Sides::One);
}

/// The same collision with both disks' outlines held outside the other's ([`Sides::Both`]):
/// momentum, energy and parting as one-sided. Measured: they part at 0.77 of their approach
/// speed (0.77 one-sided), in 1.7 times the sweeps.
#[test]
fn two_disks_collide_and_part_with_both_sides_held() {
    disks_collide_and_part(Sides::Both);
}

fn disks_collide_and_part(sides: Sides) {
    let (rho, r) = (1000.0, 0.2);
    let h = 0.05;
    let mut points = Points::default();
    let a = points.fill_disk(V2::new(0.2, 0.2), r, h / 2.0, V2::new(0.1, 0.1), rho);
    let b = points.fill_disk(V2::new(0.8, 0.8), r, h / 2.0, V2::new(-0.1, -0.1), rho);
    let grid = Grid::covering(V2::new(0.0, 0.0), V2::new(1.0, 1.0), h, 4);
    let (oa, ob) = (Outline::disk(&points, a.clone(), V2::new(0.2, 0.2), r, h), Outline::disk(&points, b.clone(), V2::new(0.8, 0.8), r, h));
    let grains = vec![
        Grain { points: a.clone(), law: 0, friction: 0.0, radius: r, outline: oa },
        Grain { points: b.clone(), law: 0, friction: 0.0, radius: r, outline: ob },
    ];
    let law = build(&LawSpec::LinearElastic { young: 1000.0, poisson: 0.3 });
    let mut sys = System::new(grid, points, grains, vec![law], Vec::<Wall>::new(), Settings { sides, ..settings(0.01) }, FLIP);
    let mass: Real = sys.points.mass.iter().sum();
    let approach = |s: &System| {
        let d = mean_velocity(&s.points, a.clone()) - mean_velocity(&s.points, b.clone());
        d.dot(&V2::new(1.0, 1.0).normalize())
    };
    let before = approach(&sys);
    let energy0 = sys.kinetic_energy() + sys.strain_energy();
    let mut most = energy0;
    let mut touched = false;
    for _ in 0..400 {
        let rep = sys.step().expect("stable");
        touched |= sys.contacts.iter().any(|c| c.active());
        most = most.max(sys.kinetic_energy() + sys.strain_energy());
        let p: V2 = (0..sys.points.len()).map(|i| sys.points.v[i] * sys.points.mass[i]).sum();
        assert!(p.norm() < 1e-12 * mass * 0.1, "momentum {p} at step {} ({} Newton iterations)", sys.progress.steps, rep.newton);
    }
    let after = approach(&sys);
    let energy = sys.kinetic_energy() + sys.strain_energy();
    eprintln!(
        "two disks ({sides:?}): approach speed {before:.4} before, {after:.4} after; energy {energy0:.4e} before, {energy:.4e} after, at most {most:.4e} ({} Newton, {} sweeps)",
        sys.progress.totals.newton, sys.progress.totals.sweeps
    );
    // The trapezoidal rule adds no energy; the contact (inelastic at the nodes) takes some.
    assert!(most <= energy0 * (1.0 + 1e-6), "energy grew to {most} from {energy0}");
    assert!(touched, "the disks never touched");
    assert!(after < -0.2 * before, "the disks did not part: relative normal velocity {after} after, {before} before");
}

/// The Hertz fit ([`crate::methods::soft::hertz::fit`]) of the wall forces at the outline's
/// vertices: (half-width, total force, peak pressure).
fn wall_contact(sys: &System) -> (Real, Real, Real) {
    let mut at: Vec<(Real, Real)> = Vec::new();
    for c in &sys.contacts {
        if let super::contact::Other::Wall(_) = c.b {
            at.push((c.at.x, c.r.x / sys.progress.last_dt()));
        }
    }
    crate::methods::soft::hertz::fit(&mut at)
}

/// Runs an elastic disk of radius 1 m settling under gravity on a rigid floor, quasi-statically
/// (backward Euler, steps longer than its slowest period), at `cells` cells across the radius.
fn disk_on_plane(cells: usize) -> (Real, Real, Real, Real, Real, Real) {
    let (r, young, nu, rho) = (1.0, 1e6, 0.3, 1000.0);
    let e_star = young / (1.0 - nu * nu);
    // Load for a/R = 0.16: P' = π E* a² / 4R.
    let a_want: Real = 0.16;
    let load = std::f64::consts::PI * e_star * a_want * a_want / (4.0 * r);
    let h = r / cells as Real;
    let mut points = Points::default();
    let range = points.fill_disk(V2::new(0.0, r), r, h / 2.0, V2::zeros(), rho);
    let mass: Real = points.mass[range.clone()].iter().sum();
    let g = load / mass;
    let grid = Grid::covering(V2::new(-1.2 * r, 0.0), V2::new(1.2 * r, 2.2 * r), h, 4);
    let floor = Wall { point: V2::zeros(), normal: V2::new(0.0, 1.0), velocity: V2::zeros(), friction: 0.0 };
    let outline = Outline::disk(&points, range.clone(), V2::new(0.0, r), r, h);
    let grains = vec![Grain { points: range, law: 0, friction: 0.0, radius: r, outline }];
    let mut s = settings(0.1);
    s.theta = 1.0;
    let mut sys = System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young, poisson: nu })], vec![floor], s, PIC);
    sys.ghost = super::ghost::GAMMA;
    for k in 1..=30 {
        sys.settings.gravity = V2::new(0.0, -g * (k as Real / 10.0).min(1.0));
        sys.step().expect("stable");
    }
    let (a, f, p0) = wall_contact(&sys);
    let load = mass * g;
    let a_hertz = (4.0 * load * r / (std::f64::consts::PI * e_star)).sqrt();
    (a, a_hertz, f, load, p0, 2.0 * load / (std::f64::consts::PI * a_hertz))
}

/// An elastic disk (R = 1 m, E = 1 MPa, ν = 0.3) pressed on a rigid plane by its weight,
/// loaded quasi-statically, against Hertz's line contact (docs/references.md check 19, Johnson 1985 §4):
/// `a = sqrt(4 P' R / π E*)`, `p0 = 2 P' / π a`, for `a / R = 0.16`. The half-width of the
/// Hertz profile that fits the vertex forces is within 5% of Hertz's at 20 cells across the
/// radius (the tolerance; measured 3.1% narrow) and within 7% at 40 (4.8%); before the
/// ghost penalty ([`super::ghost`]) it settled about 4.5% narrow as the grid was refined
/// (7.2% at 30 cells, 5.0% at 40 after sixty steps, 4.2% at 60, 4.5% at 80) — as the finite element method does on the
/// same disk (4.4% at R/25, 4.6% at R/50, [`crate::methods::fem`]): the departure is Hertz's
/// small-strain limit (contact strains about a / 2R), halved at a / R = 0.08. The contacts act at the disk's outline
/// through its outer points' fields, linearly extrapolated from their centres (module
/// documentation of [`super::contact`]), and the outer layer this loads is stiffer than the
/// continuum by about as much as the squeezed block's is softer
/// ([`a_squeezed_block_follows_each_law`]). The wall forces balance the load within 0.5% after
/// thirty steps (measured 4e-6), and the largest vertex force over the vertex spacing stays
/// within a quarter of `p0` (measured 0.99 and 1.05; 0.97 and 1.69 before the ghost penalty,
/// whose thin nodes under the contact let the vertex forces bunch).
#[test]
fn an_elastic_disk_on_a_plane_approaches_hertz() {
    let mut errors = Vec::new();
    for cells in [20, 40] {
        let (a, a_h, f, load, p0, p0_h) = disk_on_plane(cells);
        eprintln!("R/h {cells}: a {a:.4} (Hertz {a_h:.4}), force {f:.4e} (load {load:.4e}), peak {p0:.4e} (Hertz {p0_h:.4e})");
        assert!((f - load).abs() < 5e-3 * load, "wall force {f} against the load {load}");
        errors.push(((a - a_h) / a_h).abs());
        assert!((p0 / p0_h - 1.0).abs() < 0.25, "peak pressure {p0} against Hertz's {p0_h}");
    }
    assert!(errors[0] < 0.05, "half-width error {:.3} at 20 cells a radius", errors[0]);
    assert!(errors[1] < 0.07, "half-width error {:.3} at 40 cells a radius", errors[1]);
}

/// A soft block on a floor under gravity tilted by θ (the incline), friction μ = 0.5 with the
/// floor (docs/references.md check 23): it rests iff tan θ <= μ, and slides with the acceleration
/// g (sin θ − μ cos θ) otherwise. Returns the block's mean velocity along the slope at `t/2`
/// and `t`, and the sliding acceleration of Coulomb's law.
fn block_on_incline(tan: Real, t: Real) -> (Real, Real, Real) {
    let (mu, g, rho) = (0.5, 9.81, 1000.0);
    let h = 0.1;
    let mut points = Points::default();
    let range = points.fill_rectangle(V2::new(-0.5, 0.0), V2::new(0.5, 0.5), h / 2.0, |_| V2::zeros(), rho);
    let grid = Grid::covering(V2::new(-1.5, 0.0), V2::new(3.0, 1.0), h, 4);
    let floor = Wall { point: V2::zeros(), normal: V2::new(0.0, 1.0), velocity: V2::zeros(), friction: mu };
    let outline = Outline::rectangle(&points, range.clone(), V2::new(-0.5, 0.0), V2::new(0.5, 0.5), h);
    let grains = vec![Grain { points: range.clone(), law: 0, friction: mu, radius: 0.25, outline }];
    let angle = tan.atan();
    let mut s = settings(0.01);
    s.theta = 1.0;
    s.gravity = V2::new(g * angle.sin(), -g * angle.cos());
    let mut sys =
        System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young: 1e6, poisson: 0.3 })], vec![floor], s, FLIP);
    let steps = (t / 0.01).round() as usize;
    let mut half = 0.0;
    for k in 1..=steps {
        sys.step().expect("stable");
        if k == steps / 2 {
            half = mean_velocity(&sys.points, range.clone()).x;
        }
    }
    (half, mean_velocity(&sys.points, range).x, g * (angle.sin() - mu * angle.cos()))
}

/// At tan θ = 0.4 the block stays (its mean velocity within 1e-3 of what sliding would give);
/// at tan θ = 0.6 it slides at Coulomb's acceleration within 1%, measured over the second half
/// second (the first carries the block's settling on the floor, when its normal force is
/// still building up).
#[test]
fn a_block_on_an_incline_rests_iff_tan_is_within_friction() {
    let t = 1.0;
    let (_, v_rest, _) = block_on_incline(0.4, t);
    let (v_half, v_slide, a) = block_on_incline(0.6, t);
    let measured = (v_slide - v_half) / (0.5 * t);
    eprintln!("incline: tan 0.4 mean velocity {v_rest:.3e} m/s; tan 0.6 acceleration {measured:.4} m/s² (Coulomb {a:.4})");
    assert!(v_rest.abs() < 1e-3 * a * t, "the block slid at tan θ = 0.4 < μ: {v_rest} m/s");
    assert!((measured - a).abs() < 0.01 * a, "sliding acceleration {measured} against {a}");
}

/// A small uniaxial compaction (the set of Nezamabadi 2020, §2.1.1, CI-sized): grains of 1.4–2.4 mm on
/// a lattice in a box, the top wall moving down, no gravity, no wall friction, E = 10 MPa,
/// ν = 0.45, ρ = 990 kg/m³. Returns (Φ reached, steps, seconds).
fn compaction(columns: usize, rows: usize, speed: Real, dt: Real, target: Real, cells_per_dmin: Real) -> (Real, u64, Real, Real) {
    let (dmin, dmax, rho) = (1.4e-3, 2.4e-3, 990.0);
    let pitch = 2.5e-3;
    let h = dmin / cells_per_dmin;
    let mut points = Points::default();
    let mut grains = Vec::new();
    let mut k = 0u64;
    for j in 0..rows {
        for i in 0..columns {
            k = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = (k >> 11) as Real / (1u64 << 53) as Real;
            let d = dmin + (dmax - dmin) * u;
            let c = V2::new((i as Real + 0.5) * pitch, (j as Real + 0.5) * pitch);
            let range = points.fill_disk(c, d / 2.0, h / 2.0, V2::zeros(), rho);
            let outline = Outline::disk(&points, range.clone(), c, d / 2.0, h);
            grains.push(Grain { points: range, law: 0, friction: 0.0, radius: d / 2.0, outline });
        }
    }
    let (w, top) = (columns as Real * pitch, rows as Real * pitch);
    let grid = Grid::covering(V2::new(0.0, 0.0), V2::new(w, top), h, 4);
    let walls = vec![
        Wall { point: V2::zeros(), normal: V2::new(0.0, 1.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::zeros(), normal: V2::new(1.0, 0.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::new(w, 0.0), normal: V2::new(-1.0, 0.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::new(0.0, top), normal: V2::new(0.0, -1.0), velocity: V2::new(0.0, -speed), friction: 0.0 },
    ];
    let mut s = settings(dt);
    s.theta = 1.0;
    s.newton_tolerance = 1e-5;
    s.contact = crate::nscd::Convergence {
        tolerance: 1e-6,
        violation_tolerance: 1e-6,
        worst_tolerance: 1e-4,
        max_iterations: 20_000,
        relaxation: 1.0,
        acceleration: 0.9,
        damp_cycles: true,
    };
    let law = build(&LawSpec::LinearElastic { young: 10e6, poisson: 0.45 });
    let mut sys = System::new(grid, points, grains, vec![law], walls, s, PIC);
    let t0 = std::time::Instant::now();
    let phi = |s: &System| {
        let area: Real = (0..s.points.len()).map(|p| s.points.area(p)).sum();
        area / (w * s.walls[3].point.y)
    };
    let mut jmin: Real = 1.0;
    while phi(&sys) < target {
        if let Err(e) = sys.step() {
            panic!("step {}: {:?} at Φ {:.3}", sys.progress.steps, e, phi(&sys));
        }
        jmin = jmin.min((0..sys.points.len()).map(|p| sys.points.f[p].determinant()).fold(1.0, Real::min));
    }
    (phi(&sys), sys.progress.steps, t0.elapsed().as_secs_f64(), jmin)
}

/// The compaction reaches Φ >= 0.9 without any inverted point (J > 0 everywhere), at an
/// implicit step of 5e-5 s (the explicit one is h/c = 2.3e-7 s here): 12 grains, 6 cells
/// across the smallest. Measured: Φ 0.90 after 1,132 steps, smallest J 0.84, 14 s (test
/// profile, two threads).
#[test]
fn a_small_compaction_passes_phi_0_9_without_inverting_a_point() {
    let (phi, steps, seconds, jmin) = compaction(3, 4, 0.1, 5e-5, 0.9, 6.0);
    eprintln!("compaction: Φ {phi:.4} after {steps} steps, smallest J {jmin:.3}, {seconds:.1} s");
    assert!(phi >= 0.9);
    assert!(jmin > 0.5, "a point was squeezed to J = {jmin}");
}

/// A square block (1 m, `size / h` cells, 2x2 points a cell) squeezed between frictionless
/// walls in uniaxial strain (`F = diag(1, λ)`), quasi-statically (backward Euler, dt = 0.5 s,
/// the top wall at 1 cm/s: 3 steps to 1.5% strain), through the whole method — projection,
/// Newton, contact at the block's outline, point update: the top wall's force against the
/// law's closed-form `σ_yy = τ_yy(λ) / λ`. Returns the worst relative error over the steps.
fn squeezed_block(spec: LawSpec, size: Real, h: Real, closed: impl Fn(Real) -> Real) -> (Real, Real) {
    let rho = 1000.0;
    let mut points = Points::default();
    let range = points.fill_rectangle(V2::new(0.0, 0.0), V2::new(size, size), h / 2.0, |_| V2::zeros(), rho);
    let grid = Grid::covering(V2::new(0.0, 0.0), V2::new(size, size), h, 4);
    let speed = 0.01;
    let walls = vec![
        Wall { point: V2::zeros(), normal: V2::new(0.0, 1.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::zeros(), normal: V2::new(1.0, 0.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::new(size, 0.0), normal: V2::new(-1.0, 0.0), velocity: V2::zeros(), friction: 0.0 },
        Wall { point: V2::new(0.0, size), normal: V2::new(0.0, -1.0), velocity: V2::new(0.0, -speed), friction: 0.0 },
    ];
    let outline = Outline::rectangle(&points, range.clone(), V2::new(0.0, 0.0), V2::new(size, size), h);
    let grains = vec![Grain { points: range, law: 0, friction: 0.0, radius: 0.5, outline }];
    let mut s = settings(0.5);
    s.theta = 1.0;
    s.contact.tolerance = 1e-7;
    s.contact.acceleration = 0.9;
    let mut sys = System::new(grid, points, grains, vec![build(&spec)], walls, s, PIC);
    sys.ghost = super::ghost::GAMMA;
    let mut worst: Real = 0.0;
    // The wall's work as the method counts it (impulse times velocity: the end-of-step force
    // over each step, which backward Euler dissipates a part of) and by the trapezoidal rule
    // (the work of the force ramp itself).
    let (mut work, mut trapezoid, mut before) = (0.0, 0.0, 0.0);
    for _ in 0..3 {
        sys.step().expect("stable");
        work -= sys.progress.wall_impulse[3].dot(&sys.walls[3].velocity);
        let now = sys.progress.wall_force[3].y;
        trapezoid += 0.5 * (before + now) * speed * sys.settings.dt;
        before = now;
        let stretch = sys.walls[3].point.y / size;
        let (force, want) = (sys.progress.wall_force[3].y, -closed(stretch) * size);
        worst = worst.max((force - want).abs() / want.abs());
        eprintln!("{}: stretch {stretch:.3} wall force {force:.6e} N/m, closed form {want:.6e}", sys.laws[0].name());
    }
    let stored = sys.strain_energy() + sys.kinetic_energy();
    eprintln!("{}: wall work {work:.6e} J/m (trapezoidal {trapezoid:.6e}), strain and kinetic energy {stored:.6e}", sys.laws[0].name());
    eprintln!(
        "{}: {} Newton iterations, {} sweeps, {} split steps",
        sys.laws[0].name(),
        sys.progress.totals.newton,
        sys.progress.totals.sweeps,
        sys.progress.splitting.substeps
    );
    (worst, (stored - trapezoid).abs() / trapezoid)
}

/// Each law through the method (the laws alone match their closed forms to 1e-9 and better in
/// `constitutive::tests`), at 10 cells across the block: the wall force within 1% of the
/// closed form over the three steps for every law (measured 0.40%, 0.40%, 0.42%); the error is
/// the outer layer's and shrinks as the grid is refined (linear elastic at 20 cells: 0.18%,
/// asserted below three quarters of the 10-cell error). The walls hold the block's outline,
/// half a point spacing beyond its outer points' centres, and the traction reaches the grid
/// through those points' fields extrapolated linearly to it (module documentation of
/// [`super::contact`]). Before the ghost penalty on the thinly supported nodes
/// ([`super::ghost`]) the outer layer took more of the strain than the bulk, and the errors were
/// 4.7%, 4.8% and 8.0% at 10 cells, 3.2% at 20. The elastic laws store the work of the force
/// ramp within 2% (measured 0.5%).
#[test]
fn a_squeezed_block_follows_each_law() {
    let (young, nu, yield_stress, hardening) = (1e6, 0.3, 5e3, 1e5);
    let m = crate::constitutive::Lame::from_young(young, nu);
    let j2 = |l: Real| {
        // Uniaxial strain ε = ln λ with von Mises and linear hardening, radial return.
        let eps = l.ln();
        let alpha = ((2.0 * m.mu * eps.abs() - yield_stress) / (3.0 * m.mu + hardening)).max(0.0);
        let q = 2.0 * m.mu * eps.abs() - 3.0 * m.mu * alpha;
        (m.bulk() * eps + eps.signum() * 2.0 * q / 3.0) / l
    };
    let elastic = |l: Real| m.p_wave() * l.ln() / l;
    let runs = [
        squeezed_block(LawSpec::LinearElastic { young, poisson: nu }, 1.0, 0.1, elastic),
        squeezed_block(LawSpec::NeoHookean { shear_modulus: m.mu, lambda: m.lambda }, 1.0, 0.1, |l: Real| {
            (m.mu * (l * l - 1.0) + m.lambda * l.ln()) / l
        }),
        squeezed_block(LawSpec::Elastoplastic { young, poisson: nu, yield_stress, hardening }, 1.0, 0.1, j2),
    ];
    let errors = runs.map(|r| r.0);
    eprintln!("worst relative errors (linear elastic, neo-Hookean, elastoplastic): {errors:?}");
    assert!(errors.iter().all(|&e| e < 1e-2), "wall force off the closed form: {errors:?}");
    let (finer, _) = squeezed_block(LawSpec::LinearElastic { young, poisson: nu }, 1.0, 0.05, elastic);
    eprintln!("linear elastic at 20 cells: {finer:.4}");
    assert!(finer < 0.75 * errors[0], "the outer layer's error does not shrink: {finer} at 20 cells, {} at 10", errors[0]);
    // The elastic laws store the work of the force ramp (backward Euler's end-of-step forces
    // count 4/3 of it over three equal steps, the method's numerical dissipation).
    let energy = [runs[0].1, runs[1].1];
    eprintln!("stored energy against the work of the ramp (linear elastic, neo-Hookean): {energy:?}");
    assert!(energy.iter().all(|&e| e < 2e-2), "stored energy off the work put in: {energy:?}");
}

#[test]
fn snapshot_points_tile_the_grain_with_its_stress() {
    let (young, nu, eps) = (1e6, 0.3, -0.02);
    let mut points = Points::default();
    let range = points.fill_rectangle(V2::new(0.0, 0.0), V2::new(1.0, 0.5), 0.1, |_| V2::new(0.0, 0.25), 1000.0);
    let f = crate::constitutive::Mat2::new(1.0 + eps, 0.0, 0.0, 1.0);
    for p in range.clone() {
        points.f[p] = f;
        points.x[p].x *= 1.0 + eps;
    }
    let grid = Grid::covering(V2::new(0.0, 0.0), V2::new(1.0, 0.5), 0.2, 4);
    let grains = vec![Grain { points: range.clone(), law: 0, friction: 0.0, radius: 0.5, outline: Outline::default() }];
    let sys = System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young, poisson: nu })], vec![], settings(1.0), FLIP);
    let drawn = sys.material_points();
    assert_eq!(drawn.corners.len(), range.len());
    let area: Real =
        drawn.corners.iter().map(|c| 0.5 * (0..4).map(|k| c[k].x * c[(k + 1) % 4].y - c[(k + 1) % 4].x * c[k].y).sum::<Real>()).sum();
    assert!((area - 0.5 * (1.0 + eps)).abs() < 1e-12, "quads cover {area} (counter-clockwise: positive)");
    let m = crate::constitutive::Lame::from_young(young, nu);
    let e = (1.0 + eps).ln();
    let j = 1.0 + eps;
    let (txx, tyy, tzz) = (m.lambda * e + 2.0 * m.mu * e, m.lambda * e, m.lambda * e);
    let mean = (txx + tyy + tzz) / (3.0 * j);
    let dev = ((txx / j - mean).powi(2) + (tyy / j - mean).powi(2) + (tzz / j - mean).powi(2)) * 1.5;
    for k in 0..drawn.corners.len() {
        assert!((drawn.jacobian[k] - j).abs() < 1e-15);
        assert!((drawn.pressure[k] + mean).abs() < 1e-6 * mean.abs(), "pressure {} against {}", drawn.pressure[k], -mean);
        assert!((drawn.mises[k] - dev.sqrt()).abs() < 1e-6 * dev.sqrt(), "von Mises {} against {}", drawn.mises[k], dev.sqrt());
        assert_eq!(drawn.grain[k], 0);
        assert!((drawn.velocity[k].y - 0.25).abs() < 1e-15);
    }
    assert!(drawn.pressure[0] > 0.0, "compressed along x: positive pressure");
}

/// The interpenetration counts the area two grains' outlines share and the area beyond the
/// box: two unit squares overlapping by half, the second reaching a quarter beyond the box.
#[test]
fn interpenetration_counts_shared_and_outside_area() {
    let mut points = Points::default();
    let (a0, a1) = (V2::new(0.0, 0.0), V2::new(1.0, 1.0));
    let (b0, b1) = (V2::new(0.5, 0.0), V2::new(1.5, 1.0));
    let a = points.fill_rectangle(a0, a1, 0.1, |_| V2::zeros(), 1000.0);
    let b = points.fill_rectangle(b0, b1, 0.1, |_| V2::zeros(), 1000.0);
    let grains = vec![
        Grain { points: a.clone(), law: 0, friction: 0.0, radius: 0.5, outline: Outline::rectangle(&points, a, a0, a1, 0.2) },
        Grain { points: b.clone(), law: 0, friction: 0.0, radius: 0.5, outline: Outline::rectangle(&points, b, b0, b1, 0.2) },
    ];
    let grid = Grid::covering(V2::new(0.0, 0.0), V2::new(1.5, 1.0), 0.2, 4);
    let sys =
        System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young: 1e6, poisson: 0.3 })], vec![], settings(1.0), FLIP);
    // The box ends at x = 1.25: 0.5 shared, 0.25 of the second square outside.
    let area = sys.interpenetration(V2::new(0.0, 0.0), V2::new(1.25, 1.0));
    assert!((area - 0.75).abs() < 1e-9, "interpenetration {area}");
}

/// The Newton matrix of a grain's field is the derivative of its residual with respect to the
/// nodal velocities, `M + (θh)² K` (module documentation of [`super::field`]), for every law,
/// the elastoplastic one while yielding: a disk of points (radius 1 m, cell 0.3 m, 2×2 points
/// a cell) with a smooth non-uniform deformation `F_n` (and the history the law returns there),
/// dt = 1 s and θ = 1 (the displacements are the velocities, m), a velocity field of 1e-2: each
/// entry against central differences of the residual (steps of 1e-7 m/s) within 1e-6 of the
/// largest entry (measured 3e-10 to 5e-10; the matrix assembled with `∇N_i` where
/// `g_i = F_nᵀ ∇N_i` belongs fails at 7e-2).
#[test]
fn the_newton_matrix_is_the_derivative_of_the_residual() {
    use crate::constitutive::{History, Mat2};
    let sc = crate::methods::soft::Scheme { dt: 1.0, theta: 1.0, gravity: V2::zeros() };
    let specs = [
        LawSpec::LinearElastic { young: 1e7, poisson: 0.45 },
        LawSpec::NeoHookean { shear_modulus: 1.5e6, lambda: 3e6 },
        LawSpec::Elastoplastic { young: 1e7, poisson: 0.45, yield_stress: 2e5, hardening: 0.0 },
    ];
    for spec in specs {
        let law = build(&spec);
        let mut points = Points::default();
        let h = 0.3;
        let range = points.fill_disk(V2::zeros(), 1.0, h / 2.0, V2::zeros(), 1000.0);
        for p in range.clone() {
            let x = points.x[p];
            let f = Mat2::new(1.0 + 0.04 * x.x.sin(), 0.03 * x.y, -0.02 * x.x * x.y, 0.97 + 0.02 * x.y);
            points.history[p] = law.response(&f, &History::default()).expect("not inverted").history;
            points.f[p] = f;
        }
        let grid = Grid::covering(V2::new(-1.0, -1.0), V2::new(1.0, 1.0), h, 4);
        let mut field = Field::default();
        field.begin(&grid, &points, range.clone(), law.as_ref(), super::ghost::GAMMA, false).expect("on the grid");
        let n = field.nodes();
        for i in 0..n {
            let x = i as Real;
            field.v[i] = V2::new(1e-2 * (0.7 * x).sin(), 1e-2 * (1.3 * x).cos());
        }
        field.assemble_matrix(&points, range.clone(), law.as_ref(), &sc, false).expect("not inverted");
        let yielded = field.history_new.iter().zip(range.clone()).filter(|(h, p)| h.alpha > points.history[*p].alpha).count();
        let entry = |r: usize, c: usize| if c <= r { field.matrix.get(r, c) } else { field.matrix.get(c, r) };
        let matrix: Vec<Vec<Real>> = (0..2 * n).map(|r| (0..2 * n).map(|c| entry(r, c)).collect()).collect();
        let largest = matrix.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        let step = 1e-7;
        let mut worst: Real = 0.0;
        let massive: Vec<usize> = (0..2 * n).filter(|c| field.mass[c / 2] > 0.0).collect();
        for &col in &massive {
            let mut at = |delta: Real| {
                field.v[col / 2][col % 2] += delta;
                field.assemble_residual(&points, range.clone(), law.as_ref(), &sc).expect("not inverted");
                field.v[col / 2][col % 2] -= delta;
                field.residual.clone()
            };
            let (plus, minus) = (at(step), at(-step));
            for &row in &massive {
                let d = (plus[row / 2][row % 2] - minus[row / 2][row % 2]) / (2.0 * step);
                worst = worst.max((d - matrix[row][col]).abs() / largest);
            }
        }
        eprintln!("{spec:?}: worst entry {worst:.1e} of the largest ({yielded} points yielding)");
        assert!(worst < 1e-6, "{spec:?}: the matrix is off the residual's derivative by {worst:.1e}");
        if let LawSpec::Elastoplastic { .. } = spec {
            assert!(yielded > 10, "the elastoplastic check should yield points: {yielded}");
        }
    }
}

/// The count of points switching between elastic and plastic from one Newton iterate to the
/// next (what damps a cycle between the return mapping's branches, [`super::system`]): a
/// perfectly plastic disk at rest just below its yield stress, then iterates that squeeze it
/// along x (the points yield), the same iterate again (none switches), and back to rest (the
/// same points switch back).
#[test]
fn switches_count_points_changing_flow_between_iterates() {
    use crate::constitutive::Mat2;
    let sc = crate::methods::soft::Scheme { dt: 1.0, theta: 1.0, gravity: V2::zeros() };
    let law = build(&LawSpec::Elastoplastic { young: 1e7, poisson: 0.45, yield_stress: 2e5, hardening: 0.0 });
    let mut points = Points::default();
    let h = 0.3;
    let range = points.fill_disk(V2::zeros(), 1.0, h / 2.0, V2::zeros(), 1000.0);
    // Uniaxial strain 0.5% along x: von Mises stress about 2μ ε = 3.4e4 Pa, below yield.
    for p in range.clone() {
        points.f[p] = Mat2::new(0.995, 0.0, 0.0, 1.0);
    }
    let grid = Grid::covering(V2::new(-1.0, -1.0), V2::new(1.0, 1.0), h, 4);
    let mut field = Field::default();
    field.begin(&grid, &points, range.clone(), law.as_ref(), super::ghost::GAMMA, false).expect("on the grid");
    let at = |field: &mut Field, rate: Real| {
        for i in 0..field.nodes() {
            let (gi, _) = field.grid_node(i);
            field.v[i] = V2::new(-rate * grid.h * gi as Real, 0.0);
        }
        field.assemble_residual(&points, range.clone(), law.as_ref(), &sc).expect("not inverted");
        field.count_switches(&points, range.clone());
        field.switches
    };
    // A further 5% along x: about 2μ × 0.056 = 3.9e5 Pa, above yield everywhere.
    let first = at(&mut field, 0.05);
    assert_eq!(first, range.len(), "every point yields at the first squeezing iterate");
    assert_eq!(at(&mut field, 0.05), 0, "the same iterate again: no point switches");
    assert_eq!(at(&mut field, 0.0), range.len(), "back to rest: every point is elastic again");
}

/// A step that spends Newton's budget names the grain whose correction was the largest: of a
/// block at rest and a vibrating bar (the bar of
/// [`the_vibrating_bar_keeps_its_amplitude_and_period`]), with one iteration allowed and a
/// tolerance of 1e-12, the bar (grain 1); the block's correction is zero. Its matrix is Newton's
/// own (mass and a positive stiffness), so it is not called damped.
#[test]
fn a_newton_failure_names_the_grain_with_the_largest_correction() {
    let (e, rho, l, v0) = (100.0, 1.0, 25.0, 0.1);
    let dx = l / 16.0;
    let beta = std::f64::consts::PI / (2.0 * l);
    let mut points = Points::default();
    let block = points.fill_rectangle(V2::new(-l, 4.0 * dx), V2::new(-l + 4.0 * dx, 8.0 * dx), dx / 2.0, |_| V2::zeros(), rho);
    let bar = points.fill_rectangle(V2::new(-l, 0.0), V2::new(l, dx), dx / 2.0, |x| V2::new(v0 * (beta * x.x).sin(), 0.0), rho);
    let grid = Grid::covering(V2::new(-l, 0.0), V2::new(l, 8.0 * dx), dx, 4);
    let grains = vec![
        Grain { points: block, law: 0, friction: 0.0, radius: 2.0 * dx, outline: Outline::default() },
        Grain { points: bar, law: 0, friction: 0.0, radius: l, outline: Outline::default() },
    ];
    let mut s = settings(0.2 * dx / (e / rho as Real).sqrt());
    s.max_newton = 1;
    s.newton_tolerance = 1e-12;
    let mut sys = System::new(grid, points, grains, vec![build(&LawSpec::LinearElastic { young: e, poisson: 0.0 })], vec![], s, FLIP);
    let failure = sys.step().expect_err("one iteration cannot reach 1e-12");
    match failure.cause {
        crate::error::InstabilityCause::NewtonBudget { grain, damped, .. } => {
            assert_eq!((grain, damped), (Some(1), false), "{}", failure.cause);
        }
        other => panic!("expected Newton's budget, got {other}"),
    }
    assert!(failure.cause.to_string().contains("the largest is grain 1's)"), "{}", failure.cause);
}

/// One elastic disk (R = 5 mm, E = 10 MPa, ν = 0.3, ρ = 990 kg/m³, `cells` across, two points
/// a cell each way) between two frictionless plates, the top one moving down at `speed` (m/s),
/// by backward Euler at step `dt` (s) with Newton to 1e-6 in at most 60 iterations; its
/// Newton records kept.
fn squeezed_disk(cells: usize, speed: Real, dt: Real) -> (System, crate::methods::soft::trace::recorded::Records) {
    use crate::methods::soft::trace::recorded;
    let r = 5e-3;
    let h = 2.0 * r / cells as Real;
    let mut points = Points::default();
    let range = points.fill_disk(V2::new(0.0, r), r, h / 2.0, V2::zeros(), 990.0);
    let grid = Grid::covering(V2::new(-1.5 * r, -0.5 * r), V2::new(1.5 * r, 2.5 * r), h, 4);
    let floor = Wall { point: V2::zeros(), normal: V2::new(0.0, 1.0), velocity: V2::zeros(), friction: 0.0 };
    let top = Wall { point: V2::new(0.0, 2.0 * r), normal: V2::new(0.0, -1.0), velocity: V2::new(0.0, -speed), friction: 0.0 };
    let outline = Outline::disk(&points, range.clone(), V2::new(0.0, r), r, h);
    let grains = vec![Grain { points: range, law: 0, friction: 0.0, radius: r, outline }];
    let mut s = settings(dt);
    s.theta = 1.0;
    s.max_newton = 60;
    let law = build(&LawSpec::LinearElastic { young: 1e7, poisson: 0.3 });
    let mut sys = System::new(grid, points, grains, vec![law], vec![floor, top], s, FLIP);
    sys.ghost = super::ghost::GAMMA;
    let records = recorded::record(&mut sys.tracer);
    (sys, records)
}

/// [`squeezed_disk`] at 16 cells across to 8% of its diameter at 0.05 m/s; each part's Newton
/// records.
fn squeezed_disk_trace(dt: Real) -> Vec<Vec<crate::methods::soft::trace::NewtonRecord>> {
    use crate::methods::soft::trace::recorded;
    let (speed, diameter) = (0.05, 1e-2);
    let (mut sys, records) = squeezed_disk(16, speed, dt);
    let steps = (0.08 * diameter / (speed * dt)).round() as usize;
    for _ in 0..steps {
        sys.step().expect("stable");
    }
    recorded::parts(&records)
}

/// Refining the grid no longer breaks the squeezed disk (issue 70): at 32 cells across, the
/// top plate at 10 mm/s and the step a scene of that size gets by default (1.5625 ms, 0.16% of
/// the diameter), the disk goes to 10% compression with every step converged whole, no point's
/// centre beyond a plate, and the smallest `det F` above 0.8 (Hertz's line contact at this
/// load puts the peak pressure near 0.12 E*, a compression of about that much under the plate:
/// measured 0.85). Before the ghost penalty ([`super::ghost`]) the point carrying the top
/// vertex of the outline spun in place (its `F` a rotation by 115°, its centre 0.4 mm above the
/// plate while the vertex stayed below), the step was split down to a sixteenth, and a point
/// inverted at 7.1% (det F = −0.22). Newton: measured at most 7 iterations a step; the bound
/// 12 is half the scenes' budget.
#[test]
fn a_disk_at_32_cells_is_squeezed_to_a_tenth_without_a_point_lost() {
    let (speed, dt, diameter) = (0.01, 1.5625e-3, 1e-2);
    let (mut sys, records) = squeezed_disk(32, speed, dt);
    let steps = (0.1 * diameter / (speed * dt)).round() as usize;
    for k in 0..steps {
        if let Err(e) = sys.step() {
            panic!("step {k} of {steps}: {}", e.cause);
        }
    }
    let parts = crate::methods::soft::trace::recorded::parts(&records);
    let most = parts.iter().map(Vec::len).max().unwrap_or(0);
    let top = diameter - speed * dt * steps as Real;
    let outside = (0..sys.points.len()).filter(|&p| sys.points.x[p].y > top || sys.points.x[p].y < 0.0).count();
    let smallest = (0..sys.points.len()).map(|p| sys.points.f[p].determinant()).fold(Real::INFINITY, Real::min);
    eprintln!(
        "32 cells: {} parts for {steps} steps, at most {most} iterations, {outside} points outside, smallest J {smallest:.3}",
        parts.len()
    );
    assert_eq!(parts.len(), steps, "a step was split");
    assert!(most <= 12, "a step took {most} Newton iterations");
    assert_eq!(outside, 0, "{outside} points' centres beyond a plate");
    assert!(smallest > 0.8, "a point compressed to det F = {smallest}");
}

/// The material point method's Newton on the squeezed disk at 250 µs a step (issue 70): the
/// matrix, indefinite in most iterations, is made definite along the closed contacts
/// ([`crate::methods::soft::augment`]) and is never damped (the assertion that fails on the
/// old matrices); every part converges within 10 iterations (measured 3 at most with the ghost penalty of
/// [`super::ghost`], 10 before it: the bound is a guard against the budget of 60, not a
/// discriminating figure); an iteration on a fresh matrix is
/// followed by a correction below the square of its own where it is below 1e-2 (quadratic
/// convergence; measured at most 0.34 times the square over 38 such iterations, 0.73 over 5
/// before the ghost penalty): a linear rate `r` would leave the
/// ratio at `r / c_k`, above 1 for any rate above 0.01. Before, the diagonal scaling and the points' positive parts stood in for the
/// tangent in 144 of 307 iterations (parts of up to 11).
#[test]
fn a_squeezed_disk_converges_quadratically() {
    use crate::methods::soft::trace::recorded;
    let parts = squeezed_disk_trace(2.5e-4);
    assert_eq!(parts.len(), 64, "a step was split");
    assert!(parts.iter().flatten().all(|r| r.damped_grains == Some(0)), "a matrix was damped");
    let most = parts.iter().map(Vec::len).max().unwrap_or(0);
    assert!(most <= 10, "a part took {most} iterations");
    let ratios = recorded::quadratic_ratios(&parts, |r| r.refreshed == Some(true));
    let worst = ratios.iter().copied().fold(0.0, Real::max);
    let penalised = parts.iter().flatten().filter(|r| r.penalised_grains == Some(1)).count();
    eprintln!(
        "{} parts, at most {most} iterations, {penalised} penalised; c(k+1)/c(k)² at most {worst:.2e} over {}",
        parts.len(),
        ratios.len()
    );
    assert!(penalised > 0, "the squeezed disk should need the contacts' penalty");
    assert!(!ratios.is_empty(), "no fresh matrix in the asymptotic range");
    assert!(worst <= 1.0, "a fresh matrix's next correction is {worst:.2e} times the square of its own");
}
