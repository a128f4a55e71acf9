#![allow(missing_docs)] // criterion_group! generates an undocumented public function.
//! Criterion benchmark of contact dynamics on the dense pile of
//! `sable_engine::scene::presets::cd_benchmark`: throughput in local solves (contacts × NLGS
//! sweeps), counted step by step after the pile has formed.

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use sable_engine::methods::cd::Cd;
use sable_engine::methods::cd::CdParams;
use sable_engine::methods::plan_scene;
use sable_engine::run::Simulation;
use sable_engine::scene::presets::cd_benchmark;

fn bench_cd(c: &mut Criterion) {
    let mut group = c.benchmark_group("cd");
    group.sample_size(10);
    let n = 20_000;
    let scene = plan_scene(&cd_benchmark(n, 1_000_000, 1).to_string()).expect("benchmark scene is valid");
    let Some(params) = scene.params::<CdParams>() else { panic!("the benchmark scene uses method cd") };
    let mut sim = Cd::new(&scene, params).expect("benchmark scene builds");
    for _ in 0..20 {
        sim.step().expect("benchmark scene is stable");
    }
    // The work of a step varies (sweeps to converge): time it and report contact-iterations
    // per second alongside criterion's time per step.
    let (mut work, mut seconds) = (0u64, 0.0);
    group.bench_function("dense_pile_20k_step", |b| {
        b.iter(|| {
            let start = Instant::now();
            sim.step().expect("benchmark scene is stable");
            seconds += start.elapsed().as_secs_f64();
            let r = sim.solver_report();
            work += r.contacts as u64 * u64::from(r.iterations);
        })
    });
    group.finish();
    if seconds > 0.0 {
        println!("cd/dense_pile_20k: {:.3e} contact-iterations/s", work as f64 / seconds);
    }
}

criterion_group!(benches, bench_cd);
criterion_main!(benches);
