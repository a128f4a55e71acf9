//! Non-smooth contact dynamics (Moreau-Jean; Nezamabadi 2020, §1.1.2; Roux & Chevoir 2005, §2.2.3;
//! docs/physics.md §3): the contact solver that the `"cd"` method uses for rigid grains, kept
//! apart from any one method so that the bonded-particle, MPM-CD and FEM-CD methods can reuse it.
//!
//! - [`frame`]: the local frame of a contact (normal, tangents);
//! - [`local`]: the laws as graphs (velocity Signorini with restitution through the formal
//!   velocity, Coulomb friction, cohesion as a shift of the Signorini graph, rolling resistance)
//!   and their exact local solvers;
//! - [`nlgs`]: the non-linear Gauss-Seidel loop over the contacts of rigid bodies, with warm
//!   start, its convergence criterion and the residual history of the step;
//! - [`colour`]: the parallel sweep, over contacts coloured so that none of a colour share a
//!   body.
//!
//! Units: impulses (percussions) in N·s, velocities in m/s, the Delassus operator in 1/kg.

pub mod colour;
pub mod frame;
pub mod local;
pub mod nlgs;

pub use colour::Colours;
pub use frame::ContactFrame;
pub use local::{Delassus, LocalLaw, Rolling};
pub use nlgs::{Convergence, Iterate, Mobility, Nlgs, NlgsReport, RigidContact, Side};
