//! The ghost penalty on a grain's thinly supported nodes: the small-cut instability of the
//! material point method, and its cure.
//!
//! A grid node that only the tails of the outer points' splines reach carries almost no mass
//! and almost no stiffness (a quadratic spline's value falls as the square of its distance to
//! the edge of its support, its gradient as the distance): the velocity field there is barely
//! determined, and a contact acting through those nodes can drive it where the material
//! cannot follow: a point carrying an outline vertex can spin in place under a plate until a
//! point inverts (docs/methods/mpm.md, Limits, "Thinly supported nodes"). The unfitted
//! finite-element methods know this as the small-cut problem, and the ghost penalty as its
//! remedy (Burman, "Ghost penalty", C. R. Math. Acad. Sci. Paris 348, 1217, 2010); Coombs
//! brought it to the material point method ("Ghost stabilisation of the material point
//! method for stable quasi-static and dynamic analysis of large deformation problems", Int. J.
//! Numer. Methods Eng. 124, 2023; docs/physics.md §5.1).
//!
//! Off unless a scene sets `method.ghost_penalty`
//! ([`crate::methods::mpm::MpmParams::ghost_penalty`]: it raised the outlines' overlap in
//! random compactions, docs/methods/mpm.md, Limits). Here: along each grid line, every three
//! consecutive nodes of a grain's field that all carry mass, one of which is thin (mass below
//! [`THIN`] of the grain's fullest node), add the energy `½ κ |u_a − 2 u_b + u_c|²` of the
//! step's displacements, `κ = g M` with `M` the law's P-wave modulus and `g` the scene's
//! fraction ([`GAMMA`] recommended). The second difference vanishes on every linear
//! displacement field — translations, rotations to first order, uniform strains — so the patch
//! test and momentum are kept (its forces sum to zero and have no moment about any point); it
//! resists only the curvature of the field where the points do not hold it, at the scale of a
//! cell. The penalty is linear in the displacements, so Newton's matrix takes it exactly.
//!
//! Its price is a stiffer outer layer wherever the field is curved: the second difference is
//! not zero on a quadratic field, which the splines represent (measured on the two-plate disk:
//! docs/methods/mpm.md, Limits). A third difference would leave quadratic fields free, at the
//! price of a wider band.

use super::field::Field;
use super::grid::V2;
use crate::math::Real;
use crate::methods::soft::Scheme;

/// A node is thin below this fraction of the grain's fullest node's mass.
pub const THIN: Real = 0.25;

/// The recommended ghost stiffness as a fraction of the law's P-wave modulus (chosen on the
/// squeezed disk: docs/methods/mpm.md, Limits).
pub const GAMMA: Real = 0.1;

/// The triples of `field`'s nodes the penalty acts on: every three consecutive nodes (local
/// indices) along a grid line that all carry mass, one of them thin ([`THIN`]), into `out`.
pub fn find(field: &Field, out: &mut Vec<[usize; 3]>) {
    out.clear();
    let full = field.mass.iter().copied().fold(0.0, Real::max);
    let thin = |k: usize| field.mass[k] < THIN * full;
    let (i0, j0) = (field.i0, field.j0);
    for j in j0..j0 + field.wy {
        for i in i0..i0 + field.wx {
            for (di, dj) in [(1, 0), (0, 1)] {
                if i + 2 * di >= i0 + field.wx || j + 2 * dj >= j0 + field.wy {
                    continue;
                }
                let t = [field.local(i, j), field.local(i + di, j + dj), field.local(i + 2 * di, j + 2 * dj)];
                if t.iter().all(|&k| field.mass[k] > 0.0) && t.iter().any(|&k| thin(k)) {
                    out.push(t);
                }
            }
        }
    }
}

/// The second difference's weights on a triple's nodes.
const WEIGHTS: [Real; 3] = [1.0, -2.0, 1.0];

/// The ghost forces' part of the residual at the current iterate, `h θ κ Dᵀ D u` for the
/// step's displacements `u` (N·s/m, per node), over the `triples`; `kappa` in Pa (N/m per m
/// of displacement, per metre of thickness); `displacement(k)` node `k`'s, m.
pub fn add_residual(triples: &[[usize; 3]], kappa: Real, sc: &Scheme, displacement: impl Fn(usize) -> V2, residual: &mut [V2]) {
    let scale = sc.dt * sc.theta * kappa;
    for t in triples {
        let d = (0..3).fold(V2::zeros(), |d, a| d + displacement(t[a]) * WEIGHTS[a]);
        for a in 0..3 {
            residual[t[a]] += d * (scale * WEIGHTS[a]);
        }
    }
}

/// Calls `add(row, col, value)` (`row >= col`, unknowns `2 node + axis`) with the lower
/// triangle of the ghost term of Newton's matrix over the `triples`, `(θh)² κ Dᵀ D`.
pub fn add_matrix(triples: &[[usize; 3]], kappa: Real, sc: &Scheme, mut add: impl FnMut(usize, usize, Real)) {
    let scale = (sc.dt * sc.theta).powi(2) * kappa;
    for t in triples {
        for a in 0..3 {
            for b in 0..3 {
                let (r, c) = (t[a], t[b]);
                if c <= r {
                    for axis in 0..2 {
                        add(2 * r + axis, 2 * c + axis, scale * WEIGHTS[a] * WEIGHTS[b]);
                    }
                }
            }
        }
    }
}
