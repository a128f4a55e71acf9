//! The rates at which a wet agglomerate elongates, is damaged and is eroded in a shear flow of
//! dry grains (T. T. Vo, S. Nezamabadi, P. Mutabaruka, J.-Y. Delenne, F. Radjai, "Evolution of
//! wet agglomerates inside inertial shear flow of dry granules", Physical Review E 101, 2020;
//! Nezamabadi 2020, §3.2.2): per unit strain, `K_g/γ̇ = A_g (ξI)^n_g`, `K_b/γ̇ = A_b (ξI)^n_b`
//! and `K_e/γ̇ = A_e (I_e^n_e − I_0^n_e)` with `I_e = I^¼/ξ`, no erosion below `I_e = I_0`.
//!
//! The fit reads each run's `agglomerate` rates and its `shear` inertial number and cohesion
//! index. `A` and `n` of elongation and damage are the least-squares line of `ln K` against
//! `ln(ξI)` over the runs whose rate is positive; those of erosion are fitted by
//! Levenberg–Marquardt to the rates themselves (residuals over the largest rate, the model 0
//! below `I_0`). The rates are Sable's reductions of the cluster's series
//! (`observe/results/agglomerate.rs`); the published ones may be defined otherwise.

use super::{log_space, number, Constant, FitLaw, FitReport, Panel, RunResult};
use crate::observe::least_squares::minimise;
use crate::observe::power::line_fit;

/// Published constants: A_g, n_g, A_b, n_b, A_e, I_0, n_e (Vo et al. 2020, Physical Review E).
pub const PUBLISHED: [(&str, f64); 7] =
    [("A_g", 6.5e-4), ("n_g", -0.88), ("A_b", 3.0e-3), ("n_b", -0.65), ("A_e", 4.5e-2), ("I_0", 5.2e-2), ("n_e", 1.4)];

/// The agglomerate-rates law.
pub struct AgglomerateRates;

#[derive(Debug, Clone, Copy)]
struct Run {
    index: usize,
    xi_i: f64,
    i_e: f64,
    k_g: f64,
    k_b: f64,
    k_e: f64,
}

impl FitLaw for AgglomerateRates {
    fn name(&self) -> &'static str {
        "agglomerate_rates"
    }

    fn formula(&self) -> &'static str {
        "K_g/rate = A_g (xi I)^n_g; K_b/rate = A_b (xi I)^n_b; K_e/rate = A_e (I_e^n_e - I_0^n_e), I_e = I^(1/4)/xi"
    }

    fn fit(&self, results: &[RunResult<'_>]) -> Result<FitReport, String> {
        let mut notes = Vec::new();
        let mut runs = Vec::new();
        for r in results {
            let get = |p: &str| number(r.result, p);
            let rates = (get("agglomerate.elongation_rate"), get("agglomerate.damage_rate"), get("agglomerate.erosion_rate"));
            match (rates, get("shear.inertial_number"), get("shear.cohesion_index")) {
                ((Some(k_g), Some(k_b), Some(k_e)), Some(i), Some(xi)) if i > 0.0 && xi > 0.0 => {
                    runs.push(Run { index: r.index, xi_i: xi * i, i_e: i.powf(0.25) / xi, k_g, k_b, k_e })
                }
                _ => notes.push(format!("run {} left out: no agglomerate rates, or no inertial number and cohesion index", r.index)),
            }
        }
        if runs.len() < 3 {
            return Err(format!("the agglomerate rates need three runs or more with an agglomerate; {} have one", runs.len()));
        }
        let published = |k: usize| Some(PUBLISHED[k].1);
        let mut constants = Vec::new();
        let mut curves_g = Vec::new();
        let mut curves_b = Vec::new();
        let xs: Vec<f64> = runs.iter().map(|r| r.xi_i).collect();
        let (lo, hi) = (xs.iter().copied().fold(f64::INFINITY, f64::min) / 1.5, xs.iter().copied().fold(0.0, f64::max) * 1.5);
        let grid = log_space(lo, hi, 40);
        let mut squares = 0.0;
        let mut count = 0usize;
        for (k, curves) in [&mut curves_g, &mut curves_b].into_iter().enumerate() {
            let rate: fn(&Run) -> f64 = if k == 0 { |r| r.k_g } else { |r| r.k_b };
            let pts: Vec<(f64, f64)> = runs.iter().filter(|r| rate(r) > 0.0).map(|r| (r.xi_i.ln(), rate(r).ln())).collect();
            let (a_name, n_name) = (PUBLISHED[2 * k].0, PUBLISHED[2 * k + 1].0);
            match line_fit(&pts) {
                Some(l) => {
                    let (a, n) = (l.intercept.exp(), l.slope);
                    constants.push(Constant::new(a_name, Some(a), Some(l.intercept_error * a), published(2 * k)));
                    constants.push(Constant::new(n_name, Some(n), Some(l.slope_error), published(2 * k + 1)));
                    curves.push(("fitted".to_string(), grid.iter().map(|x| [*x, a * x.powf(n)]).collect()));
                    squares += l.residual;
                    count += pts.len();
                }
                None => {
                    notes.push(format!("{a_name}, {n_name} not determined: fewer than three runs with a positive rate at distinct xi I"));
                    constants.push(Constant::new(a_name, None, None, published(2 * k)));
                    constants.push(Constant::new(n_name, None, None, published(2 * k + 1)));
                }
            }
            let (a, n) = (PUBLISHED[2 * k].1, PUBLISHED[2 * k + 1].1);
            curves.push(("Vo et al. 2020".to_string(), grid.iter().map(|x| [*x, a * x.powf(n)]).collect()));
        }
        // Erosion.
        let eroding = runs.iter().filter(|r| r.k_e > 0.0).count();
        let scale = runs.iter().map(|r| r.k_e.abs()).fold(0.0, f64::max);
        let erosion = |p: &[f64], i_e: f64| {
            let (a, i0, n) = (p[0].exp(), p[1].exp(), p[2].exp());
            (a * (i_e.powf(n) - i0.powf(n))).max(0.0)
        };
        let mut fitted_e = None;
        if eroding >= 2 && runs.len() >= 4 && scale > 0.0 {
            let residuals = |p: &[f64], out: &mut Vec<f64>| {
                out.clear();
                out.extend(runs.iter().map(|r| (erosion(p, r.i_e) - r.k_e) / scale));
            };
            let i_es: Vec<f64> = runs.iter().map(|r| r.i_e).collect();
            let (e_lo, e_hi) = (i_es.iter().copied().fold(f64::INFINITY, f64::min), i_es.iter().copied().fold(0.0, f64::max));
            let mut best: Option<crate::observe::least_squares::Solution> = None;
            for a0 in [0.01, 0.1, 1.0] {
                for i0 in [e_lo * 0.5, (e_lo * e_hi).sqrt()] {
                    for n0 in [0.7, 1.5, 3.0] {
                        if let Some(s) = minimise(&[f64::ln(a0), f64::ln(i0.max(1e-12)), f64::ln(n0)], &residuals) {
                            if best.as_ref().is_none_or(|b| s.cost < b.cost) {
                                best = Some(s);
                            }
                        }
                    }
                }
            }
            fitted_e = best;
        } else {
            notes.push(format!("A_e, I_0, n_e not determined: {eroding} runs eroded (two needed, of four runs or more)"));
        }
        match &fitted_e {
            Some(s) => {
                for (j, k) in [4usize, 5, 6].iter().enumerate() {
                    let v = s.params[j].exp();
                    constants.push(Constant::new(PUBLISHED[*k].0, Some(v), s.std_errors[j].map(|e| e * v), published(*k)));
                }
                squares += s.cost;
                count += runs.len();
            }
            None => {
                for k in [4usize, 5, 6] {
                    constants.push(Constant::new(PUBLISHED[k].0, None, None, published(k)));
                }
            }
        }
        notes.extend(super::undetermined(&constants));
        let i_es: Vec<f64> = runs.iter().map(|r| r.i_e).collect();
        let (e_lo, e_hi) = (i_es.iter().copied().fold(f64::INFINITY, f64::min) / 1.5, i_es.iter().copied().fold(0.0, f64::max) * 1.5);
        let e_grid = log_space(e_lo, e_hi, 60);
        let mut curves_e = Vec::new();
        if let Some(s) = &fitted_e {
            curves_e.push(("fitted".to_string(), e_grid.iter().map(|x| [*x, erosion(&s.params, *x)]).collect()));
        }
        let pub_e = [PUBLISHED[4].1.ln(), PUBLISHED[5].1.ln(), PUBLISHED[6].1.ln()];
        curves_e.push(("Vo et al. 2020".to_string(), e_grid.iter().map(|x| [*x, erosion(&pub_e, *x)]).collect()));
        Ok(FitReport {
            law: self.name().into(),
            formula: self.formula().into(),
            source: "T. T. Vo, S. Nezamabadi, P. Mutabaruka, J.-Y. Delenne, F. Radjai, Evolution of wet agglomerates inside inertial shear flow of dry granules, Physical Review E 101 (2020)".into(),
            runs: runs.iter().map(|r| r.index).collect(),
            constants,
            rms: if count > 0 { (squares / count as f64).sqrt() } else { 0.0 },
            panels: vec![
                Panel { x: "xi I".into(), y: "K_g / shear rate".into(), log_x: true, log_y: true,
                        points: runs.iter().filter(|r| r.k_g > 0.0).map(|r| (r.index, r.xi_i, r.k_g)).collect(), curves: curves_g },
                Panel { x: "xi I".into(), y: "K_b / shear rate".into(), log_x: true, log_y: true,
                        points: runs.iter().filter(|r| r.k_b > 0.0).map(|r| (r.index, r.xi_i, r.k_b)).collect(), curves: curves_b },
                Panel { x: "I_e = I^(1/4) / xi".into(), y: "K_e / shear rate".into(), log_x: true, log_y: false,
                        points: runs.iter().map(|r| (r.index, r.i_e, r.k_e)).collect(), curves: curves_e },
            ],
            notes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    /// Rates drawn from the published laws at four I and three ξ come back with the published
    /// constants; runs below the erosion threshold erode nothing.
    #[test]
    fn the_published_rates_give_the_published_constants() {
        let mut values: Vec<Value> = Vec::new();
        for xi in [0.5f64, 1.0, 2.0, 4.0] {
            for i in [0.003f64, 0.01, 0.03, 0.1] {
                let i_e = i.powf(0.25) / xi;
                let k_e = (4.5e-2 * (i_e.powf(1.4) - 5.2e-2f64.powf(1.4))).max(0.0);
                values.push(json!({"shear": {"inertial_number": i, "cohesion_index": xi},
                    "agglomerate": {"elongation_rate": 6.5e-4 * (xi * i).powf(-0.88), "damage_rate": 3.0e-3 * (xi * i).powf(-0.65),
                                    "erosion_rate": k_e}}));
            }
        }
        values.push(json!({"shear": {"inertial_number": 0.01}}));
        let runs: Vec<RunResult<'_>> = values.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let r = AgglomerateRates.fit(&runs).expect("a fit");
        for (c, (name, want)) in r.constants.iter().zip(PUBLISHED) {
            assert_eq!(c.name, name);
            let got = c.value.expect("determined");
            assert!((got / want - 1.0).abs() < 1e-3, "{name}: {got} against {want}");
        }
        assert_eq!(r.runs.len(), 16);
        assert!(r.notes.iter().any(|n| n.starts_with("run 16 left out")), "{:?}", r.notes);
        assert_eq!(r.panels.len(), 3);
    }
}
