#![allow(missing_docs)] // criterion_group! generates an undocumented public function.
//! Criterion benchmark of soft-contact DEM on the standard scene
//! (`sable_engine::scene::presets::dem_benchmark`): throughput is reported in particle-steps.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sable_engine::methods::plan_scene;
use sable_engine::scene::presets::dem_benchmark;

const STEPS_PER_ITER: u64 = 20;

fn bench_dem(c: &mut Criterion) {
    let mut group = c.benchmark_group("dem");
    group.sample_size(10);
    for threads in [1usize, 2] {
        let n = 20_000;
        let scene = plan_scene(&dem_benchmark(n, 1_000_000, threads).to_string()).expect("benchmark scene is valid");
        let mut sim = scene.build().expect("benchmark scene builds");
        group.throughput(Throughput::Elements(n as u64 * STEPS_PER_ITER));
        group.bench_function(format!("standard_20k_{threads}threads"), |b| {
            b.iter(|| {
                for _ in 0..STEPS_PER_ITER {
                    sim.step().expect("benchmark scene is stable");
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_dem);
criterion_main!(benches);
