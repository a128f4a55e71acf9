//! Meshed grains touching through contact dynamics, one step at a time (FEM-CD;
//! Nezamabadi 2020, §1.2.3, as LMGC90 does it): each grain a [`Body`], the contacts between their boundaries
//! and with walls those of every soft-grain method ([`crate::methods::soft::contact`]).
//!
//! **Contacts.** A boundary node of one grain within `reach` of the boundary of another grain
//! (the nearest segment, its outward normal and the signed gap; at a reflex corner of that
//! boundary, the segment beyond the corner too: [`contact::candidates()`]), as for the material
//! point method's outlines. A node acts through itself, a place on a segment through the
//! segment's two nodes with the weights of its position: the contact moves exactly as the
//! nodes do. A boundary node within `reach` of a wall touches it. `reach` is the longest
//! boundary segment of any grain. By default both grains' nodes are held outside the other's
//! boundary (the symmetric two-pass treatment, [`contact::Sides::Both`]); where the boundaries
//! lie flat on each other the two sets of contacts are redundant, and the contact solves
//! measure their change in the grains' velocities ([`contact::solve()`]). One-sided
//! (`symmetric_contact: false`, only the nodes of the grain of lower index) the other grain's
//! nodes cross the first's segments by the sagitta of the boundary's chord, `s²/8R` for
//! segments `s` on a radius `R` (3% of an element with eight across the diameter), and further
//! once boundaries are dented, and the contacts that push the first grain's nodes back out of
//! the dents do work ([`contact`]'s module documentation).
//!
//! **A step** ([`System::step`]) is that of the material point method
//! ([`crate::methods::mpm::system`]) on meshed grains: each grain's residual and matrix at the
//! iterate, its free correction, the contact problem with each grain's `A⁻¹` between its
//! contacts' samples (assembled from the block between the samples' nodes, which the grain
//! keeps with its factor: [`crate::methods::soft::node_block`]), the drift
//! of each gap at the first two iterates (the other boundary turning and sliding under the
//! node), then each grain takes its correction with the impulses.
//!
//! **Kept matrices.** Each grain keeps its last matrix, its factor and its contacts' blocks while
//! they contract its own largest nodal correction by four or more an iteration
//! ([`REFRESH_RATIO`]) or once that correction is within Newton's tolerance (a modified Newton
//! iteration: the fixed point does not depend on the matrix). A part as long as the last
//! converged one starts with the same matrices: a grain's mesh does not change, and in a loose
//! packing its matrix hardly does; only the nodes new to a grain's contacts are solved for,
//! with the kept factors. A grain that needed a new matrix after a part's first iteration
//! starts the next part with one. A grain without contacts whose correction is within the
//! tolerance is left where it is by the part's further iterations, which the grains in contact
//! need. Each grain decides for itself: one decision for all grains, on the largest correction
//! of any, cost a loose packing a Newton iteration more a step (docs/methods/fem.md, "Design
//! measurements").
//!
//! Where Newton converged the drifts are measured once more: a contact whose drift moved since
//! the first iterates by more than [`DRIFT_TOLERANCE`] times the longest boundary segment had
//! its gap predicted from a geometry the step left behind, and — if it carries an impulse or
//! may close by the part's end (an open one leaves the solution as it is whatever its drift) —
//! the part fails ([`InstabilityCause::ContactDrift`]): without this check grains rearranging
//! fast went into each other. A part that fails so, or on Newton or the contact solve over
//! budget, a matrix not positive definite or an inverted element, is done again in halves, down
//! to a sixteenth, and the next steps keep parts that short until ten in a row pass
//! ([`crate::methods::soft::parts`]); the shortest part is kept as it converged.
//!
//! Momentum is conserved exactly by every iteration: the internal forces of a grain sum to zero
//! and the contact impulses are equal and opposite.
//!
//! `step.rs` holds one part of a step (the Newton iterations with the contact solve, then the
//! grains' and walls' move), `detect.rs` the step's contacts and their drifts.
//!
//! [`contact`]: crate::methods::soft::contact
//! [`contact::candidates()`]: crate::methods::soft::contact::candidates
//! [`contact::Sides::Both`]: crate::methods::soft::contact::Sides::Both
//! [`contact::solve()`]: crate::methods::soft::contact::solve
//! [`REFRESH_RATIO`]: crate::methods::soft::REFRESH_RATIO
//! [`InstabilityCause::ContactDrift`]: crate::error::InstabilityCause::ContactDrift

mod detect;
mod step;

use nalgebra::Vector2;

use super::body::Body;
use crate::constitutive::ConstitutiveLaw;
use crate::math::Real;
use crate::methods::soft::contact::{GrainContacts, Metric, Support, VertexContact, Wall, Warm};
use crate::methods::soft::parts::StepParts;
pub use crate::methods::soft::parts::{StepFailure, StepReport};
use crate::methods::soft::progress::{self, Progress};
use crate::methods::soft::trace::Tracer;
pub use crate::methods::soft::Settings;
use crate::nscd::Nlgs;

type V2 = Vector2<Real>;

/// How far a contact's drift may move between the first iterates and the converged one, in
/// units of the longest boundary segment, before the part fails and is split (module
/// documentation).
pub const DRIFT_TOLERANCE: Real = 2e-2;

/// A meshed grain.
#[derive(Debug)]
pub struct Grain {
    /// Its mesh and state.
    pub body: Body,
    /// Its law (index in [`System::laws`]).
    pub law: usize,
    /// Friction coefficient.
    pub friction: Real,
    /// Radius of the disk it was meshed from, m.
    pub radius: Real,
}

/// The whole state of the method (module documentation).
pub struct System {
    /// Grains.
    pub grains: Vec<Grain>,
    /// Constitutive laws, indexed by [`Grain::law`].
    pub laws: Vec<Box<dyn ConstitutiveLaw>>,
    /// Walls.
    pub walls: Vec<Wall>,
    /// Settings.
    pub settings: Settings,
    /// The contacts of the last step, with their impulses.
    pub contacts: Vec<VertexContact>,
    /// Steps, time and costs so far, the walls' loads of the last step.
    pub progress: Progress,
    /// The friction of every grain–grain contact when set; otherwise the geometric mean of the
    /// two grains'.
    pub pair_friction: Option<Real>,
    /// How near a boundary node must come to another boundary or a wall to be a contact, m.
    pub reach: Real,
    sides: Vec<GrainContacts>,
    /// The contact solves' measure of their change (kept between solves).
    metric: Metric,
    /// The Newton iterations' trace (off unless a sink is set).
    pub tracer: Tracer,
    corrections: Vec<Vec<Real>>,
    /// The contacts' impulses of the last step, by key, from which the next step's contact
    /// solve starts.
    pub warm: Warm,
    nlgs: Nlgs,
    outlines: Vec<Vec<V2>>,
    /// The contacts' drifts before they are measured again (scratch kept between steps).
    drifts: Vec<Real>,
    /// The part length every grain's factorised matrix was assembled for, s, when the last
    /// part converged with it (module documentation: the next part of that length keeps it).
    kept: Option<Real>,
    /// Each grain's pace of the Newton iterations.
    pace: Vec<Pace>,
}

/// A grain's Newton iterations (module documentation).
#[derive(Debug, Clone, Copy, Default)]
struct Pace {
    /// Its next iteration assembles and factorises its matrix anew.
    refresh: bool,
    /// It has no contact in the part and its last correction was within Newton's tolerance:
    /// the part's next iterations leave it where it is.
    done: bool,
    /// It needed a new matrix after the first iteration of the last part: the next part starts
    /// with one.
    refreshed: bool,
    /// Its largest nodal correction at the last iteration and at the one before, m/s.
    correction: Real,
    last: Real,
}

impl StepParts for System {
    fn try_part(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let part = self.progress.part(dt);
        self.tracer.begin_part();
        let done = self.try_step(dt, last_chance);
        self.tracer.end_part(part, done.as_ref().err().map(|f| &f.cause));
        done
    }

    /// A failed part leaves the velocities where its iterations took them.
    fn undo_part(&mut self) {
        for g in &mut self.grains {
            g.body.v.clone_from(&g.body.v0);
        }
    }
}

impl System {
    /// A system of `grains` and `walls`.
    pub fn new(grains: Vec<Grain>, laws: Vec<Box<dyn ConstitutiveLaw>>, walls: Vec<Wall>, settings: Settings) -> Self {
        let n = grains.len();
        let reach = grains
            .iter()
            .map(|g| {
                let b = &g.body.mesh.boundary;
                (0..b.len())
                    .map(|k| (g.body.mesh.nodes[b[k] as usize] - g.body.mesh.nodes[b[(k + 1) % b.len()] as usize]).norm())
                    .fold(0.0, Real::max)
            })
            .fold(0.0, Real::max);
        let walls_len = walls.len();
        Self {
            grains,
            laws,
            walls,
            settings,
            contacts: Vec::new(),
            progress: Progress::new(walls_len, settings.dt),
            pair_friction: None,
            reach,
            sides: vec![GrainContacts::default(); n],
            metric: Metric::default(),
            tracer: Tracer::default(),
            corrections: vec![Vec::new(); n],
            warm: Warm::default(),
            nlgs: Nlgs::new(settings.contact),
            outlines: vec![Vec::new(); n],
            drifts: Vec::new(),
            kept: None,
            pace: vec![Pace::default(); n],
        }
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.grains.iter().map(|g| g.body.heap_bytes()).sum::<usize>()
            + self
                .sides
                .iter()
                .map(|s| {
                    (s.inverse.capacity() + s.work.capacity()) * 8
                        + s.samples.capacity() * std::mem::size_of::<Support>()
                        + s.nodes.heap_bytes()
                })
                .sum::<usize>()
            + self.corrections.iter().map(|c| c.capacity() * 8).sum::<usize>()
            + self.contacts.capacity() * std::mem::size_of::<VertexContact>()
            + self.metric.heap_bytes()
            + self.outlines.iter().map(|o| o.capacity() * std::mem::size_of::<V2>()).sum::<usize>()
    }

    /// Kinetic energy, J/m.
    pub fn kinetic_energy(&self) -> Real {
        self.grains.iter().map(|g| g.body.kinetic_energy()).sum()
    }

    /// Energy stored in the grains, J/m.
    pub fn strain_energy(&self) -> Real {
        self.grains.iter().map(|g| g.body.strain_energy(self.laws[g.law].as_ref())).sum()
    }

    /// Total momentum, kg·m/s per m.
    pub fn momentum(&self) -> V2 {
        self.grains.iter().flat_map(|g| g.body.mass.iter().zip(&g.body.v).map(|(m, v)| v * *m)).sum()
    }

    /// Mean grain diameter, m.
    pub fn mean_diameter(&self) -> Real {
        2.0 * self.grains.iter().map(|g| g.radius).sum::<Real>() / self.grains.len().max(1) as Real
    }

    /// Advances one step of `settings.dt`, in parts where it fails
    /// ([`Splitting`](crate::methods::soft::parts::Splitting)).
    pub fn step(&mut self) -> Result<StepReport, StepFailure> {
        let dt = self.settings.dt;
        progress::step(self, |s| &mut s.progress, dt)
    }
}
