//! Soft-contact DEM (Cundall-Strack "molecular dynamics"; Nezamabadi 2020, §1.1.1; Roux &
//! Chevoir 2005, §2.1, §2.2.1; docs/physics.md §2): explicit velocity-Verlet integration of
//! Newton-Euler equations with the contact laws of [`crate::contact`], cell-list Verlet
//! neighbour search and parallel force loops.
//!
//! One step runs the stages of [`Stage`] in their declared order.

pub mod bench_suite;
mod bonds;
mod forces;
mod pair_state;
pub mod params;
pub use params::{DemParams, DemParamsSpec};
mod relax;
mod stability;
pub mod timestep;
mod wall_contacts;

use rayon::prelude::*;

use super::world;
use crate::contact::{ContactTable, NormalForce};
use crate::error::EngineError;
use crate::geometry::{Domain, NearPairs, NeighborList};
use crate::loading::{CellDeformation, Wall};
use crate::math::{Real, Vec3};
use crate::methods::rigid::{RigidMethod, RigidWorld};
use crate::observe::{ContactRecord, Sample};
use crate::particles::Particles;
use crate::run::{Balance, GrainModel};
use crate::scene::{Controls, Deformation, Material, Scene};
use forces::LOOP_CHUNK;
use pair_state::{PairBlock, PairSprings};
use stability::EnergyBudget;
use timestep::{collision_time, Bodies, CollisionTime};
use wall_contacts::WallContacts;

/// The stages of one DEM step, in execution order:
/// 1. `InitialIntegrate`: half kick of velocities and spins and drift of positions, in one pass
///    that also packs positions for the pair scan and measures the largest displacement for the
///    near pairs (particles are wrapped back into the periodic box at the next neighbour build);
/// 2. `Boundaries`: walls and periodic cell move, Lees-Edwards offset advances;
/// 3. `NeighborUpdate`: the Verlet list is rebuilt if a particle moved more than half the skin;
/// 4. `Force`: pair forces (a scan of the near pairs, refiltered from the Verlet list when
///    stale), walls, then the gather per particle with gravity;
/// 5. `FinalIntegrate`: second half kick, done by the gather of the force stage for the
///    particles it has just summed (one pass over memory instead of two);
/// 6. `Check`: every few steps, the stability guard.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Half kick and drift.
    InitialIntegrate,
    /// Walls, cell and shear boundary move.
    Boundaries,
    /// Neighbour list refresh.
    NeighborUpdate,
    /// Forces and torques.
    Force,
    /// Second half kick.
    FinalIntegrate,
    /// Stability guard.
    Check,
}

/// Wall-clock seconds spent in each stage (collected only when enabled with
/// [`Dem::set_profiling`]; `sable bench --profile` prints them).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Half kicks and drift.
    pub integrate: f64,
    /// Walls, cell deformation, Lees-Edwards offset.
    pub boundaries: f64,
    /// Rebuild test and rebuilds.
    pub neighbors: f64,
    /// Pair forces: near scan (or filtering) and contact laws.
    pub pairs: f64,
    /// Wall forces and the gather of every force on the particles (with the second half kick).
    pub forces: f64,
    /// Stability guard.
    pub check: f64,
    /// Samples (the guard's scan, contacts and metrics), outside the steps.
    pub sampling: f64,
}

/// Margin of the near pairs as a fraction of the Verlet skin (see
/// [`crate::geometry::near_pairs`]): smaller means fewer pairs scanned per step but more
/// frequent scans of the whole list.
const NEAR_GAP: Real = 0.15;

/// How often (steps) the stability guard runs and the pressure servo updates.
const CHECK_EVERY: u64 = 20;
const SERVO_EVERY: u64 = 10;

/// A soft-contact DEM simulation.
pub struct Dem {
    /// The particles, box, walls, drum and clock ([`RigidWorld`]).
    w: RigidWorld,
    dt: Real,
    params: DemParams,
    collision: CollisionTime,
    table: ContactTable,
    /// Laws of the particle-wall contacts: those of the scene's materials (a stage's friction
    /// override applies between particles only).
    wall_table: ContactTable,
    /// The method's own local damping (a stage may override it).
    base_local_damping: Real,
    wall_material: usize,
    deformation: Option<CellDeformation>,
    nl: NeighborList,
    /// The pairs of `nl` close enough to touch within the next few steps.
    near: NearPairs,
    /// The interacting pairs of each block of particles, with their springs and forces, in
    /// pair order ([`pair_state`]).
    pairs: Vec<PairBlock>,
    /// The springs of the evaluation before (scratch of the force stage).
    previous_springs: Vec<PairSprings>,
    /// The particles each block's records touch: the smallest and largest second particle j
    /// (`(u32::MAX, 0)` for a block without records), written with the records, so that a
    /// gather task skips the blocks that cannot reach its particles.
    reach: Vec<(u32, u32)>,
    /// The pairs of primaries of one aggregate, which attract ([`bonds`]); empty without
    /// aggregates.
    bonds: bonds::Bonds,
    /// Position and radius of each particle, packed for the pair loop: written by the drift,
    /// repacked before the force stage when positions changed otherwise (`xr_current` false).
    xr: Vec<[Real; 4]>,
    xr_current: bool,
    /// The end-of-step predictions of each particle's velocity and spin ([`Kin`]): written by
    /// the drift, recomputed before the force stage when velocities or forces changed otherwise
    /// (`kin_current` false).
    kin: Vec<Kin>,
    kin_current: bool,
    /// The largest squared displacement since the last neighbour build, m², measured by this
    /// step's drift (`None` when positions moved after it, or the particles are not those of
    /// the build): saves the neighbour check a pass over the positions.
    drift2: Option<Real>,
    needs_extra: bool,
    /// The particle-wall contacts: candidates, records with their springs, reactions
    /// ([`wall_contacts`]); slots are the plane walls, then the drum.
    wall_contacts: WallContacts,
    budget: EnergyBudget,
    profile: Option<StageTimes>,
}

impl Dem {
    /// Builds the simulation: places particles, chooses the time step, builds the neighbour list
    /// and evaluates the initial forces.
    pub fn new(scene: &Scene, params: &DemParams) -> Result<Self, EngineError> {
        if let Some(m) = scene.materials.iter().find(|m| m.cohesion.is_some()) {
            // Roux & Chevoir 2005, §2.2.3's constant attraction is a law for rigid grains; soft contacts would need
            // RC's own adhesion law (a force growing with the overlap), which DEM lacks.
            return Err(EngineError::Build {
                field: format!("materials.{}.cohesion", m.name),
                reason: "the constant cohesion F_0 within D_0 is a law of rigid grains: use method \"cd\"".into(),
            });
        }
        let c = &scene.container;
        let (p, domain) = world::initial_particles(scene)?;
        let table = ContactTable::new(&scene.materials);
        let wall_material = c.wall_material.unwrap_or(0);

        // Lightest particle and smallest radius of each material, for the collision time.
        let mut lightest: Vec<Option<(Real, Real)>> = vec![None; scene.materials.len()];
        for k in 0..p.len() {
            let m = p.material[k] as usize;
            let e = lightest[m].get_or_insert((Real::INFINITY, Real::INFINITY));
            e.0 = e.0.min(p.mass[k]);
            e.1 = e.1.min(p.radius[k]);
        }
        let v_ref = params.reference_velocity.unwrap_or_else(|| world::reference_velocity(scene, &p));
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        let has_walls = !c.walls.is_empty() || c.drum.is_some();
        let bodies = Bodies { lightest: &lightest, names: &names, wall_material: has_walls.then_some(wall_material) };
        let collision = relax::with_bonds(collision_time(&table, &bodies, v_ref), &p);
        let dt = params.time_step.unwrap_or(params.time_step_fraction * collision.t_c);
        if !(dt.is_finite() && dt > 0.0) {
            return Err(EngineError::Build {
                field: "method.time_step".into(),
                reason: format!("could not derive a time step from the collision time {:e} s; give method.time_step", collision.t_c),
            });
        }

        let rmin = p.radius.iter().copied().fold(Real::INFINITY, f64::min);
        let rmax = p.radius.iter().copied().fold(0.0, f64::max);
        // An aggregate's primaries attract to the bond's cut-off.
        let range =
            p.bondings.iter().map(|b| b.attraction.range()).fold(table.laws().iter().map(|l| l.range()).fold(0.0, f64::max), f64::max);
        let skin = params.skin * 2.0 * rmin;
        // Periodic boxes must be wide enough for minimum images to be unique.
        for a in 0..scene.dim {
            let need = 2.0 * (2.0 * rmax + range + skin);
            if c.periodic[a] && domain.length(a) < need {
                return Err(EngineError::Build {
                    field: format!("container.max[{a}]"),
                    reason: format!(
                        "periodic length {:e} m along {} is below {need:e} m (twice the interaction reach): enlarge the box",
                        domain.length(a),
                        crate::math::AXES[a]
                    ),
                });
            }
        }
        let k_eff = collision_stiffness(&collision, &p);
        // Largest normal dashpot of a particle-wall contact (at an overlap of 1% of the radius,
        // for laws whose damping depends on it).
        let wall_dashpot = (0..p.len())
            .map(|i| table.get(p.material[i] as usize, wall_material).normal.damping(0.01 * p.radius[i], p.radius[i], p.mass[i]))
            .fold(0.0, Real::max);
        let walls: Vec<Wall> = c
            .walls
            .iter()
            .map(|w| {
                let pos = if w.face.upper { c.hi[w.face.axis] } else { c.lo[w.face.axis] };
                // Default servo gain: the wall moves by at most ~5% of the overlap change that the
                // stress error would cause in one step (stiffness per area ~ k / d^(D-1)).
                let gain = 0.05 * (2.0 * rmax).powi(scene.dim as i32 - 1) / (k_eff * dt);
                // One wall contact per d_min^(D-1) of wall, at most.
                let dashpot_per_area = wall_dashpot / (2.0 * rmin).powi(scene.dim as i32 - 1);
                Wall::new(w.face, pos, w.motion, gain, dashpot_per_area)
            })
            .collect();
        let nw = walls.len() + usize::from(c.drum.is_some());
        let needs_extra = table.laws().iter().any(|l| l.rolling.is_some() || l.capillary.is_some());
        let n = p.len();
        let mut sim = Self {
            w: RigidWorld::new(scene, p, domain, walls, params.threads)?,
            dt,
            params: params.clone(),
            collision,
            wall_table: table.clone(),
            table,
            base_local_damping: params.local_damping,
            wall_material,
            deformation: c.deformation.map(CellDeformation::new),
            nl: NeighborList::new(range, skin),
            near: NearPairs::new(n.div_ceil(forces::PARTICLE_BLOCK), NEAR_GAP * skin),
            pairs: vec![PairBlock::default(); n.div_ceil(forces::PARTICLE_BLOCK)],
            previous_springs: vec![PairSprings::default(); n.div_ceil(forces::PARTICLE_BLOCK)],
            reach: vec![(u32::MAX, 0); n.div_ceil(forces::PARTICLE_BLOCK)],
            bonds: bonds::Bonds::default(),
            xr: vec![[0.0; 4]; n],
            xr_current: false,
            kin: vec![Kin::default(); n],
            kin_current: false,
            drift2: None,
            needs_extra,
            wall_contacts: WallContacts::new(n.div_ceil(forces::PARTICLE_BLOCK), nw),
            budget: EnergyBudget::default(),
            profile: None,
        };
        sim.refresh_neighbors();
        sim.compute_forces(false);
        if sim.w.p.aggregate_count() > 0 {
            sim.relax_aggregates()?;
        }
        sim.budget = EnergyBudget::start(sim.mechanical_energy());
        Ok(sim)
    }

    /// Time step, s.
    pub fn time_step(&self) -> Real {
        self.dt
    }

    /// Collision-time estimate used for the time step and messages.
    pub fn collision_time(&self) -> &CollisionTime {
        &self.collision
    }

    /// The particles (read only).
    pub fn particles(&self) -> &Particles {
        &self.w.p
    }

    /// Mutable access to the particles, for tests and custom set-ups. Call
    /// [`Dem::reset_forces`] after moving particles.
    pub fn particles_mut(&mut self) -> &mut Particles {
        // Particles may be moved by any amount: the near pairs must be filtered again.
        self.near.invalidate();
        self.xr_current = false;
        self.kin_current = false;
        &mut self.w.p
    }

    /// The box.
    pub fn domain(&self) -> &Domain {
        &self.w.domain
    }

    /// The walls.
    pub fn walls(&self) -> &[Wall] {
        &self.w.walls
    }

    /// What the periodic cell's deformation imposes now, if anything.
    pub fn cell_deformation(&self) -> Option<Deformation> {
        self.deformation.as_ref().map(|d| d.kind)
    }

    /// The Verlet skin, m.
    pub fn skin(&self) -> Real {
        self.nl.skin
    }

    /// Number of neighbour-list builds so far.
    pub fn neighbor_builds(&self) -> u64 {
        self.nl.builds
    }

    /// Replaces the imposed deformation of the periodic cell (`None`: the cell keeps its size
    /// from now on). For multi-stage protocols, e.g. compress, then servo to a pressure, then
    /// relax at fixed volume. Deformation is only allowed on periodic axes.
    pub fn set_deformation(&mut self, deformation: Option<Deformation>) {
        self.deformation = deformation.map(CellDeformation::new);
        // The energy budget restarts from here (it only applies to a fixed cell).
        self.budget = EnergyBudget::start(self.mechanical_energy());
    }

    /// Starts (or stops) timing the stages of each step.
    pub fn set_profiling(&mut self, on: bool) {
        self.profile = on.then(StageTimes::default);
    }

    /// Time spent per stage since profiling started.
    pub fn stage_times(&self) -> Option<StageTimes> {
        self.profile
    }

    /// Number of pairs that interacted at the last force evaluation.
    pub fn interacting_pairs(&self) -> usize {
        self.pairs.iter().map(PairBlock::len).sum()
    }

    /// Number of particle-wall contacts (drum included) at the last force evaluation.
    pub fn wall_contact_count(&self) -> usize {
        self.wall_contacts.len()
    }

    /// The particle pairs (i < j) that interacted at the last force evaluation — touching, or
    /// held by a capillary bridge — whatever their force (a contact whose damped force is floored
    /// at zero still counts). For tests and diagnostics.
    pub fn interacting_pair_list(&self) -> Vec<(u32, u32)> {
        self.pairs.iter().flat_map(PairBlock::pairs).map(|c| (c.i.min(c.j), c.i.max(c.j))).collect()
    }

    /// Number of near pairs (the listed pairs scanned every step, see
    /// [`crate::geometry::near_pairs`]).
    pub fn near_pairs(&self) -> usize {
        self.near.len()
    }

    /// Number of times the near pairs were filtered from the neighbour list.
    pub fn near_filters(&self) -> u64 {
        self.near.filters
    }

    /// Number of pairs in the neighbour list.
    pub fn neighbor_pairs(&self) -> usize {
        self.nl.len()
    }

    /// Recomputes neighbours and forces after the state was changed from outside, and restarts
    /// the energy budget.
    pub fn reset_forces(&mut self) {
        self.refresh_neighbors();
        self.compute_forces(false);
        self.budget = EnergyBudget::start(self.mechanical_energy());
    }

    /// Heap bytes held by the simulation.
    pub fn heap_bytes(&self) -> usize {
        self.w.p.heap_bytes()
            + self.nl.heap_bytes()
            + self.near.heap_bytes()
            + self.pairs.iter().map(PairBlock::heap_bytes).sum::<usize>()
            + self.previous_springs.iter().map(PairSprings::heap_bytes).sum::<usize>()
            + self.xr.capacity() * 32
            + self.kin.capacity() * std::mem::size_of::<Kin>()
            + self.wall_contacts.heap_bytes()
            + self.bonds.heap_bytes()
    }

    /// Current contact forces as records (pairs and walls), for metrics and tests.
    pub fn contacts(&self) -> Vec<ContactRecord> {
        let mut records = Vec::new();
        // The attraction of the primaries of an aggregate, reported with their contact when
        // they touch (one record per pair, its net force: bonded when touching, as in CD).
        let mut attraction: std::collections::BTreeMap<(u32, u32), (Vec3, Vec3)> =
            self.bond_records().into_iter().map(|(i, j, f, d)| ((i, j), (f, d))).collect();
        for c in self.pairs.iter().flat_map(PairBlock::pairs) {
            let bond = attraction.remove(&(c.i, c.j)).map(|(f, _)| f);
            let bridge = c.extra.is_some_and(|e| e.bridge);
            if c.out.force == Vec3::zeros() && !bridge && bond.is_none() {
                continue;
            }
            let (d, _) = self.nl.separation(c.q as usize, &self.w.p.pos, &self.w.domain);
            let touching = d.norm() < self.w.p.radius[c.i as usize] + self.w.p.radius[c.j as usize];
            let force = c.out.force + bond.unwrap_or_else(Vec3::zeros);
            let bonded = bridge || (touching && bond.is_some());
            records.push(ContactRecord { i: c.i, j: Some(c.j), force, branch: d, touching, bonded });
        }
        for ((i, j), (force, branch)) in attraction {
            records.push(ContactRecord { i, j: Some(j), force, branch, touching: false, bonded: false });
        }
        for c in self.wall_contacts.iter().filter(|c| c.force != Vec3::zeros()) {
            let i = c.i as usize;
            let branch = match self.w.walls.get(c.w as usize) {
                Some(wall) => {
                    let n = wall.normal();
                    n * ((self.w.p.pos[i][wall.face.axis] - wall.position) * n[wall.face.axis])
                }
                None => match self.w.drum.as_ref().and_then(|d| d.touch(&self.w.p.pos[i], self.w.p.radius[i])) {
                    Some((n, delta)) => n * (self.w.p.radius[i] - delta),
                    None => continue,
                },
            };
            records.push(ContactRecord { i: c.i, j: None, force: c.force, branch, touching: true, bonded: false });
        }
        records
    }

    fn refresh_neighbors(&mut self) {
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
    fn glued_loads(&mut self) {
        for &(i, w) in &self.w.glued {
            let i = i as usize;
            let own = self.w.gravity * self.w.p.mass[i];
            self.w.walls[w as usize].force += self.w.p.force[i] - own;
        }
    }

    /// Wall contact slots per particle: the plane walls, then the drum.
    fn wall_slots(&self) -> usize {
        self.w.walls.len() + usize::from(self.w.drum.is_some())
    }

    /// Diagonal of the stress tensor from the virial of the current forces and the kinetic part
    /// (Pa; velocities relative to the Lees-Edwards profile), and the affine estimate of the bulk
    /// stiffness of the contact network, `sum k |l|² / (D² V)` (Pa).
    ///
    /// The forces are the contacts' and the attraction of aggregates' primaries ([`bonds`]):
    /// without the attraction, the repulsion that balances it inside every aggregate reads as a
    /// pressure of order `p_I`, and a cell servoed to a lower pressure opened instead of closing.
    /// The stiffness is the contacts' alone (the attraction only softens a stretched bond).
    fn stress_and_stiffness(&self) -> (Vec3, Real) {
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

    /// Half kick of velocities and spins, then drift of the particles by `v dt` with the new
    /// velocity, in one pass (the first half of velocity Verlet), which saves a sweep over memory
    /// and a parallel region per step; the pass also packs positions and velocities for the
    /// force stage. The drift reports the largest displacement to the near pairs, and the
    /// largest displacement since the last neighbour build to the neighbour stage
    /// ([`Dem::drift2`]). (The second half kick runs inside the gather of the force stage.)
    fn kick_and_drift(&mut self) {
        let h = 0.5 * self.dt;
        let dt = self.dt;
        let alpha = self.params.local_damping;
        let reference = self.nl.reference_positions();
        let measured = reference.len() == self.w.p.len();
        let p = &mut self.w.p;
        let (force, torque, inv_mass, inv_inertia, radius) = (&p.force, &p.torque, &p.inv_mass, &p.inv_inertia, &p.radius);
        // No wrap after the drift: particles return into the box at the next neighbour build.
        let (largest2, drift2) = p
            .vel
            .par_chunks_mut(LOOP_CHUNK)
            .zip(p.omega.par_chunks_mut(LOOP_CHUNK))
            .zip(p.pos.par_chunks_mut(LOOP_CHUNK))
            .zip(self.xr.par_chunks_mut(LOOP_CHUNK).zip(self.kin.par_chunks_mut(LOOP_CHUNK)))
            .enumerate()
            .map(|(c, (((vs, ws), xs), (xrs, kins)))| {
                let (mut largest2, mut drift2): (Real, Real) = (0.0, 0.0);
                let r = c * LOOP_CHUNK..c * LOOP_CHUNK + vs.len();
                let refs = if measured { &reference[r.clone()] } else { &[] };
                let parts =
                    force[r.clone()].iter().zip(&torque[r.clone()]).zip(&inv_mass[r.clone()]).zip(&inv_inertia[r.clone()]).zip(&radius[r]);
                let state = vs.iter_mut().zip(ws.iter_mut()).zip(xs.iter_mut()).zip(xrs.iter_mut().zip(kins.iter_mut()));
                for (k, ((((v, w), x), (xr, kin)), ((((f, t), im), ii), rad))) in state.zip(parts).enumerate() {
                    half_kick(v, w, f, t, h * im, h * ii, alpha);
                    *kin = Kin::predicted(v, w, f, t, h * im, h * ii);
                    let step = *v * dt;
                    *x += step;
                    largest2 = largest2.max(step.norm_squared());
                    if let Some(x0) = refs.get(k) {
                        drift2 = drift2.max((*x - x0).norm_squared());
                    }
                    *xr = [x.x, x.y, x.z, *rad];
                }
                (largest2, drift2)
            })
            .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
        self.near.add_motion(largest2.sqrt());
        self.drift2 = measured.then_some(drift2);
        self.xr_current = true;
        self.kin_current = true;
    }

    /// Packs every particle's velocities and predictions ([`Kin`]) from the current state.
    fn pack_kinematics(&mut self) {
        let h = 0.5 * self.dt;
        let p = &self.w.p;
        self.kin.par_chunks_mut(LOOP_CHUNK).enumerate().for_each(|(c, kins)| {
            for (k, kin) in kins.iter_mut().enumerate() {
                let i = c * LOOP_CHUNK + k;
                *kin = Kin::predicted(&p.vel[i], &p.omega[i], &p.force[i], &p.torque[i], h * p.inv_mass[i], h * p.inv_inertia[i]);
            }
        });
        self.kin_current = true;
    }
}

/// The end-of-step predictions of a particle's velocity and spin from its last force and torque
/// (`v + F h/m`, `w + T h/I`), which the contact dashpots use; written by the drift for the force
/// stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Kin {
    /// Predicted velocity at the end of the step, m/s.
    pub vp: Vec3,
    /// Predicted angular velocity at the end of the step, rad/s.
    pub wp: Vec3,
}

impl Kin {
    /// The prediction for a particle with velocity `v`, spin `w`, last force `f` and torque `t`
    /// (`h_im` = h/m, `h_ii` = h/I, h half the step).
    #[inline(always)]
    pub(crate) fn predicted(v: &Vec3, w: &Vec3, f: &Vec3, t: &Vec3, h_im: Real, h_ii: Real) -> Self {
        Self { vp: v + f * h_im, wp: w + t * h_ii }
    }
}

/// Half kick of one particle: `v += F h/m`, `w += T h/I` (`h_im` = h/m, `h_ii` = h/I), with
/// Cundall's local damping when `alpha > 0`.
#[inline(always)]
pub(crate) fn half_kick(v: &mut Vec3, w: &mut Vec3, f: &Vec3, t: &Vec3, h_im: Real, h_ii: Real, alpha: Real) {
    if alpha > 0.0 {
        *v += local_damping(f, v, alpha) * h_im;
        *w += local_damping(t, w, alpha) * h_ii;
    } else {
        *v += f * h_im;
        *w += t * h_ii;
    }
}

/// Cundall's local damping (Cundall & Strack 1979; Yade's `NewtonIntegrator.damping`): each
/// component of the force is reduced by `alpha` times its magnitude when it drives the motion
/// and increased when it opposes it, `F_k (1 - alpha sign(F_k v_k))`.
#[inline(always)]
fn local_damping(f: &Vec3, v: &Vec3, alpha: Real) -> Vec3 {
    let damp = |fk: Real, vk: Real| {
        let s = fk * vk;
        let sign = if s > 0.0 {
            1.0
        } else if s < 0.0 {
            -1.0
        } else {
            0.0
        };
        fk * (1.0 - alpha * sign)
    };
    Vec3::new(damp(f.x, v.x), damp(f.y, v.y), damp(f.z, v.z))
}

/// Effective stiffness of the limiting contact, N/m: m* (pi / t_c)², for servo gains.
fn collision_stiffness(c: &CollisionTime, p: &Particles) -> Real {
    let m = p.mass.iter().copied().fold(Real::INFINITY, f64::min);
    0.5 * m * (std::f64::consts::PI / c.t_c).powi(2)
}

impl RigidMethod for Dem {
    const NAME: &'static str = "dem";
    const GRAIN_MODEL: GrainModel = GrainModel::SoftContacts;

    fn world(&self) -> &RigidWorld {
        &self.w
    }

    fn world_mut(&mut self) -> &mut RigidWorld {
        &mut self.w
    }

    fn nominal_step(&self) -> Real {
        self.dt
    }

    fn advance(&mut self) -> Result<(), EngineError> {
        self.step_stages()
    }

    fn contact_records(&self) -> Vec<ContactRecord> {
        self.contacts()
    }

    fn drum_loads(&self) -> Vec<(Vec3, Vec3)> {
        let slot = self.w.walls.len() as u16;
        self.wall_contacts.iter().filter(|c| c.w == slot).map(|c| (self.w.p.pos[c.i as usize], c.force)).collect()
    }

    fn measure(&mut self) -> Result<Sample, EngineError> {
        let clock = self.profile.map(|_| std::time::Instant::now());
        let sample = self.take_sample();
        if let (Some(c), Some(t)) = (clock, self.profile.as_mut()) {
            t.sampling += c.elapsed().as_secs_f64();
        }
        sample
    }

    fn heap_size(&self) -> usize {
        self.heap_bytes()
    }

    fn controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        if self.w.apply_controls(controls) {
            // Walls closed onto the grains.
            self.refresh_neighbors();
            self.compute_forces(false);
        }
        if controls.glue.is_some() {
            self.kin_current = false;
        }
        if let Some(d) = controls.deformation {
            self.deformation = d.map(CellDeformation::new);
        }
        // Friction between particles; the walls keep their material's.
        self.table = match controls.friction {
            Some(mu) => ContactTable::new(&self.w.materials.iter().map(|m| Material { friction: mu, ..m.clone() }).collect::<Vec<_>>())
                .with_history_of(&self.wall_table),
            None => self.wall_table.clone(),
        };
        self.params.local_damping = controls.local_damping.unwrap_or(self.base_local_damping);
        if let Some(rate) = controls.shear_rate {
            // Into the box first (with the old images), so that every grain gets the profile of
            // its own position.
            self.refresh_neighbors();
            self.w.impose_shear_rate(rate);
            // The shear velocities of the images changed: pairs across the boundary must be found
            // again.
            self.refresh_neighbors();
            self.compute_forces(false);
        }
        // New boundary work and forces from here: the energy budget restarts.
        self.budget = EnergyBudget::start(self.mechanical_energy());
        Ok(())
    }

    fn equilibrium(&mut self) -> Balance {
        let kinetic = self.w.kinetic_energy();
        let elastic = self.elastic_energy();
        let net = self.w.mean_net_force();
        let (mut sum, mut count) = (0.0, 0usize);
        for c in self.pairs.iter().flat_map(PairBlock::pairs) {
            if c.out.force != Vec3::zeros() {
                sum += c.out.force.norm();
                count += 1;
            }
        }
        for c in self.wall_contacts.iter().filter(|c| c.force != Vec3::zeros()) {
            sum += c.force.norm();
            count += 1;
        }
        let mean_contact = if count > 0 { sum / count as Real } else { 0.0 };
        let unbalanced_force = if mean_contact > 0.0 { net / mean_contact } else { Real::INFINITY };
        // Stress-controlled boundaries against their targets.
        let mut stress_error = self.w.wall_stress_error();
        match self.deformation.as_ref().map(|d| d.kind) {
            Some(Deformation::Pressure { target, .. }) => {
                let (stress, _) = self.stress_and_stiffness();
                let pressure = (0..self.w.dim).map(|a| stress[a]).sum::<Real>() / self.w.dim as Real;
                stress_error = stress_error.max((pressure - target).abs() / target);
            }
            Some(Deformation::NormalStress { axis, target, .. }) => {
                let (stress, _) = self.stress_and_stiffness();
                stress_error = stress_error.max((stress[axis] - target).abs() / target);
            }
            _ => {}
        }
        Balance { kinetic_energy: kinetic, reference_energy: elastic, unbalanced_force, stress_error }
    }
}

impl Dem {
    /// Takes a sample: the guard's scan (its elastic energy), the contacts, the metrics.
    fn take_sample(&mut self) -> Result<Sample, EngineError> {
        let energies = self.check_stability()?;
        let contacts = self.contacts();
        let frictional = self.table.laws().iter().any(|l| l.friction > 0.0);
        let s = self.w.measure(&contacts, energies.elastic, frictional);
        if !s.is_finite() {
            return Err(self.unstable(crate::error::InstabilityCause::NonFinite { particle: 0 }));
        }
        Ok(s)
    }

    /// The stages of one step, in the order of [`Stage`].
    fn step_stages(&mut self) -> Result<(), EngineError> {
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
}
