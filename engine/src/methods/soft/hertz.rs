//! The half-width of a line contact from the forces at the nodes or vertices along it, for the
//! tests of the soft-grain methods against Hertz (docs/references.md check 19).

use crate::math::Real;

/// Half-width of the contact from the forces `at` (`(x, force)` pairs along the contact, any
/// order): the `a` of the Hertz pressure `p(x) = (2P / πa) sqrt(1 − (x − x0)²/a²)` (the total
/// force `P`, its centre `x0` the forces' mean) whose integral over each place's share of the
/// line (from midway to its neighbours) fits the forces best, least squares. (The forces'
/// variance, `a²/4` for the continuous profile, resolves the patch's edges only to a spacing.)
/// Returns (a, total force, peak pressure: the largest force over the mean spacing).
pub fn fit(at: &mut [(Real, Real)]) -> (Real, Real, Real) {
    at.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: Real = at.iter().map(|e| e.1).sum();
    let x0 = at.iter().map(|e| e.0 * e.1).sum::<Real>() / total;
    let n = at.len();
    let spacing = (at[n - 1].0 - at[0].0) / (n - 1) as Real;
    let share = |k: usize| {
        let lo = if k == 0 { at[0].0 - 0.5 * spacing } else { 0.5 * (at[k - 1].0 + at[k].0) };
        let hi = if k + 1 == n { at[n - 1].0 + 0.5 * spacing } else { 0.5 * (at[k].0 + at[k + 1].0) };
        (lo, hi)
    };
    // The fraction of the Hertz force below `u = (x − x0) / a`.
    let below = |u: Real| {
        let u = u.clamp(-1.0, 1.0);
        0.5 + (u * (1.0 - u * u).sqrt() + u.asin()) / std::f64::consts::PI as Real
    };
    let misfit = |a: Real| {
        (0..n)
            .map(|k| {
                let (lo, hi) = share(k);
                let model = total * (below((hi - x0) / a) - below((lo - x0) / a));
                (model - at[k].1).powi(2)
            })
            .sum::<Real>()
    };
    // Golden-section search over a from a tenth of the patch to all of it.
    let (mut lo, mut hi) = (0.1 * spacing * n as Real, spacing * n as Real);
    let g = 0.5 * (5.0 as Real).sqrt() - 0.5;
    for _ in 0..100 {
        let (c, d) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if misfit(c) < misfit(d) {
            hi = d;
        } else {
            lo = c;
        }
    }
    let peak = at.iter().map(|e| e.1).fold(0.0, Real::max) / spacing;
    (0.5 * (lo + hi), total, peak)
}
