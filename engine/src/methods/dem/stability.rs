//! The stability guard of explicit DEM. Every few steps it checks for non-finite values,
//! overlaps beyond a stated fraction of the smaller radius, and mechanical energy growing beyond
//! the work put in by moving walls (gravity is part of the mechanical energy). It stops the run
//! with [`EngineError::Unstable`] naming the step, the cause and what to change.
//!
//! The energy budget is skipped when the periodic cell deforms, under Lees-Edwards shear, and
//! when gravity acts along a periodic axis: energy is then injected by the boundary in a way this
//! guard does not account for. Non-finite values and overlaps are always checked.

use rayon::prelude::*;

use super::pair_state::PairBlock;
use super::wall_contacts::{self, WallContact};
use super::Dem;
use crate::contact::NormalForce;
use crate::error::{EngineError, InstabilityCause};
use crate::math::{Real, Vec3};

/// Running account of mechanical energy and external work.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct EnergyBudget {
    /// The parts of the mechanical energy at the start, J.
    start: Energies,
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
    /// The attraction within aggregates ([`super::bonds`]): negative, zero for pairs apart.
    pub bond: Real,
}

impl Energies {
    pub(crate) fn total(&self) -> Real {
        self.kinetic + self.elastic + self.gravity + self.capillary + self.bond
    }
    fn scale(&self) -> Real {
        self.kinetic + self.elastic + self.capillary.abs()
    }
}

impl EnergyBudget {
    pub(crate) fn start(e: Energies) -> Self {
        Self { start: e, work_in: 0.0, scale: e.scale() }
    }
}

impl Energies {
    /// The part that grew the most from `start`, with its gain, J.
    fn largest_gain(&self, start: &Energies) -> (&'static str, Real) {
        [
            ("kinetic", self.kinetic - start.kinetic),
            ("elastic", self.elastic - start.elastic),
            ("gravitational", self.gravity - start.gravity),
            ("capillary", self.capillary - start.capillary),
            ("bond", self.bond - start.bond),
        ]
        .into_iter()
        .fold(("kinetic", Real::NEG_INFINITY), |best, part| if part.1 > best.1 { part } else { best })
    }
}

impl Dem {
    /// Kinetic, elastic, capillary, bond and gravitational energy.
    pub(crate) fn mechanical_energy(&self) -> Energies {
        self.scan().energies
    }

    /// The guard's measurements in two parallel passes, one over blocks of particles and one
    /// over the blocks of pair records, each block's terms summed in block order (the same
    /// value for any number of threads).
    fn scan(&self) -> Scan {
        // Per block of particles: the first non-finite particle, the kinetic energy, the
        // potential of gravity and of the centripetal field.
        let particles: Vec<ParticleTerms> = (0..self.w.p.len().div_ceil(BLOCK)).into_par_iter().map(|b| self.particle_terms(b)).collect();
        // Per block of pair and wall records: the largest overlap, the springs' and the bridges'
        // energy.
        let pairs: Vec<(Real, Real, Real)> =
            self.pairs.par_iter().zip(self.wall_contacts.records.par_iter()).map(|(list, walls)| self.contact_terms(list, walls)).collect();
        let mut scan = Scan { bad: particles.iter().find_map(|b| b.bad), ..Default::default() };
        for b in &particles {
            scan.energies.kinetic += b.kinetic;
            scan.energies.gravity += b.potential;
        }
        for (overlap, elastic, capillary) in &pairs {
            scan.energies.elastic += elastic;
            scan.energies.capillary += capillary;
            scan.overlap = scan.overlap.max(*overlap);
        }
        if !self.bonds.is_empty() {
            scan.energies.bond = self.bond_energy();
        }
        scan
    }

    /// Block `b` of particles' terms: its first non-finite particle, its kinetic energy, and
    /// its potential of gravity and of the centripetal field.
    fn particle_terms(&self, b: usize) -> ParticleTerms {
        let p = &self.w.p;
        let g = self.w.gravity;
        let r = b * BLOCK..((b + 1) * BLOCK).min(p.len());
        let bad = first_non_finite_in(p, r.clone());
        let mut kinetic = 0.0;
        let mut potential = 0.0;
        for i in r.clone() {
            kinetic += p.kinetic_energy_at(i, &p.vel[i]);
        }
        // Grains whose motion is imposed belong to the wall that carries them.
        if g != Vec3::zeros() {
            for i in r.clone().filter(|&i| p.is_free(i)) {
                potential -= p.mass[i] * g.dot(&p.pos[i]);
            }
        }
        // The centripetal field's potential, m a |x - c|.
        if let Some((c, a)) = self.w.field {
            for i in r.clone() {
                potential += p.mass[i] * a * (p.pos[i] - c).norm();
            }
        }
        ParticleTerms { bad, kinetic, potential }
    }

    /// A block of pair and wall records' terms: the largest overlap (over the smaller radius),
    /// the springs' energy and the bridges' energy.
    fn contact_terms(&self, list: &PairBlock, walls: &[WallContact]) -> (Real, Real, Real) {
        let p = &self.w.p;
        let (mut overlap, mut elastic, mut capillary) = (0.0, 0.0, 0.0);
        for c in walls {
            let i = c.i as usize;
            let rad = p.radius[i];
            let Some((_, delta, _)) = wall_contacts::touch(&self.w.walls, self.w.drum.as_ref(), &p.pos[i], rad, c.w as usize) else {
                continue;
            };
            overlap = Real::max(overlap, delta / rad);
            let law = self.wall_table.get(p.material[i] as usize, self.wall_material);
            elastic += law.normal.energy(delta, rad) + law.tangential.energy(c.xi.norm_squared(), delta, rad);
            if let Some(rr) = law.rolling {
                elastic += 0.5 * rr.stiffness * c.roll.norm_squared();
            }
        }
        for c in list.pairs() {
            let (i, j) = (c.i as usize, c.j as usize);
            let (d, _) = self.nl.separation(c.q as usize, &p.pos, &self.w.domain);
            let (ri, rj) = (p.radius[i], p.radius[j]);
            let dist = d.norm();
            let delta = ri + rj - dist;
            let law = self.table.get(p.material[i] as usize, p.material[j] as usize);
            if delta > 0.0 {
                overlap = Real::max(overlap, delta / ri.min(rj));
                let r_eff = ri * rj / (ri + rj);
                elastic += law.normal.energy(delta, r_eff) + law.tangential.energy(c.xi.norm_squared(), delta, r_eff);
                if let (Some(rr), Some(e)) = (law.rolling, c.extra) {
                    elastic += 0.5 * rr.stiffness * e.roll.norm_squared();
                }
            }
            if let (Some(true), Some(cap)) = (c.extra.map(|e| e.bridge), law.capillary) {
                capillary += cap.energy(dist - ri - rj, ri, rj);
            }
        }
        (overlap, elastic, capillary)
    }

    /// Adds the work done by moving walls during the last step.
    pub(crate) fn record_wall_work(&mut self) {
        for w in &self.w.walls {
            // The particles push the wall with `force`; the wall does -force·v on them.
            self.budget.work_in -= w.force.dot(&w.velocity) * self.dt;
        }
        if let Some(d) = &self.w.drum {
            // The drive turns the drum against the particles' torque.
            self.budget.work_in -= d.torque * d.angular_velocity * self.dt;
        }
    }

    fn energy_check_applies(&self) -> bool {
        let gravity_along_periodic = (0..self.w.dim).any(|a| self.w.domain.periodic[a] && self.w.gravity[a] != 0.0);
        self.deformation.is_none() && !self.w.domain.sheared() && !gravity_along_periodic
    }

    /// Builds the typed error for `cause`, with a suggestion that depends on the step in use:
    /// above the default t_c/50 it asks for t_c/50; at or below it, it never names the step in
    /// use again but says what else to change for what grew.
    pub(crate) fn unstable(&self, cause: InstabilityCause) -> EngineError {
        let c = &self.collision;
        let per_collision = c.t_c / self.dt;
        let now = format!(
            "dt = {:.3e} s = t_c/{per_collision:.0}, with the collision time t_c = {:.3e} s of the {} and velocity Verlet's stable limit {:.3e} s",
            self.dt, c.t_c, c.limiting, c.dt_limit
        );
        // The default fraction: a step above it is the first thing to change.
        let fraction = super::DemParams::default().time_step_fraction;
        let coarse = self.dt > fraction * c.t_c * (1.0 + 1e-9);
        let smaller_step = if coarse {
            format!("use dt <= t_c/{:.0} = {:.3e} s (method.time_step_fraction {fraction}; {now})", 1.0 / fraction, fraction * c.t_c)
        } else {
            format!(
                "{now}: the step already resolves the collisions, so halving it (method.time_step {:.3e} s) only tells a numerical growth, which follows the step, from one it does not change",
                0.5 * self.dt
            )
        };
        let suggestion = match &cause {
            InstabilityCause::Overlap { .. } if self.dt <= 0.1 * c.t_c => {
                let step = if coarse { format!("; {smaller_step}") } else { format!(" ({now})") };
                format!("the contacts are too soft for the load: raise the stiffness (k_n or E) or lower velocities, wall speeds or stresses{step}")
            }
            InstabilityCause::EnergyGrowth { part, .. } if !coarse => {
                let hint = match *part {
                    "elastic" => "springs that store energy faster than the collision time allows: a tangential stiffness k_t (or a rolling stiffness) far above k_n makes modes faster than t_c; lower it",
                    "capillary" => "bridges that form and break within a step: lower the rupture distance's ratio to the step's displacement (a smaller step or slower grains)",
                    "bond" => "primaries of an aggregate that fall into one another's attraction faster than the step resolves: a smaller step, or stiffer contacts between the primaries",
                    "gravitational" => "grains pushed up out of deep overlaps: lower the speeds or loads that make them, or stiffen the contacts",
                    _ => "forces that do work no spring stored: a contact stiffer than its collision time, or an imposed motion the budget does not count; lower the stiffest contact's k_n or the speeds",
                };
                format!("{hint}; {smaller_step}")
            }
            _ => smaller_step,
        };
        EngineError::Unstable { step: self.w.step, time: self.w.time, cause, suggestion }
    }

    /// Runs the guard now; returns the mechanical energy it measured on the way (a sample
    /// reports its elastic part without scanning again).
    pub(crate) fn check_stability(&mut self) -> Result<Energies, EngineError> {
        let scan = self.scan();
        if let Some(i) = scan.bad {
            return Err(self.unstable(InstabilityCause::NonFinite { particle: i }));
        }
        if scan.overlap > self.params.max_overlap {
            return Err(self.unstable(InstabilityCause::Overlap { fraction: scan.overlap, limit: self.params.max_overlap }));
        }
        if self.energy_check_applies() {
            let e = scan.energies;
            let b = &mut self.budget;
            // Like gravity's, the bond energy counts by its change: the binding energy of the
            // aggregates at rest is not an energy scale of their motion.
            let changes = (e.gravity - b.start.gravity).abs() + (e.bond - b.start.bond).abs();
            b.scale = b.scale.max(e.scale() + b.work_in.abs() + changes);
            let excess = e.total() - b.start.total() - b.work_in;
            if excess > ENERGY_TOLERANCE * b.scale && excess > 0.0 {
                let scale = b.scale;
                let (part, part_gain) = e.largest_gain(&b.start);
                return Err(self.unstable(InstabilityCause::EnergyGrowth { excess, scale, part, part_gain }));
            }
        }
        Ok(scan.energies)
    }

    /// Elastic energy stored in every contact (normal, tangential and rolling springs, pairs
    /// and walls), J.
    pub fn elastic_energy(&self) -> Real {
        self.scan().energies.elastic
    }
}

/// Particles per block of the guard's particle pass.
const BLOCK: usize = 4096;

/// What the guard's particle pass measures on one block ([`Dem::scan`]).
struct ParticleTerms {
    /// The block's first particle holding a non-finite value.
    bad: Option<usize>,
    /// Kinetic energy, J.
    kinetic: Real,
    /// Potential energy of gravity and of the centripetal field, J.
    potential: Real,
}

/// What the guard measures ([`Dem::scan`]).
#[derive(Debug, Clone, Copy, Default)]
struct Scan {
    /// The first particle holding a non-finite value.
    bad: Option<usize>,
    /// Largest overlap of a pair or a wall contact over the smaller radius.
    overlap: Real,
    /// Mechanical energy (its elastic part includes the walls' springs).
    energies: Energies,
}

/// The first particle of `r` whose position, velocity or force holds a non-finite value:
/// `x * 0` is 0 for a finite x and NaN otherwise, so the sum of them is 0 exactly when all the
/// values are finite (a plain loop the compiler vectorises; no overflow to fear).
fn first_non_finite_in(p: &crate::particles::Particles, r: std::ops::Range<usize>) -> Option<usize> {
    let zero = |v: &[Vec3]| v.iter().map(|x| (x * 0.0).sum()).sum::<Real>();
    if zero(&p.pos[r.clone()]) + zero(&p.vel[r.clone()]) + zero(&p.force[r.clone()]) == 0.0 {
        return None;
    }
    r.into_iter().find(|&i| ![p.pos[i], p.vel[i], p.force[i]].iter().all(|v| v.iter().all(|x| x.is_finite())))
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

    /// A grain resting on a floor, at `fraction` of the collision time.
    fn resting(fraction: f64) -> Dem {
        let scene = crate::methods::plan_scene(
            &serde_json::json!({
                "dimension": 2,
                "method": {"kind": "dem", "time_step_fraction": fraction},
                "materials": {"m": {"density": 2500.0, "contact": {"law": "linear", "k_n": 1e4}, "restitution": 0.5, "friction": 0.5}},
                "particles": [{"material": "m", "placement": {"kind": "list", "positions": [[0.02, 0.005]], "diameters": [0.01]}}],
                "container": {"min": [0, 0], "max": [0.04, 0.04], "wall_material": "m"},
                "gravity": [0, -9.81],
                "stop": {"steps": 1}
            })
            .to_string(),
        )
        .unwrap_or_else(|v| panic!("{v:?}"));
        let params = scene.params::<crate::methods::dem::DemParams>().expect("dem");
        Dem::new(&scene, params).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn the_advice_never_asks_for_the_step_in_use() {
        let causes = [
            InstabilityCause::NonFinite { particle: 0 },
            InstabilityCause::Overlap { fraction: 0.2, limit: 0.1 },
            InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part: "kinetic", part_gain: 1.0 },
            InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part: "elastic", part_gain: 1.0 },
            InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part: "gravitational", part_gain: 1.0 },
            InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part: "capillary", part_gain: 1.0 },
        ];
        // At the default step t_c/50 and finer: the step in use is stated, never asked for.
        for fraction in [0.02, 0.01] {
            let sim = resting(fraction);
            for cause in &causes {
                let EngineError::Unstable { suggestion, .. } = sim.unstable(cause.clone()) else { panic!("unstable") };
                assert!(!suggestion.contains("use dt"), "t_c × {fraction}, {cause}: {suggestion}");
                assert!(suggestion.contains(&format!("t_c/{:.0}", 1.0 / fraction)), "{suggestion}");
                if matches!(cause, InstabilityCause::EnergyGrowth { .. } | InstabilityCause::NonFinite { .. }) {
                    assert!(suggestion.contains("halving it"), "{suggestion}");
                }
            }
            // What grew decides the advice.
            let advice = |part| match sim.unstable(InstabilityCause::EnergyGrowth { excess: 1.0, scale: 1.0, part, part_gain: 1.0 }) {
                EngineError::Unstable { suggestion, .. } => suggestion,
                _ => String::new(),
            };
            assert!(advice("elastic").contains("k_t"));
            assert_ne!(advice("elastic"), advice("kinetic"));
        }
        // Above the default, the first thing to change is the step, to t_c/50.
        let sim = resting(0.1);
        for cause in &causes {
            let EngineError::Unstable { suggestion, .. } = sim.unstable(cause.clone()) else { panic!("unstable") };
            assert!(suggestion.contains("use dt <= t_c/50"), "{cause}: {suggestion}");
        }
    }

    #[test]
    fn the_largest_gain_names_the_part_that_grew() {
        let start = Energies { kinetic: 1.0, elastic: 2.0, gravity: 3.0, capillary: -1.0, bond: 0.0 };
        let now = Energies { kinetic: 1.5, elastic: 1.0, gravity: 3.2, capillary: -0.1, bond: 0.0 };
        assert_eq!(now.largest_gain(&start), ("capillary", 0.9));
        assert_eq!(Energies { elastic: 2.6, ..start }.largest_gain(&start).0, "elastic");
    }

    #[test]
    fn first_non_finite_names_the_first_bad_particle_of_a_range() {
        let mut p = particles(10_000);
        assert_eq!(first_non_finite_in(&p, 0..p.len()), None);
        // Huge but finite values are not flagged (their sum would overflow, not their x * 0).
        p.vel[3] = Vec3::repeat(Real::MAX);
        p.pos[4] = Vec3::repeat(-Real::MAX);
        assert_eq!(first_non_finite_in(&p, 0..p.len()), None);
        p.force[9_000].y = Real::NAN;
        assert_eq!(first_non_finite_in(&p, 0..p.len()), Some(9_000));
        p.vel[5_000].z = Real::NEG_INFINITY;
        assert_eq!(first_non_finite_in(&p, 0..p.len()), Some(5_000));
        p.pos[4_097].x = Real::INFINITY;
        assert_eq!(first_non_finite_in(&p, 0..p.len()), Some(4_097));
        // Within a block: only its own particles count.
        assert_eq!(first_non_finite_in(&p, 4_098..8_192), Some(5_000));
        assert_eq!(first_non_finite_in(&p, 5_001..8_192), None);
    }
}
