//! A step's contacts entered ([`enter`]): each with its samples on its grains' sides, its
//! impulse warm-started from the last solve's by its key ([`Warm`]).

use std::collections::HashMap;

use nalgebra::Vector2;

use super::grain_contacts::GrainContacts;
use super::records::{Other, Support, VertexContact, Wall};
use crate::math::{Real, Vec3};
use crate::methods::soft::polygon::Nearest;
use crate::nscd::local::{Delassus, LocalLaw};
use crate::nscd::ContactFrame;
use crate::scene::state_points::StateImpulse;

type V2 = Vector2<Real>;

/// The impulses of the last solve kept for the next step's warm start, by contact key.
#[derive(Debug, Clone, Default)]
pub struct Warm(HashMap<(usize, u32, i64), Vec3>);

impl Warm {
    /// Keeps the impulses of `contacts` (those not zero), forgetting the others.
    pub fn remember(&mut self, contacts: &[VertexContact]) {
        self.0.clear();
        for c in contacts {
            if c.r != Vec3::zeros() {
                self.0.insert(c.key(), c.r);
            }
        }
    }

    /// The impulse kept for `contact`'s key, or zero.
    pub fn start(&self, contact: &VertexContact) -> Vec3 {
        self.0.get(&contact.key()).copied().unwrap_or_else(Vec3::zeros)
    }

    /// Every kept impulse with its key ([`VertexContact::key`]), in the keys' order (a saved
    /// state's).
    pub fn entries(&self) -> Vec<((usize, u32, i64), Vec3)> {
        let mut all: Vec<_> = self.0.iter().map(|(k, r)| (*k, *r)).collect();
        all.sort_unstable_by_key(|e| e.0);
        all
    }

    /// The impulses as a saved state holds them ([`Warm::restore_saved`] reads them back).
    pub fn saved(&self) -> Vec<StateImpulse> {
        self.entries()
            .into_iter()
            .map(|((vertex, grain, other), r)| StateImpulse { grain, vertex: vertex as u32, other, impulse: vec![r.x, r.y] })
            .collect()
    }

    /// Keeps the impulses a saved state holds for the next step.
    pub fn restore_saved(&mut self, impulses: &[StateImpulse]) {
        self.restore(impulses.iter().map(|e| ((e.vertex as usize, e.grain, e.other), Vec3::new(e.impulse[0], e.impulse[1], 0.0))));
    }

    /// Keeps `entries` ([`Warm::entries`]) for the next step.
    pub fn restore(&mut self, entries: impl IntoIterator<Item = ((usize, u32, i64), Vec3)>) {
        self.0 = entries.into_iter().collect();
    }
}

/// The second member of a contact being entered: a grain with the support its place has on
/// it, or a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Against {
    /// Grain `grain`, its place carried by `support`.
    Grain {
        /// Grain index.
        grain: u32,
        /// The place on its outline.
        support: Support,
    },
    /// Wall index.
    Wall(u32),
}

/// A contact of the step to enter ([`enter`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Entry {
    /// The vertex of grain `a`'s outline it is measured from.
    pub vertex: usize,
    /// The contact point, m.
    pub at: V2,
    /// First grain.
    pub a: u32,
    /// The vertex's support on grain `a`.
    pub support: Support,
    /// Second member.
    pub b: Against,
    /// Unit normal from `b` towards `a`.
    pub normal: V2,
    /// Gap along it, m.
    pub gap: Real,
    /// Friction coefficient of the pair.
    pub friction: Real,
    /// Radius of grain `a`, m.
    pub lever: Real,
    /// The segment whose line alone holds the vertex ([`VertexContact::line`]).
    pub line: Option<u32>,
    /// The segment of the other outline it was found against ([`VertexContact::segment`]).
    pub segment: u32,
}

impl Entry {
    /// The contact of vertex `vertex` of grain `a` (at `x`, held by `support`) with the outline
    /// of grain `b` at `near` (held there by `on_b`), on that segment's line alone when `line`
    /// ([`crate::methods::soft::contact::Candidate::Grain`]); the contact point is midway across
    /// the gap, `friction` the pair's coefficient and `lever` grain `a`'s radius.
    #[allow(clippy::too_many_arguments)]
    pub fn between_grains(
        vertex: usize,
        x: V2,
        a: usize,
        support: Support,
        b: usize,
        on_b: Support,
        near: &Nearest,
        line: bool,
        friction: Real,
        lever: Real,
    ) -> Self {
        Self {
            vertex,
            at: x - near.normal * (0.5 * near.gap),
            a: a as u32,
            support,
            b: Against::Grain { grain: b as u32, support: on_b },
            normal: near.normal,
            gap: near.gap,
            friction,
            lever,
            line: line.then_some(near.segment as u32),
            segment: near.segment as u32,
        }
    }

    /// The contact of vertex `vertex` of grain `a` (at `x`, held by `support`) with `wall`
    /// (number `w`) across `gap`, the grain's friction coefficient and radius being `friction`
    /// and `lever`.
    #[allow(clippy::too_many_arguments)]
    pub fn against_wall(
        vertex: usize,
        x: V2,
        a: usize,
        support: Support,
        w: usize,
        wall: &Wall,
        gap: Real,
        friction: Real,
        lever: Real,
    ) -> Self {
        Self {
            vertex,
            at: x - wall.normal * gap,
            a: a as u32,
            support,
            b: Against::Wall(w as u32),
            normal: wall.normal,
            gap,
            friction: (friction * wall.friction).sqrt(),
            lever,
            line: None,
            segment: 0,
        }
    }
}

/// Adds a contact of the step, warm-started, with its samples on its grains' sides.
pub fn enter(contacts: &mut Vec<VertexContact>, sides: &mut [GrainContacts], warm: &Warm, e: Entry) {
    let index = contacts.len() as u32;
    let b = match e.b {
        Against::Grain { grain, support } => Other::Grain { grain, slot: sides[grain as usize].push(support, index, false) },
        Against::Wall(w) => Other::Wall(w),
    };
    let slot = sides[e.a as usize].push(e.support, index, true);
    let mut contact = VertexContact {
        vertex: e.vertex,
        at: e.at,
        a: e.a,
        slot,
        b,
        frame: ContactFrame::new(2, Vec3::new(e.normal.x, e.normal.y, 0.0)),
        gap: e.gap,
        drift: 0.0,
        // The Signorini target is set by each solve ([`solve`]).
        law: LocalLaw { target: 0.0, friction: e.friction, cohesion: 0.0, viscosity: 0.0 },
        w: Delassus { n: 0.0, t: 0.0 },
        r: Vec3::zeros(),
        scale: 0.0,
        lever: e.lever,
        line: e.line,
        segment: e.segment,
    };
    contact.r = warm.start(&contact);
    contacts.push(contact);
}
