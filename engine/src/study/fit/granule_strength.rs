//! The strength of a wet granule (T. T. Vo, P. Mutabaruka, S. Nezamabadi, J.-Y. Delenne,
//! E. Izard, R. Pellenq, F. Radjai, "Mechanical strength of wet particle agglomerates",
//! Mechanics Research Communications 92:1–7, 2018; Nezamabadi 2020, §3.2.3, eqs. 3.11–3.12):
//! the plastic strength of a granule squeezed between two plates is
//! `σ_p = η s Z Φ σ_c / (2π)`, with a prefactor η nearly independent of the grains' friction,
//! about linear in the bridges' rupture distance `d_rupt / d_max` and growing with the size ratio
//! `α = d_max / d_min`; `s Z Φ` is nearly independent of α and about linear in `d_rupt / d_max`.
//! The sources give these trends, not numbers.
//!
//! The fit reads each run's `granule` result (`eta`, `s`, `z`, `phi`, `size_ratio`,
//! `rupture_distance`, `largest_diameter`), groups the runs by size ratio (within 10%), and fits
//! in each group with two rupture distances or more the line `η = η_0 + η_1 d_rupt / d_max` by
//! least squares; the notes say whether each trend holds.

use super::{Constant, FitLaw, FitReport, Panel, RunResult};
use crate::observe::power::line_fit;

/// The granule-strength law.
pub struct GranuleStrength;

/// One run's granule.
#[derive(Debug, Clone, Copy)]
struct Run {
    index: usize,
    alpha: f64,
    x: f64,
    eta: f64,
    szphi: f64,
    group: usize,
}

impl FitLaw for GranuleStrength {
    fn name(&self) -> &'static str {
        "granule_strength"
    }

    fn formula(&self) -> &'static str {
        "sigma_p = eta s Z Phi sigma_c / (2 pi); eta = eta_0 + eta_1 d_rupt/d_max at each size ratio alpha"
    }

    fn fit(&self, results: &[RunResult<'_>]) -> Result<FitReport, String> {
        let mut notes = Vec::new();
        let mut runs = Vec::new();
        for r in results {
            let get = |f: &str| super::number(r.result, &format!("granule.{f}"));
            let fields = (get("eta"), get("size_ratio"), get("rupture_distance"), get("largest_diameter"), get("s"), get("z"), get("phi"));
            match fields {
                (Some(eta), Some(alpha), Some(d_rupt), Some(d_max), Some(s), Some(z), Some(phi)) if alpha >= 1.0 && d_max > 0.0 => {
                    runs.push(Run { index: r.index, alpha, x: d_rupt / d_max, eta, szphi: s * z * phi, group: 0 })
                }
                _ => notes.push(format!("run {} left out: its results have no granule with eta, size_ratio and rupture_distance", r.index)),
            }
        }
        if runs.len() < 2 {
            return Err(format!("the granule strength needs two runs or more with a plastic strength; {} have one", runs.len()));
        }
        // Group by size ratio.
        runs.sort_by(|a, b| a.alpha.total_cmp(&b.alpha).then(a.x.total_cmp(&b.x)));
        let mut alphas: Vec<f64> = Vec::new();
        for r in &mut runs {
            if alphas.last().is_none_or(|a| r.alpha > a * 1.1) {
                alphas.push(r.alpha);
            }
            r.group = alphas.len() - 1;
        }
        let mut constants = Vec::new();
        let mut lines = Vec::new();
        let (mut squares, mut count) = (0.0, 0usize);
        for (g, alpha) in alphas.iter().enumerate() {
            let of: Vec<&Run> = runs.iter().filter(|r| r.group == g).collect();
            let mean_alpha = of.iter().map(|r| r.alpha).sum::<f64>() / of.len() as f64;
            let points: Vec<(f64, f64)> = of.iter().map(|r| (r.x, r.eta)).collect();
            match line_fit(&points) {
                Some(l) => {
                    constants.push(Constant::new(
                        format!("eta_0(alpha={mean_alpha:.2})"),
                        Some(l.intercept),
                        Some(l.intercept_error),
                        None,
                    ));
                    constants.push(Constant::new(format!("eta_1(alpha={mean_alpha:.2})"), Some(l.slope), Some(l.slope_error), None));
                    squares += l.residual;
                    count += of.len();
                    let x_min = points.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
                    let x_max = points.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
                    lines.push((mean_alpha, l, x_min, x_max));
                }
                None => notes.push(format!("size ratio {alpha:.2}: fewer than three runs at distinct rupture distances, no line")),
            }
        }
        for (alpha, l, _, _) in &lines {
            let rises = l.slope > 0.0 && l.slope > 2.0 * l.slope_error;
            notes.push(format!(
                "size ratio {alpha:.2}: eta {} with d_rupt/d_max (slope {:.3} ± {:.3})",
                if rises { "rises" } else { "does not clearly rise" },
                l.slope,
                l.slope_error
            ));
        }
        if lines.len() >= 2 {
            // Compare the lines at the middle of the rupture distances every group covers.
            let lo = lines.iter().map(|(_, _, x_min, _)| *x_min).fold(f64::NEG_INFINITY, f64::max);
            let hi = lines.iter().map(|(_, _, _, x_max)| *x_max).fold(f64::INFINITY, f64::min);
            if lo <= hi {
                let x = 0.5 * (lo + hi);
                let at: Vec<String> =
                    lines.iter().map(|(a, l, _, _)| format!("{:.3} at alpha {a:.2}", l.intercept + l.slope * x)).collect();
                let grows = lines.windows(2).all(|w| w[1].1.intercept + w[1].1.slope * x > w[0].1.intercept + w[0].1.slope * x);
                notes.push(format!(
                    "at d_rupt/d_max = {x:.3}, eta is {}: {}",
                    if grows { "larger at each larger size ratio" } else { "not larger at each larger size ratio" },
                    at.join(", ")
                ));
            } else {
                notes.push("the size ratios' rupture distances do not overlap: eta is not compared across them".into());
            }
        }
        let xs: Vec<f64> = runs.iter().map(|r| r.x).collect();
        let (x0, x1) = (xs.iter().copied().fold(f64::INFINITY, f64::min), xs.iter().copied().fold(0.0, f64::max));
        let curves = lines
            .iter()
            .map(|(a, l, _, _)| {
                (
                    format!("alpha {a:.2}: {:.2} + {:.2} x", l.intercept, l.slope),
                    vec![[x0, l.intercept + l.slope * x0], [x1, l.intercept + l.slope * x1]],
                )
            })
            .collect();
        Ok(FitReport {
            law: self.name().into(),
            formula: self.formula().into(),
            source: "T. T. Vo et al., Mechanical strength of wet particle agglomerates, Mechanics Research Communications 92:1-7 (2018); Nezamabadi 2020, §3.2.3 (trends, no published constants)".into(),
            runs: { let mut r: Vec<usize> = runs.iter().map(|r| r.index).collect(); r.sort_unstable(); r },
            constants,
            rms: if count > 0 { (squares / count as f64).sqrt() } else { 0.0 },
            panels: vec![
                Panel { x: "d_rupt / d_max".into(), y: "eta".into(), log_x: false, log_y: false, points: runs.iter().map(|r| (r.index, r.x, r.eta)).collect(), curves },
                Panel { x: "d_rupt / d_max".into(), y: "s Z Phi".into(), log_x: false, log_y: false, points: runs.iter().map(|r| (r.index, r.x, r.szphi)).collect(), curves: Vec::new() },
            ],
            notes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    fn granule(alpha: f64, d_rupt: f64, eta: f64) -> Value {
        json!({"granule": {"eta": eta, "size_ratio": alpha, "rupture_distance": d_rupt, "largest_diameter": 1e-3,
                           "s": 1.0, "z": 5.0, "phi": 0.6}})
    }

    /// Lines η = 0.5 + 4x (α = 1) and 0.8 + 4x (α = 3) with ±0.01 alternating scatter come back
    /// within a few standard errors; both trends are said to hold.
    #[test]
    fn the_lines_of_each_size_ratio_are_fitted() {
        let mut values = Vec::new();
        for (alpha, a) in [(1.0, 0.5), (3.0, 0.8)] {
            for (k, x) in [0.05, 0.1, 0.15, 0.2].iter().enumerate() {
                let noise = if k % 2 == 0 { 0.01 } else { -0.01 };
                values.push(granule(alpha * (1.0 + 0.01 * k as f64), x * 1e-3, a + 4.0 * x + noise));
            }
        }
        values.push(json!({"shear": {}}));
        let runs: Vec<RunResult<'_>> = values.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let r = GranuleStrength.fit(&runs).expect("a fit");
        let v = |name: &str| r.constants.iter().find(|c| c.name.starts_with(name)).and_then(|c| c.value).expect(name);
        assert!((v("eta_0(alpha=1.0") - 0.5).abs() < 0.03, "{:?}", r.constants);
        assert!((v("eta_1(alpha=1.0") - 4.0).abs() < 0.3, "{:?}", r.constants);
        assert!((v("eta_0(alpha=3.0") - 0.8).abs() < 0.03, "{:?}", r.constants);
        assert_eq!(r.runs, (0..8).collect::<Vec<_>>());
        assert!(r.notes.iter().any(|n| n.starts_with("run 8 left out")), "{:?}", r.notes);
        assert!(r.notes.iter().any(|n| n.contains("larger at each larger size ratio")), "{:?}", r.notes);
        assert_eq!(r.notes.iter().filter(|n| n.contains("eta rises")).count(), 2, "{:?}", r.notes);
        // Flat η at α = 1: its trend is said not to hold.
        let flat: Vec<Value> =
            [0.05, 0.1, 0.15].iter().enumerate().map(|(k, x)| granule(1.0, x * 1e-3, 0.6 + 0.01 * (k % 2) as f64)).collect();
        let runs: Vec<RunResult<'_>> = flat.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let r = GranuleStrength.fit(&runs).expect("a fit");
        assert!(r.notes.iter().any(|n| n.contains("does not clearly rise")), "{:?}", r.notes);
    }
}
