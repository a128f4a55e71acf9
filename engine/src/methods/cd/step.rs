//! One step of contact dynamics, stage by stage (the numbered stages of the module
//! documentation of [`super`]): the walls' velocities, the free motion, the contact problem,
//! the integration, the boundaries' reactions and motion, and the warm start of the next step;
//! with the step's length and the typed errors that stop a run.

use super::detect::Held;
use super::{world, Cd};
use crate::error::{EngineError, InstabilityCause};
use crate::loading::Wall;
use crate::math::{Real, Vec3};
use crate::nscd::{image_lever, RigidBodies};
use crate::nscd::{Mobility, Side};
use crate::scene::{Deformation, WallMotion};

impl Cd {
    /// The walls' velocities for the step before the contacts act: imposed ones (a wall driven
    /// at a strain rate takes it from the current length), and for a stress-controlled wall its
    /// velocity plus the push of its target stress over the step. Stress-controlled walls
    /// become free along their axis; when both walls of an axis are, they share one degree of
    /// freedom, the box length (each moves opposite to the other, with half its inverse mass):
    /// two independent free walls would let the box and its grains drift as a whole, at
    /// whatever velocity the compression left them.
    fn free_walls(&mut self) {
        let h = self.h;
        let stress = |w: &Wall| match w.motion {
            WallMotion::Stress { stress, .. } | WallMotion::Shearing { stress, .. } => Some(stress),
            _ => None,
        };
        for w in 0..self.w.walls.len() {
            let wall = &self.w.walls[w];
            let a = wall.face.axis;
            let area = world::wall_area(&self.w.domain, a);
            let mut axis = Vec3::zeros();
            axis[a] = 1.0;
            let Some(target) = stress(wall) else {
                let length = self.w.domain.length(a);
                // Sets the velocity of a wall driven at a strain rate (the others keep theirs).
                let wall = &mut self.w.walls[w];
                wall.servo(area, length);
                self.wall_vel[w] = wall.velocity;
                self.wall_mobility[w] = Mobility::FIXED;
                continue;
            };
            let partner = (0..self.w.walls.len()).find(|&o| o != w && self.w.walls[o].face.axis == a && stress(&self.w.walls[o]).is_some());
            let (push, inv_mass) = match partner {
                // The gap's velocity: each wall's inward speed, pushed by both targets against
                // both masses.
                Some(o) => {
                    let other = stress(&self.w.walls[o]).unwrap_or(0.0);
                    (0.5 * (target + other) * area * h / self.wall_mass, 0.5 / self.wall_mass)
                }
                None => (target * area * h / self.wall_mass, 1.0 / self.wall_mass),
            };
            // `max_speed` bounds the speed the wall moves at within the contact problem
            // (`Mobility::max_speed`), not the push: a wall at rest on the grains must still
            // push with its whole target.
            let max_speed = match wall.motion {
                WallMotion::Stress { max_speed, .. } | WallMotion::Shearing { max_speed, .. } => max_speed,
                _ => Real::INFINITY,
            };
            let n = wall.normal();
            // A shearing wall slides along its flow axis at its shear rate times the gap.
            let mut slide = Vec3::zeros();
            if let WallMotion::Shearing { shear_rate, flow, .. } = wall.motion {
                slide[flow] = shear_rate * self.w.domain.length(a);
            }
            self.wall_vel[w] = n * (wall.velocity.dot(&n) + push) + slide;
            self.wall_mobility[w] = Mobility { direction: axis, inv_mass, partner: partner.map(|o| o as u32), max_speed };
        }
        let k = self.cell_slot;
        (self.wall_vel[k], self.wall_mobility[k]) = match &self.cell {
            Some(cell) => cell.velocity(&self.w.domain, h),
            None => (Vec3::zeros(), Mobility::FIXED),
        };
        if self.wall_mobility[k].inv_mass == 0.0 {
            // Imposed rates: the velocity of the whole step.
            self.cell_vel = self.wall_vel[k];
        }
    }

    /// Length of the next step: `dt` if the scene gave `method.time_step`; otherwise `dt`
    /// shortened, if need be, so that no pair closes by more than `max_displacement` of the
    /// smallest diameter (two grains at the largest current speed, or a grain and a wall, head
    /// on, and accelerated towards each other by gravity and the centripetal field over the
    /// step). The default `dt` covers the imposed motions, but rigid grains squeezed between
    /// converging neighbours or struck by a wall can leave faster, and a pair that Moreau's
    /// anticipation has not caught interpenetrates by up to its closing over a step. The
    /// acceleration term matters for the granule's field (310 m/s² in
    /// `scenes/granule_full_3d.json`: 1.8e-4 s instead of the 4.4e-4 s of its imposed motions;
    /// at 4.4e-4 s a step's field impulse was so large against what the violation bound allows
    /// that Gauss-Seidel stalled on the gathered ball); under gravity alone the free fall across
    /// the box already sets a shorter `dt`.
    pub(super) fn step_length(&self) -> Real {
        if self.params.time_step.is_some() {
            return self.dt;
        }
        let fastest = |v: &[Vec3]| v.iter().map(|v| v.norm_squared()).fold(0.0, Real::max).sqrt();
        let rim = self.w.drum.as_ref().map_or(0.0, |d| (d.angular_velocity * d.def.radius).abs());
        let closing = 2.0 * fastest(&self.w.p.vel).max(fastest(&self.wall_vel)).max(rim);
        // Body forces close pairs too: two grains driven head on by accelerations up to
        // `accel` close by `accel h²` more over the step. The largest h with
        // `closing h + accel h² <= reach`, in the form that stays exact as accel goes to 0.
        let accel = self.w.gravity.norm() + self.w.field.map_or(0.0, |(_, a)| a.abs());
        let reach = self.params.max_displacement * self.d_min;
        let longest = 2.0 * reach / (closing + (closing * closing + 4.0 * accel * reach).sqrt());
        self.dt.min(longest)
    }

    /// The stages of one step, in the order of the module documentation.
    pub(super) fn step_stages(&mut self) -> Result<(), EngineError> {
        self.h = self.step_length();
        let (h, theta) = (self.h, self.params.theta);
        self.prepare()?;
        self.free_motion(h, theta);
        self.solve(h)?;
        self.integrate(h, theta);
        self.boundary_reactions(h);
        self.move_boundaries(h, theta);
        self.remember();
        self.w.step += 1;
        self.w.time += h;
        self.check()
    }

    /// Neighbours, the walls' velocities and the contacts of the step; an interpenetration
    /// beyond `max_interpenetration` stops the run here.
    fn prepare(&mut self) -> Result<(), EngineError> {
        if self.force_rebuild || self.nl.needs_rebuild(&self.w.p.pos, &self.w.domain) {
            self.refresh_neighbors();
        }
        // Glued grains move with their walls.
        for &(i, w) in &self.w.glued {
            self.w.p.vel[i as usize] = self.w.walls[w as usize].velocity;
            self.w.p.omega[i as usize] = Vec3::zeros();
        }
        self.free_walls();
        self.detect();
        if self.interpenetration.0 > self.params.max_interpenetration {
            return Err(
                self.unstable(InstabilityCause::Overlap { fraction: self.interpenetration.0, limit: self.params.max_interpenetration })
            );
        }
        Ok(())
    }

    /// Free motion under gravity and the centripetal field, if any (bodies of imposed motion
    /// keep theirs). The field acts at the grain's position at theta of the step, predicted
    /// with its start velocity: the theta-scheme's force `theta F(x+) + (1 - theta) F(x-)` to
    /// first order. At the start position, a granule swinging about the field's centre would
    /// gain energy at every step (for a linear force the scheme's determinant is
    /// 1 + h²ω²/2 at theta = 1/2); at the theta point it is 1 + (1 - 2 theta) h²ω²: none at
    /// 1/2, damped above.
    fn free_motion(&mut self, h: Real, theta: Real) {
        self.vel_start.copy_from_slice(&self.w.p.vel);
        self.omega_start.copy_from_slice(&self.w.p.omega);
        let g = self.w.gravity;
        let field = self.w.field;
        for ((v, im), x) in self.w.p.vel.iter_mut().zip(&self.w.p.inv_mass).zip(&self.w.p.pos) {
            if *im > 0.0 {
                let ahead = x + *v * (theta * h);
                *v += g * h;
                if let Some((centre, a)) = field {
                    let d = centre - ahead;
                    let r = d.norm();
                    if r > 0.0 {
                        *v += d * (a * h / r);
                    }
                }
            }
        }
    }

    /// The contact problem: NLGS finds the impulses and the end-of-step velocities. With the
    /// parallel sweep the contacts (and their status) are first stored in colour order. A
    /// solve that does not converge within the budget stops the run (unless `lenient`).
    fn solve(&mut self, h: Real) -> Result<(), EngineError> {
        let p = &mut self.w.p;
        let coloured = self.params.sweep.coloured(self.contacts.len());
        if coloured {
            self.colours.assign(&self.contacts, p.len(), &self.wall_mobility, &mut self.order);
            std::mem::swap(&mut self.contacts, &mut self.unordered);
            std::mem::swap(&mut self.status, &mut self.unordered_status);
            self.contacts.clear();
            self.contacts.extend(self.order.iter().map(|&k| self.unordered[k as usize]));
            self.status.clear();
            self.status.extend(self.order.iter().map(|&k| self.unordered_status[k as usize]));
        }
        let mut bodies = RigidBodies {
            vel: &mut p.vel,
            omega: &mut p.omega,
            inv_mass: &p.inv_mass,
            inv_inertia: &p.inv_inertia,
            boundary_vel: &mut self.wall_vel,
            boundary_mobility: &self.wall_mobility,
            boundary_omega: &self.wall_omega,
        };
        self.report = self.solver.solve(&mut self.contacts, &mut bodies, h, self.w.mean_diameter, coloured.then_some(&self.colours));
        self.sweeps += u64::from(self.report.iterations);
        if !self.report.converged && !self.lenient {
            let r = self.report;
            return Err(self.unstable(InstabilityCause::SolverBudget {
                iterations: r.iterations,
                change: r.last.change,
                violation: r.last.violation,
                tolerance: self.params.tolerance,
                violation_tolerance: self.solver.settings.violation_tolerance,
                worst: r.last.worst,
                worst_tolerance: self.solver.settings.worst_tolerance,
            }));
        }
        Ok(())
    }

    /// Theta-scheme positions; mean forces and torques over the step. The glued grains end the
    /// step with their walls.
    fn integrate(&mut self, h: Real, theta: Real) {
        for &(i, w) in &self.w.glued {
            self.w.p.vel[i as usize] = self.wall_vel[w as usize];
        }
        let p = &mut self.w.p;
        for i in 0..p.len() {
            let (v0, v1) = (self.vel_start[i], p.vel[i]);
            let dx = (v1 * theta + v0 * (1.0 - theta)) * h;
            p.pos[i] += dx;
            self.window.travel(i, dx);
            p.force[i] = (v1 - v0) * (p.mass[i] / h);
            let inertia = if p.inv_inertia[i] > 0.0 { 1.0 / p.inv_inertia[i] } else { 0.0 };
            p.torque[i] = (p.omega[i] - self.omega_start[i]) * (inertia / h);
        }
    }

    /// Walls and drum take the reaction of their contacts.
    fn boundary_reactions(&mut self, h: Real) {
        for w in &mut self.w.walls {
            w.force = Vec3::zeros();
        }
        if let Some(d) = &mut self.w.drum {
            (d.force, d.torque) = (Vec3::zeros(), 0.0);
        }
        for c in &self.contacts {
            let Side::Boundary(w) = c.j else { continue };
            let f = c.force(h);
            match self.w.walls.get_mut(w as usize) {
                Some(wall) => {
                    wall.force -= f;
                    self.window.wall_impulse(w as usize, -c.frame.to_global(&c.r));
                }
                None => {
                    if let Some(d) = &mut self.w.drum {
                        // The force at the contact point, and the rolling moment.
                        d.force -= f;
                        d.torque -= d.torque_of(&d.surface_point(&self.w.p.pos[c.i as usize]), &f) + c.rolling.m[d.def.axis] / h;
                    }
                }
            }
        }
    }

    /// The boundaries move: the deforming cell (from the generalised impulse of the contacts
    /// across it), the Lees-Edwards offset and the walls, by the theta-scheme.
    fn move_boundaries(&mut self, h: Real, theta: Real) {
        if let Some(cell) = &mut self.cell {
            // Each contact's impulse on the image's side, through its lever k ⊙ direction (zero
            // direction for imposed rates).
            let direction = self.wall_mobility[self.cell_slot].direction;
            let mut impulse = 0.0;
            for c in &self.contacts {
                if let Side::Image { k, .. } = c.j {
                    impulse -= c.frame.to_global(&c.r).dot(&image_lever(k, &direction));
                }
            }
            self.window.cell_impulse(impulse);
            self.cell_vel = cell.finish(&mut self.w.domain, self.cell_vel, self.wall_vel[self.cell_slot], h, theta);
        }
        self.window.advance(h);
        self.w.domain.advance_shear(h);
        for (wall, v1) in self.w.walls.iter_mut().zip(self.wall_vel.iter()) {
            let a = wall.face.axis;
            wall.position += h * (theta * v1[a] + (1.0 - theta) * wall.velocity[a]);
            wall.velocity = *v1;
            if wall.face.upper {
                self.w.domain.hi[a] = wall.position;
            } else {
                self.w.domain.lo[a] = wall.position;
            }
        }
    }

    /// Which contacts press, from their impulses and end-of-step normal velocities; then the
    /// warm start of the next step: this step's impulses by pair.
    fn remember(&mut self) {
        for (c, s) in self.contacts.iter().zip(self.status.iter_mut()) {
            let u_n = c.frame.n.dot(&c.relative_velocity(&self.w.p.vel, &self.w.p.omega, &self.wall_vel));
            s.pressed = c.law.contact_part(c.r.x, u_n) > 0.0;
        }
        self.previous.clear();
        self.previous.extend(
            self.contacts
                .iter()
                .zip(&self.status)
                .filter(|(c, s)| c.r != Vec3::zeros() || c.rolling.m != Vec3::zeros() || s.bridge || s.pressed)
                .map(|(c, s)| {
                    let turned = if c.i == s.key.0 { 1.0 } else { -1.0 };
                    Held { key: s.key, r: c.frame.to_global(&c.r) * turned, m: c.rolling.m * turned, pressed: s.pressed, bridge: s.bridge }
                }),
        );
        self.previous.sort_unstable_by_key(|e| e.key);
    }

    /// Non-finite positions or velocities stop the run.
    pub(super) fn check(&self) -> Result<(), EngineError> {
        match self.w.non_finite() {
            Some(i) => Err(self.unstable(InstabilityCause::NonFinite { particle: i })),
            None => Ok(()),
        }
    }

    /// Whether something imposes a motion on the grains: a wall's velocity or strain rate, the
    /// cell's strain rate, a Lees-Edwards shear, a turning drum.
    pub(super) fn imposes_motion(&self) -> bool {
        let walls = self.w.walls.iter().any(|w| match w.motion {
            WallMotion::Velocity(v) => v != Vec3::zeros(),
            WallMotion::StrainRate(r) => r != 0.0,
            WallMotion::Shearing { shear_rate, .. } => shear_rate != 0.0,
            WallMotion::Fixed | WallMotion::Stress { .. } => false,
        });
        let cell = self.cell.as_ref().is_some_and(|c| matches!(c.kind, Deformation::StrainRate(r) if r != Vec3::zeros()));
        let drum = self.wall_omega.iter().any(|w| *w != Vec3::zeros());
        walls || cell || drum || self.w.domain.sheared()
    }

    /// Builds the typed error for `cause`, with what to change.
    pub(super) fn unstable(&self, cause: InstabilityCause) -> EngineError {
        // The violation bound in effect, and the field that sets it ([`Cd::stage`]).
        let bound = self.solver.settings.violation_tolerance;
        let field = if bound == self.params.violation_bound(self.w.dim) { "violation_tolerance" } else { "loading_violation_tolerance" };
        let suggestion = match &cause {
            InstabilityCause::SolverBudget { .. } => {
                // Rigid grains cannot follow an imposed motion that squeezes or shears a jammed
                // packing at constant volume: the contact problem then has no solution, and no
                // budget helps. Say so when something imposes a motion.
                let imposed = if self.imposes_motion() {
                    "; if the packing is jammed, an imposed motion (a wall's velocity or strain rate, the cell's strain rate, a Lees-Edwards shear at constant volume) that squeezes it has no solution with rigid grains: stop it earlier, or hold a stress instead"
                } else {
                    ""
                };
                format!(
                    "raise method.max_iterations (now {}), loosen method.tolerance (now {:.1e}) or method.{field} (now {bound:.1e}), raise method.slop (now {:.1e}; no contact may go deeper over a step than a tenth of it), or lower method.time_step (now {:.3e} s): fewer contacts change per step{imposed}",
                    self.params.max_iterations, self.params.tolerance, self.params.slop, self.dt
                )
            }
            InstabilityCause::Overlap { .. } => format!(
                "lower method.time_step (now {:.3e} s) so that grains move less per step, or tighten method.{field} (now {bound:.1e})",
                self.dt
            ),
            _ => format!("lower method.time_step (now {:.3e} s)", self.dt),
        };
        EngineError::Unstable { step: self.w.step, time: self.w.time, cause, suggestion }
    }
}
