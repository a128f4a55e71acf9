//! A soft grain's Newton matrix made definite along its closed contacts.
//!
//! Under compression a grain's geometric stiffness is negative, and over a long step it can
//! outweigh the inertia along the few modes its contacts hold: the linearised rotation of a
//! grain squeezed between plates stretches it at second order, which its stress favours. The
//! matrix `A = M + (θh)² K` is then indefinite, while the step's problem — `A` together with
//! the contacts that hold the grain — is well posed.
//!
//! Each closed contact (normal impulse > 0 at the last solve) then adds `ρ h hᵀ` to `A`,
//! `h = Hᵀ n` its normal's nodal weights: the augmented Lagrangian's penalty (Hestenes,
//! "Multiplier and gradient methods", J. Optim. Theory Appl. 4, 303, 1969; in contact
//! mechanics, Alart & Curnier, "A mixed formulation for frictional contact problems prone to
//! Newton like solution methods", Comput. Methods Appl. Mech. Eng. 92, 353, 1991). The
//! residual is left as it is. A contact that stays closed keeps its normal velocity at its
//! Signorini target from one iterate to the next, `hᵀ δv = 0`, and there `(A + ρ h hᵀ) δv =
//! A δv`: the linearised step is Newton's own on the grain and its closed contacts, whatever
//! `ρ`, and Newton keeps its quadratic rate once the set of closed contacts has settled. Only
//! a contact that opens or closes during the iteration sees the penalty (as a spring of
//! stiffness `ρ/(θh)²` for that iteration); the fixed point is the residual's, unchanged.
//! (Replacing `K` by its positive part instead changes every compressed mode, and Newton is
//! then linear.)
//!
//! Between two grains a closed contact holds only their relative normal velocity, and each
//! grain's factor sees its own side alone: there the linearised step is Newton's own only
//! where the other grain's side does not move within the iteration.
//!
//! `ρ` starts at the largest diagonal entry of `A` on the contacts' unknowns and grows by
//! [`PENALTY_GROWTH`] until the Cholesky factorisation succeeds, at most [`PENALTY_TRIES`]
//! times. Where the closed contacts do not hold every indefinite mode (on a squeezed disk, one
//! sat at the node just outside the contact), the open contacts ([`with_contacts_of`]) are added
//! and the search made again; a grain that neither makes definite falls back on the method's
//! damping.

use nalgebra::Vector2;

use super::contact::{GrainContacts, Support, VertexContact};
use crate::math::Real;

type V2 = Vector2<Real>;

/// The factor by which the penalty grows between factorisations.
pub const PENALTY_GROWTH: Real = 8.0;

/// Most penalties tried before the method's damping.
pub const PENALTY_TRIES: u32 = 8;

/// A contact on a grain, closed or open: where it acts and its normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closed {
    /// The grain's nodes that carry the contact, with their weights.
    pub support: Support,
    /// The contact's unit normal.
    pub normal: V2,
}

thread_local! {
    /// Each thread's list of a grain's contacts, kept between grains and steps.
    static CONTACTS: std::cell::RefCell<Vec<Closed>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Calls `f` with the contacts of grain side `side` — the closed ones first (normal impulse
/// above zero in `contacts`), then the open ones — and how many are closed; the list is a
/// thread's scratch, not allocated again for each grain.
pub fn with_contacts_of<R>(side: &GrainContacts, contacts: &[VertexContact], f: impl FnOnce(&[Closed], usize) -> R) -> R {
    CONTACTS.with(|cell| {
        let mut list = cell.borrow_mut();
        list.clear();
        let mut closed_count = 0;
        for closed in [true, false] {
            for (support, &(c, _)) in side.samples.iter().zip(&side.entries) {
                if let Some(k) = contacts.get(c as usize).filter(|k| (k.r.x > 0.0) == closed) {
                    list.push(Closed { support: *support, normal: V2::new(k.frame.n.x, k.frame.n.y) });
                }
            }
            if closed {
                closed_count = list.len();
            }
        }
        f(&list, closed_count)
    })
}

/// Calls `add(row, col, value)` with `row >= col` for the lower triangle of `ρ Σ h hᵀ` over
/// `closed` (unknowns `2 node + axis`), leaving out the unknowns `held` says are prescribed.
pub fn penalty(closed: &[Closed], rho: Real, held: impl Fn(usize) -> bool, mut add: impl FnMut(usize, usize, Real)) {
    for c in closed {
        let h = || c.support.iter().flat_map(|(k, w)| [(2 * k, w * c.normal.x), (2 * k + 1, w * c.normal.y)]);
        for (i, hi) in h() {
            if held(i) {
                continue;
            }
            for (j, hj) in h() {
                if j <= i && !held(j) {
                    add(i, j, rho * hi * hj);
                }
            }
        }
    }
}

/// The unknowns the closed contacts act on (with repeats).
pub fn unknowns(closed: &[Closed]) -> impl Iterator<Item = usize> + '_ {
    closed.iter().flat_map(|c| c.support.iter().flat_map(|(k, _)| [2 * k, 2 * k + 1]))
}

/// Tries `factorise(ρ)` for `ρ = first`, then [`PENALTY_GROWTH`] times more, at most
/// [`PENALTY_TRIES`] times; the `ρ` that succeeded.
pub fn search(first: Real, mut factorise: impl FnMut(Real) -> bool) -> Option<Real> {
    let mut rho = first;
    for _ in 0..PENALTY_TRIES {
        if factorise(rho) {
            return Some(rho);
        }
        rho *= PENALTY_GROWTH;
    }
    None
}
