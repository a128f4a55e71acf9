//! DEM's contact history in a checkpoint ([`crate::resume`]): the springs of every pair
//! touching (or held by a capillary bridge) and of every particle touching a wall or the drum,
//! written from the pair and wall records, and set back into them in a simulation built from the
//! checkpoint's state, whose particles keep the state's order.

use super::pair_state::{PairExtra, PairForce};
use super::tasks::PARTICLE_BLOCK;
use super::wall_contacts::WallContact;
use super::Dem;
use crate::error::EngineError;
use crate::math::Vec3;
use crate::resume::{ContactHistory, Other, SpringContact};

/// A pair's history on its way back: index in the neighbour list, particles, spring, extras.
type Held = (u32, u32, u32, Vec3, PairExtra);

impl Dem {
    /// The springs of the last force evaluation.
    pub(super) fn springs(&self) -> ContactHistory {
        let pairs = self.pairs.iter().flat_map(|b| b.pairs()).map(|c| {
            let extra = c.extra.unwrap_or_default();
            SpringContact { i: c.i, with: Other::Particle(c.j), spring: c.xi.into(), roll: extra.roll.into(), bridge: extra.bridge }
        });
        let walls = self.wall_contacts.iter().map(|c| SpringContact {
            i: c.i,
            with: Other::Boundary(c.w),
            spring: c.xi.into(),
            roll: c.roll.into(),
            bridge: false,
        });
        let p = &self.w.p;
        let loads = p.force.iter().zip(&p.torque).map(|(f, t)| [f.x, f.y, f.z, t.x, t.y, t.z]).collect();
        let wall_forces = self.w.walls.iter().map(|w| w.force.into()).collect();
        ContactHistory::Springs { contacts: pairs.chain(walls).collect(), loads, walls: wall_forces }
    }

    /// Sets back the springs of `history` and evaluates the forces with them, as the run that
    /// saved them had them at its last evaluation: with a zero time step, so that the springs
    /// do not advance a second time over the step they were saved at; then sets back the loads
    /// of that evaluation on the particles and walls, which the next step reads first.
    pub(super) fn set_springs(&mut self, history: Option<&ContactHistory>) -> Result<(), EngineError> {
        let refuse = |reason: String| EngineError::Build { field: "checkpoint.carried.contacts".into(), reason };
        let (contacts, loads, wall_forces) = match history {
            None => (&[][..], &[][..], &[][..]),
            Some(ContactHistory::Springs { contacts, loads, walls }) => (contacts.as_slice(), loads.as_slice(), walls.as_slice()),
            Some(ContactHistory::Impulses { .. }) => return Err(refuse("impulses of contact dynamics cannot go on as DEM springs".into())),
        };
        let n = self.w.p.len();
        let slots = self.wall_slots();
        let blocks = self.pairs.len();
        // Per block: the pairs and the wall records.
        let mut pairs: Vec<Vec<Held>> = vec![Vec::new(); blocks];
        let mut walls: Vec<Vec<WallContact>> = vec![Vec::new(); blocks];
        for c in contacts {
            let i = c.i as usize;
            if i >= n {
                return Err(refuse(format!("particle {i} does not exist: the state has {n}")));
            }
            let (xi, roll) = (Vec3::from(c.spring), Vec3::from(c.roll));
            if !(xi.iter().chain(roll.iter()).all(|x| x.is_finite())) {
                return Err(refuse(format!("the springs of particle {i} are not finite")));
            }
            match c.with {
                Other::Particle(j) => {
                    // A pair not listed now cannot touch: its history would be dropped at the
                    // next evaluation anyway.
                    let Some(q) = self.nl.find(c.i, j) else { continue };
                    let extra = PairExtra { roll, bridge: c.bridge };
                    pairs[i / PARTICLE_BLOCK].push((q as u32, c.i, j, xi, extra));
                }
                Other::Boundary(w) => {
                    if w as usize >= slots {
                        return Err(refuse(format!("boundary {w} does not exist: the scene has {slots}")));
                    }
                    let zero = Vec3::zeros();
                    walls[i / PARTICLE_BLOCK].push(WallContact { i: c.i, w, xi, roll, force: zero, torque: zero });
                }
            }
        }
        for (block, mut list) in self.pairs.iter_mut().zip(pairs) {
            list.sort_unstable_by_key(|e| e.0);
            list.dedup_by_key(|e| e.0);
            let s = &mut block.state;
            s.clear();
            block.forces.clear();
            for (q, i, j, xi, extra) in list {
                s.q.push(q);
                for (a, x) in s.xi.iter_mut().zip(xi.iter()) {
                    a.push(*x);
                }
                if self.needs_extra {
                    s.extras.push(extra);
                }
                block.forces.push(PairForce { i, j, out: Default::default() });
            }
        }
        for (records, mut list) in self.wall_contacts.records.iter_mut().zip(walls) {
            list.sort_unstable_by_key(|c| (c.i, c.w));
            list.dedup_by_key(|c| (c.i, c.w));
            *records = list;
        }
        let dt = std::mem::replace(&mut self.dt, 0.0);
        self.kin_current = false;
        self.compute_forces(false);
        self.dt = dt;
        self.kin_current = false;
        // The loads the run that saved them had: the damping of the evaluation above read the
        // velocities at the end of the step, not their predictions, and differed by up to 0.2%
        // in a sheared flow.
        if loads.len() == n && wall_forces.len() == self.w.walls.len() {
            if !loads.iter().flatten().chain(wall_forces.iter().flatten()).all(|x| x.is_finite()) {
                return Err(refuse("the loads of the last evaluation are not finite".into()));
            }
            let p = &mut self.w.p;
            for ((f, t), l) in p.force.iter_mut().zip(p.torque.iter_mut()).zip(loads) {
                *f = Vec3::new(l[0], l[1], l[2]);
                *t = Vec3::new(l[3], l[4], l[5]);
            }
            for (w, f) in self.w.walls.iter_mut().zip(wall_forces) {
                w.force = Vec3::from(*f);
            }
        }
        self.budget = super::stability::EnergyBudget::start(self.mechanical_energy());
        Ok(())
    }
}
