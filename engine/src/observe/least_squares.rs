//! Nonlinear least squares by Levenberg–Marquardt (K. Levenberg, "A method for the solution of
//! certain non-linear problems in least squares", 1944; D. W. Marquardt, "An algorithm for
//! least-squares estimation of nonlinear parameters", 1963), with a forward-difference Jacobian
//! and the standard errors of the parameters from the covariance `s² (JᵀJ)⁻¹`.

use nalgebra::{DMatrix, DVector};

/// The minimum found from one start.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The parameters.
    pub params: Vec<f64>,
    /// Sum of the squared residuals.
    pub cost: f64,
    /// Standard error of each parameter (all `None` when the normal matrix is singular: some
    /// parameter is not determined by the data).
    pub std_errors: Vec<Option<f64>>,
}

/// Minimises `Σ r_i(p)²` from `start`. `residuals` writes the residuals for parameters `p`
/// (their count must not change); a non-finite residual counts as a rejected step.
pub fn minimise(start: &[f64], residuals: &dyn Fn(&[f64], &mut Vec<f64>)) -> Option<Solution> {
    let n = start.len();
    let mut p = start.to_vec();
    let mut r = Vec::new();
    residuals(&p, &mut r);
    let m = r.len();
    if m < n || r.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    let mut lambda = 1e-3;
    let mut trial = Vec::with_capacity(m);
    let mut jac = DMatrix::<f64>::zeros(m, n);
    for _ in 0..400 {
        jacobian(&p, &r, residuals, &mut jac)?;
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * DVector::from_column_slice(&r);
        let mut improved = false;
        while lambda < 1e12 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let next: Vec<f64> = p.iter().zip(step.iter()).map(|(x, d)| x + d).collect();
            residuals(&next, &mut trial);
            let c: f64 = trial.iter().map(|x| x * x).sum();
            if c.is_finite() && c < cost {
                let gain = (cost - c) / cost.max(1e-300);
                p = next;
                std::mem::swap(&mut r, &mut trial);
                cost = c;
                lambda = (lambda / 10.0).max(1e-12);
                improved = gain > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    jacobian(&p, &r, residuals, &mut jac)?;
    let dof = m.saturating_sub(n).max(1) as f64;
    let s2 = cost / dof;
    let std_errors = match (jac.transpose() * &jac).try_inverse() {
        Some(cov) => (0..n).map(|k| (cov[(k, k)] >= 0.0).then(|| (s2 * cov[(k, k)]).sqrt())).collect(),
        None => vec![None; n],
    };
    Some(Solution { params: p, cost, std_errors })
}

/// Forward-difference Jacobian of the residuals at `p` (whose residuals are `r`).
fn jacobian(p: &[f64], r: &[f64], residuals: &dyn Fn(&[f64], &mut Vec<f64>), jac: &mut DMatrix<f64>) -> Option<()> {
    let mut q = p.to_vec();
    let mut rq = Vec::with_capacity(r.len());
    for k in 0..p.len() {
        let h = 1e-7 * p[k].abs().max(1e-3);
        q[k] = p[k] + h;
        residuals(&q, &mut rq);
        q[k] = p[k];
        if rq.len() != r.len() {
            return None;
        }
        for i in 0..r.len() {
            let d = (rq[i] - r[i]) / h;
            jac[(i, k)] = if d.is_finite() { d } else { 0.0 };
        }
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An exponential decay y = a e^(−b x) + c from exact data: the fit returns a, b, c to 1e-8
    /// from a start 50% off, and zero standard errors.
    #[test]
    fn it_recovers_the_parameters_of_exact_data() {
        let xs: Vec<f64> = (0..30).map(|i| i as f64 * 0.2).collect();
        let (a, b, c) = (2.5, 0.7, 0.3);
        let data: Vec<f64> = xs.iter().map(|x| a * (-b * x).exp() + c).collect();
        let f = |p: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.extend(xs.iter().zip(&data).map(|(x, y)| p[0] * (-p[1] * x).exp() + p[2] - y));
        };
        let s = minimise(&[1.2, 1.1, 0.0], &f).expect("a solution");
        for (got, want) in s.params.iter().zip([a, b, c]) {
            assert!((got - want).abs() < 1e-8, "{:?}", s.params);
        }
        assert!(s.cost < 1e-18, "cost {}", s.cost);
        assert!(s.std_errors.iter().all(|e| e.is_some_and(|e| e < 1e-6)), "{:?}", s.std_errors);
    }

    /// A parameter the residuals do not depend on leaves the normal matrix singular: no standard
    /// errors; the other parameter still reaches its least-squares value 31/30.
    #[test]
    fn an_undetermined_parameter_has_no_standard_error() {
        let f = |p: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.extend([p[0] - 1.0, 2.0 * p[0] - 2.1, p[0] + 0.5 - 1.5]);
        };
        let s = minimise(&[0.0, 3.0], &f).expect("a solution");
        assert!((s.params[0] - 31.0 / 30.0).abs() < 1e-6, "{:?}", s.params);
        assert_eq!(s.std_errors, vec![None, None]);
    }
}
