//! Errors of the engine: invalid scenes and numerical failures.

use crate::scene::Violation;

/// Why a running simulation was judged unstable.
#[derive(Debug, Clone, PartialEq)]
pub enum InstabilityCause {
    /// A position, velocity or force became NaN or infinite.
    NonFinite {
        /// Index of the first particle found with a non-finite value.
        particle: usize,
    },
    /// Two bodies overlap by more than the allowed fraction of the smaller radius.
    Overlap {
        /// Largest overlap found divided by the smaller radius of the pair.
        fraction: f64,
        /// The allowed fraction.
        limit: f64,
    },
    /// The contact solver did not meet its convergence criterion within its iteration budget
    /// (contact dynamics).
    SolverBudget {
        /// Sweeps done (the budget).
        iterations: u32,
        /// Relative change over the last sweep (of the impulses; for soft grains, of the
        /// grains' velocities the impulses give).
        change: f64,
        /// Mean violation after the last sweep (fraction of the mean diameter per step).
        violation: f64,
        /// The tolerance on the change.
        tolerance: f64,
        /// The tolerance on the violation.
        violation_tolerance: f64,
        /// Largest violation after the last sweep (fraction of the contact's radius per step).
        worst: f64,
        /// The tolerance on the largest violation.
        worst_tolerance: f64,
    },
    /// The Newton iterations of an implicit step did not converge within their budget.
    NewtonBudget {
        /// Iterations done: the budget, or fewer when the correction shrank too slowly to reach
        /// the tolerance within it.
        iterations: u32,
        /// Size of the last velocity correction relative to the velocity scale.
        correction: f64,
        /// Its tolerance.
        tolerance: f64,
        /// The grain whose correction was the largest at the last iteration, when known.
        grain: Option<usize>,
        /// That grain's matrix was not Newton's own but damped to make it definite (`mpm`:
        /// the iterations then converge linearly at best).
        damped: bool,
    },
    /// A material point of a deformable grain turned inside out (`J = det F <= 0`) or left the
    /// domain its constitutive law is defined on.
    Inverted {
        /// Grain index.
        grain: usize,
        /// Point index within the whole set of points.
        point: usize,
        /// `det F` reached.
        jacobian: f64,
    },
    /// An element of a meshed grain turned inside out (`det F <= 0` at one of its integration
    /// points or its centre) or left the domain its constitutive law is defined on.
    InvertedElement {
        /// Grain index.
        grain: usize,
        /// Element index within the grain's mesh.
        element: usize,
        /// `det F` reached.
        jacobian: f64,
    },
    /// A material point left the background grid.
    LeftGrid {
        /// Grain index.
        grain: usize,
        /// Point index within the whole set of points.
        point: usize,
    },
    /// A grain's Newton matrix `M + (θh)² K` lost positive definiteness (a geometric stiffness
    /// stronger than the mass term at this step).
    NotPositiveDefinite {
        /// Grain index.
        grain: usize,
    },
    /// The contacts between soft grains moved over a step farther than their linearisation
    /// follows: at the iterate Newton converged to, the gaps measured anew between the moved
    /// outlines differ from those the contacts were solved with by more than the limit.
    ContactDrift {
        /// Largest difference found, m.
        drift: f64,
        /// The limit, m.
        limit: f64,
    },
    /// Mechanical energy grew more than the work put in by walls and gravity allows.
    EnergyGrowth {
        /// Energy gained beyond the work put in, J.
        excess: f64,
        /// Reference energy scale the excess was compared with, J.
        scale: f64,
        /// The part of the mechanical energy that grew the most since the budget started:
        /// `kinetic`, `elastic` (the contacts' springs), `gravitational` or `capillary`.
        part: &'static str,
        /// How much that part grew, J.
        part_gain: f64,
    },
}

impl InstabilityCause {
    /// The cause's name, without its numbers (`"contact_drift"`, `"newton_budget"`, ...): what
    /// counts of failures are kept under.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::NonFinite { .. } => "non_finite",
            Self::Overlap { .. } => "overlap",
            Self::SolverBudget { .. } => "solver_budget",
            Self::NewtonBudget { .. } => "newton_budget",
            Self::Inverted { .. } => "inverted",
            Self::InvertedElement { .. } => "inverted_element",
            Self::LeftGrid { .. } => "left_grid",
            Self::NotPositiveDefinite { .. } => "not_positive_definite",
            Self::ContactDrift { .. } => "contact_drift",
            Self::EnergyGrowth { .. } => "energy_growth",
        }
    }
}

impl std::fmt::Display for InstabilityCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NonFinite { particle } => {
                write!(f, "non-finite position, velocity or force on particle {particle}")
            }
            Self::Overlap { fraction, limit } => {
                write!(f, "overlap reached {:.1}% of the smaller radius (limit {:.1}%)", fraction * 100.0, limit * 100.0)
            }
            Self::SolverBudget { iterations, change, violation, tolerance, violation_tolerance, worst, worst_tolerance } => write!(
                f,
                "the contact solver did not converge in {iterations} iterations (relative change over the last sweep {change:.2e}, tolerance {tolerance:.1e}; mean violation {violation:.2e}, tolerance {violation_tolerance:.1e}; largest violation {worst:.2e} of the radius per step, tolerance {worst_tolerance:.1e})"
            ),
            Self::NewtonBudget { iterations, correction, tolerance, grain, damped } => {
                write!(
                    f,
                    "the Newton iterations did not converge in {iterations} iterations (last velocity correction {correction:.2e} of the velocity scale, tolerance {tolerance:.1e}"
                )?;
                match (grain, damped) {
                    (Some(g), true) => write!(f, "; the largest is grain {g}'s, whose matrix was damped to make it definite)"),
                    (Some(g), false) => write!(f, "; the largest is grain {g}'s)"),
                    (None, _) => write!(f, ")"),
                }
            }
            Self::Inverted { grain, point, jacobian } => {
                write!(f, "material point {point} of grain {grain} inverted (det F = {jacobian:.3e})")
            }
            Self::InvertedElement { grain, element, jacobian } => {
                write!(f, "element {element} of grain {grain} inverted (det F = {jacobian:.3e})")
            }
            Self::LeftGrid { grain, point } => write!(f, "material point {point} of grain {grain} left the background grid"),
            Self::NotPositiveDefinite { grain } => {
                write!(f, "the Newton matrix of grain {grain} is not positive definite (its geometric stiffness outweighs its mass at this step)")
            }
            Self::ContactDrift { drift, limit } => write!(
                f,
                "the contacts' geometry moved over the step {drift:.2e} m beyond their linearisation (limit {limit:.2e} m)"
            ),
            Self::EnergyGrowth { excess, scale, part, part_gain } => write!(
                f,
                "mechanical energy grew by {excess:.3e} J beyond the work put in (energy scale {scale:.3e} J); the {part} energy grew the most, by {part_gain:.3e} J"
            ),
        }
    }
}

/// Every failure the engine reports.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// The scene breaks one or more rules; every violation is listed.
    #[error("invalid scene: {}", crate::scene::format_violations(.0))]
    InvalidScene(Vec<Violation>),
    /// The scene is valid but could not be built (for example, particles do not fit).
    #[error("cannot build scene: {field}: {reason}")]
    Build {
        /// Path of the field responsible.
        field: String,
        /// What went wrong and what to change.
        reason: String,
    },
    /// The integration became unstable; results up to `step` are valid, nothing after.
    #[error("unstable at step {step} (t = {time:.6e} s): {cause}; {suggestion}")]
    Unstable {
        /// Step at which the check failed.
        step: u64,
        /// Simulated time at that step, s.
        time: f64,
        /// What was detected.
        cause: InstabilityCause,
        /// What to change in the scene.
        suggestion: String,
    },
    /// A stage that runs until equilibrium reached its step or time limit first.
    #[error(
        "stage '{stage}' did not reach equilibrium within its limit (step {step}): kinetic/reference energy {kinetic_ratio:.2e} (needs < {kinetic_limit:.1e}), unbalanced force {unbalanced_force:.2e} (needs < {unbalanced_limit:.1e}), stress error {stress_error:.2e} (needs < {stress_limit:.1e}); raise the stage's max_steps, loosen its equilibrium criterion, or add local damping"
    )]
    NotConverged {
        /// Stage name.
        stage: String,
        /// Step at which the limit was reached.
        step: u64,
        /// Kinetic / elastic energy at the last check.
        kinetic_ratio: f64,
        /// Bound on it.
        kinetic_limit: f64,
        /// Unbalanced force ratio at the last check.
        unbalanced_force: f64,
        /// Bound on it.
        unbalanced_limit: f64,
        /// Largest relative error of a stress-controlled boundary at the last check.
        stress_error: f64,
        /// Bound on it.
        stress_limit: f64,
    },
    /// The run was cancelled from outside.
    #[error("cancelled at step {step}")]
    Cancelled {
        /// Step reached when the cancellation was seen.
        step: u64,
    },
}

impl EngineError {
    /// Stable machine-readable code for the error kind.
    pub fn code(&self) -> &'static str {
        match self {
            Self::InvalidScene(_) => "invalid_scene",
            Self::Build { .. } => "build_failed",
            Self::Unstable { .. } => "unstable",
            Self::NotConverged { .. } => "not_converged",
            Self::Cancelled { .. } => "cancelled",
        }
    }
}
