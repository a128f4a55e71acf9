//! The relaxation of freshly grown aggregates ([`crate::particles::aggregate`]) before a run.
//!
//! A grown aggregate is a packing in which each primary touches the two it was placed against:
//! pulled together by the attraction and frictionless, it is not yet in equilibrium and
//! rearranges, its primaries moving by more than half a diameter. The sources relax their
//! aggregates before loading them; so does [`Cd::relax_aggregates`], with the walls held, no
//! gravity and no imposed motion, until the kinetic energy has fallen below
//! [`SETTLED`] of the bond energy scale `N F_0 ⟨a_0⟩`. The relaxation is preparation: a step
//! whose contact problem is not solved within the budget goes on (while primaries rearrange,
//! Gauss-Seidel can stall just above the tolerance), and the run's clock, step count and the
//! grains' initial velocities start after it. The measurements are in docs/methods/bpm.md.

use super::Cd;
use crate::contact::attraction_lj::characteristic_stress;
use crate::error::EngineError;
use crate::math::Real;
use crate::methods::rigid::settle::{settle_aggregates, Held, Settling};
use crate::particles::Particles;

/// Kinetic energy, as a fraction of `N F_0 ⟨a_0⟩`, below which the aggregates have settled
/// (measured: 1e-11 once settled at the solver tolerance 1e-6; 6e-5 while they rearrange).
pub(super) const SETTLED: Real = 1e-9;
/// Steps between two looks at the kinetic energy.
const CHECK_EVERY: u64 = 50;
/// Most relaxation steps (measured: the kinetic energy of one aggregate of 227 primaries was
/// down to 1e-11 of `N F_0 ⟨a_0⟩` by step 2,500 of 1e-7 s).
const MAX_STEPS: u64 = 20_000;

impl Cd {
    /// Relaxes the aggregates in place (module documentation); the error names the scene's
    /// solver settings if they do not settle in [`MAX_STEPS`].
    pub(super) fn relax_aggregates(&mut self) -> Result<(), EngineError> {
        if self.w.p.aggregate_count() == 0 {
            return Ok(());
        }
        let held = Held::hold(&mut self.w);
        let cell = self.cell.take();
        let tolerance = self.params.tolerance;
        self.lenient = true;
        let not_settled = EngineError::Build {
            field: "method.tolerance".into(),
            reason: format!(
                "the aggregates did not settle in {MAX_STEPS} steps (kinetic energy above {SETTLED:e} of N F_0 <a_0>): tighten the solver's tolerance (now {tolerance:e}; 1e-6 settled an aggregate of 227 primaries) or shorten method.time_step"
            ),
        };
        let settling = Settling { settled: SETTLED, check_every: CHECK_EVERY, max_steps: MAX_STEPS };
        let outcome = settle_aggregates(self, settling, not_settled);
        self.lenient = false;
        held.restore(&mut self.w);
        self.cell = cell;
        self.sweeps = 0;
        self.window.open(&self.w.p.vel, self.w.walls.len());
        outcome
    }
}

/// The speed `sqrt(p_I / ρ)` at which the primaries of an aggregate rearrange, m/s (0 without
/// aggregates): the largest over the primaries, `p_I` at `a_0` twice the primary's radius.
pub(super) fn bond_speed(p: &Particles, dim: usize) -> Real {
    (0..p.len())
        .filter_map(|i| {
            let b = p.bondings.get(*p.aggregate.get(i)? as usize)?;
            let density = p.mass[i] / Particles::volume_of(dim, p.radius[i]);
            Some((characteristic_stress(b.attraction.f0, 2.0 * p.radius[i], dim) / density).sqrt())
        })
        .fold(0.0, Real::max)
}
