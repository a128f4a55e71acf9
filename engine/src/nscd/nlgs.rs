//! Non-linear Gauss-Seidel over the contacts of rigid round bodies (Moreau 1994; Jean 1999;
//! docs/physics.md §3.3).
//!
//! On entry the bodies carry their free velocities (end of step without contact impulses) and
//! each contact its warm-start impulse (the previous step's, or zero). The solver adds the
//! warm-start impulses to the bodies, then sweeps the contacts in order: each one's local
//! problem is solved exactly with the others frozen ([`super::local::solve`]) and the change of
//! its impulse is applied to its two bodies at once, so the next contact sees it (then its
//! rolling block, if it has one). Sweeps repeat until the convergence criterion holds or the
//! budget is spent. The order is the contacts' order, or colour by colour with each colour swept
//! in parallel ([`super::colour`]).
//!
//! **Acceleration** (momentum with adaptive restart): after a sweep that did not converge, each
//! contact's impulse is carried on along its change over the sweep, `r + beta (r - r_prev)`,
//! projected back on its admissible set (`r_n >= -c`, `|r_t| <= mu (r_n + c)`), and the change
//! applied to its bodies. `beta` grows as Nesterov's `(k - 1) / (k + 2)` with the sweeps `k` since
//! the last restart, up to `Convergence::acceleration`, and the count restarts whenever the sum of
//! the violations grows over a sweep (O'Donoghue & Candès 2015's restart; Mazhar et al. 2015 use
//! the same momentum on the projected gradient of the contact problem, Chrono's APGD). Plain
//! Gauss-Seidel crawls on the slow collective modes of a packing moved by free walls — its error
//! there decays by a few percent per thousand sweeps — and the momentum carries those modes along
//! (docs/methods/cd.md, "Design measurements"). Contacts with a liquid's viscosity keep their
//! plain update, as the rolling blocks do ([`super::sweep::carry_local`]).
//!
//! **Cycles.** Gauss-Seidel on frictional contacts is not bound to converge (Coulomb's law is
//! not associated: the local problems are not the minimisations of one function). On dense
//! frictional packings of deformable grains its change was seen to swing for good between 2e-6
//! and 2e-5 where 1e-6 was asked, or to fall for some sweeps and jump back up by a hundred
//! times at a fixed period (docs/methods/fem.md, "Design measurements"). Under-relaxation
//! damps such cycles (M. Jean, "The non-smooth contact dynamics method", 1999; LMGC90's
//! `relax`) but slows every solve that converges without it, so the solver lowers it only
//! where a cycle shows ([`Cycles`]): when 500 sweeps have not brought the change a fifth below
//! the level it had reached and it rose at least once among them, the relaxation is halved
//! (down to an eighth of the settings') and the momentum restarts. The fixed point is the same
//! at any relaxation; a damped sweep's change is divided by its damping, so that the criterion
//! measures the distance to the local solutions whatever the damping. The soft-grain methods
//! ask for it ([`Convergence::damp_cycles`]); contact dynamics of rigid grains, whose
//! accelerated sweeps swing by design, leave it to `method.relaxation`.
//!
//! **Convergence criterion** (checked after every sweep), all below their tolerances:
//! - the relative change of the impulses over the sweep, `sqrt(sum |dr|² / sum max(|r|, s)²)`
//!   (LMGC90's "quadratic" norm), where each contact's impulse scale `s` (set by the method:
//!   the impulse that stops its approach, one step of gravity, and the bodies' speeds at the
//!   level of rounding) keeps contacts that carry (almost) nothing from turning rounding noise
//!   into a large relative change (a column in free fall has all its impulses at 1e-17 N·s,
//!   changing by their own size at every sweep);
//! - the mean violation of the Signorini condition, `h <max(0, b - U_n)> / <d>`: how far, as a
//!   fraction of the mean diameter, the contacts would interpenetrate over the step beyond
//!   what the law allows, measured on each contact just before it is solved in the sweep
//!   (over the contacts; near pairs only while they act: [`RigidContact::near`]);
//! - the largest violation, `h max(max(0, b - U_n) / a_i)`: how far the deepest-going contact
//!   would interpenetrate over the step, as a fraction of its radius (a bound on the mean alone
//!   lets one contact in a thousand go a thousand times deeper than the mean).

use super::bodies::{BodyStore, Cells, RigidBodies, SolveBodies};
use super::colour::Colours;
use super::contact::RigidContact;
use super::sweep::{ContactProblem, Pass, Sums};
use crate::math::{Real, Vec3};

/// The solver's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Convergence {
    /// Tolerance on the relative change of the impulses over a sweep.
    pub tolerance: Real,
    /// Tolerance on the mean violation (fraction of the mean diameter per step).
    pub violation_tolerance: Real,
    /// Tolerance on the largest violation (fraction of the contact's radius per step): a mean
    /// bound alone lets one contact of a thousand go a thousand times deeper than the mean.
    pub worst_tolerance: Real,
    /// Largest number of sweeps in one step.
    pub max_iterations: u32,
    /// Relaxation `omega` in (0, 1]: each contact moves its impulse `omega` of the way to its
    /// local solution. Below 1 it damps the cycles in which Gauss-Seidel can lock on frictional,
    /// hyperstatic packings under imposed boundary motions (LMGC90's NLGS exposes the same
    /// factor, `relax`).
    pub relaxation: Real,
    /// Largest momentum factor `beta` of the accelerated sweep, in [0, 1) (0: plain
    /// Gauss-Seidel; see the module documentation).
    pub acceleration: Real,
    /// Lower the relaxation where the sweeps cycle (module documentation, "Cycles").
    pub damp_cycles: bool,
}

/// The state of the iteration after one sweep.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Iterate {
    /// Relative change of the impulses over the sweep.
    pub change: Real,
    /// Mean violation (fraction of the mean diameter per step).
    pub violation: Real,
    /// Largest violation (fraction of the contact's radius per step).
    pub worst: Real,
}

/// The outcome of one solve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NlgsReport {
    /// Sweeps done.
    pub iterations: u32,
    /// The criterion's values after the last sweep.
    pub last: Iterate,
    /// True if the criterion held within the budget.
    pub converged: bool,
    /// Contacts solved.
    pub contacts: usize,
}

impl NlgsReport {
    /// The failure of a solve that ran out of its budget under `settings`.
    pub fn budget_failure(&self, settings: &Convergence) -> crate::error::InstabilityCause {
        crate::error::InstabilityCause::SolverBudget {
            iterations: self.iterations,
            change: self.last.change,
            violation: self.last.violation,
            tolerance: settings.tolerance,
            violation_tolerance: settings.violation_tolerance,
            worst: self.last.worst,
            worst_tolerance: settings.worst_tolerance,
        }
    }
}

/// The non-linear Gauss-Seidel solver, with the residual history of its last solve.
#[derive(Debug)]
pub struct Nlgs {
    /// Settings.
    pub settings: Convergence,
    /// The criterion after each sweep of the last solve.
    pub history: Vec<Iterate>,
    /// The velocity cells of the coloured sweep, kept between solves.
    cells: Cells,
    /// Each contact's impulse after the previous sweep (the accelerated sweep's momentum).
    last: Vec<Vec3>,
}

impl Nlgs {
    /// A solver with these settings.
    pub fn new(settings: Convergence) -> Self {
        Self { settings, history: Vec::new(), cells: Cells::default(), last: Vec::new() }
    }

    /// Heap bytes held (the history, the coloured sweep's cells and the momentum's impulses).
    pub fn heap_bytes(&self) -> usize {
        self.history.capacity() * std::mem::size_of::<Iterate>()
            + self.cells.heap_bytes()
            + self.last.capacity() * std::mem::size_of::<Vec3>()
    }

    /// Solves the contacts (see the module documentation) for a step of `h` seconds, between
    /// bodies of mean diameter `mean_diameter` (m; the mean violation's unit). With `colours`,
    /// the contacts are in colour order ([`super::colour`]) and each colour is swept in
    /// parallel. Free boundaries end the solve within their [`Mobility::max_speed`].
    pub fn solve(
        &mut self,
        contacts: &mut [RigidContact],
        bodies: &mut RigidBodies<'_>,
        h: Real,
        mean_diameter: Real,
        colours: Option<&Colours>,
    ) -> NlgsReport {
        self.history.clear();
        let report = match colours {
            None => self.sweeps(contacts, bodies, (h, mean_diameter), |contacts, last, bodies, pass| {
                let mut sums = Sums::default();
                for (c, slot) in contacts.iter_mut().zip(last.iter_mut()) {
                    pass.apply(c, slot, bodies, &mut sums);
                }
                sums
            }),
            Some(colours) => {
                // The velocities in cells the threads of a colour share, for the solve.
                let mut cells = std::mem::take(&mut self.cells);
                cells.fill(bodies);
                let shared = SolveBodies::new(bodies, &cells);
                let report = self.sweeps(contacts, &mut &shared, (h, mean_diameter), |contacts, last, bodies, pass| {
                    colours.sweep(contacts, last, bodies, pass)
                });
                shared.store(bodies);
                self.cells = cells;
                report
            }
        };
        for (v, m) in bodies.boundary_vel.iter_mut().zip(bodies.boundary_mobility) {
            *v = m.bound(*v);
        }
        report
    }

    /// The warm start and the sweeps of [`Nlgs::solve`], `sweep` doing one pass over the
    /// contacts with their slots of the previous impulses.
    fn sweeps<B: BodyStore>(
        &mut self,
        contacts: &mut [RigidContact],
        bodies: &mut B,
        (h, mean_diameter): (Real, Real),
        sweep: impl Fn(&mut [RigidContact], &mut [Vec3], &mut B, Pass) -> Sums,
    ) -> NlgsReport {
        for c in contacts.iter_mut() {
            if c.r != Vec3::zeros() {
                c.apply(&c.frame.to_global(&c.r), bodies);
            }
            if c.rolling.bound > 0.0 && c.rolling.w > 0.0 {
                // The warm moment in the current tangent plane.
                let n = c.frame.n;
                c.rolling.m -= n * n.dot(&c.rolling.m);
                if c.rolling.m != Vec3::zeros() {
                    c.apply_moment(&c.rolling.m, bodies);
                }
            } else {
                c.rolling.m = Vec3::zeros();
            }
        }
        self.prime(contacts.iter().map(|c| c.r));
        self.iterate(contacts.len(), (h, mean_diameter), |last, pass| sweep(contacts, last, bodies, pass))
    }

    /// Solves a contact problem of any kind of bodies ([`ContactProblem`]: a method's own
    /// contacts, such as the nodal contacts of deformable grains) with the same sweeps,
    /// acceleration and criterion as [`Nlgs::solve`], serially, for a step of `h` seconds
    /// between bodies of mean diameter `mean_diameter` (m).
    pub(crate) fn solve_problem<P: ContactProblem>(&mut self, problem: &mut P, h: Real, mean_diameter: Real) -> NlgsReport {
        self.history.clear();
        problem.warm_start();
        let n = problem.len();
        self.prime((0..n).map(|c| problem.impulse(c)));
        self.iterate(n, (h, mean_diameter), |last, pass| problem.sweep(last, pass))
    }

    /// Sets the momentum's previous impulses for a solve starting from `impulses`.
    fn prime(&mut self, impulses: impl ExactSizeIterator<Item = Vec3>) {
        let n = impulses.len();
        self.last.clear();
        if self.settings.acceleration > 0.0 {
            self.last.extend(impulses);
        } else {
            self.last.resize(n, Vec3::zeros());
        }
    }

    /// The sweeps of a solve of `n` contacts (warm-started, with [`Nlgs::prime`] done), `sweep`
    /// doing one pass over them with their slots of the previous impulses.
    fn iterate(&mut self, n: usize, (h, mean_diameter): (Real, Real), mut sweep: impl FnMut(&mut [Vec3], Pass) -> Sums) -> NlgsReport {
        let mut report = NlgsReport { contacts: n, ..NlgsReport::default() };
        if n == 0 {
            report.converged = true;
            return report;
        }
        let (tol, vtol) = (self.settings.tolerance, self.settings.violation_tolerance);
        let mut previous = std::mem::take(&mut self.last);
        let accelerate = self.settings.acceleration > 0.0;
        // The sweep the momentum restarted at, and the violations of the last sweep.
        let (mut restart, mut violations) = (0, Real::INFINITY);
        let mut cycles = Cycles::default();
        for it in 1..=self.settings.max_iterations {
            let omega = self.settings.relaxation * cycles.damping;
            // Always forward: sweeping backward every other time (symmetric Gauss-Seidel)
            // took 40% more sweeps on the quickstart deposition.
            let sums = sweep(&mut previous, Pass::Solve { omega });
            // A damped sweep moves each impulse `damping` of the way the settings' relaxation
            // would: its change is measured undamped, as the distance to the local solutions.
            let change = if sums.size2 > 0.0 {
                (sums.change2 / sums.size2).sqrt() / cycles.damping
            } else if sums.change2 > 0.0 {
                Real::INFINITY
            } else {
                0.0
            };
            if self.settings.damp_cycles && cycles.observe(change) {
                restart = it;
            }
            let last =
                Iterate { change, violation: h * sums.violation / (sums.count.max(1) as Real * mean_diameter), worst: h * sums.worst };
            self.history.push(last);
            report.iterations = it;
            report.last = last;
            if last.change <= tol && last.violation <= vtol && last.worst <= self.settings.worst_tolerance {
                report.converged = true;
                break;
            }
            if accelerate {
                if sums.violation > violations {
                    restart = it;
                }
                violations = sums.violation;
                let k = Real::from(it - restart);
                let beta = ((k - 1.0) / (k + 2.0)).clamp(0.0, self.settings.acceleration);
                sweep(&mut previous, Pass::Carry { beta });
            }
        }
        self.last = previous;
        report
    }
}

/// Sweeps without progress after which [`Cycles`] judges a solve that has swung up at least
/// once to be caught in a cycle.
const STALL: u32 = 500;

/// A sweep makes progress when its change falls below this fraction of the level the last
/// progress set ([`Cycles`]).
const PROGRESS: Real = 0.8;

/// Smallest damping [`Cycles`] lowers the relaxation to.
const MIN_DAMPING: Real = 0.125;

/// The detection of a solve caught in a cycle, and the damping that breaks it (module
/// documentation, "Cycles").
#[derive(Debug, Clone, Copy)]
struct Cycles {
    /// Factor on the settings' relaxation, in (0, 1].
    damping: Real,
    /// The change the last progress reached.
    level: Real,
    /// The last sweep's change.
    last: Real,
    /// Sweeps since the last progress, and whether the change rose among them.
    stalled: u32,
    rose: bool,
}

impl Default for Cycles {
    fn default() -> Self {
        Self { damping: 1.0, level: Real::INFINITY, last: Real::INFINITY, stalled: 0, rose: false }
    }
}

impl Cycles {
    /// Takes a sweep's change; true when it halved the damping (the momentum then restarts).
    /// A solve is caught in a cycle when [`STALL`] sweeps have not brought its change a fifth
    /// below the level it had reached and the change rose at least once among them:
    /// Gauss-Seidel that converges, however slowly, lowers its change sweep after sweep; the
    /// cycles seen swing about a level (frictional contacts trading stick and slip) or fall
    /// for a while and jump back up, by a hundred times, at a fixed period (10 sweeps, or
    /// 8,000).
    fn observe(&mut self, change: Real) -> bool {
        let rose = change > self.last;
        self.last = change;
        if change < PROGRESS * self.level {
            (self.level, self.stalled, self.rose) = (change, 0, false);
            return false;
        }
        self.stalled += 1;
        self.rose |= rose;
        if self.stalled < STALL || !self.rose || self.damping <= MIN_DAMPING {
            return false;
        }
        // Halved; the level is judged again in the damped sweeps' measure.
        self.damping *= 0.5;
        (self.level, self.stalled, self.rose) = (Real::INFINITY, 0, false);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nscd::contact::test_contact;
    use crate::nscd::{law_for, ContactFrame, Mobility, Rolling, Side};

    fn frame_x() -> ContactFrame {
        ContactFrame::new(2, Vec3::x())
    }

    /// A row of equal disks touching along x, pushed from the left at 1 m/s, frictionless and
    /// perfectly plastic: the whole row ends moving at the mean momentum, N contacts solved
    /// exactly — with plain and with under-relaxed updates (same fixed point, more sweeps).
    #[test]
    fn a_row_of_disks_shares_the_momentum() {
        let plain = row_of_disks(1.0);
        let relaxed = row_of_disks(0.6);
        assert!(relaxed > plain, "relaxed {relaxed} sweeps, plain {plain}");
    }

    /// Solves the row at relaxation `relax` and checks the answer; returns the sweeps.
    fn row_of_disks(relax: Real) -> u32 {
        let n = 5;
        let mut vel = vec![Vec3::zeros(); n];
        vel[0] = Vec3::new(1.0, 0.0, 0.0);
        let mut omega = vec![Vec3::zeros(); n];
        let (im, ii) = (vec![1.0; n], vec![2.0; n]);
        // Contact k between disk k+1 (i) and disk k (j): n points from k to k+1.
        let mut contacts: Vec<RigidContact> = (0..n - 1)
            .map(|k| RigidContact {
                i: (k + 1) as u32,
                j: Side::Body(k as u32),
                frame: frame_x(),
                a_i: 0.5,
                a_j: 0.5,
                drive: Vec3::zeros(),
                w: RigidContact::delassus(1.0, 2.0, 0.5, 1.0, 2.0, 0.5),
                law: law_for(-1.0, 0.0, 0.0, 0.0),
                r: Vec3::zeros(),
                rolling: Rolling::default(),
                scale: 0.0,
                near: false,
            })
            .collect();
        // Only contact 0 approaches at the start; the others are closed at rest.
        for c in contacts.iter_mut().skip(1) {
            c.law = law_for(0.0, 0.0, 0.0, 0.0);
        }
        let mut solver = Nlgs::new(Convergence {
            tolerance: 1e-10,
            violation_tolerance: 1e-10,
            worst_tolerance: 1e-10,
            max_iterations: 10_000,
            relaxation: relax,
            acceleration: 0.0,
            damp_cycles: false,
        });
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut [], &[]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged, "{report:?}");
        for v in &vel {
            assert!((v.x - 0.2).abs() < 1e-8, "{vel:?}");
        }
        assert!(omega.iter().all(|w| w.norm() < 1e-15));
        // The history decreases to the tolerance.
        let h = &solver.history;
        assert_eq!(h.len() as u32, report.iterations);
        assert!(h.last().is_some_and(|l| l.change <= 1e-10));
        report.iterations
    }

    /// A column of 40 equal disks (mass 1 kg) on a fixed floor, each given one step of gravity
    /// as its free velocity, solved from nothing: contact k (below disk k) carries the weight of
    /// the 40 - k disks above it over the step, `(40 - k) g h`, and every disk ends at rest —
    /// with plain and with accelerated sweeps, the momentum taking a small part of the sweeps
    /// (Gauss-Seidel moves the load down a chain by about one contact per sweep, its error
    /// decays by a factor 1 - O(1/n²) per sweep). Measured: 13,124 sweeps plain, 1,126 with
    /// momentum (11.7x). The bound asks 3x: a momentum that does nothing (or that restarts at
    /// every sweep) fails it, and it leaves room to change the restart rule.
    #[test]
    fn momentum_carries_the_weight_of_a_column_down_in_fewer_sweeps() {
        let plain = column_of_disks(0.0);
        let accelerated = column_of_disks(0.9);
        assert!(3 * accelerated < plain, "accelerated {accelerated} sweeps, plain {plain}");
    }

    /// Solves the column with momentum factor `acceleration` and checks the answer; returns the
    /// sweeps.
    fn column_of_disks(acceleration: Real) -> u32 {
        let (n, gh) = (40, 9.81e-3);
        let mut vel = vec![Vec3::new(0.0, -gh, 0.0); n];
        let mut omega = vec![Vec3::zeros(); n];
        let (im, ii) = (vec![1.0; n], vec![2.0; n]);
        // Contact 0: disk 0 on the floor; contact k: disk k on disk k - 1 (n points up).
        let mut contacts: Vec<RigidContact> = (0..n)
            .map(|k| RigidContact {
                i: k as u32,
                j: if k == 0 { Side::Boundary(0) } else { Side::Body(k as u32 - 1) },
                frame: ContactFrame::new(2, Vec3::y()),
                a_i: 0.5,
                a_j: if k == 0 { 0.0 } else { 0.5 },
                drive: Vec3::zeros(),
                w: if k == 0 {
                    RigidContact::delassus_boundary(1.0, 2.0, 0.5, 0.0)
                } else {
                    RigidContact::delassus(1.0, 2.0, 0.5, 1.0, 2.0, 0.5)
                },
                law: law_for(0.0, 0.0, 0.5, 0.0),
                r: Vec3::zeros(),
                rolling: Rolling::default(),
                scale: gh,
                near: false,
            })
            .collect();
        let mut solver = Nlgs::new(Convergence {
            tolerance: 1e-9,
            violation_tolerance: 1e-12,
            worst_tolerance: 1e-9,
            max_iterations: 100_000,
            relaxation: 1.0,
            acceleration,
            damp_cycles: false,
        });
        let mut floor = [Vec3::zeros()];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut floor, &[Mobility::FIXED]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged, "{report:?}");
        for (k, c) in contacts.iter().enumerate() {
            let exact = (n - k) as Real * gh;
            assert!((c.r.x - exact).abs() < 1e-6 * exact && c.r.y == 0.0, "contact {k}: {:?}, exact {exact}", c.r);
        }
        assert!(vel.iter().all(|v| v.norm() < 1e-8 * gh), "{vel:?}");
        report.iterations
    }

    /// A disk sliding on a boundary with friction: the contact impulse stops the fall and
    /// the friction impulse takes mu times it from the slip, and the spin.
    #[test]
    fn friction_on_a_boundary_slows_the_slip_and_spins_the_disk() {
        let (m, r) = (2.0, 0.1);
        let inertia = 0.5 * m * r * r;
        let mut vel = vec![Vec3::new(1.0, -0.5, 0.0)];
        let mut omega = vec![Vec3::zeros()];
        let (im, ii) = (vec![1.0 / m], vec![1.0 / inertia]);
        let mut contacts = vec![RigidContact {
            i: 0,
            j: Side::Boundary(0),
            frame: ContactFrame::new(2, Vec3::y()),
            a_i: r,
            a_j: 0.0,
            drive: Vec3::zeros(),
            w: RigidContact::delassus(1.0 / m, 1.0 / inertia, r, 0.0, 0.0, 0.0),
            law: law_for(-0.5, 0.0, 0.2, 0.0),
            r: Vec3::zeros(),
            rolling: Rolling::default(),
            scale: 0.0,
            near: false,
        }];
        let mut solver = Nlgs::new(tight(100));
        let mut wall = [Vec3::zeros()];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut wall, &[Mobility::FIXED]);
        let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
        assert!(report.converged);
        // Normal impulse m * 0.5 = 1 N·s; friction 0.2 N·s against the slip (t1 = -x for n = y).
        let p = contacts[0].frame.to_global(&contacts[0].r);
        assert!((p.y - 1.0).abs() < 1e-12 && (p.x + 0.2).abs() < 1e-12, "{p:?}");
        assert!(vel[0].y.abs() < 1e-12 && (vel[0].x - 0.9).abs() < 1e-12);
        // Torque of -0.2 x at the bottom point: spin -0.2 * r / I about z (clockwise: rolling
        // towards +x).
        assert!((omega[0].z + 0.2 * r / inertia).abs() < 1e-12, "{:?}", omega[0]);
    }

    /// A free plate of mass M falling at V onto a resting disk of mass m (no restitution): both
    /// end at the common velocity M V / (M + m), momentum kept.
    #[test]
    fn a_free_boundary_shares_its_momentum_with_the_grain_it_hits() {
        let (m, big_m, v): (f64, f64, f64) = (1.0, 3.0, -2.0);
        let mut vel = vec![Vec3::zeros()];
        let mut omega = vec![Vec3::zeros()];
        let (im, ii) = (vec![1.0 / m], vec![10.0]);
        // The plate is above the disk: the normal points from the plate down to the disk.
        let n = -Vec3::y();
        let mut contacts = vec![RigidContact {
            i: 0,
            j: Side::Boundary(0),
            frame: ContactFrame::new(2, n),
            a_i: 0.1,
            a_j: 0.0,
            drive: Vec3::zeros(),
            w: RigidContact::delassus_boundary(1.0 / m, 10.0, 0.1, 1.0 / big_m),
            law: law_for(-v.abs(), 0.0, 0.5, 0.0),
            r: Vec3::zeros(),
            rolling: Rolling::default(),
            scale: 0.0,
            near: false,
        }];
        let mut plate = [Vec3::new(0.0, v, 0.0)];
        let mut solver = Nlgs::new(tight(100));
        let mobility = [Mobility { direction: Vec3::y(), inv_mass: 1.0 / big_m, partner: None, max_speed: Real::INFINITY }];
        let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut plate, &mobility);
        assert!(solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None).converged);
        let common = big_m * v / (big_m + m);
        assert!((vel[0].y - common).abs() < 1e-12 && (plate[0].y - common).abs() < 1e-12, "{:?} {:?}", vel[0], plate[0]);
        assert!((m * vel[0].y + big_m * plate[0].y - big_m * v).abs() < 1e-12);
    }

    /// The bodies of a test: grains with their velocities, spins and inverse masses and
    /// inertias, boundaries with their velocities and mobilities, none turning.
    fn bodies<'a>(
        (vel, omega): (&'a mut [Vec3], &'a mut [Vec3]),
        (inv_mass, inv_inertia): (&'a [Real], &'a [Real]),
        boundary_vel: &'a mut [Vec3],
        boundary_mobility: &'a [Mobility],
    ) -> RigidBodies<'a> {
        RigidBodies { vel, omega, inv_mass, inv_inertia, boundary_vel, boundary_mobility, boundary_omega: &[] }
    }

    /// Every tolerance at 1e-12, no relaxation, `max_iterations` sweeps.
    fn tight(max_iterations: u32) -> Convergence {
        Convergence {
            tolerance: 1e-12,
            violation_tolerance: 1e-12,
            worst_tolerance: 1e-12,
            max_iterations,
            relaxation: 1.0,
            acceleration: 0.0,
            damp_cycles: false,
        }
    }

    /// A contact between disk `0` and boundary `k`, along `n` (from the boundary to the disk).
    fn disk_on(k: u32, n: Vec3, im_b: Real) -> RigidContact {
        test_contact(0, Side::Boundary(k), n, (0.1, 0.0), RigidContact::delassus_boundary(1.0, 10.0, 0.1, im_b))
    }

    /// Ten disks resting on a fixed floor and one coming down on it at 1 m/s: the first sweep
    /// sees a mean violation of 1/11 (h = 1 s, d = 1 m) and a largest one of 1/0.1 = 10 radii.
    /// A mean bound alone accepts that sweep; the bound on the largest violation makes the
    /// solver sweep again (the second sweep finds every contact satisfied).
    #[test]
    fn one_violated_contact_among_many_satisfied_ones_is_not_converged() {
        let n = 11;
        let sweeps = |worst_tolerance: Real| {
            let mut vel = vec![Vec3::zeros(); n];
            vel[n - 1].y = -1.0;
            let mut omega = vec![Vec3::zeros(); n];
            let (im, ii) = (vec![1.0; n], vec![10.0; n]);
            let mut contacts: Vec<RigidContact> = (0..n as u32).map(|i| RigidContact { i, ..disk_on(0, Vec3::y(), 0.0) }).collect();
            let mut walls = [Vec3::zeros()];
            let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut walls, &[Mobility::FIXED]);
            let settings = Convergence {
                tolerance: Real::INFINITY,
                violation_tolerance: 0.1,
                worst_tolerance,
                max_iterations: 10,
                relaxation: 1.0,
                acceleration: 0.0,
                damp_cycles: false,
            };
            let mut solver = Nlgs::new(settings);
            let report = solver.solve(&mut contacts, &mut bodies, 1.0, 1.0, None);
            assert!(report.converged);
            let first = solver.history[0];
            assert!((first.violation - 1.0 / n as Real).abs() < 1e-12 && (first.worst - 10.0).abs() < 1e-12, "{first:?}");
            assert!(vel[n - 1].norm() < 1e-12);
            report.iterations
        };
        assert_eq!(sweeps(100.0), 1);
        assert_eq!(sweeps(1.0), 2);
    }

    /// A free plate whose push has built up a velocity of 2 m/s, bounded at 0.5 m/s: a free
    /// disk it meets is driven at the bound, not at 2 m/s; a disk resting on a fixed floor stops
    /// it, and then takes the whole of its push (the bound holds the plate's speed, not its
    /// force), passed on to the floor.
    #[test]
    fn a_bounded_boundary_drives_at_its_bound_and_pushes_with_its_whole_force() {
        let big_m = 3.0;
        let plate = Mobility { direction: Vec3::y(), inv_mass: 1.0 / big_m, partner: None, max_speed: 0.5 };
        let mobility = [plate, Mobility::FIXED];
        let settings = tight(200);
        let (im, ii) = ([1.0], [10.0]);
        let solve = |contacts: &mut Vec<RigidContact>| {
            let (mut vel, mut omega) = (vec![Vec3::zeros()], vec![Vec3::zeros()]);
            let mut walls = [Vec3::new(0.0, -2.0, 0.0), Vec3::zeros()];
            let mut bodies = bodies((&mut vel, &mut omega), (&im, &ii), &mut walls, &mobility);
            assert!(Nlgs::new(settings).solve(contacts, &mut bodies, 1.0, 1.0, None).converged);
            (vel[0], walls[0])
        };
        // Free disk: it ends with the plate at the bound; its impulse is m × 0.5.
        let mut free = vec![disk_on(0, -Vec3::y(), 1.0 / big_m)];
        let (v, w) = solve(&mut free);
        assert!((v.y + 0.5).abs() < 1e-12 && (w.y + 0.5).abs() < 1e-12, "{v:?} {w:?}");
        assert!((free[0].r.x - 0.5).abs() < 1e-12, "{:?}", free[0].r);
        // On the floor: the plate stops, and the contacts carry M × 2 = 6 N·s.
        let mut held = vec![disk_on(0, -Vec3::y(), 1.0 / big_m), disk_on(1, Vec3::y(), 0.0)];
        let (v, w) = solve(&mut held);
        assert!(v.norm() < 1e-12 && w.norm() < 1e-12, "{v:?} {w:?}");
        assert!((held[0].r.x - 6.0).abs() < 1e-9 && (held[1].r.x - 6.0).abs() < 1e-9, "{:?} {:?}", held[0].r, held[1].r);
    }
    /// The cycle detector on the changes it is meant to tell apart, the three cycles of stalled
    /// frictional solves seen on the FEM compaction (issue 70): a change swinging by ten times
    /// about a level; one falling for 9 sweeps and jumping back up by 35 times, period 10; one
    /// falling by 1% a thousand sweeps and jumping up by 100 times every 8,000. Each halves the
    /// relaxation once it has shown no progress for [`STALL`] sweeps with a rise among them,
    /// then again, down to an eighth. A change that falls, however slowly and however noisily,
    /// keeps it whole.
    #[test]
    fn only_a_change_that_cycles_damps_the_sweeps() {
        let damping = |changes: &mut dyn Iterator<Item = Real>| {
            let mut c = Cycles::default();
            let mut halved = Vec::new();
            for (k, change) in changes.enumerate() {
                if c.observe(change) {
                    halved.push(k);
                }
            }
            (c.damping, halved)
        };
        let swing = |k: u32| if k.is_multiple_of(3) { 2e-5 } else { 2e-6 + 1e-7 * Real::from(k % 7) };
        assert_eq!(damping(&mut (0..3 * STALL).map(swing)), (0.25, vec![501, 1002]));
        assert_eq!(damping(&mut (0..20 * STALL).map(swing)).0, MIN_DAMPING);
        let period10 = |k: u32| 7.3e-3 * (0.66 as Real).powi((k % 10) as i32);
        assert_eq!(damping(&mut (0..2 * STALL).map(period10)), (0.5, vec![509]));
        let period8000 =
            |k: u32| 1e-4 * (0.01 as Real).powf(Real::from((k % 8000).min(2000)) / 2000.0) * (0.99999 as Real).powi((k % 8000) as i32);
        let (d, halved) = damping(&mut (0..12_000).map(period8000));
        assert_eq!(d, 0.5);
        assert!(halved.len() == 1 && (8000..8000 + STALL as usize + 10).contains(&halved[0]), "{halved:?}");
        // Plain Gauss-Seidel's slow decay (a few percent per thousand sweeps).
        let slow = |k: u32| 1e-3 * (0.99997 as Real).powi(k as i32);
        assert_eq!(damping(&mut (0..20 * STALL).map(slow)), (1.0, vec![]));
        // A noisy decay: its change halves every hundred sweeps.
        let noisy = |k: u32| 1e-3 * (0.993 as Real).powi(k as i32) * if k.is_multiple_of(2) { 3.0 } else { 1.0 };
        assert_eq!(damping(&mut (0..20 * STALL).map(noisy)), (1.0, vec![]));
    }
}
