//! Exclusive prefix sum throughput (elements/s): serial CPU, rayon CPU and the GPU scan
//! (data resident on the device; the time includes submission and waiting for completion).
//!
//! `cargo bench --bench scan`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::gpu::run_pass;
use simkit::backend::prefix::{exclusive_scan, par_exclusive_scan};
use simkit::backend::rng::rng_u32;
use simkit::backend::{GpuBuffer, GpuContext, GpuScan};

const SIZES: [usize; 4] = [10_000, 100_000, 1_000_000, 10_000_000];

fn input(n: usize) -> Vec<u32> {
    (0..n as u32).map(|i| rng_u32(1, 0, i) % 16).collect()
}

fn bench_scan(c: &mut Criterion) {
    let mut group = c.benchmark_group("exclusive_scan");
    group
        .sample_size(10)
        .measurement_time(std::time::Duration::from_secs(2));
    for n in SIZES {
        group.throughput(Throughput::Elements(n as u64));
        let data = input(n);
        group.bench_with_input(BenchmarkId::new("cpu_serial", n), &data, |b, d| {
            let mut v = d.clone();
            b.iter(|| {
                v.copy_from_slice(d);
                exclusive_scan(&mut v)
            })
        });
        group.bench_with_input(BenchmarkId::new("cpu_rayon", n), &data, |b, d| {
            let mut v = d.clone();
            b.iter(|| {
                v.copy_from_slice(d);
                par_exclusive_scan(&mut v)
            })
        });
    }
    match GpuContext::new() {
        Err(e) => eprintln!("GPU scan skipped: {e}"),
        Ok(ctx) => {
            let scan = GpuScan::new(&ctx).expect("scan kernels compile");
            let name = format!("gpu ({})", ctx.adapter_info().name);
            for n in SIZES {
                group.throughput(Throughput::Elements(n as u64));
                let buf = GpuBuffer::from_slice(&ctx, "scan bench", &input(n)).expect("upload");
                let plan = scan.plan(&ctx, &buf).expect("plan");
                group.bench_function(BenchmarkId::new(&name, n), |b| {
                    b.iter(|| {
                        run_pass(&ctx, "scan", |pass| scan.encode(&ctx, pass, &plan))
                            .expect("scan");
                        ctx.wait().expect("wait");
                    })
                });
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench_scan);
criterion_main!(benches);
