//! One broken rule of a scene, with the path of the field that breaks it.

use serde::{Deserialize, Serialize};

/// A rule broken by a field, e.g. `materials.glass.friction: must be >= 0, got -0.2`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Violation {
    /// Dotted path of the field (`particles[0].count`), or `""` for the whole document.
    pub field: String,
    /// The rule, stated so that it says what to change.
    pub rule: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.field.is_empty() {
            write!(f, "{}", self.rule)
        } else {
            write!(f, "{}: {}", self.field, self.rule)
        }
    }
}

/// Joins violations with `; ` for one-line messages.
pub fn format_violations(v: &[Violation]) -> String {
    v.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
}

/// Collects violations while a scene is checked (by the scene, then by its method).
#[derive(Debug, Default)]
pub struct Checker {
    /// The rules broken so far, in the order found.
    pub violations: Vec<Violation>,
}

impl Checker {
    /// Records that `field` breaks `rule`.
    pub fn fail(&mut self, field: impl Into<String>, rule: impl Into<String>) {
        self.violations.push(Violation { field: field.into(), rule: rule.into() });
    }

    /// Requires a finite value > 0.
    pub fn positive(&mut self, field: &str, v: f64) -> bool {
        if !(v.is_finite() && v > 0.0) {
            self.fail(field, format!("must be > 0, got {v}"));
            return false;
        }
        true
    }

    /// Requires a finite value >= 0.
    pub fn non_negative(&mut self, field: &str, v: f64) -> bool {
        if !(v.is_finite() && v >= 0.0) {
            self.fail(field, format!("must be >= 0, got {v}"));
            return false;
        }
        true
    }

    /// Requires `lo <= v <= hi` (finite).
    pub fn within(&mut self, field: &str, v: f64, lo: f64, hi: f64) -> bool {
        if !(v.is_finite() && v >= lo && v <= hi) {
            self.fail(field, format!("must be between {lo} and {hi}, got {v}"));
            return false;
        }
        true
    }

    /// Requires a vector of length `dim` with finite components.
    pub fn vector(&mut self, field: &str, v: &[f64], dim: usize) -> bool {
        if v.len() != dim {
            self.fail(field, format!("must have {dim} components (the scene's dimension), got {}", v.len()));
            return false;
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            self.fail(format!("{field}[{i}]"), "must be a finite number");
            return false;
        }
        true
    }
}

/// Violations reported per array of a saved state before the rest are summarised.
const MAX_ENTRY_VIOLATIONS: usize = 5;

/// Reports the first violations of a rule over the entries of an array (a saved state's
/// particles or points), then how many more there were: a state of a million bad entries gives
/// a readable list.
pub(crate) struct EntryRule<'a> {
    field: String,
    what: &'static str,
    seen: usize,
    c: &'a mut Checker,
}

impl<'a> EntryRule<'a> {
    /// A rule over the array at `field`, whose entries are `what` (plural: "particles").
    pub(crate) fn new(c: &'a mut Checker, field: String, what: &'static str) -> Self {
        Self { field, what, seen: 0, c }
    }

    /// Entry `index` breaks the rule.
    pub(crate) fn fail(&mut self, index: usize, rule: String) {
        self.seen += 1;
        if self.seen <= MAX_ENTRY_VIOLATIONS {
            self.c.fail(format!("{}[{index}]", self.field), rule);
        }
    }
}

impl Drop for EntryRule<'_> {
    fn drop(&mut self) {
        if self.seen > MAX_ENTRY_VIOLATIONS {
            self.c.fail(self.field.clone(), format!("{} more {} break a rule", self.seen - MAX_ENTRY_VIOLATIONS, self.what));
        }
    }
}
