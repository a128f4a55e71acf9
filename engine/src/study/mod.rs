//! Studies: speed against accuracy (docs/physics.md §10.1).
//!
//! A study is a base scene, series of runs that set and sweep its parameters (the method, the
//! time step or its fraction of the collision time, the solver's tolerance and budget, the
//! contact stiffness, the particle count), a measured quantity ([`measure`]) and a reference
//! to measure the error against (a value, the scene's own restitution, a chosen job, or the
//! finest run of a series) — or a stability search on one knob ([`search`]). The engine
//! expands a study into the scenes of its runs and turns their outcomes into a report
//! ([`report`]); the service runs the scenes as jobs and stores both. The format is
//! documented in `docs/studies.md`.

pub mod fit;
pub mod formula;
pub mod measure;
pub mod paths;
pub mod report;
pub mod search;
pub mod theory;

use serde::{Deserialize, Serialize};
use serde_json::Value;

pub use measure::MeasureSpec;
pub use search::SearchSpec;

use crate::scene::Violation;

/// Most runs one study may expand into.
pub const MAX_POINTS: usize = 200;

/// A study file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    /// Name (default: the scene's, with "study").
    #[serde(default)]
    pub name: Option<String>,
    /// The base scene (docs/scene-format.md).
    pub scene: Value,
    /// Series of runs (one line or group of points on the chart each); not with `search`.
    #[serde(default)]
    pub series: Vec<SeriesSpec>,
    /// What is measured on each run (sweeps only).
    #[serde(default)]
    pub measure: Option<MeasureSpec>,
    /// What the measure is compared with (sweeps only).
    #[serde(default)]
    pub reference: Option<ReferenceSpec>,
    /// A stability search instead of series.
    #[serde(default)]
    pub search: Option<SearchSpec>,
    /// A law fitted over the succeeded runs' results ([`fit`]); with it the reference may be
    /// left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<fit::FitSpec>,
}

/// One series: parameters set for all its runs, and swept ones (every combination is a run).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesSpec {
    /// Legend of the series (`DEM`, `CD`).
    pub label: String,
    /// Parameters set for every run: path → value (`{"method": "cd"}`).
    #[serde(default)]
    pub set: serde_json::Map<String, Value>,
    /// Swept parameters, in order; every combination of their values is a run.
    #[serde(default)]
    pub sweep: Vec<SweepSpec>,
    /// What is measured on this series' runs instead of the study's `measure`: two models
    /// whose samples scale the same quantity differently (each model's wall stress at its own
    /// characteristic stress).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measure: Option<MeasureSpec>,
}

/// One swept parameter.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Path into the scene (`method.time_step_fraction`).
    pub parameter: String,
    /// Its values, one run each (combined with the other sweeps of the series).
    pub values: Vec<Value>,
}

/// The reference of a study: exactly one field.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// An analytic value, in the units of the measure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// A formula of the swept parameters, each named by its last field (`k_n`,
    /// `time_step_fraction`), evaluated for each run ([`formula`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub formula: Option<String>,
    /// `restitution`: the restitution coefficient of the scene's first material (what a
    /// binary collision should give; docs/physics.md §2.2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub analytic: Option<String>,
    /// A job of the service, measured the same way.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub job: Option<i64>,
    /// The finest run of the series with this label: the succeeded run that cost the most CPU
    /// time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finest: Option<String>,
}

/// One run of a study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// Position in the study, from 0.
    pub index: usize,
    /// Label of its series.
    pub series: String,
    /// Swept parameters and their values.
    pub params: Vec<(String, Value)>,
    /// The numeric parameters the series sets and sweeps, by their last field: the variables of
    /// a reference formula.
    pub vars: std::collections::BTreeMap<String, f64>,
    /// The scene to run.
    pub scene: Value,
    /// Its series' own measure, if it has one (else the study's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measure: Option<MeasureSpec>,
}

impl Point {
    /// The swept values as a chart label (`0.02`, `1e5, 0.01`).
    pub fn label(&self) -> String {
        self.params.iter().map(|(_, v)| short(v)).collect::<Vec<_>>().join(", ")
    }
}

/// A JSON value written briefly (numbers in the shortest of plain and scientific form).
pub fn short(v: &Value) -> String {
    match v {
        Value::Number(n) => match n.as_f64() {
            Some(x) if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-2) => format!("{x:e}"),
            Some(x) => format!("{x}"),
            None => n.to_string(),
        },
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A checked study.
#[derive(Debug, Clone, PartialEq)]
pub enum Study {
    /// Series of runs measured against a reference.
    Sweep {
        /// The runs.
        points: Vec<Point>,
        /// What is measured.
        measure: MeasureSpec,
        /// The reference.
        reference: ReferenceSpec,
    },
    /// A stability search.
    Search {
        /// The knob and range.
        search: SearchSpec,
        /// The base scene (each probe sets the knob in it).
        scene: Value,
    },
}

/// Parses and checks a study file; every broken rule comes back with its path.
pub fn parse_study(json: &str) -> Result<(StudySpec, Study), Vec<Violation>> {
    let spec = parse_spec(json)?;
    let study = check(&spec)?;
    Ok((spec, study))
}

/// Parses and expands a study file that was checked before (a stored study): its runs'
/// scenes are not validated again, which for many runs of a large scene is the costly part.
pub fn parse_checked_study(json: &str) -> Result<(StudySpec, Study), Vec<Violation>> {
    let spec = parse_spec(json)?;
    let study = build(&spec, false)?;
    Ok((spec, study))
}

fn parse_spec(json: &str) -> Result<StudySpec, Vec<Violation>> {
    let de = &mut serde_json::Deserializer::from_str(json);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." || path == "?" { String::new() } else { path };
        vec![Violation { field, rule: e.into_inner().to_string() }]
    })
}

/// The scene of a search's probe at `value`.
pub fn probe_scene(scene: &Value, search: &SearchSpec, value: f64) -> Result<Value, String> {
    let mut s = scene.clone();
    let v = if search.integer { Value::from(value.round() as i64) } else { Value::from(value) };
    paths::set(&mut s, &search.parameter, v)?;
    Ok(s)
}

/// Checks a study: its shape, each run's scene (validated as a submitted scene would be, the
/// error naming the series and the values), the measure and the reference.
pub fn check(spec: &StudySpec) -> Result<Study, Vec<Violation>> {
    build(spec, true)
}

/// Expands a study, validating each run's scene when `validate_scenes`.
fn build(spec: &StudySpec, validate_scenes: bool) -> Result<Study, Vec<Violation>> {
    let mut v = Vec::new();
    check_shape(spec, &mut v);
    if let Some(s) = &spec.search {
        return build_search(spec, s, validate_scenes, v);
    }
    let mut points = Vec::new();
    let mut labels = std::collections::BTreeSet::new();
    for (i, series) in spec.series.iter().enumerate() {
        if !expand_series(spec, i, series, &mut labels, validate_scenes, &mut points, &mut v) {
            return Err(v);
        }
    }
    let measure = check_measure(spec, &mut v);
    let reference = check_reference(spec, &points, &mut v);
    check_fit(spec, &mut v);
    if v.is_empty() {
        Ok(Study::Sweep { points, measure, reference })
    } else {
        Err(v)
    }
}

/// Checks the study's name, that its scene is an object, and that it has series or a search.
fn check_shape(spec: &StudySpec, v: &mut Vec<Violation>) {
    if let Some(n) = &spec.name {
        if n.trim().is_empty() || n.chars().count() > 200 {
            fail(v, "name".into(), "must be 1 to 200 characters".into());
        }
    }
    if !spec.scene.is_object() {
        fail(v, "scene".into(), "must be a scene (a JSON object)".into());
    }
    match (&spec.search, spec.series.is_empty()) {
        (Some(_), false) => fail(v, "search".into(), "a study has either series or a search, not both".into()),
        (None, true) => fail(v, "series".into(), "give at least one series (or a search)".into()),
        _ => {}
    }
}

/// Checks a search and, when `validate_scenes`, the scenes at both ends of its range.
fn build_search(spec: &StudySpec, s: &SearchSpec, validate_scenes: bool, mut v: Vec<Violation>) -> Result<Study, Vec<Violation>> {
    for (f, rule) in s.check() {
        fail(&mut v, format!("search.{f}"), rule);
    }
    if spec.measure.is_some() || spec.reference.is_some() {
        fail(&mut v, "measure".into(), "a search measures where runs fail: it takes no measure or reference".into());
    }
    if spec.fit.is_some() {
        fail(&mut v, "fit".into(), "a search has no runs' results to fit a law to: fit over series".into());
    }
    if v.is_empty() && validate_scenes {
        for (end, value) in [("low", s.low), ("high", s.high)] {
            match probe_scene(&spec.scene, s, value) {
                Ok(scene) => scene_ok(&mut v, &scene, &format!("with {} = {value} (search.{end})", s.parameter)),
                Err(e) => fail(&mut v, "search.parameter".into(), e),
            }
        }
    }
    if v.is_empty() {
        Ok(Study::Search { search: s.clone(), scene: spec.scene.clone() })
    } else {
        Err(v)
    }
}

/// Checks series `i` and appends its runs to `points`; false when the study expands into too
/// many runs (the violation is recorded and the expansion must stop).
fn expand_series(
    spec: &StudySpec,
    i: usize,
    series: &SeriesSpec,
    labels: &mut std::collections::BTreeSet<String>,
    validate_scenes: bool,
    points: &mut Vec<Point>,
    v: &mut Vec<Violation>,
) -> bool {
    let at = format!("series[{i}]");
    if series.label.trim().is_empty() || !labels.insert(series.label.clone()) {
        fail(v, format!("{at}.label"), "must be a non-empty label that no other series has".into());
    }
    let mut base = spec.scene.clone();
    for (path, value) in &series.set {
        if let Err(e) = paths::set(&mut base, path, value.clone()) {
            fail(v, format!("{at}.set.{path}"), e);
        }
    }
    if let Some(m) = &series.measure {
        for (f, rule) in m.check() {
            fail(v, if f.is_empty() { format!("{at}.measure") } else { format!("{at}.measure.{f}") }, rule);
        }
    }
    for params in sweep_combinations(series, &at, v) {
        if points.len() >= MAX_POINTS {
            fail(v, format!("{at}.sweep"), format!("the study expands into more than {MAX_POINTS} runs"));
            return false;
        }
        let mut scene = base.clone();
        let mut ok = true;
        for (path, value) in &params {
            if let Err(e) = paths::set(&mut scene, path, value.clone()) {
                fail(v, format!("{at}.sweep"), e);
                ok = false;
            }
        }
        if ok && validate_scenes {
            let values = params.iter().map(|(p, x)| format!("{p} = {}", short(x))).collect::<Vec<_>>().join(", ");
            let context = if values.is_empty() {
                format!("in series '{}'", series.label)
            } else {
                format!("in series '{}' with {values}", series.label)
            };
            scene_ok(v, &scene, &context);
        }
        let vars = series
            .set
            .iter()
            .chain(params.iter().map(|(p, v)| (p, v)))
            .filter_map(|(p, v)| v.as_f64().map(|x| (formula::variable_of(p), x)))
            .collect();
        points.push(Point { index: points.len(), series: series.label.clone(), params, vars, scene, measure: series.measure.clone() });
    }
    true
}

/// Every combination of the series' swept values, in order (one empty combination without sweeps).
fn sweep_combinations(series: &SeriesSpec, at: &str, v: &mut Vec<Violation>) -> Vec<Vec<(String, Value)>> {
    let mut combos: Vec<Vec<(String, Value)>> = vec![Vec::new()];
    for (j, sw) in series.sweep.iter().enumerate() {
        if sw.values.is_empty() {
            fail(v, format!("{at}.sweep[{j}].values"), "must list at least one value".into());
        }
        combos = combos
            .into_iter()
            .flat_map(|c| {
                sw.values.iter().map(move |x| {
                    let mut c = c.clone();
                    c.push((sw.parameter.clone(), x.clone()));
                    c
                })
            })
            .collect();
    }
    combos
}

/// Checks the study's measure, required unless every series has its own.
fn check_measure(spec: &StudySpec, v: &mut Vec<Violation>) -> MeasureSpec {
    match &spec.measure {
        Some(m) => {
            for (f, rule) in m.check() {
                fail(v, if f.is_empty() { "measure".into() } else { format!("measure.{f}") }, rule);
            }
            m.clone()
        }
        None => {
            if spec.series.iter().any(|s| s.measure.is_none()) {
                fail(v, "measure".into(), "required: what to measure on each run (unless every series has its own)".into());
            }
            MeasureSpec::default()
        }
    }
}

/// Checks the study's reference: exactly one kind, each well formed for the runs.
fn check_reference(spec: &StudySpec, points: &[Point], v: &mut Vec<Violation>) -> ReferenceSpec {
    let Some(r) = &spec.reference else {
        if spec.fit.is_none() {
            fail(v, "reference".into(), "required: a value, a formula, analytic, a job, or the finest run of a series (or a fit)".into());
        }
        return ReferenceSpec::default();
    };
    let given =
        [r.value.is_some(), r.formula.is_some(), r.analytic.is_some(), r.job.is_some(), r.finest.is_some()].iter().filter(|x| **x).count();
    if given != 1 {
        fail(v, "reference".into(), "give exactly one of value, formula, analytic, job, finest".into());
    }
    if let Some(text) = &r.formula {
        check_reference_formula(text, points, v);
    }
    if let Some(a) = &r.analytic {
        if a != "restitution" {
            fail(v, "reference.analytic".into(), format!("unknown analytic reference '{a}'; known: restitution"));
        }
    }
    if let Some(x) = r.value {
        if !x.is_finite() {
            fail(v, "reference.value".into(), "must be a finite number".into());
        }
    }
    if r.job.is_some() && spec.measure.is_none() {
        fail(v, "measure".into(), "a job as reference is measured by the study's measure: give one".into());
    }
    if let Some(label) = &r.finest {
        if !spec.series.iter().any(|s| &s.label == label) {
            fail(v, "reference.finest".into(), format!("no series is labelled '{label}'"));
        }
    }
    r.clone()
}

/// Checks that the law to fit is known.
fn check_fit(spec: &StudySpec, v: &mut Vec<Violation>) {
    if let Some(f) = &spec.fit {
        if fit::law(&f.law).is_none() {
            fail(v, "fit.law".into(), format!("unknown law '{}'; known: {}", f.law, fit::names().join(", ")));
        }
        for (k, label) in f.series.iter().enumerate() {
            if !spec.series.iter().any(|s| &s.label == label) {
                fail(v, format!("fit.series[{k}]"), format!("no series is labelled '{label}'"));
            }
        }
    }
}

/// Checks that a reference formula parses and that every run gives every variable a value.
fn check_reference_formula(text: &str, points: &[Point], v: &mut Vec<Violation>) {
    let f = match formula::Formula::parse(text) {
        Err(e) => return fail(v, "reference.formula".into(), e),
        Ok(f) => f,
    };
    for p in points {
        if let Some(missing) = f.variables().into_iter().find(|x| !p.vars.contains_key(x)) {
            let known: Vec<&str> = p.vars.keys().map(String::as_str).collect();
            fail(
                v,
                "reference.formula".into(),
                format!(
                    "'{missing}' is not a numeric parameter of series '{}' (its variables: {})",
                    p.series,
                    if known.is_empty() { "none".to_string() } else { known.join(", ") }
                ),
            );
            break;
        }
    }
}

/// Records a broken rule.
fn fail(v: &mut Vec<Violation>, field: String, rule: String) {
    v.push(Violation { field, rule });
}

/// Records the rules a run's scene breaks, prefixed by which run it is.
fn scene_ok(v: &mut Vec<Violation>, scene: &Value, context: &str) {
    if let Err(errors) = crate::methods::plan_scene(&scene.to_string()) {
        for e in errors {
            fail(v, format!("scene.{}", e.field).trim_end_matches('.').to_string(), format!("{context}: {}", e.rule));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn base() -> Value {
        json!({
            "dimension": 2, "method": "dem",
            "materials": {"glass": {"density": 2500, "contact": {"law": "linear", "k_n": 1e5}, "restitution": 0.5, "friction": 0.3}},
            "particles": [{"material": "glass", "count": 10, "size": {"kind": "monodisperse", "diameter": 0.001}, "placement": {"kind": "random"}}],
            "container": {"min": [0, 0], "max": [0.01, 0.01], "wall_material": "glass"},
            "stop": {"steps": 10}
        })
    }

    #[test]
    fn a_study_expands_into_every_combination_of_each_series() {
        let study = json!({
            "scene": base(),
            "series": [
                {"label": "DEM", "sweep": [
                    {"parameter": "method.time_step_fraction", "values": [0.01, 0.02, 0.05]},
                    {"parameter": "materials.glass.contact.k_n", "values": [1e5, 1e6]}
                ]},
                {"label": "CD", "set": {"method": "cd"}, "sweep": [{"parameter": "method.tolerance", "values": [1e-3, 1e-4]}]}
            ],
            "measure": {"sample": "phi"},
            "reference": {"finest": "CD"}
        });
        let (_, s) = parse_study(&study.to_string()).expect("valid study");
        let Study::Sweep { points, .. } = s else { panic!("a sweep") };
        assert_eq!(points.len(), 8);
        assert_eq!(
            points[1].params,
            vec![("method.time_step_fraction".to_string(), json!(0.01)), ("materials.glass.contact.k_n".to_string(), json!(1e6))]
        );
        assert_eq!(points[1].scene["method"], json!({"kind": "dem", "time_step_fraction": 0.01}));
        assert_eq!(points[1].scene["materials"]["glass"]["contact"]["k_n"], json!(1e6));
        assert_eq!(points[1].label(), "0.01, 1e6");
        assert_eq!((points[7].series.as_str(), &points[7].scene["method"]), ("CD", &json!({"kind": "cd", "tolerance": 1e-4})));
        assert_eq!(points.iter().map(|p| p.index).collect::<Vec<_>>(), (0..8).collect::<Vec<_>>());
    }

    #[test]
    fn a_bad_study_names_each_broken_rule() {
        let study = json!({
            "scene": base(),
            "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.01, 0.9]}]}],
            "measure": {"sample": "phi", "from": 2},
            "reference": {"finest": "CD"}
        });
        let v = parse_study(&study.to_string()).expect_err("rejected");
        let got: Vec<String> = v.iter().map(|x| format!("{}: {}", x.field, x.rule)).collect();
        assert_eq!(
            got,
            vec![
                "scene.method.time_step_fraction: in series 'DEM' with method.time_step_fraction = 0.9: must be between 0.000001 and 0.5, got 0.9",
                "measure.from: must be in [0, 1), got 2",
                "reference.finest: no series is labelled 'CD'",
            ]
        );
        let search = json!({"scene": base(), "search": {"parameter": "method.time_step", "low": 1e-3, "high": 1e-4}});
        let v = parse_study(&search.to_string()).expect_err("rejected");
        assert_eq!(v[0].field, "search.high");
        let unknown = json!({"scene": base(), "serie": []});
        assert!(parse_study(&unknown.to_string()).expect_err("rejected")[0].rule.starts_with("unknown field `serie`"));
    }
    #[test]
    fn a_series_may_measure_its_own_quantity() {
        let study = json!({
            "scene": base(),
            "series": [
                {"label": "grains", "measure": {"sample": "grains.phi"}},
                {"label": "disks", "set": {"method": "cd"}, "measure": {"sample": "phi", "at": "peak"}}
            ],
            "reference": {"finest": "disks"}
        });
        let (_, s) = parse_study(&study.to_string()).expect("valid: every series has its measure");
        let Study::Sweep { points, .. } = s else { panic!("a sweep") };
        let own: Vec<Option<String>> = points.iter().map(|p| p.measure.as_ref().and_then(|m| m.sample.clone())).collect();
        assert_eq!(own, vec![Some("grains.phi".to_string()), Some("phi".to_string())]);
        // One series without a measure of its own needs the study's; a series' measure is checked
        // like the study's; a job as reference is measured by the study's measure.
        let mut bad = study.clone();
        bad["series"][1].as_object_mut().expect("series").remove("measure");
        bad["series"][0]["measure"]["from"] = json!(-1);
        bad["reference"] = json!({"job": 3});
        let got: Vec<String> =
            parse_study(&bad.to_string()).expect_err("rejected").iter().map(|x| format!("{}: {}", x.field, x.rule)).collect();
        assert_eq!(
            got,
            vec![
                "series[0].measure.from: must be in [0, 1), got -1",
                "measure: required: what to measure on each run (unless every series has its own)",
                "measure: a job as reference is measured by the study's measure: give one",
            ]
        );
    }

    /// A study that fits a law needs no reference; the law and the series it names must be
    /// known, and a search takes no fit.
    #[test]
    fn a_study_may_fit_a_law_instead_of_a_reference() {
        let study = json!({
            "scene": base(),
            "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.01, 0.02]}]}],
            "measure": {"result": "shear.mu"},
            "fit": {"law": "wet_rheology"}
        });
        let (spec, s) = parse_study(&study.to_string()).expect("valid: the fit stands for the reference");
        assert_eq!(spec.fit.map(|f| f.law), Some("wet_rheology".to_string()));
        assert!(matches!(s, Study::Sweep { ref points, .. } if points.len() == 2));
        let mut bad = study.clone();
        bad["fit"]["law"] = json!("wet_rheolgy");
        bad["fit"]["series"] = json!(["DEM", "CD"]);
        let v = parse_study(&bad.to_string()).expect_err("rejected");
        assert_eq!((v[1].field.as_str(), v[1].rule.as_str()), ("fit.series[1]", "no series is labelled 'CD'"));
        assert_eq!(
            (v[0].field.as_str(), v[0].rule.as_str()),
            ("fit.law", "unknown law 'wet_rheolgy'; known: wet_rheology, granule_strength, agglomerate_rates, granule_growth")
        );
        let search = json!({"scene": base(), "search": {"parameter": "method.time_step", "low": 1e-4, "high": 1e-3},
                            "fit": {"law": "wet_rheology"}});
        let v = parse_study(&search.to_string()).expect_err("rejected");
        assert_eq!(v[0].field, "fit");
        let mut none = study;
        none.as_object_mut().expect("study").remove("fit");
        let v = parse_study(&none.to_string()).expect_err("rejected");
        assert!(v[0].field == "reference" && v[0].rule.ends_with("(or a fit)"), "{v:?}");
    }
}
