//! Gray–Scott at the spots parameter set grows a pattern of separate spots from a seeded
//! square, on both backends.

#[cfg(feature = "gpu")]
use simkit_backend::testing::gpu_or_skip;
use simkit_backend::{Backend, Simulation};
use simkit_rd::scenes::{count_spots, gray_scott_square, variance};
use simkit_rd::{Config, GrayScott, Grid, Rd, Stepping};
#[cfg(feature = "gpu")]
use simkit_rd::{GpuKernel, GpuOptions};

const N: usize = 128;
const STEPS: u32 = 6000;

fn square() -> Grid<f32> {
    gray_scott_square::<f32>(N, GrayScott::PEARSON_H, 24, 4).unwrap()
}

fn run(mut sim: Rd<f32, GrayScott>) -> (f64, usize) {
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
    let sim = Rd::new(
        square(),
        GrayScott::spots(),
        &Config::new(Stepping::euler(1.0)),
        Backend::Cpu,
    );
    check(run(sim.unwrap()));
}

#[cfg(feature = "gpu")]
#[test]
fn spots_on_gpu() {
    let Some(ctx) = gpu_or_skip("spots_on_gpu") else {
        return;
    };
    for kernel in [GpuKernel::Tiled, GpuKernel::Global] {
        let options = GpuOptions {
            kernel,
            ..GpuOptions::default()
        };
        let config = Config::new(Stepping::euler(1.0)).with_gpu(options);
        let sim = Rd::new(square(), GrayScott::spots(), &config, Backend::Gpu(&ctx));
        check(run(sim.unwrap()));
    }
}
