//! The order a soft-grain contact solve sweeps its contacts in, so that a sweep runs on every
//! thread ([`super::contact::solve()`]).
//!
//! A contact's turn changes the sample velocities of its two grains (of one, against a wall)
//! through their dense blocks of `A⁻¹`, so turns on contacts that share no grain commute. The
//! contacts are grouped into **tasks**, one for each pair of grains that touch (and one for
//! each grain's contacts with the walls), and the tasks are coloured greedily so that no two
//! tasks of a colour share a grain: a sweep takes the colours one after the other and the tasks
//! of a colour at once, each task's contacts in their order. The order depends on the contacts
//! only, never on the thread count, so the results do not either. The sweeps are worth sharing
//! because past jamming they take most of a step (docs/performance.md, "Design measurements"
//! under "FEM").

use std::collections::HashMap;
use std::ops::Range;

use super::contact::grain_contacts::GrainContacts;
use super::contact::records::{Other, VertexContact};

/// One task of a sweep: contacts `contacts` (contiguous), between grain `a` and grain `b` (or
/// the walls).
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    /// The contacts of the task.
    pub contacts: Range<usize>,
    /// One grain.
    pub a: u32,
    /// The other grain, `None` for a grain's contacts with the walls.
    pub b: Option<u32>,
}

/// The contacts' order for a sweep (module documentation).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Schedule {
    /// The tasks, colour after colour.
    pub tasks: Vec<Task>,
    /// Each colour's tasks: a range of [`Schedule::tasks`].
    pub colours: Vec<Range<usize>>,
    /// Scratch: the contacts in their new order.
    buffer: Vec<VertexContact>,
}

/// The task key of a contact: its two grains, the lower first (`u32::MAX` for the walls).
fn key(c: &VertexContact) -> (u32, u32) {
    match c.b {
        Other::Grain { grain, .. } => (c.a.min(grain), c.a.max(grain)),
        Other::Wall(_) => (c.a, u32::MAX),
    }
}

impl Schedule {
    /// Orders `contacts` colour by colour and task by task (each task's contacts kept in their
    /// order, so that a vertex's group stays together), renumbers the grains' entries in
    /// `sides` (one for each grain) to match, and sets the tasks and colours; leaves them as
    /// they are when the schedule still fits the contacts (`fits`).
    pub fn order(&mut self, contacts: &mut [VertexContact], sides: &mut [GrainContacts]) {
        if self.fits(contacts) {
            return;
        }
        self.tasks.clear();
        self.colours.clear();
        if contacts.is_empty() {
            return;
        }
        // The tasks in order of their keys, and each contact's task.
        let mut keys: Vec<(u32, u32)> = contacts.iter().map(key).collect();
        keys.sort_unstable();
        keys.dedup();
        let index: HashMap<(u32, u32), usize> = keys.iter().enumerate().map(|(t, k)| (*k, t)).collect();
        // Greedy colouring: each task the first colour neither of its grains has yet.
        let mut used: Vec<Vec<u32>> = vec![Vec::new(); sides.len()];
        let mut colour = Vec::with_capacity(keys.len());
        for &(a, b) in &keys {
            let taken = |c: u32| used[a as usize].contains(&c) || (b != u32::MAX && used[b as usize].contains(&c));
            let c = (0..).find(|&c| !taken(c)).unwrap_or(0);
            used[a as usize].push(c);
            if b != u32::MAX {
                used[b as usize].push(c);
            }
            colour.push(c);
        }
        // Tasks by colour, then by key; contacts by their task, then by their index.
        let mut rank: Vec<usize> = (0..keys.len()).collect();
        rank.sort_by_key(|&t| (colour[t], t));
        let mut place = vec![0; keys.len()];
        for (r, &t) in rank.iter().enumerate() {
            place[t] = r;
        }
        let task_of: Vec<usize> = contacts.iter().map(|c| place[index[&key(c)]]).collect();
        let mut order: Vec<usize> = (0..contacts.len()).collect();
        order.sort_by_key(|&c| (task_of[c], c));
        if order.iter().enumerate().any(|(i, &c)| i != c) {
            let mut new_index = vec![0u32; contacts.len()];
            for (i, &c) in order.iter().enumerate() {
                new_index[c] = i as u32;
            }
            self.buffer.clear();
            self.buffer.extend(order.iter().map(|&c| contacts[c]));
            contacts.copy_from_slice(&self.buffer);
            for side in sides.iter_mut() {
                for e in &mut side.entries {
                    e.0 = new_index[e.0 as usize];
                }
            }
        }
        // The tasks' ranges and the colours' ranges of tasks.
        let mut start = 0;
        for c in 1..=contacts.len() {
            if c == contacts.len() || task_of[order[c]] != task_of[order[start]] {
                let (a, b) = keys[rank[task_of[order[start]]]];
                self.tasks.push(Task { contacts: start..c, a, b: (b != u32::MAX).then_some(b) });
                start = c;
            }
        }
        let mut first = 0;
        for t in 1..=self.tasks.len() {
            if t == self.tasks.len() || colour[rank[t]] != colour[rank[first]] {
                self.colours.push(first..t);
                first = t;
            }
        }
    }

    /// Whether the tasks still cover `contacts` exactly, each contact in a task of its pair: a
    /// Newton iteration's contacts are those of the part's first, ordered then; a schedule
    /// that fits is a valid order whatever the contacts.
    fn fits(&self, contacts: &[VertexContact]) -> bool {
        self.tasks.last().map_or(0, |t| t.contacts.end) == contacts.len()
            && !contacts.is_empty()
            && self.tasks.iter().all(|t| {
                let k = (t.a, t.b.unwrap_or(u32::MAX));
                contacts[t.contacts.clone()].iter().all(|c| key(c) == k)
            })
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.tasks.capacity() * std::mem::size_of::<Task>()
            + self.colours.capacity() * std::mem::size_of::<Range<usize>>()
            + self.buffer.capacity() * std::mem::size_of::<VertexContact>()
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;
    use crate::math::Real;
    use crate::methods::soft::contact::records::Support;
    use crate::methods::soft::contact::warm::{enter, Against, Entry, Warm};

    /// A tangle of random contacts between 12 grains and two walls, groups of a vertex's
    /// contacts among them: the order is a permutation that keeps each pair's contacts in their
    /// order, no colour holds two tasks of one grain, and the grains' entries follow.
    #[test]
    fn a_schedule_colours_pairs_apart_and_keeps_each_pairs_order() {
        let grains = 12;
        let mut seed = 7u64;
        let mut next = |n: u64| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) % n
        };
        let mut contacts = Vec::new();
        let mut sides = vec![GrainContacts::default(); grains];
        for vertex in 0..400 {
            let a = next(grains as u64) as u32;
            let b = if next(8) == 0 {
                Against::Wall(next(2) as u32)
            } else {
                let mut b = next(grains as u64 - 1) as u32;
                if b >= a {
                    b += 1;
                }
                Against::Grain { grain: b, support: Support::from_entries(&mut [(vertex as u32, 1.0)]).expect("one node") }
            };
            let e = Entry {
                vertex,
                at: Vector2::new(vertex as Real, 0.0),
                a,
                support: Support::from_entries(&mut [(vertex as u32, 1.0)]).expect("one node"),
                b,
                normal: Vector2::new(0.0, 1.0),
                gap: vertex as Real,
                friction: 0.0,
                lever: 1.0,
                line: None,
                segment: 0,
            };
            enter(&mut contacts, &mut sides, &Warm::default(), e);
        }
        let before = contacts.clone();
        let mut s = Schedule::default();
        s.order(&mut contacts, &mut sides);
        // A permutation (the gap tells each contact apart), each pair's contacts in order.
        let mut gaps: Vec<usize> = contacts.iter().map(|c| c.gap as usize).collect();
        gaps.sort_unstable();
        assert_eq!(gaps, (0..before.len()).collect::<Vec<_>>());
        let mut covered = 0;
        for (colour, tasks) in s.colours.iter().enumerate() {
            let mut seen = vec![false; grains];
            for t in &s.tasks[tasks.clone()] {
                assert_eq!(t.contacts.start, covered, "tasks are contiguous");
                covered = t.contacts.end;
                for g in std::iter::once(t.a).chain(t.b) {
                    assert!(!seen[g as usize], "colour {colour} holds grain {g} twice");
                    seen[g as usize] = true;
                }
                let cs = &contacts[t.contacts.clone()];
                assert!(cs.iter().all(|c| key(c) == (t.a, t.b.unwrap_or(u32::MAX))));
                assert!(cs.windows(2).all(|w| w[0].gap < w[1].gap), "a pair's contacts keep their order");
            }
        }
        assert_eq!(covered, contacts.len());
        assert!(s.colours.len() > 1 && s.colours.len() < 40, "{} colours", s.colours.len());
        // Every grain's entries name the contact whose sample they hold.
        for (g, side) in sides.iter().enumerate() {
            for (slot, &(c, is_a)) in side.entries.iter().enumerate() {
                let k = &contacts[c as usize];
                let (grain, at) = if is_a {
                    (k.a, k.slot)
                } else {
                    match k.b {
                        Other::Grain { grain, slot } => (grain, slot),
                        Other::Wall(_) => panic!("a wall has no entries"),
                    }
                };
                assert_eq!((grain as usize, at as usize), (g, slot));
            }
        }
        // Ordering again changes nothing.
        let once = contacts.clone();
        s.order(&mut contacts, &mut sides);
        assert_eq!(contacts, once);
    }
}
