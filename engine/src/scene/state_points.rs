//! The material points of deformable grains in a saved state (`material_points`, written by a
//! run of method `mpm`, `docs/scene-format.md` §14), and their check when a scene starts from
//! one.
//!
//! A state's `particles` hold every grain as a disk of its current area, which any method can
//! start from. An `mpm` run adds its material points, so that another `mpm` run goes on from
//! the same deformed, stressed grains rather than from fresh disks: each point's mass, area and
//! side when placed, position, velocity, deformation gradient and constitutive history (the
//! inverse plastic right Cauchy-Green tensor and the equivalent plastic strain), and each
//! grain's outline (the points its vertices ride on, and their offsets), and the level the run
//! split its steps at, and the contact impulses of the last step that the next one's solve
//! starts from. A run started from the state goes on as the saving run would have, to round-off
//! (`tests/tests/saved_state.rs`); only the energy balance starts afresh (the work done before
//! is not kept).

use serde::{Deserialize, Serialize};

use super::violation::{Checker, EntryRule};

/// The deepest a soft-grain method may split a step (into `2^MAX_SPLIT_DEPTH` parts): the bound
/// of a saved state's `split_depth` (here and in [`super::state_meshes`]).
pub const MAX_SPLIT_DEPTH: u32 = 4;

/// The material points of a state's grains, in the order of its `particles` (grain `k`'s points
/// follow grain `k − 1`'s). Vectors are in-plane (2 components); tensors list their
/// components as named on each field.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatePoints {
    /// Points of each grain (one entry per particle of the state).
    pub count: Vec<u32>,
    /// Radius of the disk each grain was cut from, m (sets the grid's cell with the scene's
    /// `method.cells_per_diameter`; one entry per particle).
    pub radius0: Vec<f64>,
    /// Mass of each point, kg per metre of thickness.
    pub mass: Vec<f64>,
    /// Area of each point when placed, m².
    pub area0: Vec<f64>,
    /// Side of the square each point stood for when placed, m.
    pub side0: Vec<f64>,
    /// Position, m.
    pub position: Vec<Vec<f64>>,
    /// Velocity, m/s.
    pub velocity: Vec<Vec<f64>>,
    /// Deformation gradient `[F_xx, F_xy, F_yx, F_yy]` (plane strain: `F_zz = 1`).
    pub deformation: Vec<Vec<f64>>,
    /// Inverse plastic right Cauchy-Green tensor `[xx, xy, yy, zz]` (the identity for a point
    /// that never yielded).
    pub plastic: Vec<Vec<f64>>,
    /// Equivalent plastic strain.
    pub plastic_strain: Vec<f64>,
    /// Vertices of each grain's outline (one entry per particle; 0: the grain touches nothing).
    pub outline_count: Vec<u32>,
    /// The point each vertex rides on, numbered within its grain.
    pub outline_point: Vec<u32>,
    /// Each vertex's offset from its point's centre in the point's reference configuration, m.
    pub outline_offset: Vec<Vec<f64>>,
    /// The level the saving run split its steps at (`2^split_depth` parts, at most 4) and the
    /// steps it had done there without a failure: the new run starts its steps alike.
    #[serde(default)]
    pub split_depth: u32,
    /// Steps done at `split_depth` without a failure.
    #[serde(default)]
    pub split_calm: u32,
    /// The contacts' impulses of the saving run's last step, which the next step's contact
    /// solve starts from (its warm start): with them, and the rest above, the new run goes on
    /// as the saving run would have, to round-off.
    #[serde(default)]
    pub impulses: Vec<StateImpulse>,
}

/// One contact's impulse in a saved state ([`StatePoints::impulses`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateImpulse {
    /// The grain whose outline's vertex the contact is measured from.
    pub grain: u32,
    /// That vertex, numbered along the grain's outline.
    pub vertex: u32,
    /// The other side: a grain's index, that index plus 2³² for the second side of a reflex
    /// corner of its outline, or `−1 − w` for wall `w`.
    pub other: i64,
    /// The impulse over the step's last part in the contact's frame `[normal, tangent]`,
    /// N·s/m.
    pub impulse: Vec<f64>,
}

/// Checks the points of a state with `grains` particles in the box `[lo, hi]` (2D); `path` is
/// their field path (`start_from.state.material_points`). True when every rule holds.
pub(crate) fn check_points(c: &mut Checker, path: &str, s: &StatePoints, grains: usize, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let before = c.violations.len();
    for (name, len) in [("count", s.count.len()), ("radius0", s.radius0.len()), ("outline_count", s.outline_count.len())] {
        if len != grains {
            c.fail(format!("{path}.{name}"), format!("must have one entry per particle of the state ({grains}), got {len}"));
        }
    }
    let n: u64 = s.count.iter().map(|&k| u64::from(k)).sum();
    let arrays = [
        ("mass", s.mass.len()),
        ("area0", s.area0.len()),
        ("side0", s.side0.len()),
        ("position", s.position.len()),
        ("velocity", s.velocity.len()),
        ("deformation", s.deformation.len()),
        ("plastic", s.plastic.len()),
        ("plastic_strain", s.plastic_strain.len()),
    ];
    for (name, len) in arrays {
        if len as u64 != n {
            c.fail(format!("{path}.{name}"), format!("must have one entry per point ({n}, the sum of count), got {len}"));
        }
    }
    let vertices: u64 = s.outline_count.iter().map(|&k| u64::from(k)).sum();
    for (name, len) in [("outline_point", s.outline_point.len()), ("outline_offset", s.outline_offset.len())] {
        if len as u64 != vertices {
            c.fail(
                format!("{path}.{name}"),
                format!("must have one entry per outline vertex ({vertices}, the sum of outline_count), got {len}"),
            );
        }
    }
    if s.split_depth > MAX_SPLIT_DEPTH {
        c.fail(
            format!("{path}.split_depth"),
            format!("must be at most {MAX_SPLIT_DEPTH} (a step splits into at most {} parts), got {}", 1 << MAX_SPLIT_DEPTH, s.split_depth),
        );
    }
    if c.violations.len() > before {
        return false;
    }
    {
        let mut rule = EntryRule::new(c, format!("{path}.count"), "entries");
        for (k, &m) in s.count.iter().enumerate() {
            if m < 4 {
                rule.fail(k, format!("a grain needs at least 4 points, got {m}"));
            }
        }
    }
    {
        let mut rule = EntryRule::new(c, format!("{path}.outline_count"), "entries");
        for (k, &m) in s.outline_count.iter().enumerate() {
            if m != 0 && m < 3 {
                rule.fail(k, format!("an outline needs at least 3 vertices (or 0: none), got {m}"));
            }
        }
    }
    for (name, values) in [("radius0", &s.radius0), ("mass", &s.mass), ("area0", &s.area0), ("side0", &s.side0)] {
        let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
        for (i, v) in values.iter().enumerate() {
            if !(v.is_finite() && *v > 0.0) {
                rule.fail(i, format!("must be > 0, got {v}"));
            }
        }
    }
    {
        let mut rule = EntryRule::new(c, format!("{path}.plastic_strain"), "entries");
        for (i, v) in s.plastic_strain.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                rule.fail(i, format!("must be >= 0, got {v}"));
            }
        }
    }
    // A point may stand a little past a wall that presses its grain; a grain's size past one
    // is a corrupted state.
    let reach = s.radius0.iter().copied().fold(0.0, f64::max);
    for (name, values, want) in [
        ("position", &s.position, 2),
        ("velocity", &s.velocity, 2),
        ("deformation", &s.deformation, 4),
        ("plastic", &s.plastic, 4),
        ("outline_offset", &s.outline_offset, 2),
    ] {
        let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
        for (i, v) in values.iter().enumerate() {
            if v.len() != want {
                rule.fail(i, format!("must have {want} components, got {}", v.len()));
            } else if v.iter().any(|x| !x.is_finite()) {
                rule.fail(i, "must be finite numbers".to_string());
            } else if name == "position" && (0..2).any(|a| !(lo[a] - reach <= v[a] && v[a] <= hi[a] + reach)) {
                rule.fail(
                    i,
                    format!("[{}, {}] lies more than {reach} m (the largest radius0) outside the box [{lo:?}, {hi:?}]", v[0], v[1]),
                );
            } else if name == "deformation" && v[0] * v[3] - v[1] * v[2] <= 0.0 {
                rule.fail(i, "must have a positive determinant (an inverted point cannot go on)".to_string());
            } else if name == "plastic" && !(v[0] > 0.0 && v[0] * v[2] - v[1] * v[1] > 0.0 && v[3] > 0.0) {
                rule.fail(i, "must be positive definite".to_string());
            }
        }
    }
    {
        let mut rule = EntryRule::new(c, format!("{path}.impulses"), "entries");
        for (i, e) in s.impulses.iter().enumerate() {
            if e.grain as usize >= grains {
                rule.fail(i, format!("grain must number a particle of the state (0..{grains}), got {}", e.grain));
            } else if e.impulse.len() != 2 || e.impulse.iter().any(|x| !x.is_finite()) {
                rule.fail(i, format!("impulse must be 2 finite numbers (normal, tangent), got {:?}", e.impulse));
            }
        }
    }
    {
        let mut rule = EntryRule::new(c, format!("{path}.outline_point"), "entries");
        let mut at = 0usize;
        for (&points, &vertices) in s.count.iter().zip(&s.outline_count) {
            for i in at..at + vertices as usize {
                if s.outline_point[i] >= points {
                    rule.fail(i, format!("must number a point of its grain (0..{points}), got {}", s.outline_point[i]));
                }
            }
            at += vertices as usize;
        }
    }
    c.violations.len() == before
}
