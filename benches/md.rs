//! Molecular-dynamics throughput in atom-steps per second on LAMMPS's `in.lj` system
//! (`scenes::lj_melt`: 32 000 Lennard-Jones atoms, density 0.8442, T = 1.44, cutoff 2.5,
//! skin 0.3, dt = 0.005), the system of `examples/lj_fluid.rs` and
//! `benches/peers/md_vs_lammps.sh`.
//!
//! Every iteration starts a fresh run from the FCC lattice (construction, which builds the
//! first Verlet list and forces, not timed) and runs the first 100 steps, the window of
//! LAMMPS's `in.lj`. On the CPU backend in f64 and in f32, each with 1 and 2 rayon threads,
//! and on the GPU backend (f32) when an adapter exists, with each of its force kernels
//! (`GpuKernel::PerParticle` and `GpuKernel::CellBlock`: run this on a hardware GPU to
//! decide which should be the default there). The GPU rows time the first 20 steps only: on
//! lavapipe, a CPU Vulkan driver, a step of 32 000 atoms is slow; GPU figures from lavapipe
//! are lavapipe figures. Run: `cargo bench --bench md` (or `-- --quick`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{Backend, GpuContext, Precision, Simulation};
use simkit::md::{Config, GpuKernel, Md, System, scenes};

/// Steps per CPU iteration (`in.lj` runs 100).
const STEPS: u32 = 100;
/// Steps per GPU iteration.
const GPU_STEPS: u32 = 20;

fn config(precision: Precision) -> Config {
    Config {
        precision,
        ..Config::with_dt(0.005)
    }
}

fn benches(c: &mut Criterion) {
    let system: System = scenes::lj_melt().expect("in.lj system");
    let n = system.particle_count() as u64;
    let gpu = GpuContext::new().ok();
    if gpu.is_none() {
        eprintln!("md bench: no GPU adapter, GPU rows skipped");
    }
    let mut g = c.benchmark_group("md_lj_32000");
    g.throughput(Throughput::Elements(n * u64::from(STEPS)));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(10));
    for (label, precision) in [
        ("cpu_f64_threads", Precision::F64),
        ("cpu_f32_threads", Precision::F32),
    ] {
        let config = config(precision);
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            g.bench_function(BenchmarkId::new(label, threads), |b| {
                b.iter_batched(
                    || {
                        pool.install(|| Md::new(&system, &config, Backend::Cpu))
                            .expect("cpu run")
                    },
                    |mut md| {
                        pool.install(|| md.step(STEPS)).expect("step");
                        black_box(md.steps_done())
                    },
                    BatchSize::PerIteration,
                )
            });
        }
    }
    if let Some(ctx) = gpu.as_ref() {
        g.throughput(Throughput::Elements(n * u64::from(GPU_STEPS)));
        for (label, kernel) in [
            ("gpu_f32_per_particle", GpuKernel::PerParticle),
            ("gpu_f32_cell_block", GpuKernel::cell_block()),
        ] {
            let config = Config {
                gpu_kernel: kernel,
                ..config(Precision::F32)
            };
            g.bench_function(BenchmarkId::new(label, &ctx.adapter_info().name), |b| {
                b.iter_batched(
                    || Md::new(&system, &config, Backend::Gpu(ctx)).expect("gpu run"),
                    |mut md| {
                        md.step(GPU_STEPS).expect("step");
                        ctx.wait().expect("gpu wait");
                        black_box(md.steps_done())
                    },
                    BatchSize::PerIteration,
                )
            });
        }
    }
    g.finish();
}

criterion_group!(md, benches);
criterion_main!(md);
