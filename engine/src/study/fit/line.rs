//! The least-squares straight line, with the standard errors of its constants.

/// A least-squares line.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Line {
    /// Its value at x = 0.
    pub(crate) intercept: f64,
    /// Its slope.
    pub(crate) slope: f64,
    /// Standard error of the intercept (none from two points).
    pub(crate) intercept_error: Option<f64>,
    /// Standard error of the slope (none from two points).
    pub(crate) slope_error: Option<f64>,
    /// Sum of the squared residuals.
    pub(crate) squares: f64,
    /// Smallest x of the points.
    pub(crate) x_min: f64,
    /// Largest x of the points.
    pub(crate) x_max: f64,
}

/// The least-squares line through `(x, y)`, with the standard errors of its two constants (none
/// with two points); `None` without two distinct x.
pub(crate) fn line(p: &[(f64, f64)]) -> Option<Line> {
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    if p.len() < 2 || sxx <= 1e-12 * mx.abs().max(1e-30).powi(2) {
        return None;
    }
    let slope = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum::<f64>() / sxx;
    let intercept = my - slope * mx;
    let squares: f64 = p.iter().map(|q| (q.1 - intercept - slope * q.0).powi(2)).sum();
    let s2 = (p.len() > 2).then(|| squares / (n - 2.0));
    Some(Line {
        intercept,
        slope,
        slope_error: s2.map(|s2| (s2 / sxx).sqrt()),
        intercept_error: s2.map(|s2| (s2 * (1.0 / n + mx * mx / sxx)).sqrt()),
        squares,
        x_min: p.iter().map(|q| q.0).fold(f64::INFINITY, f64::min),
        x_max: p.iter().map(|q| q.0).fold(f64::NEG_INFINITY, f64::max),
    })
}
