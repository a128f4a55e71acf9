//! Method `"fem"` as a [`crate::run::Simulation`]: a scene's deformable grains as meshed bodies
//! ([`super::system::System`]) in the shared soft-grain driver ([`SoftSim`]: walls and servos,
//! energies, metrics).
//!
//! Grains are placed as rigid disks are (the scene's sizes and placements), then each disk is
//! meshed ([`super::mesh::Mesh::disk`]) with boundary segments of the smallest diameter over
//! `elements_per_diameter`, F-bar elements ([`super::element`]).

use nalgebra::Vector2;

use super::body::Body;
use super::mesh::Mesh;
use super::system::{Grain, Settings, System};
use crate::constitutive::{build, ConstitutiveLaw};
use crate::error::{EngineError, InstabilityCause};
use crate::math::{Real, Vec3};
use crate::methods::soft::contact::Sides;
use crate::methods::soft::contact::Wall as PlaneWall;
use crate::methods::soft::measure::{self, aspect_ratio, GrainState};
use crate::methods::soft::parts::Cost;
use crate::methods::soft::polygon::second_moments;
use crate::methods::soft::sim::{planes, SoftSim, SoftSystem};
use crate::methods::soft::trace::Tracer;
use crate::methods::world;
use crate::nscd::Convergence;
use crate::observe::{ContactRecord, MaterialPoints};
use crate::scene::{FemParams, Scene};

type V2 = Vector2<Real>;

/// Raster cells across the shortest boundary segment, for the interpenetration.
const RASTER_PER_SEGMENT: Real = 4.0;

/// The finite element method on a scene.
pub type Fem = SoftSim<System>;

impl System {
    /// Each grain's boundary now, m.
    pub fn outlines(&self) -> Vec<Vec<V2>> {
        self.grains.iter().map(|g| g.body.mesh.boundary.iter().map(|&k| g.body.position(k as usize)).collect()).collect()
    }
}

impl SoftSystem for System {
    fn advance(&mut self) -> Result<(u32, u32), InstabilityCause> {
        self.step().map(|r| (r.newton, r.sweeps)).map_err(|f| f.cause)
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn time(&self) -> Real {
        self.time
    }

    fn gravity(&self) -> V2 {
        self.settings.gravity
    }

    fn planes_mut(&mut self) -> &mut [PlaneWall] {
        &mut self.walls
    }

    fn wall_impulse(&self) -> &[V2] {
        &self.wall_impulse
    }

    fn wall_force(&self) -> &[V2] {
        &self.wall_force
    }

    /// Centroid and velocity from the nodes' masses; area and shape from the boundary polygon.
    fn grain_states(&self) -> Vec<GrainState> {
        self.grains
            .iter()
            .map(|g| {
                let b = &g.body;
                let mass: Real = b.mass.iter().sum();
                let (mut mx, mut mv) = (V2::zeros(), V2::zeros());
                for k in 0..b.nodes() {
                    mx += b.position(k) * b.mass[k];
                    mv += b.v[k] * b.mass[k];
                }
                let outline: Vec<V2> = b.mesh.boundary.iter().map(|&k| b.position(k as usize)).collect();
                let (area, _, second) = second_moments(&outline);
                GrainState { centroid: mx / mass, velocity: mv / mass, mass, area, aspect_ratio: aspect_ratio(&second) }
            })
            .collect()
    }

    fn contact_records(&self, grains: &[GrainState]) -> Vec<ContactRecord> {
        measure::contact_records(&self.contacts, self.walls.len(), grains, self.last_dt())
    }

    fn kinetic_energy(&self) -> Real {
        System::kinetic_energy(self)
    }

    fn strain_energy(&self) -> Real {
        System::strain_energy(self)
    }

    fn min_jacobian(&self) -> Real {
        self.grains.iter().flat_map(|g| g.body.states.iter().flat_map(|s| s.f.iter().map(|f| f.determinant()))).fold(1.0, Real::min)
    }

    fn solid_area(&self) -> Real {
        self.outlines().iter().map(|x| crate::methods::soft::polygon::area(x)).sum()
    }

    fn interpenetration(&self, lo: V2, hi: V2) -> Real {
        let shortest = self
            .grains
            .iter()
            .map(|g| {
                let b = &g.body.mesh.boundary;
                (0..b.len())
                    .map(|k| (g.body.mesh.nodes[b[k] as usize] - g.body.mesh.nodes[b[(k + 1) % b.len()] as usize]).norm())
                    .fold(Real::INFINITY, Real::min)
            })
            .fold(Real::INFINITY, Real::min);
        measure::interpenetration(&self.outlines(), shortest / RASTER_PER_SEGMENT, lo, hi)
    }

    /// Each element as a quadrilateral of its current nodes, its mean `det F`, and the pressure
    /// and von Mises stress of its Gauss points' mean Cauchy stress.
    fn material_points(&self) -> MaterialPoints {
        let mut out = MaterialPoints::default();
        let v3 = |v: V2| Vec3::new(v.x, v.y, 0.0);
        for (g, grain) in self.grains.iter().enumerate() {
            let law = self.laws[grain.law].as_ref();
            let b = &grain.body;
            for (q, s) in b.mesh.quads.iter().zip(&b.states) {
                out.grain.push(g as u32);
                out.corners.push(q.map(|k| v3(b.position(k as usize))));
                let (mut j, mut mean, mut dev) = (0.0, 0.0, 0.0);
                for p in 0..4 {
                    let jp = s.f[p].determinant();
                    j += 0.25 * jp;
                    if let Some(r) = law.response(&s.f[p], &s.history[p]).filter(|_| jp > 0.0) {
                        let m = r.tau.trace() / (3.0 * jp);
                        mean += 0.25 * m;
                        dev += 0.25 * (1.5 * (r.tau.norm_squared() / (jp * jp) - 3.0 * m * m).max(0.0)).sqrt();
                    }
                }
                out.jacobian.push(j);
                out.pressure.push(-mean);
                out.mises.push(dev);
                out.velocity.push(v3(q.iter().map(|&k| b.v[k as usize]).sum::<V2>() * 0.25));
            }
        }
        out
    }

    fn memory_bytes(&self) -> usize {
        System::memory_bytes(self)
    }

    fn sweeps(&self) -> u64 {
        u64::from(self.totals.sweeps)
    }

    fn set_pair_friction(&mut self, friction: Option<Real>) {
        self.pair_friction = friction;
    }

    fn grain_momenta(&self) -> Vec<V2> {
        self.grains.iter().map(|g| g.body.mass.iter().zip(&g.body.v).map(|(m, v)| v * *m).sum()).collect()
    }

    fn center_of_mass(&self) -> (Real, V2) {
        let (mut m, mut mx) = (0.0, V2::zeros());
        for g in &self.grains {
            for k in 0..g.body.nodes() {
                m += g.body.mass[k];
                mx += g.body.position(k) * g.body.mass[k];
            }
        }
        (m, if m > 0.0 { mx / m } else { V2::zeros() })
    }

    fn suggestion(&self, cause: &InstabilityCause) -> &'static str {
        match cause {
            InstabilityCause::NewtonBudget { .. } => {
                "take a smaller method.time_step (or a smaller method.max_displacement), or raise method.max_newton"
            }
            InstabilityCause::SolverBudget { .. } => "raise method.max_iterations, or take a smaller method.time_step",
            InstabilityCause::InvertedElement { .. } => {
                "the grain is squeezed beyond what its elements can follow: refine the mesh (method.elements_per_diameter) or take a smaller method.time_step"
            }
            _ => "take a smaller method.time_step",
        }
    }

    fn tracer(&mut self) -> &mut Tracer {
        &mut self.tracer
    }
}

/// Builds the method on a validated 2D scene whose grains are all deformable.
pub fn fem(scene: &Scene, params: &FemParams) -> Result<Fem, EngineError> {
    if scene.dim != 2 {
        return Err(EngineError::Build { field: "dimension".into(), reason: "method fem is 2D (plane strain)".into() });
    }
    let (particles, domain) = world::initial_particles(scene)?;
    let dmin = particles.radius.iter().copied().fold(Real::INFINITY, Real::min) * 2.0;
    let size = dmin / params.elements_per_diameter;
    let mut law_of: Vec<Option<usize>> = vec![None; scene.materials.len()];
    let mut laws: Vec<Box<dyn ConstitutiveLaw>> = Vec::new();
    for (m, mat) in scene.materials.iter().enumerate() {
        if let Some(spec) = &mat.deformable {
            law_of[m] = Some(laws.len());
            laws.push(build(spec));
        }
    }
    let mut grains = Vec::with_capacity(particles.len());
    let mut elements = 0;
    for k in 0..particles.len() {
        let m = particles.material[k] as usize;
        let (Some(law), Some(mat)) = (law_of.get(m).copied().flatten(), scene.materials.get(m)) else {
            return Err(EngineError::Build {
                field: "particles".into(),
                reason: format!("grain {k}'s material is not deformable: method fem needs deformable grains"),
            });
        };
        let c = particles.pos[k];
        let mesh = Mesh::disk(V2::new(c.x, c.y), particles.radius[k], size);
        elements += mesh.quads.len();
        let mut body = Body::new(mesh, mat.density, true).map_err(|e| EngineError::Build {
            field: "method.elements_per_diameter".into(),
            reason: format!("grain {k} could not be meshed ({e})"),
        })?;
        let v = V2::new(particles.vel[k].x, particles.vel[k].y);
        body.v.iter_mut().for_each(|x| *x = v);
        grains.push(Grain { body, law, friction: mat.friction, radius: particles.radius[k] });
    }
    const MAX_ELEMENTS: usize = 5_000_000;
    if elements > MAX_ELEMENTS {
        return Err(EngineError::Build {
            field: "method.elements_per_diameter".into(),
            reason: format!("the grains hold {elements} elements (at most {MAX_ELEMENTS}); coarsen the mesh"),
        });
    }
    let walls = world::container_walls(&scene.container);
    let planes = planes(scene, &walls);
    // The time step: the fastest imposed motion covers `max_displacement` of an element.
    let speed = world::imposed_speed(scene, &particles, true).max(1e-3 * size);
    let dt = params.time_step.unwrap_or(params.max_displacement * size / speed);
    let settings = Settings {
        dt,
        theta: params.theta,
        gravity: V2::new(scene.gravity.x, scene.gravity.y),
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
        sides: if params.symmetric_contact { Sides::Both } else { Sides::One },
    };
    let sys = System::new(grains, laws, planes, settings);
    SoftSim::new("fem", scene, sys, &particles, walls, domain, dt, params.threads)
}

impl Fem {
    /// Elements of all the grains.
    pub fn element_count(&self) -> usize {
        self.sys.grains.iter().map(|g| g.body.mesh.quads.len()).sum()
    }

    /// Nodes of all the grains.
    pub fn node_count(&self) -> usize {
        self.sys.grains.iter().map(|g| g.body.nodes()).sum()
    }

    /// What the steps cost since the start: Newton iterations, contact sweeps, step parts
    /// done and failed (done again as two halves), and the failures' causes.
    pub fn cost(&self) -> Cost {
        Cost::new(&self.sys.totals, &self.sys.splitting)
    }
}
