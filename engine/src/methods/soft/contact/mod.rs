//! Contacts between soft grains' outlines and with walls, each grain acting through its own
//! nodes (the multi-field method of the sources, Nezamabadi 2020, §1.2.2–1.2.3), solved by the
//! shared contact solver ([`crate::nscd`]). How a method finds its contacts and which of its
//! nodes carry each one ([`Support`]) is its own ([`crate::methods::mpm::contact`],
//! [`crate::methods::fem`]); what they are once found is here.
//!
//! **Signorini condition.** On the relative normal velocity at the step's end:
//! `U_n >= (−max(gap, 0) − drift) / h`: a contact with a positive gap may close it within the
//! step and no more, one that overlaps may not overlap more (no restitution: grains rebound by
//! their elasticity). A negative drift (the outlines moved closer than the linear prediction)
//! makes the target positive: the contact then pushes its grains apart along the normal of the
//! step's start, and that push does work on the nodes although the true gap does not open.
//! The target is not capped at zero: capping it removes that work but leaves the outlines
//! overlapping several times more; holding both sides (below) removes most of the pushes.
//!
//! **Sides.** With one side held ([`Sides::One`]) only the vertices of the grain of lower index
//! are held outside the other's outline, so the other's vertices enter it, the first grain's
//! vertices then sit in the dents they left, and the contacts that push them out do work: with
//! meshed grains, more than the walls do, and the dissipated energy falls below zero. With both
//! grains' vertices held ([`Sides::Both`]) neither outline's vertices enter the other, and the
//! dissipated energy stays positive. Both is `fem`'s default. `mpm` keeps one side by default
//! for elastic grains, whose pushes and overlap are small and for which both sides cost 2.6
//! times the time; for plastic grains both sides are its default
//! ([`crate::methods::mpm::MpmParams::symmetric_contact`]). The measurements are in docs/methods/fem.md
//! and docs/methods/mpm.md ("Design measurements").
//!
//! **Criterion.** Where two outlines lie flat on each other the two sets of contacts are
//! redundant: an impulse moved from one grain's vertex to the other's nearby changes no node's
//! force, so the impulses are not unique, and a change measured on them stalls while the
//! velocities have converged. The solves therefore measure a sweep's change in the grains'
//! velocities, in the units of the correction of the Newton iteration they serve:
//! `√(ΔPᵀ W ΔP / M)` for the impulses' change `ΔP` over the sweep, the Delassus operator
//! `W = H A⁻¹ Hᵀ` and the grains' mass `M` (an upper bound of the mass-weighted root mean
//! square of the nodes' velocity change, since `A ≥ M`), relative to Newton's velocity scale.
//! [`FORCING`] then asks each solve for a hundredth of Newton's last correction in the same
//! units. Measured relative to the impulses' own size instead, the tolerance meant nothing in
//! Newton's units: the solves stopped after one sweep, and Newton's corrections, each the change
//! of that one sweep, stalled above Newton's tolerance.
//!
//! **Delassus operator.** A contact's velocity answers an impulse through its grain's Newton
//! matrix: `u = u_free + Hᵀ A⁻¹ H P`, `H` its weights. For each grain the block of
//! `Hᵀ A⁻¹ H` between its contacts' samples is computed with its factorised matrix, so that
//! every impulse a contact changes updates the velocities of all the samples of its grains at
//! once (the exact coupling through the grain's stiffness, not the nodes' mass alone). The
//! solver's local problems see the diagonal of each contact's block in its frame, and its
//! sweeps converge to the solution of the full coupled problem (each visit reads the
//! velocities the other contacts left).
//!
//! **Pairs.** The contacts of one pair of grains (or of one grain with the walls), however
//! many, take their turn together: their normal impulses are solved exactly as one small
//! complementarity problem with every other impulse frozen ([`super::block`]), then, with
//! friction, their tangential impulses exactly as one box-constrained problem within their new
//! Coulomb bounds ([`super::block::boxed`]). Gauss-Seidel one contact at a time crawls along
//! the pair's own slow directions: where two boundaries lie flat on each other, moving impulse
//! from one grain's nodes to the other's nearby ones, or between the nearly parallel normals of
//! a vertex in a dent's reflex corner, changes the velocities by almost nothing, and past
//! jamming most of the error such a solve leaves lies along those directions; solved pair by
//! pair, they converge in a few sweeps (docs/methods/fem.md). The tangential impulses of the
//! same contacts have the same slow directions.
//!
//! **Modules.** [`records`]: walls, contacts, the nodes that carry them and the walls'
//! impulses; [`grain_contacts`]: a grain's side of the problem (its samples, their block of
//! `A⁻¹`, their velocities); [`candidates`](mod@candidates): which vertex may touch which
//! outline or wall; [`warm`]: a step's contacts entered, warm-started from the last solve's
//! impulses; [`drift`]: how far the outlines move from the contacts' linear prediction;
//! [`solve`](mod@solve): the contact problem of a Newton iteration and its sweeps.

pub mod candidates;
pub mod drift;
pub mod grain_contacts;
pub mod records;
pub mod solve;
pub mod warm;

pub use candidates::{candidates, Candidate, Sides, REFLEX_TURN};
pub use drift::measure_drifts;
pub use grain_contacts::GrainContacts;
pub use records::{wall_impulses, Other, Support, VertexContact, Wall, SUPPORT_NODES};
pub use solve::{solve, Metric, Problem, FORCING};
pub use warm::{enter, Against, Entry, Warm};
