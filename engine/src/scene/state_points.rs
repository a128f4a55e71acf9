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

use super::state_rules as rules;
pub use super::state_rules::{StateImpulse, MAX_SPLIT_DEPTH};
use super::violation::{Checker, EntryRule};

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

/// Checks the points of a state with `grains` particles in the box `[lo, hi]` (2D); `path` is
/// their field path (`start_from.state.material_points`). True when every rule holds.
pub(crate) fn check_points(c: &mut Checker, path: &str, s: &StatePoints, grains: usize, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let before = c.violations.len();
    rules::per_particle(
        c,
        path,
        &[("count", s.count.len()), ("radius0", s.radius0.len()), ("outline_count", s.outline_count.len())],
        grains,
    );
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
    rules::lengths(c, path, &arrays, rules::total(&s.count), "point (the sum of count");
    let outline = [("outline_point", s.outline_point.len()), ("outline_offset", s.outline_offset.len())];
    rules::lengths(c, path, &outline, rules::total(&s.outline_count), "outline vertex (the sum of outline_count");
    rules::split_depth(c, path, s.split_depth);
    if c.violations.len() > before {
        return false;
    }
    rules::at_least(c, path, "count", &s.count, 4, "a grain needs at least 4 points", false);
    rules::at_least(c, path, "outline_count", &s.outline_count, 3, "an outline needs at least 3 vertices", true);
    for (name, values) in [("radius0", &s.radius0), ("mass", &s.mass), ("area0", &s.area0), ("side0", &s.side0)] {
        rules::positive(c, path, name, values);
    }
    rules::plastic_strain(c, path, &s.plastic_strain);
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
            } else if let Some(wrong) = (name == "plastic").then(|| rules::plastic_tensor(v)).flatten() {
                rule.fail(i, wrong);
            }
        }
    }
    rules::impulses(c, path, &s.impulses, grains);
    rules::numbered_within(c, path, "outline_point", &s.outline_point, &s.outline_count, &s.count, "a point");
    c.violations.len() == before
}
