//! `sable advise`: the method advisor's answer for a scene file, without running it.

use std::path::PathBuf;

use sable_engine::advise::Advice;

/// Arguments of `sable advise`.
#[derive(Debug, clap::Args)]
pub struct AdviseArgs {
    /// Scene file (JSON); its `method` may be `auto` or a method's name.
    pub scene: PathBuf,
    /// Print the advice as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `sable advise`.
pub fn advise(a: AdviseArgs) -> anyhow::Result<()> {
    let scene = super::run::load_scene(&a.scene)?;
    let advice = scene.advice();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&advice)?);
    } else {
        print!("{}", render(&advice));
    }
    Ok(())
}

/// The advice as text for a terminal.
pub fn render(a: &Advice) -> String {
    let mut s = String::new();
    let choice = if a.requested == "auto" || a.requested == a.method {
        format!("method: {}", a.method)
    } else {
        format!("method: {} (the scene asks for {})", a.method, a.requested)
    };
    s.push_str(&format!("{choice}; regime: {}\n", a.regime.name()));
    for r in &a.reasons {
        s.push_str(&format!("  because {r}\n"));
    }
    if let Some(n) = &a.needs {
        s.push_str(&format!("  needs {n}\n"));
    }
    for d in &a.dropped {
        s.push_str(&format!("  left out: {d}\n"));
    }
    for x in &a.suggestions {
        s.push_str(&format!("  suggestion: {x}\n"));
    }
    for c in &a.expected_cost {
        let e = c.error.map_or("—".to_string(), |e| format!("{e:.2e}"));
        let front = if c.pareto { ", on the Pareto front" } else { "" };
        s.push_str(&format!(
            "  study {} measured {} ({} {}): {:.3} CPU s, error {e}{front}\n",
            c.study_id, c.method, c.series, c.label, c.cpu_seconds
        ));
    }
    let n = &a.numbers;
    let opt = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{v:.3e}"));
    s.push_str(&format!(
        "numbers: d = {:.3e} m, ρ = {:.0} kg/m³, Φ0 = {:.3}, p = {} Pa ({}), ε̇ = {} 1/s ({})\n",
        n.mean_diameter,
        n.density,
        n.initial_solid_fraction,
        opt(n.pressure),
        n.pressure_source.as_deref().unwrap_or("none"),
        opt(n.strain_rate),
        n.strain_rate_source.as_deref().unwrap_or("none"),
    ));
    s.push_str(&format!(
        "         I = {}, κ = {}, 1/κ = {}, ξ = {}, St = {}\n",
        opt(n.inertial_number),
        opt(n.stiffness_number),
        opt(n.deflection),
        opt(n.cohesion_index),
        opt(n.stokes_number)
    ));
    s
}
