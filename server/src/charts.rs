//! Charts as SVG (plotters): a study's error against cost on log-log axes (one series per
//! label, the Pareto front, each point labelled with its swept value, failed runs marked), a
//! stability search's probes against the theory, and sample fields of jobs against time or
//! strain.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use sable_engine::study::report::StudyReport;
use sable_engine::study::search::FailureMode;

/// Chart size, px.
const SIZE: (u32, u32) = (960, 640);
/// Series colours (a colour-blind-safe palette; red is kept for failures).
const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(120, 94, 240),
];
const FAILED: RGBColor = RGBColor(213, 94, 0);

/// The font every chart is set in (DejaVu Sans, embedded: no system fonts needed; licence in
/// server/assets/DejaVuSans-LICENSE.txt).
static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the embedded font under the family name the charts use, once.
fn fonts() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).map_err(|_| "the embedded font cannot be read".to_string())
    })
    .clone()
}

/// How a chart is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// SVG text (`image/svg+xml`).
    Svg,
    /// PNG image (`image/png`).
    Png,
}

impl Format {
    /// The MIME type.
    pub fn content_type(self) -> &'static str {
        match self {
            Self::Svg => "image/svg+xml",
            Self::Png => "image/png",
        }
    }
}

/// A chart that can be drawn on any plotters backend.
trait Chart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Draws `chart` on a white canvas and encodes it.
fn render(chart: &impl Chart, format: Format) -> Result<Vec<u8>, String> {
    fonts()?;
    match format {
        Format::Svg => {
            let mut out = String::new();
            {
                let root = SVGBackend::with_string(&mut out, SIZE).into_drawing_area();
                root.fill(&WHITE).map_err(err)?;
                chart.draw(&root)?;
                root.present().map_err(err)?;
            }
            Ok(out.into_bytes())
        }
        Format::Png => {
            let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
                root.fill(&WHITE).map_err(err)?;
                chart.draw(&root)?;
                root.present().map_err(err)?;
            }
            let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb).ok_or("the chart's pixels do not fill the image")?;
            let mut png = std::io::Cursor::new(Vec::new());
            img.write_to(&mut png, image::ImageOutputFormat::Png).map_err(err)?;
            Ok(png.into_inner())
        }
    }
}

fn err<E: std::fmt::Display>(e: E) -> String {
    format!("cannot draw the chart: {e}")
}

/// A log axis range around positive values.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.filter(|v| v.is_finite() && *v > 0.0).fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    let (lo, hi) = if hi / lo < 10.0 { (lo / 3.0, hi * 3.0) } else { (lo / 1.6, hi * 1.6) };
    (lo, hi)
}

/// The chart of a study: error against cost for a sweep, the probes for a search.
pub fn study(name: &str, report: &StudyReport, format: Format) -> Result<Vec<u8>, String> {
    struct Study<'a>(&'a str, &'a StudyReport);
    impl Chart for Study<'_> {
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
            if self.1.limit.is_some() || self.1.points.iter().any(|p| p.value.is_some()) {
                search_chart(root, self.0, self.1)
            } else if let Some(f) = self.1.fit.as_ref().filter(|f| !f.panels.is_empty()) {
                fit_chart(root, self.0, f)
            } else {
                sweep_chart(root, self.0, self.1)
            }
        }
    }
    render(&Study(name, report), format)
}

/// Font size of a chart's title, and of the lines under it (px).
const TITLE_SIZE: f64 = 22.0;
const LINE_SIZE: f64 = 13.0;

/// `text` cut at a word so that it and `reserve` more characters fit across the chart in a
/// sans-serif font of `size` px (a character taken as 0.55 of the size, a little wider than
/// the mean), with "…" where it was cut: study names run long and were clipped at both sides.
fn fit(text: &str, size: f64, reserve: usize) -> String {
    fit_along(text, size, f64::from(SIZE.0) - 40.0, reserve)
}

/// [`fit`] along `length` px (the height, for an axis' description).
fn fit_along(text: &str, size: f64, length: f64, reserve: usize) -> String {
    let room = (length / (0.55 * size)) as usize;
    let room = room.saturating_sub(reserve).max(8);
    if text.chars().count() <= room {
        return text.to_string();
    }
    let cut: String = text.chars().take(room - 1).collect();
    let at = cut.rfind(' ').filter(|&i| i > cut.len() / 2).unwrap_or(cut.len());
    format!("{}…", cut[..at].trim_end_matches([' ', ',', ':', ';', '(']))
}

/// A title and up to two lines under it, centred at the top of the chart (each cut to fit).
fn titles<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, title: &str, lines: &[String]) -> Result<(), String> {
    let centre = |size: f64| TextStyle::from(("sans-serif", size).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
    let x = SIZE.0 as i32 / 2;
    root.draw(&Text::new(fit(title, TITLE_SIZE, 0), (x, 10), centre(TITLE_SIZE))).map_err(err)?;
    for (k, line) in lines.iter().take(2).enumerate() {
        root.draw(&Text::new(fit(line, LINE_SIZE, 0), (x, 38 + 18 * k as i32), centre(LINE_SIZE))).map_err(err)?;
    }
    Ok(())
}

fn sweep_chart<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, name: &str, report: &StudyReport) -> Result<(), String> {
    // Cost: CPU seconds when measured, else wall seconds.
    let cpu = report.points.iter().any(|p| p.cost.cpu_seconds > 0.0);
    let cost = |p: &sable_engine::study::report::PointReport| if cpu { p.cost.cpu_seconds } else { p.cost.wall_seconds };
    // Relative errors when every run's reference is known and not zero.
    let refs: Vec<f64> = report.points.iter().filter_map(|p| p.reference).collect();
    let relative = !refs.is_empty() && refs.iter().all(|r| *r != 0.0);
    let error = |p: &sable_engine::study::report::PointReport| if relative { p.relative_error } else { p.error };
    let (x0, x1) = log_range(report.points.iter().map(cost));
    let (y0, y1) = log_range(report.points.iter().filter_map(error));
    // A run that matches the reference exactly (the reference run itself) sits on the floor.
    let floor = y0 * 1.2;
    let reference = match report.reference {
        Some(r) => format!("reference {r:.4} ({})", report.reference_source),
        None if !refs.is_empty() => format!("reference: {}", report.reference_source),
        None => format!("reference not known yet ({})", report.reference_source),
    };
    let suffix = ": error against cost";
    let caption = format!("{}{suffix}", fit(name, TITLE_SIZE, suffix.len()));
    let mut chart = ChartBuilder::on(root)
        .margin(18)
        .margin_top(80)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    let swept: Vec<String> =
        report.swept.iter().filter(|(_, p)| !p.is_empty()).map(|(label, p)| format!("{label}: {}", p.join(", "))).collect();
    let mut lines = vec![reference];
    if !swept.is_empty() {
        lines.push(format!("points labelled by {}", swept.join("; ")));
    }
    titles(root, &caption, &lines)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| format!("{v:.2e}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .x_desc(if cpu { "cost: CPU time of the run, s" } else { "cost: wall-clock time of the run, s" })
        // Two models' measures (one per series) run long: cut to the axis' height.
        .y_desc(fit_along(
            &format!("{} error of {}", if relative { "relative" } else { "absolute" }, report.measure),
            15.0,
            f64::from(SIZE.1) - 140.0,
            0,
        ))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    let mut labels: Vec<String> = Vec::new();
    for p in &report.points {
        if !labels.contains(&p.series) {
            labels.push(p.series.clone());
        }
    }
    for (k, series) in labels.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let mut pts: Vec<(f64, f64, String)> = report
            .points
            .iter()
            .filter(|p| &p.series == series && p.state == "succeeded")
            .filter_map(|p| error(p).map(|e| (cost(p).max(x0), if e > 0.0 { e } else { floor }, p.label.clone())))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, p.1)), colour.stroke_width(1))).map_err(err)?;
        chart
            .draw_series(pts.iter().map(|p| Circle::new((p.0, p.1), 5, colour.filled())))
            .map_err(err)?
            .label(series.as_str())
            .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
        chart
            .draw_series(
                pts.iter().map(|p| EmptyElement::at((p.0, p.1)) + Text::new(p.2.clone(), (7, -14), ("sans-serif", 12).into_font())),
            )
            .map_err(err)?;
    }
    // The Pareto front.
    let mut front: Vec<(f64, f64)> = report
        .points
        .iter()
        .filter(|p| p.pareto)
        .filter_map(|p| error(p).map(|e| (cost(p).max(x0), if e > 0.0 { e } else { floor })))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    if !front.is_empty() {
        chart.draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2))).map_err(err)?;
        chart
            .draw_series(front.iter().map(|&p| Circle::new(p, 9, BLACK.stroke_width(2))))
            .map_err(err)?
            .label("Pareto front")
            .legend(|(x, y)| Circle::new((x, y), 7, BLACK.stroke_width(2)));
    }
    // Failed runs, along the top edge at their cost.
    let failed: Vec<(f64, String)> = report
        .points
        .iter()
        .filter(|p| p.state != "succeeded" && p.state != "queued" && p.state != "running")
        .map(|p| {
            let mode = p.failure.map_or("failed", |f| f.name());
            (cost(p).clamp(x0, x1), format!("{} {}: {mode}", p.series, p.label))
        })
        .collect();
    if !failed.is_empty() {
        let top = y1 / 1.3;
        chart
            .draw_series(failed.iter().map(|(x, _)| Cross::new((*x, top), 7, FAILED.stroke_width(3))))
            .map_err(err)?
            .label("failed run (unstable)")
            .legend(|(x, y)| Cross::new((x, y), 6, FAILED.stroke_width(3)));
        chart
            .draw_series(failed.iter().enumerate().map(|(k, (x, l))| {
                EmptyElement::at((*x, top))
                    + Text::new(l.clone(), (8, 6 + 14 * (k as i32 % 3)), ("sans-serif", 12).into_font().color(&FAILED))
            }))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerLeft)
        .draw()
        .map_err(err)?;
    Ok(())
}

/// A fitted law: one panel per pair of axes, side by side, the runs as points and each law as a
/// line; the fitted constants and their published values under the title.
fn fit_chart<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, name: &str, f: &sable_engine::study::fit::FitReport) -> Result<(), String> {
    let constants: Vec<String> = f
        .constants
        .iter()
        .filter(|c| c.published.is_some())
        .map(|c| match (c.value, c.published) {
            (Some(v), Some(p)) => format!("{} {} ({})", c.name, brief(v), brief(p)),
            (None, Some(p)) => format!("{} — ({})", c.name, brief(p)),
            _ => c.name.clone(),
        })
        .collect();
    let suffix = format!(": the law {} fitted over {} runs", f.law, f.runs.len());
    let caption = format!("{}{suffix}", fit(name, TITLE_SIZE, suffix.len()));
    // A law published as trends has no constants to set side by side: its formula instead.
    let first = if constants.is_empty() { f.formula.clone() } else { format!("fitted (published): {}", constants.join(", ")) };
    titles(root, &caption, &[first, format!("published: {}", f.source)])?;
    let area = root.margin(80, 0, 0, 0);
    let panels = area.split_evenly((1, f.panels.len().max(1)));
    for (panel, area) in f.panels.iter().zip(panels.iter()) {
        let xs: Vec<f64> = panel.points.iter().map(|p| p.1).chain(panel.curves.iter().flat_map(|c| c.1.iter().map(|p| p[0]))).collect();
        let ys: Vec<f64> = panel.points.iter().map(|p| p.2).chain(panel.curves.iter().flat_map(|c| c.1.iter().map(|p| p[1]))).collect();
        let lin = |v: &f64| format!("{v:.3}");
        let log = |v: &f64| format!("{v:.0e}");
        let ylin = |v: &f64| format!("{v:.2}");
        let positive = |v: &Vec<f64>| v.iter().copied().filter(|x| *x > 0.0).collect::<Vec<_>>();
        match (panel.log_x, panel.log_y) {
            (true, true) => {
                let ((x0, x1), (y0, y1)) = (log_range(positive(&xs).into_iter()), log_range(positive(&ys).into_iter()));
                fit_panel(area, panel, (x0..x1).log_scale(), (y0..y1).log_scale(), &log, &log)?;
            }
            (true, false) => {
                let ((x0, x1), (y0, y1)) = (log_range(positive(&xs).into_iter()), linear_range(&ys));
                fit_panel(area, panel, (x0..x1).log_scale(), y0..y1, &log, &ylin)?;
            }
            (false, true) => {
                let ((x0, x1), (y0, y1)) = (linear_range(&xs), log_range(positive(&ys).into_iter()));
                fit_panel(area, panel, x0..x1, (y0..y1).log_scale(), &lin, &log)?;
            }
            (false, false) => {
                let ((x0, x1), (y0, y1)) = (linear_range(&xs), linear_range(&ys));
                fit_panel(area, panel, x0..x1, y0..y1, &lin, &ylin)?;
            }
        }
    }
    Ok(())
}

/// A number in four significant figures, in scientific form when it is below 1e-2 or from 1e4
/// on (a fitted constant that ran away, a small published prefactor).
pub fn brief(x: f64) -> String {
    if x != 0.0 && (x.abs() < 1e-2 || x.abs() >= 1e4) {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// A linear axis' range: the values' span padded by 5% each side (0..1 without values).
fn linear_range(values: &[f64]) -> (f64, f64) {
    let (lo, hi) = values.iter().filter(|y| y.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| (a.min(*y), b.max(*y)));
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-3 * hi.abs().max(1e-12));
    (lo - pad, hi + pad)
}

/// One panel of a fitted law: the laws as lines (the first black), the runs as dots.
fn fit_panel<DB: DrawingBackend, X: AsRangedCoord<Value = f64>, Y: AsRangedCoord<Value = f64>>(
    area: &DrawingArea<DB, Shift>,
    panel: &sable_engine::study::fit::Panel,
    x: X,
    y: Y,
    x_label: &dyn Fn(&f64) -> String,
    y_label: &dyn Fn(&f64) -> String,
) -> Result<(), String>
where
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area).margin(18).x_label_area_size(50).y_label_area_size(64).build_cartesian_2d(x, y).map_err(err)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_labels(5)
        .y_labels(8)
        .x_label_formatter(x_label)
        .y_label_formatter(y_label)
        .x_desc(panel.x.as_str())
        .y_desc(panel.y.as_str())
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    for (k, (label, line)) in panel.curves.iter().enumerate() {
        let colour = if k == 0 { BLACK } else { PALETTE[(k - 1) % PALETTE.len()] };
        chart
            .draw_series(LineSeries::new(line.iter().map(|p| (p[0], p[1])), colour.stroke_width(2)))
            .map_err(err)?
            .label(label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], colour.stroke_width(2)));
    }
    let dot = PALETTE[1 % PALETTE.len()];
    chart
        .draw_series(panel.points.iter().map(|p| Circle::new((p.1, p.2), 4, dot.filled())))
        .map_err(err)?
        .label("runs")
        .legend(move |(x, y)| Circle::new((x, y), 4, dot.filled()));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(err)?;
    Ok(())
}

fn search_chart<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, name: &str, report: &StudyReport) -> Result<(), String> {
    let values: Vec<f64> = report.points.iter().filter_map(|p| p.value).chain(report.theory.as_ref().map(|t| t.value)).collect();
    let (x0, x1) = log_range(values.into_iter());
    let mut subtitle = report.measure.clone();
    if let Some(l) = &report.limit {
        let v = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{v:.4e}"));
        subtitle.push_str(&format!(
            ": stable at {}, fails at {} ({})",
            v(l.stable),
            v(l.unstable),
            l.mode.map_or("no failure", |m| m.name())
        ));
    }
    if let Some(r) = report.theory.as_ref().and_then(|t| t.ratio) {
        subtitle.push_str(&format!("; measured/theory {r:.3}"));
    }
    titles(root, name, &[subtitle])?;
    let mut chart = ChartBuilder::on(root)
        .margin(18)
        .margin_top(80)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), -0.5f64..1.5f64)
        .map_err(err)?;
    let knob = report.measure.trim_start_matches("stability of ").to_string();
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_labels(6)
        .x_label_formatter(&|v| format!("{v:.2e}"))
        .x_desc(format!("{knob} (log scale)"))
        .y_desc("outcome: 1 = ran through, 0 = failed")
        .y_labels(3)
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(err)?;
    let ended = |p: &&sable_engine::study::report::PointReport| matches!(p.state.as_str(), "succeeded" | "failed" | "cancelled");
    let stable: Vec<f64> = report.points.iter().filter(ended).filter(|p| p.failure.is_none()).filter_map(|p| p.value).collect();
    chart
        .draw_series(stable.iter().map(|v| Circle::new((*v, 1.0), 6, PALETTE[2].filled())))
        .map_err(err)?
        .label("ran through (stable)")
        .legend(|(x, y)| Circle::new((x, y), 6, PALETTE[2].filled()));
    // Failed probes, one colour per failure mode.
    let modes = [FailureMode::BlowUp, FailureMode::ExcessiveOverlap, FailureMode::NonConvergence, FailureMode::Other];
    let colours = [FAILED, PALETTE[3], PALETTE[5], RGBColor(90, 90, 90)];
    for (mode, colour) in modes.into_iter().zip(colours) {
        let xs: Vec<f64> = report.points.iter().filter(ended).filter(|p| p.failure == Some(mode)).filter_map(|p| p.value).collect();
        if xs.is_empty() {
            continue;
        }
        chart
            .draw_series(xs.iter().map(|v| Cross::new((*v, 0.0), 7, colour.stroke_width(3))))
            .map_err(err)?
            .label(format!("failed: {}", mode.name()))
            .legend(move |(x, y)| Cross::new((x, y), 6, colour.stroke_width(3)));
    }
    if let Some(l) = &report.limit {
        if let (Some(a), Some(b)) = (l.stable, l.unstable) {
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            chart
                .draw_series(std::iter::once(Rectangle::new([(lo, -0.5), (hi, 1.5)], PALETTE[0].mix(0.25).filled())))
                .map_err(err)?
                .label(format!("limit: between {a:.4e} and {b:.4e}"))
                .legend(|(x, y)| Rectangle::new([(x - 6, y - 5), (x + 6, y + 5)], PALETTE[0].mix(0.4).filled()));
        }
    }
    if let Some(t) = &report.theory {
        let ratio = t.ratio.map(|r| format!(", measured/theory = {r:.3}")).unwrap_or_default();
        chart
            .draw_series(LineSeries::new([(t.value, -0.5), (t.value, 1.5)], PALETTE[1].stroke_width(2)))
            .map_err(err)?
            .label(format!("theory {:.4e}: {}{ratio}", t.value, t.what))
            .legend(|(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], PALETTE[1].stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(err)?;
    Ok(())
}

/// A chart of sample fields: one line per series of (x, y) points.
pub fn lines(title: &str, x_desc: &str, y_desc: &str, series: &[(String, Vec<(f64, f64)>)], format: Format) -> Result<Vec<u8>, String> {
    struct Lines<'a>(&'a str, &'a str, &'a str, &'a [(String, Vec<(f64, f64)>)]);
    impl Chart for Lines<'_> {
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
            lines_chart(root, self.0, self.1, self.2, self.3)
        }
    }
    render(&Lines(title, x_desc, y_desc, series), format)
}

fn lines_chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), String> {
    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let (mut x0, mut x1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (mut y0, mut y1) = all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = if y1 > y0 { 0.05 * (y1 - y0) } else { 0.5 * y0.abs().max(1e-12) };
    (y0, y1) = (y0 - pad, y1 + pad);
    let mut chart = ChartBuilder::on(root)
        .caption(fit(title, TITLE_SIZE, 0), ("sans-serif", TITLE_SIZE))
        .margin(18)
        .x_label_area_size(56)
        .y_label_area_size(90)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).axis_desc_style(("sans-serif", 15)).draw().map_err(err)?;
    for (k, (label, pts)) in series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))
            .map_err(err)?
            .label(label.as_str())
            .legend(move |(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], colour.stroke_width(2)));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.85)).border_style(BLACK).draw().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Short titles are kept; long ones are cut at a word, with "…", to what fits across the
    /// chart, leaving room for a suffix.
    #[test]
    fn long_titles_are_cut_at_a_word_to_fit() {
        assert_eq!(fit("restitution_dem", TITLE_SIZE, 0), "restitution_dem");
        let name = "Soft-grain compaction (Nezamabadi 2020, §2.1, 300 grains): the exponent of Z - Z_J against Phi - Phi_J for each law";
        let room = ((f64::from(SIZE.0) - 40.0) / (0.55 * TITLE_SIZE)) as usize;
        let cut = fit(name, TITLE_SIZE, 20);
        assert!(cut.ends_with('…') && cut.chars().count() <= room - 20, "{cut}");
        let kept = cut.trim_end_matches('…');
        assert!(name.starts_with(kept) && name[kept.len()..].starts_with(' '), "not cut at a word: {cut}");
    }

    /// A study with a fitted law is drawn as the law's panels: each axis named, both laws in
    /// the legend, the fitted and published constants under the title.
    #[test]
    fn a_fitted_law_is_drawn_as_its_panels() {
        use sable_engine::study::fit::{law, RunResult};
        // Steady states on μ = 0.3 (1 + 1.1/(1 + 0.095/I_m)), Φ = 0.6/(1 + I_m/2.01), at two
        // cohesion indices and two Stokes numbers.
        let mut values = Vec::new();
        for xi in [0.0f64, 2.0] {
            for i in [0.003f64, 0.01, 0.03, 0.1] {
                for st in [1e3f64, 0.1] {
                    let i_m: f64 = i * ((1.0 + 0.075 / st) / (1.0 + 0.062 * xi)).sqrt();
                    values
                        .push(serde_json::json!({"shear": {"mu": 0.3 * (1.0 + 1.1 / (1.0 + 0.095 / i_m)), "phi": 0.6 / (1.0 + i_m / 2.01),
                        "inertial_number": i, "cohesion_index": xi, "stokes_number": st}}));
                }
            }
        }
        let runs: Vec<RunResult<'_>> = values.iter().enumerate().map(|(index, result)| RunResult { index, result }).collect();
        let fitted = law("wet_rheology").expect("a law").fit(&runs).expect("a fit");
        let report = StudyReport {
            measure: "result shear.mu".into(),
            reference: None,
            reference_source: "none".into(),
            swept: Vec::new(),
            points: Vec::new(),
            limit: None,
            theory: None,
            fit: Some(fitted),
            fit_note: None,
        };
        let svg = String::from_utf8(study("wet rheology", &report, Format::Svg).expect("a chart")).expect("UTF-8");
        for text in ["mu / mu_c", "phi / phi_c", "Vo et al. 2020", "fitted", "alpha 0.0620 (0.0620)", "over 16 runs"] {
            assert!(svg.contains(text), "no '{text}' in the chart");
        }
    }
}
