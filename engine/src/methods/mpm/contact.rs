//! Contact between grains and with walls, measured between the grains' outlines
//! ([`super::outline`]) and acting through their own nodal fields, solved by the shared
//! contact solver ([`crate::nscd`]): the multi-field method of the sources (
//! Nezamabadi 2020, §1.2.2; Nezamabadi et al., Comput. Phys. Commun. 237, 17, 2019) — each grain its own
//! field, so that grains touch, slide and part by contact, not through a shared grid.
//!
//! **Candidates.** Every vertex of a grain's outline within a cell of a wall, and every vertex
//! of a grain's outline within a cell of the outline of a grain of higher index (the pairs
//! whose outlines' boxes come within a cell). By default one side only for elastic grains:
//! between two convex outlines the other grain's vertices can then cross a segment by at most
//! the sagitta of a chord a cell long, further once outlines are dented. Both sides
//! ([`Sides::Both`], `symmetric_contact`) remove that overlap for 2.6 times the time; they are
//! the default when a grain's law is plastic ([`crate::methods::mpm::MpmParams::symmetric_contact`]),
//! because plastic grains keep their dents and, one-sided, their outlines overlap until the
//! contact solves break down (docs/methods/mpm.md, "Design measurements").
//!
//! **Gap and normal.** From the vertex to the nearest segment of the other outline, along that
//! segment's outward normal (negative inside), or to the wall's plane; the normal points from
//! the second member towards the first.
//!
//! **How a contact moves.** A vertex `x_p + F_p o` moves over a step by
//! `Σ u_i (N_i(x_p) + ∇N_i(x_p) · F_p o)` for the nodal displacements `u_i` — its point's
//! displacement and the change of its `F`, as the points are moved — so the contact's
//! velocity is `Σ w_i v_i` with those weights (on the other side the place between the
//! segment's two vertices, their weights blended), and its impulse reaches the nodes by the
//! same weights ([`Support`]): the step keeps the gap it predicts, and the contact does no
//! work its kinematics do not see. The price is the outer layer: the traction reaches the
//! grid through the outer points' fields extrapolated linearly to the outline, which with
//! quadratic splines loads the outer nodes a sixteenth more than the splines' values there,
//! and the outer points take more of the strain than the bulk, so that a squeezed block's wall
//! force comes out a few percent low, less on a finer grid. The outline is there because the
//! points alone do not hold grains apart: contacts on the nodes' velocities (the sources' nodal
//! contact) let the point clouds pass through each other and the walls while the nodes stay
//! apart, and a gap measured from the points then in a node column jumps as points enter and
//! leave the column, which a bound that never pushes apart ratchets into overlap.
//!
//! **Drift.** The contact's prediction is linear in the step's displacements. The outlines'
//! gap at the step's end also holds what is not: the other outline turning and sliding under
//! the vertex (grains spin fast as a packing rearranges, and the flat faces their neighbours
//! pressed into them come round under their vertices). At the first
//! `system::step::DRIFT_ITERATIONS` Newton iterates every outline is moved where the iterate
//! takes it and each contact's gap measured anew; its difference from the linear prediction,
//! the drift, joins the contact's target. Measured at the first iterates only: at every
//! iterate the drift lowers the overlap further, but Newton then slows and fails its budget on
//! dense packings. The drift must stay second order, so the contacts act at the outline's
//! vertices, not at the outer points' centres, where the drift held most of the motion and
//! changed after the iterates it was measured at (docs/methods/mpm.md).
//!
//! The contacts' types, the Signorini condition and the Delassus operator are those of every
//! soft-grain method ([`crate::methods::soft::contact`]).

use super::banded::dot;
use super::field::Field;
use crate::math::Real;

pub use crate::methods::soft::contact::{
    candidates, enter, measure_drifts, solve, wall_impulses, Against, Candidate, Entry, GrainContacts, Metric, Other, Problem, Sides,
    Support, VertexContact, Wall, Warm, FORCING, SUPPORT_NODES,
};

/// Computes a grain's [`GrainContacts::inverse`] from its field's factorised matrix `A = L Lᵀ`: for each unknown of
/// each sample the column `y = L⁻¹ b`, `b` the sample's weights on that component
/// (forward substitution from its first row), then the entries are the dot products
/// `y_r · y_s`. Measured on a dense 60-grain compaction, full solves (one per unknown)
/// took 45% of the run.
pub fn invert(side: &mut GrainContacts, field: &Field) {
    let m = 2 * side.samples.len();
    let size = 2 * field.nodes();
    side.inverse.clear();
    side.inverse.resize(m * m, 0.0);
    let (ys, at) = (&mut side.work, &mut side.offsets);
    ys.clear();
    at.clear();
    let mut b = [(0usize, 0.0 as Real); SUPPORT_NODES];
    for col in 0..m {
        let (s, d) = (col / 2, col % 2);
        let support = &side.samples[s];
        for (e, (k, w)) in b.iter_mut().zip(support.iter()) {
            *e = (2 * k + d, w);
        }
        let offset = ys.len();
        let r = field.matrix.append_forward(&b[..support.len as usize], ys);
        at.push((offset, r));
    }
    for x in 0..m {
        let (ox, r) = at[x];
        for y in 0..=x {
            let (oy, s) = at[y];
            let from = r.max(s);
            let dot = dot(&ys[ox + from - r..ox + size - r], &ys[oy + from - s..oy + size - s]);
            side.inverse[x * m + y] = dot;
            side.inverse[y * m + x] = dot;
        }
    }
}
