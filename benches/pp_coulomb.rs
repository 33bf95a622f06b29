//! Pair interactions per second of the direct-sum Coulomb force (one symplectic-Euler step =
//! one force evaluation of N (N - 1) pair interactions plus an O(N) update).
//!
//! `cargo bench --bench pp_coulomb` (GPU rows run on the best adapter; here that is lavapipe,
//! a CPU Vulkan driver). A speed ratio to another program counts only when that program runs
//! on the same machine in the same session (see docs/pp-coulomb.md).

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{Backend, GpuContext, Simulation};
use simkit::pp_coulomb::{
    Config, ForceLaw, Integrator, Particles, PpCoulomb, Precision, Region, Species, Velocities,
    units,
};

/// The source's plasma (normalised), with `n` particles in its box.
fn plasma(n: usize) -> (Particles, ForceLaw) {
    let u = units::normalise(&units::PhysicalInputs::source_plasma()).expect("source inputs");
    let mut p = Particles::new();
    let e = p
        .add_species(Species::new("electron", u.charge, u.mass))
        .expect("species");
    let cube = Region::Cube {
        min: [0.0; 3],
        length: u.box_length,
    };
    let v = Velocities::Maxwellian {
        thermal_speed: u.thermal_speed,
    };
    p.fill(e, n, cube, v, 1).expect("fill");
    (
        p,
        ForceLaw::Exclusion {
            radius: u.debye_length,
        },
    )
}

fn bench(c: &mut Criterion) {
    let gpu = GpuContext::new().ok();
    let mut group = c.benchmark_group("pp_coulomb_interactions");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for n in [4096usize, 16_384, 50_000] {
        let (p, law) = plasma(n);
        group.throughput(Throughput::Elements((n * (n - 1)) as u64));
        let mut variants: Vec<(String, Backend<'_>, Precision)> = vec![
            ("cpu-f64".into(), Backend::Cpu, Precision::F64),
            ("cpu-f32".into(), Backend::Cpu, Precision::F32),
        ];
        if let Some(ctx) = &gpu {
            // lavapipe runs at a few GFLOP/s: 50,000 particles would take minutes per sample.
            if !ctx.is_cpu_adapter() || n <= 16_384 {
                variants.push(("gpu-f32".into(), Backend::Gpu(ctx), Precision::F32));
            }
        }
        for (name, backend, precision) in variants {
            let config = Config::new(1.0, law)
                .with_integrator(Integrator::SymplecticEuler)
                .with_precision(precision);
            let mut sim = PpCoulomb::new(p.clone(), &config, backend).expect("sim");
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| {
                    sim.step(1).expect("step");
                    if let Backend::Gpu(ctx) = backend {
                        ctx.wait().expect("wait");
                    }
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
