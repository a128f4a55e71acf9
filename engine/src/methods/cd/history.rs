//! Contact dynamics' history in a checkpoint ([`crate::resume`]): what each pair carried at the
//! end of the last step (its impulse, the next solve's warm start; whether it pressed; its
//! capillary bridge), written from and set back into [`Cd::previous`], in a simulation built
//! from the checkpoint's state, whose particles keep the state's order.

use super::detect::{Held, WALL_KEY};
use super::Cd;
use crate::error::EngineError;
use crate::math::Vec3;
use crate::resume::{ContactHistory, ImpulseContact, Other};

impl Cd {
    /// What each pair carried at the end of the last step.
    pub(super) fn impulses(&self) -> ContactHistory {
        let n = self.w.p.len() as u32;
        let contacts = self
            .previous
            .iter()
            .map(|h| {
                let (i, j) = h.key;
                // Particle keys are below the particle count; boundary keys count down from the top.
                let with = if j < n { Other::Particle(j) } else { Other::Boundary((WALL_KEY - j) as u16) };
                ImpulseContact { i, with, impulse: h.r.into(), moment: h.m.into(), pressed: h.pressed, bridge: h.bridge }
            })
            .collect();
        ContactHistory::Impulses { contacts }
    }

    /// Sets back what each pair of `history` carried, as the next step's warm start.
    pub(super) fn set_impulses(&mut self, history: Option<&ContactHistory>) -> Result<(), EngineError> {
        let refuse = |reason: String| EngineError::Build { field: "checkpoint.carried.contacts".into(), reason };
        let contacts = match history {
            None => &[][..],
            Some(ContactHistory::Impulses { contacts }) => contacts.as_slice(),
            Some(ContactHistory::Springs { .. }) => return Err(refuse("DEM springs cannot go on as impulses of contact dynamics".into())),
        };
        let n = self.w.p.len();
        let slots = self.cell_slot + 1;
        let mut held = Vec::with_capacity(contacts.len());
        for c in contacts {
            if c.i as usize >= n {
                return Err(refuse(format!("particle {} does not exist: the state has {n}", c.i)));
            }
            let key = match c.with {
                Other::Particle(j) if (j as usize) < n && j != c.i => (c.i, j),
                Other::Boundary(w) if (w as usize) < slots => (c.i, WALL_KEY - u32::from(w)),
                other => return Err(refuse(format!("particle {} carries a contact with {other:?}, which does not exist", c.i))),
            };
            let (r, m) = (Vec3::from(c.impulse), Vec3::from(c.moment));
            if !(r.iter().chain(m.iter()).all(|x| x.is_finite())) {
                return Err(refuse(format!("the impulses of particle {} are not finite", c.i)));
            }
            held.push(Held { key, r, m, pressed: c.pressed, bridge: c.bridge });
        }
        held.sort_unstable_by_key(|h| h.key);
        held.dedup_by_key(|h| h.key);
        self.previous = held;
        Ok(())
    }
}
