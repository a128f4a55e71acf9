//! The parameters of the implicit finite element method (`"method": "fem"`): its mesh beside
//! the solver settings it shares with `mpm` ([`SoftSolver`]).

use crate::math::Real;
use crate::methods::method::{read_spec, Method, MethodEntry};
use crate::methods::soft::params::{soft_params_spec, SoftSolver};
use crate::scene::Checker;

soft_params_spec! {
    /// Parameters of the implicit finite element method with contact dynamics, as written in a
    /// scene (all optional): the settings shared with `mpm`, and these.
    FemParamsSpec, "fem" {
        /// Boundary elements across the smallest grain diameter (>= 2). Default 8.
        elements_per_diameter: Option<f64>,
        /// Contacts between grains hold the nodes of both grains' boundaries outside the other's
        /// (true), or only those of the grain of lower index (false). Default true.
        symmetric_contact: Option<bool>,
    }
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
pub const ENTRY: MethodEntry = MethodEntry { name: "fem", parse, defaults: || Box::new(FemParams::default()), newton: true };

fn parse(object: Option<&serde_json::Value>, c: &mut Checker) -> Option<Box<dyn Method>> {
    let s: FemParamsSpec = read_spec(c, object)?;
    Some(Box::new(check(c, &s)))
}

/// Checks the parameters a scene gives, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &FemParamsSpec) -> FemParams {
    let mut p = FemParams { solver: crate::methods::soft::params::check(c, &s.solver()), ..FemParams::default() };
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
