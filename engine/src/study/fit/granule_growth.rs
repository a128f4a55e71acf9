//! Granule growth in a rotating drum (T. T. Vo, P. Mutabaruka, S. Nezamabadi, J.-Y. Delenne,
//! F. Radjai, "Combined effects of particle size ratio and friction on granule growth in a
//! rotating drum", European Physical Journal E 42:127, 2019; Nezamabadi 2020, §3.2.1,
//! eqs. 3.4–3.5): a pre-formed wet granule in a drum of dry and wet grains loses grains at a
//! constant rate, `N⁻ = k⁻ N_r`, and captures the free wet grains,
//! `N⁺ = [N_w (1 − k⁻/k⁺) − N_g0] (1 − exp(−k⁺ N_r / N_w)) + k⁻ N_r`; both rates grow with the
//! size ratio `α = d_max / d_min` and with the grains' friction. The sources give these trends,
//! not numbers.
//!
//! Each run's `drum.granule` result carries its rates, fitted by the engine
//! ([`crate::observe::results::granule_growth`]); this law gathers them: one pair of constants
//! per run, the trends with the size ratio at each friction and with the friction at each size
//! ratio (runs within 10% of a size ratio and 1% of a friction count as equal) as notes, and the
//! panels: the accretion and erosion of every run against the revolutions with its fitted law,
//! and the rates against the size ratio and the friction.

use super::{Constant, FitLaw, FitReport, Panel, RunResult};
use crate::observe::results::granule_growth::accretion;

/// The granule-growth law.
pub struct GranuleGrowthLaw;

/// Points of each run's history drawn on the accretion and erosion panels (at most).
const HISTORY_POINTS: usize = 30;

/// One run's granule.
#[derive(Debug)]
struct Run {
    index: usize,
    alpha: f64,
    mu: f64,
    k_plus: Option<f64>,
    k_plus_error: Option<f64>,
    k_minus: f64,
    k_minus_error: Option<f64>,
    wet: f64,
    initial: f64,
    history: Vec<[f64; 3]>,
}

impl Run {
    fn label(&self) -> String {
        format!("run {}: alpha {:.2}, mu {:.2}", self.index, self.alpha, self.mu)
    }
}

impl FitLaw for GranuleGrowthLaw {
    fn name(&self) -> &'static str {
        "granule_growth"
    }

    fn formula(&self) -> &'static str {
        "N- = k- N_r; N+ = [N_w (1 - k-/k+) - N_g0] (1 - exp(-k+ N_r / N_w)) + k- N_r; k+ and k- grow with alpha and friction"
    }

    fn fit(&self, results: &[RunResult<'_>]) -> Result<FitReport, String> {
        let mut notes = Vec::new();
        let mut runs = Vec::new();
        for r in results {
            match run_of(r) {
                Some(run) => runs.push(run),
                None => notes.push(format!("run {} left out: its results have no drum.granule with rates", r.index)),
            }
        }
        if runs.is_empty() {
            return Err("the granule growth needs a drum run with a wet granule; none has one".into());
        }
        runs.sort_by(|a, b| a.alpha.total_cmp(&b.alpha).then(a.mu.total_cmp(&b.mu)).then(a.index.cmp(&b.index)));
        let mut constants = Vec::new();
        for r in &runs {
            let tag = format!("alpha={:.2},mu={:.2}", r.alpha, r.mu);
            constants.push(Constant::new(format!("k+({tag})"), r.k_plus, r.k_plus.and(r.k_plus_error), None));
            constants.push(Constant::new(format!("k-({tag})"), Some(r.k_minus), r.k_minus_error, None));
        }
        for r in runs.iter().filter(|r| r.k_plus.is_none()) {
            notes.push(format!("run {}: no accretion rate (no free wet grain)", r.index));
        }
        let (squares, count) = runs.iter().filter_map(|r| r.k_plus.map(|k| (r, k))).fold((0.0, 0usize), |(s, n), (r, k)| {
            let sum: f64 = r.history.iter().map(|h| (accretion(h[0], k, r.k_minus, r.wet, r.initial) - h[1]).powi(2)).sum();
            (s + sum, n + r.history.len())
        });
        let alpha_groups = groups(runs.iter().map(|r| r.alpha), 0.1);
        let mu_groups = groups(runs.iter().map(|r| r.mu), 0.01);
        // The trend with the size ratio at each friction, and with the friction at each size ratio.
        let mut by_alpha = Vec::new();
        for mu in &mu_groups {
            let of: Vec<&Run> = runs.iter().filter(|r| same(r.mu, *mu, 0.01)).collect();
            if groups(of.iter().map(|r| r.alpha), 0.1).len() >= 2 {
                notes.push(trend("size ratio", &format!("friction {mu:.2}"), &of, |r| r.alpha));
                by_alpha.push((*mu, of));
            }
        }
        let mut by_mu = Vec::new();
        for alpha in &alpha_groups {
            let of: Vec<&Run> = runs.iter().filter(|r| same(r.alpha, *alpha, 0.1)).collect();
            if groups(of.iter().map(|r| r.mu), 0.01).len() >= 2 {
                notes.push(trend("friction", &format!("size ratio {alpha:.2}"), &of, |r| r.mu));
                by_mu.push((*alpha, of));
            }
        }
        if by_alpha.is_empty() && by_mu.is_empty() {
            notes.push("no two runs differ in size ratio or friction alone: no trend".into());
        }
        let rates_against = |x: &str, sets: &[(f64, Vec<&Run>)], var: &dyn Fn(&Run) -> f64, tag: &str| {
            let mut curves = Vec::new();
            let mut points = Vec::new();
            for (value, of) in sets {
                let mut of = of.clone();
                of.sort_by(|a, b| var(a).total_cmp(&var(b)));
                curves.push((format!("k+ at {tag} {value:.2}"), of.iter().filter_map(|r| r.k_plus.map(|k| [var(r), k])).collect()));
                curves.push((format!("k- at {tag} {value:.2}"), of.iter().map(|r| [var(r), r.k_minus]).collect()));
                points.extend(of.iter().filter_map(|r| r.k_plus.map(|k| (r.index, var(r), k))));
                points.extend(of.iter().map(|r| (r.index, var(r), r.k_minus)));
            }
            Panel { x: x.into(), y: "rate, grains per revolution".into(), log_x: false, log_y: false, points, curves }
        };
        let mut panels = vec![history_panel(&runs, true), history_panel(&runs, false)];
        if !by_alpha.is_empty() {
            panels.push(rates_against("size ratio alpha", &by_alpha, &|r| r.alpha, "mu"));
        }
        if !by_mu.is_empty() {
            panels.push(rates_against("friction mu", &by_mu, &|r| r.mu, "alpha"));
        }
        Ok(FitReport {
            law: self.name().into(),
            formula: self.formula().into(),
            source: "T. T. Vo et al., Combined effects of particle size ratio and friction on granule growth in a rotating drum, European Physical Journal E 42:127 (2019); Nezamabadi 2020, §3.2.1 (trends, no published constants)".into(),
            runs: {
                let mut r: Vec<usize> = runs.iter().map(|r| r.index).collect();
                r.sort_unstable();
                r
            },
            constants,
            rms: if count > 0 { (squares / count as f64).sqrt() } else { 0.0 },
            panels,
            notes,
        })
    }
}

/// A run's granule from its results.
fn run_of(r: &RunResult<'_>) -> Option<Run> {
    let g = r.result.get("drum")?.get("granule")?;
    let get = |f: &str| super::number(g, f);
    let history: Vec<[f64; 3]> = g
        .get("history")?
        .as_array()?
        .iter()
        .filter_map(|h| {
            let h = h.as_array()?;
            Some([h.first()?.as_f64()?, h.get(1)?.as_f64()?, h.get(2)?.as_f64()?])
        })
        .collect();
    Some(Run {
        index: r.index,
        alpha: get("size_ratio")?,
        mu: get("friction")?,
        // Results stored before a run that accreted nothing reported k+ = 0 have no rate.
        k_plus: get("accretion_rate").or_else(|| (get("accreted") == Some(0.0)).then_some(0.0)),
        k_plus_error: get("accretion_rate_error"),
        k_minus: get("erosion_rate")?,
        k_minus_error: get("erosion_rate_error"),
        wet: get("wet")?,
        initial: get("initial")?,
        history,
    })
}

/// True if `a` and `b` are within `tolerance` of each other, relatively (or both zero).
fn same(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance * a.abs().max(b.abs())
}

/// The distinct values among `values` (the first of each group within `tolerance`, sorted).
fn groups(values: impl Iterator<Item = f64>, tolerance: f64) -> Vec<f64> {
    let mut values: Vec<f64> = values.collect();
    values.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for v in values {
        if out.last().is_none_or(|&last| !same(last, v, tolerance)) {
            out.push(v);
        }
    }
    out
}

/// The note on the trend of both rates with `what` over the runs `of` (all at `at`).
fn trend(what: &str, at: &str, of: &[&Run], var: impl Fn(&Run) -> f64) -> String {
    let mut of = of.to_vec();
    of.sort_by(|a, b| var(a).total_cmp(&var(b)));
    let list = |f: &dyn Fn(&Run) -> Option<f64>| -> String {
        of.iter().map(|r| f(r).map_or("—".into(), |v| format!("{v:.3}"))).collect::<Vec<_>>().join(", ")
    };
    let grows = |f: &dyn Fn(&Run) -> Option<f64>| -> &'static str {
        let v: Vec<f64> = of.iter().filter_map(|r| f(r)).collect();
        if v.len() < 2 {
            "not determined"
        } else if v.windows(2).all(|w| w[1] > w[0]) {
            "grows at each step"
        } else if v.last() > v.first() {
            "grows overall, not at each step"
        } else {
            "does not grow"
        }
    };
    format!(
        "at {at}, {what} {}: k+ {} ({}), k- {} ({}); published: both grow",
        list(&|r| Some(var(r))),
        list(&|r| r.k_plus),
        grows(&|r| r.k_plus),
        list(&|r| Some(r.k_minus)),
        grows(&|r| Some(r.k_minus)),
    )
}

/// The accretion (`plus`) or erosion of every run against the revolutions, with its fitted law.
fn history_panel(runs: &[Run], plus: bool) -> Panel {
    let column = if plus { 1 } else { 2 };
    let mut points = Vec::new();
    let mut curves = Vec::new();
    for r in runs {
        let every = r.history.len().div_ceil(HISTORY_POINTS).max(1);
        points.extend(r.history.iter().step_by(every).map(|h| (r.index, h[0], h[column])));
        let end = r.history.last().map_or(0.0, |h| h[0]);
        let line: Vec<[f64; 2]> = match (plus, r.k_plus) {
            (true, Some(k)) => (0..=40).map(|i| end * i as f64 / 40.0).map(|n| [n, accretion(n, k, r.k_minus, r.wet, r.initial)]).collect(),
            (true, None) => Vec::new(),
            (false, _) => vec![[0.0, 0.0], [end, r.k_minus * end]],
        };
        if !line.is_empty() {
            curves.push((r.label(), line));
        }
    }
    let y = if plus { "accreted grains N+" } else { "eroded grains N-" };
    Panel { x: "drum revolutions N_r".into(), y: y.into(), log_x: false, log_y: false, points, curves }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    /// A run's result whose granule follows the law with rates `k_plus`, `k_minus`.
    fn drum(alpha: f64, mu: f64, k_plus: f64, k_minus: f64) -> Value {
        let history: Vec<[f64; 3]> =
            (0..=20).map(|i| 0.5 * i as f64).map(|n| [n, accretion(n, k_plus, k_minus, 200.0, 50.0), k_minus * n]).collect();
        json!({"drum": {"granule": {"wet": 200, "initial": 50, "size_ratio": alpha, "friction": mu,
                                     "accretion_rate": k_plus, "erosion_rate": k_minus, "history": history}}})
    }

    /// Five runs: three size ratios at friction 0.5 with both rates growing, and friction 0.1
    /// and 0.3 at size ratio 5 with k- falling: the trends are said as they are; a run without
    /// a granule is left out; the accretion panel draws each run's law through its points.
    #[test]
    fn the_trends_with_size_ratio_and_friction_are_read_from_the_runs() {
        let values = [
            drum(1.0, 0.5, 20.0, 1.0),
            drum(2.0, 0.5, 30.0, 2.0),
            drum(5.0, 0.5, 45.0, 3.0),
            drum(5.0, 0.1, 25.0, 4.0),
            drum(5.0, 0.3, 35.0, 3.5),
            json!({"drum": {"regime": "rolling"}}),
        ];
        let runs: Vec<RunResult<'_>> = values.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let r = GranuleGrowthLaw.fit(&runs).expect("a fit");
        assert_eq!(r.runs, vec![0, 1, 2, 3, 4]);
        assert!(r.rms < 1e-9, "the runs follow the law exactly: rms {}", r.rms);
        let k = |name: &str| r.constants.iter().find(|c| c.name == name).and_then(|c| c.value).expect(name);
        assert_eq!(k("k+(alpha=2.00,mu=0.50)"), 30.0);
        assert_eq!(k("k-(alpha=5.00,mu=0.10)"), 4.0);
        let note = |start: &str| r.notes.iter().find(|n| n.starts_with(start)).cloned().unwrap_or_default();
        let by_alpha = note("at friction 0.50, size ratio 1.000, 2.000, 5.000");
        assert!(by_alpha.contains("k+ 20.000, 30.000, 45.000 (grows at each step)"), "{:?}", r.notes);
        assert!(by_alpha.contains("k- 1.000, 2.000, 3.000 (grows at each step)"), "{:?}", r.notes);
        let by_mu = note("at size ratio 5.00, friction 0.100, 0.300, 0.500");
        assert!(by_mu.contains("k+ 25.000, 35.000, 45.000 (grows at each step)"), "{:?}", r.notes);
        assert!(by_mu.contains("k- 4.000, 3.500, 3.000 (does not grow)"), "{:?}", r.notes);
        assert!(r.notes.iter().any(|n| n.starts_with("run 5 left out")), "{:?}", r.notes);
        assert_eq!(r.panels.len(), 4);
        let plus = &r.panels[0];
        assert_eq!(plus.curves.len(), 5);
        for (_, line) in &plus.curves {
            assert_eq!(line.first().map(|p| p[1]), Some(0.0));
        }
        // A run that accreted nothing, stored without a rate, has k+ = 0.
        let mut still = drum(2.0, 0.1, 1.0, 0.0);
        still["drum"]["granule"].as_object_mut().map(|g| g.remove("accretion_rate"));
        still["drum"]["granule"]["accreted"] = json!(0);
        let r = GranuleGrowthLaw.fit(&[RunResult { index: 0, result: &still }]).expect("a fit");
        assert_eq!(r.constants[0].value, Some(0.0), "{:?}", r.constants);
        // Every number of the report is finite (it goes through JSON).
        assert!(r.rms.is_finite() && r.panels.iter().all(|p| p.curves.iter().all(|c| c.1.iter().all(|x| x[1].is_finite()))));
        // A lone run gives its constants and says there is no trend.
        let r = GranuleGrowthLaw.fit(&runs[..1]).expect("a fit");
        assert!(r.notes.iter().any(|n| n.starts_with("no two runs")), "{:?}", r.notes);
        assert!(GranuleGrowthLaw.fit(&runs[5..]).is_err());
    }
}
