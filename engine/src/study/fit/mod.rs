//! Laws fitted over a study's runs: a study that names a `fit` gets, besides each run's
//! measure, the constants of a published law fitted to all its succeeded runs' results, their
//! standard errors and their difference from the published values, and the panels of its chart
//! (the runs' points against the fitted and the published law). One law per file, listed in
//! [`LAWS`].

pub mod agglomerate_rates;
pub mod granule_growth;
pub mod granule_strength;
pub mod wet_rheology;

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// A law a study can fit.
pub trait FitLaw: Sync {
    /// Its name in a study file (`wet_rheology`).
    fn name(&self) -> &'static str;
    /// The law, in one line.
    fn formula(&self) -> &'static str;
    /// Fits the law to the runs' results; the error says what the runs lack.
    fn fit(&self, runs: &[RunResult<'_>]) -> Result<FitReport, String>;
}

/// The laws a study can fit.
pub static LAWS: &[&dyn FitLaw] = &[
    &wet_rheology::WetRheology,
    &granule_strength::GranuleStrength,
    &agglomerate_rates::AgglomerateRates,
    &granule_growth::GranuleGrowthLaw,
];

/// The law of that name.
pub fn law(name: &str) -> Option<&'static dyn FitLaw> {
    LAWS.iter().copied().find(|l| l.name() == name)
}

/// The names of the laws, for error messages.
pub fn names() -> Vec<&'static str> {
    LAWS.iter().map(|l| l.name()).collect()
}

/// What a study file asks to fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSpec {
    /// The law's name ([`LAWS`]).
    pub law: String,
    /// The series whose runs are fitted, by label (default: every series): a study may also
    /// hold runs that check something else (the grains' friction, the size) the law does not
    /// take as a variable.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub series: Vec<String>,
}

impl FitSpec {
    /// True if the runs of the series `label` are fitted.
    pub fn fits(&self, label: &str) -> bool {
        self.series.is_empty() || self.series.iter().any(|s| s == label)
    }
}

/// One succeeded run's experiment results.
#[derive(Debug, Clone, Copy)]
pub struct RunResult<'a> {
    /// Its position in the study.
    pub index: usize,
    /// Its results (the job's `result`, an `ExperimentResult` as JSON).
    pub result: &'a Value,
}

/// A fitted law.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// The law's name.
    pub law: String,
    /// The law, in one line.
    pub formula: String,
    /// Where the published constants come from.
    pub source: String,
    /// The runs fitted, by position in the study.
    pub runs: Vec<usize>,
    /// The fitted constants.
    pub constants: Vec<Constant>,
    /// Root mean square of the (weighted) residuals at the fit.
    pub rms: f64,
    /// What the chart draws.
    pub panels: Vec<Panel>,
    /// Remarks on the fit: what the runs could not determine, runs left out and why.
    #[serde(default)]
    pub notes: Vec<String>,
}

/// One fitted constant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Constant {
    /// Its name (`alpha`, `mu_c(xi=0.52)`).
    pub name: String,
    /// Its fitted value (`None` when the runs do not determine it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// Its standard error from the fit's covariance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std_error: Option<f64>,
    /// The published value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub published: Option<f64>,
    /// `(value − published) / published`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub difference: Option<f64>,
}

impl Constant {
    pub(crate) fn new(name: impl Into<String>, value: Option<f64>, std_error: Option<f64>, published: Option<f64>) -> Self {
        let difference = match (value, published) {
            (Some(v), Some(p)) if p != 0.0 => Some((v - p) / p),
            _ => None,
        };
        Constant { name: name.into(), value, std_error, published, difference }
    }
}

/// A law's line on a chart: its label and its points `[x, y]`.
pub type Curve = (String, Vec<[f64; 2]>);

/// One panel of a fit's chart: the runs' points and the laws' curves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Panel {
    /// The x axis's name.
    pub x: String,
    /// The y axis's name.
    pub y: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    #[serde(default)]
    pub log_y: bool,
    /// The runs: `[run, x, y]`.
    pub points: Vec<(usize, f64, f64)>,
    /// The laws: a label and its line.
    pub curves: Vec<Curve>,
}

/// The notes on fitted constants the runs do not determine: a standard error larger than the
/// value, or none at all (the fit's normal matrix is singular).
pub(crate) fn undetermined(constants: &[Constant]) -> Vec<String> {
    constants
        .iter()
        .filter_map(|c| match (c.value, c.std_error) {
            (Some(v), Some(e)) if e > v.abs() => {
                Some(format!("{} not determined by the runs: its standard error ({e:.3e}) exceeds its value ({v:.3e})", c.name))
            }
            (Some(v), None) => Some(format!(
                "{} not determined by the runs: no standard error (the fit's normal matrix is singular; value {v:.3e})",
                c.name
            )),
            _ => None,
        })
        .collect()
}

/// The field at `path` (dots between names) of a result, as a number.
pub(crate) fn number(result: &Value, path: &str) -> Option<f64> {
    path.split('.').try_fold(result, |v, k| v.get(k))?.as_f64().filter(|x| x.is_finite())
}

/// `n` points spread evenly in log between `lo` and `hi`.
pub(crate) fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let (a, b) = (lo.ln(), hi.ln());
    (0..n).map(|k| (a + (b - a) * k as f64 / (n.max(2) - 1) as f64).exp()).collect()
}
