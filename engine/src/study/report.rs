//! A study's report: each run's cost and error against the reference, the Pareto front of
//! cost against error, and a search's limit with the theory it is compared with.

use serde::{Deserialize, Serialize};

use super::search::{FailureMode, Limit};

/// What a run cost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Cost {
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// CPU seconds of the job's threads.
    pub cpu_seconds: f64,
    /// Steps.
    pub steps: u64,
    /// Contact-solver sweeps (contact dynamics; 0 for DEM).
    pub solver_iterations: u64,
}

/// How one run of a study ended and what it measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointReport {
    /// Position in the study.
    pub index: usize,
    /// Its series.
    pub series: String,
    /// The swept values, as a label.
    pub label: String,
    /// The value of the knob for a search's probe.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// The job that ran it.
    pub job_id: i64,
    /// queued, running, succeeded, failed or cancelled.
    pub state: String,
    /// What it cost (so far).
    pub cost: Cost,
    /// The measured value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured: Option<f64>,
    /// The reference of this run (the study's, or its formula's value for this run).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<f64>,
    /// `|measured − reference|`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<f64>,
    /// `|measured − reference| / |reference|` (none when the reference is 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_error: Option<f64>,
    /// How the run failed, for a failed run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<FailureMode>,
    /// Why no value was measured, or the run's error message.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// On the Pareto front of cost (CPU seconds) against error.
    #[serde(default)]
    pub pareto: bool,
}

/// The theory a stability limit is compared with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Theory {
    /// The predicted limit, in the knob's units.
    pub value: f64,
    /// What it is (`2/ω0 of the stiffest, lightest contact`).
    pub what: String,
    /// Measured limit (the stable bound) / theory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio: Option<f64>,
}

/// A study's report, recomputed from its runs whenever one of them changes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyReport {
    /// What was measured (`mean mu from 50% of the run (shear)`), or the knob of a search.
    pub measure: String,
    /// The reference value, once known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<f64>,
    /// Where the reference comes from.
    pub reference_source: String,
    /// Each series' label and the parameters it sweeps (the order of a point's label).
    #[serde(default)]
    pub swept: Vec<(String, Vec<String>)>,
    /// The runs, in the order of the study.
    pub points: Vec<PointReport>,
    /// A search's result.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit: Option<Limit>,
    /// A search's theory, where there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theory: Option<Theory>,
    /// The law fitted over the succeeded runs, for a study with a `fit`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<super::fit::FitReport>,
    /// Why there is no fit (yet): too few runs, or what they lack.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_note: Option<String>,
}

impl StudyReport {
    /// Fills the errors against `reference` and marks the Pareto front: the succeeded runs
    /// that no other run beats on both CPU time and error.
    pub fn score(&mut self, reference: Option<f64>) {
        self.reference = reference;
        self.score_each(|_| reference);
    }

    /// [`StudyReport::score`] with a reference per run (a formula of its parameters).
    pub fn score_each(&mut self, reference: impl Fn(&PointReport) -> Option<f64>) {
        for p in &mut self.points {
            p.reference = reference(p);
            p.error = None;
            p.relative_error = None;
            p.pareto = false;
            if let (Some(m), Some(r)) = (p.measured, p.reference) {
                let e = (m - r).abs();
                p.error = Some(e);
                p.relative_error = (r != 0.0).then(|| e / r.abs());
            }
        }
        let scored: Vec<(usize, f64, f64)> = self
            .points
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.error.filter(|_| p.state == "succeeded").map(|e| (i, p.cost.cpu_seconds, e)))
            .collect();
        for &(i, c, e) in &scored {
            let beaten = scored.iter().any(|&(j, c2, e2)| j != i && c2 <= c && e2 <= e && (c2 < c || e2 < e));
            self.points[i].pareto = !beaten;
        }
    }

    /// The finest run of a series: its succeeded run with the largest CPU time.
    pub fn finest(&self, series: &str) -> Option<&PointReport> {
        self.points
            .iter()
            .filter(|p| p.series == series && p.state == "succeeded" && p.measured.is_some())
            .max_by(|a, b| a.cost.cpu_seconds.total_cmp(&b.cost.cpu_seconds))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(index: usize, series: &str, cpu: f64, measured: Option<f64>, state: &str) -> PointReport {
        PointReport {
            index,
            series: series.into(),
            label: index.to_string(),
            value: None,
            job_id: index as i64 + 1,
            state: state.into(),
            cost: Cost { cpu_seconds: cpu, wall_seconds: cpu, steps: 10, solver_iterations: 0 },
            measured,
            reference: None,
            error: None,
            relative_error: None,
            failure: None,
            note: None,
            pareto: false,
        }
    }

    #[test]
    fn errors_and_the_pareto_front_are_those_of_the_definition() {
        let mut r = StudyReport {
            measure: "restitution".into(),
            reference: None,
            reference_source: "value".into(),
            swept: Vec::new(),
            points: vec![
                point(0, "A", 1.0, Some(0.60), "succeeded"), // error 0.10: cheapest, front
                point(1, "A", 2.0, Some(0.68), "succeeded"), // error 0.02: front
                point(2, "B", 3.0, Some(0.75), "succeeded"), // error 0.05: beaten by 1
                point(3, "B", 4.0, Some(0.70), "succeeded"), // error 0: front
                point(4, "B", 0.5, None, "failed"),          // no value: never on the front
            ],
            limit: None,
            theory: None,
            fit: None,
            fit_note: None,
        };
        r.score(Some(0.7));
        let err: Vec<Option<f64>> = r.points.iter().map(|p| p.error.map(|e| (e * 1e6).round() / 1e6)).collect();
        assert_eq!(err, vec![Some(0.1), Some(0.02), Some(0.05), Some(0.0), None]);
        assert!((r.points[0].relative_error.unwrap_or(0.0) - 0.1 / 0.7).abs() < 1e-12);
        assert_eq!(r.points.iter().map(|p| p.pareto).collect::<Vec<_>>(), vec![true, true, false, true, false]);
        assert_eq!(r.finest("B").map(|p| p.index), Some(3));
        assert_eq!(r.finest("C"), None);
        r.score(Some(0.0));
        assert_eq!(r.points[0].relative_error, None);
    }
}
