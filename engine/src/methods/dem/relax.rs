//! Aggregates in DEM: the time step their attraction needs, and their relaxation before a run.
//!
//! A freshly grown aggregate ([`crate::particles::aggregate`]) is not in equilibrium: each
//! primary touches the two it was placed against and the attraction pulls the others in (see
//! `methods/cd/relax.rs`, which does the same for contact dynamics). [`Dem::relax_aggregates`]
//! lets the aggregates settle with the walls and the periodic cell held, no gravity and
//! Cundall's local damping ([`RELAX_DAMPING`]), until their kinetic energy has fallen below
//! [`SETTLED`] of the bond energy scale `N F_0 ⟨a_0⟩`; the run's clock, step count and the
//! grains' initial velocities start after it.

use super::timestep::CollisionTime;
use super::Dem;
use crate::error::EngineError;
use crate::math::Real;
use crate::methods::rigid::settle::{settle_aggregates, Held, Settling};
use crate::particles::Particles;

/// Kinetic energy, as a fraction of `N F_0 ⟨a_0⟩`, below which the aggregates have settled
/// (the value of contact dynamics' relaxation).
const SETTLED: Real = 1e-9;
/// Cundall's local damping while the aggregates settle (0.7: the usual quasi-static value,
/// which removes most of the kinetic energy of a mode within a few of its periods).
const RELAX_DAMPING: Real = 0.7;
/// Steps between two looks at the kinetic energy.
const CHECK_EVERY: u64 = 100;
/// Most relaxation steps (measured at the default step, t_c/50 of the sources' primaries with
/// k_n = 2e8 N/m: one aggregate of 222 primaries settled in 19,000 steps; 100 aggregates of
/// 30,262 primaries grew and settled in 598 s on one thread, about 34,000 steps at the run's
/// rate; the kinetic energy comes and goes as primaries rearrange, between 3e-4 and 3e-6 of
/// `N F_0 ⟨a_0⟩` until the last of them).
const MAX_STEPS: u64 = 500_000;

/// The collision time `c`, or the attraction's between two primaries of an aggregate if that
/// is shorter: at touching the attraction stiffens as `γ F_0 / a_0` ([`AttractionLj`]'s slope),
/// a spring between the lightest primary and its partner (`m* = m/2`), whose period the step
/// must resolve like a contact's.
///
/// [`AttractionLj`]: crate::contact::attraction_lj::AttractionLj
pub(super) fn with_bonds(c: CollisionTime, p: &Particles) -> CollisionTime {
    let mut best = c;
    for i in 0..p.len() {
        let Some(b) = p.bondings.get(p.aggregate[i] as usize) else { continue };
        let a = b.attraction;
        let k = a.gamma * a.f0 / (2.0 * p.radius[i]);
        let w0 = (k / (0.5 * p.mass[i])).sqrt();
        let t_c = std::f64::consts::PI / w0;
        if t_c < best.t_c {
            best = CollisionTime { t_c, dt_limit: 2.0 / w0, limiting: "attraction between the primaries of an aggregate".into() };
        }
    }
    best
}

impl Dem {
    /// Relaxes the aggregates in place (module documentation).
    pub(super) fn relax_aggregates(&mut self) -> Result<(), EngineError> {
        let held = Held::hold(&mut self.w);
        // The cell holds still too (as contact dynamics' does): a servo or imposed rate
        // running during the relaxation kept the aggregates moving, and they never settled.
        let (deformation, damping) = (self.deformation.take(), self.params.local_damping);
        self.params.local_damping = RELAX_DAMPING;
        self.kin_current = false;
        self.budget = super::stability::EnergyBudget::start(self.mechanical_energy());
        let not_settled = EngineError::Build {
            field: "method.time_step".into(),
            reason: format!(
                "the aggregates did not settle in {MAX_STEPS} steps of {:.3e} s (kinetic energy above {SETTLED:e} of N F_0 <a_0>): shorten the step (method.time_step_fraction, now {:.3}: at t_c/10 the damped contacts of the sources' primaries kept vibrating above it, at the default t_c/50 one aggregate settled within 20,000 steps)",
                self.dt,
                self.dt / self.collision.t_c
            ),
        };
        let settling = Settling { settled: SETTLED, check_every: CHECK_EVERY, max_steps: MAX_STEPS };
        let outcome = settle_aggregates(self, settling, not_settled);
        held.restore(&mut self.w);
        (self.deformation, self.params.local_damping) = (deformation, damping);
        self.kin_current = false;
        self.compute_forces(false);
        outcome
    }
}
