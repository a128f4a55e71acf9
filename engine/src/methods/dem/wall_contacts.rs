//! The contacts of particles with the plane walls and the drum, stored sparsely.
//!
//! A box of 10,000 grains with six walls has about 2,000 grains near a wall and fewer touching
//! one; an array of springs and forces for every particle against every wall made the force stage
//! write 4 MB a step, most of it zeros (70% of a walled deposition's time). Here each block of
//! particles (the blocks of [`super::tasks::PARTICLE_BLOCK`]) keeps
//!
//! - its **candidates**: the (particle, wall) pairs whose gap was below the Verlet skin when the
//!   neighbour list was last built, in particle then wall order. The list is exact by the skin's
//!   argument: the neighbour list is rebuilt before any particle has moved half the skin, and
//!   [`WallContacts::walls_moved`] asks for a rebuild before any wall has moved half the skin
//!   (walls move only along their normal), so a pair left out cannot have closed its gap;
//! - its **records**: the candidates touching at the last evaluation, with their tangential and
//!   rolling springs, force and torque, in the same order, so that the next evaluation finds a
//!   pair's springs by a merge walk, as the pair records do ([`super::pair_state`]);
//! - its share of the **reactions**: the force of its records on each wall and the drum's torque,
//!   summed over blocks in block order afterwards (the same value for any number of threads).
//!
//! The evaluation runs in the gather of the force stage, in the task that owns the block, before
//! the task overwrites the previous forces that the end-of-step velocity prediction needs.

use rayon::prelude::*;

use super::tasks::PARTICLE_BLOCK;
use crate::contact::{ContactInput, ContactTable};
use crate::loading::{Drum, Wall};
use crate::math::{Real, Vec3};
use crate::particles::Particles;

/// A particle touching a wall (slot `w` < number of plane walls) or the drum (the last slot).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct WallContact {
    /// The particle.
    pub i: u32,
    /// The wall's slot: plane walls in order, then the drum.
    pub w: u16,
    /// Tangential spring, m.
    pub xi: Vec3,
    /// Rolling spring, rad.
    pub roll: Vec3,
    /// Force of the wall on the particle, N.
    pub force: Vec3,
    /// Torque of the wall on the particle, N·m.
    pub torque: Vec3,
}

/// The walls' contacts, by block of particles.
#[derive(Debug, Clone, Default)]
pub(crate) struct WallContacts {
    /// Wall slots (plane walls, then the drum).
    pub slots: usize,
    /// Per block: (particle, slot) pairs that may touch before the next neighbour build.
    pub candidates: Vec<Vec<(u32, u16)>>,
    /// Per block: the touching candidates at the last evaluation.
    pub records: Vec<Vec<WallContact>>,
    /// Per block: the records of the evaluation before (scratch).
    pub previous: Vec<Vec<WallContact>>,
    /// Per block and slot: the force of the block's records on the particles, N (one unused
    /// entry per block without slots, so that it splits into as many chunks as the blocks).
    pub block_force: Vec<Vec3>,
    /// Per block: the torque of its records about the drum's axis, N·m.
    pub block_drum_torque: Vec<Real>,
    /// Position of each plane wall when the candidates were chosen, m.
    reference: Vec<Real>,
}

/// What the evaluation of a block reads of every particle.
pub(crate) struct Grains<'a> {
    /// Positions, m.
    pub pos: &'a [Vec3],
    /// Radii, m.
    pub radius: &'a [Real],
    /// Masses, kg.
    pub mass: &'a [Real],
    /// Inverse masses, 1/kg.
    pub inv_mass: &'a [Real],
    /// Inverse moments of inertia, 1/(kg m²).
    pub inv_inertia: &'a [Real],
    /// Material indices.
    pub material: &'a [u16],
}

/// The velocities and last forces of the particles a task owns, from particle `base` on.
pub(crate) struct Owned<'a> {
    /// First particle.
    pub base: usize,
    /// Velocities, m/s.
    pub vel: &'a [Vec3],
    /// Angular velocities, rad/s.
    pub omega: &'a [Vec3],
    /// Forces of the last evaluation, N.
    pub force: &'a [Vec3],
    /// Torques of the last evaluation, N·m.
    pub torque: &'a [Vec3],
}

/// What the evaluation of a block needs from the simulation.
pub(crate) struct WallScene<'a> {
    /// The plane walls.
    pub walls: &'a [Wall],
    /// The drum, if any (the last slot).
    pub drum: Option<&'a Drum>,
    /// The wall each particle is glued to (empty while none is).
    pub glued_to: &'a [u16],
    /// Laws of the particle-wall contacts.
    pub table: &'a ContactTable,
    /// The walls' material.
    pub wall_material: usize,
    /// Time step, s.
    pub dt: Real,
}

impl WallContacts {
    /// Storage for `blocks` blocks of particles and `slots` wall slots.
    pub fn new(blocks: usize, slots: usize) -> Self {
        Self {
            slots,
            candidates: vec![Vec::new(); blocks],
            records: vec![Vec::new(); blocks],
            previous: vec![Vec::new(); blocks],
            block_force: vec![Vec3::zeros(); blocks * slots.max(1)],
            block_drum_torque: vec![0.0; blocks],
            reference: Vec::new(),
        }
    }

    /// Chooses the candidates: the pairs whose gap is below `skin` (m) now. Called with each
    /// neighbour-list build; the records keep their springs (a record whose pair is no longer a
    /// candidate is not touching).
    pub fn choose(&mut self, p: &Particles, walls: &[Wall], drum: Option<&Drum>, skin: Real) {
        if self.slots == 0 {
            return;
        }
        let planes = walls.len();
        self.candidates.par_iter_mut().enumerate().for_each(|(b, list)| {
            list.clear();
            let range = b * PARTICLE_BLOCK..((b + 1) * PARTICLE_BLOCK).min(p.len());
            for i in range {
                let (x, r) = (&p.pos[i], p.radius[i]);
                for (w, wall) in walls.iter().enumerate() {
                    let gap = (x[wall.face.axis] - wall.position) * wall.normal()[wall.face.axis] - r;
                    if gap < skin {
                        list.push((i as u32, w as u16));
                    }
                }
                if drum.is_some_and(|d| d.gap(x, r) < skin) {
                    list.push((i as u32, planes as u16));
                }
            }
        });
        self.reference = walls.iter().map(|w| w.position).collect();
    }

    /// True if some plane wall moved by half the skin or more since the candidates were chosen:
    /// the neighbour list (and with it the candidates) must then be rebuilt.
    pub fn walls_moved(&self, walls: &[Wall], skin: Real) -> bool {
        self.reference.len() != walls.len() || walls.iter().zip(&self.reference).any(|(w, x0)| (w.position - x0).abs() >= 0.5 * skin)
    }

    /// Every record, in block then particle order.
    pub fn iter(&self) -> impl Iterator<Item = &WallContact> {
        self.records.iter().flatten()
    }

    /// Number of touching pairs.
    pub fn len(&self) -> usize {
        self.records.iter().map(Vec::len).sum()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        let lists = |v: &Vec<Vec<WallContact>>| v.iter().map(|l| l.capacity() * std::mem::size_of::<WallContact>()).sum::<usize>();
        lists(&self.records)
            + lists(&self.previous)
            + self.candidates.iter().map(|l| l.capacity() * std::mem::size_of::<(u32, u16)>()).sum::<usize>()
            + self.block_force.capacity() * std::mem::size_of::<Vec3>()
            + self.block_drum_torque.capacity() * std::mem::size_of::<Real>()
    }

    /// Sums the blocks' reactions, in block order: the force the particles exert on each slot,
    /// and the drum's torque.
    pub fn reactions(&self) -> (Vec<Vec3>, Real) {
        let mut on_walls = vec![Vec3::zeros(); self.slots];
        if self.slots > 0 {
            for block in self.block_force.chunks_exact(self.slots) {
                for (s, f) in on_walls.iter_mut().zip(block) {
                    *s -= f;
                }
            }
        }
        (on_walls, -self.block_drum_torque.iter().sum::<Real>())
    }
}

/// The contact of a particle of radius `r` at `x` with slot `w` (a plane wall, or the drum after
/// them), if they touch: the inward normal, the overlap and the velocity of the wall's surface
/// there.
#[inline(always)]
pub(crate) fn touch(walls: &[Wall], drum: Option<&Drum>, x: &Vec3, r: Real, w: usize) -> Option<(Vec3, Real, Vec3)> {
    match walls.get(w) {
        Some(wall) => {
            let n = wall.normal();
            let delta = r - (x[wall.face.axis] - wall.position) * n[wall.face.axis];
            (delta > 0.0).then_some((n, delta, wall.velocity))
        }
        None => drum.and_then(|d| d.touch(x, r).map(|(n, delta)| (n, delta, d.surface_velocity(&(x - n * (r - delta)))))),
    }
}

/// Evaluates the wall contacts of one block: the candidates that touch get a record (with the
/// springs of their record of the last evaluation, found by a merge walk), and the block's
/// reactions are summed. The owner's forces are those of the last evaluation (for the
/// end-of-step velocity prediction of the dashpots).
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate_block(
    s: &WallScene<'_>,
    p: &Grains<'_>,
    owner: &Owned<'_>,
    candidates: &[(u32, u16)],
    records: &mut Vec<WallContact>,
    previous: &mut Vec<WallContact>,
    block_force: &mut [Vec3],
    drum_torque: &mut Real,
) {
    std::mem::swap(records, previous);
    records.clear();
    block_force.fill(Vec3::zeros());
    *drum_torque = 0.0;
    let mut cursor = 0;
    let h = 0.5 * s.dt;
    for &(i, w) in candidates {
        let (iu, wu) = (i as usize, w as usize);
        // A grain glued to a wall is part of it.
        if s.glued_to.get(iu) == Some(&w) {
            continue;
        }
        let (x, r) = (p.pos[iu], p.radius[iu]);
        let Some((n, delta, wall_velocity)) = touch(s.walls, s.drum, &x, r, wu) else { continue };
        // The springs of the last evaluation, if this pair touched then.
        while previous.get(cursor).is_some_and(|o| (o.i, o.w) < (i, w)) {
            cursor += 1;
        }
        let (mut xi, mut roll) = match previous.get(cursor) {
            Some(o) if (o.i, o.w) == (i, w) => (o.xi, o.roll),
            _ => (Vec3::zeros(), Vec3::zeros()),
        };
        let law = s.table.get(p.material[iu] as usize, s.wall_material);
        let k = iu - owner.base;
        let (dv, dw) = (owner.force[k] * (h * p.inv_mass[iu]), owner.torque[k] * (h * p.inv_inertia[iu]));
        let (v, omega) = (owner.vel[k], owner.omega[k]);
        let a_i = r - delta;
        let v_c = v - (omega * a_i).cross(&n) - wall_velocity;
        let v_damp = v_c + dv - (dw * a_i).cross(&n);
        let input = ContactInput {
            n,
            delta,
            r_i: r,
            r_j: Real::INFINITY,
            r_eff: r,
            m_eff: p.mass[iu],
            a_i,
            a_j: 0.0,
            v_c,
            v_damp,
            w_rel: omega,
            spin_n: 0.5 * omega.dot(&n),
        };
        let out = law.compute(&input, &mut xi, Some(&mut roll), None, s.dt);
        block_force[wu] += out.force;
        if let Some(d) = s.drum.filter(|_| wu == s.walls.len()) {
            *drum_torque += d.torque_of(&d.surface_point(&x), &out.force);
        }
        records.push(WallContact { i, w, xi, roll, force: out.force, torque: out.torque_i });
    }
}
