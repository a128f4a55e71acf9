//! The parameters of contact dynamics (`"method": "cd"`; Moreau–Jean, docs/physics.md §3): what
//! a scene may set, their defaults and checks, and what the method requires of a scene.

use serde::{Deserialize, Serialize};

use crate::error::EngineError;
use crate::math::Real;
use crate::methods::method::{check_threads, read_spec, Method, MethodEntry};
use crate::run::Simulation;
use crate::scene::{Checker, Scene};

/// Parameters of the `cd` method as written in a scene (all optional).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CdParamsSpec {
    /// Always `"cd"`.
    pub kind: String,
    /// Time step, s. Default: the time the reference velocity takes to cover
    /// `max_displacement` of the smallest diameter.
    #[serde(default)]
    pub time_step: Option<f64>,
    /// Largest expected displacement per step as a fraction of the smallest diameter, for the
    /// default time step. Default 0.02.
    #[serde(default)]
    pub max_displacement: Option<f64>,
    /// Fastest expected motion, m/s, for the default time step. Default from the scene (as for
    /// DEM: initial speeds, free fall across the box, wall speeds, at least 0.1 m/s).
    #[serde(default)]
    pub reference_velocity: Option<f64>,
    /// Implicitness of the theta-scheme in [0.5, 1]. Default 0.5.
    #[serde(default)]
    pub theta: Option<f64>,
    /// Tolerance of the NLGS criterion on the relative change of the impulses over a sweep.
    /// Default 1e-3.
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// Tolerance of the NLGS criterion on the mean violation of the Signorini condition, as a
    /// fraction of the mean diameter per step. Default 1e-6 in 2D, 1e-5 in 3D.
    #[serde(default)]
    pub violation_tolerance: Option<f64>,
    /// Largest number of NLGS sweeps per step. Default 5000.
    #[serde(default)]
    pub max_iterations: Option<u32>,
    /// Violation bound during loading (an experiment's stages that do not run until
    /// equilibrium, a plain scene that imposes a motion), same units as `violation_tolerance`.
    /// Default 1e-4.
    #[serde(default)]
    pub loading_violation_tolerance: Option<f64>,
    /// Relaxation of the NLGS updates, in (0, 1]. Default 1.
    #[serde(default)]
    pub relaxation: Option<f64>,
    /// Largest momentum factor of the accelerated NLGS sweep, in [0, 1) (0: plain
    /// Gauss-Seidel). Default 0.9.
    #[serde(default)]
    pub acceleration: Option<f64>,
    /// Order of the NLGS sweep: `serial`, `coloured` (parallel) or `auto`. Default `auto`.
    #[serde(default)]
    pub sweep: Option<Sweep>,
    /// Largest allowed interpenetration as a fraction of the smaller radius. Default 0.05.
    #[serde(default)]
    pub max_interpenetration: Option<f64>,
    /// Interpenetration left alone by the gap restoration, as a fraction of the smaller radius.
    /// Default 0.01.
    #[serde(default)]
    pub slop: Option<f64>,
    /// Verlet skin as a fraction of the smallest diameter. Default 0.3.
    #[serde(default)]
    pub skin: Option<f64>,
    /// Threads (0 or absent: rayon's global pool).
    #[serde(default)]
    pub threads: Option<usize>,
}

/// Parameters of contact dynamics, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct CdParams {
    /// Time step, s; `None`: the reference velocity covers `max_displacement` of the smallest
    /// diameter in one step.
    pub time_step: Option<Real>,
    /// Largest expected displacement per step / smallest diameter (default time step).
    pub max_displacement: Real,
    /// Fastest expected motion, m/s (`None`: estimated from the scene).
    pub reference_velocity: Option<Real>,
    /// Implicitness of the theta-scheme, in [0.5, 1].
    pub theta: Real,
    /// Tolerance of the NLGS criterion on the relative change of the impulses over a sweep.
    pub tolerance: Real,
    /// Tolerance of the NLGS criterion on the mean violation (fraction of the mean diameter per
    /// step); `None`: [`CdParams::violation_bound`]'s default for the dimension.
    pub violation_tolerance: Option<Real>,
    /// Largest number of NLGS sweeps per step.
    pub max_iterations: u32,
    /// Violation bound during loading (an experiment's stages that do not run until equilibrium,
    /// a plain scene that imposes a motion), same units as `violation_tolerance`. Looser than
    /// the bound of a packing at rest: from a 400-disk preparation a biaxial loading at 1e-6
    /// stalled NLGS, at 1e-4 it ran in about 50 sweeps a step and matched DEM
    /// (docs/methods/cd.md).
    pub loading_violation_tolerance: Real,
    /// Relaxation of the NLGS updates, in (0, 1] ([`crate::nscd::Convergence::relaxation`]).
    pub relaxation: Real,
    /// Largest momentum factor of the accelerated NLGS sweep, in [0, 1) (0: plain Gauss-Seidel;
    /// [`crate::nscd::Convergence::acceleration`]).
    pub acceleration: Real,
    /// Order of the NLGS sweep.
    pub sweep: Sweep,
    /// Largest allowed interpenetration / smaller radius.
    pub max_interpenetration: Real,
    /// Interpenetration the gap restoration leaves alone / smaller radius ([`super::SLOP`] by
    /// default).
    pub slop: Real,
    /// Verlet skin as a fraction of the smallest diameter.
    pub skin: Real,
    /// Threads; 0 = rayon's global pool.
    pub threads: usize,
}

impl CdParams {
    /// The bound on the mean violation of a packing at rest in `dimension`: `violation_tolerance`,
    /// or by default 1e-6 in 2D and 1e-5 in 3D. Measured: at 1e-5 the 400-disk biaxial
    /// preparation (`sable bench biaxial`) crept for 20,000-24,000 steps before it came to rest
    /// (4,000-7,000 at 1e-6); on frictional sphere packings Gauss-Seidel's violation decays
    /// slowly (the triaxial preparation of `scenes/triaxial_3d.json`: 1.0e-5 after 250 sweeps,
    /// 2.0e-6 after 2,250, 1.07e-6 after 4,750), so that 1e-6 spends the budget, while at 1e-5
    /// that preparation came to rest in 2,000 steps and the isotropic ones agree with DEM.
    pub fn violation_bound(&self, dimension: usize) -> Real {
        self.violation_tolerance.unwrap_or(if dimension == 3 { 1e-5 } else { 1e-6 })
    }
}

impl Default for CdParams {
    fn default() -> Self {
        Self {
            time_step: None,
            max_displacement: 0.02,
            reference_velocity: None,
            theta: 0.5,
            tolerance: 1e-3,
            violation_tolerance: None,
            max_iterations: 5000,
            loading_violation_tolerance: 1e-4,
            relaxation: 1.0,
            acceleration: 0.9,
            sweep: Sweep::Auto,
            max_interpenetration: 0.05,
            slop: super::SLOP,
            skin: 0.3,
            threads: 0,
        }
    }
}

/// Order of the contact-dynamics sweep ([`crate::nscd::colour`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sweep {
    /// `coloured` from [`Sweep::PARALLEL_FROM`] contacts, `serial` below.
    #[default]
    Auto,
    /// The contacts in detection order, on one thread.
    Serial,
    /// The contacts coloured so that none of a colour share a body, each colour swept in
    /// parallel.
    Coloured,
}

impl Sweep {
    /// Contacts from which `auto` colours: below, a colour holds too few contacts to share
    /// between threads.
    pub const PARALLEL_FROM: usize = 4096;

    /// Whether a step with `contacts` contacts sweeps in colours.
    pub fn coloured(self, contacts: usize) -> bool {
        match self {
            Sweep::Auto => contacts >= Self::PARALLEL_FROM,
            Sweep::Serial => false,
            Sweep::Coloured => true,
        }
    }
}

/// The solver's default tolerance (relative change of the impulses) in a scene with
/// aggregates. Their primaries carry the attraction's internal forces, balanced by their
/// contacts and far larger than what loads a grain: at the usual 1e-3 the solver's leftover
/// kicks keep an aggregate jittering and creeping; at 1e-6 it stays still, for a few tens of
/// sweeps a step (docs/methods/bpm.md, "Design measurements").
pub const AGGREGATE_TOLERANCE: Real = 1e-6;

/// The registry's line for contact dynamics.
pub const ENTRY: MethodEntry = MethodEntry { name: "cd", parse, defaults: || Box::new(CdParams::default()), newton: false };

fn parse(object: Option<&serde_json::Value>, c: &mut Checker) -> Option<Box<dyn Method>> {
    let s: CdParamsSpec = read_spec(c, object)?;
    Some(Box::new(check(c, &s)))
}

/// Checks the parameters a scene gives, every bad one named under `method.`.
pub fn check(c: &mut Checker, s: &CdParamsSpec) -> CdParams {
    let mut p = CdParams::default();
    check_step(c, s, &mut p);
    check_solver(c, s, &mut p);
    check_contacts(c, s, &mut p);
    if let Some(t) = s.threads {
        p.threads = check_threads(c, t);
    }
    p
}

/// Checks how the time step is set: fixed, or by a largest displacement per step and a
/// reference velocity.
fn check_step(c: &mut Checker, s: &CdParamsSpec, p: &mut CdParams) {
    if let Some(dt) = s.time_step {
        if c.positive("method.time_step", dt) {
            p.time_step = Some(dt);
        }
    }
    if let Some(f) = s.max_displacement {
        if s.time_step.is_some() {
            c.fail("method.max_displacement", "give either time_step or max_displacement, not both");
        } else if c.within("method.max_displacement", f, 1e-6, 0.5) {
            p.max_displacement = f;
        }
    }
    if let Some(v) = s.reference_velocity {
        if c.positive("method.reference_velocity", v) {
            p.reference_velocity = Some(v);
        }
    }
}

/// Checks the contact solver's parameters: θ, tolerances, iterations, sweep, relaxation and
/// acceleration.
fn check_solver(c: &mut Checker, s: &CdParamsSpec, p: &mut CdParams) {
    if let Some(t) = s.theta {
        if c.within("method.theta", t, 0.5, 1.0) {
            p.theta = t;
        }
    }
    if let Some(t) = s.tolerance {
        if c.within("method.tolerance", t, 1e-14, 0.1) {
            p.tolerance = t;
        }
    }
    if let Some(t) = s.violation_tolerance {
        if c.within("method.violation_tolerance", t, 1e-14, 0.1) {
            p.violation_tolerance = Some(t);
        }
    }
    if let Some(n) = s.max_iterations {
        if !(1..=1_000_000).contains(&n) {
            c.fail("method.max_iterations", format!("must be between 1 and 1000000, got {n}"));
        } else {
            p.max_iterations = n;
        }
    }
    if let Some(t) = s.loading_violation_tolerance {
        if c.within("method.loading_violation_tolerance", t, 1e-14, 0.1) {
            p.loading_violation_tolerance = t;
        }
    }
    if let Some(w) = s.sweep {
        p.sweep = w;
    }
    if let Some(w) = s.relaxation {
        if !(w > 0.0 && w <= 1.0) {
            c.fail("method.relaxation", format!("must be in (0, 1], got {w}"));
        } else {
            p.relaxation = w;
        }
    }
    if let Some(a) = s.acceleration {
        if !(0.0..1.0).contains(&a) {
            c.fail("method.acceleration", format!("must be in [0, 1), got {a}"));
        } else {
            p.acceleration = a;
        }
    }
}

/// Checks the contact geometry's parameters: the interpenetration allowed, the slop and the
/// neighbour skin.
fn check_contacts(c: &mut Checker, s: &CdParamsSpec, p: &mut CdParams) {
    if let Some(o) = s.max_interpenetration {
        if c.within("method.max_interpenetration", o, 1e-6, 1.0) {
            p.max_interpenetration = o;
        }
    }
    if let Some(slop) = s.slop {
        if c.within("method.slop", slop, 0.0, 1.0) {
            if slop < p.max_interpenetration {
                p.slop = slop;
            } else {
                c.fail("method.slop", format!("must be below method.max_interpenetration ({}), got {slop}", p.max_interpenetration));
            }
        }
    }
    if let Some(skin) = s.skin {
        if c.within("method.skin", skin, 1e-3, 2.0) {
            p.skin = skin;
        }
    }
}

impl Method for CdParams {
    /// Rigid grains only; with aggregates of bonded primaries, the tighter
    /// [`AGGREGATE_TOLERANCE`] unless the scene sets `method.tolerance`.
    fn fit(&mut self, scene: &Scene, given: &serde_json::Value, c: &mut Checker) {
        crate::methods::fit::rigid_grains(scene, "cd", c);
        if crate::methods::fit::aggregates(scene).is_some() && given.get("tolerance").is_none() {
            self.tolerance = AGGREGATE_TOLERANCE;
        }
    }

    fn build(&self, scene: &Scene) -> Result<Box<dyn Simulation>, EngineError> {
        Ok(Box::new(super::Cd::new(scene, self)?))
    }

    crate::method_common!("cd", threads);
}
