//! The relaxation of freshly grown aggregates before a run, as both rigid-grain methods run it:
//! what is held still meanwhile ([`Held`]) and the loop that steps until the primaries settle
//! ([`settle_aggregates`]). Each method chooses its own thresholds and what else it holds.

use super::{RigidMethod, RigidWorld};
use crate::error::EngineError;
use crate::math::{Real, Vec3};
use crate::particles::aggregate::NO_AGGREGATE;
use crate::scene::WallMotion;

/// How long the aggregates of a run may take to relax before it ([`settle_aggregates`]).
#[derive(Debug, Clone, Copy)]
pub struct Settling {
    /// Kinetic energy of the primaries, as a fraction of `N F_0 ⟨a_0⟩`, below which they have
    /// settled.
    pub settled: Real,
    /// Steps between two looks at the kinetic energy.
    pub check_every: u64,
    /// Most steps.
    pub max_steps: u64,
}

/// What a relaxation of aggregates holds still while they settle and gives back after: the
/// walls' motions, gravity, the centripetal field and the particles' velocities (the run's
/// initial velocities start after it).
pub struct Held {
    motions: Vec<(WallMotion, Vec3)>,
    gravity: Vec3,
    field: Option<(Vec3, Real)>,
    vel: Vec<Vec3>,
    omega: Vec<Vec3>,
}

impl Held {
    /// Holds the walls fixed, turns gravity and the field off and the particles at rest.
    pub fn hold(w: &mut RigidWorld) -> Self {
        let motions = w.walls.iter().map(|w| (w.motion, w.velocity)).collect();
        for wall in w.walls.iter_mut() {
            (wall.motion, wall.velocity) = (WallMotion::Fixed, Vec3::zeros());
        }
        let held = Held {
            motions,
            gravity: std::mem::replace(&mut w.gravity, Vec3::zeros()),
            field: w.field.take(),
            vel: w.p.vel.clone(),
            omega: w.p.omega.clone(),
        };
        w.p.vel.iter_mut().for_each(|v| *v = Vec3::zeros());
        w.p.omega.iter_mut().for_each(|v| *v = Vec3::zeros());
        held
    }

    /// Gives back what [`Held::hold`] took, and restarts the clock: the run starts after the
    /// relaxation.
    pub fn restore(self, w: &mut RigidWorld) {
        for (wall, (motion, velocity)) in w.walls.iter_mut().zip(self.motions) {
            (wall.motion, wall.velocity) = (motion, velocity);
        }
        (w.gravity, w.field) = (self.gravity, self.field);
        w.p.vel = self.vel;
        w.p.omega = self.omega;
        w.step = 0;
        w.time = 0.0;
    }
}

/// Steps `sim` until the kinetic energy of the primaries of its aggregates falls to
/// `s.settled` of their bond energy scale `N F_0 ⟨a_0⟩`, looking every `s.check_every` steps,
/// for at most `s.max_steps`; then `not_settled` is the error. An instability comes back with
/// "while the aggregates relaxed before the run" in its suggestion. The caller holds the walls,
/// gravity and whatever else must not act meanwhile ([`Held`]), and restores them after.
pub fn settle_aggregates<M: RigidMethod>(sim: &mut M, s: Settling, not_settled: EngineError) -> Result<(), EngineError> {
    let p = &sim.world().p;
    let primaries: Vec<usize> = (0..p.len()).filter(|&i| p.aggregate[i] != NO_AGGREGATE).collect();
    let scale: Real =
        primaries.iter().map(|&i| p.bondings.get(p.aggregate[i] as usize).map_or(0.0, |b| b.attraction.f0) * 2.0 * p.radius[i]).sum();
    for k in 1..=s.max_steps {
        if let Err(e) = sim.advance() {
            return Err(match e {
                EngineError::Unstable { step, time, cause, suggestion } => EngineError::Unstable {
                    step,
                    time,
                    cause,
                    suggestion: format!("while the aggregates relaxed before the run: {suggestion}"),
                },
                other => other,
            });
        }
        if k % s.check_every == 0 {
            let p = &sim.world().p;
            let kinetic: Real = primaries.iter().map(|&i| p.kinetic_energy_at(i, &p.vel[i])).sum();
            if kinetic <= s.settled * scale {
                return Ok(());
            }
        }
    }
    Err(not_settled)
}
