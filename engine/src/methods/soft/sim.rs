//! A method of soft grains on a scene, as a [`Simulation`]: the method's system of grains
//! ([`SoftSystem`]: the material point method's or the finite element method's), the
//! container's walls driven as for the other methods ([`crate::loading::Wall`]: fixed, at a
//! velocity, at a strain rate or at a stress) and copied onto the system's planes each step, and
//! the shared metrics measured on the grains as disks of their current area
//! ([`crate::observe::DeformableView`]).
//!
//! A stress-controlled wall ([`Wall::servo`]) gets, unless the scene gives one, the gain
//! `½ L / (n E' dt)` (m/(s·Pa)): `L` the box's length along its axis, `n` the servo walls on
//! that axis, `E' = E / (1 − ν²)` the stiffest grain's plane-strain modulus. A packing is no
//! stiffer than its grains, so one step changes the wall stress by at most half the error:
//! stable for any packing, and within a few steps of the target once the grains are pressed
//! together (looser packings answer more slowly, at the wall's `max_speed`).

use nalgebra::Vector2;

use super::contact::Wall as PlaneWall;
use super::measure::GrainState;
use super::parts::Cost;
use super::progress::Progress;
use super::trace::{NewtonSink, Tracer};
use crate::error::{EngineError, InstabilityCause};
use crate::geometry::Domain;
use crate::loading::Wall;
use crate::math::{Real, Vec3};
use crate::methods::world;
use crate::observe::{
    measure, rattler_threshold, ContactRecord, DeformableSample, DeformableView, MaterialPoints, Sample, Snapshot, SystemView,
};
use crate::particles::Particles;
use crate::resume::Clock;
use crate::run::{Balance, Simulation};
use crate::scene::{Controls, Material, Scene, StateFile, WallMotion};

type V2 = Vector2<Real>;

/// What a soft-grain method's system of grains offers its [`SoftSim`].
pub trait SoftSystem: Send {
    /// Advances one step; returns its Newton iterations and contact sweeps.
    fn advance(&mut self) -> Result<(u32, u32), InstabilityCause>;
    /// Steps, time and costs so far, the walls' loads of the last step.
    fn progress(&self) -> &Progress;
    /// The same, to set the clock of a run that resumes from a checkpoint.
    fn progress_mut(&mut self) -> &mut Progress;
    /// Steps done.
    fn steps(&self) -> u64 {
        self.progress().steps
    }
    /// Time, s.
    fn time(&self) -> Real {
        self.progress().time
    }
    /// Gravity, m/s².
    fn gravity(&self) -> V2;
    /// The planes the grains touch (the container's walls, in its order).
    fn planes_mut(&mut self) -> &mut [PlaneWall];
    /// The impulse the grains gave each wall over the last step, N·s/m.
    fn wall_impulse(&self) -> &[V2] {
        &self.progress().wall_impulse
    }
    /// The force the grains exert on each wall at the step's end, N/m.
    fn wall_force(&self) -> &[V2] {
        &self.progress().wall_force
    }
    /// Every grain now.
    fn grain_states(&self) -> Vec<GrainState>;
    /// The contacts of the last step as the metrics count them (`grains` from
    /// [`SoftSystem::grain_states`]).
    fn contact_records(&self, grains: &[GrainState]) -> Vec<ContactRecord>;
    /// Kinetic energy, J/m.
    fn kinetic_energy(&self) -> Real;
    /// Energy stored in the grains, J/m.
    fn strain_energy(&self) -> Real;
    /// Smallest `det F` anywhere.
    fn min_jacobian(&self) -> Real;
    /// The grains' solid area now, m² per metre.
    fn solid_area(&self) -> Real;
    /// The area the grains cover twice or outside the box `[lo, hi]`, m² per metre.
    fn interpenetration(&self, lo: V2, hi: V2) -> Real;
    /// The grains' material for drawing (points or elements).
    fn material_points(&self) -> MaterialPoints;
    /// Heap bytes held.
    fn memory_bytes(&self) -> usize;
    /// Contact-solver sweeps since the start.
    fn sweeps(&self) -> u64 {
        u64::from(self.progress().totals.sweeps)
    }
    /// Sets the friction of every grain–grain contact (`None`: each pair's own).
    fn set_pair_friction(&mut self, friction: Option<Real>);
    /// Each grain's momentum, kg·m/s per m.
    fn grain_momenta(&self) -> Vec<V2>;
    /// Mass (kg/m) and centre of mass (m).
    fn center_of_mass(&self) -> (Real, V2);
    /// What to change when a step fails for `cause` (by default [`suggestion`]'s advice).
    fn suggestion(&self, cause: &InstabilityCause) -> &'static str {
        suggestion(cause)
    }
    /// The Newton iterations' trace ([`super::trace`]).
    fn tracer(&mut self) -> &mut Tracer;
    /// Adds to a saved state (which holds the grains as disks of their current area) what the
    /// method needs to go on from the same deformed grains: `mpm` its material points
    /// ([`StateFile::material_points`]), `fem` its meshes ([`StateFile::meshes`]), in the order
    /// of [`SoftSystem::grain_states`]. By default nothing: the state holds disks only.
    fn save_grains(&self, _state: &mut StateFile) {}
}

/// What to change when a soft-grain method's step fails for `cause`, for the causes every
/// such method shares (a method adds its own in [`SoftSystem::suggestion`]).
pub fn suggestion(cause: &InstabilityCause) -> &'static str {
    match cause {
        InstabilityCause::NewtonBudget { .. } => {
            "take a smaller method.time_step (or a smaller method.max_displacement), or raise method.max_newton"
        }
        InstabilityCause::SolverBudget { .. } => "raise method.max_iterations, or take a smaller method.time_step",
        _ => "take a smaller method.time_step",
    }
}

fn v2(v: &Vec3) -> V2 {
    V2::new(v.x, v.y)
}

fn v3(v: &V2) -> Vec3 {
    Vec3::new(v.x, v.y, 0.0)
}

/// A soft-grain method on a scene (module documentation).
pub struct SoftSim<S: SoftSystem> {
    /// The method's grains.
    pub sys: S,
    name: &'static str,
    walls: Vec<Wall>,
    domain: Domain,
    len0: [Real; 2],
    materials: Vec<Material>,
    grain_material: Vec<u16>,
    density: Real,
    mean_diameter: Real,
    dt: Real,
    pool: Option<rayon::ThreadPool>,
    last: (u32, u32),
    /// Work of the walls and gravity on the grains since the start, J/m.
    work: Real,
    /// Kinetic and strain energy at the start, J/m.
    energy0: Real,
    /// Mean norm of the grains' net force over the last step, N/m.
    net_force: Real,
    /// The stiffest grain's plane-strain modulus `E / (1 − ν²)`, Pa (the servo's gain).
    modulus: Real,
}

impl<S: SoftSystem> SoftSim<S> {
    /// The method `name` on `scene`, its grains `sys` built from `particles` (the scene's
    /// placement), the container's `walls` in `domain`, steps of `dt` (s), on `threads`
    /// threads (0: the caller's pool).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &'static str,
        scene: &Scene,
        sys: S,
        particles: &Particles,
        walls: Vec<Wall>,
        domain: Domain,
        dt: Real,
        threads: usize,
    ) -> Result<Self, EngineError> {
        let density = scene.materials.get(particles.material.first().copied().unwrap_or(0) as usize).map_or(1.0, |m| m.density);
        let modulus = scene
            .materials
            .iter()
            .filter_map(|m| m.deformable.as_ref())
            .map(|law| {
                let (e, nu) = law.young_poisson();
                e / (1.0 - nu * nu)
            })
            .fold(0.0, Real::max);
        let mean_diameter = 2.0 * particles.radius.iter().sum::<Real>() / particles.len().max(1) as Real;
        let energy0 = sys.kinetic_energy() + sys.strain_energy();
        Ok(Self {
            sys,
            name,
            walls,
            len0: [domain.length(0), domain.length(1)],
            domain,
            materials: scene.materials.clone(),
            grain_material: particles.material.clone(),
            density,
            mean_diameter,
            dt,
            pool: world::own_pool(threads)?,
            last: (0, 0),
            work: 0.0,
            energy0,
            net_force: 0.0,
            modulus,
        })
    }

    /// What the steps cost since the start: Newton iterations, contact sweeps, step parts
    /// done and failed (done again as two halves), and the failures' causes.
    pub fn cost(&self) -> Cost {
        self.sys.progress().cost()
    }

    /// The grains as disks of their current area, at their centroids, moving at their mean
    /// velocities.
    fn disks(&self, grains: &[GrainState]) -> Particles {
        let mut out = Particles::default();
        for (k, g) in grains.iter().enumerate() {
            let r = (g.area / std::f64::consts::PI).sqrt();
            out.push(2, v3(&g.centroid), v3(&g.velocity), r, self.density, self.grain_material[k], false);
        }
        out
    }

    fn one_step(&mut self) -> Result<(), EngineError> {
        let mut servos = [0usize; 2];
        for w in &self.walls {
            if w.target_stress().is_some() {
                servos[w.face.axis] += 1;
            }
        }
        for (w, plane) in self.walls.iter_mut().zip(self.sys.planes_mut().iter_mut()) {
            let a = w.face.axis;
            if let WallMotion::Stress { gain: None, .. } = w.motion {
                w.gain = 0.5 * self.domain.length(a) / (servos[a].max(1) as Real * self.modulus * self.dt);
            }
            w.servo(world::wall_area(&self.domain, a), self.domain.length(a));
            plane.velocity = v2(&w.velocity);
            plane.point[a] = w.position;
        }
        let momentum = self.sys.grain_momenta();
        let (mass, com0) = self.sys.center_of_mass();
        self.last = self.sys.advance().map_err(|cause| {
            let suggestion = self.sys.suggestion(&cause).to_string();
            EngineError::Unstable { step: self.sys.steps(), time: self.sys.time(), cause, suggestion }
        })?;
        let (_, com1) = self.sys.center_of_mass();
        // Work: the walls' impulses on the grains times their velocities, gravity's on the
        // centre of mass.
        let dt = self.dt;
        for (k, w) in self.walls.iter_mut().enumerate() {
            self.work -= self.sys.wall_impulse()[k].dot(&v2(&w.velocity));
            w.force = v3(&self.sys.wall_force()[k]);
            w.advance(dt);
            let a = w.face.axis;
            if w.face.upper {
                self.domain.hi[a] = w.position;
            } else {
                self.domain.lo[a] = w.position;
            }
        }
        self.work += mass * self.sys.gravity().dot(&(com1 - com0));
        let n = momentum.len().max(1) as Real;
        self.net_force = self.sys.grain_momenta().iter().zip(&momentum).map(|(p1, p0)| (p1 - p0).norm() / dt).sum::<Real>() / n;
        Ok(())
    }
}

impl<S: SoftSystem> Simulation for SoftSim<S> {
    fn method(&self) -> &'static str {
        self.name
    }

    fn grain_model(&self) -> crate::run::GrainModel {
        crate::run::GrainModel::Deformable
    }

    fn step(&mut self) -> Result<(), EngineError> {
        world::in_own_pool(self, |s| &mut s.pool, |s| s.one_step())
    }

    fn steps_done(&self) -> u64 {
        self.sys.steps()
    }

    fn time(&self) -> Real {
        self.sys.time()
    }

    fn dt(&self) -> Real {
        self.dt
    }

    fn particle_count(&self) -> usize {
        self.grain_material.len()
    }

    fn packing_fraction(&self) -> Real {
        self.sys.solid_area() / self.domain.volume()
    }

    fn strain(&self) -> Real {
        (0..2).map(|a| (self.domain.length(a) / self.len0[a]).ln().abs()).fold(0.0, f64::max)
    }

    fn box_lengths(&self) -> Vec3 {
        self.domain.hi - self.domain.lo
    }

    fn sample(&mut self) -> Result<Sample, EngineError> {
        let grains = self.sys.grain_states();
        let disks = self.disks(&grains);
        let contacts = self.sys.contact_records(&grains);
        let walls = world::wall_views(&self.walls, &self.domain);
        let kinetic = self.sys.kinetic_energy();
        let strain = self.sys.strain_energy();
        let n = grains.len().max(1) as Real;
        let frictional = self.grain_material.iter().any(|&m| self.materials.get(m as usize).is_some_and(|m| m.friction > 0.0));
        let view = SystemView {
            dim: 2,
            step: self.sys.steps(),
            time: self.sys.time(),
            particles: &disks,
            volume: self.domain.volume(),
            contacts: &contacts,
            walls: &walls,
            shear: world::shear_geometry(&self.domain, &self.walls),
            elastic_energy: strain,
            rattler_threshold: rattler_threshold(2, frictional),
            drum: None,
            deformable: Some(DeformableView {
                kinetic_energy: kinetic,
                aspect_ratios: (
                    grains.iter().map(|g| g.aspect_ratio).sum::<Real>() / n,
                    grains.iter().map(|g| g.aspect_ratio).fold(1.0, Real::max),
                ),
                sample: DeformableSample {
                    min_jacobian: self.sys.min_jacobian(),
                    dissipated_energy: self.work - (kinetic + strain - self.energy0),
                    interpenetration: self.sys.interpenetration(v2(&self.domain.lo), v2(&self.domain.hi)) / self.domain.volume(),
                    newton_iterations: self.last.0,
                    sweeps: self.last.1,
                },
            }),
            domain: &self.domain,
        };
        let s = measure(&view);
        if !s.is_finite() {
            return Err(EngineError::Unstable {
                step: self.sys.steps(),
                time: self.sys.time(),
                cause: InstabilityCause::NonFinite { particle: 0 },
                suggestion: "take a smaller method.time_step".into(),
            });
        }
        Ok(s)
    }

    fn snapshot(&self) -> Snapshot {
        let grains = self.sys.grain_states();
        let disks = self.disks(&grains);
        let contacts = self.sys.contact_records(&grains);
        let mut force = vec![Vec3::zeros(); disks.len()];
        for c in &contacts {
            force[c.i as usize] += c.force;
            if let Some(j) = c.j {
                force[j as usize] -= c.force;
            }
        }
        Snapshot {
            dim: 2,
            step: self.sys.steps(),
            time: self.sys.time(),
            lo: self.domain.lo,
            hi: self.domain.hi,
            position: disks.pos.clone(),
            radius: disks.radius.clone(),
            velocity: disks.vel.clone(),
            omega: disks.omega.clone(),
            force,
            contacts: contacts.into_iter().filter(|c| c.bears_load()).collect(),
            walls: world::wall_faces(&self.walls),
            drum: None,
            material_points: Some(self.sys.material_points()),
        }
    }

    fn memory_bytes(&self) -> usize {
        self.sys.memory_bytes() + self.grain_material.capacity() * 2
    }

    fn solver_iterations(&self) -> u64 {
        self.sys.sweeps()
    }

    fn apply_controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        for def in &controls.walls {
            if let Some(w) = self.walls.iter_mut().find(|w| w.face == def.face) {
                w.set_motion(def.motion);
            }
        }
        self.sys.set_pair_friction(controls.friction);
        Ok(())
    }

    fn balance(&mut self) -> Balance {
        let contacts = self.sys.contact_records(&self.sys.grain_states());
        let forces: Vec<Real> = contacts.iter().map(|c| c.force.norm()).filter(|&f| f > 0.0).collect();
        let mean = if forces.is_empty() { 0.0 } else { forces.iter().sum::<Real>() / forces.len() as Real };
        Balance {
            kinetic_energy: self.sys.kinetic_energy(),
            reference_energy: self.sys.strain_energy(),
            unbalanced_force: if mean > 0.0 { self.net_force / mean } else { Real::INFINITY },
            stress_error: world::wall_stress_error(&self.walls, &self.domain),
        }
    }

    fn grain_scales(&self) -> (Real, Real) {
        (self.mean_diameter, self.density)
    }

    /// The grains as disks of their current area, which any method may start from, and the
    /// system's material points if it has them (a run of `mpm` goes on from those).
    fn saved_state(&self) -> StateFile {
        let grains = self.sys.grain_states();
        let disks = self.disks(&grains);
        let mut st = world::saved_state(self.sys.time(), self.sys.steps(), &self.domain, &self.materials, &disks);
        self.sys.save_grains(&mut st);
        st
    }

    fn clock(&self) -> Clock {
        Clock {
            steps: self.sys.steps(),
            time: self.sys.time(),
            len0: [self.len0[0], self.len0[1], 0.0],
            totals: vec![self.work, self.energy0],
            shear_rate: 0.0,
            walls: self.walls.iter().map(|w| w.servo_state()).collect(),
        }
    }

    fn set_clock(&mut self, clock: &Clock) {
        let p = self.sys.progress_mut();
        p.steps = clock.steps;
        p.time = clock.time;
        self.len0 = [clock.len0[0], clock.len0[1]];
        if let [work, energy0] = clock.totals[..] {
            self.work = work;
            self.energy0 = energy0;
        }
        for (wall, s) in self.walls.iter_mut().zip(&clock.walls) {
            wall.set_servo_state(*s);
        }
    }

    fn trace_newton(&mut self, sink: NewtonSink) -> bool {
        self.sys.tracer().set(sink);
        true
    }
}
