//! Method `"mpm"` as a [`crate::run::Simulation`]: a scene's deformable grains as clouds of
//! material points ([`super::system::System`]) in the shared soft-grain driver
//! ([`SoftSim`]: walls and servos, energies, metrics).
//!
//! Grains are placed as rigid disks are (the scene's sizes and placements), then each disk is
//! filled with points on a square lattice of spacing `h / points_per_cell`, the grid's cell
//! `h` being the smallest diameter over `cells_per_diameter`. The grid covers the container
//! with a margin of four cells. A scene that starts from a state an `mpm` run saved goes on
//! from its material points instead ([`crate::scene::state_points`]; the cell from the disks
//! the grains were cut from).

use super::grain::Grain;
use super::grid::{Grid, V2};
use super::measure::GrainState;
use super::outline::{Outline, Vertex};
use super::params::MpmParams;
use super::points::Points;
use super::system::System;
use crate::constitutive::{History, Mat2, PlaneSym};
use crate::error::{EngineError, InstabilityCause};
use crate::math::Real;
use crate::methods::method::Method;
use crate::methods::soft::build;
use crate::methods::soft::contact::Wall as PlaneWall;
use crate::methods::soft::progress::Progress;
use crate::methods::soft::sim::{self, SoftSim, SoftSystem};
use crate::methods::soft::trace::Tracer;
use crate::methods::world;
use crate::observe::{ContactRecord, MaterialPoints};
use crate::particles::Particles;
use crate::run::Simulation;
use crate::scene::state_points::StatePoints;
use crate::scene::{Checker, Scene, StateFile};
use std::ops::Range;

/// Nodes of margin around the container.
const MARGIN: usize = 4;

/// The material point method on a scene.
pub type Mpm = SoftSim<System>;

impl SoftSystem for System {
    fn advance(&mut self) -> Result<(u32, u32), InstabilityCause> {
        self.step().map(|r| (r.newton, r.sweeps)).map_err(|f| f.cause)
    }

    fn progress(&self) -> &Progress {
        &self.progress
    }

    fn progress_mut(&mut self) -> &mut Progress {
        &mut self.progress
    }

    fn gravity(&self) -> V2 {
        self.settings.gravity
    }

    fn planes_mut(&mut self) -> &mut [PlaneWall] {
        &mut self.walls
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
            InstabilityCause::Inverted { .. } => {
                "the grain is squeezed beyond what its points can follow: refine the grid (method.cells_per_diameter) or take a smaller method.time_step"
            }
            InstabilityCause::LeftGrid { .. } => "a grain left the container: keep walls around the grains (no open face)",
            _ => sim::suggestion(cause),
        }
    }

    fn tracer(&mut self) -> &mut Tracer {
        &mut self.tracer
    }

    fn save_grains(&self, state: &mut StateFile) {
        state.material_points = Some(saved_points(self));
    }
}

/// Builds the method on a validated 2D scene whose grains are all deformable.
pub fn mpm(scene: &Scene, params: &MpmParams) -> Result<Mpm, EngineError> {
    let (particles, domain) = build::placed(scene, "mpm")?;
    let saved = scene.initial.as_ref().and_then(|st| st.points.as_ref());
    // The grid's cell comes from the disks the grains were cut from (a saved state's grains
    // have deformed since).
    let h = build::smallest_diameter(saved.map_or(&particles.radius, |s| &s.radius0)) / params.cells_per_diameter;
    let (law_of, laws) = build::laws(scene);
    let (points, grains) = fill_grains(scene, &particles, saved, &law_of, h, params.points_per_cell)?;
    let c = &scene.container;
    let grid = Grid::covering(V2::new(c.lo.x, c.lo.y), V2::new(c.hi.x, c.hi.y), h, MARGIN);
    let walls = world::container_walls(c);
    let planes = build::planes(scene, &walls);
    let dt = build::time_step(scene, &particles, &params.solver, h);
    let both = params.symmetric_contact.unwrap_or_else(|| grains.iter().any(|g| laws[g.law].plastic()));
    let settings = build::settings(scene, &params.solver, dt, both);
    let mut sys = System::new(grid, points, grains, laws, planes, settings, params.flip);
    sys.ghost = params.ghost_penalty;
    if let Some(saved) = saved {
        sys.progress.splitting.resume(saved.split_depth, saved.split_calm);
        sys.warm.restore_saved(&saved.impulses);
    }
    SoftSim::new("mpm", scene, sys, &particles, walls, domain, dt, params.solver.threads)
}

/// The grains' material points and the grains, each with its law (`law_of`, by material):
/// each placed disk filled with points on a square lattice of spacing `h / points_per_cell`
/// (`h` the grid's cell, m), or, from a `saved` state, its points as saved.
fn fill_grains(
    scene: &Scene,
    particles: &Particles,
    saved: Option<&StatePoints>,
    law_of: &[Option<usize>],
    h: Real,
    points_per_cell: u32,
) -> Result<(Points, Vec<Grain>), EngineError> {
    let spacing = h / points_per_cell as Real;
    let mut points = Points::default();
    let mut grains = Vec::with_capacity(particles.len());
    // Where the next grain's points and outline vertices start in a saved state's arrays.
    let mut restored = (0usize, 0usize);
    for k in 0..particles.len() {
        let (law, mat) = build::grain_law(scene, law_of, particles, k, "mpm")?;
        if let Some(saved) = saved {
            let (range, outline) = restore_grain(&mut points, saved, k, &mut restored);
            grains.push(Grain { points: range, law, friction: mat.friction, radius: saved.radius0[k], outline });
            continue;
        }
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
    Ok((points, grains))
}

/// Grain `k`'s points and outline from a saved state (checked: its arrays agree), appended to
/// `points`; `from`: where grain `k`'s points and outline vertices start in the state's arrays,
/// moved on to grain `k + 1`'s.
fn restore_grain(points: &mut Points, saved: &StatePoints, k: usize, from: &mut (usize, usize)) -> (Range<usize>, Outline) {
    let (first, vertex) = *from;
    *from = (first + saved.count[k] as usize, vertex + saved.outline_count[k] as usize);
    let start = points.len();
    for i in first..first + saved.count[k] as usize {
        let v2 = |v: &[f64]| V2::new(v[0], v[1]);
        let (f, c) = (&saved.deformation[i], &saved.plastic[i]);
        points.mass.push(saved.mass[i]);
        points.vol0.push(saved.area0[i]);
        points.side0.push(saved.side0[i]);
        points.x.push(v2(&saved.position[i]));
        points.v.push(v2(&saved.velocity[i]));
        points.f.push(Mat2::new(f[0], f[1], f[2], f[3]));
        points.history.push(History { inv_plastic: PlaneSym { xx: c[0], xy: c[1], yy: c[2], zz: c[3] }, alpha: saved.plastic_strain[i] });
    }
    let vertices = (vertex..vertex + saved.outline_count[k] as usize)
        .map(|j| {
            let o = &saved.outline_offset[j];
            Vertex { point: (start + saved.outline_point[j] as usize) as u32, offset: V2::new(o[0], o[1]) }
        })
        .collect();
    (start..points.len(), Outline { vertices })
}

/// The grains' material points as a saved state holds them ([`StatePoints`]).
pub(crate) fn saved_points(sys: &System) -> StatePoints {
    let p = &sys.points;
    let mut s = StatePoints {
        count: sys.grains.iter().map(|g| g.points.len() as u32).collect(),
        radius0: sys.grains.iter().map(|g| g.radius).collect(),
        mass: p.mass.clone(),
        area0: p.vol0.clone(),
        side0: p.side0.clone(),
        position: p.x.iter().map(|x| vec![x.x, x.y]).collect(),
        velocity: p.v.iter().map(|v| vec![v.x, v.y]).collect(),
        deformation: p.f.iter().map(|f| vec![f[(0, 0)], f[(0, 1)], f[(1, 0)], f[(1, 1)]]).collect(),
        plastic: p.history.iter().map(|h| vec![h.inv_plastic.xx, h.inv_plastic.xy, h.inv_plastic.yy, h.inv_plastic.zz]).collect(),
        plastic_strain: p.history.iter().map(|h| h.alpha).collect(),
        outline_count: sys.grains.iter().map(|g| g.outline.len() as u32).collect(),
        split_depth: sys.progress.splitting.level().0,
        split_calm: sys.progress.splitting.level().1,
        impulses: sys.warm.saved(),
        ..StatePoints::default()
    };
    for g in &sys.grains {
        for v in &g.outline.vertices {
            s.outline_point.push(v.point - g.points.start as u32);
            s.outline_offset.push(vec![v.offset.x, v.offset.y]);
        }
    }
    s
}

impl Mpm {
    /// Material points.
    pub fn point_count(&self) -> usize {
        self.sys.points.len()
    }
}

impl Method for MpmParams {
    fn fit(&mut self, scene: &Scene, _given: &serde_json::Value, c: &mut Checker) {
        crate::methods::fit::soft_grains(scene, "mpm", self.solver.time_step.is_some(), c);
    }

    fn build(&self, scene: &Scene) -> Result<Box<dyn Simulation>, EngineError> {
        Ok(Box::new(mpm(scene, self)?))
    }

    crate::method_common!("mpm", solver.threads);
}
