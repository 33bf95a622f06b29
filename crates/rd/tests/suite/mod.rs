//! The conformance suite every simkit simulation crate runs (`conformance_tests!` of
//! `simkit-backend`, compiled into `tests/restart.rs`): the backends agree, split calls
//! equal one call, restart bit for bit, rollback after a blow-up, damaged checkpoints
//! refused; on Gray–Scott spots in `f32`.

use simkit_backend::testing::{max_rel_diff, within};
use simkit_backend::{Backend, Result};
use simkit_rd::scenes::gray_scott_square;
use simkit_rd::{Config, GpuOptions, GrayScott, Grid, Rd, Stepping};

fn run(backend: Backend<'_>, stepping: Stepping, check_every: u32) -> Result<Rd<f32, GrayScott>> {
    let grid = gray_scott_square::<f32>(24, 1.0, 6, 3)?;
    let model = GrayScott::new(1.0, 0.5, 0.04, 0.06)?;
    let config = Config::new(stepping)
        .with_check_every(check_every)
        .with_gpu(GpuOptions {
            steps_per_submit: 16,
            ..GpuOptions::default()
        });
    Rd::new(grid, model, &config, backend)
}

fn spots(backend: Backend<'_>) -> Result<Rd<f32, GrayScott>> {
    run(backend, Stepping::euler(0.2), 9)
}

/// 1.5 times the stability bound (0.25), the guard overridden, checked every 7 steps.
fn unstable(backend: Backend<'_>) -> Result<Rd<f32, GrayScott>> {
    run(backend, Stepping::euler(0.375).unguarded(), 7)
}

/// The GPU's f32 fields within 1e-5 of the largest value of the CPU's: the bound of the
/// 1000-step comparison in `tests/conformance.rs` (measured there 1e-7 to 1e-6 on llvmpipe).
fn within_f32(cpu: &Grid<f32>, gpu: &Grid<f32>) -> std::result::Result<(), String> {
    let flat = |g: &Grid<f32>| -> Vec<f64> {
        g.fields().iter().flatten().map(|&v| f64::from(v)).collect()
    };
    let (a, b) = (flat(cpu), flat(gpu));
    within(
        "fields (of their largest value)",
        max_rel_diff(&a, &b, &a),
        1e-5,
    )
}

simkit_backend::conformance_tests! {
    sim: Rd<f32, GrayScott>,
    make: spots,
    steps: 60,
    compare: within_f32,
    blow_up: unstable,
    blow_up_steps: 2000,
}
