//! rd throughput in cell updates per second (one cell update = every species of one cell
//! advanced by one Euler step): the bacterial colony model (f32) and Gray–Scott (f64 and f32)
//! at 512^2 and 4096^2, CPU with 1 and 2 threads, GPU tiled and global-memory kernels.
//!
//! Each iteration is one `step` call of 48 steps (CPU) or 24 (512^2) / 12 (4096^2) steps
//! (GPU, lavapipe is slow); for the colony model that includes the stability re-check `step`
//! makes once per call from the current fields (a pass over b, n and d: at 4096^2 about 5 % of
//! the memory traffic of a 48-step call with temporal blocking).
//!
//! `cargo bench --bench rd` (add `-- colony` etc. to filter). GPU figures come from whatever
//! adapter `GpuContext::new()` picks (lavapipe on a machine without a GPU).

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{Backend, GpuContext, Simulation};
use simkit::rd::scenes::{colony_scene, gray_scott_square};
use simkit::rd::{Config, GpuKernel, GpuOptions, GrayScott, Grid, Model, Rd, Real, Stepping};

const CPU_STEPS: u32 = 48;

fn gpu_steps_for(n: usize) -> u32 {
    if n <= 512 { 24 } else { 12 }
}

fn bench_sim<T: Real, M: Model>(
    c: &mut Criterion,
    group: &str,
    make: &dyn Fn(usize) -> (Grid<T>, M, f64),
    gpu: Option<&GpuContext>,
) {
    let mut g = c.benchmark_group(group);
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for n in [512usize, 4096] {
        g.throughput(Throughput::Elements((n * n) as u64 * u64::from(CPU_STEPS)));
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (grid, model, dt) = make(n);
            let config = Config::new(Stepping::euler(dt));
            let mut sim = Rd::new(grid, model, &config, Backend::Cpu).unwrap();
            g.bench_function(BenchmarkId::new(format!("cpu-{threads}t"), n), |b| {
                b.iter(|| pool.install(|| sim.step(CPU_STEPS).unwrap()))
            });
        }
        let Some(ctx) = gpu else { continue };
        let steps = gpu_steps_for(n);
        g.throughput(Throughput::Elements((n * n) as u64 * u64::from(steps)));
        for (name, kernel) in [
            ("gpu-tiled", GpuKernel::Tiled),
            ("gpu-global", GpuKernel::Global),
        ] {
            let (grid, model, dt) = make(n);
            let config = Config::new(Stepping::euler(dt)).with_gpu(GpuOptions {
                kernel,
                ..GpuOptions::default()
            });
            match Rd::new(grid, model, &config, Backend::Gpu(ctx)) {
                Ok(mut sim) => g.bench_function(BenchmarkId::new(name, n), |b| {
                    b.iter(|| sim.step(steps).unwrap())
                }),
                Err(e) => {
                    eprintln!("{group} {name} {n}: skipped ({e})");
                    continue;
                }
            };
        }
    }
    g.finish();
}

/// Temporal blocking on the CPU: the colony model (f32, 4096^2, 2 threads) with 1 (no
/// blocking), 2, 4 (the default) and 8 Euler steps fused per sweep.
fn bench_sweep(c: &mut Criterion) {
    let mut g = c.benchmark_group("rd colony f32 steps per sweep");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let n = 4096;
    g.throughput(Throughput::Elements((n * n) as u64 * u64::from(CPU_STEPS)));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for k in [1u32, 2, 4, 8] {
        let (grid, model) = colony_scene::<f32>(n, n, 1).unwrap();
        let config = Config::new(Stepping::euler(0.005)).with_steps_per_sweep(k);
        let mut sim = Rd::new(grid, model, &config, Backend::Cpu).unwrap();
        g.bench_function(BenchmarkId::new("cpu-2t", k), |b| {
            b.iter(|| pool.install(|| sim.step(CPU_STEPS).unwrap()))
        });
    }
    g.finish();
}

fn benches(c: &mut Criterion) {
    let gpu = match GpuContext::new() {
        Ok(ctx) => {
            eprintln!("GPU adapter: {}", ctx.summary());
            Some(ctx)
        }
        Err(e) => {
            eprintln!("no GPU: {e}");
            None
        }
    };
    let colony = |n: usize| {
        let (grid, model) = colony_scene::<f32>(n, n, 1).unwrap();
        (grid, model, 0.005)
    };
    bench_sim(c, "rd colony f32", &colony, gpu.as_ref());
    bench_sweep(c);
    let gs64 = |n: usize| {
        let grid = gray_scott_square::<f64>(n, 1.0, n / 8, 1).unwrap();
        let m = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
        (grid, m, 0.1)
    };
    bench_sim(c, "rd gray-scott f64", &gs64, gpu.as_ref());
    let gs32 = |n: usize| {
        let grid = gray_scott_square::<f32>(n, 1.0, n / 8, 1).unwrap();
        let m = GrayScott::new(1.0, 0.5, 0.04, 0.06).unwrap();
        (grid, m, 0.1)
    };
    bench_sim(c, "rd gray-scott f32", &gs32, gpu.as_ref());
}

criterion_group!(rd_benches, benches);
criterion_main!(rd_benches);
