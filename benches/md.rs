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
//! are lavapipe figures.
//!
//! The group `md_law_32000` times the same system with a pair law defined outside the crate
//! (`UserLj` below: Lennard-Jones written in the bench) against the built-in
//! [`LennardJones`], CPU f64 on 1 and 2 threads: the kernels are compiled for each law, so
//! a law from outside the crate runs at the speed of a built-in one.
//!
//! Run: `cargo bench --bench md` (or `-- --quick`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use simkit::backend::{Backend, GpuContext, Precision, Simulation};
use simkit::md::{Config, GpuKernel, LennardJones, Md, PairLaw, PairTable, System, scenes};

/// A pair law from outside `simkit-md`: Lennard-Jones as a user would write it, with the
/// arithmetic of the built-in law (so that the comparison measures where the law is
/// defined, not how it is written: on an AVX2 machine a different formulation, LAMMPS's
/// `lj1..lj4`, measured 8 % slower than the built-in from the compiler's register
/// allocation in the 16-lane kernel, whatever crate defines it).
mod user_lj {
    use serde::{Deserialize, Serialize};
    use simkit::backend::{Error, Real, Result};
    use simkit::md::PairLaw;

    /// `4 eps ((sigma/r)^12 - (sigma/r)^6)` for `r < r_c`.
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub struct UserLj {
        pub eps: f64,
        pub sigma: f64,
        pub r_c: f64,
    }

    /// `c12 = 4 eps sigma^12`, `c6 = 4 eps sigma^6`, `rc2 = r_c^2`, the energy shift.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Coeff<T> {
        c12: T,
        c6: T,
        rc2: T,
        shift: T,
    }

    impl PairLaw for UserLj {
        type Coeff<T: Real> = Coeff<T>;
        type Gpu = [f32; 4];
        const NAME: &'static str = "user-lj";
        const WGSL: &'static str = "
struct MdCoeff { c12: f32, c6: f32, rc2: f32, shift: f32 }
fn md_pair_force_energy(c: MdCoeff, r2: f32) -> vec2<f32> {
    if (r2 >= c.rc2) { return vec2<f32>(0.0, 0.0); }
    let ir2 = 1.0 / r2;
    let ir6 = ir2 * ir2 * ir2;
    return vec2<f32>((12.0 * c.c12 * ir6 * ir6 - 6.0 * c.c6 * ir6) * ir2, c.c12 * ir6 * ir6 - c.c6 * ir6 - c.shift);
}";

        fn validate(&self, pair: &str) -> Result<()> {
            if self.eps >= 0.0 && self.sigma > 0.0 && self.r_c > 0.0 && self.sigma < 100.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    pair,
                    format!("{self:?}"),
                    "needs eps >= 0, 0 < sigma < 100, r_c > 0",
                ))
            }
        }

        fn cutoff(&self) -> f64 {
            self.r_c
        }

        fn energy(&self, r: f64) -> f64 {
            let s6 = (self.sigma / r).powi(6);
            4.0 * self.eps * (s6 * s6 - s6)
        }

        fn coefficients<T: Real>(&self, shift: f64) -> Coeff<T> {
            let s6 = self.sigma.powi(6);
            let c6 = 4.0 * self.eps * s6;
            Coeff {
                c12: T::from_f64(c6 * s6),
                c6: T::from_f64(c6),
                rc2: T::from_f64(self.r_c * self.r_c),
                shift: T::from_f64(shift),
            }
        }

        fn gpu(c: &Coeff<f32>) -> [f32; 4] {
            [c.c12, c.c6, c.rc2, c.shift]
        }

        #[inline(always)]
        fn force_energy<T: Real>(c: &Coeff<T>, r2: T) -> (T, T) {
            if r2 >= c.rc2 {
                return (T::ZERO, T::ZERO);
            }
            let ir2 = T::ONE / r2;
            let ir6 = ir2 * ir2 * ir2;
            let (rep, att) = (c.c12 * ir6 * ir6, c.c6 * ir6);
            let (twelve, six) = (T::from_f64(12.0), T::from_f64(6.0));
            ((twelve * rep - six * att) * ir2, rep - att - c.shift)
        }

        fn stiffness(&self) -> Option<(f64, f64)> {
            let r = self.sigma * 2f64.powf(1.0 / 6.0);
            Some((
                r,
                72.0 * self.eps / (2f64.powf(1.0 / 3.0) * self.sigma * self.sigma),
            ))
        }
    }
}

/// Steps per CPU iteration (`in.lj` runs 100).
const STEPS: u32 = 100;
/// Steps per GPU iteration.
const GPU_STEPS: u32 = 20;

fn config(precision: Precision) -> Config {
    Config {
        precision,
        ..Config::default().with_dt(0.005)
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
    cpu_rows(&mut g, "cpu_f64_threads", &system, Precision::F64);
    cpu_rows(&mut g, "cpu_f32_threads", &system, Precision::F32);
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
                    || Md::new(system.clone(), &config, Backend::Gpu(ctx)).expect("gpu run"),
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

/// One CPU row per thread count (1 and 2): 100 steps of `system` in `precision`, a fresh
/// run per iteration (its construction not timed).
fn cpu_rows<L: PairLaw>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    label: &str,
    system: &System<L>,
    precision: Precision,
) {
    let config = config(precision);
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        g.bench_function(BenchmarkId::new(label, threads), |b| {
            b.iter_batched(
                || {
                    pool.install(|| Md::new(system.clone(), &config, Backend::Cpu))
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

/// The built-in Lennard-Jones law against the same law defined outside the crate.
fn user_law(c: &mut Criterion) {
    let built_in: System = scenes::lj_melt().expect("in.lj system");
    let table = PairTable::uniform(
        1,
        user_lj::UserLj {
            eps: 1.0,
            sigma: 1.0,
            r_c: 2.5,
        },
    )
    .expect("table");
    let user = scenes::fcc_lattice([20; 3], 0.8442, 1.44, table, &[0], 87287).expect("system");
    let mut g = c.benchmark_group("md_law_32000");
    g.throughput(Throughput::Elements(
        built_in.particle_count() as u64 * u64::from(STEPS),
    ));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(10));
    cpu_rows::<LennardJones>(&mut g, "built_in_lj_f64_threads", &built_in, Precision::F64);
    cpu_rows(&mut g, "user_lj_f64_threads", &user, Precision::F64);
    g.finish();
}

criterion_group!(md, benches, user_law);
criterion_main!(md);
