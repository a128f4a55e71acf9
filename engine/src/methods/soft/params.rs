//! The solver settings the soft-grain methods share (`mpm` and `fem`): the time step, the
//! θ-method, Newton and the contact solve, with their defaults and checks.

use crate::math::Real;
use crate::methods::method::check_threads;
use crate::scene::Checker;

/// The settings of a soft-grain method's step, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftSolver {
    /// Time step, s; `None`: the fastest imposed motion covers `max_displacement` of a cell (or
    /// an element) in one step.
    pub time_step: Option<Real>,
    /// Largest expected displacement per step / cell or element size (default time step).
    pub max_displacement: Real,
    /// θ of the time integration, in [½, 1].
    pub theta: Real,
    /// Whether the steps keep the grains' inertia, or leave it out, or let the scene decide.
    pub dynamics: Dynamics,
    /// Newton's tolerance on the velocity correction, relative.
    pub newton_tolerance: Real,
    /// Newton iterations allowed per step.
    pub max_newton: u32,
    /// Contact solver: tolerance on a sweep's change of the grains' velocities, relative to
    /// Newton's velocity scale ([`crate::methods::soft::contact`]), of a step's first Newton
    /// iteration; each further one is asked for a hundredth of the last correction as well
    /// ([`crate::methods::soft::contact::FORCING`]), and Newton converges only on a solve asked
    /// for Newton's tolerance or less.
    pub tolerance: Real,
    /// Contact solver: tolerance on the mean violation.
    pub violation_tolerance: Real,
    /// Contact solver: sweeps allowed per Newton iteration.
    pub max_iterations: u32,
    /// Contact solver: momentum factor of the accelerated sweep, in [0, 1); `None` (the
    /// default): [`SOFT_MOMENTUM`] with one side held, none with both ([`soft_momentum`]).
    pub acceleration: Option<Real>,
    /// Threads; 0 = rayon's global pool.
    pub threads: usize,
}

impl SoftSolver {
    /// The contact solver's settings for a step, contacts held on both sides of each pair
    /// (`both`) or on one ([`soft_momentum`]).
    pub fn contact(&self, both: bool) -> crate::nscd::Convergence {
        crate::nscd::Convergence {
            tolerance: self.tolerance,
            violation_tolerance: self.violation_tolerance,
            worst_tolerance: 1e-4,
            max_iterations: self.max_iterations,
            relaxation: 1.0,
            acceleration: soft_momentum(self.acceleration, both),
            damp_cycles: true,
        }
    }
}

impl Default for SoftSolver {
    /// Backward Euler for quasi-static loadings, Newton to 1e-5 in at most 25 iterations, the
    /// contact solve to 1e-6: the settings of the compaction tests (`methods::mpm::tests`).
    fn default() -> Self {
        Self {
            time_step: None,
            max_displacement: 0.05,
            theta: 1.0,
            dynamics: Dynamics::Auto,
            newton_tolerance: 1e-5,
            max_newton: 25,
            tolerance: 1e-6,
            violation_tolerance: 1e-6,
            max_iterations: 20_000,
            acceleration: None,
            threads: 0,
        }
    }
}

/// Whether a soft-grain method's steps keep the grains' inertia (`method.dynamics`, written
/// `"auto"`, `"inertial"` or `"quasi_static"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dynamics {
    /// Quasi-static when the scene's loading is slow against the grains' elastic waves
    /// ([`crate::advise::soft_inertia`]), inertial otherwise.
    #[default]
    Auto,
    /// The θ-method: each step starts from the grains' velocities at the end of the last.
    Inertial,
    /// Load steps solved to equilibrium: each step starts from rest, so no momentum is carried
    /// from one to the next, and is solved at its end (θ = 1). The mass stays in the step's
    /// equations as a drag `M v / dt` (it holds a grain that nothing touches), small against
    /// the forces of loaded grains (docs/physics.md §5.1, "Quasi-static load steps").
    QuasiStatic,
}

/// The shared settings as a scene writes them (each method's own spec holds them among its
/// fields and hands them over).
#[derive(Debug, Clone, Default)]
pub struct SoftSolverSpec {
    /// `method.time_step`.
    pub time_step: Option<f64>,
    /// `method.max_displacement`.
    pub max_displacement: Option<f64>,
    /// `method.theta`.
    pub theta: Option<f64>,
    /// `method.dynamics`.
    pub dynamics: Option<Dynamics>,
    /// `method.newton_tolerance`.
    pub newton_tolerance: Option<f64>,
    /// `method.max_newton`.
    pub max_newton: Option<u32>,
    /// `method.tolerance`.
    pub tolerance: Option<f64>,
    /// `method.violation_tolerance`.
    pub violation_tolerance: Option<f64>,
    /// `method.max_iterations`.
    pub max_iterations: Option<u32>,
    /// `method.acceleration`.
    pub acceleration: Option<f64>,
    /// `method.threads`.
    pub threads: Option<usize>,
}

/// Declares a soft-grain method's spec (`$name`, for `"method": {"kind": $kind, ...}`): the
/// settings every soft-grain method shares, written once here, then the method's own fields;
/// unknown fields are refused. Its `solver()` hands the shared ones to [`check`].
macro_rules! soft_params_spec {
    ($(#[$meta:meta])* $name:ident, $kind:literal { $($(#[$fmeta:meta])* $field:ident: $ty:ty),* $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            #[doc = concat!("Always `\"", $kind, "\"`.")]
            #[serde(default)]
            pub kind: String,
            /// Time step, s. Default: the fastest imposed motion covers `max_displacement` of a
            /// grid cell (`mpm`) or an element (`fem`) in one step.
            #[serde(default)]
            pub time_step: Option<f64>,
            /// Largest expected displacement per step / cell or element size (default time
            /// step). Default 0.05.
            #[serde(default)]
            pub max_displacement: Option<f64>,
            /// θ of the time integration, in [0.5, 1]. Default 1 (backward Euler).
            #[serde(default)]
            pub theta: Option<f64>,
            /// `"inertial"` (the θ-method: the grains keep their momentum from step to step),
            /// `"quasi_static"` (each step a load step solved to equilibrium: no momentum kept,
            /// θ = 1) or `"auto"`: quasi-static when the loading is slow against the grains'
            /// waves ([`crate::advise::soft_inertia`]). Default `"auto"`.
            #[serde(default)]
            pub dynamics: Option<$crate::methods::soft::params::Dynamics>,
            /// Newton's tolerance on the velocity correction (relative). Default 1e-5.
            #[serde(default)]
            pub newton_tolerance: Option<f64>,
            /// Newton iterations allowed per step. Default 25.
            #[serde(default)]
            pub max_newton: Option<u32>,
            /// Contact solver: tolerance on a sweep's change of the grains' velocities, relative
            /// to Newton's velocity scale. Default 1e-6.
            #[serde(default)]
            pub tolerance: Option<f64>,
            /// Contact solver: tolerance on the mean violation (m/s relative to the velocity
            /// scale). Default 1e-6.
            #[serde(default)]
            pub violation_tolerance: Option<f64>,
            /// Contact solver: sweeps allowed per Newton iteration. Default 20000.
            #[serde(default)]
            pub max_iterations: Option<u32>,
            /// Contact solver: momentum factor of the accelerated sweep, in [0, 1). Default 0.9
            /// with contacts held on one side, none with both (`symmetric_contact`).
            #[serde(default)]
            pub acceleration: Option<f64>,
            /// Threads; 0 = rayon's global pool. Default 0.
            #[serde(default)]
            pub threads: Option<usize>,
            $($(#[$fmeta])* #[serde(default)] pub $field: $ty,)*
        }

        impl $name {
            /// The settings shared with the other soft-grain methods.
            fn solver(&self) -> $crate::methods::soft::params::SoftSolverSpec {
                $crate::methods::soft::params::SoftSolverSpec {
                    time_step: self.time_step,
                    max_displacement: self.max_displacement,
                    theta: self.theta,
                    dynamics: self.dynamics,
                    newton_tolerance: self.newton_tolerance,
                    max_newton: self.max_newton,
                    tolerance: self.tolerance,
                    violation_tolerance: self.violation_tolerance,
                    max_iterations: self.max_iterations,
                    acceleration: self.acceleration,
                    threads: self.threads,
                }
            }
        }
    };
}
pub(crate) use soft_params_spec;

/// Checks the shared settings, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &SoftSolverSpec) -> SoftSolver {
    let mut p = SoftSolver::default();
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.max_displacement {
        if s.time_step.is_some() {
            c.fail("method.max_displacement", "give time_step or max_displacement, not both");
        } else if c.positive("method.max_displacement", f) {
            p.max_displacement = f;
        }
    }
    if let Some(t) = s.theta {
        if c.within("method.theta", t, 0.5, 1.0) {
            p.theta = t;
            if t != 1.0 {
                // A θ-method asked for by name: the scene wants the inertial steps.
                p.dynamics = Dynamics::Inertial;
            }
        }
    }
    match s.dynamics {
        Some(Dynamics::QuasiStatic) if s.theta.is_some_and(|t| t != 1.0) => {
            c.fail("method.theta", "quasi_static dynamics solves each step at its end: theta must be 1 (or left out)")
        }
        Some(d @ (Dynamics::Inertial | Dynamics::QuasiStatic)) => p.dynamics = d,
        Some(Dynamics::Auto) | None => {}
    }
    if let Some(t) = s.newton_tolerance {
        if c.positive("method.newton_tolerance", t) {
            p.newton_tolerance = t;
        }
    }
    match s.max_newton {
        Some(0) => c.fail("method.max_newton", "must be >= 1"),
        Some(n) => p.max_newton = n,
        None => {}
    }
    if let Some(t) = s.tolerance {
        if c.positive("method.tolerance", t) {
            p.tolerance = t;
        }
    }
    if let Some(t) = s.violation_tolerance {
        if c.positive("method.violation_tolerance", t) {
            p.violation_tolerance = t;
        }
    }
    match s.max_iterations {
        Some(0) => c.fail("method.max_iterations", "must be >= 1"),
        Some(n) => p.max_iterations = n,
        None => {}
    }
    if let Some(a) = s.acceleration {
        if !(a.is_finite() && (0.0..1.0).contains(&a)) {
            c.fail("method.acceleration", format!("must be >= 0 and < 1, got {a}"));
        } else {
            p.acceleration = Some(a);
        }
    }
    p.threads = s.threads.map_or(0, |t| check_threads(c, t));
    p
}

/// The soft-grain contact solve's momentum factor when one side is held and the scene sets
/// none ([`soft_momentum`]).
pub const SOFT_MOMENTUM: Real = 0.9;

/// The soft-grain contact solve's momentum factor (`method.acceleration` of `mpm` and `fem`)
/// with both grains' outlines held (`both`) or one: `acceleration` if the scene sets it, else
/// [`SOFT_MOMENTUM`] with one side and none with both. The solve takes each pair's contacts
/// together ([`crate::methods::soft::block`]); with both sides held, momentum carries the
/// impulses on along the directions where the two grains' contacts hold the same places twice,
/// where nothing damps it, and solves can cycle until their budget is spent. One-sided, momentum
/// still saves sweeps (docs/methods/fem.md, "Parameters"; docs/methods/mpm.md, "Design
/// measurements").
pub fn soft_momentum(acceleration: Option<Real>, both: bool) -> Real {
    acceleration.unwrap_or(if both { 0.0 } else { SOFT_MOMENTUM })
}
