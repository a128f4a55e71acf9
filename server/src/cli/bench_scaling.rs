//! `sable bench dem --scene NAME --scaling 1000,10000,...`: the cost of a particle-step against
//! the number of particles. The suite scene's box grows with the count at the same density, so
//! a flat cost means no stage grows faster than the particles (neighbour search, gather, memory
//! traffic beyond the caches). The counts run in alternated rounds (ascending, then descending)
//! so that the machine's drifting speed does not pass for a trend. Never a pass/fail test.

use std::path::Path;

use anyhow::Context;
use serde::Serialize;

use super::bench_dem::{measure, BenchArgs, BenchResult};
use sable_engine::methods::dem::bench_suite::SUITE;

/// One count's runs.
#[derive(Debug, Serialize)]
struct Point {
    particles: usize,
    steps: u64,
    threads: usize,
    /// Nanoseconds per particle-step, one per round.
    ns_per_particle_step: Vec<f64>,
    median_ns: f64,
    bytes_per_particle: f64,
    neighbor_pairs_per_particle: f64,
    interacting_pairs_per_particle: f64,
}

#[derive(Debug, Serialize)]
struct Sweep {
    scene: String,
    points: Vec<Point>,
    /// Largest median cost over the smallest, minus one.
    spread: f64,
    /// Peak resident memory of the process over the sweep, bytes (Linux; the largest count's run
    /// sets it).
    peak_rss_bytes: Option<u64>,
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Smallest and largest of `v`.
fn range(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

/// Peak resident set of this process, bytes (`VmHWM` of /proc/self/status).
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Runs the sweep of `a.scaling`.
pub fn sweep(a: &BenchArgs) -> anyhow::Result<()> {
    if !SUITE.contains(&a.scene.as_str()) {
        anyhow::bail!("--scaling: --scene must be a scene of the suite ({}), not {:?}", SUITE.join(", "), a.scene);
    }
    if let Some(&bad) = a.scaling.iter().find(|&&n| n == 0) {
        anyhow::bail!("--scaling: every count must be at least 1 (got {bad})");
    }
    if a.particles.is_some() || a.lammps_data.is_some() || a.save_state.is_some() {
        anyhow::bail!("--scaling: cannot be combined with --particles, --lammps-data or --save-state");
    }
    if a.rounds == 0 {
        anyhow::bail!("--rounds: must be at least 1");
    }
    let mut counts = a.scaling.clone();
    counts.sort_unstable();
    counts.dedup();
    let mut runs: Vec<Vec<BenchResult>> = counts.iter().map(|_| Vec::new()).collect();
    for round in 0..a.rounds {
        let order: Vec<usize> = if round % 2 == 0 { (0..counts.len()).collect() } else { (0..counts.len()).rev().collect() };
        for k in order {
            let r = measure(a, Some(counts[k]))?;
            eprintln!(
                "scaling round {}: {} particles x {} steps: {:.2} ns/particle-step, {:.0} B/particle",
                round + 1,
                r.particles,
                r.steps,
                1e9 / r.particle_steps_per_second,
                r.bytes_per_particle
            );
            runs[k].push(r);
        }
    }
    let points: Vec<Point> = runs
        .iter()
        .map(|rs| {
            let ns: Vec<f64> = rs.iter().map(|r| 1e9 / r.particle_steps_per_second).collect();
            let last = &rs[rs.len() - 1];
            let n = last.particles as f64;
            Point {
                particles: last.particles,
                steps: last.steps,
                threads: last.threads,
                median_ns: median(&ns),
                ns_per_particle_step: ns,
                bytes_per_particle: last.bytes_per_particle,
                neighbor_pairs_per_particle: last.neighbor_pairs as f64 / n,
                interacting_pairs_per_particle: last.interacting_pairs as f64 / n,
            }
        })
        .collect();
    let medians: Vec<f64> = points.iter().map(|p| p.median_ns).collect();
    let (lo, hi) = range(&medians);
    let s = Sweep { scene: a.scene.clone(), spread: hi / lo - 1.0, points, peak_rss_bytes: peak_rss() };
    if let Some(path) = &a.chart {
        write_chart(&s, path)?;
    }
    if a.json {
        println!("{}", serde_json::to_string(&s)?);
        return Ok(());
    }
    println!(
        "| particles | steps | threads | ns per particle-step: range (median) | B/particle | listed pairs/particle | contacts/particle |"
    );
    println!("|---|---|---|---|---|---|---|");
    for p in &s.points {
        let (min, max) = range(&p.ns_per_particle_step);
        println!(
            "| {} | {} | {} | {:.2}–{:.2} ({:.2}) | {:.0} | {:.2} | {:.3} |",
            p.particles,
            p.steps,
            p.threads,
            min,
            max,
            p.median_ns,
            p.bytes_per_particle,
            p.neighbor_pairs_per_particle,
            p.interacting_pairs_per_particle
        );
    }
    println!("spread of the medians (slowest / fastest - 1): {:.1}%", 100.0 * s.spread);
    if let Some(rss) = s.peak_rss_bytes {
        println!("peak resident memory of the sweep: {:.1} MiB", rss as f64 / (1024.0 * 1024.0));
    }
    Ok(())
}

/// The median and the range of the cost against log10 of the count.
fn write_chart(s: &Sweep, path: &Path) -> anyhow::Result<()> {
    let series = |label: &str, f: &dyn Fn(&Point) -> f64| {
        (label.to_string(), s.points.iter().map(|p| ((p.particles as f64).log10(), f(p))).collect())
    };
    let threads = s.points.first().map_or(1, |p| p.threads);
    let all = [
        series("median", &|p| p.median_ns),
        series("fastest round", &|p| range(&p.ns_per_particle_step).0),
        series("slowest round", &|p| range(&p.ns_per_particle_step).1),
    ];
    let format = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        sable_server::charts::Format::Png
    } else {
        sable_server::charts::Format::Svg
    };
    let title = format!("DEM {}: cost per particle-step, {} thread(s)", s.scene, threads);
    let bytes =
        sable_server::charts::lines(&title, "log10(particles)", "ns per particle-step", &all, format).map_err(anyhow::Error::msg)?;
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))?;
    eprintln!("chart written to {}", path.display());
    Ok(())
}
