//! The parameters of the implicit finite element method (`"method": "fem"`): its mesh beside
//! the solver settings it shares with `mpm` ([`SoftSolver`]).

use serde::{Deserialize, Serialize};

use crate::math::Real;
use crate::methods::method::{read_spec, Method, MethodEntry};
use crate::methods::soft::params::{soft_solver_spec, SoftSolver};
use crate::scene::Checker;

/// Parameters of the implicit finite element method with contact dynamics, as written in a
/// scene (all optional).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FemParamsSpec {
    /// Always `"fem"`.
    #[serde(default)]
    pub kind: String,
    /// Time step, s. Default: the fastest imposed motion covers `max_displacement` of an
    /// element in one step.
    #[serde(default)]
    pub time_step: Option<f64>,
    /// Largest expected displacement per step / element size (default time step). Default 0.05.
    #[serde(default)]
    pub max_displacement: Option<f64>,
    /// Boundary elements across the smallest grain diameter (>= 2). Default 8.
    #[serde(default)]
    pub elements_per_diameter: Option<f64>,
    /// θ of the time integration, in [0.5, 1]. Default 1 (backward Euler).
    #[serde(default)]
    pub theta: Option<f64>,
    /// Newton's tolerance on the velocity correction (relative). Default 1e-5.
    #[serde(default)]
    pub newton_tolerance: Option<f64>,
    /// Newton iterations allowed per step. Default 25.
    #[serde(default)]
    pub max_newton: Option<u32>,
    /// Contact solver: tolerance on a sweep's change of the grains' velocities, relative to
    /// Newton's velocity scale. Default 1e-6.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Contact solver: tolerance on the mean violation (m/s relative to the velocity scale).
    /// Default 1e-6.
    #[serde(default)]
    pub violation_tolerance: Option<f64>,
    /// Contact solver: sweeps allowed per Newton iteration. Default 20000.
    #[serde(default)]
    pub max_iterations: Option<u32>,
    /// Contact solver: momentum factor of the accelerated sweep, in [0, 1). Default: none, with
    /// contacts held on both sides.
    #[serde(default)]
    pub acceleration: Option<f64>,
    /// Contacts between grains hold the nodes of both grains' boundaries outside the other's
    /// (true), or only those of the grain of lower index (false). Default true.
    #[serde(default)]
    pub symmetric_contact: Option<bool>,
    /// Threads; 0 = rayon's global pool. Default 0.
    #[serde(default)]
    pub threads: Option<usize>,
}

/// Parameters of the implicit finite element method ([`crate::methods::fem`]), checked.
#[derive(Debug, Clone, PartialEq)]
pub struct FemParams {
    /// The step's settings, shared with `mpm`.
    pub solver: SoftSolver,
    /// Boundary elements across the smallest grain diameter (the element size is that diameter
    /// over this).
    pub elements_per_diameter: Real,
    /// Contacts between grains hold both grains' vertices outside the other's outline
    /// ([`crate::methods::soft::contact::Sides::Both`]), not only the lower index's.
    pub symmetric_contact: bool,
}

impl Default for FemParams {
    /// The material point method's solver settings, eight boundary elements across the smallest
    /// grain, contacts held on both sides.
    fn default() -> Self {
        Self { solver: SoftSolver::default(), elements_per_diameter: 8.0, symmetric_contact: true }
    }
}

/// The registry's line for the finite element method.
pub const ENTRY: MethodEntry = MethodEntry { name: "fem", parse, defaults: || Box::new(FemParams::default()) };

fn parse(object: Option<&serde_json::Value>, c: &mut Checker) -> Option<Box<dyn Method>> {
    let s: FemParamsSpec = read_spec(c, object)?;
    Some(Box::new(check(c, &s)))
}

/// Checks the parameters a scene gives, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &FemParamsSpec) -> FemParams {
    let mut p = FemParams { solver: crate::methods::soft::params::check(c, &soft_solver_spec!(s)), ..FemParams::default() };
    if let Some(b) = s.symmetric_contact {
        p.symmetric_contact = b;
    }
    if let Some(n) = s.elements_per_diameter {
        if !(n.is_finite() && n >= 2.0) {
            c.fail(
                "method.elements_per_diameter",
                format!("must be >= 2 (an element larger than half the smallest grain cannot tell its shape), got {n}"),
            );
        } else {
            p.elements_per_diameter = n;
        }
    }
    p
}
