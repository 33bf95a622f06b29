//! The same scenes on every backend (CPU, then the GPU when compiled in and present, with each
//! of its kernel variants) and in both precisions, compared with the CPU result.
//!
//! The CPU is deterministic (bit-identical for every thread count and fused depth, see
//! `temporal_blocking.rs`); other backends are compared with [`max_rel_diff`] per species
//! (largest cell difference over the largest magnitude of the reference field).

use approx::abs_diff_eq;
use simkit_backend::testing::{backends, max_rel_diff};
use simkit_backend::{Backend, Simulation, max_or_nan};
use simkit_rd::scenes::colony_scene;
use simkit_rd::{
    Boundaries, Boundary, Config, Diffusion, GpuKernel, GpuOptions, Grid, Integrator, Rd, Real,
    Stepping,
};

/// Largest [`max_rel_diff`] over the species of `a` against the reference `b`.
fn max_rel<T: Real>(a: &Grid<T>, b: &Grid<T>) -> f64 {
    let f64s = |g: &Grid<T>, s| g.field(s).iter().map(|v| v.to_f64()).collect::<Vec<f64>>();
    (0..b.species())
        .map(|s| {
            let (x, y) = (f64s(a, s), f64s(b, s));
            max_rel_diff(&x, &y, &y)
        })
        .fold(0.0, max_or_nan)
}

/// The configurations to run on `backend`: the given stepping once on the CPU; on the GPU,
/// once per `(kernel, tile)` variant with `steps_per_submit` steps per submission.
fn configs(
    backend: Backend<'_>,
    stepping: Stepping,
    variants: &[(GpuKernel, (u32, u32))],
    steps_per_submit: u32,
) -> Vec<Config> {
    if matches!(backend, Backend::Cpu) {
        return vec![Config::new(stepping)];
    }
    variants
        .iter()
        .map(|&(kernel, tile)| {
            Config::new(stepping).with_gpu(GpuOptions {
                kernel,
                tile,
                steps_per_submit,
            })
        })
        .collect()
}

/// The colony scene on 72 x 60 (not a multiple of the tile), 1000 steps, f32, Euler and Heun:
/// the CPU f32 run agrees with the CPU f64 run within 1e-5 relative, and every backend (each
/// GPU kernel variant, stepping in calls of 400 and 600 steps) agrees within 1e-5 with both
/// CPU runs (f32 rounding accumulated over 1000 steps). Measured (this test, `--nocapture`):
/// CPU f32 vs f64 5.1e-6 (Euler) and 4.7e-6 (Heun); llvmpipe 2.3e-6 (Euler) and 3.0e-6 (Heun)
/// against CPU f32 and 5.1e-6 / 4.7e-6 against CPU f64 (bound 2x); the CPU against itself is
/// bit-identical.
#[test]
fn cpu_and_gpu_agree_after_1000_steps() {
    let (grid, model) = colony_scene::<f32>(72, 60, 7).unwrap();
    let (grid64, model64) = colony_scene::<f64>(72, 60, 7).unwrap();
    let variants = [
        (GpuKernel::Tiled, (16, 16)),
        (GpuKernel::Tiled, (32, 8)),
        (GpuKernel::Global, (16, 16)),
    ];
    for integrator in [Integrator::Euler, Integrator::Heun] {
        let stepping = Stepping {
            dt: 0.005,
            integrator,
            ..Stepping::euler(0.005)
        };
        let config = Config::new(stepping);
        let mut cpu = Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).unwrap();
        cpu.step(1000).unwrap();
        let reference = cpu.state().unwrap();
        let moved = max_rel(&grid, &reference);
        assert!(moved > 1e-2, "the scene must evolve ({moved})");
        // f64 CPU is the reference for every f32 backend.
        let mut cpu64 = Rd::new(grid64.clone(), model64.clone(), &config, Backend::Cpu).unwrap();
        cpu64.step(1000).unwrap();
        let reference64 = cpu64.state().unwrap().convert::<f32>();
        let err64 = max_rel(&reference, &reference64);
        println!("{integrator:?} CPU f32 vs CPU f64: max rel diff {err64:e}");
        assert!(err64 < 1e-5, "{integrator:?} CPU f32 vs f64: {err64:e}");
        for backend in backends("cpu_and_gpu_agree_after_1000_steps") {
            for config in configs(backend, stepping, &variants, 250) {
                let mut sim = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
                sim.step(400).unwrap();
                sim.step(600).unwrap();
                let g = sim.state().unwrap();
                let err = max_rel(&g, &reference);
                let err64 = max_rel(&g, &reference64);
                let name = sim.backend_name();
                println!(
                    "{integrator:?} {name}: max rel diff {err:e} (CPU f32), {err64:e} (CPU f64)"
                );
                assert!(err < 1e-5, "{integrator:?} {name}: {err:e}");
                assert!(err64 < 1e-5, "{integrator:?} {name} vs f64: {err64:e}");
            }
        }
    }
}

/// f64 on every backend matches the f64 CPU reference cell by cell within 7e-15 absolute
/// (colony scene, Heun, 300 steps, values of order 1): measured 2.2e-15 at most on llvmpipe
/// (this test, `--nocapture`); bound 3x. A GPU without `SHADER_F64` must refuse f64 with
/// `Error::Unsupported`, and the test then says that the comparison was skipped.
#[test]
fn gpu_f64_matches_cpu_f64() {
    let (grid, model) = colony_scene::<f64>(40, 40, 3).unwrap();
    let config = Config::new(Stepping::heun(0.005));
    let mut cpu = Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).unwrap();
    cpu.step(300).unwrap();
    let c = cpu.state().unwrap();
    for backend in backends("gpu_f64_matches_cpu_f64") {
        match Rd::new(grid.clone(), model.clone(), &config, backend) {
            Ok(mut sim) => {
                sim.step(300).unwrap();
                let g = sim.state().unwrap();
                let mut worst = 0.0f64;
                for s in 0..2 {
                    for (x, y) in g.field(s).iter().zip(c.field(s)) {
                        assert!(
                            abs_diff_eq!(x, y, epsilon = 7e-15),
                            "{}: {x} vs {y}",
                            sim.backend_name()
                        );
                        worst = max_or_nan(worst, (x - y).abs());
                    }
                }
                println!("{}: max abs diff {worst:e}", sim.backend_name());
            }
            #[cfg(feature = "gpu")]
            Err(simkit_backend::Error::Unsupported(m)) if matches!(backend, Backend::Gpu(ctx) if !ctx.has_f64()) =>
            {
                eprintln!(
                    "SKIPPED gpu_f64_matches_cpu_f64 on the GPU: the adapter lacks SHADER_F64, \
                     so f64 was refused as expected ({m}) and no f64 GPU result was compared"
                );
            }
            Err(e) => panic!("{e}"),
        }
    }
}

/// Mixed edge conditions (periodic west/east, Dirichlet south, no-flux north) with two
/// species of different diffusivities, Euler and Heun: every backend (the GPU ghost kernel,
/// tiled and global stencils) agrees with the CPU ghost fill cell by cell within 4e-7 relative
/// (f32, 500 steps; measured 6.2e-8 Euler, 1.25e-7 Heun on llvmpipe, this test with
/// `--nocapture`; bound ~3x), and the wrap-around actually carries
/// mass across the periodic edges.
#[test]
fn mixed_boundaries_agree_on_both_backends() {
    let (nx, ny) = (40, 24);
    let bc = Boundaries {
        west: Boundary::Periodic,
        east: Boundary::Periodic,
        south: Boundary::Dirichlet(vec![1.0, -0.5]),
        north: Boundary::NoFlux,
    };
    // Blobs next to the west edge: they can only reach the east columns by wrapping.
    let blob = |a: f32| {
        (0..nx * ny)
            .map(|k| {
                let (i, j) = ((k % nx) as f32, (k / nx) as f32);
                a * (-((i - 1.0).powi(2) + (j - 12.0).powi(2)) / 8.0).exp()
            })
            .collect::<Vec<f32>>()
    };
    let grid = Grid::new(nx, ny, 1.0, bc, vec![blob(1.0), blob(2.0)]).unwrap();
    let model = Diffusion::new(&[1.0, 0.4]).unwrap();
    let variants = [(GpuKernel::Tiled, (16, 8)), (GpuKernel::Global, (16, 8))];
    for stepping in [Stepping::euler(0.2), Stepping::heun(0.2)] {
        let config = Config::new(stepping);
        let mut cpu = Rd::new(grid.clone(), model.clone(), &config, Backend::Cpu).unwrap();
        cpu.step(500).unwrap();
        let reference = cpu.state().unwrap();
        // Column nx - 2 sees the blob only through the periodic wrap.
        assert!(
            reference.get(0, nx - 2, 12).unwrap() > 0.05,
            "no wrap-around"
        );
        for backend in backends("mixed_boundaries_agree_on_both_backends") {
            for config in configs(backend, stepping, &variants, 64) {
                let mut sim = Rd::new(grid.clone(), model.clone(), &config, backend).unwrap();
                sim.step(500).unwrap();
                let err = max_rel(&sim.state().unwrap(), &reference);
                let name = sim.backend_name();
                println!("{:?} {name}: max rel diff {err:e}", stepping.integrator);
                assert!(err < 4e-7, "{:?} {name}: {err:e}", stepping.integrator);
            }
        }
    }
}
