//! Non-smooth contact dynamics (Moreau-Jean; Nezamabadi 2020, §1.1.2; Roux & Chevoir 2005, §2.2.3;
//! docs/physics.md §3): the contact solver that the `"cd"` method uses for rigid grains, kept
//! apart from any one method so that the bonded-particle, MPM-CD and FEM-CD methods can reuse it.
//!
//! - [`frame`]: the local frame of a contact (normal, tangents);
//! - [`local`]: the laws as graphs (velocity Signorini with restitution through the formal
//!   velocity, Coulomb friction, cohesion as a shift of the Signorini graph, rolling resistance)
//!   and their exact local solvers;
//! - [`contact`]: one contact of a rigid round body, and what its impulse does to its bodies;
//! - [`bodies`]: the bodies' velocities and inverse inertias, and how a boundary may move;
//! - [`sweep`]: one contact's turn in a sweep, the accelerated sweep's momentum, and what a
//!   sweep adds up for the convergence criterion (also for a method's own contact problem);
//! - [`nlgs`]: the non-linear Gauss-Seidel loop over the contacts, with warm start, its
//!   convergence criterion and the residual history of the step;
//! - [`colour`]: the parallel sweep, over contacts coloured so that none of a colour share a
//!   body.
//!
//! Units: impulses (percussions) in N·s, velocities in m/s, the Delassus operator in 1/kg.

pub mod bodies;
pub mod colour;
pub mod contact;
pub mod frame;
pub mod local;
pub mod nlgs;
pub mod sweep;

pub use bodies::{Mobility, RigidBodies};
pub use colour::Colours;
pub use contact::{image_lever, RigidContact, Side};
pub use frame::ContactFrame;
pub use local::{Delassus, LocalLaw, Rolling};
pub use nlgs::{Convergence, Iterate, Nlgs, NlgsReport};
pub use sweep::law_for;
