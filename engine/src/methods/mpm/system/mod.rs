//! The implicit material point method with contact dynamics, one step at a time: grains as
//! clouds of points ([`super::points`]), each with its own nodal field ([`super::field`]),
//! touching at nodes ([`super::contact`]) through the shared contact solver.
//!
//! A step:
//! 1. each grain projects its points on its nodes (mass, velocity, internal force at the
//!    start);
//! 2. the contacts are found between the grains' outlines and with the walls, with their
//!    normals and gaps;
//! 3. Newton iterations on the nodal velocities of every grain at once: each grain assembles
//!    its residual and matrix and solves for its free correction (no contact impulse); the
//!    contact problem, with each grain's `A⁻¹` between its contacts' samples, is solved by the
//!    non-linear Gauss-Seidel sweeps of [`crate::nscd`] for the step's total impulses
//!    (warm-started from the previous iteration and step); each grain then takes its
//!    correction with the impulses. The iterations stop when the correction is below
//!    `newton_tolerance` times the velocity scale. The matrix (with its `A⁻¹` blocks) is
//!    assembled and factorised at the first iteration and kept as long as each iteration
//!    divides the correction by four or more (a modified Newton: the fixed point, where the
//!    residual balances the contact impulses, does not depend on the matrix, and the contact
//!    problem uses the same `A⁻¹` as the update, so the two stay consistent). The tangent and
//!    the factorisation were two thirds of an iteration's cost. While points switch between
//!    elastic and plastic and the correction does not shrink, only a fraction of it is taken
//!    (`step::CYCLE_RATE`);
//! 4. the points move with their nodes: displacement `Σ N_i u_i`, deformation gradient
//!    `(I + Σ u_i ⊗ ∇N_i) F`, history from the law, velocity by a FLIP/PIC blend.
//!
//! A step that fails (Newton or the contact solve over budget, a matrix that stays
//! indefinite, an inverted point) is done again in halves, and the steps after it keep parts
//! that short until ten in a row converge ([`crate::methods::soft::parts`]). In a dense packing
//! the grains' stress makes the geometric stiffness of their rotation outweigh their inertia
//! over a long step ([`super::field`]); the damped matrix then converges slowly, and such a step
//! is split.
//!
//! Momentum is conserved exactly by every iteration (the internal forces of a grain sum to
//! zero and the contact impulses are equal and opposite), whatever the convergence.
//!
//! `step.rs` holds one attempt at a step (the Newton iterations with the contact solve, then
//! the points' move), `detect.rs` the step's contacts (found, supported, their drifts).

mod detect;
mod step;

use super::contact::{self, GrainContacts, Metric, Support, VertexContact, Wall, Warm};
use super::field::Field;
use super::grain::Grain;
use super::grid::{Grid, V2};
use super::points::Points;
use crate::constitutive::ConstitutiveLaw;
use crate::math::Real;
use crate::methods::soft::parts::StepParts;
pub use crate::methods::soft::parts::{StepFailure, StepReport};
use crate::methods::soft::progress::{self, Progress};
use crate::methods::soft::trace::Tracer;
pub use crate::methods::soft::Settings;
use crate::nscd::Nlgs;

/// The whole state of the method (module documentation).
pub struct System {
    /// Background grid.
    pub grid: Grid,
    /// Material points.
    pub points: Points,
    /// Grains.
    pub grains: Vec<Grain>,
    /// Constitutive laws, indexed by [`Grain::law`].
    pub laws: Vec<Box<dyn ConstitutiveLaw>>,
    /// Walls.
    pub walls: Vec<Wall>,
    /// Settings.
    pub settings: Settings,
    /// FLIP fraction of the points' velocity update (1: pure FLIP, no damping of the modes the
    /// grid carries; 0: PIC).
    pub flip: Real,
    /// The ghost penalty's stiffness as a fraction of each grain's P-wave modulus
    /// ([`super::ghost`]); 0 (the default): off.
    pub ghost: Real,
    /// The contacts of the last step, with their impulses.
    pub contacts: Vec<VertexContact>,
    /// Steps, time and costs so far, the walls' loads of the last step.
    pub progress: Progress,
    /// The friction of every grain–grain contact when set (a stage's `friction`); otherwise
    /// the geometric mean of the two grains'. Wall contacts keep their own.
    pub pair_friction: Option<Real>,
    fields: Vec<Field>,
    sides: Vec<GrainContacts>,
    /// The contact solves' measure of their change (kept between solves).
    metric: Metric,
    /// The contacts' impulses of the last step, which the next one's solve starts from.
    pub warm: Warm,
    nlgs: Nlgs,
    /// Each grain's outline at the step's start, and where an iterate moves it (scratch kept
    /// between steps).
    outlines: Vec<Vec<V2>>,
    moved: Vec<Vec<V2>>,
    /// The Newton iterations' trace (off unless a sink is set).
    pub tracer: Tracer,
}

impl StepParts for System {
    fn try_part(&mut self, dt: Real, last_chance: bool) -> Result<StepReport, StepFailure> {
        let part = self.progress.part(dt);
        self.tracer.begin_part();
        let done = self.try_step(dt, !last_chance);
        self.tracer.end_part(part, done.as_ref().err().map(|f| &f.cause));
        done
    }
}

impl System {
    /// A system at rest in time, its points' velocities updated with the FLIP fraction `flip`.
    pub fn new(
        grid: Grid,
        points: Points,
        grains: Vec<Grain>,
        laws: Vec<Box<dyn ConstitutiveLaw>>,
        walls: Vec<Wall>,
        settings: Settings,
        flip: Real,
    ) -> Self {
        let n = grains.len();
        let walls_len = walls.len();
        Self {
            grid,
            points,
            grains,
            laws,
            walls,
            settings,
            flip,
            ghost: 0.0,
            contacts: Vec::new(),
            progress: Progress::new(walls_len, settings.dt),
            pair_friction: None,
            fields: (0..n).map(|_| Field::default()).collect(),
            sides: vec![GrainContacts::default(); n],
            metric: Metric::default(),
            warm: Warm::default(),
            nlgs: Nlgs::new(settings.contact),
            outlines: vec![Vec::new(); n],
            moved: vec![Vec::new(); n],
            tracer: Tracer::default(),
        }
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.points.heap_bytes()
            + self.fields.iter().map(Field::heap_bytes).sum::<usize>()
            + self
                .sides
                .iter()
                .map(|s| {
                    (s.inverse.capacity() + s.work.capacity() + 2 * s.offsets.capacity() + 2 * s.entries.capacity() + 3 * s.u.capacity())
                        * 8
                        + s.samples.capacity() * std::mem::size_of::<Support>()
                })
                .sum::<usize>()
            + self.contacts.capacity() * std::mem::size_of::<VertexContact>()
            + self.nlgs.heap_bytes()
            + self.metric.heap_bytes()
            + self.grains.iter().map(|g| g.outline.vertices.capacity() * std::mem::size_of::<super::outline::Vertex>()).sum::<usize>()
            + self.outlines.iter().chain(&self.moved).map(|v| v.capacity() * std::mem::size_of::<V2>()).sum::<usize>()
    }

    /// Kinetic energy of the points, J/m (per metre of thickness).
    pub fn kinetic_energy(&self) -> Real {
        (0..self.points.len()).map(|p| 0.5 * self.points.mass[p] * self.points.v[p].norm_squared()).sum()
    }

    /// Energy stored in the grains' deformation, J/m (the elastic part for plastic laws).
    pub fn strain_energy(&self) -> Real {
        let mut e = 0.0;
        for g in &self.grains {
            let law = self.laws[g.law].as_ref();
            for p in g.points.clone() {
                e += self.points.vol0[p] * law.stored_energy(&self.points.f[p], &self.points.history[p]).unwrap_or(0.0);
            }
        }
        e
    }

    /// Mean grain diameter, m.
    pub fn mean_diameter(&self) -> Real {
        2.0 * self.grains.iter().map(|g| g.radius).sum::<Real>() / self.grains.len().max(1) as Real
    }

    /// Advances one step of `settings.dt` (module documentation), in parts where it fails
    /// ([`Splitting`](crate::methods::soft::parts::Splitting)): nothing has moved when a part
    /// fails (the points move only once the iterations converged).
    pub fn step(&mut self) -> Result<StepReport, StepFailure> {
        let dt = self.settings.dt;
        progress::step(self, |s| &mut s.progress, dt)
    }
}
