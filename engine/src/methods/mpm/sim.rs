//! Method `"mpm"` as a [`crate::run::Simulation`]: a scene's deformable grains as clouds of
//! material points ([`super::system::System`]) in the shared soft-grain driver
//! ([`SoftSim`]: walls and servos, energies, metrics).
//!
//! Grains are placed as rigid disks are (the scene's sizes and placements), then each disk is
//! filled with points on a square lattice of spacing `h / points_per_cell`, the grid's cell
//! `h` being the smallest diameter over `cells_per_diameter`. The grid covers the container
//! with a margin of four cells.

use super::grain::Grain;
use super::grid::{Grid, V2};
use super::measure::GrainState;
use super::outline::Outline;
use super::points::Points;
use super::system::{Settings, System};
use crate::constitutive::{build, ConstitutiveLaw};
use crate::error::{EngineError, InstabilityCause};
use crate::math::Real;
use crate::methods::soft::contact::Sides;
use crate::methods::soft::contact::Wall as PlaneWall;
use crate::methods::soft::parts::Cost;
use crate::methods::soft::sim::{planes, SoftSim, SoftSystem};
use crate::methods::soft::trace::Tracer;
use crate::methods::world;
use crate::nscd::Convergence;
use crate::observe::{ContactRecord, MaterialPoints};
use crate::scene::{MpmParams, Scene};

/// Nodes of margin around the container.
const MARGIN: usize = 4;

/// The material point method on a scene.
pub type Mpm = SoftSim<System>;

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

    fn grain_states(&self) -> Vec<GrainState> {
        System::grain_states(self)
    }

    fn contact_records(&self, grains: &[GrainState]) -> Vec<ContactRecord> {
        System::contact_records(self, grains)
    }

    fn kinetic_energy(&self) -> Real {
        System::kinetic_energy(self)
    }

    fn strain_energy(&self) -> Real {
        System::strain_energy(self)
    }

    fn min_jacobian(&self) -> Real {
        System::min_jacobian(self)
    }

    fn solid_area(&self) -> Real {
        (0..self.points.len()).map(|p| self.points.area(p)).sum()
    }

    fn interpenetration(&self, lo: V2, hi: V2) -> Real {
        System::interpenetration(self, lo, hi)
    }

    fn material_points(&self) -> MaterialPoints {
        System::material_points(self)
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
        let p = &self.points;
        self.grains.iter().map(|g| g.points.clone().map(|k| p.v[k] * p.mass[k]).sum()).collect()
    }

    fn center_of_mass(&self) -> (Real, V2) {
        System::center_of_mass(self)
    }

    fn suggestion(&self, cause: &InstabilityCause) -> &'static str {
        match cause {
            InstabilityCause::NewtonBudget { .. } => {
                "take a smaller method.time_step (or a smaller method.max_displacement), or raise method.max_newton"
            }
            InstabilityCause::SolverBudget { .. } => "raise method.max_iterations, or take a smaller method.time_step",
            InstabilityCause::Inverted { .. } => {
                "the grain is squeezed beyond what its points can follow: refine the grid (method.cells_per_diameter) or take a smaller method.time_step"
            }
            InstabilityCause::LeftGrid { .. } => "a grain left the container: keep walls around the grains (no open face)",
            _ => "take a smaller method.time_step",
        }
    }

    fn tracer(&mut self) -> &mut Tracer {
        &mut self.tracer
    }
}

/// Builds the method on a validated 2D scene whose grains are all deformable.
pub fn mpm(scene: &Scene, params: &MpmParams) -> Result<Mpm, EngineError> {
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
        let range =
            points.fill_disk(V2::new(c.x, c.y), particles.radius[k], spacing, V2::new(particles.vel[k].x, particles.vel[k].y), mat.density);
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
    let walls = world::container_walls(c);
    let planes = planes(scene, &walls);
    // The time step: the fastest imposed motion covers `max_displacement` of a cell.
    let speed = world::imposed_speed(scene, &particles, true).max(1e-3 * h);
    let dt = params.time_step.unwrap_or(params.max_displacement * h / speed);
    let settings = Settings {
        dt,
        theta: params.theta,
        flip: params.flip,
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
        sides: if params.symmetric_contact.unwrap_or_else(|| grains.iter().any(|g| laws[g.law].plastic())) {
            Sides::Both
        } else {
            Sides::One
        },
    };
    let sys = System::new(grid, points, grains, laws, planes, settings);
    SoftSim::new("mpm", scene, sys, &particles, walls, domain, dt, params.threads)
}

impl Mpm {
    /// Material points.
    pub fn point_count(&self) -> usize {
        self.sys.points.len()
    }

    /// What the steps cost since the start: Newton iterations, contact sweeps, step parts
    /// done and failed (done again as two halves), and the failures' causes.
    pub fn cost(&self) -> Cost {
        Cost::new(&self.sys.totals, &self.sys.splitting)
    }
}
