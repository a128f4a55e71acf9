//! One pass of the solver over the contacts: a contact's turn (its local problem solved exactly
//! with the others frozen, [`visit`]), the accelerated sweep's momentum ([`carry`]), what a
//! sweep adds up for the convergence criterion ([`Sums`]), and the same turn for a method's own
//! contact problem ([`ContactProblem`], [`visit_local`], [`carry_local`]).

use super::bodies::BodyStore;
use super::contact::RigidContact;
use super::local::{self, Delassus, LocalLaw};
use crate::math::{Real, Vec3};

/// A contact problem the solver can sweep whatever its bodies ([`Nlgs::solve_problem`]):
/// each contact's local velocity comes from its bodies, its impulse changes them. A method
/// implements the bodies' side (what an impulse does to them) and calls [`visit_local`] and
/// [`carry_local`] for the contact's own turn, so that the local laws, the relaxation, the
/// acceleration and the criterion are those of every other method.
pub(crate) trait ContactProblem {
    /// Number of contacts.
    fn len(&self) -> usize;
    /// Contact `c`'s impulse (local components, N·s).
    fn impulse(&self, c: usize) -> Vec3;
    /// Adds the contacts' warm-start impulses to their bodies.
    fn warm_start(&mut self);
    /// One pass over the contacts, each with its impulse after the previous sweep in `last`:
    /// at [`Pass::Solve`] each contact's turn ([`visit_local`], its impulse's change applied to
    /// its bodies) with what it adds to the criterion; at [`Pass::Carry`] the accelerated
    /// sweep's momentum ([`carry_local`]). The problem chooses the order (and may take
    /// contacts that share no body at once, on several threads).
    fn sweep(&mut self, last: &mut [Vec3], pass: Pass) -> Sums;
}

/// One pass of the solver over the contacts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Pass {
    /// A Gauss-Seidel sweep at relaxation `omega` ([`visit`]).
    Solve {
        /// Relaxation.
        omega: Real,
    },
    /// The accelerated sweep's momentum at factor `beta` ([`carry`]).
    Carry {
        /// Momentum factor.
        beta: Real,
    },
}

impl Pass {
    /// The pass on contact `c`, whose impulse after the previous sweep is in `last`.
    #[inline(always)]
    pub(crate) fn apply(self, c: &mut RigidContact, last: &mut Vec3, bodies: &mut impl BodyStore, sums: &mut Sums) {
        match self {
            Pass::Solve { omega } => visit(c, bodies, omega, sums),
            Pass::Carry { beta } => carry(c, last, bodies, beta),
        }
    }
}

/// The momentum of the accelerated sweep on one contact (module documentation): its impulse
/// carried on by `beta` times its change since `last` (the impulse after the previous sweep),
/// projected on the admissible set, the change applied to its bodies; `last` takes the impulse
/// the sweep left. A contact with a liquid's viscosity takes none ([`carry_local`]).
#[inline(always)]
pub(crate) fn carry(c: &mut RigidContact, last: &mut Vec3, bodies: &mut impl BodyStore, beta: Real) {
    let y = carry_local(c.r, last, beta, &c.law);
    if let Some(y) = y {
        c.apply(&c.frame.to_global(&(y - c.r)), bodies);
        c.r = y;
    }
}

/// The momentum of the accelerated sweep on a contact of impulse `x` (local, N·s) and law
/// `law`, whatever its bodies: `x` carried on by `beta` times its change since `last`,
/// projected on the admissible set; `last` takes `x`. The new impulse if it differs from `x`.
///
/// A contact with a liquid's viscosity `k` takes no momentum: its normal bound,
/// `r_n >= −c − k U_n`, moves with the velocities the momentum itself changes, and open its law
/// is an equality (`r_n = −c − k U_n`) that nothing projects a carried impulse back onto, while
/// the restart watches only the Signorini violations (an open contact violates nothing). On a
/// sheared packing held by bridges 800 times as viscous as water (the most viscous series of
/// `scenes/studies/wet_rheology.json`, run by contact dynamics) the carried impulses grew without
/// bound, the grains reached 2e9 m/s within one solve and the step failed on a NaN change at
/// step 27, also with the momentum kept on the closed viscous contacts alone. The plain sweep
/// converges on the viscous law, which is monotone.
#[inline(always)]
pub(crate) fn carry_local(x: Vec3, last: &mut Vec3, beta: Real, law: &LocalLaw) -> Option<Vec3> {
    let d = x - *last;
    *last = x;
    if beta == 0.0 || law.viscosity > 0.0 || d == Vec3::zeros() {
        return None;
    }
    let ahead = x + d * beta;
    let r_n = ahead.x.max(-law.cohesion);
    let (t1, t2) = local::within_disk(ahead.y, ahead.z, law.friction * (r_n + law.cohesion));
    let y = Vec3::new(r_n, t1, t2);
    (y != x).then_some(y)
}

/// What a sweep adds up for the criterion: the squared changes and sizes of the impulses, the
/// violations, and the contacts counted (all but the near pairs, [`RigidContact::near`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Sums {
    pub(crate) change2: Real,
    pub(crate) size2: Real,
    pub(crate) violation: Real,
    /// Contacts counted in the mean violation (near pairs only while they act).
    pub(crate) count: usize,
    /// The largest violation over the lever of the contact's first body, 1/s.
    pub(crate) worst: Real,
}

impl std::ops::AddAssign for Sums {
    fn add_assign(&mut self, o: Self) {
        self.change2 += o.change2;
        self.size2 += o.size2;
        self.violation += o.violation;
        self.count += o.count;
        self.worst = self.worst.max(o.worst);
    }
}

/// One contact's turn in a sweep: its violation measured, its local problem solved exactly with
/// the rest frozen (then its rolling block), the change of its impulses applied to its bodies.
#[inline(always)]
pub(crate) fn visit(c: &mut RigidContact, bodies: &mut impl BodyStore, omega: Real, sums: &mut Sums) {
    let u_now = c.frame.to_local(&c.velocity_in(bodies));
    let (r, u_free) = visit_local(u_now, &c.w, &c.law, c.r, Turn { omega, near: c.near, scale: c.scale, lever: c.a_i }, sums);
    let dr = r - c.r;
    if dr != Vec3::zeros() {
        c.apply(&c.frame.to_global(&dr), bodies);
    }
    c.r = r;
    if c.rolling.bound > 0.0 && c.rolling.w > 0.0 {
        // The rolling block, with the normal impulse just found (its moments counted as
        // impulses at the lever a_i).
        let free = c.rolling_velocity(bodies) - c.rolling.m * c.rolling.w;
        let rho = c.law.contact_part(r.x, u_free.x + c.w.n * r.x);
        let mut m = local::solve_rolling(&c.rolling, &free, rho);
        if omega != 1.0 {
            m = c.rolling.m + (m - c.rolling.m) * omega;
        }
        let dm = m - c.rolling.m;
        if dm != Vec3::zeros() {
            c.apply_moment(&dm, bodies);
            sums.change2 += dm.norm_squared() / (c.a_i * c.a_i);
        }
        sums.size2 += m.norm_squared() / (c.a_i * c.a_i);
        c.rolling.m = m;
    }
}

/// What a contact brings to its turn in a sweep besides its velocity, block, law and impulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Turn {
    /// Relaxation.
    pub(crate) omega: Real,
    /// A near pair ([`RigidContact::near`]).
    pub(crate) near: bool,
    /// Impulse scale for the criterion, N·s ([`RigidContact::scale`]).
    pub(crate) scale: Real,
    /// Length the largest violation is measured against (the first body's radius), m.
    pub(crate) lever: Real,
}

/// A contact's turn in a sweep, whatever its bodies: its violation measured at the local
/// velocity `u_now` (with its impulse `r` in it), its local problem of block `w` solved
/// exactly with the rest frozen, relaxed by `turn.omega`, the sums of the criterion updated.
/// Returns the new impulse and the velocity the contact would have without its own impulse;
/// the caller applies the change of impulse to the bodies.
#[inline(always)]
pub(crate) fn visit_local(u_now: Vec3, w: &Delassus, law: &LocalLaw, r_old: Vec3, turn: Turn, sums: &mut Sums) -> (Vec3, Vec3) {
    measure_violation(u_now.x, law, &turn, sums);
    let u_free = u_now - w.apply(&r_old);
    let mut r = local::solve(w, &u_free, law);
    if turn.omega != 1.0 {
        r = r_old + (r - r_old) * turn.omega;
    }
    tally_change(r_old, r, &turn, sums);
    (r, u_free)
}

/// The criterion's violation of a contact at the normal velocity `u_n` (m/s) it has when its
/// turn comes ([`visit_local`]; a method that solves several contacts at once measures each
/// with this before it solves them).
#[inline(always)]
pub(crate) fn measure_violation(u_n: Real, law: &LocalLaw, turn: &Turn, sums: &mut Sums) {
    let violation = (law.target - u_n).max(0.0);
    sums.violation += violation;
    sums.worst = sums.worst.max(violation / turn.lever);
}

/// The criterion's change and size of a contact whose turn took its impulse from `r_old` to
/// `r` ([`visit_local`]; with [`measure_violation`], for a method that solves several contacts
/// at once).
#[inline(always)]
pub(crate) fn tally_change(r_old: Vec3, r: Vec3, turn: &Turn, sums: &mut Sums) {
    let dr = r - r_old;
    if dr != Vec3::zeros() {
        sums.change2 += dr.norm_squared();
    }
    if !turn.near || r != Vec3::zeros() || dr != Vec3::zeros() {
        sums.size2 += r.norm_squared().max(turn.scale * turn.scale);
        sums.count += 1;
    }
}

/// The law of a contact whose normal velocity at the start of the step is `u_n` (m/s), for the
/// restitution `e`, friction `mu` and cohesive impulse `c`: the formal-velocity target
/// `b = -e min(u_n, 0)` ([`super::local`]).
pub fn law_for(u_n: Real, e: Real, mu: Real, c: Real) -> LocalLaw {
    LocalLaw { target: -e * u_n.min(0.0), friction: mu, cohesion: c, viscosity: 0.0 }
}
