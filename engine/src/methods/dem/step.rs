//! One DEM step, stage by stage ([`Stage`](super::Stage)): the neighbour refresh, the moving
//! boundaries (walls, grains glued to them, the periodic cell and its stress servo), then the
//! forces and the stability guard.

use rayon::prelude::*;

use super::integrate::Kin;
use super::tasks::LOOP_CHUNK;
use super::{pair_state, Dem, StageTimes, CHECK_EVERY, SERVO_EVERY};
use crate::contact::NormalForce;
use crate::error::EngineError;
use crate::math::{Real, Vec3};
use crate::scene::Deformation;

impl Dem {
    /// The stages of one step, in the order of [`Stage`](super::Stage).
    pub(super) fn step_stages(&mut self) -> Result<(), EngineError> {
        let mut clock = self.profile.map(|_| std::time::Instant::now());
        let mut lap = |slot: fn(&mut StageTimes) -> &mut f64, profile: &mut Option<StageTimes>| {
            if let (Some(c), Some(p)) = (clock.as_mut(), profile.as_mut()) {
                let now = std::time::Instant::now();
                *slot(p) += (now - *c).as_secs_f64();
                *c = now;
            }
        };
        // Stage::InitialIntegrate
        self.kick_and_drift();
        lap(|t| &mut t.integrate, &mut self.profile);
        // Stage::Boundaries
        self.boundaries();
        lap(|t| &mut t.boundaries, &mut self.profile);
        // Stage::NeighborUpdate
        let rebuild = match self.drift2.take() {
            Some(max2) => self.nl.needs_rebuild_after(max2, &self.w.domain),
            None => self.nl.needs_rebuild(&self.w.p.pos, &self.w.domain),
        } || self.wall_contacts.walls_moved(&self.w.walls, self.nl.skin);
        if rebuild {
            self.refresh_neighbors();
        }
        lap(|t| &mut t.neighbors, &mut self.profile);
        // Stage::Force, with Stage::FinalIntegrate fused into its gather.
        self.pair_forces();
        lap(|t| &mut t.pairs, &mut self.profile);
        self.wall_forces_and_gather(true);
        lap(|t| &mut t.forces, &mut self.profile);
        self.w.step += 1;
        self.w.time += self.dt;
        self.record_wall_work();
        lap(|t| &mut t.integrate, &mut self.profile);
        // Stage::Check
        if self.w.step.is_multiple_of(CHECK_EVERY) {
            self.check_stability()?;
        }
        lap(|t| &mut t.check, &mut self.profile);
        Ok(())
    }

    pub(super) fn refresh_neighbors(&mut self) {
        let domain = &self.w.domain;
        // Wrapping may shift velocities (Lees-Edwards images).
        self.xr_current = false;
        self.kin_current = false;
        self.w.p.pos.par_chunks_mut(LOOP_CHUNK).zip(self.w.p.vel.par_chunks_mut(LOOP_CHUNK)).for_each(|(xs, vs)| {
            for (x, v) in xs.iter_mut().zip(vs.iter_mut()) {
                domain.wrap(x, v);
            }
        });
        self.nl.rebuild(&self.w.p.pos, &self.w.p.radius, &self.w.domain);
        self.near.invalidate();
        pair_state::renumber(&mut self.pairs, &self.nl);
        self.bonds.rebuild(&self.nl, &self.w.p);
        self.wall_contacts.choose(&self.w.p, &self.w.walls, self.w.drum.as_ref(), self.nl.skin);
    }

    /// Moves the glued grains with their walls: each takes its wall's new velocity, and its
    /// position the correction of this step's drift (made with the velocity before the servo).
    fn move_glued(&mut self) {
        let dt = self.dt;
        let mut largest: Real = 0.0;
        for &(i, w) in &self.w.glued {
            let (i, v) = (i as usize, self.w.walls[w as usize].velocity);
            let correction = (v - self.w.p.vel[i]) * dt;
            self.w.p.pos[i] += correction;
            self.w.p.vel[i] = v;
            self.w.p.omega[i] = Vec3::zeros();
            let x = self.w.p.pos[i];
            self.xr[i] = [x.x, x.y, x.z, self.w.p.radius[i]];
            // A glued grain has no inverse mass: no acceleration to predict.
            self.kin[i] = Kin { vp: v, wp: Vec3::zeros() };
            largest = largest.max(correction.norm());
        }
        self.near.add_motion(largest);
    }
    /// Adds to each wall the load the other grains put on the grains glued to it.
    pub(super) fn glued_loads(&mut self) {
        for &(i, w) in &self.w.glued {
            let i = i as usize;
            let own = self.w.gravity * self.w.p.mass[i];
            self.w.walls[w as usize].force += self.w.p.force[i] - own;
        }
    }

    /// Diagonal of the stress tensor from the virial of the current forces and the kinetic part
    /// (Pa; velocities relative to the Lees-Edwards profile), and the affine estimate of the bulk
    /// stiffness of the contact network, `sum k |l|² / (D² V)` (Pa).
    ///
    /// The forces are the contacts' and the attraction of aggregates' primaries
    /// ([`bonds`](super::bonds)): without the attraction, the repulsion that balances it inside
    /// every aggregate reads as a pressure of order `p_I`, and a cell servoed to a lower pressure
    /// opened instead of closing.
    /// The stiffness is the contacts' alone (the attraction only softens a stretched bond).
    pub(super) fn stress_and_stiffness(&self) -> (Vec3, Real) {
        // Partial sums per particle block, added in order: the same result for any thread count.
        let p = &self.w.p;
        let partial: Vec<(Vec3, Real)> = self
            .pairs
            .par_iter()
            .map(|list| {
                let (mut virial, mut stiff) = (Vec3::zeros(), 0.0);
                for c in list.pairs() {
                    let (i, j) = (c.i as usize, c.j as usize);
                    let l = self.nl.separation(c.q as usize, &p.pos, &self.w.domain).0;
                    virial += c.out.force.component_mul(&l);
                    let (ri, rj) = (p.radius[i], p.radius[j]);
                    let delta = ri + rj - l.norm();
                    if delta > 0.0 {
                        let law = self.table.get(p.material[i] as usize, p.material[j] as usize);
                        stiff += law.normal.stiffness(delta, ri * rj / (ri + rj)) * l.norm_squared();
                    }
                }
                (virial, stiff)
            })
            .collect();
        let (virial, stiff) = partial.iter().fold((Vec3::zeros(), 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        let virial = virial + self.bond_virial();
        let (rate, ymid) = (self.w.domain.shear_rate, 0.5 * (self.w.domain.lo.y + self.w.domain.hi.y));
        let kinetic: Vec3 = p.vel.iter().zip(&p.pos).zip(&p.mass).fold(Vec3::zeros(), |acc, ((v, x), m)| {
            let mut u = *v;
            u.x -= rate * (x.y - ymid);
            acc + u.component_mul(&u) * *m
        });
        let (d, v) = (self.w.dim as Real, self.w.domain.volume());
        ((virial + kinetic) / v, stiff / (d * d * v))
    }

    fn boundaries(&mut self) {
        let dt = self.dt;
        for w in 0..self.w.walls.len() {
            let area = self.w.wall_area(self.w.walls[w].face.axis);
            let wall = &mut self.w.walls[w];
            let length = self.w.domain.length(wall.face.axis);
            wall.servo(area, length);
            wall.advance(dt);
            let a = wall.face.axis;
            if wall.face.upper {
                self.w.domain.hi[a] = wall.position;
            } else {
                self.w.domain.lo[a] = wall.position;
            }
        }
        if !self.w.glued.is_empty() {
            self.move_glued();
            self.drift2 = None;
        }
        self.w.domain.advance_shear(dt);
        if self.deformation.is_some() {
            if self.w.step.is_multiple_of(SERVO_EVERY)
                && matches!(
                    self.deformation.as_ref().map(|d| d.kind),
                    Some(Deformation::Pressure { .. } | Deformation::NormalStress { .. })
                )
            {
                let (stress, bulk) = self.stress_and_stiffness();
                if let Some(d) = self.deformation.as_mut() {
                    d.servo(stress, bulk, dt, &self.w.domain);
                }
            }
            if let Some(d) = &self.deformation {
                let (centre, scale) = d.deform(&mut self.w.domain, dt);
                // Bound on the affine displacement: particles lie within half a box length plus
                // the skin of the centre (they are wrapped only at neighbour builds).
                let bound: Real =
                    (0..self.w.dim).map(|a| ((0.5 * self.w.domain.length(a) + self.nl.skin) * (scale[a] - 1.0)).powi(2)).sum();
                self.near.add_motion(bound.sqrt());
                self.xr_current = false;
                self.drift2 = None;
                self.w.p.pos.par_chunks_mut(LOOP_CHUNK).for_each(|xs| {
                    for x in xs {
                        for a in 0..3 {
                            x[a] = centre[a] + (x[a] - centre[a]) * scale[a];
                        }
                    }
                });
            }
        }
    }
}
