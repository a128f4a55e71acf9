//! The contacts of a sample and what is counted from them: one interaction ([`ContactRecord`]),
//! the rattlers, the coordination number with and without them.

use crate::math::{Real, Vec3};

/// One interaction at sampling time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactRecord {
    /// First body (a particle).
    pub i: u32,
    /// Second particle, or `None` for a wall contact.
    pub j: Option<u32>,
    /// Force on i, N.
    pub force: Vec3,
    /// Branch vector, m: `r_i - r_j` (minimum image) for a pair; from the contact point to the
    /// centre of i for a wall.
    pub branch: Vec3,
    /// The bodies overlap (a contact in the strict sense).
    pub touching: bool,
    /// A cohesive bond (capillary bridge) joins them.
    pub bonded: bool,
}

impl ContactRecord {
    /// The contact counts in the coordination: touching with a non-zero force, or bonded.
    pub fn bears_load(&self) -> bool {
        (self.touching && self.force.norm_squared() > 0.0) || self.bonded
    }
}

/// Contacts a particle needs not to be a rattler, in `dim` dimensions, with or without friction.
pub fn rattler_threshold(dim: usize, frictional: bool) -> usize {
    if frictional {
        2
    } else {
        dim + 1
    }
}

/// Returns (Z, Z without rattlers). A contact counts if it carries force (touching with a
/// non-zero force, or a cohesive bond). Rattlers, particles with fewer than `threshold` contacts
/// (walls included), are removed recursively (docs/references.md §B); Z counts particle-particle
/// contacts only: Z = 2 N_c / N.
pub fn coordination(n: usize, threshold: usize, contacts: &[ContactRecord]) -> (Real, Real) {
    if n == 0 {
        return (0.0, 0.0);
    }
    let pairs = contacts.iter().filter(|c| c.bears_load() && c.j.is_some()).count();
    let z = 2.0 * pairs as Real / n as Real;
    let rattler = rattlers(n, threshold, contacts);
    let kept = rattler.iter().filter(|r| !**r).count();
    let backbone_pairs = contacts
        .iter()
        .filter(|c| c.bears_load())
        .filter_map(|c| c.j.map(|j| (c.i, j)))
        .filter(|&(i, j)| !rattler[i as usize] && !rattler[j as usize])
        .count();
    let z_nr = if kept > 0 { 2.0 * backbone_pairs as Real / kept as Real } else { 0.0 };
    (z, z_nr)
}

/// The rattlers among `n` particles: removed, recursively, while they have fewer than
/// `threshold` force-bearing contacts ([`ContactRecord::bears_load`]; wall contacts count) with
/// particles not yet removed. `true` marks a rattler; the others form the backbone.
pub fn rattlers(n: usize, threshold: usize, contacts: &[ContactRecord]) -> Vec<bool> {
    let mut count = vec![0u32; n];
    let mut adjacency: Vec<Vec<u32>> = vec![Vec::new(); n];
    for c in contacts.iter().filter(|c| c.bears_load()) {
        count[c.i as usize] += 1;
        if let Some(j) = c.j {
            count[j as usize] += 1;
            adjacency[c.i as usize].push(j);
            adjacency[j as usize].push(c.i);
        }
    }
    let need = threshold as u32;
    let mut removed = vec![false; n];
    let mut stack: Vec<usize> = (0..n).filter(|&i| count[i] < need).collect();
    while let Some(i) = stack.pop() {
        if removed[i] {
            continue;
        }
        removed[i] = true;
        for &j in &adjacency[i] {
            let j = j as usize;
            if !removed[j] {
                count[j] -= 1;
                if count[j] < need {
                    stack.push(j);
                }
            }
        }
    }
    removed
}
