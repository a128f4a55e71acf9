//! What the soft-grain methods — the material point method ([`super::mpm`]) and the finite
//! element method ([`super::fem`]), both with contact dynamics — share:
//!
//! - [`Settings`]: a method's settings for its steps, and [`Scheme`]: the θ-method's for one;
//! - [`build`]: what building a method on a scene shares (the placed disks, the laws, the
//!   walls as planes, the time step);
//! - [`polygon`]: the geometry of a grain's outline (area, inside, nearest segment);
//! - [`measure`]: the grains and their contacts as the shared metrics see them;
//! - [`contact`]: contacts between grains' outlines and with walls, each grain acting through
//!   its own nodes, as a problem of the shared contact solver ([`crate::nscd`]);
//! - [`augment`]: a grain's Newton matrix made definite along its closed contacts;
//! - [`block`]: the normal impulses of a pair of grains' contacts solved together, exactly;
//! - [`node_block`]: a grain's `A⁻¹` between its contacts' nodes, kept with its factor (fem);
//! - [`schedule`]: the order of the contact solve's sweeps, tasks that share no grain at once;
//! - [`parts`]: a step done in parts, split where it fails;
//! - [`progress`]: a system's steps, time and costs so far, and a step's bookkeeping;
//! - [`trace`]: a record of every Newton iteration, for a run that asks.

pub mod augment;
pub mod block;
pub mod build;
pub mod contact;
#[cfg(test)]
pub mod hertz;
pub mod measure;
pub mod node_block;
pub mod params;
pub mod parts;
pub mod polygon;
pub mod progress;
pub mod schedule;
pub mod sim;
pub mod trace;

use nalgebra::Vector2;

use crate::math::Real;

/// A Newton iteration that reduces the correction by less than this factor makes the next one
/// assemble and factorise the matrices anew; otherwise the next one keeps them and their
/// contact blocks (a modified Newton iteration: a factorisation and the solves of the contacts'
/// Delassus blocks saved for each kept matrix; the fixed point does not depend on the matrix).
pub const REFRESH_RATIO: Real = 0.25;

/// The θ-method's settings for a step (the nodal residuals of [`crate::methods::mpm::field`] and
/// [`crate::methods::fem::body`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scheme {
    /// Time step, s.
    pub dt: Real,
    /// θ of the θ-method, in [½, 1].
    pub theta: Real,
    /// Gravity, m/s².
    pub gravity: Vector2<Real>,
}

/// A soft-grain method's settings for its steps (each method's own, such as the material point
/// method's FLIP fraction, are its system's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Time step, s.
    pub dt: Real,
    /// θ of the θ-method, in [½, 1].
    pub theta: Real,
    /// Gravity, m/s².
    pub gravity: Vector2<Real>,
    /// Each step starts from rest: a load step solved to equilibrium, no momentum carried
    /// ([`params::Dynamics::QuasiStatic`]; `theta` is then 1).
    pub quasi_static: bool,
    /// Newton's tolerance on the velocity correction, relative to the velocity scale.
    pub newton_tolerance: Real,
    /// Newton's budget of iterations a step.
    pub max_newton: u32,
    /// The contact solver's settings.
    pub contact: crate::nscd::Convergence,
    /// Which grains' vertices the contacts between grains hold outside the other's outline.
    pub sides: contact::Sides,
}

impl Settings {
    /// The θ-method's settings for a part of `dt` (s).
    pub fn scheme(&self, dt: Real) -> Scheme {
        Scheme { dt, theta: self.theta, gravity: self.gravity }
    }
}

/// The contact solver's settings of the soft-grain methods' tests: tight tolerances, plain
/// Gauss-Seidel.
#[cfg(test)]
pub fn tests_convergence() -> crate::nscd::Convergence {
    crate::nscd::Convergence {
        tolerance: 1e-6,
        violation_tolerance: 1e-7,
        worst_tolerance: 1e-5,
        max_iterations: 20_000,
        relaxation: 1.0,
        acceleration: 0.0,
        damp_cycles: true,
    }
}

/// The index of the largest of `values` (the grain a Newton failure names); `None` when there
/// are none or all are NaN.
pub fn largest(values: impl Iterator<Item = Real>) -> Option<usize> {
    values.enumerate().filter(|(_, v)| !v.is_nan()).max_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i)
}
