//! The geometry of a closed counter-clockwise polygon given by its vertices' positions (a
//! grain's outline): its area, whether a place is inside, and the segment nearest a place.

use nalgebra::Vector2;

use crate::math::Real;

type V2 = Vector2<Real>;

/// Area enclosed by the polygon `positions`, m² (shoelace).
pub fn area(positions: &[V2]) -> Real {
    let n = positions.len();
    0.5 * (0..n).map(|k| positions[k].perp(&positions[(k + 1) % n])).sum::<Real>()
}

/// The smallest box holding the polygon `positions`: (lower corner, upper corner), m (empty:
/// +∞ and −∞).
pub fn bounding_box(positions: &[V2]) -> (V2, V2) {
    positions.iter().fold((V2::repeat(Real::INFINITY), V2::repeat(Real::NEG_INFINITY)), |(lo, hi), p| (lo.inf(p), hi.sup(p)))
}

/// Area (m²), centroid (m) and second moments of area about the centroid (m⁴: `∫ d dᵀ dA`,
/// `d` the offset from the centroid) of the polygon `positions` (the polygon's own formulas,
/// offsets taken from its first vertex for round-off).
pub fn second_moments(positions: &[V2]) -> (Real, V2, nalgebra::Matrix2<Real>) {
    let n = positions.len();
    let Some(&o) = positions.first() else { return (0.0, V2::zeros(), nalgebra::Matrix2::zeros()) };
    let (mut a, mut cx, mut cy, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for k in 0..n {
        let (p, q) = (positions[k] - o, positions[(k + 1) % n] - o);
        let c = p.x * q.y - q.x * p.y;
        a += 0.5 * c;
        cx += (p.x + q.x) * c / 6.0;
        cy += (p.y + q.y) * c / 6.0;
        xx += (p.x * p.x + p.x * q.x + q.x * q.x) * c / 12.0;
        yy += (p.y * p.y + p.y * q.y + q.y * q.y) * c / 12.0;
        xy += (p.x * q.y + 2.0 * p.x * p.y + 2.0 * q.x * q.y + q.x * p.y) * c / 24.0;
    }
    if a == 0.0 {
        return (0.0, o, nalgebra::Matrix2::zeros());
    }
    let (gx, gy) = (cx / a, cy / a);
    let m = nalgebra::Matrix2::new(xx - a * gx * gx, xy - a * gx * gy, xy - a * gx * gy, yy - a * gy * gy);
    (a, o + V2::new(gx, gy), m)
}

/// Whether `x` is inside the polygon `positions` (even-odd rule).
pub fn contains(positions: &[V2], x: &V2) -> bool {
    let n = positions.len();
    let mut inside = false;
    for k in 0..n {
        let (a, b) = (positions[k], positions[(k + 1) % n]);
        if (a.y > x.y) != (b.y > x.y) {
            let cross = a.x + (x.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if x.x < cross {
                inside = !inside;
            }
        }
    }
    inside
}

/// The segment of a polygon nearest a place, and the place's signed distance from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// The segment: from vertex `segment` to the next.
    pub segment: usize,
    /// Where along it the place projects, in [0, 1].
    pub t: Real,
    /// Outward unit normal of the segment.
    pub normal: V2,
    /// Distance along the normal from the segment's line, m (negative inside).
    pub gap: Real,
}

/// The segment of the counter-clockwise polygon `positions` nearest `x` (by distance to the
/// segment), with `x`'s distance along its outward normal; `None` for a degenerate polygon.
pub fn nearest(positions: &[V2], x: &V2) -> Option<Nearest> {
    let n = positions.len();
    let mut best: Option<(Real, Nearest)> = None;
    for k in 0..n {
        let (a, b) = (positions[k], positions[(k + 1) % n]);
        let d = b - a;
        let len2 = d.norm_squared();
        if len2 <= 0.0 {
            continue;
        }
        let t = ((x - a).dot(&d) / len2).clamp(0.0, 1.0);
        let dist2 = (x - (a + d * t)).norm_squared();
        if best.as_ref().is_none_or(|(b2, _)| dist2 < *b2) {
            let len = len2.sqrt();
            let normal = V2::new(d.y / len, -d.x / len);
            best = Some((dist2, Nearest { segment: k, t, normal, gap: (x - a).dot(&normal) }));
        }
    }
    best.map(|(_, n)| n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_moments_of_a_rectangle_and_a_fine_ellipse() {
        let (w, h) = (3.0, 1.0);
        let rect = [V2::new(1.0, 2.0), V2::new(1.0 + w, 2.0), V2::new(1.0 + w, 2.0 + h), V2::new(1.0, 2.0 + h)];
        let (a, c, m) = second_moments(&rect);
        assert!((a - w * h).abs() < 1e-12 && (c - V2::new(2.5, 2.5)).norm() < 1e-12);
        assert!((m[(0, 0)] - w.powi(3) * h / 12.0).abs() < 1e-12 && (m[(1, 1)] - w * h.powi(3) / 12.0).abs() < 1e-12);
        assert!(m[(0, 1)].abs() < 1e-12);
        // An ellipse of half-axes 2 and 1 turned by 30°: its principal moments' ratio is 4.
        let t = std::f64::consts::FRAC_PI_6;
        let e: Vec<V2> = (0..2000)
            .map(|k| {
                let s = 2.0 * std::f64::consts::PI * k as Real / 2000.0;
                let (x, y) = (2.0 * s.cos(), s.sin());
                V2::new(x * t.cos() - y * t.sin(), x * t.sin() + y * t.cos())
            })
            .collect();
        let (_, _, m) = second_moments(&e);
        let (mean, r) = (0.5 * (m[(0, 0)] + m[(1, 1)]), (0.25 * (m[(0, 0)] - m[(1, 1)]).powi(2) + m[(0, 1)].powi(2)).sqrt());
        assert!(((mean + r) / (mean - r) - 4.0).abs() < 1e-4);
    }
}
