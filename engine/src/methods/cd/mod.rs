//! Contact dynamics (Moreau-Jean non-smooth contact dynamics; Nezamabadi 2020, §1.1.2, Roux & Chevoir 2005, §2.2.3, docs/physics.md §3)
//! for rigid disks and spheres: implicit time stepping, no contact stiffness, the contact
//! impulses found by the non-linear Gauss-Seidel solver of [`crate::nscd`].
//!
//! One step, with `h` the time step and `theta` the implicitness:
//! 1. `NeighborUpdate`: the Verlet list is rebuilt if a particle moved more than half the skin;
//! 2. `Detect`: every listed pair and every particle-wall pair whose gap `g` at the start of
//!    the step, advanced by `(1 - theta) h u_n` (the approach at the start-of-step normal
//!    velocity), is closed (within [`ALERT`] of the smaller radius) becomes a contact of the
//!    step, with its frame, Delassus block,
//!    restitution target (raised to pull back an interpenetration beyond the slop,
//!    `method.slop`) and friction, and as warm start the impulse the same pair carried at
//!    the last step (projected on the new frame). Restitution applies to impacts: a pair that
//!    carried an impulse at the last step is a lasting contact and gets none (otherwise the
//!    approach velocity left by an unconverged solve, or by a wall pressing on, bounces back
//!    at every step and keeps a confined packing agitated). A pair whose gap is within
//!    `max_interpenetration` of the smaller radius, and whose start velocity would not close it
//!    within the whole step, is a contact of the step too ([`near_law`]: nothing within the
//!    step may drive it deeper than the slop): a grain squeezed out between converging
//!    neighbours leaves within the step faster than any speed at its start, and would otherwise
//!    go into a neighbour that the anticipation left out (in a 400-disk biaxial compression,
//!    grains at 0.05-0.07 m/s, twenty times the platen's speed, reached the 5% limit of the
//!    radius in one step);
//! 3. `Free`: velocities advance under gravity alone; walls take their imposed velocity, and a
//!    stress-controlled wall — a rigid plate of mass [`Cd::wall_mass`] free to move along its
//!    axis — is pushed by its target stress times its area;
//! 4. `Solve`: NLGS finds the impulses and the end-of-step velocities of grains and free walls
//!    together (the walls are bodies of the contact problem, as in LMGC90); with
//!    `method.sweep` coloured (by default from [`super::cd::Sweep::PARALLEL_FROM`] contacts),
//!    the contacts are stored in colour order and each colour is swept in parallel
//!    ([`crate::nscd::colour`]);
//! 5. `Integrate`: positions advance by `h (theta v+ + (1 - theta) v-)` (theta-scheme); forces
//!    and torques are stored as the mean over the step, `m (v+ - v-) / h`;
//! 6. `Boundaries`: walls take the reaction of their contacts and move by the theta-scheme (a
//!    stress-controlled one at most at `max_speed`);
//! 7. `Check`: non-finite values; interpenetration beyond `max_interpenetration` is checked
//!    when the next step detects its contacts.
//!
//! Lees-Edwards cells: a pair across the sheared boundary sees the image's velocity in its
//! contact velocity (`drive`), and the image offset advances with the positions. A deforming
//! periodic cell is the boundary slot after the walls and the drum: the grains are not remapped,
//! the cell's lengths move and the contacts across its boundary see them move; held at a stress,
//! the cell is a body of the contact problem ([`cell`]).
//!
//! Experiments: every experiment of DEM runs (a stage with local damping makes impacts
//! inelastic, [`laws::PairLaws::set_inelastic`]; a stage's equilibrium is judged on means over
//! the check interval, [`balance`]; an experiment's loading stages take the looser
//! `loading_violation_tolerance`, [`Cd::stage`]). The rotating drum is the boundary after
//! the walls (its contacts drive the grains with the rim's velocity and spin); the granule's
//! centripetal field acts in the free motion. A grain glued to a wall (rough walls) is part of the
//! wall: its contacts with the other grains are the wall's, seen from the free grain; a shearing
//! wall is a stress-controlled wall sliding at its shear rate times the gap.
//!
//! Rolling resistance is a graph on the contact's moment impulse ([`crate::nscd::Rolling`]).
//! Cohesion — the constant attraction F_0 within D_0 of Roux & Chevoir 2005, §2.2.3, and the capillary bridges of
//! wet grains (Nezamabadi 2020, eqs. 1.5–1.8, formed on contact, broken beyond the rupture distance) — shifts the
//! Signorini graph by the attraction over the step at the gap of the step's start; a pair
//! within range but apart is held by [`open_law`]. The bridges' lubrication (Nezamabadi 2020, eqs. 1.9–1.11) acts
//! implicitly on the end-of-step normal velocity ([`crate::nscd::LocalLaw::viscosity`]).
//! Primaries of one aggregate (the bonded particle method's grains,
//! [`crate::particles::aggregate`]) attract by their bond instead, in the same way, and touch
//! without bouncing, with the bond's friction; primaries of different aggregates follow their
//! materials' laws.
//!
//! Contacts interpenetrated beyond the slop (`method.slop`, [`SLOP`] by default) of the radius
//! are pulled back by [`RESTORE`] of the excess per step ([`restoring`]).
//!
//! The step is `dt` (the scene's `time_step`, or the time the fastest imposed motion takes to
//! cover `max_displacement` of the smallest diameter), shortened when grains move faster
//! ([`Cd::step_length`]).

mod balance;
mod cell;
mod detect;
mod history;
mod laws;
pub mod params;
pub use params::{CdParams, CdParamsSpec, Sweep, AGGREGATE_TOLERANCE};
mod relax;
mod step;

use crate::error::{EngineError, InstabilityCause};
use crate::geometry::NeighborList;
use crate::loading::{Drum, Wall};
use crate::math::{Real, Vec3};
use crate::methods::rigid::{RigidMethod, RigidWorld};
use crate::nscd::{Colours, Convergence, Mobility, Nlgs, NlgsReport, RigidContact, Side};
use crate::observe::{ContactRecord, Sample, SolverSample};
use crate::particles::Particles;
use crate::run::{Balance, GrainModel};
use crate::scene::{Controls, Scene, Stage};
use balance::{Freedom, Window};
use cell::Cell;
use detect::{Held, Status};
use laws::PairLaws;

use super::world;

/// Gap below which a contact counts as closed, as a fraction of the smaller radius: a resting
/// contact whose normal velocity came out of the solver at +1e-20 m/s instead of 0 would
/// otherwise look separating, be left out, and let its grain fall freely for one step. A contact
/// this close that does not close is held at that distance at most (1e-9 of the radius).
pub const ALERT: Real = 1e-9;

/// Fraction of the bodies' speeds below which a change of a contact's velocity is rounding
/// noise, for the impulse scale of the convergence criterion ([`crate::nscd::nlgs`]): two disks
/// carried along at 0.05 m/s by a wall exchange impulses of 1e-11 N·s, and the rounding of
/// their velocities (1e-17 m/s) alone changes them by 2e-9 of that at every sweep.
const SPEED_FLOOR: Real = 1e-6;

/// Interpenetration left alone by default (`method.slop`), as a fraction of the smaller radius
/// of the pair ([`restoring`]).
pub const SLOP: Real = 0.01;

/// The largest violation a converged solve leaves, as a fraction of the slop (per step, of the
/// contact's radius). It bounds how fast a contact can creep: a contact left approaching by this
/// much at every step stops sinking where the restoration beyond the slop ([`RESTORE`]) pulls it
/// back as fast, `WORST_VIOLATION x slop / RESTORE` past the slop — 25% of the radius at half the
/// slop, past the 5% limit (`max_interpenetration`), to which grains pressed together by liquid
/// bridges crept; at a tenth it is 5% at most, and the contacts that stay at the bound are few.
/// The restoration is not made faster instead: a faster one made Gauss-Seidel cycle in a drum.
/// The largest violation is bounded because a bound on the mean alone let single contacts keep
/// approaching fast (docs/methods/cd.md, "Design measurements").
const WORST_VIOLATION: Real = 0.1;

/// Fraction of the interpenetration beyond the slop that a contact removes per step (see
/// [`WORST_VIOLATION`] for how the two bound the creep).
pub const RESTORE: Real = 0.02;

/// The time step, s: `method.time_step`, or the one in which the fastest expected motion of
/// the particles `p` covers `max_displacement` of the smallest diameter (`rmin` the smallest
/// radius, m); an error when it is not a usable step.
fn nominal_time_step(scene: &Scene, params: &CdParams, p: &Particles, rmin: Real) -> Result<Real, EngineError> {
    let dt = match params.time_step {
        Some(dt) => dt,
        None => {
            // The fastest imposed motion, stages included (0.1 m/s if nothing moves).
            // The primaries of aggregates rearrange at up to sqrt(p_I / ρ).
            let v = params.reference_velocity.unwrap_or_else(|| {
                let imposed = match world::imposed_speed(scene, p, true) {
                    v if v > 0.0 => v,
                    _ => world::reference_velocity(scene, p),
                };
                imposed.max(relax::bond_speed(p, scene.dim))
            });
            params.max_displacement * 2.0 * rmin / v
        }
    };
    if !(dt.is_finite() && dt > 0.0) {
        return Err(EngineError::Build {
            field: "method.time_step".into(),
            reason: format!("the time step {dt:e} s is not usable; give method.time_step"),
        });
    }
    Ok(dt)
}

/// The mass of a stress-controlled wall of world `w`, kg: one layer of grains across the box's
/// largest length.
fn wall_mass(w: &RigidWorld) -> Real {
    let span = (0..w.dim).map(|a| w.domain.length(a)).fold(0.0, Real::max);
    w.p.mass.iter().sum::<Real>() * (w.mean_diameter / span).min(1.0)
}

/// The contact solver's settings from the method's parameters, in `dim` dimensions.
fn convergence(params: &CdParams, dim: usize) -> Convergence {
    Convergence {
        tolerance: params.tolerance,
        violation_tolerance: params.violation_bound(dim),
        worst_tolerance: WORST_VIOLATION * params.slop,
        max_iterations: params.max_iterations,
        relaxation: params.relaxation,
        acceleration: params.acceleration,
        damp_cycles: false,
    }
}

/// A contact-dynamics simulation.
pub struct Cd {
    /// The particles, box, walls, drum and clock ([`RigidWorld`]).
    w: RigidWorld,
    /// The time step, s (`method.time_step` or the default one).
    dt: Real,
    /// Length of the current (or last) step, s: `dt`, or less when grains move fast
    /// ([`Cd::step_length`]).
    h: Real,
    /// Smallest diameter, m.
    d_min: Real,
    params: CdParams,
    laws: PairLaws,
    /// Mass of a stress-controlled wall, kg ([`Cd::wall_mass`]).
    wall_mass: Real,
    /// Velocities of the boundaries (walls, then the drum) within the step (scratch for the
    /// solver), how each may move, and their spins (the drum's; empty without a drum).
    wall_vel: Vec<Vec3>,
    wall_mobility: Vec<Mobility>,
    wall_omega: Vec<Vec3>,
    /// The deforming periodic cell, if the cell deforms: the boundary slot `cell_slot`, after
    /// the walls and the drum ([`cell`]).
    cell: Option<Cell>,
    cell_slot: usize,
    /// Velocity of the cell's lengths at the end of the last step, m/s.
    cell_vel: Vec3,
    nl: NeighborList,
    /// The neighbour list must be rebuilt before the next step (particles moved from outside).
    force_rebuild: bool,
    /// The contacts of the last step, with their impulses.
    contacts: Vec<RigidContact>,
    /// What each contact of the last step is (parallel to `contacts`).
    status: Vec<Status>,
    /// The colour order of the contacts of the step, the colours, and the contacts and their
    /// status before reordering (scratch of the parallel sweep, kept between steps).
    order: Vec<u32>,
    colours: Colours,
    unordered: Vec<RigidContact>,
    unordered_status: Vec<Status>,
    /// What each pair carried at the end of the last step, sorted by pair ([`detect::key_of`]).
    previous: Vec<Held>,
    /// Velocities and spins at the start of the step (scratch).
    vel_start: Vec<Vec3>,
    omega_start: Vec<Vec3>,
    solver: Nlgs,
    report: NlgsReport,
    /// NLGS sweeps since the start.
    sweeps: u64,
    /// Largest and mean interpenetration of the contacts at the last detection, as fractions
    /// of the smaller radius.
    interpenetration: (Real, Real),
    /// Displacements and impulses since the last equilibrium check ([`balance`]).
    window: Window,
    /// The scene runs a standard experiment (its loading stages take
    /// `loading_violation_tolerance`).
    experiment: bool,
    /// A step whose contact problem is not solved within the budget goes on with the impulses
    /// reached (the aggregates' relaxation, which is preparation, [`relax`]).
    lenient: bool,
}

impl Cd {
    /// Builds the simulation: places particles, chooses the time step and builds the
    /// neighbour list.
    pub fn new(scene: &Scene, params: &CdParams) -> Result<Self, EngineError> {
        let c = &scene.container;
        let (p, domain) = world::initial_particles(scene)?;
        let rmin = p.radius.iter().copied().fold(Real::INFINITY, f64::min);
        let rmax = p.radius.iter().copied().fold(0.0, f64::max);
        let dt = nominal_time_step(scene, params, &p, rmin)?;
        let skin = params.skin * 2.0 * rmin;
        let laws = PairLaws::new(&scene.materials, c.wall_material.unwrap_or(0), None);
        // An aggregate's primaries attract to the bond's cut-off.
        let reach = p.bondings.iter().map(|b| b.attraction.range()).fold(laws.range(), Real::max);
        world::check_periodic_room(&domain, rmax, reach, skin)?;
        let n = p.len();
        let w = RigidWorld::new(scene, p, domain, world::container_walls(c), params.threads)?;
        // The walls, the drum, the periodic cell.
        let cell_slot = w.walls.len() + usize::from(w.drum.is_some());
        let slots = cell_slot + 1;
        let wall_mass = wall_mass(&w);
        let mut sim = Self {
            dt,
            h: dt,
            d_min: 2.0 * rmin,
            params: params.clone(),
            laws,
            wall_vel: vec![Vec3::zeros(); slots],
            wall_mobility: vec![Mobility::FIXED; slots],
            wall_omega: if w.drum.is_some() { vec![Vec3::zeros(); slots] } else { Vec::new() },
            w,
            cell: c.deformation.map(|d| Cell::new(d, wall_mass)),
            cell_slot,
            cell_vel: Vec3::zeros(),
            wall_mass,
            nl: NeighborList::new(reach, skin),
            force_rebuild: true,
            contacts: Vec::new(),
            status: Vec::new(),
            order: Vec::new(),
            colours: Colours::default(),
            unordered: Vec::new(),
            unordered_status: Vec::new(),
            previous: Vec::new(),
            vel_start: vec![Vec3::zeros(); n],
            omega_start: vec![Vec3::zeros(); n],
            solver: Nlgs::new(convergence(params, scene.dim)),
            report: NlgsReport::default(),
            sweeps: 0,
            interpenetration: (0.0, 0.0),
            window: Window::default(),
            experiment: scene.experiment.is_some(),
            lenient: false,
        };
        sim.refresh_neighbors();
        sim.window.open(&sim.w.p.vel, sim.w.walls.len());
        // A checkpoint's aggregates were relaxed by the run that saved them.
        if sim.w.p.aggregate_count() > 0 && !scene.continues_saved_run() {
            sim.relax_aggregates()?;
        }
        Ok(sim)
    }

    /// Time step, s.
    pub fn time_step(&self) -> Real {
        self.dt
    }

    /// The particles (read only).
    pub fn particles(&self) -> &Particles {
        &self.w.p
    }

    /// Mutable access to the particles, for tests and custom set-ups (the neighbour list is
    /// rebuilt before the next step).
    pub fn particles_mut(&mut self) -> &mut Particles {
        self.force_rebuild = true;
        &mut self.w.p
    }

    /// The walls.
    pub fn walls(&self) -> &[Wall] {
        &self.w.walls
    }

    /// The rotating drum, if the scene has one (its force and torque from the last step).
    pub fn drum(&self) -> Option<&Drum> {
        self.w.drum.as_ref()
    }

    /// Mass of a stress-controlled wall, kg: that of one layer of grains across the box's
    /// largest length at the start (total mass × mean diameter / length). Light enough to follow
    /// the sample, heavy enough not to rattle on single grains; it sets how fast the wall answers
    /// a stress change (the wall is a body of the contact problem, not a servo).
    pub fn wall_mass(&self) -> Real {
        self.wall_mass
    }

    /// The contacts of the last step with their impulses.
    pub fn contact_list(&self) -> &[RigidContact] {
        &self.contacts
    }

    /// The solver's report of the last step.
    pub fn solver_report(&self) -> NlgsReport {
        self.report
    }

    /// The solver's criterion after each sweep of the last step.
    pub fn residual_history(&self) -> &[crate::nscd::Iterate] {
        &self.solver.history
    }

    /// Largest and mean interpenetration at the last detection, as fractions of the smaller
    /// radius of each contact.
    pub fn interpenetration(&self) -> (Real, Real) {
        self.interpenetration
    }

    /// Heap bytes held by the simulation.
    pub fn heap_bytes(&self) -> usize {
        self.w.p.heap_bytes()
            + self.nl.heap_bytes()
            + self.contacts.capacity() * std::mem::size_of::<RigidContact>()
            + self.status.capacity() * std::mem::size_of::<Status>()
            + self.order.capacity() * std::mem::size_of::<u32>()
            + self.unordered.capacity() * std::mem::size_of::<RigidContact>()
            + self.unordered_status.capacity() * std::mem::size_of::<Status>()
            + self.colours.heap_bytes()
            + self.solver.heap_bytes()
            + self.previous.capacity() * std::mem::size_of::<Held>()
            + (self.vel_start.capacity() + self.omega_start.capacity() + self.wall_omega.capacity()) * std::mem::size_of::<Vec3>()
            + self.w.glued.capacity() * std::mem::size_of::<(u32, u16)>()
            + self.w.glued_to.capacity() * std::mem::size_of::<u16>()
            + self.window.heap_bytes()
    }

    fn refresh_neighbors(&mut self) {
        let domain = &self.w.domain;
        // A grain brought back across the boundary of a deforming cell becomes its own image
        // `m` periods away, which moves at `v + m dL/dt` ([`cell`]); the sheared axis x keeps
        // the Lees-Edwards rule of `wrap`.
        // That change of reference grain is no force: the momentum it adds is taken off every
        // grain alike (a change of frame, which a periodic cell allows).
        let cell_vel = self.cell_vel;
        let deforming: Vec<usize> = (0..self.w.dim).filter(|&a| cell_vel[a] != 0.0 && !(a == 0 && domain.sheared())).collect();
        let mut momentum = Vec3::zeros();
        for ((x, v), m) in self.w.p.pos.iter_mut().zip(self.w.p.vel.iter_mut()).zip(&self.w.p.mass) {
            let before = *x;
            domain.wrap(x, v);
            for &a in &deforming {
                let dv = ((x[a] - before[a]) / domain.length(a)).round() * cell_vel[a];
                v[a] += dv;
                momentum[a] += m * dv;
            }
        }
        if momentum != Vec3::zeros() {
            let free: Real = self.w.p.mass.iter().zip(&self.w.p.inv_mass).filter(|(_, im)| **im > 0.0).map(|(m, _)| m).sum();
            let dv = momentum / free;
            for (v, im) in self.w.p.vel.iter_mut().zip(&self.w.p.inv_mass) {
                if *im > 0.0 {
                    *v -= dv;
                }
            }
        }
        self.nl.rebuild(&self.w.p.pos, &self.w.p.radius, &self.w.domain);
        self.force_rebuild = false;
    }

    /// Contact forces (mean over the last step) as records, for metrics and tests.
    pub fn contacts(&self) -> Vec<ContactRecord> {
        let h = self.h;
        self.contacts
            .iter()
            .zip(&self.status)
            .filter_map(|(c, s)| {
                // A contact with a glued grain is a pair, seen from the free grain.
                let pair = (s.key.1 as usize) < self.w.p.len();
                let j = pair.then_some(if s.key.0 == c.i { s.key.1 } else { s.key.0 });
                let branch = c.frame.n * (c.a_i + c.a_j);
                // Touching: in contact at the start of the step, or pressed by its end. Bonded:
                // a capillary bridge, or cohesion holding grains in contact (whose net force
                // may be zero: the attraction balanced by the contact's reaction).
                let touching = s.touching || s.pressed;
                let bonded = s.bridge || (touching && c.law.cohesion > 0.0);
                (c.r != Vec3::zeros() || bonded).then(|| ContactRecord { i: c.i, j, force: c.force(h), branch, touching, bonded })
            })
            .collect()
    }
}

impl RigidMethod for Cd {
    const NAME: &'static str = "cd";
    const GRAIN_MODEL: GrainModel = GrainModel::Rigid;

    crate::methods::rigid::rigid_method_common!();

    fn drum_loads(&self) -> Vec<(Vec3, Vec3)> {
        let drum = Side::Boundary(self.w.walls.len() as u32);
        self.contacts.iter().filter(|c| c.j == drum).map(|c| (self.w.p.pos[c.i as usize], c.force(self.h))).collect()
    }

    fn sweeps_done(&self) -> u64 {
        self.sweeps
    }

    fn measure(&mut self) -> Result<Sample, EngineError> {
        self.check()?;
        let mut s = self.w.measure(&self.contacts(), 0.0, self.laws.frictional());
        s.solver = Some(Box::new(SolverSample {
            iterations: self.report.iterations,
            change: self.report.last.change,
            violation: self.report.last.violation,
            contacts: self.report.contacts as u64,
            max_interpenetration: self.interpenetration.0,
            mean_interpenetration: self.interpenetration.1,
        }));
        if !s.is_finite() {
            return Err(self.unstable(InstabilityCause::NonFinite { particle: 0 }));
        }
        Ok(s)
    }

    fn heap_size(&self) -> usize {
        self.heap_bytes()
    }

    fn running_values(&self) -> Vec<Real> {
        let mut v = vec![self.dt, self.wall_mass];
        if let Some(cell) = &self.cell {
            v.extend(self.cell_vel.iter());
            v.push(cell.speed);
        }
        v
    }

    fn set_running_values(&mut self, values: &[Real]) {
        let Some(&[dt, mass]) = values.get(..2) else { return };
        if dt.is_finite() && dt > 0.0 {
            (self.dt, self.h) = (dt, dt);
        }
        if mass.is_finite() && mass > 0.0 {
            self.wall_mass = mass;
            if let Some(cell) = self.cell.as_mut() {
                cell.mass = mass;
            }
        }
        if let (Some(cell), Some(&[x, y, z, speed])) = (self.cell.as_mut(), values.get(2..6)) {
            self.cell_vel = Vec3::new(x, y, z);
            cell.speed = speed;
        }
    }

    fn history(&self) -> crate::resume::ContactHistory {
        self.impulses()
    }

    fn restore_history(&mut self, history: Option<&crate::resume::ContactHistory>) -> Result<(), EngineError> {
        self.set_impulses(history)
    }

    fn controls(&mut self, controls: &Controls) -> Result<(), EngineError> {
        if self.w.apply_controls(controls) {
            // Walls closed onto the grains.
            self.force_rebuild = true;
        }
        if let (Some(w), Some(spin), Some(drum)) = (controls.drum_angular_velocity, self.wall_omega.last_mut(), self.w.drum.as_ref()) {
            *spin = drum.axis_vector() * w;
        }
        if let Some(d) = controls.deformation {
            // A new deformation starts from rest (imposed rates take their velocity at the next
            // step).
            self.cell = d.map(|d| Cell::new(d, self.wall_mass));
            self.cell_vel = Vec3::zeros();
        }
        if let Some(rate) = controls.shear_rate {
            // Into the box first (with the old images), so that every grain gets the profile of
            // its own position; the pairs across the sheared boundary are found again.
            self.refresh_neighbors();
            self.w.impose_shear_rate(rate);
            self.force_rebuild = true;
        }
        self.laws.set_friction(controls.friction);
        self.laws.set_inelastic(controls.local_damping.is_some_and(|a| a > 0.0));
        Ok(())
    }
    /// Applies the stage's controls, and the violation bound of its kind: a loading stage — an
    /// experiment's stage that does not run until equilibrium, or a stage of a plain scene that
    /// imposes a motion — takes `loading_violation_tolerance`, every other stage
    /// `violation_tolerance` (the largest violation is bounded in every stage, by a tenth of
    /// the slop). The stage's first equilibrium check measures from its start.
    fn stage(&mut self, stage: &Stage) -> Result<(), EngineError> {
        self.controls(&stage.controls)?;
        let loading = stage.equilibrium.is_none() && (self.experiment || self.imposes_motion());
        self.solver.settings.violation_tolerance =
            if loading { self.params.loading_violation_tolerance } else { self.params.violation_bound(self.w.dim) };
        self.window.open(&self.w.p.vel, self.w.walls.len());
        Ok(())
    }

    /// Means over the interval since the last check ([`balance`]): the kinetic energy of the
    /// grains' mean velocities, their mean net force against the mean contact force of the last
    /// step, and the walls' (and a stress-controlled cell's) mean stress against their targets;
    /// against the reference energy of the last step's contact forces
    /// ([`crate::run::rigid_reference_energy`]).
    fn equilibrium(&mut self) -> Balance {
        let h = self.h;
        let forces: Vec<Real> = self.contacts.iter().filter(|c| c.r != Vec3::zeros()).map(|c| c.force(h).norm()).collect();
        let mean_contact = if forces.is_empty() { 0.0 } else { forces.iter().sum::<Real>() / forces.len() as Real };
        let p = &self.w.p;
        // Nothing holds the grains in place and nothing pulls them: no boundary touches them
        // (contacts across a periodic cell's boundary are between grains), no gravity, no field.
        // Such grains keep their common drift, and their common spin too where no axis is
        // periodic (a periodic packing cannot turn as a body, and its wrapped positions would
        // not say how it turned).
        let free = self.w.gravity == Vec3::zeros() && self.w.field.is_none() && self.contacts.iter().all(|c| c.j.body().is_some());
        let freedom = match (free, self.w.domain.periodic.iter().any(|&a| a)) {
            (false, _) => Freedom::Held,
            (true, true) => Freedom::Drift,
            (true, false) => Freedom::RigidBody,
        };
        let (kinetic_energy, net, stress_error) = match self.window.close(&p.pos, &p.vel, &p.mass, &self.w.walls, freedom) {
            Some(m) => {
                // The stress-controlled cell against its target, from the mean generalised force
                // of the contacts across its boundary.
                let cell = self.cell.as_ref().and_then(|c| c.stress_error(&self.w.domain, m.cell_impulse, m.time)).unwrap_or(0.0);
                (m.kinetic_energy, m.net_force, world::wall_stress_error(&m.walls, &self.w.domain).max(cell))
            }
            // No step since the last check: the state of the last step.
            None => (self.w.kinetic_energy(), self.w.mean_net_force(), self.w.wall_stress_error()),
        };
        Balance {
            kinetic_energy,
            reference_energy: crate::run::rigid_reference_energy(&forces, self.w.mean_diameter),
            unbalanced_force: if mean_contact > 0.0 { net / mean_contact } else { Real::INFINITY },
            stress_error,
        }
    }

    /// One: [`Cd::equilibrium`] is a mean over the whole interval since the previous check (500
    /// steps by default, about fifty inertial times `d sqrt(rho / p)` at the default step),
    /// not a snapshot that may catch a packing at a quiet instant; a drift over the interval
    /// fails it as a snapshot of that drift's velocity would. Three such windows in a row made
    /// the 400-disk biaxial preparation of `sable bench biaxial` wait 1,000 more steps (a
    /// fifth of its whole run) with its kinetic ratio already below 1e-4.
    fn checks_in_a_row(&self) -> u32 {
        1
    }
}
