//! Each contact's drift at a Newton iterate ([`measure_drifts`]): how much more its gap will be
//! at the step's end than its linear prediction says, the outlines moved where the iterate
//! takes them and the gap measured anew on the contact's own segment or a neighbour across a
//! convex corner (`sliding`).

use nalgebra::Vector2;

use super::candidates::{on_segment, reflex};
use super::grain_contacts::GrainContacts;
use super::records::{Other, Support, VertexContact, Wall};
use crate::math::Real;

type V2 = Vector2<Real>;

/// Sets each contact's drift ([`VertexContact::drift`]) at the current iterate: `moved` each
/// grain's outline where the iterate takes it (empty for a grain without a contact),
/// `displacement(grain, support)` the iterate's displacement of a place over the step (m), the
/// walls moving at their velocity over `dt` (s).
pub fn measure_drifts(
    contacts: &mut [VertexContact],
    sides: &[GrainContacts],
    walls: &[Wall],
    moved: &[Vec<V2>],
    dt: Real,
    displacement: impl Fn(usize, &Support) -> V2,
) {
    for c in contacts {
        let n = V2::new(c.frame.n.x, c.frame.n.y);
        let x = moved[c.a as usize][c.vertex];
        let ua = displacement(c.a as usize, &sides[c.a as usize].samples[c.slot as usize]);
        let (ub, now) = match c.b {
            Other::Grain { grain, slot } => {
                let ub = displacement(grain as usize, &sides[grain as usize].samples[slot as usize]);
                let outline = &moved[grain as usize];
                let now = match c.line {
                    Some(k) => on_segment(outline, k as usize, &x).map(|s| s.0.gap),
                    None => sliding(outline, c.segment as usize, &x),
                };
                (ub, now.unwrap_or(c.gap))
            }
            Other::Wall(w) => {
                let wall = &walls[w as usize];
                let ub = wall.velocity * dt;
                (ub, (x - wall.point - ub).dot(&wall.normal))
            }
        };
        c.drift = now - (c.gap + (ua - ub).dot(&n));
    }
}

/// The gap (m) of a vertex at `x` from `outline` (moved by the iterate), for a contact found
/// against segment `own` ([`measure_drifts`]): from that segment or from a neighbour across a
/// convex corner, whichever is nearer (the outline sliding under the vertex). Not from any
/// other segment: at a reflex corner the vertex's second contact holds it on the other side's
/// line ([`candidates`]), and the gap from the outline's nearest segment jumps there: a vertex
/// moved nearer the dent's other side would see a large negative drift within a part and push
/// its grains apart fast enough for Newton to diverge (docs/methods/mpm.md).
///
/// [`candidates`]: super::candidates::candidates
fn sliding(outline: &[V2], own: usize, x: &V2) -> Option<Real> {
    let n = outline.len();
    let mut best = on_segment(outline, own % n, x);
    for (corner, side) in [(own % n, (own + n - 1) % n), ((own + 1) % n, (own + 1) % n)] {
        if side == own % n || reflex(outline, corner) {
            continue;
        }
        if let Some(s) = on_segment(outline, side, x) {
            if best.is_none_or(|b| s.1 < b.1) {
                best = Some(s);
            }
        }
    }
    best.map(|s| s.0.gap)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::soft::polygon::nearest;

    /// A contact's gap is measured again on its own segment, or on a neighbour across a convex
    /// corner, never across a reflex one, where the outline's nearest segment would jump.
    #[test]
    fn the_gap_slides_across_convex_corners_only() {
        let dented = vec![V2::new(-2.0, -2.0), V2::new(2.0, -2.0), V2::new(2.0, 1.0), V2::new(0.0, 0.0), V2::new(-2.0, 1.0)];
        // Past the reflex corner (0, 0) the nearest segment is the dent's other side, whose
        // line the vertex is behind; the contact keeps its own segment's line.
        let x = V2::new(-0.3, 0.05);
        let near = nearest(&dented, &x).expect("nearest");
        assert!(near.segment == 3 && near.gap < 0.0, "{near:?}");
        let gap = sliding(&dented, 2, &x).expect("gap");
        assert!((gap - 0.4 / 5f64.sqrt()).abs() < 1e-12, "{gap}");
        // Past the convex corner (2, 1) it slides on to the side x = 2.
        let gap = sliding(&dented, 2, &V2::new(2.3, 0.5)).expect("gap");
        assert!((gap - 0.3).abs() < 1e-12, "{gap}");
    }
}
