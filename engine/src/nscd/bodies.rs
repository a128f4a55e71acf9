//! The bodies the contacts act on: their velocities and inverse inertias ([`RigidBodies`]),
//! how a boundary may move ([`Mobility`]), and the same seen through cells that the threads of
//! the coloured sweep share ([`SolveBodies`]).

use std::sync::atomic::{AtomicU64, Ordering};

use crate::math::{Real, Vec3};

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

/// The parts of [`BodyStore`] that the sweep only reads, the same for both stores: their fields
/// have the same names.
macro_rules! fixed_parts {
    () => {
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
    };
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
    fixed_parts!();
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
    fixed_parts!();
}

/// A vector whose components threads may read and write: each `f64` held in an `AtomicU64`,
/// loaded and stored with relaxed ordering (plain moves on common hardware). The sweep never
/// lets two threads at one body at the same time ([`super::colour`]); the atomics make that a
/// matter of correctness, not of memory safety, and rayon's joins order the colours.
#[derive(Debug, Default)]
pub(crate) struct SharedVec3([AtomicU64; 3]);

impl SharedVec3 {
    pub(super) fn new(v: &Vec3) -> Self {
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
    pub(super) fn fill(&mut self, b: &RigidBodies<'_>) {
        let copy = |to: &mut Vec<SharedVec3>, from: &[Vec3]| {
            to.clear();
            to.extend(from.iter().map(SharedVec3::new));
        };
        copy(&mut self.vel, b.vel);
        copy(&mut self.omega, b.omega);
        copy(&mut self.boundary_vel, b.boundary_vel);
    }

    /// Heap bytes held.
    pub(super) fn heap_bytes(&self) -> usize {
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
    pub(super) fn new(b: &RigidBodies<'a>, cells: &'a Cells) -> Self {
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

    pub(super) fn store(&self, b: &mut RigidBodies<'_>) {
        let back = |from: &[SharedVec3], to: &mut [Vec3]| to.iter_mut().zip(from).for_each(|(t, f)| *t = f.get());
        back(self.vel, b.vel);
        back(self.omega, b.omega);
        back(self.boundary_vel, b.boundary_vel);
    }
}
