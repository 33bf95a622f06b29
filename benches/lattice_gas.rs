//! Site updates per second of the FHP lattice gas on periodic lattices of 1024^2 and 4096^2,
//! for the lookup-table CPU, multi-spin CPU and GPU backends (FHP-I, d = 0.3).
//!
//! ```text
//! cargo bench --bench lattice_gas
//! ```
//! Criterion reports "elements/s" = site updates/s.

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::GpuContext;
use simkit::lattice_gas::{Engine, Lattice, Params, simulation};

fn bench(c: &mut Criterion) {
    let gpu = GpuContext::new().ok();
    let mut group = c.benchmark_group("fhp_site_updates");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(3));
    for n in [1024usize, 4096] {
        let mut lattice = Lattice::new(n, n).expect("size");
        lattice.fill_random(0.3, 1).expect("density");
        let mut engines = vec![("lut", Engine::Lut), ("multispin", Engine::MultiSpin)];
        if let Some(ctx) = gpu.as_ref() {
            engines.push(("gpu", Engine::Gpu(ctx)));
        }
        for (name, engine) in engines {
            let steps: u32 = if n == 1024 { 8 } else { 2 };
            let mut sim = simulation(lattice.clone(), Params::default(), engine).expect("backend");
            group.throughput(Throughput::Elements((n * n) as u64 * u64::from(steps)));
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| {
                    sim.step(steps).expect("step");
                    if let Engine::Gpu(ctx) = engine {
                        // Include the device time: wait for the queue to drain.
                        ctx.wait().expect("sync");
                    }
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
