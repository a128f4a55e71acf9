//! The stability guard of explicit DEM. Every few steps it checks for non-finite values,
//! overlaps beyond a stated fraction of the smaller radius, and mechanical energy growing beyond
//! the work put in by moving walls (gravity is part of the mechanical energy). It stops the run
//! with [`EngineError::Unstable`] naming the step, the cause and what to change.
//!
//! The energy budget is skipped when the periodic cell deforms, under Lees-Edwards shear, and
//! when gravity acts along a periodic axis: energy is then injected by the boundary in a way this
//! guard does not account for. Non-finite values and overlaps are always checked.

use rayon::prelude::*;

use super::Dem;
use crate::error::{EngineError, InstabilityCause};
use crate::math::{Real, Vec3};

/// Running account of mechanical energy and external work.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct EnergyBudget {
    /// Mechanical energy at the start, J.
    start: Real,
    /// Gravitational energy at the start, J.
    gravity0: Real,
    /// Work done on the particles by moving walls since the start, J.
    work_in: Real,
    /// Largest energy scale seen (kinetic + elastic + |capillary| + |gravity change|), J.
    scale: Real,
}

/// Fraction of the energy scale that the unexplained gain may reach before the run stops.
/// Velocity Verlet at dt <= t_c/10 errs by well under 1% per collision; an unstable integration
/// grows exponentially and crosses this within a few checks.
const ENERGY_TOLERANCE: Real = 0.2;

/// Parts of the mechanical energy, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Energies {
    pub kinetic: Real,
    pub elastic: Real,
    pub gravity: Real,
    pub capillary: Real,
}

impl Energies {
    pub(crate) fn total(&self) -> Real {
        self.kinetic + self.elastic + self.gravity + self.capillary
    }
    fn scale(&self) -> Real {
        self.kinetic + self.elastic + self.capillary.abs()
    }
}

impl EnergyBudget {
    pub(crate) fn start(e: Energies) -> Self {
        Self { start: e.total(), gravity0: e.gravity, work_in: 0.0, scale: e.scale() }
    }
}

impl Dem {
    /// Kinetic, elastic, capillary and gravitational energy.
    pub(crate) fn mechanical_energy(&self) -> Energies {
        let p = &self.p;
        let kinetic = block_sum(p.len(), |i| p.kinetic_energy_at(i, &p.vel[i]));
        let elastic = self.elastic_energy();
        let g = self.gravity;
        // Grains whose motion is imposed belong to the wall that carries them.
        let mut gravity =
            if g == Vec3::zeros() { 0.0 } else { -block_sum(p.len(), |i| if p.is_free(i) { p.mass[i] * g.dot(&p.pos[i]) } else { 0.0 }) };
        // The centripetal field's potential, m a |x - c|.
        if let Some((c, a)) = self.field {
            gravity += block_sum(p.len(), |i| p.mass[i] * a * (p.pos[i] - c).norm());
        }
        let mut capillary = 0.0;
        for c in self.contacts.iter().flatten().filter(|c| c.extra.bridge) {
            let (i, j) = (c.i as usize, c.j as usize);
            if let Some(cap) = self.table.get(p.material[i] as usize, p.material[j] as usize).capillary {
                let (d, _) = self.nl.separation(c.q as usize, &p.pos, &self.domain);
                capillary += cap.energy(d.norm() - p.radius[i] - p.radius[j], p.radius[i], p.radius[j]);
            }
        }
        Energies { kinetic, elastic, gravity, capillary }
    }

    /// Adds the work done by moving walls during the last step.
    pub(crate) fn record_wall_work(&mut self) {
        for w in &self.walls {
            // The particles push the wall with `force`; the wall does -force·v on them.
            self.budget.work_in -= w.force.dot(&w.velocity) * self.dt;
        }
        if let Some(d) = &self.drum {
            // The drive turns the drum against the particles' torque.
            self.budget.work_in -= d.torque * d.angular_velocity * self.dt;
        }
    }

    fn energy_check_applies(&self) -> bool {
        let gravity_along_periodic = (0..self.dim).any(|a| self.domain.periodic[a] && self.gravity[a] != 0.0);
        self.deformation.is_none() && !self.domain.sheared() && !gravity_along_periodic
    }

    /// Builds the typed error for `cause`, with a suggestion.
    pub(crate) fn unstable(&self, cause: InstabilityCause) -> EngineError {
        let c = &self.collision;
        let step_fix = format!(
            "dt = {:.3e} s against a collision time t_c = {:.3e} s ({}); the stable limit of velocity Verlet is about {:.3e} s: \
             use dt <= t_c/50 = {:.3e} s (method.time_step_fraction 0.02)",
            self.dt,
            c.t_c,
            c.limiting,
            c.dt_limit,
            c.t_c / 50.0
        );
        let suggestion = match &cause {
            InstabilityCause::Overlap { .. } if self.dt <= 0.1 * c.t_c => format!(
                "the contacts are too soft for the load: raise the stiffness (k_n or E) or lower velocities, wall speeds or stresses ({step_fix})"
            ),
            _ => step_fix,
        };
        EngineError::Unstable { step: self.step, time: self.time, cause, suggestion }
    }

    /// Runs the guard now.
    pub(crate) fn check_stability(&mut self) -> Result<(), EngineError> {
        let p = &self.p;
        let bad = first_non_finite(p);
        if let Some(i) = bad {
            return Err(self.unstable(InstabilityCause::NonFinite { particle: i }));
        }
        let worst = self.max_overlap_fraction();
        if worst > self.params.max_overlap {
            return Err(self.unstable(InstabilityCause::Overlap { fraction: worst, limit: self.params.max_overlap }));
        }
        if self.energy_check_applies() {
            let e = self.mechanical_energy();
            let b = &mut self.budget;
            b.scale = b.scale.max(e.scale() + b.work_in.abs() + (e.gravity - b.gravity0).abs());
            let excess = e.total() - b.start - b.work_in;
            if excess > ENERGY_TOLERANCE * b.scale && excess > 0.0 {
                let scale = b.scale;
                return Err(self.unstable(InstabilityCause::EnergyGrowth { excess, scale }));
            }
        }
        Ok(())
    }

    /// Largest overlap divided by the smaller radius, over pairs and walls.
    pub(crate) fn max_overlap_fraction(&self) -> Real {
        let p = &self.p;
        // Only interacting pairs can overlap: the others were found apart at the last force stage.
        let pairs = self
            .contacts
            .par_iter()
            .map(|list| {
                list.iter()
                    .map(|c| {
                        let (i, j) = (c.i as usize, c.j as usize);
                        let (d, _) = self.nl.separation(c.q as usize, &p.pos, &self.domain);
                        let (ri, rj) = (p.radius[i], p.radius[j]);
                        ((ri + rj - d.norm()) / ri.min(rj)).max(0.0)
                    })
                    .fold(0.0, Real::max)
            })
            .reduce(|| 0.0, Real::max);
        let walls = self
            .walls
            .iter()
            .map(|w| {
                let n: Vec3 = w.normal();
                (0..p.len())
                    .map(|i| ((p.radius[i] - (p.pos[i][w.face.axis] - w.position) * n[w.face.axis]) / p.radius[i]).max(0.0))
                    .fold(0.0, Real::max)
            })
            .fold(0.0, Real::max);
        let drum = self.drum.as_ref().map_or(0.0, |d| {
            (0..p.len()).filter_map(|i| d.touch(&p.pos[i], p.radius[i]).map(|(_, delta)| delta / p.radius[i])).fold(0.0, Real::max)
        });
        pairs.max(walls).max(drum)
    }
}

/// The first particle whose position, velocity or force holds a non-finite value. By blocks:
/// `x * 0` is 0 for a finite x and NaN otherwise, so a block's sum of them is 0 exactly when
/// all its values are finite (a plain loop the compiler vectorises; no overflow to fear).
fn first_non_finite(p: &crate::particles::Particles) -> Option<usize> {
    const BLOCK: usize = 4096;
    let finite = |i: usize| [p.pos[i], p.vel[i], p.force[i]].iter().all(|v| v.iter().all(|x| x.is_finite()));
    (0..p.len().div_ceil(BLOCK)).into_par_iter().find_map_first(|b| {
        let r = b * BLOCK..((b + 1) * BLOCK).min(p.len());
        let zero = |v: &[Vec3]| v.iter().map(|x| (x * 0.0).sum()).sum::<Real>();
        let sum = zero(&p.pos[r.clone()]) + zero(&p.vel[r.clone()]) + zero(&p.force[r.clone()]);
        if sum == 0.0 {
            None
        } else {
            r.into_iter().find(|&i| !finite(i))
        }
    })
}

/// Sum of `f(i)` over `0..n`, by fixed blocks added in order: the same value for any number of
/// threads.
fn block_sum(n: usize, f: impl Fn(usize) -> Real + Sync) -> Real {
    const BLOCK: usize = 4096;
    let partial: Vec<Real> = (0..n.div_ceil(BLOCK)).into_par_iter().map(|b| (b * BLOCK..((b + 1) * BLOCK).min(n)).map(&f).sum()).collect();
    partial.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::particles::Particles;

    fn particles(n: usize) -> Particles {
        let mut p = Particles::default();
        for i in 0..n {
            p.push(3, Vec3::new(i as Real, 0.0, 0.0), Vec3::zeros(), 0.5, 1000.0, 0, false);
        }
        p
    }

    #[test]
    fn first_non_finite_names_the_first_bad_particle_in_any_block() {
        let mut p = particles(10_000);
        assert_eq!(first_non_finite(&p), None);
        // Huge but finite values are not flagged (their sum would overflow, not their x * 0).
        p.vel[3] = Vec3::repeat(Real::MAX);
        p.pos[4] = Vec3::repeat(-Real::MAX);
        assert_eq!(first_non_finite(&p), None);
        p.force[9_000].y = Real::NAN;
        assert_eq!(first_non_finite(&p), Some(9_000));
        p.vel[5_000].z = Real::NEG_INFINITY;
        assert_eq!(first_non_finite(&p), Some(5_000));
        p.pos[4_097].x = Real::INFINITY;
        assert_eq!(first_non_finite(&p), Some(4_097));
    }
}
