//! The contacts of a step: each grain's boundary at the step's start, the contacts between
//! boundaries and with the walls, and their drifts at an iterate.

use super::{Grain, System, V2};
use crate::math::Real;
use crate::methods::soft::contact::{self, candidates, enter, Candidate, Entry, Support};
use crate::methods::soft::Scheme;

/// How far the current iterate moves the place `s` of grain `g`'s boundary over the step, m.
fn support_displacement(grains: &[Grain], g: usize, s: &Support, sc: &Scheme) -> V2 {
    s.iter().map(|(k, w)| grains[g].body.increment(k, sc) * w).sum()
}

impl System {
    /// Each grain's boundary at the step's start, and the step's contacts (module
    /// documentation).
    pub(super) fn detect(&mut self) {
        let mut shapes = std::mem::take(&mut self.outlines);
        for (g, at) in shapes.iter_mut().enumerate() {
            let b = &self.grains[g].body;
            at.clear();
            at.extend(b.mesh.boundary.iter().map(|&k| b.position(k as usize)));
        }
        for side in &mut self.sides {
            side.clear();
        }
        self.contacts.clear();
        let node = |g: usize, k: usize| self.grains[g].body.mesh.boundary[k];
        for candidate in candidates(&shapes, &self.walls, self.reach, self.settings.sides) {
            let e = match candidate {
                Candidate::Grain { a, k, b, near, line } => {
                    let next = (near.segment + 1) % shapes[b].len();
                    let on_b = Support::from_entries(&mut [(node(b, near.segment), 1.0 - near.t), (node(b, next), near.t)]);
                    let (Some(support), Some(on_b)) = (Support::from_entries(&mut [(node(a, k), 1.0)]), on_b) else { continue };
                    let friction = self.pair_friction.unwrap_or_else(|| (self.grains[a].friction * self.grains[b].friction).sqrt());
                    Entry::between_grains(k, shapes[a][k], a, support, b, on_b, &near, line, friction, self.grains[a].radius)
                }
                Candidate::Wall { g, k, w, gap } => {
                    let Some(support) = Support::from_entries(&mut [(node(g, k), 1.0)]) else { continue };
                    let grain = &self.grains[g];
                    Entry::against_wall(k, shapes[g][k], g, support, w, &self.walls[w], gap, grain.friction, grain.radius)
                }
            };
            enter(&mut self.contacts, &mut self.sides, &self.warm, e);
        }
        self.outlines = shapes;
    }

    /// Sets each contact's drift at the current iterate: every boundary moved as the iterate
    /// moves its nodes and the gap measured anew, against the gap the contact's supports
    /// predict.
    pub(super) fn measure_drifts(&mut self, sc: &Scheme) {
        let moved: Vec<Vec<V2>> = self
            .grains
            .iter()
            .zip(&self.outlines)
            .zip(&self.sides)
            .map(|((g, from), side)| {
                if side.is_empty() {
                    return Vec::new();
                }
                g.body.mesh.boundary.iter().zip(from).map(|(&k, x)| x + g.body.increment(k as usize, sc)).collect()
            })
            .collect();
        let grains = &self.grains;
        let displacement = |g: usize, s: &Support| support_displacement(grains, g, s, sc);
        contact::measure_drifts(&mut self.contacts, &self.sides, &self.walls, &moved, sc.dt, displacement);
    }

    /// Measures the contacts' drifts anew at the current iterate; returns the largest change, m,
    /// over the contacts whose drift matters: those that carry an impulse, and those whose gap
    /// at the part's end, with the new drift, is within `limit` (m). A contact that stays open
    /// whatever its drift leaves the solution as it is (the contacts that failed the parts of
    /// a 100-grain compaction past Φ 0.83 were mostly one such contact among 1,300, a gap of
    /// 1.0–1.3 mm open, its drift moved by 30 µm).
    pub(super) fn remeasure_drifts(&mut self, sc: &Scheme, limit: Real) -> Real {
        let mut before = std::mem::take(&mut self.drifts);
        before.clear();
        before.extend(self.contacts.iter().map(|c| c.drift));
        self.measure_drifts(sc);
        let grains = &self.grains;
        let sides = &self.sides;
        let displacement = |g: usize, slot: u32| support_displacement(grains, g, &sides[g].samples[slot as usize], sc);
        let moved = self
            .contacts
            .iter()
            .zip(&before)
            .filter(|(c, _)| {
                let n = V2::new(c.frame.n.x, c.frame.n.y);
                let ub = match c.b {
                    contact::Other::Grain { grain, slot } => displacement(grain as usize, slot),
                    contact::Other::Wall(w) => self.walls[w as usize].velocity * sc.dt,
                };
                let end_gap = c.gap + (displacement(c.a as usize, c.slot) - ub).dot(&n) + c.drift;
                c.r.x > 0.0 || end_gap <= limit
            })
            .map(|(c, d)| (c.drift - d).abs())
            .fold(0.0, Real::max);
        self.drifts = before;
        moved
    }
}
