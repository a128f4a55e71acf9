//! The parallel sweep: contacts coloured so that no two of a colour share a body, each colour
//! swept by several threads at once.
//!
//! Gauss-Seidel is sequential by nature — each contact sees the impulses the contacts before it
//! just changed — but two contacts that share no body do not see each other within a sweep: in
//! whatever order, or at the same time, they are solved alike. Greedy colouring (each contact
//! takes the first colour none of its bodies has yet) splits the contacts into such groups; a
//! sweep in colour order is a Gauss-Seidel sweep in another order, which converges to a solution
//! of the same problem (the velocities, and the impulses where they are unique). Contacts with a
//! boundary free to move (a stress-controlled wall is one body for all its contacts, and so is a
//! stress-controlled periodic cell for the contacts across its boundary) and those past
//! [`MAX_COLOURS`] colours go to a last group swept serially.
//!
//! The order and the groups depend on the contacts only, and each task sums its part of the
//! criterion over a fixed range of contacts: the answer does not depend on the number of
//! threads.

use rayon::prelude::*;

use super::bodies::{Mobility, SolveBodies};
use super::contact::{RigidContact, Side};
use super::sweep::{Pass, Sums};
use crate::math::Vec3;

/// Contacts per parallel task; a colour of fewer contacts is swept by one.
pub const CHUNK: usize = 256;

/// Largest number of colours (one bit per colour and body).
pub const MAX_COLOURS: usize = 64;

/// The groups of a coloured sweep over contacts stored in colour order.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Colours {
    /// Colour `c` holds the contacts `bounds[c]..bounds[c + 1]`; the last group
    /// (`bounds[MAX_COLOURS]..`) is swept serially.
    bounds: Vec<usize>,
    /// The colours each body has (one bit per colour; scratch kept between steps).
    used: Vec<u64>,
    /// The colour of each contact (scratch).
    colour: Vec<u8>,
}

impl Colours {
    /// Colours `contacts` between `bodies` bodies and boundaries of mobilities `mobility`, and
    /// writes in `order` the permutation that stores them in colour order: position `k` takes
    /// contact `order[k]` (detection order kept within a colour).
    pub fn new(contacts: &[RigidContact], bodies: usize, mobility: &[Mobility], order: &mut Vec<u32>) -> Self {
        let mut colours = Self::default();
        colours.assign(contacts, bodies, mobility, order);
        colours
    }

    /// [`Colours::new`] into `self`, reusing its buffers (no allocation once they are large
    /// enough: the step loop colours its contacts at every step).
    pub fn assign(&mut self, contacts: &[RigidContact], bodies: usize, mobility: &[Mobility], order: &mut Vec<u32>) {
        let (used, colour) = (&mut self.used, &mut self.colour);
        used.clear();
        used.resize(bodies, 0);
        colour.clear();
        let mut count = [0usize; MAX_COLOURS + 1];
        for c in contacts {
            let i = c.i as usize;
            let k = match c.j {
                Side::Boundary(b) if mobility.get(b as usize).is_some_and(|m| m.inv_mass > 0.0) => MAX_COLOURS,
                Side::Boundary(_) => {
                    let k = (!used[i]).trailing_zeros() as usize;
                    if k < MAX_COLOURS {
                        used[i] |= 1 << k;
                    }
                    k
                }
                Side::Image { cell, .. } if mobility.get(cell as usize).is_some_and(|m| m.inv_mass > 0.0) => MAX_COLOURS,
                Side::Body(j) | Side::Image { j, .. } => {
                    let j = j as usize;
                    let k = (!(used[i] | used[j])).trailing_zeros() as usize;
                    if k < MAX_COLOURS {
                        used[i] |= 1 << k;
                        used[j] |= 1 << k;
                    }
                    k
                }
            };
            colour.push(k as u8);
            count[k] += 1;
        }
        let bounds = &mut self.bounds;
        bounds.clear();
        let mut start = 0;
        for n in count {
            bounds.push(start);
            start += n;
        }
        bounds.push(start);
        let mut next = [0usize; MAX_COLOURS + 2];
        next.copy_from_slice(bounds);
        order.clear();
        order.resize(contacts.len(), 0);
        for (k, &c) in colour.iter().enumerate() {
            order[next[c as usize]] = k as u32;
            next[c as usize] += 1;
        }
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.bounds.capacity() * std::mem::size_of::<usize>() + self.used.capacity() * 8 + self.colour.capacity()
    }

    /// Number of non-empty colours swept in parallel.
    pub fn colours(&self) -> usize {
        self.bounds.windows(2).take(MAX_COLOURS).filter(|w| w[1] > w[0]).count()
    }

    /// Contacts left to the serial group.
    pub fn serial(&self) -> usize {
        self.bounds[MAX_COLOURS + 1] - self.bounds[MAX_COLOURS]
    }

    /// One pass over `contacts` (in colour order), `pass` applied to each contact with its slot
    /// of `last` (the same length: the impulses after the previous sweep); returns what it adds
    /// up for the criterion.
    pub(crate) fn sweep(&self, contacts: &mut [RigidContact], last: &mut [Vec3], bodies: &mut &SolveBodies<'_>, pass: Pass) -> Sums {
        let mut sums = Sums::default();
        for c in 0..=MAX_COLOURS {
            let range = self.bounds[c]..self.bounds[c + 1];
            let (group, slots) = (&mut contacts[range.clone()], &mut last[range]);
            if c == MAX_COLOURS || group.len() <= CHUNK {
                for (contact, slot) in group.iter_mut().zip(slots.iter_mut()) {
                    pass.apply(contact, slot, bodies, &mut sums);
                }
                continue;
            }
            let parts: Vec<Sums> = group
                .par_chunks_mut(CHUNK)
                .zip(slots.par_chunks_mut(CHUNK))
                .map(|(chunk, slots)| {
                    let mut bodies = *bodies;
                    let mut part = Sums::default();
                    for (contact, slot) in chunk.iter_mut().zip(slots.iter_mut()) {
                        pass.apply(contact, slot, &mut bodies, &mut part);
                    }
                    part
                })
                .collect();
            for part in parts {
                sums += part;
            }
        }
        sums
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Real;
    use crate::nscd::contact::test_contact;

    fn contact(i: u32, j: Side) -> RigidContact {
        test_contact(i, j, Vec3::x(), (0.5, 0.5), RigidContact::delassus(1.0, 2.0, 0.5, 1.0, 2.0, 0.5))
    }

    #[test]
    fn no_two_contacts_of_a_colour_share_a_body_and_free_walls_go_last() {
        // A chain 0-1-2-3, a triangle 4-5-6, contacts with a fixed wall 0 and a free wall 1.
        let contacts = vec![
            contact(0, Side::Body(1)),
            contact(1, Side::Body(2)),
            contact(2, Side::Body(3)),
            contact(4, Side::Body(5)),
            contact(5, Side::Body(6)),
            contact(6, Side::Body(4)),
            contact(0, Side::Boundary(0)),
            contact(3, Side::Boundary(1)),
            contact(5, Side::Boundary(0)),
        ];
        let free = Mobility { direction: Vec3::y(), inv_mass: 1.0, partner: None, max_speed: Real::INFINITY };
        let mut order = Vec::new();
        let colours = Colours::new(&contacts, 7, &[Mobility::FIXED, free], &mut order);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..contacts.len() as u32).collect::<Vec<_>>(), "a permutation");
        assert_eq!(colours.serial(), 1);
        assert_eq!(contacts[order[order.len() - 1] as usize].j, Side::Boundary(1));
        // Triangle: three colours; nothing needs more.
        assert_eq!(colours.colours(), 3);
        for c in 0..MAX_COLOURS {
            let mut bodies: Vec<u32> = Vec::new();
            for &k in &order[colours.bounds[c]..colours.bounds[c + 1]] {
                let ct = &contacts[k as usize];
                bodies.push(ct.i);
                if let Side::Body(j) = ct.j {
                    bodies.push(j);
                }
            }
            let n = bodies.len();
            bodies.sort_unstable();
            bodies.dedup();
            assert_eq!(bodies.len(), n, "colour {c} shares a body");
        }
        // Detection order within a colour.
        for c in 0..=MAX_COLOURS {
            let within = &order[colours.bounds[c]..colours.bounds[c + 1]];
            assert!(within.windows(2).all(|w| w[0] < w[1]));
        }
    }
}
