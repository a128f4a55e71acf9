//! The meshes of deformable grains in a saved state (`meshes`, written by a run of method
//! `fem`, `docs/scene-format.md` §14), and their check when a scene starts from one.
//!
//! A state's `particles` hold every grain as a disk of its current area, which any method can
//! start from. A `fem` run adds each grain's mesh as it left it, so that another `fem` run goes
//! on from the same deformed, stressed grains rather than from freshly meshed disks: the
//! nodes' reference positions, displacements and velocities, the elements' nodes, the boundary
//! loop, the constitutive history of each element's Gauss points (left out when no point ever
//! yielded), and — as for the material points of `mpm` ([`super::state_points`]) — the level the
//! run split its steps at and the contact impulses of its last step, which the next step's
//! solve starts from. The elements' stresses are evaluated again from the displacements and
//! histories: a run started from the state goes on as the saving run would have, to round-off
//! (`tests/tests/saved_state.rs`); only the energy balance starts afresh.

use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

use super::state_rules as rules;
use super::state_rules::StateImpulse;
use super::violation::{Checker, EntryRule};
use crate::geometry::quad::Geometry;

/// The meshes of a state's grains, in the order of its `particles` (grain `k`'s nodes,
/// elements and boundary follow grain `k − 1`'s; node numbers are within the grain).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateMeshes {
    /// Radius of the disk each grain was meshed from, m (one entry per particle).
    pub radius0: Vec<f64>,
    /// Nodes of each grain's mesh (one entry per particle).
    pub node_count: Vec<u32>,
    /// Elements of each grain's mesh (one entry per particle).
    pub element_count: Vec<u32>,
    /// Nodes of each grain's boundary loop (one entry per particle).
    pub boundary_count: Vec<u32>,
    /// Each node's reference position `[x, y]`, m.
    pub reference: Vec<Vec<f64>>,
    /// Each node's displacement from its reference position, m.
    pub displacement: Vec<Vec<f64>>,
    /// Each node's velocity, m/s.
    pub velocity: Vec<Vec<f64>>,
    /// Each element's four nodes, counter-clockwise, numbered within its grain.
    pub elements: Vec<Vec<u32>>,
    /// Each grain's boundary nodes in counter-clockwise order (a closed loop), numbered within
    /// the grain.
    pub boundary: Vec<u32>,
    /// The inverse plastic right Cauchy-Green tensor `[xx, xy, yy, zz]` at each Gauss point
    /// (four an element, in the elements' order); empty: no point ever yielded (the identity).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plastic: Vec<Vec<f64>>,
    /// The equivalent plastic strain at each Gauss point; empty with `plastic`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plastic_strain: Vec<f64>,
    /// The level the saving run split its steps at (`2^split_depth` parts, at most 4).
    #[serde(default)]
    pub split_depth: u32,
    /// Steps done at `split_depth` without a failure.
    #[serde(default)]
    pub split_calm: u32,
    /// The contacts' impulses of the saving run's last step (the next solve's warm start); a
    /// contact's `vertex` is its boundary node's place along the grain's boundary loop.
    #[serde(default)]
    pub impulses: Vec<StateImpulse>,
}

/// Gauss points of an element.
pub const GAUSS_POINTS: usize = 4;

type V2 = Vector2<f64>;

/// Checks the meshes of a state with `grains` particles in the box `[lo, hi]` (2D); `path` is
/// their field path (`start_from.state.meshes`). True when every rule holds: the arrays agree
/// with the counts, every node number is its grain's, every number is finite, every element is
/// counter-clockwise and not degenerate at its reference positions and not inverted at its
/// current ones (at its Gauss points), the histories are admissible.
pub(crate) fn check_meshes(c: &mut Checker, path: &str, s: &StateMeshes, grains: usize, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let before = c.violations.len();
    let counts = [
        ("radius0", s.radius0.len()),
        ("node_count", s.node_count.len()),
        ("element_count", s.element_count.len()),
        ("boundary_count", s.boundary_count.len()),
    ];
    rules::per_particle(c, path, &counts, grains);
    if c.violations.len() > before {
        return false;
    }
    let nodes = [("reference", s.reference.len()), ("displacement", s.displacement.len()), ("velocity", s.velocity.len())];
    rules::lengths(c, path, &nodes, rules::total(&s.node_count), "node (the sum of node_count");
    let elements = rules::total(&s.element_count);
    rules::lengths(c, path, &[("elements", s.elements.len())], elements, "element (the sum of element_count");
    rules::lengths(c, path, &[("boundary", s.boundary.len())], rules::total(&s.boundary_count), "boundary node (the sum of boundary_count");
    let points = elements * GAUSS_POINTS as u64;
    if s.plastic.len() != s.plastic_strain.len() || !(s.plastic.is_empty() || s.plastic.len() as u64 == points) {
        let field = if s.plastic.is_empty() { "plastic_strain" } else { "plastic" };
        c.fail(
            format!("{path}.{field}"),
            format!(
                "plastic and plastic_strain must both be empty or have {GAUSS_POINTS} entries per element ({points}), got {} and {}",
                s.plastic.len(),
                s.plastic_strain.len()
            ),
        );
    }
    rules::split_depth(c, path, s.split_depth);
    if c.violations.len() > before {
        return false;
    }
    rules::at_least(c, path, "node_count", &s.node_count, 4, "a grain's mesh needs at least 4 nodes", false);
    rules::at_least(c, path, "element_count", &s.element_count, 1, "a grain's mesh needs at least 1 element", false);
    rules::at_least(c, path, "boundary_count", &s.boundary_count, 3, "a grain's mesh needs at least 3 boundary nodes", false);
    rules::positive(c, path, "radius0", &s.radius0);
    let vectors_ok = check_node_vectors(c, path, s, lo, hi);
    check_elements(c, path, s, vectors_ok);
    rules::numbered_within(c, path, "boundary", &s.boundary, &s.boundary_count, &s.node_count, "a node");
    {
        let mut rule = EntryRule::new(c, format!("{path}.plastic"), "entries");
        for (i, v) in s.plastic.iter().enumerate() {
            if v.len() != 4 || v.iter().any(|x| !x.is_finite()) {
                rule.fail(i, format!("must be 4 finite numbers [xx, xy, yy, zz], got {v:?}"));
            } else if let Some(wrong) = rules::plastic_tensor(v) {
                rule.fail(i, wrong);
            }
        }
    }
    rules::plastic_strain(c, path, &s.plastic_strain);
    rules::impulses(c, path, &s.impulses, grains);
    c.violations.len() == before
}

/// Checks the nodes' positions, displacements and velocities (2 finite components each; no
/// node more than the largest grain's radius outside the box `[lo, hi]`); true when all are
/// numbers the elements' checks can use.
fn check_node_vectors(c: &mut Checker, path: &str, s: &StateMeshes, lo: [f64; 2], hi: [f64; 2]) -> bool {
    let reach = s.radius0.iter().copied().filter(|r| r.is_finite()).fold(0.0, f64::max);
    let mut vectors_ok = true;
    for (name, values) in [("reference", &s.reference), ("displacement", &s.displacement), ("velocity", &s.velocity)] {
        let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
        for (i, v) in values.iter().enumerate() {
            if v.len() != 2 {
                rule.fail(i, format!("must have 2 components, got {}", v.len()));
                vectors_ok = false;
            } else if v.iter().any(|x| !x.is_finite()) {
                rule.fail(i, "must be finite numbers".to_string());
                vectors_ok = false;
            } else if name == "displacement" && s.reference[i].len() == 2 {
                // A node may stand a little past a wall that presses its grain; a grain's size
                // past one is a corrupted state.
                let x = [s.reference[i][0] + v[0], s.reference[i][1] + v[1]];
                if (0..2).any(|a| !(lo[a] - reach <= x[a] && x[a] <= hi[a] + reach)) {
                    rule.fail(
                        i,
                        format!(
                            "takes its node to [{}, {}], more than {reach} m (the largest radius0) outside the box [{lo:?}, {hi:?}]",
                            x[0], x[1]
                        ),
                    );
                }
            }
        }
    }
    vectors_ok
}

/// Checks each element's nodes, then — where they are its grain's and the positions finite
/// (`vectors_ok`) — its shape at its reference and current positions.
fn check_elements(c: &mut Checker, path: &str, s: &StateMeshes, vectors_ok: bool) {
    let mut rule = EntryRule::new(c, format!("{path}.elements"), "entries");
    let (mut node, mut element) = (0usize, 0usize);
    for (&n, &e) in s.node_count.iter().zip(&s.element_count) {
        let at = |k: u32, moved: bool| {
            let i = node + k as usize;
            let (x, u) = (&s.reference[i], &s.displacement[i]);
            if moved {
                V2::new(x[0] + u[0], x[1] + u[1])
            } else {
                V2::new(x[0], x[1])
            }
        };
        for i in element..element + e as usize {
            let q = &s.elements[i];
            if q.len() != 4 {
                rule.fail(i, format!("must list 4 nodes, got {}", q.len()));
            } else if let Some(bad) = q.iter().find(|&&k| k >= n) {
                rule.fail(i, format!("must number nodes of its grain (0..{n}), got {bad}"));
            } else if vectors_ok {
                let corners = |moved: bool| [at(q[0], moved), at(q[1], moved), at(q[2], moved), at(q[3], moved)];
                if Geometry::new(&corners(false)).is_none() {
                    rule.fail(i, "is degenerate, or not counter-clockwise, at its reference positions".to_string());
                } else if Geometry::new(&corners(true)).is_none() {
                    rule.fail(i, "is inverted at its current positions (det F <= 0 at a Gauss point): it cannot go on".to_string());
                }
            }
        }
        node += n as usize;
        element += e as usize;
    }
}
