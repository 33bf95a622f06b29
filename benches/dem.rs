//! Granular DEM throughput in particle-steps per second:
//!
//! - `bed2d_2048`: the source's 2D vibrated bed (2048 discs, 64 wide, Gamma = 3 at 20 Hz,
//!   friction, vibrating floor and lid), dt = t_c / 30, 200 steps per iteration, starting
//!   from the initial lattice (a dense bed, no warm-up).
//! - `box3d_20000`: the 3D granular box of `benches/peers/dem_gran3d.lmp` (25 x 25 x 32 spheres of
//!   diameter 1 on a lattice of spacing 1.05, Gaussian velocities, gravity, frictional floor,
//!   periodic x and y; k_n = 2e5, gamma_n = 50, mu = 0.5, dt = 1e-4, skin 0.1), the scene
//!   of the LAMMPS `gran/hooke` comparison.
//!
//! Every iteration starts a fresh simulation from the initial state (construction not
//! timed) and runs the same steps, so each sample times the same physical window: the box
//! runs the 2000 steps of `benches/peers/dem_gran3d.lmp` on the CPU (the GPU rows time the
//! first 200 steps only, since lavapipe is slow).
//!
//! Each on the CPU backend (f64) with 1 and 2 rayon threads, and on the GPU backend (f32)
//! when an adapter exists (here: lavapipe, a CPU Vulkan driver, so GPU figures are lavapipe
//! figures). Run: `cargo bench --bench dem` (or `-- --quick`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{Backend, GpuContext, Simulation};
use simkit::dem::scenes::{BedParams, granular_box, vibrating_bed};
use simkit::dem::{Config, Dem, Scene};

fn bed() -> Scene {
    vibrating_bed(&BedParams::default()).expect("bed scene").0
}

fn gran_box() -> Scene {
    granular_box(25, 25, 32, 4_928_459).expect("box scene")
}

fn bench_scene(
    c: &mut Criterion,
    name: &str,
    scene: &Scene,
    config: &Config,
    steps: u32,
    gpu: Option<&GpuContext>,
) {
    let n = scene.particles().len() as u64;
    let mut g = c.benchmark_group(name);
    g.throughput(Throughput::Elements(n * u64::from(steps)));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        g.bench_function(BenchmarkId::new("cpu_f64_threads", threads), |b| {
            b.iter_batched(
                || Dem::new(scene.clone(), config, Backend::Cpu).expect("cpu sim"),
                |mut sim| {
                    pool.install(|| sim.step(steps)).expect("step");
                    black_box(sim.steps_done())
                },
                BatchSize::PerIteration,
            )
        });
    }
    if let Some(ctx) = gpu {
        // lavapipe manages ~1e6 particle-steps/s: the GPU rows time the first 200 steps.
        let steps = steps.min(200);
        g.throughput(Throughput::Elements(n * u64::from(steps)));
        g.bench_function(BenchmarkId::new("gpu_f32", &ctx.adapter_info().name), |b| {
            b.iter_batched(
                || Dem::new(scene.clone(), config, Backend::Gpu(ctx)).expect("gpu sim"),
                |mut sim| {
                    sim.step(steps).expect("step");
                    ctx.wait().expect("gpu wait");
                    black_box(sim.steps_done())
                },
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

fn benches(c: &mut Criterion) {
    let gpu = GpuContext::new().ok();
    if gpu.is_none() {
        eprintln!("dem bench: no GPU adapter, GPU rows skipped");
    }
    bench_scene(
        c,
        "dem_bed2d_2048",
        &bed(),
        &Config::default(),
        200,
        gpu.as_ref(),
    );
    bench_scene(
        c,
        "dem_box3d_20000",
        &gran_box(),
        &Config::default().with_dt(1e-4),
        2000,
        gpu.as_ref(),
    );
}

criterion_group!(dem, benches);
criterion_main!(dem);
