//! Gray–Scott at the spots parameter set grows a pattern of separate spots from a seeded
//! square, on both backends.

use backend::testing::gpu_or_skip;
use backend::{Backend, Simulation};
use rd::scenes::{count_spots, gray_scott_square, variance};
use rd::{GpuKernel, GpuOptions, GrayScott, Rd, Stepping};

const N: usize = 128;
const STEPS: u32 = 6000;

fn run(backend: Backend<'_>, options: GpuOptions) -> (f64, usize) {
    let grid = gray_scott_square::<f32>(N, GrayScott::PEARSON_H, 24, 4).unwrap();
    let mut sim = Rd::with_options(
        backend,
        grid,
        GrayScott::spots(),
        Stepping::euler(1.0),
        options,
    )
    .unwrap();
    sim.step(STEPS).unwrap();
    let g = sim.state().unwrap();
    let (var, spots) = (variance(&g, 1), count_spots(&g, 1, 0.2));
    println!(
        "{}: var(v) = {var:.3e}, spots = {spots}",
        sim.backend_name()
    );
    (var, spots)
}

fn check((var, spots): (f64, usize)) {
    // The seeded square (v = 0.25 on 1/64 of the area) starts at var(v) ~ 1e-3 and would decay
    // to 0 without the instability; a field of spots has var(v) ~ 1e-2.
    assert!(var > 5e-3, "var(v) = {var:e}: no pattern");
    assert!((12..=60).contains(&spots), "{spots} spots");
}

#[test]
fn spots_on_cpu() {
    check(run(Backend::Cpu, GpuOptions::default()));
}

#[test]
fn spots_on_gpu() {
    let Some(ctx) = gpu_or_skip("spots_on_gpu") else {
        return;
    };
    check(run(Backend::Gpu(&ctx), GpuOptions::default()));
    check(run(
        Backend::Gpu(&ctx),
        GpuOptions {
            kernel: GpuKernel::Global,
            ..GpuOptions::default()
        },
    ));
}
