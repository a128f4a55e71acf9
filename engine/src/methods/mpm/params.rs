//! The parameters of the implicit material point method (`"method": "mpm"`): its grid and
//! points beside the solver settings it shares with `fem` ([`SoftSolver`]).

use crate::math::Real;
use crate::methods::method::{read_spec, Method, MethodEntry};
use crate::methods::soft::params::{soft_params_spec, Dynamics, SoftSolver};
use crate::scene::Checker;

soft_params_spec! {
    /// Parameters of the implicit material point method with contact dynamics, as written in a
    /// scene (all optional): the settings shared with `fem`, and these.
    MpmParamsSpec, "mpm" {
        /// Grid cells across the smallest grain diameter (>= 1). Default 8.
        cells_per_diameter: Option<f64>,
        /// Material points per cell along each axis (>= 1). Default 2.
        points_per_cell: Option<u32>,
        /// FLIP fraction of the points' velocity update, in [0, 1]. Default 0 (PIC).
        flip: Option<f64>,
        /// Contacts between grains hold the vertices of both grains' outlines outside the
        /// other's (true), or only those of the grain of lower index (false). Default: true
        /// when a grain's law is plastic (`elastoplastic`), false otherwise.
        symmetric_contact: Option<bool>,
        /// The ghost penalty on the nodes a grain's points barely reach, as a fraction of the
        /// law's P-wave modulus, in [0, 10]. Default 0 (off).
        ghost_penalty: Option<f64>,
    }
}

/// Parameters of the implicit material point method ([`crate::methods::mpm`]), checked.
#[derive(Debug, Clone, PartialEq)]
pub struct MpmParams {
    /// The step's settings, shared with `fem`.
    pub solver: SoftSolver,
    /// Grid cells across the smallest grain diameter.
    pub cells_per_diameter: Real,
    /// Material points per cell along each axis.
    pub points_per_cell: u32,
    /// FLIP fraction of the points' velocity update, in [0, 1].
    pub flip: Real,
    /// Contacts between grains hold both grains' outlines outside the other's
    /// ([`crate::methods::soft::contact::Sides::Both`]: `Some(true)`), or only the lower
    /// index's (`Some(false)`). `None` (the default): both when a grain's law is plastic
    /// ([`crate::constitutive::ConstitutiveLaw::plastic`]), one side otherwise. One-sided, plastic
    /// outlines dent deeply and the contact solves break down (60 grains, H = 0: 0.94% of the
    /// box covered twice and the solver's budget at Φ 0.91); elastic grains overlap by 0.1% of
    /// the box at Φ 0.9 one-sided, and both sides cost them 2.6 times the time
    /// ([`crate::methods::mpm::contact`]).
    pub symmetric_contact: Option<bool>,
    /// The ghost penalty's stiffness as a fraction of each grain's P-wave modulus
    /// ([`crate::methods::mpm::ghost`]); 0: off. It keeps single grains on fine grids from
    /// inverting under a contact, but raised the outlines' overlap in random compactions with
    /// one-sided contacts (docs/methods/mpm.md, Limits), so it is off unless a scene asks.
    pub ghost_penalty: Real,
}

impl Default for MpmParams {
    /// The settings of the compaction test (`methods::mpm::tests`): backward Euler and PIC for
    /// quasi-static loadings, eight cells and sixteen points across the smallest grain.
    fn default() -> Self {
        Self {
            solver: SoftSolver::default(),
            cells_per_diameter: 8.0,
            points_per_cell: 2,
            flip: 0.0,
            symmetric_contact: None,
            ghost_penalty: 0.0,
        }
    }
}

/// The registry's line for the material point method.
pub const ENTRY: MethodEntry = MethodEntry { name: "mpm", parse, defaults: || Box::new(MpmParams::default()), newton: true };

fn parse(object: Option<&serde_json::Value>, c: &mut Checker) -> Option<Box<dyn Method>> {
    let s: MpmParamsSpec = read_spec(c, object)?;
    Some(Box::new(check(c, &s)))
}

/// Checks the parameters a scene gives, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &MpmParamsSpec) -> MpmParams {
    let mut p = MpmParams {
        solver: crate::methods::soft::params::check(c, &s.solver()),
        symmetric_contact: s.symmetric_contact,
        ..MpmParams::default()
    };
    if let Some(n) = s.cells_per_diameter {
        if !(n.is_finite() && n >= 1.0) {
            c.fail(
                "method.cells_per_diameter",
                format!("must be >= 1 (a grid cell larger than the smallest grain cannot tell its shape), got {n}"),
            );
        } else {
            p.cells_per_diameter = n;
        }
    }
    if let Some(n) = s.points_per_cell {
        if n == 0 || n > 8 {
            c.fail("method.points_per_cell", format!("must be 1 to 8, got {n}"));
        } else {
            p.points_per_cell = n;
        }
    }
    if p.cells_per_diameter * (p.points_per_cell as Real) < 2.0 {
        c.fail(
            "method.points_per_cell",
            format!(
                "gives {} point(s) across the smallest grain (cells_per_diameter × points_per_cell); a grain needs at least 2",
                p.cells_per_diameter * p.points_per_cell as Real
            ),
        );
    }
    if let Some(f) = s.flip {
        if c.within("method.flip", f, 0.0, 1.0) {
            p.flip = f;
        }
        // FLIP carries the points' velocities from step to step, which quasi-static steps do
        // not have.
        match p.solver.dynamics {
            Dynamics::QuasiStatic if f > 0.0 => {
                c.fail("method.flip", "must be 0 with quasi_static dynamics: the steps start from rest and carry no velocity")
            }
            Dynamics::Auto if f > 0.0 => p.solver.dynamics = Dynamics::Inertial,
            _ => {}
        }
    }
    if let Some(g) = s.ghost_penalty {
        if c.within("method.ghost_penalty", g, 0.0, 10.0) {
            p.ghost_penalty = g;
        }
    }
    p
}
