//! The contacts of a step: found between the grains' outlines and with the walls, with their
//! frames, gaps, laws, warm starts and supports on the grains' nodes, and their drifts at an
//! iterate.

use super::System;
use crate::math::Real;
use crate::methods::mpm::contact::{self, candidates, enter, Candidate, Entry, Support, SUPPORT_NODES};
use crate::methods::mpm::field::Scheme;
use crate::methods::mpm::grid::V2;

impl System {
    /// Finds the contacts of the step, their frames, gaps, laws and warm starts, and each
    /// grain's samples: every vertex of a grain's outline within a cell of a wall, and of a
    /// grain's outline within a cell of a grain of higher index's — of any other grain's with
    /// [`Sides::Both`](contact::Sides::Both) — (module documentation of [`contact`]).
    pub(super) fn detect(&mut self) {
        let h = self.grid.h;
        let mut shapes = std::mem::take(&mut self.outlines);
        for (g, at) in shapes.iter_mut().enumerate() {
            self.grains[g].outline.positions_into(&self.points, at);
        }
        for side in &mut self.sides {
            side.clear();
        }
        self.contacts.clear();
        let mut entries = Vec::with_capacity(2 * 9);
        for candidate in candidates(&shapes, &self.walls, h, self.settings.sides) {
            let e = match candidate {
                Candidate::Grain { a, k, b, near, line } => {
                    // Each side moves as its vertices do over the step (module documentation of
                    // [`contact`]): grain `b`'s place between its segment's two.
                    let next = (near.segment + 1) % shapes[b].len();
                    let support = self.vertex_support(a, &[(k, 1.0)], &mut entries);
                    let on_b = self.vertex_support(b, &[(near.segment, 1.0 - near.t), (next, near.t)], &mut entries);
                    let friction = self.pair_friction.unwrap_or_else(|| (self.grains[a].friction * self.grains[b].friction).sqrt());
                    Entry::between_grains(k, shapes[a][k], a, support, b, on_b, &near, line, friction, self.grains[a].radius)
                }
                Candidate::Wall { g, k, w, gap } => {
                    let support = self.vertex_support(g, &[(k, 1.0)], &mut entries);
                    let grain = &self.grains[g];
                    Entry::against_wall(k, shapes[g][k], g, support, w, &self.walls[w], gap, grain.friction, grain.radius)
                }
            };
            enter(&mut self.contacts, &mut self.sides, &self.warm, e);
        }
        self.outlines = shapes;
    }

    /// Sets each contact's drift ([`VertexContact::drift`](contact::VertexContact::drift)) at the
    /// current iterate: every outline moved as the iterate moves its vertices, and the gap
    /// measured anew, against the gap the contact's supports predict.
    pub(super) fn measure_drifts(&mut self, sc: &Scheme) {
        let mut moved = std::mem::take(&mut self.moved);
        let mut entries = Vec::with_capacity(9);
        for (g, (to, from)) in moved.iter_mut().zip(&self.outlines).enumerate() {
            let f = &self.fields[g];
            to.clear();
            // A grain without a contact has no sample: no contact reads its outline.
            if self.sides[g].is_empty() {
                continue;
            }
            to.extend(from.iter().enumerate().map(|(k, x)| {
                entries.clear();
                self.vertex_weights(g, k, 1.0, &mut entries);
                x + entries.iter().map(|&(i, w)| f.displacement(i as usize, sc) * w).sum::<V2>()
            }));
        }
        let fields = &self.fields;
        let displacement = |g: usize, s: &Support| s.iter().map(|(i, w)| fields[g].displacement(i, sc) * w).sum::<V2>();
        contact::measure_drifts(&mut self.contacts, &self.sides, &self.walls, &moved, sc.dt, displacement);
        self.moved = moved;
    }

    /// The support of the place `Σ t_k x_k` between vertices `(k, t_k)` of grain `g`'s outline
    /// (`entries` scratch). The two vertices' points' stencils together hold at most
    /// [`SUPPORT_NODES`] nodes while the points are less than about a cell apart along each
    /// axis; farther apart (a grain stretched that much) the place moves with the nearer
    /// vertex.
    fn vertex_support(&self, g: usize, at: &[(usize, Real)], entries: &mut Vec<(u32, Real)>) -> Support {
        entries.clear();
        for &(k, t) in at {
            self.vertex_weights(g, k, t, entries);
        }
        if let Some(s) = Support::from_entries(entries) {
            return s;
        }
        let k = at.iter().fold((0, Real::NEG_INFINITY), |best, &(k, t)| if t > best.1 { (k, t) } else { best }).0;
        entries.clear();
        self.vertex_weights(g, k, 1.0, entries);
        // One vertex moves the nine nodes of its point's stencil at most.
        Support::from_entries(entries).unwrap_or(Support { nodes: [0; SUPPORT_NODES], weights: [0.0; SUPPORT_NODES], len: 0 })
    }

    /// Appends to `out` the nodes of grain `g`'s field that move vertex `k` of its outline,
    /// each weight times `scale`: over a step the vertex, `x_p + F_p o`, moves by
    /// `Σ_i u_i (N_i(x_p) + ∇N_i(x_p) · F_p o)` for the nodal displacements `u_i` (the point's
    /// own displacement and the change of its `F`), so these weights give its velocity
    /// exactly, and an impulse on it reaches the nodes by them.
    fn vertex_weights(&self, g: usize, k: usize, scale: Real, out: &mut Vec<(u32, Real)>) {
        let v = self.grains[g].outline.vertices[k];
        let p = v.point as usize;
        let f = &self.fields[g];
        let fo = self.points.f[p] * v.offset;
        let st = f.stencils[p - self.grains[g].points.start];
        let nodes = f.stencil_nodes(&st);
        for a in 0..3 {
            for b in 0..3 {
                let i = nodes[a][b];
                if f.mass[i] > 0.0 {
                    out.push((i as u32, scale * (st.weight(a, b) + st.gradient(a, b).dot(&fo))));
                }
            }
        }
    }
}
