//! Method `"fem"` as a [`crate::run::Simulation`]: a scene's deformable grains as meshed bodies
//! ([`super::system::System`]) in the shared soft-grain driver ([`SoftSim`]: walls and servos,
//! energies, metrics).
//!
//! Grains are placed as rigid disks are (the scene's sizes and placements), then each disk is
//! meshed ([`super::mesh::Mesh::disk`]) with boundary segments of the smallest diameter over
//! `elements_per_diameter`, F-bar elements ([`super::element`]). A scene that starts from a
//! state a `fem` run saved goes on from its meshes instead ([`crate::scene::state_meshes`]:
//! the same deformed, stressed grains, the steps' splitting level and the contacts' warm
//! start).

use nalgebra::Vector2;

use super::body::Body;
use super::mesh::Mesh;
use super::params::FemParams;
use super::system::{Grain, System};
use crate::constitutive::{ConstitutiveLaw, History, PlaneSym};
use crate::error::{EngineError, InstabilityCause};
use crate::math::{Real, Vec3};
use crate::methods::method::Method;
use crate::methods::soft::build;
use crate::methods::soft::contact::Wall as PlaneWall;
use crate::methods::soft::measure::{self, aspect_ratio, GrainState};
use crate::methods::soft::polygon::second_moments;
use crate::methods::soft::progress::Progress;
use crate::methods::soft::sim::{self, SoftSim, SoftSystem};
use crate::methods::soft::trace::Tracer;
use crate::methods::world;
use crate::observe::{ContactRecord, MaterialPoints};
use crate::particles::Particles;
use crate::run::Simulation;
use crate::scene::state_meshes::{StateMeshes, GAUSS_POINTS};
use crate::scene::{Checker, Scene, StateFile};

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
        measure::contact_records(&self.contacts, self.walls.len(), grains, self.progress.last_dt())
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
            InstabilityCause::InvertedElement { .. } => {
                "the grain is squeezed beyond what its elements can follow: refine the mesh (method.elements_per_diameter) or take a smaller method.time_step"
            }
            _ => sim::suggestion(cause),
        }
    }

    fn tracer(&mut self) -> &mut Tracer {
        &mut self.tracer
    }

    fn save_grains(&self, state: &mut StateFile) {
        state.meshes = Some(saved_meshes(self));
    }
}

/// Builds the method on a validated 2D scene whose grains are all deformable.
pub fn fem(scene: &Scene, params: &FemParams) -> Result<Fem, EngineError> {
    let (particles, domain) = build::placed(scene, "fem")?;
    let saved = scene.initial.as_ref().and_then(|st| st.meshes.as_ref());
    // The element size comes from the disks the grains were meshed from (a saved state's
    // grains are disks of their current area in `particles`).
    let size = build::smallest_diameter(saved.map_or(&particles.radius, |s| &s.radius0)) / params.elements_per_diameter;
    let (law_of, laws) = build::laws(scene);
    let grains = mesh_grains(scene, &particles, saved, &law_of, &laws, size)?;
    let walls = world::container_walls(&scene.container);
    let planes = build::planes(scene, &walls);
    let dt = build::time_step(scene, &particles, &params.solver, size);
    let settings = build::settings(scene, &params.solver, dt, params.symmetric_contact);
    let mut sys = System::new(grains, laws, planes, settings);
    if let Some(saved) = saved {
        sys.progress.splitting.resume(saved.split_depth, saved.split_calm);
        sys.warm.restore_saved(&saved.impulses);
    }
    SoftSim::new("fem", scene, sys, &particles, walls, domain, dt, params.solver.threads)
}

/// The grains, each with its law (`law_of`, by material; `laws`): each placed disk meshed with
/// boundary segments of about `size` (m), or, from a `saved` state, its mesh as saved.
fn mesh_grains(
    scene: &Scene,
    particles: &Particles,
    saved: Option<&StateMeshes>,
    law_of: &[Option<usize>],
    laws: &[Box<dyn ConstitutiveLaw>],
    size: Real,
) -> Result<Vec<Grain>, EngineError> {
    let mut grains = Vec::with_capacity(particles.len());
    let mut elements = 0;
    // Where the next grain's nodes, elements and boundary start in a saved state's arrays.
    let mut from = Restored::default();
    for k in 0..particles.len() {
        let (law, mat) = build::grain_law(scene, law_of, particles, k, "fem")?;
        let grain = match saved {
            Some(saved) => restore_grain(saved, k, &mut from, law, laws[law].as_ref(), mat.density, mat.friction)?,
            None => {
                let c = particles.pos[k];
                let mesh = Mesh::disk(V2::new(c.x, c.y), particles.radius[k], size);
                let mut body = Body::new(mesh, mat.density, true).map_err(|e| EngineError::Build {
                    field: "method.elements_per_diameter".into(),
                    reason: format!("grain {k} could not be meshed ({e})"),
                })?;
                let v = V2::new(particles.vel[k].x, particles.vel[k].y);
                body.v.iter_mut().for_each(|x| *x = v);
                Grain { body, law, friction: mat.friction, radius: particles.radius[k] }
            }
        };
        elements += grain.body.mesh.quads.len();
        grains.push(grain);
    }
    const MAX_ELEMENTS: usize = 5_000_000;
    if elements > MAX_ELEMENTS {
        return Err(EngineError::Build {
            field: "method.elements_per_diameter".into(),
            reason: format!("the grains hold {elements} elements (at most {MAX_ELEMENTS}); coarsen the mesh"),
        });
    }
    Ok(grains)
}

/// Where grain `k`'s nodes, elements and boundary nodes start in a saved state's arrays
/// ([`StateMeshes`]).
#[derive(Debug, Default, Clone, Copy)]
struct Restored {
    node: usize,
    element: usize,
    boundary: usize,
}

/// Grain `k` from a saved state's meshes (checked by validation: its arrays agree, its node
/// numbers are its own and its elements are neither degenerate nor inverted), its law `law`
/// (index and law), density (kg/m³) and friction those of the new scene's material.
fn restore_grain(
    saved: &StateMeshes,
    k: usize,
    from: &mut Restored,
    law: usize,
    constitutive: &dyn ConstitutiveLaw,
    density: Real,
    friction: Real,
) -> Result<Grain, EngineError> {
    let (n, e, b) = (saved.node_count[k] as usize, saved.element_count[k] as usize, saved.boundary_count[k] as usize);
    let at = *from;
    *from = Restored { node: at.node + n, element: at.element + e, boundary: at.boundary + b };
    let v2 = |v: &Vec<f64>| V2::new(v[0], v[1]);
    let nodes = at.node..at.node + n;
    let mesh = Mesh {
        nodes: saved.reference[nodes.clone()].iter().map(v2).collect(),
        quads: saved.elements[at.element..at.element + e].iter().map(|q| [q[0], q[1], q[2], q[3]]).collect(),
        boundary: saved.boundary[at.boundary..at.boundary + b].to_vec(),
    };
    let failed = |reason: String| EngineError::Build { field: "start_from.state.meshes".into(), reason: format!("grain {k}: {reason}") };
    let mut body = Body::new(mesh, density, true).map_err(|f| failed(f.to_string()))?;
    let u: Vec<V2> = saved.displacement[nodes.clone()].iter().map(v2).collect();
    let v: Vec<V2> = saved.velocity[nodes].iter().map(v2).collect();
    let points = at.element * GAUSS_POINTS..(at.element + e) * GAUSS_POINTS;
    let history: Option<Vec<History>> = (!saved.plastic.is_empty()).then(|| {
        points
            .map(|p| {
                let c = &saved.plastic[p];
                History { inv_plastic: PlaneSym { xx: c[0], xy: c[1], yy: c[2], zz: c[3] }, alpha: saved.plastic_strain[p] }
            })
            .collect()
    });
    body.restore(constitutive, &u, &v, history.as_deref()).map_err(|f| failed(f.to_string()))?;
    Ok(Grain { body, law, friction, radius: saved.radius0[k] })
}

/// The grains' meshes as a saved state holds them ([`StateMeshes`]); the Gauss points'
/// histories only when one of them is not at rest.
fn saved_meshes(sys: &System) -> StateMeshes {
    let bodies = || sys.grains.iter().map(|g| &g.body);
    let pair = |v: &V2| vec![v.x, v.y];
    let mut s = StateMeshes {
        radius0: sys.grains.iter().map(|g| g.radius).collect(),
        node_count: bodies().map(|b| b.nodes() as u32).collect(),
        element_count: bodies().map(|b| b.mesh.quads.len() as u32).collect(),
        boundary_count: bodies().map(|b| b.mesh.boundary.len() as u32).collect(),
        reference: bodies().flat_map(|b| b.mesh.nodes.iter().map(pair)).collect(),
        displacement: bodies().flat_map(|b| b.u.iter().map(pair)).collect(),
        velocity: bodies().flat_map(|b| b.v.iter().map(pair)).collect(),
        elements: bodies().flat_map(|b| b.mesh.quads.iter().map(|q| q.to_vec())).collect(),
        boundary: bodies().flat_map(|b| b.mesh.boundary.iter().copied()).collect(),
        split_depth: sys.progress.splitting.level().0,
        split_calm: sys.progress.splitting.level().1,
        impulses: sys.warm.saved(),
        ..StateMeshes::default()
    };
    let histories = || bodies().flat_map(|b| b.states.iter().flat_map(|st| st.history.iter()));
    if histories().any(|h| *h != History::default()) {
        for h in histories() {
            let c = &h.inv_plastic;
            s.plastic.push(vec![c.xx, c.xy, c.yy, c.zz]);
            s.plastic_strain.push(h.alpha);
        }
    }
    s
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
}

impl Method for FemParams {
    fn fit(&mut self, scene: &Scene, _given: &serde_json::Value, c: &mut Checker) {
        crate::methods::fit::soft_grains(scene, "fem", self.solver.time_step.is_some(), c);
    }

    fn build(&self, scene: &Scene) -> Result<Box<dyn Simulation>, EngineError> {
        Ok(Box::new(fem(scene, self)?))
    }

    crate::method_common!("fem", solver.threads);
}
