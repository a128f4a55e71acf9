//! The equilibrium measure of rigid grains: means over the interval between two checks.
//!
//! Within one step, the velocities of contact dynamics carry the solver's residual: NLGS stops
//! at a relative change of the impulses of `method.tolerance`, and what it has not resolved is
//! left as velocity, about tolerance × (impulse of a contact / mass of a grain) — in a packing
//! of disks at 100 Pa with h = 0.03 d √(ρ/p), an r.m.s. speed of 3 % of the speed one step of
//! contact force gives a grain. That noise does not move the packing (the grains are jammed: it
//! is undone at the next step) but it sets a floor under the instantaneous kinetic energy and
//! unbalanced force: at the default tolerance a kinetic ratio of 1e-2, a hundred times the
//! default bound of the `kinetic_ratio` criterion, and only ten times lower at a ten times
//! tighter tolerance (which costs several times the sweeps). What a
//! quasi-static check asks — is the packing still moving, is every grain in balance, does each
//! wall hold its target — is answered by the means over the check interval: the displacement
//! of each grain over the interval time (`kinetic_energy` of the mean velocities), its mean net
//! force (momentum change over the interval time) and each wall's mean force (its contacts'
//! impulse over the interval time).

use crate::loading::Wall;
use crate::math::{Mat3, Real, Vec3};

/// What common motion of the grains the equilibrium measure leaves out ([`Window::close`]).
/// When nothing holds the grains in place (no boundary touches them, as for a granule between
/// the plates before they close, and neither gravity nor a field pulls them), rigid grains keep
/// whatever momentum and angular momentum they have, with nothing to damp them: their common
/// motion is no lack of balance. (A granule of 300 wet grains, gathered by its field, floated
/// away spinning at about 2.5 rad/s — 80% of its kinetic energy, which no relaxation removes.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Freedom {
    /// Something holds the grains: all their motion counts.
    Held,
    /// Free in a periodic box: their common translation is left out.
    Drift,
    /// Free in an open box: their common translation and rotation are left out.
    RigidBody,
}

/// Displacements, momenta and wall impulses since the last check.
#[derive(Debug, Default)]
pub(super) struct Window {
    /// Displacement of each grain since the window opened, m.
    travel: Vec<Vec3>,
    /// Velocity of each grain when the window opened, m/s.
    vel: Vec<Vec3>,
    /// Impulse the contacts gave each wall, N·s.
    wall_impulse: Vec<Vec3>,
    /// Generalised impulse the contacts gave a stress-controlled periodic cell, N·s.
    cell_impulse: Real,
    /// Time since the window opened, s.
    time: Real,
}

/// The means over a window ([`Window::close`]).
pub(super) struct Means {
    /// Kinetic energy of the mean velocities (displacement / time), J.
    pub kinetic_energy: Real,
    /// Mean over the grains of the norm of the mean net force, N.
    pub net_force: Real,
    /// The walls with their mean force over the window.
    pub walls: Vec<Wall>,
    /// Generalised impulse the contacts gave a stress-controlled cell over the window, N·s.
    pub cell_impulse: Real,
    /// Length of the window, s.
    pub time: Real,
}

impl Window {
    /// Opens a window at the current velocities.
    pub fn open(&mut self, vel: &[Vec3], walls: usize) {
        self.travel.clear();
        self.travel.resize(vel.len(), Vec3::zeros());
        self.vel.clear();
        self.vel.extend_from_slice(vel);
        self.wall_impulse.clear();
        self.wall_impulse.resize(walls, Vec3::zeros());
        self.cell_impulse = 0.0;
        self.time = 0.0;
    }

    /// Adds grain `i`'s displacement over a step.
    #[inline]
    pub fn travel(&mut self, i: usize, dx: Vec3) {
        self.travel[i] += dx;
    }

    /// Adds an impulse on wall `w`, N·s.
    #[inline]
    pub fn wall_impulse(&mut self, w: usize, impulse: Vec3) {
        self.wall_impulse[w] += impulse;
    }

    /// Adds a generalised impulse on the periodic cell, N·s.
    #[inline]
    pub fn cell_impulse(&mut self, impulse: Real) {
        self.cell_impulse += impulse;
    }

    /// Adds a step of `h` seconds.
    pub fn advance(&mut self, h: Real) {
        self.time += h;
    }

    /// The means since the window opened (`None` if no step was made), and a new window.
    ///
    /// `freedom` says what common motion of the grains over the window is no lack of balance,
    /// and is left out of the kinetic energy ([`Freedom`]). `pos` are the positions now, m.
    pub fn close(&mut self, pos: &[Vec3], vel: &[Vec3], mass: &[Real], walls: &[Wall], freedom: Freedom) -> Option<Means> {
        let t = self.time;
        let means = (t > 0.0 && self.travel.len() == vel.len() && pos.len() == vel.len()).then(|| {
            let rigid = match freedom {
                Freedom::Held => RigidMotion::default(),
                Freedom::Drift => RigidMotion { shift: mean_shift(&self.travel, mass), ..RigidMotion::default() },
                Freedom::RigidBody => rigid_motion(&self.travel, pos, mass),
            };
            let kinetic_energy = 0.5
                * self
                    .travel
                    .iter()
                    .zip(pos)
                    .zip(mass)
                    .map(|((d, x), m)| m * ((d - rigid.displacement(x - 0.5 * d)) / t).norm_squared())
                    .sum::<Real>();
            let net_force = vel.iter().zip(&self.vel).zip(mass).map(|((v, v0), m)| ((v - v0) * (m / t)).norm()).sum::<Real>()
                / vel.len().max(1) as Real;
            let walls = walls
                .iter()
                .zip(&self.wall_impulse)
                .map(|(w, j)| {
                    let mut w = w.clone();
                    w.force = j / t;
                    w
                })
                .collect();
            Means { kinetic_energy, net_force, walls, cell_impulse: self.cell_impulse, time: t }
        });
        self.open(vel, walls.len());
        means
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.travel.capacity() + self.vel.capacity() + self.wall_impulse.capacity()) * std::mem::size_of::<Vec3>()
    }
}

/// The rigid motion that best fits displacements (mass-weighted least squares): a translation
/// `shift` of the centre of mass `centre` and a rotation, as the chord `spin × (x_mid - centre)`
/// of every point about its mid-window position `x_mid` — Cayley's form of a finite rotation,
/// `x1 - x0 = 2 tan(θ/2) n × (x0 + x1)/2`, so a rigid rotation of any angle is fitted exactly.
#[derive(Debug, Default, Clone, Copy)]
struct RigidMotion {
    shift: Vec3,
    centre: Vec3,
    spin: Vec3,
}

impl RigidMotion {
    /// The displacement of the point whose mid-window position is `mid`.
    fn displacement(&self, mid: Vec3) -> Vec3 {
        self.shift + self.spin.cross(&(mid - self.centre))
    }
}

/// The mass-weighted mean of displacements `travel`, m.
fn mean_shift(travel: &[Vec3], mass: &[Real]) -> Vec3 {
    let total: Real = mass.iter().sum();
    travel.iter().zip(mass).map(|(d, m)| d * *m).sum::<Vec3>() / total.max(Real::MIN_POSITIVE)
}

/// [`RigidMotion`] of displacements `travel` ending at `pos`, weighted by `mass`. The spin
/// solves `I spin = Σ m r × (d - shift)` with `I` the inertia tensor of the points about their
/// centre, by pseudo-inverse (points on a line leave the spin about it undefined, and zero).
fn rigid_motion(travel: &[Vec3], pos: &[Vec3], mass: &[Real]) -> RigidMotion {
    let total: Real = mass.iter().sum();
    if total <= 0.0 {
        return RigidMotion::default();
    }
    let mids = || travel.iter().zip(pos).map(|(d, x)| x - 0.5 * d);
    let shift = mean_shift(travel, mass);
    let centre = mids().zip(mass).map(|(x, m)| x * *m).sum::<Vec3>() / total;
    let (mut inertia, mut moment) = (Mat3::zeros(), Vec3::zeros());
    for ((x, d), m) in mids().zip(travel).zip(mass) {
        let r = x - centre;
        inertia += (Mat3::identity() * r.norm_squared() - r * r.transpose()) * *m;
        moment += r.cross(&(d - shift)) * *m;
    }
    let eps = 1e-12 * inertia.trace().max(Real::MIN_POSITIVE);
    let spin = inertia.pseudo_inverse(eps).map_or(Vec3::zeros(), |inv| inv * moment);
    RigidMotion { shift, centre, spin }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grain that rattles back and forth has no mean velocity; one that drifts has its drift;
    /// the net force is the momentum change over the window's time; the window reopens.
    #[test]
    fn means_keep_the_drift_and_drop_the_rattle() {
        let mass = [2.0, 2.0];
        let mut vel = vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0)];
        let mut w = Window::default();
        w.open(&vel, 0);
        let h = 0.1;
        for k in 0..10 {
            // Grain 0 alternates +1/-1 m/s; grain 1 drifts at 0.5 m/s.
            let s = if k % 2 == 0 { 1.0 } else { -1.0 };
            w.travel(0, Vec3::new(s * h, 0.0, 0.0));
            w.travel(1, Vec3::new(0.5 * h, 0.0, 0.0));
            w.advance(h);
        }
        vel[1].x = 0.7;
        let pos = vec![Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)];
        let m = w.close(&pos, &vel, &mass, &[], Freedom::Held).expect("a step was made");
        assert!((m.kinetic_energy - 0.5 * 2.0 * 0.25).abs() < 1e-12, "{}", m.kinetic_energy);
        // Grain 1 gained 0.2 m/s over 1 s: 0.4 N; mean over the two grains 0.2 N.
        assert!((m.net_force - 0.2).abs() < 1e-12, "{}", m.net_force);
        assert!(w.close(&pos, &vel, &mass, &[], Freedom::Held).is_none(), "a new window has no step yet");
    }

    /// Free grains: their common drift is left out, their motion relative to it is not.
    #[test]
    fn free_grains_lose_their_common_drift() {
        let mass = [1.0, 3.0];
        let vel = vec![Vec3::zeros(); 2];
        let mut w = Window::default();
        w.open(&vel, 0);
        // Both drift at 0.2 m/s along y; grain 0 also moves at 0.3 m/s along x and grain 1 at
        // -0.1 m/s (no momentum along x), over 1 s.
        w.travel(0, Vec3::new(0.3, 0.2, 0.0));
        w.travel(1, Vec3::new(-0.1, 0.2, 0.0));
        w.advance(1.0);
        // On a line along x, so that their relative motion along x is a stretch, not a spin.
        let pos = vec![Vec3::new(0.3, 0.2, 0.0), Vec3::new(0.9, 0.2, 0.0)];
        let m = w.close(&pos, &vel, &mass, &[], Freedom::RigidBody).expect("a step was made");
        assert!((m.kinetic_energy - 0.5 * (0.09 + 3.0 * 0.01)).abs() < 1e-12, "{}", m.kinetic_energy);
    }

    /// Free grains turning together as a rigid body, by a large angle over the window and while
    /// drifting: no kinetic energy is left; held grains keep it all; a grain that also moves
    /// relative to the others keeps what the rigid fit cannot take.
    #[test]
    fn free_grains_lose_their_common_rotation() {
        let mass = [1.0, 2.0, 1.5, 0.5];
        let start = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.2), Vec3::new(0.0, 1.5, -0.3), Vec3::new(0.4, 0.3, 1.0)];
        let (axis, angle, shift) = (Vec3::new(1.0, 2.0, -0.5).normalize(), 0.9, Vec3::new(0.05, -0.02, 0.01));
        let turn = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        let centre = Vec3::new(0.3, 0.4, 0.2);
        let end: Vec<Vec3> = start.iter().map(|x| centre + turn * (x - centre) + shift).collect();
        let vel = vec![Vec3::zeros(); 4];
        let window = |end: &[Vec3], freedom: Freedom| {
            let mut w = Window::default();
            w.open(&vel, 0);
            for (i, (x0, x1)) in start.iter().zip(end).enumerate() {
                w.travel(i, x1 - x0);
            }
            w.advance(2.0);
            w.close(end, &vel, &mass, &[], freedom).expect("a step was made").kinetic_energy
        };
        let held = window(&end, Freedom::Held);
        assert!(held > 0.01, "{held}");
        // In a periodic box only the drift goes: the turn stays.
        let periodic = window(&end, Freedom::Drift);
        assert!(periodic > 0.5 * held && periodic < held, "{periodic} J against {held} J");
        let free = window(&end, Freedom::RigidBody);
        assert!(free < 1e-20 * held.max(1.0), "a rigid turn of 0.9 rad left {free} J of {held}");
        // Grain 3 also moves by 0.1 m relative to the body: what remains is of that order.
        let mut moved = end.clone();
        moved[3] += Vec3::new(0.1, 0.0, 0.0);
        let rest = window(&moved, Freedom::RigidBody);
        let own = 0.5 * mass[3] * (0.1f64 / 2.0).powi(2);
        assert!(rest > 0.2 * own && rest < own, "{rest} J against {own} J for the grain's own motion");
    }
}
