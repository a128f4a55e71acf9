//! The rules a saved state of deformable grains obeys whatever the method that saved it: the
//! checks [`super::state_points`] (MPM's material points) and [`super::state_meshes`] (FEM's
//! meshes) share, and the two types they share. Each check takes the field path of the arrays it checks and reports every broken
//! entry through the [`Checker`] (a few per array, then a count).

use serde::{Deserialize, Serialize};

use super::violation::{Checker, EntryRule};

/// The deepest a soft-grain method may split a step (into `2^MAX_SPLIT_DEPTH` parts): the bound
/// of a saved state's `split_depth` ([`super::state_points`] and [`super::state_meshes`]).
pub const MAX_SPLIT_DEPTH: u32 = 4;

/// One contact's impulse in a saved state ([`super::state_points::StatePoints::impulses`], [`super::state_meshes::StateMeshes::impulses`]).
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

/// Each array of `fields` (name, length) has one entry per particle of the state (`grains`).
pub(super) fn per_particle(c: &mut Checker, path: &str, fields: &[(&str, usize)], grains: usize) {
    for &(name, len) in fields {
        if len != grains {
            c.fail(format!("{path}.{name}"), format!("must have one entry per particle of the state ({grains}), got {len}"));
        }
    }
}

/// The sum of per-grain counts (in `u64`: the counts come from the user).
pub(super) fn total(counts: &[u32]) -> u64 {
    counts.iter().map(|&k| u64::from(k)).sum()
}

/// Each array of `fields` (name, length) has `want` entries, one per `what` (`what` names the
/// entry and where `want` comes from).
pub(super) fn lengths(c: &mut Checker, path: &str, fields: &[(&str, usize)], want: u64, what: &str) {
    for &(name, len) in fields {
        if len as u64 != want {
            c.fail(format!("{path}.{name}"), format!("must have one entry per {what}, {want}), got {len}"));
        }
    }
}

/// The level a state's run split its steps at is one the methods can take up.
pub(super) fn split_depth(c: &mut Checker, path: &str, depth: u32) {
    if depth > MAX_SPLIT_DEPTH {
        c.fail(
            format!("{path}.split_depth"),
            format!("must be at most {MAX_SPLIT_DEPTH} (a step splits into at most {} parts), got {depth}", 1 << MAX_SPLIT_DEPTH),
        );
    }
}

/// Every per-grain count of `name` is at least `least`, or 0 where `or_none`; `needs` says
/// who needs how many of what, for the message ("a grain needs at least 4 points").
pub(super) fn at_least(c: &mut Checker, path: &str, name: &str, counts: &[u32], least: u32, needs: &str, or_none: bool) {
    let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
    for (k, &m) in counts.iter().enumerate() {
        if m < least && !(or_none && m == 0) {
            let none = if or_none { " (or 0: none)" } else { "" };
            rule.fail(k, format!("{needs}{none}, got {m}"));
        }
    }
}

/// Every entry of `name` is a finite number above 0.
pub(super) fn positive(c: &mut Checker, path: &str, name: &str, values: &[f64]) {
    let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
    for (i, v) in values.iter().enumerate() {
        if !(v.is_finite() && *v > 0.0) {
            rule.fail(i, format!("must be > 0, got {v}"));
        }
    }
}

/// Every equivalent plastic strain is a finite number, not negative.
pub(super) fn plastic_strain(c: &mut Checker, path: &str, values: &[f64]) {
    let mut rule = EntryRule::new(c, format!("{path}.plastic_strain"), "entries");
    for (i, v) in values.iter().enumerate() {
        if !(v.is_finite() && *v >= 0.0) {
            rule.fail(i, format!("must be >= 0, got {v}"));
        }
    }
}

/// What is wrong with an inverse plastic right Cauchy-Green tensor `[xx, xy, yy, zz]` of 4
/// finite numbers, if anything: it must be positive definite.
pub(super) fn plastic_tensor(v: &[f64]) -> Option<String> {
    (!(v[0] > 0.0 && v[0] * v[2] - v[1] * v[1] > 0.0 && v[3] > 0.0)).then(|| "must be positive definite".to_string())
}

/// Every contact impulse names a grain of the state and holds two finite numbers.
pub(super) fn impulses(c: &mut Checker, path: &str, impulses: &[StateImpulse], grains: usize) {
    let mut rule = EntryRule::new(c, format!("{path}.impulses"), "entries");
    for (i, e) in impulses.iter().enumerate() {
        if e.grain as usize >= grains {
            rule.fail(i, format!("grain must number a particle of the state (0..{grains}), got {}", e.grain));
        } else if e.impulse.len() != 2 || e.impulse.iter().any(|x| !x.is_finite()) {
            rule.fail(i, format!("impulse must be 2 finite numbers (normal, tangent), got {:?}", e.impulse));
        }
    }
}

/// Every entry of `name` (grain by grain, `per_grain[k]` of them for grain `k`) numbers one of
/// its grain's `of[k]` items (`what`: the items, for the message).
pub(super) fn numbered_within(c: &mut Checker, path: &str, name: &str, values: &[u32], per_grain: &[u32], of: &[u32], what: &str) {
    let mut rule = EntryRule::new(c, format!("{path}.{name}"), "entries");
    let mut at = 0usize;
    for (&n, &m) in of.iter().zip(per_grain) {
        for (i, &v) in values.iter().enumerate().skip(at).take(m as usize) {
            if v >= n {
                rule.fail(i, format!("must number {what} of its grain (0..{n}), got {v}"));
            }
        }
        at += m as usize;
    }
}
