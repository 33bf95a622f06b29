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
use simkit::backend::{Backend, GpuContext, Simulation};
use simkit::lattice_gas::{Config, CpuMethod, GpuLayout, Lattice, LatticeGas, RuleSet};

fn bench(c: &mut Criterion) {
    let gpu = GpuContext::new().ok();
    let mut group = c.benchmark_group("fhp_site_updates");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(3));
    for n in [1024usize, 4096] {
        let mut lattice = Lattice::new(n, n).expect("size");
        lattice.fill_random(0.3, 1).expect("density");
        let cpu = |method: CpuMethod, rules: RuleSet| Config {
            cpu: method,
            rules,
            ..Config::default()
        };
        let mut runs: Vec<(&str, Config, Backend<'_>)> = vec![
            ("lut", cpu(CpuMethod::Lut, RuleSet::FhpI), Backend::Cpu),
            (
                "lut-scalar",
                cpu(CpuMethod::LutPortable, RuleSet::FhpI),
                Backend::Cpu,
            ),
            (
                "multispin",
                cpu(CpuMethod::MultiSpin, RuleSet::FhpI),
                Backend::Cpu,
            ),
            (
                "multispin-full",
                cpu(CpuMethod::MultiSpin, RuleSet::Full),
                Backend::Cpu,
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
                runs.push((name, config, Backend::Gpu(ctx)));
            }
        }
        let sims = runs.into_iter().map(|(name, config, backend)| {
            let sim = LatticeGas::new(lattice.clone(), &config, backend).expect(name);
            (name, sim)
        });
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
