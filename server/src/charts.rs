//! Charts as SVG (plotters): a study's error against cost on log-log axes (one series per
//! label, the Pareto front, each point labelled with its swept value, failed runs marked), a
//! stability search's probes against the theory, and sample fields of jobs against time or
//! strain.

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
}
