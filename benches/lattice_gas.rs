//! Site updates per second of the FHP lattice gas on periodic lattices of 1024^2 and 4096^2,
//! for the lookup-table CPU (AVX-512 VBMI where present, and the scalar loop), multi-spin CPU
//! and both GPU layouts (bit-planes and bytes with the table in workgroup memory), FHP-I,
//! d = 0.3; and the multi-spin backend with the full collision table (`multispin-full`; the
//! table lookup costs the same for both rule sets).
//!
//! ```text
//! cargo bench --bench lattice_gas
//! ```
//! Criterion reports "elements/s" = site updates/s.

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{GpuContext, Simulation};
use simkit::lattice_gas::{Config, GpuLattice, GpuLayout, Lattice, LutCpu, MultiSpinCpu, RuleSet};

fn bench(c: &mut Criterion) {
    let gpu = GpuContext::new().ok();
    let mut group = c.benchmark_group("fhp_site_updates");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(3));
    for n in [1024usize, 4096] {
        let mut lattice = Lattice::new(n, n).expect("size");
        lattice.fill_random(0.3, 1).expect("density");
        let p = Config::default();
        let full = Config {
            rules: RuleSet::Full,
            ..Config::default()
        };
        type Sim = Box<dyn Simulation<State = Lattice>>;
        let mut sims: Vec<(&str, Sim)> = vec![
            (
                "lut",
                Box::new(LutCpu::new(lattice.clone(), &p).expect("lut")),
            ),
            (
                "lut-scalar",
                Box::new(
                    LutCpu::new(lattice.clone(), &p)
                        .expect("lut")
                        .force_scalar(),
                ),
            ),
            (
                "multispin",
                Box::new(MultiSpinCpu::new(lattice.clone(), &p).expect("multispin")),
            ),
            (
                "multispin-full",
                Box::new(MultiSpinCpu::new(lattice.clone(), &full).expect("multispin")),
            ),
        ];
        if let Some(ctx) = gpu.as_ref() {
            for (name, layout) in [
                ("gpu-bitplanes", GpuLayout::BitPlanes),
                ("gpu-bytes", GpuLayout::Bytes),
            ] {
                let config = Config {
                    gpu_layout: Some(layout),
                    ..Config::default()
                };
                let sim = GpuLattice::new(lattice.clone(), &config, ctx).expect("gpu");
                sims.push((name, Box::new(sim)));
            }
        }
        for (name, mut sim) in sims {
            let steps: u32 = match (n, name) {
                (_, "gpu-bytes") => 1,
                (1024, _) => 8,
                _ => 2,
            };
            group.throughput(Throughput::Elements((n * n) as u64 * u64::from(steps)));
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| {
                    sim.step(steps).expect("step");
                    if let Some(ctx) = gpu.as_ref().filter(|_| name.starts_with("gpu")) {
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
