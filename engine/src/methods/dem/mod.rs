//! Soft-contact DEM (Cundall-Strack "molecular dynamics"; Nezamabadi 2020, §1.1.1; Roux &
//! Chevoir 2005, §2.1, §2.2.1; docs/physics.md §2): explicit velocity-Verlet integration of
//! Newton-Euler equations with the contact laws of [`crate::contact`], cell-list Verlet
//! neighbour search and parallel force loops.
//!
//! One step runs the stages of [`Stage`] in their declared order (`step.rs`; velocity Verlet's
//! kicks and drift in `integrate.rs`). `rigid_method.rs` answers what the rigid-grain runner
//! asks of DEM: controls, samples, equilibrium.

pub mod bench_suite;
mod bonds;
mod forces;
mod history;
mod integrate;
mod pair_state;
pub mod params;
pub use params::{DemParams, DemParamsSpec};
mod relax;
mod rigid_method;
mod stability;
mod step;
mod tasks;
pub mod timestep;
mod wall_contacts;

use super::world;
use crate::contact::{ContactTable, NormalForce};
use crate::error::EngineError;
use crate::geometry::{Domain, NearPairs, NeighborList};
use crate::loading::{CellDeformation, Wall};
use crate::math::{Real, Vec3};
use crate::methods::rigid::RigidWorld;
use crate::observe::ContactRecord;
use crate::particles::Particles;
use crate::scene::{Deformation, Scene};
use integrate::Kin;
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
        refuse_cohesion(scene)?;
        let c = &scene.container;
        let (p, domain) = world::initial_particles(scene)?;
        let table = ContactTable::new(&scene.materials);
        let wall_material = c.wall_material.unwrap_or(0);

        let lightest = lightest_per_material(&p, scene.materials.len());
        let v_ref = params.reference_velocity.unwrap_or_else(|| world::reference_velocity(scene, &p));
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        let has_walls = !c.walls.is_empty() || c.drum.is_some();
        let bodies = Bodies { lightest: &lightest, names: &names, wall_material: has_walls.then_some(wall_material) };
        let collision = relax::with_bonds(collision_time(&table, &bodies, v_ref), &p);
        let dt = choose_time_step(params, collision.t_c)?;

        let rmin = p.radius.iter().copied().fold(Real::INFINITY, f64::min);
        let rmax = p.radius.iter().copied().fold(0.0, f64::max);
        // An aggregate's primaries attract to the bond's cut-off.
        let range =
            p.bondings.iter().map(|b| b.attraction.range()).fold(table.laws().iter().map(|l| l.range()).fold(0.0, f64::max), f64::max);
        let skin = params.skin * 2.0 * rmin;
        world::check_periodic_room(&domain, rmax, range, skin)?;
        let k_eff = collision_stiffness(&collision, &p);
        let walls = container_walls(scene, &p, &table, wall_material, k_eff, dt);
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
            near: NearPairs::new(n.div_ceil(tasks::PARTICLE_BLOCK), NEAR_GAP * skin),
            pairs: vec![PairBlock::default(); n.div_ceil(tasks::PARTICLE_BLOCK)],
            previous_springs: vec![PairSprings::default(); n.div_ceil(tasks::PARTICLE_BLOCK)],
            reach: vec![(u32::MAX, 0); n.div_ceil(tasks::PARTICLE_BLOCK)],
            bonds: bonds::Bonds::default(),
            xr: vec![[0.0; 4]; n],
            xr_current: false,
            kin: vec![Kin::default(); n],
            kin_current: false,
            drift2: None,
            needs_extra,
            wall_contacts: WallContacts::new(n.div_ceil(tasks::PARTICLE_BLOCK), nw),
            budget: EnergyBudget::default(),
            profile: None,
        };
        sim.refresh_neighbors();
        sim.compute_forces(false);
        // A checkpoint's aggregates were relaxed by the run that saved them.
        if sim.w.p.aggregate_count() > 0 && !scene.continues_saved_run() {
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

    /// Wall contact slots per particle: the plane walls, then the drum.
    fn wall_slots(&self) -> usize {
        self.w.walls.len() + usize::from(self.w.drum.is_some())
    }
}

/// Effective stiffness of the limiting contact, N/m: m* (pi / t_c)², for servo gains.
fn collision_stiffness(c: &CollisionTime, p: &Particles) -> Real {
    let m = p.mass.iter().copied().fold(Real::INFINITY, f64::min);
    0.5 * m * (std::f64::consts::PI / c.t_c).powi(2)
}

/// Refuses the constant cohesion of Roux & Chevoir 2005, a law of rigid grains.
fn refuse_cohesion(scene: &Scene) -> Result<(), EngineError> {
    if let Some(m) = scene.materials.iter().find(|m| m.cohesion.is_some()) {
        // Roux & Chevoir 2005, §2.2.3's constant attraction is a law for rigid grains; soft contacts would need
        // RC's own adhesion law (a force growing with the overlap), which DEM lacks.
        return Err(EngineError::Build {
            field: format!("materials.{}.cohesion", m.name),
            reason: "the constant cohesion F_0 within D_0 is a law of rigid grains: use method \"cd\"".into(),
        });
    }
    Ok(())
}

/// Lightest particle and smallest radius of each of the `materials`, for the collision time
/// (`None` for a material no particle is made of).
fn lightest_per_material(p: &Particles, materials: usize) -> Vec<Option<(Real, Real)>> {
    let mut lightest: Vec<Option<(Real, Real)>> = vec![None; materials];
    for k in 0..p.len() {
        let m = p.material[k] as usize;
        let e = lightest[m].get_or_insert((Real::INFINITY, Real::INFINITY));
        e.0 = e.0.min(p.mass[k]);
        e.1 = e.1.min(p.radius[k]);
    }
    lightest
}

/// The time step: given, or the parameters' fraction of the collision time `t_c`.
fn choose_time_step(params: &DemParams, t_c: Real) -> Result<Real, EngineError> {
    let dt = params.time_step.unwrap_or(params.time_step_fraction * t_c);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(EngineError::Build {
            field: "method.time_step".into(),
            reason: format!("could not derive a time step from the collision time {t_c:e} s; give method.time_step"),
        });
    }
    Ok(dt)
}

/// The container's walls, with their default servo gain (from the contact stiffness `k_eff`
/// and the step `dt`) and their largest dashpot per area.
fn container_walls(scene: &Scene, p: &Particles, table: &ContactTable, wall_material: usize, k_eff: Real, dt: Real) -> Vec<Wall> {
    let c = &scene.container;
    let rmin = p.radius.iter().copied().fold(Real::INFINITY, f64::min);
    let rmax = p.radius.iter().copied().fold(0.0, f64::max);
    // Largest normal dashpot of a particle-wall contact (at an overlap of 1% of the radius,
    // for laws whose damping depends on it).
    let wall_dashpot = (0..p.len())
        .map(|i| table.get(p.material[i] as usize, wall_material).normal.damping(0.01 * p.radius[i], p.radius[i], p.mass[i]))
        .fold(0.0, Real::max);
    c.walls
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
        .collect()
}
