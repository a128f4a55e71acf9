//! [`RigidWorld`]: the particles of a rigid-grain method in their box, with the walls, the drum,
//! the grains glued to walls, the granule's field and the clock, and what DEM and contact
//! dynamics do to them the same way.

use crate::error::EngineError;
use crate::geometry::Domain;
use crate::loading::{Drum, Wall};
use crate::math::{Real, Vec3};
use crate::methods::world;
use crate::observe::cluster::{measure_cluster, ClusterTrack};
use crate::observe::{measure, rattler_threshold, ContactRecord, Sample, ShearGeometry, Snapshot, SystemView};
use crate::particles::Particles;
use crate::scene::{Controls, Material, Scene, StateFile};

/// Marks a particle glued to no wall in [`RigidWorld::glued_to`].
pub const NOT_GLUED: u16 = u16::MAX;

/// The world a rigid-grain method (DEM, contact dynamics) moves: particles, box, boundaries,
/// imposed fields and clock. The method owns how the grains interact and how a step advances
/// them; the world owns everything else, written once for both.
pub struct RigidWorld {
    /// 2 or 3.
    pub dim: usize,
    /// Gravity, m/s² (held at zero while aggregates relax).
    pub gravity: Vec3,
    /// The scene's materials.
    pub materials: Vec<Material>,
    /// The particles.
    pub p: Particles,
    /// The box, its periodic axes and Lees-Edwards shear.
    pub domain: Domain,
    /// The container's plane walls.
    pub walls: Vec<Wall>,
    /// The rotating drum, if the scene has one: the boundary after the walls.
    pub drum: Option<Drum>,
    /// Grains glued to a wall (rough walls): (particle, wall), in particle order.
    pub glued: Vec<(u32, u16)>,
    /// The wall each particle is glued to ([`NOT_GLUED`] for none); empty while none is.
    pub glued_to: Vec<u16>,
    /// Centre of the scene's granule ball, where the centripetal field pulls.
    pub granule_center: Option<Vec3>,
    /// Centripetal field: centre and acceleration, m/s² (while a granule forms).
    pub field: Option<(Vec3, Real)>,
    /// Steps done.
    pub step: u64,
    /// Simulated time, s.
    pub time: Real,
    /// Box lengths at the start, m (for the strain).
    pub len0: Vec3,
    /// Volume (area in 2D) of the grains, m^D.
    pub solid_volume: Real,
    /// Number-mean diameter, m.
    pub mean_diameter: Real,
    /// The method's own thread pool (`method.threads`), or none for rayon's global one.
    pub pool: Option<rayon::ThreadPool>,
    /// Built from a checkpoint's state to go on from it ([`Scene::continue_saved_run`]): the
    /// particles are in the state's order.
    pub continued: bool,
    /// The wet grains' cluster followed from sample to sample ([`crate::observe::cluster`]).
    pub cluster: ClusterTrack,
}

impl RigidWorld {
    /// The world of `scene` with its placed particles `p` in `domain`, the `walls` the method
    /// built, and a pool of `threads` threads (0: the global pool).
    pub fn new(scene: &Scene, p: Particles, domain: Domain, walls: Vec<Wall>, threads: usize) -> Result<Self, EngineError> {
        let n = p.len().max(1) as Real;
        Ok(Self {
            dim: scene.dim,
            gravity: scene.gravity,
            materials: scene.materials.clone(),
            solid_volume: p.radius.iter().map(|&r| Particles::volume_of(scene.dim, r)).sum(),
            mean_diameter: 2.0 * p.radius.iter().sum::<Real>() / n,
            len0: domain.hi - domain.lo,
            p,
            domain,
            walls,
            drum: scene.container.drum.map(Drum::new),
            glued: Vec::new(),
            glued_to: Vec::new(),
            granule_center: scene.container.granule.map(|b| b.center),
            field: None,
            step: 0,
            time: 0.0,
            pool: world::own_pool(threads)?,
            continued: scene.continues_saved_run(),
            cluster: ClusterTrack::default(),
        })
    }

    /// Packing fraction: the grains' volume over the box's.
    pub fn packing_fraction(&self) -> Real {
        self.solid_volume / self.domain.volume()
    }

    /// Strain magnitude since the start: the Lees-Edwards shear `γ̇ t`, or the largest
    /// logarithmic change of a box length.
    pub fn strain(&self) -> Real {
        if self.domain.sheared() {
            return (self.domain.shear_rate * self.time).abs();
        }
        (0..self.dim).map(|a| (self.domain.length(a) / self.len0[a]).ln().abs()).fold(0.0, f64::max)
    }

    /// Box lengths, m.
    pub fn box_lengths(&self) -> Vec3 {
        self.domain.hi - self.domain.lo
    }

    /// Number-mean diameter (m) and solid density (kg/m³).
    pub fn grain_scales(&self) -> (Real, Real) {
        let mass: Real = self.p.mass.iter().sum();
        (self.mean_diameter, if self.solid_volume > 0.0 { mass / self.solid_volume } else { 0.0 })
    }

    /// The particles and box now, as a state file.
    pub fn saved_state(&self) -> StateFile {
        world::saved_state(self.time, self.step, &self.domain, &self.materials, &self.p)
    }

    /// Area (length in 2D) of the faces normal to `axis`, m^(D-1).
    pub fn wall_area(&self, axis: usize) -> Real {
        world::wall_area(&self.domain, axis)
    }

    /// Where a shear rate is defined ([`world::shear_geometry`]).
    pub fn shear_geometry(&self) -> Option<ShearGeometry> {
        world::shear_geometry(&self.domain, &self.walls)
    }

    /// Largest relative error of a stress-controlled wall against its target (0 if none).
    pub fn wall_stress_error(&self) -> Real {
        world::wall_stress_error(&self.walls, &self.domain)
    }

    /// Translational kinetic energy of the grains, J (J/m in 2D). A rattler spinning between
    /// frictionless walls keeps its spin for ever, yet the packing is at rest: spins are left
    /// out.
    pub fn kinetic_energy(&self) -> Real {
        0.5 * self.p.vel.iter().zip(&self.p.mass).map(|(v, m)| m * v.norm_squared()).sum::<Real>()
    }

    /// Mean norm of the net force on a grain, N.
    pub fn mean_net_force(&self) -> Real {
        self.p.force.iter().map(|f| f.norm()).sum::<Real>() / self.p.len().max(1) as Real
    }

    /// The first particle whose position or velocity is not finite.
    pub fn non_finite(&self) -> Option<usize> {
        let p = &self.p;
        (0..p.len()).find(|&i| !(p.pos[i].iter().all(|x| x.is_finite()) && p.vel[i].iter().all(|x| x.is_finite())))
    }

    /// The metrics of the state with these `contacts`, the stored `elastic_energy` (J) and the
    /// rattler rule for `frictional` grains; the wet grains' followed cluster moves on to this
    /// sample.
    pub fn measure(&mut self, contacts: &[ContactRecord], elastic_energy: Real, frictional: bool) -> Sample {
        let walls = world::wall_views(&self.walls, &self.domain);
        let mut sample = measure(&SystemView {
            dim: self.dim,
            step: self.step,
            time: self.time,
            particles: &self.p,
            volume: self.domain.volume(),
            contacts,
            walls: &walls,
            shear: self.shear_geometry(),
            elastic_energy,
            rattler_threshold: rattler_threshold(self.dim, frictional),
            drum: self.drum.as_ref().map(Drum::view),
            deformable: None,
            domain: &self.domain,
        });
        sample.cluster = measure_cluster(&self.p, self.dim, contacts, &mut self.cluster).map(Box::new);
        sample
    }

    /// The particles, `contacts` and walls now; the drum's shell carries `drum_loads`, the
    /// (position, force) of each grain on it.
    pub fn snapshot(&self, contacts: Vec<ContactRecord>, drum_loads: Vec<(Vec3, Vec3)>) -> Snapshot {
        let p = &self.p;
        let (position, velocity) = world::wrapped(&self.domain, p);
        Snapshot {
            dim: self.dim,
            step: self.step,
            time: self.time,
            lo: self.domain.lo,
            hi: self.domain.hi,
            position,
            radius: p.radius.clone(),
            velocity,
            omega: p.omega.clone(),
            force: p.force.clone(),
            contacts,
            walls: world::wall_faces(&self.walls),
            drum: self.drum.as_ref().map(|d| d.shell(drum_loads.into_iter())),
            material_points: None,
        }
    }

    /// Applies the controls that act on the world alike for both methods: the drum's speed, the
    /// walls' motions, the centripetal field, closing the walls of an axis onto the grains and
    /// gluing grains to the walls. Returns whether walls were closed (the method then finds
    /// its neighbours again). The cell's deformation, the shear rate, the friction and the
    /// damping are the method's.
    pub fn apply_controls(&mut self, controls: &Controls) -> bool {
        if let (Some(w), Some(drum)) = (controls.drum_angular_velocity, self.drum.as_mut()) {
            drum.angular_velocity = w;
        }
        for def in &controls.walls {
            if let Some(w) = self.walls.iter_mut().find(|w| w.face == def.face) {
                w.set_motion(def.motion);
            }
        }
        if let Some(a) = controls.centripetal {
            self.field = self.granule_center.filter(|_| a != 0.0).map(|c| (c, a));
        }
        let closed = controls.close_walls.is_some_and(|axis| self.close_walls(axis));
        if let Some(gap) = controls.glue {
            self.glue_to_walls(gap);
        }
        closed
    }

    /// Glues to each wall the grains whose surface lies within `gap` mean diameters of it (rough
    /// walls): they keep their place against the wall, move with it and do not turn (infinite
    /// mass and inertia; each method moves them with their wall).
    pub fn glue_to_walls(&mut self, gap: Real) {
        let p = &mut self.p;
        let mean_d = 2.0 * p.radius.iter().sum::<Real>() / p.len().max(1) as Real;
        if self.glued_to.is_empty() {
            self.glued_to = vec![NOT_GLUED; p.len()];
        }
        for (i, glue) in self.glued_to.iter_mut().enumerate() {
            if *glue != NOT_GLUED {
                continue;
            }
            let near = self.walls.iter().position(|w| {
                let n = w.normal();
                (p.pos[i][w.face.axis] - w.position) * n[w.face.axis] - p.radius[i] <= gap * mean_d
            });
            if let Some(w) = near {
                *glue = w as u16;
                self.glued.push((i as u32, w as u16));
                hold_on_wall(p, i, &self.walls[w]);
            }
        }
        self.glued.sort_unstable();
    }

    /// Glues the grains of `list` (particle, wall) to their walls, as [`Self::glue_to_walls`]
    /// left them in the run a checkpoint was taken from; why not if a particle or a wall does
    /// not exist or a grain is listed twice.
    pub fn glue(&mut self, list: &[(u32, u16)]) -> Result<(), String> {
        if list.is_empty() {
            return Ok(());
        }
        let n = self.p.len();
        if self.glued_to.is_empty() {
            self.glued_to = vec![NOT_GLUED; n];
        }
        for &(i, w) in list {
            let (k, wall) = (i as usize, w as usize);
            if k >= n || wall >= self.walls.len() {
                return Err(format!("grain {i} glued to wall {w}: the state has {n} particles and the scene {} walls", self.walls.len()));
            }
            if self.glued_to[k] != NOT_GLUED {
                return Err(format!("grain {i} is glued twice"));
            }
            self.glued_to[k] = w;
            self.glued.push((i, w));
            hold_on_wall(&mut self.p, k, &self.walls[wall]);
        }
        self.glued.sort_unstable();
        Ok(())
    }

    /// Moves the two walls of `axis` onto the grains' extent along it, so that they touch the
    /// outermost grains (the granule's plates); false if there are no grains to close on.
    pub fn close_walls(&mut self, axis: usize) -> bool {
        let p = &self.p;
        let lo = (0..p.len()).map(|i| p.pos[i][axis] - p.radius[i]).fold(Real::INFINITY, Real::min);
        let hi = (0..p.len()).map(|i| p.pos[i][axis] + p.radius[i]).fold(Real::NEG_INFINITY, Real::max);
        if !(lo.is_finite() && hi > lo) {
            return false;
        }
        for w in self.walls.iter_mut().filter(|w| w.face.axis == axis) {
            w.position = if w.face.upper { hi } else { lo };
        }
        self.domain.lo[axis] = lo;
        self.domain.hi[axis] = hi;
        true
    }

    /// Sets the Lees-Edwards shear rate ([`world::impose_shear_rate`]); the grains must be in
    /// the box.
    pub fn impose_shear_rate(&mut self, rate: Real) {
        world::impose_shear_rate(&mut self.domain, &mut self.p, rate);
    }
}

/// Makes grain `i` part of `wall`: infinite mass and inertia, the wall's velocity, no spin.
fn hold_on_wall(p: &mut Particles, i: usize, wall: &Wall) {
    p.inv_mass[i] = 0.0;
    p.inv_inertia[i] = 0.0;
    p.vel[i] = wall.velocity;
    p.omega[i] = Vec3::zeros();
}
