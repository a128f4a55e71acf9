//! `sable study FILE [--watch] [--chart out.svg]`: submit a study to a server, follow it, print
//! its report and save its chart; `sable study --show ID` for one submitted before.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use sable_engine::study::report::StudyReport;

use super::service::ServerArg;

/// Arguments of `sable study`.
#[derive(Debug, Args)]
pub struct StudyArgs {
    /// Study file (JSON, docs/studies.md); its `scene` may also be a path to a scene file.
    #[arg(required_unless_present = "show")]
    pub file: Option<PathBuf>,
    /// Show the study with this id instead of submitting one.
    #[arg(long, conflicts_with = "file")]
    pub show: Option<i64>,
    #[command(flatten)]
    server: ServerArg,
    /// Follow the study until its runs have all ended, then print its report.
    #[arg(long)]
    pub watch: bool,
    /// Write the study's chart to this file, PNG if it ends in .png, else SVG (after --watch,
    /// the final one).
    #[arg(long)]
    pub chart: Option<PathBuf>,
    /// Print the study as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Reads a study file; a `scene` given as a string is read as a scene file relative to it.
fn read_study(path: &PathBuf) -> anyhow::Result<String> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let Ok(mut v) = serde_json::from_str::<serde_json::Value>(&text) else { return Ok(text) };
    if let Some(rel) = v.get("scene").and_then(|s| s.as_str()).map(str::to_string) {
        let scene_path = path.parent().unwrap_or(std::path::Path::new(".")).join(&rel);
        let (scene, _) = super::run::read_scene_text(&scene_path)?;
        v["scene"] = serde_json::from_str(&scene).with_context(|| format!("{} is not JSON", scene_path.display()))?;
    }
    Ok(v.to_string())
}

/// `sable study`.
pub fn study(a: StudyArgs) -> anyhow::Result<()> {
    let text = a.file.as_ref().map(read_study).transpose()?;
    super::service::runtime()?.block_on(async move {
        let mut client = a.server.connect().await?;
        let mut s = match (a.show, text) {
            (Some(id), _) => client.study(id).await?,
            (None, Some(t)) => {
                let s = client.create_study(&t).await?;
                eprintln!("study {} accepted: {} ({} runs queued)", s.id, s.name, s.runs);
                s
            }
            (None, None) => anyhow::bail!("give a study file or --show ID"),
        };
        if a.watch {
            let mut last = (u32::MAX, u32::MAX);
            while s.state == "running" {
                if (s.runs_done, s.runs) != last {
                    eprintln!("study {}: {} of {} runs ended", s.id, s.runs_done, s.runs);
                    last = (s.runs_done, s.runs);
                }
                tokio::time::sleep(Duration::from_millis(500)).await;
                s = client.study(s.id).await?;
            }
            eprintln!("study {}: {}", s.id, s.state);
        }
        if a.json {
            let report: serde_json::Value = serde_json::from_str(&s.report_json).unwrap_or(serde_json::Value::Null);
            println!(
                "{}",
                serde_json::json!({"id": s.id, "name": s.name, "kind": s.kind, "state": s.state, "runs_done": s.runs_done, "runs": s.runs,
                    "created_at": s.created_at, "finished_at": s.finished_at, "error": s.error, "report": report})
            );
        } else {
            println!("study {} '{}' ({}): {}, {} of {} runs ended", s.id, s.name, s.kind, s.state, s.runs_done, s.runs);
            if let Ok(r) = serde_json::from_str::<StudyReport>(&s.report_json) {
                print!("{}", render(&r));
            }
        }
        if let Some(path) = &a.chart {
            let format = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) { "png" } else { "svg" };
            let bytes = client.study_chart(s.id, format).await?;
            std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!("chart written to {}", path.display());
        }
        Ok(())
    })
}

/// A report as a table.
pub fn render(r: &StudyReport) -> String {
    let mut out = format!("measure: {}\n", r.measure);
    match r.reference {
        Some(v) => out.push_str(&format!("reference: {v:.6e} ({})\n", r.reference_source)),
        None if !r.reference_source.is_empty() => out.push_str(&format!("reference: {}\n", r.reference_source)),
        None => {}
    }
    out.push_str(&format!(
        "{:>4}  {:<10}  {:<18}  {:<9}  {:>7}  {:>10}  {:>10}  {:>12}  {:>11}  {:>10}  pareto\n",
        "run", "series", "values", "state", "job", "steps", "cpu s", "measured", "rel. error", "sweeps"
    ));
    for p in &r.points {
        let num = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{v:.4e}"));
        let state = match p.failure {
            Some(f) if p.state == "failed" => f.name().to_string(),
            _ => p.state.clone(),
        };
        out.push_str(&format!(
            "{:>4}  {:<10}  {:<18}  {:<9}  {:>7}  {:>10}  {:>10.3e}  {:>12}  {:>11}  {:>10}  {}\n",
            p.index,
            p.series,
            p.label,
            state,
            p.job_id,
            p.cost.steps,
            p.cost.cpu_seconds,
            num(p.measured),
            num(p.relative_error.or(p.error)),
            p.cost.solver_iterations,
            if p.pareto { "*" } else { "" }
        ));
    }
    if let Some(l) = &r.limit {
        let v = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{v:.5e}"));
        out.push_str(&format!(
            "limit: stable at {}, fails at {} ({})\n",
            v(l.stable),
            v(l.unstable),
            l.mode.map_or("no failure seen", |m| m.name())
        ));
        if let Some(n) = &l.note {
            out.push_str(&format!("note: {n}\n"));
        }
    }
    if let Some(f) = &r.fit {
        out.push_str(&format!("fit: {} over {} runs, rms residual {:.3e}\n  {}\n", f.law, f.runs.len(), f.rms, f.formula));
        out.push_str(&format!("  {:<18}  {:>11}  {:>10}  {:>10}  {:>10}\n", "constant", "fitted", "± std", "published", "difference"));
        for c in &f.constants {
            let num = |x: Option<f64>| x.map_or("—".to_string(), sable_server::charts::brief);
            out.push_str(&format!(
                "  {:<18}  {:>11}  {:>10}  {:>10}  {:>10}\n",
                c.name,
                num(c.value),
                num(c.std_error),
                c.published.map_or(String::new(), sable_server::charts::brief),
                c.difference.map_or(String::new(), |d| if d.abs() < 10.0 {
                    format!("{:+.1}%", 100.0 * d)
                } else {
                    format!("×{}", sable_server::charts::brief(1.0 + d))
                })
            ));
        }
        for n in &f.notes {
            out.push_str(&format!("  note: {n}\n"));
        }
        out.push_str(&format!("  published: {}\n", f.source));
    }
    if let Some(n) = &r.fit_note {
        out.push_str(&format!("fit: none yet: {n}\n"));
    }
    if let Some(t) = &r.theory {
        out.push_str(&format!(
            "theory: {:.5e} ({}){}\n",
            t.value,
            t.what,
            t.ratio.map(|x| format!("; measured/theory = {x:.4}")).unwrap_or_default()
        ));
    }
    out
}
