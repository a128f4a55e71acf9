//! Method `"mpm"` as a [`Simulation`]: a scene's deformable grains as clouds of material points
//! ([`super::system::System`]), its container's walls driven as for the other methods
//! ([`crate::loading::Wall`]: fixed, at a velocity, at a strain rate or at a stress), and the shared metrics
//! measured on the grains as disks of their current area ([`crate::observe::DeformableView`]).
//!
//! A stress-controlled wall ([`Wall::servo`]) gets, unless the scene gives one, the gain
//! `½ L / (n E' dt)` (m/(s·Pa)): `L` the box's length along its axis, `n` the servo walls on
//! that axis, `E' = E / (1 − ν²)` the stiffest grain's plane-strain modulus. A packing is no
//! stiffer than its grains, so one step changes the wall stress by at most half the error:
//! stable for any packing, and within a few steps of the target once the grains are pressed
//! together (looser packings answer more slowly, at the wall's `max_speed`).
//!
//! Grains are placed as rigid disks are (the scene's sizes and placements), then each disk is
//! filled with points on a square lattice of spacing `h / points_per_cell`, the grid's cell
//! `h` being the smallest diameter over `cells_per_diameter`. The grid covers the container
//! with a margin of four cells.

use super::contact::Wall as PlaneWall;
use super::grain::Grain;
use super::grid::{Grid, V2};
use super::measure::GrainState;
use super::outline::Outline;
use super::points::Points;
use super::system::{Settings, StepFailure, StepReport, System};
use crate::constitutive::{build, ConstitutiveLaw};
use crate::error::{EngineError, InstabilityCause};
use crate::geometry::Domain;
use crate::loading::Wall;
use crate::math::{Real, Vec3};
use crate::methods::world;
use crate::nscd::Convergence;
use crate::observe::{measure, rattler_threshold, DeformableSample, DeformableView, Sample, Snapshot, SystemView};
use crate::particles::Particles;
use crate::run::{Balance, Simulation};
use crate::scene::{Controls, Material, MpmParams, Scene, StateFile, WallMotion};

/// Nodes of margin around the container.
const MARGIN: usize = 4;

/// The material point method on a scene (module documentation).
pub struct Mpm {
    sys: System,
    walls: Vec<Wall>,
    domain: Domain,
    len0: [Real; 2],
    materials: Vec<Material>,
    grain_material: Vec<u16>,
    density: Real,
    mean_diameter: Real,
    dt: Real,
    pool: Option<rayon::ThreadPool>,
    last: StepReport,
    /// Work of the walls and gravity on the grains since the start, J/m.
    work: Real,
    /// Kinetic and strain energy at the start, J/m.
    energy0: Real,
    /// Each grain's momentum at the start of the last step, kg·m/s per m.
    momentum: Vec<V2>,
    /// Mean norm of the grains' net force over the last step, N/m.
    net_force: Real,
    /// The stiffest grain's plane-strain modulus `E / (1 − ν²)`, Pa (the servo's gain).
    modulus: Real,
}

fn v2(v: &Vec3) -> V2 {
    V2::new(v.x, v.y)
}

fn v3(v: &V2) -> Vec3 {
    Vec3::new(v.x, v.y, 0.0)
}

impl Mpm {
    /// Builds the method on a validated 2D scene whose grains are all deformable.
    pub fn new(scene: &Scene, params: &MpmParams) -> Result<Self, EngineError> {
        if scene.dim != 2 {
            return Err(EngineError::Build { field: "dimension".into(), reason: "method mpm is 2D (plane strain)".into() });
        }
        let (particles, domain) = world::initial_particles(scene)?;
        let dmin = particles.radius.iter().copied().fold(Real::INFINITY, Real::min) * 2.0;
        let h = dmin / params.cells_per_diameter;
        let spacing = h / params.points_per_cell as Real;
        // One law per deformable material.
        let mut law_of: Vec<Option<usize>> = vec![None; scene.materials.len()];
        let mut laws: Vec<Box<dyn ConstitutiveLaw>> = Vec::new();
        for (m, mat) in scene.materials.iter().enumerate() {
            if let Some(spec) = &mat.deformable {
                law_of[m] = Some(laws.len());
                laws.push(build(spec));
            }
        }
        let mut points = Points::default();
        let mut grains = Vec::with_capacity(particles.len());
        for k in 0..particles.len() {
            let m = particles.material[k] as usize;
            let (Some(law), Some(mat)) = (law_of.get(m).copied().flatten(), scene.materials.get(m)) else {
                return Err(EngineError::Build {
                    field: "particles".into(),
                    reason: format!("grain {k}'s material is not deformable: method mpm needs deformable grains"),
                });
            };
            let c = particles.pos[k];
            let range = points.fill_disk(V2::new(c.x, c.y), particles.radius[k], spacing, v2(&particles.vel[k]), mat.density);
            if range.len() < 4 {
                return Err(EngineError::Build {
                    field: "method.cells_per_diameter".into(),
                    reason: format!("grain {k} holds {} material point(s); refine the grid so that every grain holds several", range.len()),
                });
            }
            let outline = Outline::disk(&points, range.clone(), V2::new(c.x, c.y), particles.radius[k], h);
            grains.push(Grain { points: range, law, friction: mat.friction, radius: particles.radius[k], outline });
        }
        const MAX_POINTS: usize = 20_000_000;
        if points.len() > MAX_POINTS {
            return Err(EngineError::Build {
                field: "method.cells_per_diameter".into(),
                reason: format!(
                    "the grains hold {} material points (at most {MAX_POINTS}); coarsen the grid or the points per cell",
                    points.len()
                ),
            });
        }
        let c = &scene.container;
        let grid = Grid::covering(V2::new(c.lo.x, c.lo.y), V2::new(c.hi.x, c.hi.y), h, MARGIN);
        let wall_friction = c.wall_material.and_then(|w| scene.materials.get(w)).map(|m| m.friction);
        let walls: Vec<Wall> = world::container_walls(c);
        // A grain–wall pair's coefficient is the geometric mean of the grain's and the wall
        // material's (which validation requires when there are walls).
        let planes: Vec<PlaneWall> = walls
            .iter()
            .map(|w| {
                let n = w.normal();
                let mut point = V2::zeros();
                point[w.face.axis] = w.position;
                PlaneWall { point, normal: v2(&n), velocity: v2(&w.velocity), friction: wall_friction.unwrap_or(0.0) }
            })
            .collect();
        // The time step: the fastest imposed motion covers `max_displacement` of a cell.
        let speed = world::imposed_speed(scene, &particles, true).max(1e-3 * h);
        let dt = params.time_step.unwrap_or(params.max_displacement * h / speed);
        let settings = Settings {
            dt,
            theta: params.theta,
            flip: params.flip,
            gravity: v2(&scene.gravity),
            newton_tolerance: params.newton_tolerance,
            max_newton: params.max_newton,
            contact: Convergence {
                tolerance: params.tolerance,
                violation_tolerance: params.violation_tolerance,
                worst_tolerance: 1e-4,
                max_iterations: params.max_iterations,
                relaxation: 1.0,
                acceleration: params.acceleration,
            },
        };
        let density = scene.materials.get(particles.material[0] as usize).map_or(1.0, |m| m.density);
        let modulus = scene
            .materials
            .iter()
            .filter_map(|m| m.deformable.as_ref())
            .map(|law| {
                let (e, nu) = law.young_poisson();
                e / (1.0 - nu * nu)
            })
            .fold(0.0, Real::max);
        let mean_diameter = 2.0 * particles.radius.iter().sum::<Real>() / particles.len() as Real;
        let grain_material = particles.material.clone();
        let sys = System::new(grid, points, grains, laws, planes, settings);
        let pool = world::own_pool(params.threads)?;
        let energy0 = sys.kinetic_energy() + sys.strain_energy();
        let len0 = [domain.length(0), domain.length(1)];
        let n = sys.grains.len();
        Ok(Self {
            sys,
            walls,
            domain,
            len0,
            materials: scene.materials.clone(),
            grain_material,
            density,
            mean_diameter,
            dt,
            pool,
            last: StepReport::default(),
            work: 0.0,
            energy0,
            momentum: vec![V2::zeros(); n],
            net_force: 0.0,
            modulus,
        })
    }

    /// Material points.
    pub fn point_count(&self) -> usize {
        self.sys.points.len()
    }

    /// Newton iterations, contact sweeps, failed step parts (done again as two halves) and
    /// step parts done, since the start.
    pub fn cost(&self) -> (u64, u64, u64, u64) {
        (self.sys.totals.newton as u64, self.sys.totals.sweeps as u64, self.sys.substeps, self.sys.parts)
    }

    /// The step's failure as the engine reports it, with what to change.
    fn unstable(&self, f: StepFailure) -> EngineError {
        let suggestion = match f.cause {
            InstabilityCause::NewtonBudget { .. } => {
                "take a smaller method.time_step (or a smaller method.max_displacement), or raise method.max_newton"
            }
            InstabilityCause::SolverBudget { .. } => "raise method.max_iterations, or take a smaller method.time_step",
            InstabilityCause::Inverted { .. } => {
                "the grain is squeezed beyond what its points can follow: refine the grid (method.cells_per_diameter) or take a smaller method.time_step"
            }
            InstabilityCause::LeftGrid { .. } => "a grain left the container: keep walls around the grains (no open face)",
            InstabilityCause::NotPositiveDefinite { .. } => "take a smaller method.time_step",
            _ => "take a smaller method.time_step",
        };
        EngineError::Unstable { step: self.sys.steps, time: self.sys.time, cause: f.cause, suggestion: suggestion.to_string() }
    }

    /// Grain `g`'s momentum now.
    fn momentum_of(&self, g: usize) -> V2 {
        let p = &self.sys.points;
        self.sys.grains[g].points.clone().map(|k| p.v[k] * p.mass[k]).sum()
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
        for (w, plane) in self.walls.iter_mut().zip(self.sys.walls.iter_mut()) {
            let a = w.face.axis;
            if let WallMotion::Stress { gain: None, .. } = w.motion {
                w.gain = 0.5 * self.domain.length(a) / (servos[a].max(1) as Real * self.modulus * self.dt);
            }
            w.servo(world::wall_area(&self.domain, a), self.domain.length(a));
            plane.velocity = v2(&w.velocity);
            plane.point[a] = w.position;
        }
        for g in 0..self.momentum.len() {
            self.momentum[g] = self.momentum_of(g);
        }
        let (mass, com0) = self.sys.center_of_mass();
        let report = self.sys.step().map_err(|f| self.unstable(f))?;
        self.last = report;
        let (_, com1) = self.sys.center_of_mass();
        // Work: the walls' impulses on the grains times their velocities, gravity's on the
        // centre of mass.
        let dt = self.sys.settings.dt;
        for (k, w) in self.walls.iter_mut().enumerate() {
            self.work -= self.sys.wall_impulse[k].dot(&v2(&w.velocity));
            w.force = v3(&self.sys.wall_force[k]);
            w.advance(dt);
            let a = w.face.axis;
            if w.face.upper {
                self.domain.hi[a] = w.position;
            } else {
                self.domain.lo[a] = w.position;
            }
        }
        self.work += mass * self.sys.settings.gravity.dot(&(com1 - com0));
        let n = self.momentum.len().max(1) as Real;
        self.net_force = (0..self.momentum.len()).map(|g| (self.momentum_of(g) - self.momentum[g]).norm() / dt).sum::<Real>() / n;
        Ok(())
    }
}

impl Simulation for Mpm {
    fn method(&self) -> &'static str {
        "mpm"
    }

    fn step(&mut self) -> Result<(), EngineError> {
        world::in_own_pool(self, |s| &mut s.pool, |s| s.one_step())
    }

    fn steps_done(&self) -> u64 {
        self.sys.steps
    }

    fn time(&self) -> Real {
        self.sys.time
    }

    fn dt(&self) -> Real {
        self.dt
    }

    fn particle_count(&self) -> usize {
        self.sys.grains.len()
    }

    fn packing_fraction(&self) -> Real {
        let solid: Real = (0..self.sys.points.len()).map(|p| self.sys.points.area(p)).sum();
        solid / self.domain.volume()
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
        let frictional = self.sys.grains.iter().any(|g| g.friction > 0.0);
        let view = SystemView {
            dim: 2,
            step: self.sys.steps,
            time: self.sys.time,
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
                sample: DeformableSample {
                    mean_aspect_ratio: grains.iter().map(|g| g.aspect_ratio).sum::<Real>() / n,
                    max_aspect_ratio: grains.iter().map(|g| g.aspect_ratio).fold(1.0, Real::max),
                    min_jacobian: self.sys.min_jacobian(),
                    dissipated_energy: self.work - (kinetic + strain - self.energy0),
                    interpenetration: self.sys.interpenetration(v2(&self.domain.lo), v2(&self.domain.hi)) / self.domain.volume(),
                    newton_iterations: self.last.newton,
                    sweeps: self.last.sweeps,
                },
            }),
        };
        let s = measure(&view);
        if !s.is_finite() {
            return Err(EngineError::Unstable {
                step: self.sys.steps,
                time: self.sys.time,
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
            step: self.sys.steps,
            time: self.sys.time,
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
        self.sys.memory_bytes() + self.grain_material.capacity() * 2 + self.momentum.capacity() * std::mem::size_of::<V2>()
    }

    fn solver_iterations(&self) -> u64 {
        self.sys.totals.sweeps as u64
    }

    fn apply_controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        for def in &controls.walls {
            if let Some(w) = self.walls.iter_mut().find(|w| w.face == def.face) {
                w.set_motion(def.motion);
            }
        }
        self.sys.pair_friction = controls.friction;
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

    /// The grains as rigid disks of their current area (a state holds no material points):
    /// a rigid-grain run may start from it.
    fn saved_state(&self) -> StateFile {
        let grains = self.sys.grain_states();
        let disks = self.disks(&grains);
        world::saved_state(self.sys.time, self.sys.steps, &self.domain, &self.materials, &disks)
    }
}
