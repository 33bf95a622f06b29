//! CPU and GPU backends against each other, and the GPU-specific options.
#![cfg(feature = "gpu")]

#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::{Error, Simulation};
use simkit_rd::scenes::colony_scene;
use simkit_rd::{
    Boundaries, Boundary, CpuRd, Diffusion, GpuKernel, GpuOptions, GpuRd, Grid, Integrator,
    Stepping,
};

fn max_rel(a: &Grid<f32>, b: &Grid<f32>) -> f64 {
    let mut worst = 0.0f64;
    for s in 0..a.species() {
        let scale = b.max_abs(s).max(1e-30);
        for (x, y) in a.field(s).iter().zip(b.field(s)) {
            worst = worst.max(f64::from((x - y).abs()) / scale);
        }
    }
    worst
}

/// The colony scene on 72 x 60 (not a multiple of the tile), 1000 steps, f32: the CPU
/// and every GPU kernel variant agree within 1e-5 relative, with each other and with the f64
/// CPU reference.
#[cfg(feature = "gpu")]
#[test]
fn cpu_and_gpu_agree_after_1000_steps() {
    let Some(ctx) = gpu_or_skip("cpu_and_gpu_agree_after_1000_steps") else {
        return;
    };
    let (grid, model) = colony_scene::<f32>(72, 60, 7).unwrap();
    for integrator in [Integrator::Euler, Integrator::Heun] {
        let stepping = Stepping {
            dt: 0.005,
            integrator,
            ..Stepping::euler(0.005)
        };
        let mut cpu = CpuRd::new(grid.clone(), model.clone(), stepping).unwrap();
        cpu.step(1000).unwrap();
        let reference = cpu.state().unwrap();
        let moved = max_rel(&grid, &reference);
        assert!(moved > 1e-2, "the scene must evolve ({moved})");
        // f64 CPU is the reference for both f32 backends.
        let (grid64, model64) = colony_scene::<f64>(72, 60, 7).unwrap();
        let mut cpu64 = CpuRd::new(grid64, model64, stepping).unwrap();
        cpu64.step(1000).unwrap();
        let reference64 = cpu64.state().unwrap().convert::<f32>();
        let err64 = max_rel(&reference, &reference64);
        println!("{integrator:?} CPU f32 vs CPU f64: max rel diff {err64:e}");
        assert!(err64 < 1e-5, "{integrator:?} CPU f32 vs f64: {err64:e}");
        for (kernel, tile) in [
            (GpuKernel::Tiled, (16, 16)),
            (GpuKernel::Tiled, (32, 8)),
            (GpuKernel::Global, (16, 16)),
        ] {
            let options = GpuOptions {
                kernel,
                tile,
                steps_per_submit: 250,
            };
            let mut gpu = GpuRd::new(&ctx, grid.clone(), model.clone(), stepping, options).unwrap();
            gpu.step(400).unwrap();
            gpu.step(600).unwrap();
            let g = gpu.state().unwrap();
            let err = max_rel(&g, &reference);
            let err64 = max_rel(&g, &reference64);
            println!(
                "{integrator:?} {kernel:?} {tile:?}: max rel diff {err:e} (CPU f32), {err64:e} (CPU f64)"
            );
            assert!(err < 1e-5, "{integrator:?} {kernel:?} {tile:?}: {err:e}");
            assert!(
                err64 < 1e-5,
                "{integrator:?} {kernel:?} {tile:?} vs f64: {err64:e}"
            );
        }
    }
}

/// f64 on the GPU (lavapipe has SHADER_F64) matches the f64 CPU reference closely.
#[cfg(feature = "gpu")]
#[test]
fn gpu_f64_matches_cpu_f64() {
    let Some(ctx) = gpu_or_skip("gpu_f64_matches_cpu_f64") else {
        return;
    };
    let (grid, model) = colony_scene::<f64>(40, 40, 3).unwrap();
    let stepping = Stepping::heun(0.005);
    let mut cpu = CpuRd::new(grid.clone(), model.clone(), stepping).unwrap();
    cpu.step(300).unwrap();
    let c = cpu.state().unwrap();
    match GpuRd::new(&ctx, grid, model, stepping, GpuOptions::default()) {
        Ok(mut gpu) => {
            gpu.step(300).unwrap();
            let g = gpu.state().unwrap();
            for s in 0..2 {
                for (x, y) in g.field(s).iter().zip(c.field(s)) {
                    assert!((x - y).abs() < 1e-12, "{x} vs {y}");
                }
            }
        }
        Err(Error::Unsupported(m)) => assert!(!ctx.has_f64(), "{m}"),
        Err(e) => panic!("{e}"),
    }
}

/// Tiles over the device's workgroup limits are refused with a clear error.
#[cfg(feature = "gpu")]
#[test]
fn gpu_rejects_bad_tiles() {
    let Some(ctx) = gpu_or_skip("gpu_rejects_bad_tiles") else {
        return;
    };
    let (grid, model) = colony_scene::<f32>(32, 32, 1).unwrap();
    for tile in [(0, 16), (16, 0), (1024, 1024)] {
        let options = GpuOptions {
            tile,
            ..GpuOptions::default()
        };
        let err = GpuRd::new(
            &ctx,
            grid.clone(),
            model.clone(),
            Stepping::euler(0.005),
            options,
        )
        .unwrap_err();
        assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
    }
}

/// Mixed edge conditions (periodic west/east, Dirichlet south, no-flux north) with two
/// species of different diffusivities, Euler and Heun: the GPU ghost kernel and the CPU ghost
/// fill agree cell by cell (f32, 500 steps), and the wrap-around actually carries mass across
/// the periodic edges.
#[cfg(feature = "gpu")]
#[test]
fn mixed_boundaries_agree_on_both_backends() {
    let Some(ctx) = gpu_or_skip("mixed_boundaries_agree_on_both_backends") else {
        return;
    };
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
    for stepping in [Stepping::euler(0.2), Stepping::heun(0.2)] {
        let mut cpu = CpuRd::new(grid.clone(), model.clone(), stepping).unwrap();
        cpu.step(500).unwrap();
        let reference = cpu.state().unwrap();
        // Column nx - 2 sees the blob only through the periodic wrap.
        assert!(reference.get(0, nx - 2, 12) > 0.05, "no wrap-around");
        for kernel in [GpuKernel::Tiled, GpuKernel::Global] {
            let options = GpuOptions {
                kernel,
                tile: (16, 8),
                steps_per_submit: 64,
            };
            let mut gpu = GpuRd::new(&ctx, grid.clone(), model.clone(), stepping, options).unwrap();
            gpu.step(500).unwrap();
            let err = max_rel(&gpu.state().unwrap(), &reference);
            println!("{:?} {kernel:?}: max rel diff {err:e}", stepping.integrator);
            assert!(err < 1e-5, "{:?} {kernel:?}: {err:e}", stepping.integrator);
        }
    }
}
