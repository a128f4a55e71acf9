//! The rheology of wet granular flows (T.-T. Vo, S. Nezamabadi, P. Mutabaruka, J.-Y. Delenne,
//! F. Radjai, "Additive rheology of complex granular flows", Nature Communications 11:1476,
//! 2020; docs/physics.md §8): steady plane shear of grains bound by viscous capillary bridges
//! collapses onto one curve in the visco-cohesive inertial number
//! `I_m = I sqrt((1 + β/St) / (1 + α ξ))`:
//! `μ = μ_c(ξ) (1 + Δμ / (1 + I_μ / I_m))` and `Φ = Φ_c(ξ) / (1 + I_m / I_Φ)`.
//!
//! The fit reads each run's steady state (`shear.mu`, `shear.phi`, `shear.inertial_number`,
//! `shear.cohesion_index`, `shear.stokes_number`), groups the runs by cohesion index (sorted
//! values less than 10% apart are one ξ: the index is measured, from each run's mean normal
//! stress), and fits α, β, Δμ, I_μ, I_Φ and each group's μ_c and Φ_c to the relative residuals
//! of μ and Φ, those of Φ weighing ten times those of μ (the ratio of their run-to-run scatter
//! in steady shear, about 5% and 0.5%). The five constants are fitted in log (they are
//! positive); the least squares start from 32 corners of a box around each constant's range
//! and keep the best minimum. β needs runs with a viscous liquid and α runs at two cohesion
//! indices or more: without them the constant is left out (reported as not determined).

use super::{log_space, number, Constant, FitLaw, FitReport, Panel, RunResult};
use crate::observe::least_squares::{minimise, Solution};

/// The published constants (Vo et al. 2020): α, β, Δμ, I_μ, I_Φ.
pub const PUBLISHED: [f64; 5] = [0.062, 0.075, 1.1, 0.095, 2.01];
/// Names of the five constants, in the order of [`PUBLISHED`].
pub const NAMES: [&str; 5] = ["alpha", "beta", "delta_mu", "I_mu", "I_phi"];
/// Weight of Φ's relative residuals against μ's.
const PHI_WEIGHT: f64 = 10.0;

/// The wet-rheology law of Vo et al. 2020.
pub struct WetRheology;

/// One run's steady state.
#[derive(Debug, Clone, Copy)]
struct Run {
    index: usize,
    i: f64,
    xi: f64,
    /// `1 / St` (0 for an inviscid liquid or dry grains).
    inv_st: f64,
    mu: f64,
    phi: f64,
    group: usize,
}

/// The law's constants: α, β, Δμ, I_μ, I_Φ.
#[derive(Debug, Clone, Copy)]
struct Law([f64; 5]);

impl Law {
    fn i_m(&self, r: &Run) -> f64 {
        r.i * ((1.0 + self.0[1] * r.inv_st) / (1.0 + self.0[0] * r.xi)).sqrt()
    }
    fn mu_ratio(&self, i_m: f64) -> f64 {
        1.0 + self.0[2] / (1.0 + self.0[3] / i_m)
    }
    fn phi_ratio(&self, i_m: f64) -> f64 {
        1.0 / (1.0 + i_m / self.0[4])
    }
}

impl FitLaw for WetRheology {
    fn name(&self) -> &'static str {
        "wet_rheology"
    }

    fn formula(&self) -> &'static str {
        "I_m = I sqrt((1 + beta/St)/(1 + alpha xi)); mu = mu_c(xi) (1 + delta_mu/(1 + I_mu/I_m)); phi = phi_c(xi)/(1 + I_m/I_phi)"
    }

    fn fit(&self, results: &[RunResult<'_>]) -> Result<FitReport, String> {
        let mut notes = Vec::new();
        let mut runs = Vec::new();
        for r in results {
            let get = |f: &str| number(r.result, &format!("shear.{f}"));
            match (get("mu"), get("phi"), get("inertial_number")) {
                (Some(mu), Some(phi), Some(i)) if mu > 0.0 && phi > 0.0 && i > 0.0 => runs.push(Run {
                    index: r.index,
                    i,
                    xi: get("cohesion_index").unwrap_or(0.0).max(0.0),
                    inv_st: get("stokes_number").filter(|s| *s > 0.0).map_or(0.0, |s| 1.0 / s),
                    mu,
                    phi,
                    group: 0,
                }),
                _ => notes.push(format!("run {} left out: its results have no steady shear state with positive mu, phi and I", r.index)),
            }
        }
        let groups = group_by_cohesion(&mut runs);
        let fit_alpha = groups.len() >= 2 && groups.iter().any(|x| *x > 0.0);
        let fit_beta = runs.iter().any(|r| r.inv_st > 0.0);
        if !fit_alpha {
            notes.push("alpha not determined: the runs have fewer than two cohesion indices".into());
        }
        if !fit_beta {
            notes.push("beta not determined: no run has a viscous liquid".into());
        }
        let free = [fit_alpha, fit_beta, true, true, true];
        let n_free = free.iter().filter(|f| **f).count() + 2 * groups.len();
        if runs.len() * 2 <= n_free {
            return Err(format!(
                "the wet rheology needs more than {} values of mu and phi for its {n_free} constants; {} runs have a steady shear state",
                n_free,
                runs.len()
            ));
        }
        let best = solve(&runs, groups.len(), free).ok_or("the least squares found no minimum from any start")?;
        let (law, mu_c, phi_c) = unpack(&best.params, free, groups.len());
        let mut constants = Vec::new();
        let mut k = 0;
        for (c, name) in NAMES.iter().enumerate() {
            if free[c] {
                // The fit is in ln: the error of x is x times that of ln x.
                let err = best.std_errors.get(k).copied().flatten().map(|e| e * law.0[c]);
                constants.push(Constant::new(*name, Some(law.0[c]), err, Some(PUBLISHED[c])));
                k += 1;
            } else {
                constants.push(Constant::new(*name, None, None, Some(PUBLISHED[c])));
            }
        }
        // Δμ and I_μ together: where μ/μ_c has not begun to saturate in the runs' I_m, only
        // the initial slope Δμ/I_μ is determined.
        let ratio = law.0[2] / law.0[3];
        constants.push(Constant::new("delta_mu/I_mu", Some(ratio), None, Some(PUBLISHED[2] / PUBLISHED[3])));
        notes.extend(super::undetermined(&constants[..5]));
        for (g, xi) in groups.iter().enumerate() {
            let err = |j: usize| best.std_errors.get(k + j).copied().flatten();
            constants.push(Constant::new(format!("mu_c(xi={xi:.3})"), Some(mu_c[g]), err(2 * g), None));
            constants.push(Constant::new(format!("phi_c(xi={xi:.3})"), Some(phi_c[g]), err(2 * g + 1), None));
        }
        let rms = (best.cost / (2 * runs.len()) as f64).sqrt();
        Ok(FitReport {
            law: self.name().into(),
            formula: self.formula().into(),
            source: "T.-T. Vo, S. Nezamabadi, P. Mutabaruka, J.-Y. Delenne, F. Radjai, Additive rheology of complex granular flows, Nature Communications 11:1476 (2020)".into(),
            runs: runs.iter().map(|r| r.index).collect(),
            constants,
            rms,
            panels: panels(&runs, law, &mu_c, &phi_c),
            notes,
        })
    }
}

/// Groups the runs by cohesion index: sorted, a value more than 10% (and 1e-3) above the one
/// before it starts a new group (a run's ξ is measured, from its mean normal stress, and
/// scatters by a few per cent about the value it was set for); returns each group's mean ξ.
fn group_by_cohesion(runs: &mut [Run]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by(|a, b| runs[*a].xi.total_cmp(&runs[*b].xi));
    let mut sums: Vec<(f64, usize)> = Vec::new();
    let mut previous: Option<f64> = None;
    for k in order {
        let xi = runs[k].xi;
        if previous.is_none_or(|p| xi > p * 1.1 + 1e-3) {
            sums.push((0.0, 0));
        }
        previous = Some(xi);
        let g = sums.len() - 1;
        runs[k].group = g;
        sums[g].0 += xi;
        sums[g].1 += 1;
    }
    sums.iter().map(|(s, n)| s / *n as f64).collect()
}

/// The law and the groups' μ_c, Φ_c from the parameter vector: the free constants' logs, then
/// `μ_c, Φ_c` per group. A constant that is not free is 0 (α, β: no effect).
fn unpack(p: &[f64], free: [bool; 5], groups: usize) -> (Law, Vec<f64>, Vec<f64>) {
    let mut c = [0.0; 5];
    let mut k = 0;
    for (j, f) in free.iter().enumerate() {
        if *f {
            c[j] = p[k].exp();
            k += 1;
        }
    }
    let mu_c = (0..groups).map(|g| p[k + 2 * g]).collect();
    let phi_c = (0..groups).map(|g| p[k + 2 * g + 1]).collect();
    (Law(c), mu_c, phi_c)
}

/// The best least-squares minimum over the starts.
fn solve(runs: &[Run], groups: usize, free: [bool; 5]) -> Option<Solution> {
    let residuals = |p: &[f64], out: &mut Vec<f64>| {
        let (law, mu_c, phi_c) = unpack(p, free, groups);
        out.clear();
        for r in runs {
            let i_m = law.i_m(r);
            out.push(mu_c[r.group] * law.mu_ratio(i_m) / r.mu - 1.0);
            out.push(PHI_WEIGHT * (phi_c[r.group] * law.phi_ratio(i_m) / r.phi - 1.0));
        }
    };
    // Each group starts at its smallest μ and largest Φ (the slowest flow's).
    let mut tail = Vec::new();
    for g in 0..groups {
        let of = runs.iter().filter(|r| r.group == g);
        tail.push(of.clone().map(|r| r.mu).fold(f64::INFINITY, f64::min));
        tail.push(of.map(|r| r.phi).fold(0.0, f64::max));
    }
    let corners: [[f64; 2]; 5] = [[0.02, 0.2], [0.02, 0.2], [0.5, 2.0], [0.03, 0.3], [0.5, 5.0]];
    let mut best: Option<Solution> = None;
    for corner in 0..32usize {
        let mut start: Vec<f64> = (0..5).filter(|j| free[*j]).map(|j| corners[j][(corner >> j) & 1].ln()).collect();
        start.extend_from_slice(&tail);
        if let Some(s) = minimise(&start, &residuals) {
            if best.as_ref().is_none_or(|b| s.cost < b.cost) {
                best = Some(s);
            }
        }
    }
    best
}

/// The chart: μ/μ_c and Φ/Φ_c against I_m (at the fitted α, β), with the fitted law and the
/// published one.
fn panels(runs: &[Run], law: Law, mu_c: &[f64], phi_c: &[f64]) -> Vec<Panel> {
    let published = Law(PUBLISHED);
    let ims: Vec<f64> = runs.iter().map(|r| law.i_m(r)).collect();
    let lo = ims.iter().copied().fold(f64::INFINITY, f64::min) / 2.0;
    let hi = ims.iter().copied().fold(0.0, f64::max) * 2.0;
    let xs = if lo.is_finite() && hi > lo { log_space(lo, hi, 60) } else { Vec::new() };
    let curve = |l: Law, f: fn(&Law, f64) -> f64| xs.iter().map(|x| [*x, f(&l, *x)]).collect::<Vec<_>>();
    vec![
        Panel {
            x: "I_m".into(),
            y: "mu / mu_c".into(),
            log_x: true,
            log_y: false,
            points: runs.iter().zip(&ims).map(|(r, x)| (r.index, *x, r.mu / mu_c[r.group])).collect(),
            curves: vec![("fitted".into(), curve(law, Law::mu_ratio)), ("Vo et al. 2020".into(), curve(published, Law::mu_ratio))],
        },
        Panel {
            x: "I_m".into(),
            y: "phi / phi_c".into(),
            log_x: true,
            log_y: false,
            points: runs.iter().zip(&ims).map(|(r, x)| (r.index, *x, r.phi / phi_c[r.group])).collect(),
            curves: vec![("fitted".into(), curve(law, Law::phi_ratio)), ("Vo et al. 2020".into(), curve(published, Law::phi_ratio))],
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    /// Steady states drawn from the law with constants `c`, at three cohesion indices, four
    /// inertial numbers and two viscosities, with a relative noise of `noise` on μ and
    /// `noise / 10` on Φ and `noise / 3` on the reported ξ (a fixed pseudo-random sequence).
    fn synthetic(c: [f64; 5], noise: f64) -> Vec<Value> {
        let law = Law(c);
        let mut out = Vec::new();
        let mut seed = 12345u64;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for (xi, mu_c, phi_c) in [(0.0, 0.3, 0.6), (1.0, 0.38, 0.58), (3.0, 0.5, 0.55)] {
            for i in [0.003, 0.01, 0.03, 0.1, 0.3] {
                for st in [100.0, 0.05] {
                    let r = Run { index: 0, i, xi, inv_st: 1.0 / st, mu: 0.0, phi: 0.0, group: 0 };
                    let i_m = law.i_m(&r);
                    let mu = mu_c * law.mu_ratio(i_m) * (1.0 + noise * rand());
                    let phi = phi_c * law.phi_ratio(i_m) * (1.0 + 0.1 * noise * rand());
                    out.push(json!({"shear": {"mu": mu, "phi": phi, "inertial_number": i,
                                              "cohesion_index": xi * (1.0 + noise / 3.0 * rand()), "stokes_number": st}}));
                }
            }
        }
        out
    }

    fn fit(values: &[Value]) -> FitReport {
        let runs: Vec<RunResult<'_>> = values.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        WetRheology.fit(&runs).expect("a fit")
    }

    /// Exact data from the published law come back with the published constants (to 1e-4),
    /// their ratio Δμ/I_μ, the three groups' μ_c and Φ_c, and no residual; no constant is said
    /// to be undetermined.
    #[test]
    fn the_law_s_own_data_give_its_constants() {
        let r = fit(&synthetic(PUBLISHED, 0.0));
        for (c, want) in r.constants.iter().zip(PUBLISHED) {
            let got = c.value.expect("determined");
            assert!((got / want - 1.0).abs() < 1e-4, "{}: {got} against {want}", c.name);
        }
        let mu_c: Vec<f64> = r.constants.iter().filter(|c| c.name.starts_with("mu_c")).filter_map(|c| c.value).collect();
        assert_eq!(mu_c.len(), 3);
        for (got, want) in mu_c.iter().zip([0.3, 0.38, 0.5]) {
            assert!((got - want).abs() < 1e-4, "mu_c {mu_c:?}");
        }
        assert!(r.rms < 1e-5, "rms {}", r.rms);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        let ratio = r.constants.iter().find(|c| c.name == "delta_mu/I_mu").and_then(|c| c.value).expect("the ratio");
        assert!((ratio / (1.1 / 0.095) - 1.0).abs() < 1e-4, "ratio {ratio}");
        assert_eq!(r.runs.len(), 30);
        assert_eq!(r.panels.len(), 2);
    }

    /// Other constants are found as well (the fit is not drawn to the published ones), and with
    /// 3% noise on μ (0.3% on Φ) each constant stays within three standard errors of the truth.
    #[test]
    fn other_constants_are_recovered_within_their_errors() {
        let truth = [0.2, 0.02, 0.6, 0.2, 0.8];
        let r = fit(&synthetic(truth, 0.03));
        for (c, want) in r.constants.iter().zip(truth) {
            let (got, err) = (c.value.expect("determined"), c.std_error.expect("an error"));
            assert!((got - want).abs() < 3.0 * err, "{}: {got} ± {err} against {want}", c.name);
            assert!(err < 0.5 * want, "{}: error {err} of {want}", c.name);
        }
    }

    /// Without viscous runs β is not determined; with one cohesion index neither is α; too few
    /// runs are an error that says how many are needed.
    #[test]
    fn what_the_runs_cannot_determine_is_said() {
        let mut values = synthetic(PUBLISHED, 0.0);
        values.retain(|v| v["shear"]["cohesion_index"].as_f64().is_some_and(|x| x < 0.5));
        for v in &mut values {
            v["shear"].as_object_mut().expect("shear").remove("stokes_number");
        }
        let r = fit(&values);
        assert_eq!(r.constants[0].value, None);
        assert_eq!(r.constants[1].value, None);
        assert!(r.notes.iter().any(|n| n.starts_with("alpha not determined")), "{:?}", r.notes);
        assert!(r.notes.iter().any(|n| n.starts_with("beta not determined")), "{:?}", r.notes);
        let few: Vec<RunResult<'_>> = values.iter().take(2).enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let e = WetRheology.fit(&few).expect_err("too few runs");
        assert!(e.contains("needs more than 5 values"), "{e}");
        let junk = [json!({"drum": {}})];
        let e = WetRheology.fit(&[RunResult { index: 0, result: &junk[0] }]).expect_err("no shear state");
        assert!(e.contains("0 runs have a steady shear state"), "{e}");
    }

    /// Runs whose μ/μ_c grows faster than linearly in I_m (`1 + 3 I_m + 5 I_m²`, as Sable's
    /// viscous runs do) are best met by the law's linear limit, I_μ → ∞ with Δμ/I_μ fixed: Δμ
    /// and I_μ are said to be undetermined, and their ratio is the data's initial slope, 3 to
    /// within the quadratic term's pull.
    #[test]
    fn a_law_that_does_not_saturate_determines_only_its_slope() {
        let mut values = Vec::new();
        for xi in [0.0f64, 2.0] {
            for i in [0.003f64, 0.01, 0.03, 0.1, 0.3] {
                for st in [1e3f64, 0.1] {
                    let i_m = i * ((1.0 + 0.075 / st) / (1.0 + 0.062 * xi)).sqrt();
                    values.push(json!({"shear": {"mu": 0.4 * (1.0 + 3.0 * i_m + 5.0 * i_m * i_m), "phi": 0.6 / (1.0 + i_m / 2.0),
                        "inertial_number": i, "cohesion_index": xi, "stokes_number": st}}));
                }
            }
        }
        let r = fit(&values);
        for name in ["delta_mu", "I_mu"] {
            assert!(r.notes.iter().any(|n| n.starts_with(&format!("{name} not determined"))), "{name}: {:?}", r.notes);
        }
        let ratio = r.constants.iter().find(|c| c.name == "delta_mu/I_mu").and_then(|c| c.value).expect("the ratio");
        assert!(ratio > 3.0 && ratio < 5.0, "ratio {ratio}");
    }
}
