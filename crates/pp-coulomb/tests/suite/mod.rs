//! The conformance suite every simkit simulation crate runs (`conformance_tests!` of
//! `simkit-backend`, compiled into `tests/restart.rs`): the backends agree, split calls
//! equal one call, restart bit for bit, rollback after a blow-up, damaged checkpoints
//! refused; on a two-species plasma in `f32`.

use simkit_backend::testing::{max_abs_diff, within};
use simkit_backend::{Backend, Result};
use simkit_pp_coulomb::{
    Config, ForceLaw, Particles, PpCoulomb, Precision, Region, Species, Velocities,
};

fn plasma(ions: f64, n: usize) -> Result<Particles> {
    let mut p = Particles::new();
    let e = p.add_species(Species::new("electron", -1.0, 1.0))?;
    let ion = p.add_species(Species::new("ion", ions, 50.0))?;
    let cube = Region::Cube {
        min: [-6.0; 3],
        length: 12.0,
    };
    let v = Velocities::Maxwellian { thermal_speed: 0.2 };
    p.fill(e, n - n / 4, cube, v, 21)?;
    p.fill(ion, n / 4, cube, v, 22)?;
    Ok(p)
}

fn softened(backend: Backend<'_>) -> Result<PpCoulomb> {
    let config = Config::new(0.05, ForceLaw::Plummer { epsilon: 0.5 })
        .with_precision(Precision::F32)
        .with_check_every(5);
    PpCoulomb::new(plasma(3.0, 200)?, &config, backend)
}

/// The exact law with a step of 10 time units: the first close approach is a blow-up that
/// the energy guard catches.
fn unstable(backend: Backend<'_>) -> Result<PpCoulomb> {
    let config = Config::new(10.0, ForceLaw::Exact)
        .with_precision(Precision::F32)
        .with_check_every(10);
    PpCoulomb::new(plasma(1.0, 400)?, &config, backend)
}

/// Velocities within 3e-5 of their rms: two f32 trajectories of 20 steps (the yardstick of
/// `tests/conformance.rs`: CPU f32 within 1.5e-5 of f64 after 10 steps, the GPU within
/// 6.5e-6 of the CPU f32 run, measured on llvmpipe).
fn within_f32(cpu: &Particles, gpu: &Particles) -> std::result::Result<(), String> {
    let flat = |p: &Particles| -> Vec<f64> { p.velocity.iter().flatten().copied().collect() };
    let a = flat(cpu);
    let rms = (a.iter().map(|v| v * v).sum::<f64>() / a.len().max(1) as f64).sqrt();
    within(
        "velocities (of their rms)",
        max_abs_diff(&a, &flat(gpu)) / rms,
        3e-5,
    )
}

simkit_backend::conformance_tests! {
    sim: PpCoulomb,
    make: softened,
    steps: 20,
    compare: within_f32,
    blow_up: unstable,
    blow_up_steps: 1000,
}
