//! Non-linear Gauss-Seidel over the contacts of rigid round bodies (Moreau 1994; Jean 1999;
//! docs/physics.md §3.3).
//!
//! On entry the bodies carry their free velocities (end of step without contact impulses) and
//! each contact its warm-start impulse (the previous step's, or zero). The solver adds the
//! warm-start impulses to the bodies, then sweeps the contacts in order: each one's local
//! problem is solved exactly with the others frozen ([`super::local::solve`]) and the change of
//! its impulse is applied to its two bodies at once, so the next contact sees it (then its
//! rolling block, if it has one). Sweeps repeat until the convergence criterion holds or the
//! budget is spent. The order is the contacts' order, or colour by colour with each colour swept
//! in parallel ([`super::colour`]).
//!
//! **Acceleration** (momentum with adaptive restart): after a sweep that did not converge, each
//! contact's impulse is carried on along its change over the sweep, `r + beta (r - r_prev)`,
//! projected back on its admissible set (`r_n >= -c`, `|r_t| <= mu (r_n + c)`), and the change
//! applied to its bodies. `beta` grows as Nesterov's `(k - 1) / (k + 2)` with the sweeps `k` since
//! the last restart, up to `Convergence::acceleration`, and the count restarts whenever the sum of
//! the violations grows over a sweep (O'Donoghue & Candès 2015's restart; Mazhar et al. 2015 use
//! the same momentum on the projected gradient of the contact problem, Chrono's APGD). Plain
//! Gauss-Seidel crawls on the slow collective modes of a packing moved by free walls — its error
//! there decays by a few percent per thousand sweeps — and the momentum carries those modes along
//! (docs/methods/cd.md, "Design measurements"). With a liquid's viscosity `k` the normal bound
//! is `r_n >= -c - k U_n` at the contact's current normal velocity (the admissible set moves with
//! the velocity); the rolling blocks keep their plain update.
//!
//! **Convergence criterion** (checked after every sweep), all below their tolerances:
//! - the relative change of the impulses over the sweep, `sqrt(sum |dr|² / sum max(|r|, s)²)`
//!   (LMGC90's "quadratic" norm), where each contact's impulse scale `s` (set by the method:
//!   the impulse that stops its approach, one step of gravity, and the bodies' speeds at the
//!   level of rounding) keeps contacts that carry (almost) nothing from turning rounding noise
//!   into a large relative change (a column in free fall has all its impulses at 1e-17 N·s,
//!   changing by their own size at every sweep);
//! - the mean violation of the Signorini condition, `h <max(0, b - U_n)> / <d>`: how far, as a
//!   fraction of the mean diameter, the contacts would interpenetrate over the step beyond
//!   what the law allows, measured on each contact just before it is solved in the sweep
//!   (over the contacts; near pairs only while they act: [`RigidContact::near`]);
//! - the largest violation, `h max(max(0, b - U_n) / a_i)`: how far the deepest-going contact
//!   would interpenetrate over the step, as a fraction of its radius (a bound on the mean alone
//!   lets one contact in a thousand go a thousand times deeper than the mean).

use std::sync::atomic::{AtomicU64, Ordering};

use super::colour::Colours;
use super::frame::ContactFrame;
use super::local::{self, Delassus, LocalLaw, Rolling};
use crate::math::{Real, Vec3};

/// The second member of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Another body (particle index).
    Body(u32),
    /// A boundary (wall, drum), by its index in [`RigidBodies::boundary_vel`]: of imposed
    /// motion, or free to translate along one direction (a stress-controlled wall).
    Boundary(u32),
    /// Another body seen through the boundary of a deforming periodic cell: body `j`'s image
    /// `k` periods away along each axis, in a cell whose lengths change at the velocity of
    /// boundary `cell` (component `a` of that velocity: dL_a/dt, m/s). The image moves at
    /// `v_j + k ⊙ V_cell`; when the cell is free to deform (a stress-controlled cell), the
    /// contact's impulse acts on it too — the cell is then a body of the contact problem, as a
    /// stress-controlled wall is.
    Image {
        /// Particle index.
        j: u32,
        /// Boundary slot of the cell.
        cell: u8,
        /// Periods crossed along x, y, z.
        k: [i8; 3],
    },
}

impl Side {
    /// The other body, if the contact is between two bodies (directly or through an image).
    #[inline(always)]
    pub fn body(&self) -> Option<u32> {
        match *self {
            Side::Body(j) | Side::Image { j, .. } => Some(j),
            Side::Boundary(_) => None,
        }
    }
}

/// A contact for the solver's tests: between `i` and `j` along `n` at levers `a_i`, `a_j`, of
/// Delassus block `w`, inelastic, frictionless, at rest, carrying nothing.
#[cfg(test)]
pub(crate) fn test_contact(i: u32, j: Side, n: Vec3, (a_i, a_j): (Real, Real), w: Delassus) -> RigidContact {
    RigidContact {
        i,
        j,
        near: false,
        frame: ContactFrame::new(2, n),
        a_i,
        a_j,
        drive: Vec3::zeros(),
        w,
        law: law_for(0.0, 0.0, 0.0, 0.0),
        r: Vec3::zeros(),
        rolling: Rolling::default(),
        scale: 0.0,
    }
}

/// `k ⊙ v`: the velocity of an image `k` periods away in a cell whose lengths change at `v`.
#[inline(always)]
pub fn image_lever(k: [i8; 3], v: &Vec3) -> Vec3 {
    Vec3::new(k[0] as Real * v.x, k[1] as Real * v.y, k[2] as Real * v.z)
}

/// One contact between a round body `i` and a body or boundary `j`, with its law for the step
/// and its impulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidContact {
    /// First body.
    pub i: u32,
    /// Second body or boundary.
    pub j: Side,
    /// A pair that is apart and not closing, in the problem only so that nothing within the
    /// step drives it in (a method's choice: CD's near pairs): it counts in the criterion as a
    /// contact only in the sweeps where it acts (carries or changes an impulse); otherwise only
    /// by what it violates. A dense packing has about as many near pairs as contacts: counted
    /// while idle, they doubled the number the mean violation divides by and the impulse scale
    /// of the relative change, and loosened both bounds as much.
    pub near: bool,
    /// Local frame; `n` points from `j` towards `i`.
    pub frame: ContactFrame,
    /// Distance from the centre of `i` to the contact point (along `-n`), m.
    pub a_i: Real,
    /// Distance from the centre of `j` to the contact point (along `n`), m (0 for a boundary).
    pub a_j: Real,
    /// Velocity of the second member's material point that does not come from the velocities
    /// of body or boundary `j`: the surface velocity of a turning drum, or the Lees-Edwards
    /// velocity of the periodic image of `j`, m/s.
    pub drive: Vec3,
    /// Local Delassus block, 1/kg.
    pub w: Delassus,
    /// The law for this step.
    pub law: LocalLaw,
    /// Impulse in local components (n, t1, t2), N·s: the warm start on entry, the solution on
    /// exit.
    pub r: Vec3,
    /// Rolling resistance and its moment impulse ([`Rolling`]; `bound` 0: none).
    pub rolling: Rolling,
    /// Impulse scale of the contact for the convergence criterion, N·s (see the module
    /// documentation): for a method like CD, `(|u_n| + |g| h + 1e-6 (|v_i| + |v_j|)) / w_n`,
    /// the impulse that stops its approach, one step of gravity, and the bodies' speeds at
    /// the level of rounding.
    pub scale: Real,
}

/// How a boundary may move within the contact problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mobility {
    /// Unit direction along which it translates freely.
    pub direction: Vec3,
    /// Inverse mass along it, 1/kg (0: imposed motion).
    pub inv_mass: Real,
    /// A boundary that moves opposite to this one (the two walls of an axis that share one
    /// degree of freedom, the box length, so that the box cannot drift as a whole): an impulse
    /// on either changes both velocities, by opposite amounts.
    pub partner: Option<u32>,
    /// Largest speed along `direction`, m/s (`INFINITY`: none). A bound of the contact problem,
    /// not a clamp after it: the boundary moves at `clamp(u)`, where `u` is the velocity its
    /// push and its contacts' impulses give it, so the bound's reaction is whatever keeps it
    /// there (a stress-controlled wall crossing empty space does not reach its first grains at
    /// the speed of many steps of push, yet still pushes with its whole target once at rest
    /// on them).
    pub max_speed: Real,
}

impl Mobility {
    /// A boundary of imposed motion.
    pub const FIXED: Self = Self { direction: Vec3::new(0.0, 0.0, 0.0), inv_mass: 0.0, partner: None, max_speed: Real::INFINITY };

    /// The velocity a free boundary moves at when its unbounded velocity is `u`: `u` with its
    /// component along `direction` brought within `max_speed`, m/s.
    #[inline(always)]
    pub fn bound(&self, u: Vec3) -> Vec3 {
        if self.inv_mass == 0.0 || self.max_speed == Real::INFINITY {
            return u;
        }
        let s = u.dot(&self.direction);
        u + self.direction * (s.clamp(-self.max_speed, self.max_speed) - s)
    }
}

/// The velocities and inverse inertias of the bodies the contacts act on.
pub struct RigidBodies<'a> {
    /// Velocities, m/s.
    pub vel: &'a mut [Vec3],
    /// Angular velocities, rad/s.
    pub omega: &'a mut [Vec3],
    /// 1/m, 1/kg (0 for bodies of imposed motion).
    pub inv_mass: &'a [Real],
    /// 1/I, 1/(kg·m²) (isotropic inertia).
    pub inv_inertia: &'a [Real],
    /// Velocities of the boundaries (rigid translation), m/s.
    pub boundary_vel: &'a mut [Vec3],
    /// How each boundary may move ([`Mobility`]).
    pub boundary_mobility: &'a [Mobility],
    /// Angular velocity of each boundary (imposed: a turning drum), rad/s; empty when none
    /// turns. Its surface velocity at a contact is the contact's `drive`; its spin enters the
    /// rolling velocity.
    pub boundary_omega: &'a [Vec3],
}

/// What the sweep reads and changes of the bodies: plain slices when one thread sweeps
/// ([`RigidBodies`]), shared cells when a colour is swept by several ([`SolveBodies`]).
/// Monomorphised: the serial sweep pays nothing for the parallel one.
pub(crate) trait BodyStore {
    /// Velocity of body `i`, m/s.
    fn vel(&self, i: usize) -> Vec3;
    /// Spin of body `i`, rad/s.
    fn omega(&self, i: usize) -> Vec3;
    /// Velocity boundary `k` moves at, m/s (within its [`Mobility::max_speed`]).
    fn boundary_vel(&self, k: usize) -> Vec3;
    /// Adds `dv` to the velocity of body `i`.
    fn add_vel(&mut self, i: usize, dv: Vec3);
    /// Adds `dw` to the spin of body `i`.
    fn add_omega(&mut self, i: usize, dw: Vec3);
    /// Adds `dv` to the unbounded velocity of boundary `k`.
    fn add_boundary_vel(&mut self, k: usize, dv: Vec3);
    /// 1/m of body `i`, 1/kg.
    fn inv_mass(&self, i: usize) -> Real;
    /// 1/I of body `i`, 1/(kg·m²).
    fn inv_inertia(&self, i: usize) -> Real;
    /// How boundary `k` may move.
    fn mobility(&self, k: usize) -> Mobility;
    /// Angular velocity of boundary `k`, rad/s.
    fn boundary_omega(&self, k: usize) -> Vec3;
}

impl BodyStore for RigidBodies<'_> {
    #[inline(always)]
    fn vel(&self, i: usize) -> Vec3 {
        self.vel[i]
    }
    #[inline(always)]
    fn omega(&self, i: usize) -> Vec3 {
        self.omega[i]
    }
    #[inline(always)]
    fn boundary_vel(&self, k: usize) -> Vec3 {
        self.boundary_mobility[k].bound(self.boundary_vel[k])
    }
    #[inline(always)]
    fn add_vel(&mut self, i: usize, dv: Vec3) {
        self.vel[i] += dv;
    }
    #[inline(always)]
    fn add_omega(&mut self, i: usize, dw: Vec3) {
        self.omega[i] += dw;
    }
    #[inline(always)]
    fn add_boundary_vel(&mut self, k: usize, dv: Vec3) {
        self.boundary_vel[k] += dv;
    }
    #[inline(always)]
    fn inv_mass(&self, i: usize) -> Real {
        self.inv_mass[i]
    }
    #[inline(always)]
    fn inv_inertia(&self, i: usize) -> Real {
        self.inv_inertia[i]
    }
    #[inline(always)]
    fn mobility(&self, k: usize) -> Mobility {
        self.boundary_mobility[k]
    }
    #[inline(always)]
    fn boundary_omega(&self, k: usize) -> Vec3 {
        self.boundary_omega.get(k).copied().unwrap_or_else(Vec3::zeros)
    }
}

impl BodyStore for &SolveBodies<'_> {
    #[inline(always)]
    fn vel(&self, i: usize) -> Vec3 {
        self.vel[i].get()
    }
    #[inline(always)]
    fn omega(&self, i: usize) -> Vec3 {
        self.omega[i].get()
    }
    #[inline(always)]
    fn boundary_vel(&self, k: usize) -> Vec3 {
        self.boundary_mobility[k].bound(self.boundary_vel[k].get())
    }
    #[inline(always)]
    fn add_vel(&mut self, i: usize, dv: Vec3) {
        self.vel[i].add(dv);
    }
    #[inline(always)]
    fn add_omega(&mut self, i: usize, dw: Vec3) {
        self.omega[i].add(dw);
    }
    #[inline(always)]
    fn add_boundary_vel(&mut self, k: usize, dv: Vec3) {
        self.boundary_vel[k].add(dv);
    }
    #[inline(always)]
    fn inv_mass(&self, i: usize) -> Real {
        self.inv_mass[i]
    }
    #[inline(always)]
    fn inv_inertia(&self, i: usize) -> Real {
        self.inv_inertia[i]
    }
    #[inline(always)]
    fn mobility(&self, k: usize) -> Mobility {
        self.boundary_mobility[k]
    }
    #[inline(always)]
    fn boundary_omega(&self, k: usize) -> Vec3 {
        self.boundary_omega.get(k).copied().unwrap_or_else(Vec3::zeros)
    }
}

/// A vector whose components threads may read and write: each `f64` held in an `AtomicU64`,
/// loaded and stored with relaxed ordering (plain moves on common hardware). The sweep never
/// lets two threads at one body at the same time ([`super::colour`]); the atomics make that a
/// matter of correctness, not of memory safety, and rayon's joins order the colours.
#[derive(Debug, Default)]
pub(crate) struct SharedVec3([AtomicU64; 3]);

impl SharedVec3 {
    fn new(v: &Vec3) -> Self {
        Self([AtomicU64::new(v.x.to_bits()), AtomicU64::new(v.y.to_bits()), AtomicU64::new(v.z.to_bits())])
    }

    #[inline(always)]
    fn get(&self) -> Vec3 {
        let c = |k: usize| Real::from_bits(self.0[k].load(Ordering::Relaxed));
        Vec3::new(c(0), c(1), c(2))
    }

    #[inline(always)]
    fn add(&self, dv: Vec3) {
        let v = self.get() + dv;
        for (k, x) in v.iter().enumerate() {
            self.0[k].store(x.to_bits(), Ordering::Relaxed);
        }
    }
}

/// The cells the coloured sweep shares between threads: the velocities of a solve, kept by the
/// solver between solves so that the step loop does not allocate them again.
#[derive(Debug, Default)]
pub(crate) struct Cells {
    vel: Vec<SharedVec3>,
    omega: Vec<SharedVec3>,
    boundary_vel: Vec<SharedVec3>,
}

impl Cells {
    /// Copies the bodies' velocities in.
    fn fill(&mut self, b: &RigidBodies<'_>) {
        let copy = |to: &mut Vec<SharedVec3>, from: &[Vec3]| {
            to.clear();
            to.extend(from.iter().map(SharedVec3::new));
        };
        copy(&mut self.vel, b.vel);
        copy(&mut self.omega, b.omega);
        copy(&mut self.boundary_vel, b.boundary_vel);
    }

    /// Heap bytes held.
    fn heap_bytes(&self) -> usize {
        (self.vel.capacity() + self.omega.capacity() + self.boundary_vel.capacity()) * std::mem::size_of::<SharedVec3>()
    }
}

/// The bodies as a solve sees them: [`RigidBodies`] with its velocities copied into cells that
/// the coloured sweep shares between threads, and copied back when the solve ends.
pub(crate) struct SolveBodies<'a> {
    vel: &'a [SharedVec3],
    omega: &'a [SharedVec3],
    boundary_vel: &'a [SharedVec3],
    inv_mass: &'a [Real],
    inv_inertia: &'a [Real],
    boundary_mobility: &'a [Mobility],
    boundary_omega: &'a [Vec3],
}

impl<'a> SolveBodies<'a> {
    /// The bodies `b` with their velocities in `cells` (filled by [`Cells::fill`]).
    fn new(b: &RigidBodies<'a>, cells: &'a Cells) -> Self {
        Self {
            vel: &cells.vel,
            omega: &cells.omega,
            boundary_vel: &cells.boundary_vel,
            inv_mass: b.inv_mass,
            inv_inertia: b.inv_inertia,
            boundary_mobility: b.boundary_mobility,
            boundary_omega: b.boundary_omega,
        }
    }

    fn store(&self, b: &mut RigidBodies<'_>) {
        let back = |from: &[SharedVec3], to: &mut [Vec3]| to.iter_mut().zip(from).for_each(|(t, f)| *t = f.get());
        back(self.vel, b.vel);
        back(self.omega, b.omega);
        back(self.boundary_vel, b.boundary_vel);
    }
}

impl RigidContact {
    /// Local Delassus block of a contact between bodies of inverse masses and inertias
    /// `(im_i, ii_i)` and `(im_j, ii_j)` (zeros for a boundary) at lever arms `a_i`, `a_j`.
    pub fn delassus(im_i: Real, ii_i: Real, a_i: Real, im_j: Real, ii_j: Real, a_j: Real) -> Delassus {
        let translation = im_i + im_j;
        Delassus { n: translation, t: translation + a_i * a_i * ii_i + a_j * a_j * ii_j }
    }

    /// Local Delassus block of a round body of inverse mass and inertia `(im, ii)` at lever
    /// arm `a` against a boundary that translates freely along the contact normal with inverse
    /// mass `im_b` (0 for imposed motion). The boundary adds `im_b` on the normal only: plane
    /// walls move along their normal, so the block stays diagonal.
    pub fn delassus_boundary(im: Real, ii: Real, a: Real, im_b: Real) -> Delassus {
        Delassus { n: im + im_b, t: im + a * a * ii }
    }

    /// `w` with a boundary that moves as `lever × s` for a degree of freedom `s` of inverse
    /// mass `im_b` added, at a contact of normal `n`: `im_b (n·lever)²` on the normal and
    /// `im_b (|lever|² - (n·lever)²)` on the tangents (the diagonal of the block; its
    /// off-diagonal terms are left out, as everywhere in the local blocks: NLGS converges to
    /// the same fixed point, since each visit recomputes the velocities from the bodies). For a
    /// plane wall (`lever` along `n`) this is [`RigidContact::delassus_boundary`].
    pub fn with_moving_boundary(w: Delassus, n: &Vec3, lever: &Vec3, im_b: Real) -> Delassus {
        let along = n.dot(lever);
        let across = (lever.norm_squared() - along * along).max(0.0);
        Delassus { n: w.n + im_b * along * along, t: w.t + im_b * across }
    }

    /// Relative velocity of the contact point of `i` against that of `j` (global), m/s.
    #[inline(always)]
    pub fn relative_velocity(&self, vel: &[Vec3], omega: &[Vec3], boundary_vel: &[Vec3]) -> Vec3 {
        self.relative_with(|i| vel[i], |i| omega[i], |k| boundary_vel[k])
    }

    /// [`RigidContact::relative_velocity`] within the solve.
    #[inline(always)]
    fn velocity_in(&self, bodies: &impl BodyStore) -> Vec3 {
        self.relative_with(|i| bodies.vel(i), |i| bodies.omega(i), |k| bodies.boundary_vel(k))
    }

    #[inline(always)]
    fn relative_with(&self, vel: impl Fn(usize) -> Vec3, omega: impl Fn(usize) -> Vec3, boundary_vel: impl Fn(usize) -> Vec3) -> Vec3 {
        let i = self.i as usize;
        let n = &self.frame.n;
        let mut spin = omega(i) * self.a_i;
        let mut u = vel(i) - self.drive;
        match self.j {
            Side::Body(j) => {
                let j = j as usize;
                u -= vel(j);
                spin += omega(j) * self.a_j;
            }
            Side::Boundary(k) => u -= boundary_vel(k as usize),
            Side::Image { j, cell, k } => {
                let j = j as usize;
                u -= vel(j) + image_lever(k, &boundary_vel(cell as usize));
                spin += omega(j) * self.a_j;
            }
        }
        u - spin.cross(n)
    }

    /// Applies the global impulse `p` (on `i`; `-p` on `j`) to the bodies' velocities.
    #[inline(always)]
    fn apply(&self, p: &Vec3, bodies: &mut impl BodyStore) {
        let i = self.i as usize;
        let n = &self.frame.n;
        let nxp = n.cross(p);
        bodies.add_vel(i, p * bodies.inv_mass(i));
        bodies.add_omega(i, -nxp * (self.a_i * bodies.inv_inertia(i)));
        match self.j {
            Side::Body(j) => {
                let j = j as usize;
                bodies.add_vel(j, -p * bodies.inv_mass(j));
                bodies.add_omega(j, -nxp * (self.a_j * bodies.inv_inertia(j)));
            }
            Side::Boundary(k) => {
                let m = bodies.mobility(k as usize);
                if m.inv_mass > 0.0 {
                    let dv = m.direction * (p.dot(&m.direction) * m.inv_mass);
                    bodies.add_boundary_vel(k as usize, -dv);
                    if let Some(other) = m.partner {
                        bodies.add_boundary_vel(other as usize, dv);
                    }
                }
            }
            Side::Image { j, cell, k } => {
                let j = j as usize;
                bodies.add_vel(j, -p * bodies.inv_mass(j));
                bodies.add_omega(j, -nxp * (self.a_j * bodies.inv_inertia(j)));
                let m = bodies.mobility(cell as usize);
                if m.inv_mass > 0.0 {
                    // The image's velocity is v_j + k ⊙ V: the cell takes -p through the lever
                    // k ⊙ direction.
                    let lever = image_lever(k, &m.direction);
                    bodies.add_boundary_vel(cell as usize, -m.direction * (p.dot(&lever) * m.inv_mass));
                }
            }
        }
    }

    /// Applies the moment impulse `m` (on `i`; `-m` on `j`) to the bodies' spins.
    #[inline(always)]
    fn apply_moment(&self, m: &Vec3, bodies: &mut impl BodyStore) {
        let i = self.i as usize;
        bodies.add_omega(i, m * bodies.inv_inertia(i));
        if let Some(j) = self.j.body() {
            let j = j as usize;
            bodies.add_omega(j, -m * bodies.inv_inertia(j));
        }
    }

    /// The rolling velocity of the contact: the tangential part of `omega_i - omega_j`, rad/s
    /// (`omega_j` a boundary's own spin).
    #[inline(always)]
    fn rolling_velocity(&self, bodies: &impl BodyStore) -> Vec3 {
        let mut w = bodies.omega(self.i as usize);
        match self.j {
            Side::Body(j) | Side::Image { j, .. } => w -= bodies.omega(j as usize),
            Side::Boundary(k) => w -= bodies.boundary_omega(k as usize),
        }
        let n = &self.frame.n;
        w - n * n.dot(&w)
    }

    /// Force this contact exerts on `i` over a step of `h` seconds (global), N.
    pub fn force(&self, h: Real) -> Vec3 {
        self.frame.to_global(&self.r) / h
    }
}

/// The solver's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Convergence {
    /// Tolerance on the relative change of the impulses over a sweep.
    pub tolerance: Real,
    /// Tolerance on the mean violation (fraction of the mean diameter per step).
    pub violation_tolerance: Real,
    /// Tolerance on the largest violation (fraction of the contact's radius per step): a mean
    /// bound alone lets one contact of a thousand go a thousand times deeper than the mean.
    pub worst_tolerance: Real,
    /// Largest number of sweeps in one step.
    pub max_iterations: u32,
    /// Relaxation `omega` in (0, 1]: each contact moves its impulse `omega` of the way to its
    /// local solution. Below 1 it damps the cycles in which Gauss-Seidel can lock on frictional,
    /// hyperstatic packings under imposed boundary motions (LMGC90's NLGS exposes the same
    /// factor, `relax`).
    pub relaxation: Real,
    /// Largest momentum factor `beta` of the accelerated sweep, in [0, 1) (0: plain
    /// Gauss-Seidel; see the module documentation).
    pub acceleration: Real,
}

/// The state of the iteration after one sweep.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Iterate {
    /// Relative change of the impulses over the sweep.
    pub change: Real,
    /// Mean violation (fraction of the mean diameter per step).
    pub violation: Real,
    /// Largest violation (fraction of the contact's radius per step).
    pub worst: Real,
}

/// The outcome of one solve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NlgsReport {
    /// Sweeps done.
    pub iterations: u32,
    /// The criterion's values after the last sweep.
    pub last: Iterate,
    /// True if the criterion held within the budget.
    pub converged: bool,
    /// Contacts solved.
    pub contacts: usize,
}

impl NlgsReport {
    /// The failure of a solve that ran out of its budget under `settings`.
    pub fn budget_failure(&self, settings: &Convergence) -> crate::error::InstabilityCause {
        crate::error::InstabilityCause::SolverBudget {
            iterations: self.iterations,
            change: self.last.change,
            violation: self.last.violation,
            tolerance: settings.tolerance,
            violation_tolerance: settings.violation_tolerance,
            worst: self.last.worst,
            worst_tolerance: settings.worst_tolerance,
        }
    }
}

/// The non-linear Gauss-Seidel solver, with the residual history of its last solve.
#[derive(Debug)]
pub struct Nlgs {
    /// Settings.
    pub settings: Convergence,
    /// The criterion after each sweep of the last solve.
    pub history: Vec<Iterate>,
    /// The velocity cells of the coloured sweep, kept between solves.
    cells: Cells,
    /// Each contact's impulse after the previous sweep (the accelerated sweep's momentum).
    last: Vec<Vec3>,
}

impl Nlgs {
    /// A solver with these settings.
    pub fn new(settings: Convergence) -> Self {
        Self { settings, history: Vec::new(), cells: Cells::default(), last: Vec::new() }
    }

    /// Heap bytes held (the history, the coloured sweep's cells and the momentum's impulses).
    pub fn heap_bytes(&self) -> usize {
        self.history.capacity() * std::mem::size_of::<Iterate>()
            + self.cells.heap_bytes()
            + self.last.capacity() * std::mem::size_of::<Vec3>()
    }

    /// Solves the contacts (see the module documentation) for a step of `h` seconds, between
    /// bodies of mean diameter `mean_diameter` (m; the mean violation's unit). With `colours`,
    /// the contacts are in colour order ([`super::colour`]) and each colour is swept in
    /// parallel. Free boundaries end the solve within their [`Mobility::max_speed`].
    pub fn solve(
        &mut self,
        contacts: &mut [RigidContact],
        bodies: &mut RigidBodies<'_>,
        h: Real,
        mean_diameter: Real,
        colours: Option<&Colours>,
    ) -> NlgsReport {
        self.history.clear();
        let report = match colours {
            None => self.sweeps(contacts, bodies, (h, mean_diameter), |contacts, last, bodies, pass| {
                let mut sums = Sums::default();
                for (c, slot) in contacts.iter_mut().zip(last.iter_mut()) {
                    pass.apply(c, slot, bodies, &mut sums);
                }
                sums
            }),
            Some(colours) => {
                // The velocities in cells the threads of a colour share, for the solve.
                let mut cells = std::mem::take(&mut self.cells);
                cells.fill(bodies);
                let shared = SolveBodies::new(bodies, &cells);
                let report = self.sweeps(contacts, &mut &shared, (h, mean_diameter), |contacts, last, bodies, pass| {
                    colours.sweep(contacts, last, bodies, pass)
                });
                shared.store(bodies);
                self.cells = cells;
                report
            }
        };
        for (v, m) in bodies.boundary_vel.iter_mut().zip(bodies.boundary_mobility) {
            *v = m.bound(*v);
        }
        report
    }

    /// The warm start and the sweeps of [`Nlgs::solve`], `sweep` doing one pass over the
    /// contacts with their slots of the previous impulses.
    fn sweeps<B: BodyStore>(
        &mut self,
        contacts: &mut [RigidContact],
        bodies: &mut B,
        (h, mean_diameter): (Real, Real),
        sweep: impl Fn(&mut [RigidContact], &mut [Vec3], &mut B, Pass) -> Sums,
    ) -> NlgsReport {
        for c in contacts.iter_mut() {
            if c.r != Vec3::zeros() {
                c.apply(&c.frame.to_global(&c.r), bodies);
            }
            if c.rolling.bound > 0.0 && c.rolling.w > 0.0 {
                // The warm moment in the current tangent plane.
                let n = c.frame.n;
                c.rolling.m -= n * n.dot(&c.rolling.m);
                if c.rolling.m != Vec3::zeros() {
                    c.apply_moment(&c.rolling.m, bodies);
                }
            } else {
                c.rolling.m = Vec3::zeros();
            }
        }
        self.prime(contacts.iter().map(|c| c.r));
        self.iterate(contacts.len(), (h, mean_diameter), |last, pass| sweep(contacts, last, bodies, pass))
    }

    /// Solves a contact problem of any kind of bodies ([`ContactProblem`]: a method's own
    /// contacts, such as the nodal contacts of deformable grains) with the same sweeps,
    /// acceleration and criterion as [`Nlgs::solve`], serially, for a step of `h` seconds
    /// between bodies of mean diameter `mean_diameter` (m).
    pub(crate) fn solve_problem<P: ContactProblem>(&mut self, problem: &mut P, h: Real, mean_diameter: Real) -> NlgsReport {
        self.history.clear();
        problem.warm_start();
        let n = problem.len();
        self.prime((0..n).map(|c| problem.impulse(c)));
        self.iterate(n, (h, mean_diameter), |last, pass| problem.sweep(last, pass))
    }

    /// Sets the momentum's previous impulses for a solve starting from `impulses`.
    fn prime(&mut self, impulses: impl ExactSizeIterator<Item = Vec3>) {
        let n = impulses.len();
        self.last.clear();
        if self.settings.acceleration > 0.0 {
            self.last.extend(impulses);
        } else {
            self.last.resize(n, Vec3::zeros());
        }
    }

    /// The sweeps of a solve of `n` contacts (warm-started, with [`Nlgs::prime`] done), `sweep`
    /// doing one pass over them with their slots of the previous impulses.
    fn iterate(&mut self, n: usize, (h, mean_diameter): (Real, Real), mut sweep: impl FnMut(&mut [Vec3], Pass) -> Sums) -> NlgsReport {
        let mut report = NlgsReport { contacts: n, ..NlgsReport::default() };
        if n == 0 {
            report.converged = true;
            return report;
        }
        let (tol, vtol) = (self.settings.tolerance, self.settings.violation_tolerance);
        let omega = self.settings.relaxation;
        let mut previous = std::mem::take(&mut self.last);
        let accelerate = self.settings.acceleration > 0.0;
        // The sweep the momentum restarted at, and the violations of the last sweep.
        let (mut restart, mut violations) = (0, Real::INFINITY);
        for it in 1..=self.settings.max_iterations {
            // Always forward: sweeping backward every other time (symmetric Gauss-Seidel)
            // took 40% more sweeps on the quickstart deposition.
            let sums = sweep(&mut previous, Pass::Solve { omega });
            let change = if sums.size2 > 0.0 {
                (sums.change2 / sums.size2).sqrt()
            } else if sums.change2 > 0.0 {
                Real::INFINITY
            } else {
                0.0
            };
            let last =
                Iterate { change, violation: h * sums.violation / (sums.count.max(1) as Real * mean_diameter), worst: h * sums.worst };
            self.history.push(last);
            report.iterations = it;
            report.last = last;
            if last.change <= tol && last.violation <= vtol && last.worst <= self.settings.worst_tolerance {
                report.converged = true;
                break;
            }
            if accelerate {
                if sums.violation > violations {
                    restart = it;
                }
                violations = sums.violation;
                let k = Real::from(it - restart);
                let beta = ((k - 1.0) / (k + 2.0)).clamp(0.0, self.settings.acceleration);
                sweep(&mut previous, Pass::Carry { beta });
            }
        }
        self.last = previous;
        report
    }
}

/// A contact problem the solver can sweep whatever its bodies ([`Nlgs::solve_problem`]):
/// each contact's local velocity comes from its bodies, its impulse changes them. A method
/// implements the bodies' side (what an impulse does to them) and calls [`visit_local`] and
/// [`carry_local`] for the contact's own turn, so that the local laws, the relaxation, the
/// acceleration and the criterion are those of every other method.
pub(crate) trait ContactProblem {
    /// Number of contacts.
    fn len(&self) -> usize;
    /// Contact `c`'s impulse (local components, N·s).
    fn impulse(&self, c: usize) -> Vec3;
    /// Adds the contacts' warm-start impulses to their bodies.
    fn warm_start(&mut self);
    /// One pass over the contacts, each with its impulse after the previous sweep in `last`:
    /// at [`Pass::Solve`] each contact's turn ([`visit_local`], its impulse's change applied to
    /// its bodies) with what it adds to the criterion; at [`Pass::Carry`] the accelerated
    /// sweep's momentum ([`carry_local`]). The problem chooses the order (and may take
    /// contacts that share no body at once, on several threads).
    fn sweep(&mut self, last: &mut [Vec3], pass: Pass) -> Sums;
}

/// One pass of the solver over the contacts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Pass {
    /// A Gauss-Seidel sweep at relaxation `omega` ([`visit`]).
    Solve {
        /// Relaxation.
        omega: Real,
    },
    /// The accelerated sweep's momentum at factor `beta` ([`carry`]).
    Carry {
        /// Momentum factor.
        beta: Real,
    },
}

impl Pass {
    /// The pass on contact `c`, whose impulse after the previous sweep is in `last`.
    #[inline(always)]
    pub(crate) fn apply(self, c: &mut RigidContact, last: &mut Vec3, bodies: &mut impl BodyStore, sums: &mut Sums) {
        match self {
            Pass::Solve { omega } => visit(c, bodies, omega, sums),
            Pass::Carry { beta } => carry(c, last, bodies, beta),
        }
    }
}

/// The momentum of the accelerated sweep on one contact (module documentation): its impulse
/// carried on by `beta` times its change since `last` (the impulse after the previous sweep),
/// projected on the admissible set (with a liquid's viscosity, at the contact's current normal
/// velocity), the change applied to its bodies; `last` takes the impulse the sweep left.
#[inline(always)]
pub(crate) fn carry(c: &mut RigidContact, last: &mut Vec3, bodies: &mut impl BodyStore, beta: Real) {
    let y = carry_local(c.r, last, beta, &c.law, || c.frame.n.dot(&c.velocity_in(bodies)));
    if let Some(y) = y {
        c.apply(&c.frame.to_global(&(y - c.r)), bodies);
        c.r = y;
    }
}

/// The momentum of the accelerated sweep on a contact of impulse `x` (local, N·s) and law
/// `law`, whatever its bodies: `x` carried on by `beta` times its change since `last`,
/// projected on the admissible set (with a liquid's viscosity at the normal velocity
/// `normal_velocity()`); `last` takes `x`. The new impulse if it differs from `x`.
#[inline(always)]
pub(crate) fn carry_local(x: Vec3, last: &mut Vec3, beta: Real, law: &LocalLaw, normal_velocity: impl FnOnce() -> Real) -> Option<Vec3> {
    let d = x - *last;
    *last = x;
    if beta == 0.0 || d == Vec3::zeros() {
        return None;
    }
    // The liquid's part of the normal impulse at the current normal velocity.
    let viscous = if law.viscosity > 0.0 { law.viscosity * normal_velocity() } else { 0.0 };
    let ahead = x + d * beta;
    let r_n = ahead.x.max(-law.cohesion - viscous);
    let (t1, t2) = local::within_disk(ahead.y, ahead.z, law.friction * (r_n + law.cohesion + viscous));
    let y = Vec3::new(r_n, t1, t2);
    (y != x).then_some(y)
}

/// What a sweep adds up for the criterion: the squared changes and sizes of the impulses, the
/// violations, and the contacts counted (all but the near pairs, [`RigidContact::near`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Sums {
    pub(crate) change2: Real,
    pub(crate) size2: Real,
    pub(crate) violation: Real,
    /// Contacts counted in the mean violation (near pairs only while they act).
    pub(crate) count: usize,
    /// The largest violation over the lever of the contact's first body, 1/s.
    pub(crate) worst: Real,
}

impl std::ops::AddAssign for Sums {
    fn add_assign(&mut self, o: Self) {
        self.change2 += o.change2;
        self.size2 += o.size2;
        self.violation += o.violation;
        self.count += o.count;
        self.worst = self.worst.max(o.worst);
    }
}

/// One contact's turn in a sweep: its violation measured, its local problem solved exactly with
/// the rest frozen (then its rolling block), the change of its impulses applied to its bodies.
#[inline(always)]
pub(crate) fn visit(c: &mut RigidContact, bodies: &mut impl BodyStore, omega: Real, sums: &mut Sums) {
    let u_now = c.frame.to_local(&c.velocity_in(bodies));
    let (r, u_free) = visit_local(u_now, &c.w, &c.law, c.r, Turn { omega, near: c.near, scale: c.scale, lever: c.a_i }, sums);
    let dr = r - c.r;
    if dr != Vec3::zeros() {
        c.apply(&c.frame.to_global(&dr), bodies);
    }
    c.r = r;
    if c.rolling.bound > 0.0 && c.rolling.w > 0.0 {
        // The rolling block, with the normal impulse just found (its moments counted as
        // impulses at the lever a_i).
        let free = c.rolling_velocity(bodies) - c.rolling.m * c.rolling.w;
        let rho = c.law.contact_part(r.x, u_free.x + c.w.n * r.x);
        let mut m = local::solve_rolling(&c.rolling, &free, rho);
        if omega != 1.0 {
            m = c.rolling.m + (m - c.rolling.m) * omega;
        }
        let dm = m - c.rolling.m;
        if dm != Vec3::zeros() {
            c.apply_moment(&dm, bodies);
            sums.change2 += dm.norm_squared() / (c.a_i * c.a_i);
        }
        sums.size2 += m.norm_squared() / (c.a_i * c.a_i);
        c.rolling.m = m;
    }
}

/// What a contact brings to its turn in a sweep besides its velocity, block, law and impulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Turn {
    /// Relaxation.
    pub(crate) omega: Real,
    /// A near pair ([`RigidContact::near`]).
    pub(crate) near: bool,
    /// Impulse scale for the criterion, N·s ([`RigidContact::scale`]).
    pub(crate) scale: Real,
    /// Length the largest violation is measured against (the first body's radius), m.
    pub(crate) lever: Real,
}

/// A contact's turn in a sweep, whatever its bodies: its violation measured at the local
/// velocity `u_now` (with its impulse `r` in it), its local problem of block `w` solved
/// exactly with the rest frozen, relaxed by `turn.omega`, the sums of the criterion updated.
/// Returns the new impulse and the velocity the contact would have without its own impulse;
/// the caller applies the change of impulse to the bodies.
#[inline(always)]
pub(crate) fn visit_local(u_now: Vec3, w: &Delassus, law: &LocalLaw, r_old: Vec3, turn: Turn, sums: &mut Sums) -> (Vec3, Vec3) {
    measure_violation(u_now.x, law, &turn, sums);
    let u_free = u_now - w.apply(&r_old);
    let mut r = local::solve(w, &u_free, law);
    if turn.omega != 1.0 {
        r = r_old + (r - r_old) * turn.omega;
    }
    tally_change(r_old, r, &turn, sums);
    (r, u_free)
}

/// The criterion's violation of a contact at the normal velocity `u_n` (m/s) it has when its
/// turn comes ([`visit_local`]; a method that solves several contacts at once measures each
/// with this before it solves them).
#[inline(always)]
pub(crate) fn measure_violation(u_n: Real, law: &LocalLaw, turn: &Turn, sums: &mut Sums) {
    let violation = (law.target - u_n).max(0.0);
    sums.violation += violation;
    sums.worst = sums.worst.max(violation / turn.lever);
}

/// The criterion's change and size of a contact whose turn took its impulse from `r_old` to
/// `r` ([`visit_local`]; with [`measure_violation`], for a method that solves several contacts
/// at once).
#[inline(always)]
pub(crate) fn tally_change(r_old: Vec3, r: Vec3, turn: &Turn, sums: &mut Sums) {
    let dr = r - r_old;
    if dr != Vec3::zeros() {
        sums.change2 += dr.norm_squared();
    }
    if !turn.near || r != Vec3::zeros() || dr != Vec3::zeros() {
        sums.size2 += r.norm_squared().max(turn.scale * turn.scale);
        sums.count += 1;
    }
}

/// The law of a contact whose normal velocity at the start of the step is `u_n` (m/s), for the
/// restitution `e`, friction `mu` and cohesive impulse `c`: the formal-velocity target
/// `b = -e min(u_n, 0)` ([`super::local`]).
pub fn law_for(u_n: Real, e: Real, mu: Real, c: Real) -> LocalLaw {
    LocalLaw { target: -e * u_n.min(0.0), friction: mu, cohesion: c, viscosity: 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_x() -> ContactFrame {
        ContactFrame::new(2, Vec3::x())
    }

    /// A row of equal disks touching along x, pushed from the left at 1 m/s, frictionless and
    /// perfectly plastic: the whole row ends moving at the mean momentum, N contacts solved
    /// exactly — with plain and with under-relaxed updates (same fixed point, more sweeps).
    #[test]
    fn a_row_of_disks_shares_the_momentum() {
        let plain = row_of_disks(1.0);
        let relaxed = row_of_disks(0.6);
        assert!(relaxed > plain, "relaxed {relaxed} sweeps, plain {plain}");
    }

    /// Solves the row at relaxation `relax` and checks the answer; returns the sweeps.
    fn row_of_disks(relax: Real) -> u32 {
        let n = 5;
        let mut vel = vec![Vec3::zeros(); n];
        vel[0] = Vec3::new(1.0, 0.0, 0.0);
        let mut omega = vec![Vec3::zeros(); n];
        let (im, ii) = (vec![1.0; n], vec![2.0; n]);
        // Contact k between disk k+1 (i) and disk k (j): n points from k to k+1.
        let mut contacts: Vec<RigidContact> = (0..n - 1)
            .map(|k| RigidContact {
                i: (k + 1) as u32,
                j: Side::Body(k as u32),
                frame: frame_x(),
                a_i: 0.5,
                a_j: 0.5,
                drive: Vec3::zeros(),
                w: RigidContact::delassus(1.0, 2.0, 0.5, 1.0, 2.0, 0.5),
                law: law_for(-1.0, 0.0, 0.0, 0.0),
                r: Vec3::zeros(),
                rolling: Rolling::default(),
                scale: 0.0,
                near: false,
            })
            .collect();
        // Only contact 0 approaches at the start; the others are closed at rest.
        for c in contacts.iter_mut().skip(1) {
            c.law = law_for(0.0, 0.0, 0.0, 0.0);
        }
        let mut solver = Nlgs::new(Convergence {
            tolerance: 1e-10,
            violation_tolerance: 1e-10,
            worst_tolerance: 1e-10,
            max_iterations: 10_000,
            relaxation: relax,
            acceleration: 0.0,
        });
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut [], &[]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged, "{report:?}");
        for v in &vel {
            assert!((v.x - 0.2).abs() < 1e-8, "{vel:?}");
        }
        assert!(omega.iter().all(|w| w.norm() < 1e-15));
        // The history decreases to the tolerance.
        let h = &solver.history;
        assert_eq!(h.len() as u32, report.iterations);
        assert!(h.last().is_some_and(|l| l.change <= 1e-10));
        report.iterations
    }

    /// A column of 40 equal disks (mass 1 kg) on a fixed floor, each given one step of gravity
    /// as its free velocity, solved from nothing: contact k (below disk k) carries the weight of
    /// the 40 - k disks above it over the step, `(40 - k) g h`, and every disk ends at rest —
    /// with plain and with accelerated sweeps, the momentum taking a small part of the sweeps
    /// (Gauss-Seidel moves the load down a chain by about one contact per sweep, its error
    /// decays by a factor 1 - O(1/n²) per sweep). Measured: 13,124 sweeps plain, 1,126 with
    /// momentum (11.7x). The bound asks 3x: a momentum that does nothing (or that restarts at
    /// every sweep) fails it, and it leaves room to change the restart rule.
    #[test]
    fn momentum_carries_the_weight_of_a_column_down_in_fewer_sweeps() {
        let plain = column_of_disks(0.0);
        let accelerated = column_of_disks(0.9);
        assert!(3 * accelerated < plain, "accelerated {accelerated} sweeps, plain {plain}");
    }

    /// Solves the column with momentum factor `acceleration` and checks the answer; returns the
    /// sweeps.
    fn column_of_disks(acceleration: Real) -> u32 {
        let (n, gh) = (40, 9.81e-3);
        let mut vel = vec![Vec3::new(0.0, -gh, 0.0); n];
        let mut omega = vec![Vec3::zeros(); n];
        let (im, ii) = (vec![1.0; n], vec![2.0; n]);
        // Contact 0: disk 0 on the floor; contact k: disk k on disk k - 1 (n points up).
        let mut contacts: Vec<RigidContact> = (0..n)
            .map(|k| RigidContact {
                i: k as u32,
                j: if k == 0 { Side::Boundary(0) } else { Side::Body(k as u32 - 1) },
                frame: ContactFrame::new(2, Vec3::y()),
                a_i: 0.5,
                a_j: if k == 0 { 0.0 } else { 0.5 },
                drive: Vec3::zeros(),
                w: if k == 0 {
                    RigidContact::delassus_boundary(1.0, 2.0, 0.5, 0.0)
                } else {
                    RigidContact::delassus(1.0, 2.0, 0.5, 1.0, 2.0, 0.5)
                },
                law: law_for(0.0, 0.0, 0.5, 0.0),
                r: Vec3::zeros(),
                rolling: Rolling::default(),
                scale: gh,
                near: false,
            })
            .collect();
        let mut solver = Nlgs::new(Convergence {
            tolerance: 1e-9,
            violation_tolerance: 1e-12,
            worst_tolerance: 1e-9,
            max_iterations: 100_000,
            relaxation: 1.0,
            acceleration,
        });
        let mut floor = [Vec3::zeros()];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut floor, &[Mobility::FIXED]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged, "{report:?}");
        for (k, c) in contacts.iter().enumerate() {
            let exact = (n - k) as Real * gh;
            assert!((c.r.x - exact).abs() < 1e-6 * exact && c.r.y == 0.0, "contact {k}: {:?}, exact {exact}", c.r);
        }
        assert!(vel.iter().all(|v| v.norm() < 1e-8 * gh), "{vel:?}");
        report.iterations
    }

    /// A disk sliding on a boundary with friction: the contact impulse stops the fall and
    /// the friction impulse takes mu times it from the slip, and the spin.
    #[test]
    fn friction_on_a_boundary_slows_the_slip_and_spins_the_disk() {
        let (m, r) = (2.0, 0.1);
        let inertia = 0.5 * m * r * r;
        let mut vel = vec![Vec3::new(1.0, -0.5, 0.0)];
        let mut omega = vec![Vec3::zeros()];
        let (im, ii) = (vec![1.0 / m], vec![1.0 / inertia]);
        let mut contacts = vec![RigidContact {
            i: 0,
            j: Side::Boundary(0),
            frame: ContactFrame::new(2, Vec3::y()),
            a_i: r,
            a_j: 0.0,
            drive: Vec3::zeros(),
            w: RigidContact::delassus(1.0 / m, 1.0 / inertia, r, 0.0, 0.0, 0.0),
            law: law_for(-0.5, 0.0, 0.2, 0.0),
            r: Vec3::zeros(),
            rolling: Rolling::default(),
            scale: 0.0,
            near: false,
        }];
        let mut solver = Nlgs::new(tight(100));
        let mut wall = [Vec3::zeros()];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut wall, &[Mobility::FIXED]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged);
        // Normal impulse m * 0.5 = 1 N·s; friction 0.2 N·s against the slip (t1 = -x for n = y).
        let p = contacts[0].frame.to_global(&contacts[0].r);
        assert!((p.y - 1.0).abs() < 1e-12 && (p.x + 0.2).abs() < 1e-12, "{p:?}");
        assert!(vel[0].y.abs() < 1e-12 && (vel[0].x - 0.9).abs() < 1e-12);
        // Torque of -0.2 x at the bottom point: spin -0.2 * r / I about z (clockwise: rolling
        // towards +x).
        assert!((omega[0].z + 0.2 * r / inertia).abs() < 1e-12, "{:?}", omega[0]);
    }

    /// A free plate of mass M falling at V onto a resting disk of mass m (no restitution): both
    /// end at the common velocity M V / (M + m), momentum kept.
    #[test]
    fn a_free_boundary_shares_its_momentum_with_the_grain_it_hits() {
        let (m, big_m, v): (f64, f64, f64) = (1.0, 3.0, -2.0);
        let mut vel = vec![Vec3::zeros()];
        let mut omega = vec![Vec3::zeros()];
        let (im, ii) = (vec![1.0 / m], vec![10.0]);
        // The plate is above the disk: the normal points from the plate down to the disk.
        let n = -Vec3::y();
        let mut contacts = vec![RigidContact {
            i: 0,
            j: Side::Boundary(0),
            frame: ContactFrame::new(2, n),
            a_i: 0.1,
            a_j: 0.0,
            drive: Vec3::zeros(),
            w: RigidContact::delassus_boundary(1.0 / m, 10.0, 0.1, 1.0 / big_m),
            law: law_for(-v.abs(), 0.0, 0.5, 0.0),
            r: Vec3::zeros(),
            rolling: Rolling::default(),
            scale: 0.0,
            near: false,
        }];
        let mut plate = [Vec3::new(0.0, v, 0.0)];
        let mut solver = Nlgs::new(tight(100));
        let mobility = [Mobility { direction: Vec3::y(), inv_mass: 1.0 / big_m, partner: None, max_speed: Real::INFINITY }];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut plate, &mobility);
        assert!(solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None).converged);
        let common = big_m * v / (big_m + m);
        assert!((vel[0].y - common).abs() < 1e-12 && (plate[0].y - common).abs() < 1e-12, "{:?} {:?}", vel[0], plate[0]);
        assert!((m * vel[0].y + big_m * plate[0].y - big_m * v).abs() < 1e-12);
    }

    /// The bodies of a test: grains with their velocities, spins and inverse masses and
    /// inertias, boundaries with their velocities and mobilities, none turning.
    fn bodies<'a>(
        (vel, omega): (&'a mut [Vec3], &'a mut [Vec3]),
        (inv_mass, inv_inertia): (&'a [Real], &'a [Real]),
        boundary_vel: &'a mut [Vec3],
        boundary_mobility: &'a [Mobility],
    ) -> RigidBodies<'a> {
        RigidBodies { vel, omega, inv_mass, inv_inertia, boundary_vel, boundary_mobility, boundary_omega: &[] }
    }

    /// Every tolerance at 1e-12, no relaxation, `max_iterations` sweeps.
    fn tight(max_iterations: u32) -> Convergence {
        Convergence {
            tolerance: 1e-12,
            violation_tolerance: 1e-12,
            worst_tolerance: 1e-12,
            max_iterations,
            relaxation: 1.0,
            acceleration: 0.0,
        }
    }

    /// A contact between disk `0` and boundary `k`, along `n` (from the boundary to the disk).
    fn disk_on(k: u32, n: Vec3, im_b: Real) -> RigidContact {
        test_contact(0, Side::Boundary(k), n, (0.1, 0.0), RigidContact::delassus_boundary(1.0, 10.0, 0.1, im_b))
    }

    /// Ten disks resting on a fixed floor and one coming down on it at 1 m/s: the first sweep
    /// sees a mean violation of 1/11 (h = 1 s, d = 1 m) and a largest one of 1/0.1 = 10 radii.
    /// A mean bound alone accepts that sweep; the bound on the largest violation makes the
    /// solver sweep again (the second sweep finds every contact satisfied).
    #[test]
    fn one_violated_contact_among_many_satisfied_ones_is_not_converged() {
        let n = 11;
        let sweeps = |worst_tolerance: Real| {
            let mut vel = vec![Vec3::zeros(); n];
            vel[n - 1].y = -1.0;
            let mut omega = vec![Vec3::zeros(); n];
            let (im, ii) = (vec![1.0; n], vec![10.0; n]);
            let mut contacts: Vec<RigidContact> = (0..n as u32).map(|i| RigidContact { i, ..disk_on(0, Vec3::y(), 0.0) }).collect();
            let mut walls = [Vec3::zeros()];
            let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut walls, &[Mobility::FIXED]);
            let settings = Convergence {
                tolerance: Real::INFINITY,
                violation_tolerance: 0.1,
                worst_tolerance,
                max_iterations: 10,
                relaxation: 1.0,
                acceleration: 0.0,
            };
            let mut solver = Nlgs::new(settings);
            let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
            assert!(report.converged);
            let first = solver.history[0];
            assert!((first.violation - 1.0 / n as Real).abs() < 1e-12 && (first.worst - 10.0).abs() < 1e-12, "{first:?}");
            assert!(vel[n - 1].norm() < 1e-12);
            report.iterations
        };
        assert_eq!(sweeps(100.0), 1);
        assert_eq!(sweeps(1.0), 2);
    }

    /// A free plate whose push has built up a velocity of 2 m/s, bounded at 0.5 m/s: a free
    /// disk it meets is driven at the bound, not at 2 m/s; a disk resting on a fixed floor stops
    /// it, and then takes the whole of its push (the bound holds the plate's speed, not its
    /// force), passed on to the floor.
    #[test]
    fn a_bounded_boundary_drives_at_its_bound_and_pushes_with_its_whole_force() {
        let big_m = 3.0;
        let plate = Mobility { direction: Vec3::y(), inv_mass: 1.0 / big_m, partner: None, max_speed: 0.5 };
        let mobility = [plate, Mobility::FIXED];
        let settings = tight(200);
        let (im, ii) = ([1.0], [10.0]);
        let solve = |contacts: &mut Vec<RigidContact>| {
            let (mut vel, mut omega) = (vec![Vec3::zeros()], vec![Vec3::zeros()]);
            let mut walls = [Vec3::new(0.0, -2.0, 0.0), Vec3::zeros()];
            let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut walls, &mobility);
            assert!(Nlgs::new(settings).solve(contacts, &mut bodies, 1.0, 1.0, None).converged);
            (vel[0], walls[0])
        };
        // Free disk: it ends with the plate at the bound; its impulse is m × 0.5.
        let mut free = vec![disk_on(0, -Vec3::y(), 1.0 / big_m)];
        let (v, w) = solve(&mut free);
        assert!((v.y + 0.5).abs() < 1e-12 && (w.y + 0.5).abs() < 1e-12, "{v:?} {w:?}");
        assert!((free[0].r.x - 0.5).abs() < 1e-12, "{:?}", free[0].r);
        // On the floor: the plate stops, and the contacts carry M × 2 = 6 N·s.
        let mut held = vec![disk_on(0, -Vec3::y(), 1.0 / big_m), disk_on(1, Vec3::y(), 0.0)];
        let (v, w) = solve(&mut held);
        assert!(v.norm() < 1e-12 && w.norm() < 1e-12, "{v:?} {w:?}");
        assert!((held[0].r.x - 6.0).abs() < 1e-9 && (held[1].r.x - 6.0).abs() < 1e-9, "{:?} {:?}", held[0].r, held[1].r);
    }
}
