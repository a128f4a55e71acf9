//! The normal impulses of a pair of grains' contacts solved together, exactly: the small
//! linear complementarity problem a contact solve's sweep meets at each pair's turn
//! ([`super::contact`]'s module documentation, "Pairs"); then, with friction, their tangential
//! impulses within their Coulomb bounds ([`boxed`]).
//!
//! With the pair's other impulses frozen, its contacts' normal velocities are `q + W x` for
//! their normal impulses `x` (`W` the pair's block of the Delassus operator, symmetric and
//! positive semi-definite: singular where the two grains' contacts hold the same places twice),
//! and Signorini's conditions are the complementarity problem `x >= 0`, `y = W x + q >= 0`,
//! `xᵀ y = 0` (`q` already net of the targets). It is solved by block principal pivoting
//! (Júdice and Pires, *Computers & Operations Research* 21, 1994): guess which contacts push,
//! solve the equations of those, exchange the ones that pull or the resting ones that are
//! violated, all at once while their count falls and one at a time (the largest index, Murty's
//! rule) when it does not, which ends in finitely many exchanges for a positive definite `W`.
//! `W` is made so by a proximal term: `(W + εI) x = ε x₀ − q` on the pushing set, `x₀` the
//! impulses the turn started from and `ε` a billionth of `W`'s largest diagonal, whose fixed
//! point across sweeps is the unregularised solution; along the directions where `W` is singular
//! the impulses then stay where they were, which changes no velocity.

use crate::math::Real;

/// The proximal term's weight, relative to the block's largest diagonal entry.
pub const PROXIMAL: Real = 1e-9;

/// Exchanges after which a solve gives up (a block that is not positive definite, by
/// rounding): the caller then takes the contacts one at a time.
const MAX_EXCHANGES: usize = 64;

/// Exchanges of the whole infeasible set that may fail to reduce it before Murty's rule.
const TRIES: u32 = 3;

/// Scratch of a block solve (kept between solves by each thread, so that a sweep allocates
/// nothing).
#[derive(Debug, Default)]
pub struct Scratch {
    factor: Vec<Real>,
    rhs: Vec<Real>,
    set: Vec<usize>,
    start: Vec<Real>,
    trial: Vec<Real>,
    y: Vec<Real>,
    bad: Vec<usize>,
    side: Vec<Side>,
    lower: Vec<Real>,
    upper: Vec<Real>,
}

/// Where an impulse of [`bounded`] lies in its interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    /// Inside: its equation `y = 0` holds (a normal impulse that pushes, a tangential one that
    /// sticks).
    Inside,
    /// At its lower bound, or its upper: a resting contact's zero normal impulse, a slipping
    /// contact's tangential one.
    Lower,
    Upper,
    /// An interval of one point (a contact without friction): held there.
    Pinned,
}

/// Solves the complementarity problem of `len` contacts (module documentation): `w` the block,
/// row-major `len × len`, `q` the normal velocities with no impulse minus the targets, `x` the
/// normal impulses the turn starts from, then the solution. Returns false, leaving `x` as it
/// was, when no solution is found within [`MAX_EXCHANGES`].
pub fn complementary(len: usize, w: &[Real], q: &[Real], x: &mut [Real], s: &mut Scratch) -> bool {
    let (mut lower, mut upper) = (std::mem::take(&mut s.lower), std::mem::take(&mut s.upper));
    lower.clear();
    lower.resize(len, 0.0);
    upper.clear();
    upper.resize(len, Real::INFINITY);
    let solved = bounded(len, w, q, (&lower, &upper), x, s);
    (s.lower, s.upper) = (lower, upper);
    solved
}

/// Solves the tangential impulses of a pair's contacts together, their normal impulses given
/// (module documentation of [`super::contact`], "Pairs"): `w` the pair's block of tangential
/// couplings (`t_iᵀ W t_j`, row-major `len × len`, symmetric and positive semi-definite), `q`
/// the tangential velocities with none of these impulses, `bound` each contact's Coulomb bound
/// `μ r_n` (N·s/m, zero for a contact without friction), `x` the impulses the turn starts from,
/// then the solution. With the normal impulses given, Coulomb's law in two dimensions is the
/// box-constrained problem `|x_i| ≤ bound_i`, `y = W x + q` with `y_i = 0` where `|x_i| <
/// bound_i` (sticking), `y_i ≤ 0` at `+bound_i` and `y_i ≥ 0` at `−bound_i` (slipping against
/// the impulse): the optimality conditions of the convex minimisation of `½ xᵀ W x + qᵀ x` over
/// the box, solved by the same block principal pivoting as [`complementary`] with two bounds
/// instead of one, with the same proximal term where two grains' contacts hold the same place
/// twice. Returns false, leaving `x` as it was, when no solution is found within
/// [`MAX_EXCHANGES`].
pub fn boxed(len: usize, w: &[Real], q: &[Real], bound: &[Real], x: &mut [Real], s: &mut Scratch) -> bool {
    let (mut lower, mut upper) = (std::mem::take(&mut s.lower), std::mem::take(&mut s.upper));
    lower.clear();
    lower.extend(bound[..len].iter().map(|b| -b.max(0.0)));
    upper.clear();
    upper.extend(bound[..len].iter().map(|b| b.max(0.0)));
    let solved = bounded(len, w, q, (&lower, &upper), x, s);
    (s.lower, s.upper) = (lower, upper);
    solved
}

/// The block principal pivoting of [`complementary`] and [`boxed`] for `lower ≤ x ≤ upper`
/// (`upper` may be infinite): `y = W x + q` is zero where `x` lies inside, non-negative at the
/// lower bound and non-positive at the upper one.
fn bounded(len: usize, w: &[Real], q: &[Real], (lower, upper): (&[Real], &[Real]), x: &mut [Real], s: &mut Scratch) -> bool {
    let n = len;
    let largest = (0..n).map(|i| w[i * n + i]).fold(0.0, Real::max);
    if largest.is_nan() || largest <= 0.0 {
        return false;
    }
    let eps = PROXIMAL * largest;
    s.start.clear();
    s.start.extend_from_slice(&x[..n]);
    s.side.clear();
    s.side.extend((0..n).map(|i| {
        if lower[i] >= upper[i] {
            Side::Pinned
        } else if x[i] <= lower[i] {
            Side::Lower
        } else if x[i] >= upper[i] {
            Side::Upper
        } else {
            Side::Inside
        }
    }));
    s.y.clear();
    s.y.resize(n, 0.0);
    let held = |side: Side, i: usize| match side {
        Side::Lower | Side::Pinned => lower[i],
        Side::Upper => upper[i],
        Side::Inside => 0.0,
    };
    let scale = q[..n].iter().map(|v| v.abs()).fold(0.0, Real::max) + largest * s.start.iter().map(|v| v.abs()).fold(0.0, Real::max);
    let tolerance = 1e-12 * scale;
    let (mut fewest, mut tries) = (n + 1, TRIES);
    for _ in 0..MAX_EXCHANGES {
        // The trial impulses: the held ones at their bounds, the inside ones from their
        // equations, by Cholesky.
        s.trial.clear();
        s.trial.extend((0..n).map(|i| held(s.side[i], i)));
        s.set.clear();
        s.set.extend((0..n).filter(|&i| s.side[i] == Side::Inside));
        let m = s.set.len();
        s.factor.clear();
        s.factor.resize(m * m, 0.0);
        s.rhs.clear();
        for (r, &i) in s.set.iter().enumerate() {
            for (c, &j) in s.set.iter().enumerate().take(r + 1) {
                s.factor[r * m + c] = w[i * n + j] + if i == j { eps } else { 0.0 };
            }
            let held: Real = (0..n).filter(|&j| s.side[j] != Side::Inside && s.trial[j] != 0.0).map(|j| w[i * n + j] * s.trial[j]).sum();
            s.rhs.push(eps * s.start[i] - q[i] - held);
        }
        if !cholesky_solve(m, &mut s.factor, &mut s.rhs) {
            return false;
        }
        for (r, &i) in s.set.iter().enumerate() {
            s.trial[i] = s.rhs[r];
        }
        // The velocities of every contact at the trial impulses.
        for i in 0..n {
            let mut y = q[i] + eps * (s.trial[i] - s.start[i]);
            for j in 0..n {
                if s.trial[j] != 0.0 {
                    y += w[i * n + j] * s.trial[j];
                }
            }
            s.y[i] = y;
        }
        // An inside impulse beyond a bound, or a held one whose velocity does not hold it
        // there; rounding may leave either a hair beyond, and neither is exchanged then (it
        // would be exchanged back).
        let impulses = s.trial.iter().chain(&s.start).map(|v| v.abs()).fold(0.0, Real::max);
        let hair = 1e-12 * impulses;
        s.bad.clear();
        s.bad.extend((0..n).filter(|&i| match s.side[i] {
            Side::Inside => s.trial[i] < lower[i] - hair || s.trial[i] > upper[i] + hair,
            Side::Lower => s.y[i] < -tolerance,
            Side::Upper => s.y[i] > tolerance,
            Side::Pinned => false,
        }));
        if s.bad.is_empty() {
            for i in 0..n {
                x[i] = s.trial[i].max(lower[i]).min(upper[i]);
            }
            return true;
        }
        let exchange = |side: Side, i: usize, t: Real| match side {
            Side::Inside if t > upper[i] => Side::Upper,
            Side::Inside => Side::Lower,
            _ => Side::Inside,
        };
        if s.bad.len() < fewest || tries > 0 {
            if s.bad.len() < fewest {
                fewest = s.bad.len();
                tries = TRIES;
            } else {
                tries -= 1;
            }
            for k in 0..s.bad.len() {
                let i = s.bad[k];
                s.side[i] = exchange(s.side[i], i, s.trial[i]);
            }
        } else if let Some(&i) = s.bad.last() {
            s.side[i] = exchange(s.side[i], i, s.trial[i]);
        }
    }
    false
}

/// Solves `A z = b` in place for the symmetric positive definite `A` of size `m` (its lower
/// triangle in `a`, row-major; overwritten by its Cholesky factor), `b` in `z`; false if `A` is
/// not positive definite.
fn cholesky_solve(m: usize, a: &mut [Real], z: &mut [Real]) -> bool {
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut v = a[i * m + j];
            for k in 0..j {
                v -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = v / d;
        }
    }
    for i in 0..m {
        let mut v = z[i];
        for k in 0..i {
            v -= a[i * m + k] * z[k];
        }
        z[i] = v / a[i * m + i];
    }
    for i in (0..m).rev() {
        let mut v = z[i];
        for k in i + 1..m {
            v -= a[k * m + i] * z[k];
        }
        z[i] = v / a[i * m + i];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random number generator in [0, 1) (a linear congruential one: the tests need no
    /// quality, only the same numbers every run).
    fn uniform(seed: u64) -> impl FnMut() -> Real {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as Real / (1u64 << 53) as Real
        }
    }

    /// A random block of `n` contacts as a pair's contacts make them — `W = Σ_g Hᵀ A_g⁻¹ H`
    /// through two grains, here `Gᵀ G` of a random `G` — with its first two contacts the same
    /// (the same place held twice: a singular block) if `twins`.
    fn random_block(n: usize, twins: bool, next: &mut impl FnMut() -> Real) -> Vec<Real> {
        let rank = 2 * n;
        let mut g: Vec<Vec<Real>> = (0..n).map(|_| (0..rank).map(|_| next() - 0.5).collect()).collect();
        if twins {
            g[1] = g[0].clone();
        }
        let mut w = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                w[i * n + j] = g[i].iter().zip(&g[j]).map(|(a, b)| a * b).sum::<Real>();
            }
        }
        w
    }

    /// Random blocks as a pair's contacts make them — `W = Σ_g Hᵀ A_g⁻¹ H` through two grains,
    /// here `Gᵀ G` of a random `G` plus a diagonal — of 1 to 24 contacts, a third of them with
    /// contacts duplicated (the same place held twice, as both grains' nodes along a flat
    /// boundary: a singular block), random velocities and targets: the solution meets
    /// Signorini's conditions to rounding, the pushing sets come in every size, and along a
    /// duplicated pair's null direction the impulses keep their start.
    #[test]
    fn a_pair_block_is_solved_exactly_even_when_singular() {
        let mut next = uniform(17);
        let mut scratch = Scratch::default();
        let mut sizes = [0usize; 4];
        for case in 0..2000 {
            let n = 1 + case % 24;
            let duplicated = case % 3 == 0 && n >= 2;
            let w = random_block(n, duplicated, &mut next);
            let q: Vec<Real> = (0..n).map(|_| 2.0 * next() - 1.2).collect();
            let start: Vec<Real> = (0..n).map(|_| if next() < 0.5 { 0.0 } else { next() }).collect();
            let mut x = start.clone();
            assert!(complementary(n, &w, &q, &mut x, &mut scratch), "case {case}: no solution");
            let scale = 1.0 + x.iter().map(|v| v.abs()).fold(0.0, Real::max);
            for i in 0..n {
                let y = q[i] + (0..n).map(|j| w[i * n + j] * x[j]).sum::<Real>();
                assert!(x[i] >= 0.0, "case {case}: {x:?}");
                assert!(y >= -1e-7 * scale, "case {case}: contact {i} violated by {:e}", -y);
                assert!(x[i] * y.abs() <= 1e-7 * scale * scale, "case {case}: contact {i} pushes while apart ({y:e})");
            }
            if duplicated && x[0] > 0.0 && x[1] > 0.0 {
                // The null direction moves impulse between the twins; the proximal term keeps
                // their difference where it started.
                assert!(
                    ((x[0] - x[1]) - (start[0] - start[1])).abs() <= 1e-6 * scale,
                    "case {case}: twins drifted apart: {x:?}, from {start:?}"
                );
            }
            let pushing = x.iter().filter(|&&v| v > 0.0).count();
            sizes[(4 * pushing / (n + 1)).min(3)] += 1;
        }
        assert!(sizes.iter().all(|&k| k > 0), "pushing sets of every size met: {sizes:?}");
    }
    /// Random pair blocks of tangential couplings (as in the test above, a third singular), with
    /// random velocities, bounds (one in five zero: a contact without friction) and starting
    /// impulses: the solution meets Coulomb's law with its normal impulses given to rounding —
    /// within its bound, sticking where inside (velocity zero), slipping against its impulse
    /// at a bound — and contacts stick, slip both ways and are pinned across the cases.
    #[test]
    fn a_pair_s_tangential_impulses_meet_coulomb_s_law_together() {
        let mut next = uniform(29);
        let mut scratch = Scratch::default();
        let (mut sticking, mut slipping) = (0, 0);
        for case in 0..2000 {
            let n = 1 + case % 24;
            let w = random_block(n, case % 3 == 0 && n >= 2, &mut next);
            let q: Vec<Real> = (0..n).map(|_| 2.0 * next() - 1.0).collect();
            let bound: Vec<Real> = (0..n).map(|_| if next() < 0.2 { 0.0 } else { 0.5 * next() }).collect();
            let mut x: Vec<Real> = (0..n).map(|i| (2.0 * next() - 1.0) * bound[i]).collect();
            assert!(boxed(n, &w, &q, &bound, &mut x, &mut scratch), "case {case}: no solution");
            let scale = 1.0 + q.iter().map(|v| v.abs()).fold(0.0, Real::max);
            for i in 0..n {
                let y = q[i] + (0..n).map(|j| w[i * n + j] * x[j]).sum::<Real>();
                let b = bound[i];
                assert!(x[i].abs() <= b, "case {case}: contact {i} beyond its bound: {} > {b}", x[i]);
                if b == 0.0 {
                    continue;
                }
                if x[i].abs() < b * (1.0 - 1e-9) {
                    sticking += 1;
                    assert!(y.abs() <= 1e-7 * scale, "case {case}: contact {i} sticks but moves at {y:e}");
                } else {
                    slipping += 1;
                    assert!(y * x[i] <= 1e-7 * scale * b, "case {case}: contact {i} slips with its impulse ({y:e}, {})", x[i]);
                }
            }
        }
        assert!(sticking > 1000 && slipping > 1000, "sticking {sticking}, slipping {slipping}");
    }
}
