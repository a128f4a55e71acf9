//! Contact between grains and with walls, measured between the grains' outlines
//! ([`super::outline`]) and acting through their own nodal fields, solved by the shared
//! contact solver ([`crate::nscd`]): the multi-field method of the sources (
//! Nezamabadi 2020, §1.2.2; Nezamabadi et al., Comput. Phys. Commun. 237, 17, 2019) — each grain its own
//! field, so that grains touch, slide and part by contact, not through a shared grid.
//!
//! **Candidates.** Every vertex of a grain's outline within a cell of a wall, and every vertex
//! of a grain's outline within a cell of the outline of a grain of higher index (the pairs
//! whose outlines' boxes come within a cell). By default one side only: between two convex
//! outlines the other grain's vertices can then cross a segment by at most the sagitta of a
//! chord a cell long, further once outlines are dented; both sides with
//! [`Sides::Both`] (`symmetric_contact`), which removes that overlap for 2.6 times the time
//! (measured in [`crate::methods::soft::contact`]). Plastic grains keep their dents, and
//! one-sided their outlines overlapped by 0.94% of the box and the contact solves broke down
//! (60 grains, H = 0, Φ 0.91), where both sides reached Φ 0.968: both sides are the default
//! when a grain's law is plastic ([`crate::scene::MpmParams::symmetric_contact`]).
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
//! and the outer points take more of the strain than the bulk (a squeezed block's wall force
//! 4.7% low at 10 cells, 3.2% at 20; an elastic disk's Hertz half-width 2.6% narrow at 20
//! cells across the radius, settling about 4.5% narrow, as a meshed disk does: Hertz's
//! small-strain limit at a / R = 0.16). Measured before, with the same
//! solver:
//! - contacts on the nodes' velocities (the sources' nodal contact): the point clouds pass
//!   through each other and the walls while the nodes stay apart; 16 disks pressed to 100 kPa
//!   reached Φ = 0.97 at 22 kPa with 7% of the box covered twice or beyond a wall;
//! - one contact per node column, acting at the centre of the column's outermost point, its
//!   gap from the points' extents and their growth over the step as the target: a squeezed
//!   block within 0.8%, but pressed grains overlapped — 2.6% of the box at Φ 0.90 on the
//!   12-grain CI compaction, 3.3% at Φ 0.937 on the 300-grain one, most of the densification
//!   past Φ 0.9 — because the gap, measured anew each step from the points then in the
//!   column, jumped both ways as points entered and left it, and a bound that never pushes
//!   apart kept every jump shut (a ratchet; summed over the CI run, 0.054 m shut and 0.072 m
//!   born overlapping). Smoothed measures of the same columns (a half-density level, the
//!   envelope of the points' caps, the points as ellipses) gave 3.6 to 4.3%; pushing overlaps
//!   apart at a fiftieth a step created energy at full size (7 J/m against 23 stored).
//!
//! **Drift.** The contact's prediction is linear in the step's displacements. The outlines'
//! gap at the step's end also holds what is not: the other outline turning and sliding under
//! the vertex (a grain of the CI compaction spins up to 4,000 rad/s as the packing rearranges,
//! 0.2 rad a step: the flat faces its neighbours pressed into it come round under their
//! vertices). At the first `system::DRIFT_ITERATIONS` Newton iterates every outline
//! is moved where the iterate takes it and each contact's gap measured anew; its difference
//! from the linear prediction, the drift, joins the contact's target. Measured on the CI
//! compaction at Φ 0.90: 3.2% of the box covered twice without the drift, 0.38% with it; on the
//! 300-grain compaction 1.2% at Φ 0.93 (0.66% at Φ 0.88). Measured at every iterate instead,
//! the drift gave 0.24% on the CI compaction and 0.12% on the 300-grain one at Φ 0.88, but its
//! Newton iterations slowed (28 to 84 a step) and failed their budget there at a sixteenth of
//! the step (step 4,513). Doing a step again in halves whenever it left a contact 2% of a cell
//! deeper than allowed gave 0.25% on the CI compaction, but split the 300-grain compaction's
//! dense steps down to a sixteenth (Φ 0.84 after 11 minutes). The drift must be second order: with the contacts' impulses and velocities at the outer
//! points' centres (the outline's offset from them left to the drift, or in the velocity
//! only), the drift held most of the motion, changed after the iterates it was measured at,
//! and the CI compaction reached 3.3 to 3.6% overlap.
//!
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
